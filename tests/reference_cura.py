"""Slow pure-Python references for the CuraEngine compatibility mode (compat="cura").

Written from ``spec/CURA_COMPAT.md``, not from the kernels: Python ints (C
truncating division spelled out), dicts for CuraEngine's hash map and face ->
segment map, lists for polylines (joining is concatenation, reversing is
``list.reverse``), brute-force candidate lists. Where the kernels use a shortcut
(melding by cell instead of by hash bucket, neighbours from the shorter vertex
list, successors resolved ahead of the walk, linked chains instead of lists), these
do what the spec literally says.
"""

from __future__ import annotations

import heapq
import math

Point = tuple[int, int]


# ---------------------------------------------------------------- integer helpers
def tdiv(a: int, b: int) -> int:
    """C integer division (truncating toward zero)."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b > 0) else -q


def interpolate(x: int, x0: int, x1: int, y0: int, y1: int) -> int:
    """CuraEngine's ``interpolate`` (spec section 3)."""
    dx = x1 - x0
    num = (y1 - y0) * (x - x0)
    num += tdiv(dx, 4) if num > 0 else -tdiv(dx, 4)
    return y0 + tdiv(num, dx)


def vsize(dx: int, dy: int) -> int:
    """``llrint(sqrt(double(x*x + y*y)))``: round half to even."""
    return round(math.sqrt(float(dx * dx + dy * dy)))


def shorter_than(dx: int, dy: int, length: int) -> bool:
    """CuraEngine's ``shorterThen``."""
    if abs(dx) > length or abs(dy) > length:
        return False
    return dx * dx + dy * dy <= length * length


def mm2int(x: float) -> int:
    """``MM2INT`` in double: the cast truncates ``x * 1000 + 0.5 * sign(x)``."""
    sign = (x > 0) - (x < 0)
    return math.trunc(x * 1000.0 + 0.5 * sign)


# ---------------------------------------------------------------- loading
def meld(corners: list[tuple[int, int, int]], reach: int = 30):
    """CuraEngine's ``addFace`` over corners in file order, with its hash map.

    Returns ``(vertices, faces)``: faces with two equal indices dropped.
    """
    buckets: dict[int, list[int]] = {}
    vertices: list[tuple[int, int, int]] = []

    def point_hash(p):
        q = [tdiv(c + reach // 2, reach) for c in p]
        return (q[0] ^ (q[1] << 10) ^ (q[2] << 20)) & 0xFFFFFFFF

    def find(p):
        h = point_hash(p)
        for idx in buckets.get(h, []):
            d = [p[i] - vertices[idx][i] for i in range(3)]
            if all(abs(c) <= reach for c in d) and sum(c * c for c in d) <= reach**2:
                return idx
        buckets.setdefault(h, []).append(len(vertices))
        vertices.append(tuple(p))
        return len(vertices) - 1

    faces = []
    for i in range(0, len(corners) - len(corners) % 3, 3):
        a, b, c = find(corners[i]), find(corners[i + 1]), find(corners[i + 2])
        if a != b and b != c and a != c:
            faces.append((a, b, c))
    return vertices, faces


def connected_faces(faces, n_vertices):
    """``connected_faces_`` of every vertex: its faces in face order."""
    out = [[] for _ in range(n_vertices)]
    for f, face in enumerate(faces):
        for v in face:
            out[v].append(f)
    return out


def face_neighbours(vertices, faces):
    """``Mesh::finish``: ``connected_face_index_`` of every face (spec section 2)."""
    vf = connected_faces(faces, len(vertices))
    out = []
    for i, face in enumerate(faces):
        row = []
        for j in range(3):
            idx0, idx1, other = face[j], face[(j + 1) % 3], face[(j + 2) % 3]
            cands = [g for g in vf[idx0] if g != i and idx1 in faces[g]]
            if not cands:
                row.append(-1)
            elif len(cands) == 1:
                row.append(cands[0])
            else:
                row.append(_smallest_angle(vertices, faces, idx0, idx1, other, cands))
        out.append(row)
    return out


def _sub(p, q):
    return [(p[i] - q[i]) / 1000.0 for i in range(3)]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0]]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _smallest_angle(vertices, faces, idx0, idx1, other, cands):
    v0 = _sub(vertices[idx1], vertices[idx0])
    norm = math.sqrt(_dot(v0, v0))
    # doubles: an edge of length zero divides 0 by 0 into NaN, and NaN angles
    # lose every comparison (no candidate wins)
    n = [c / norm for c in v0] if norm else [math.nan] * 3
    n0 = _cross(_sub(vertices[other], vertices[idx0]), v0)
    best, best_angle = -1, 1000.0
    for g in cands:
        third = next(v for v in faces[g] if v not in (idx0, idx1))
        n1 = _cross(v0, _sub(vertices[third], vertices[idx0]))
        angle = math.atan2(_dot(n, _cross(n0, n1)), _dot(n0, n1))
        if angle < 0:
            angle += 2 * math.pi
        if angle < best_angle:
            best, best_angle = g, angle
    return best


# ---------------------------------------------------------------- one layer
def layer_segments(vertices, faces, neighbours, z, comp_limit):
    """CuraEngine's segments of plane ``z``, faces in mesh order (spec section 3).

    Each segment is a dict with start, end, face, other (endOtherFaceIdx) and
    vertex (endVertex or None).
    """
    segs = []
    for f, face in enumerate(faces):
        p = [list(vertices[v]) for v in face]
        zs = [q[2] for q in p]
        if z < min(zs) or z > max(zs):
            continue
        for q in p:
            if q[2] == z and z < comp_limit:
                q[2] -= 1
        z0, z1, z2 = (q[2] for q in p)

        def at(a, b, p=p):
            return (interpolate(z, p[a][2], p[b][2], p[a][0], p[b][0]),
                    interpolate(z, p[a][2], p[b][2], p[a][1], p[b][1]))

        if z0 < z < z1 and z2 > z:
            s, e, edge, ev = at(0, 2), at(0, 1), 0, None
        elif z0 > z and z1 <= z and z2 <= z:
            s, e, edge, ev = at(0, 1), at(0, 2), 2, face[2] if z2 == z else None
        elif z1 < z < z0 and z2 > z:
            s, e, edge, ev = at(1, 0), at(1, 2), 1, None
        elif z1 > z and z0 <= z and z2 <= z:
            s, e, edge, ev = at(1, 2), at(1, 0), 0, face[0] if z0 == z else None
        elif z2 < z < z1 and z0 > z:
            s, e, edge, ev = at(2, 1), at(2, 0), 2, None
        elif z2 > z and z1 <= z and z0 <= z:
            s, e, edge, ev = at(2, 0), at(2, 1), 1, face[1] if z1 == z else None
        else:
            continue
        segs.append({"start": s, "end": e, "face": f, "other": neighbours[f][edge],
                     "vertex": ev})
    return segs


def basic_loops(segs, vf):
    """``makeBasicPolygonLoops``: (closed polygons, open polylines), in order."""
    face_seg: dict[int, int] = {}
    for i, s in enumerate(segs):
        face_seg.setdefault(s["face"], i)
    added = [False] * len(segs)

    def try_face(seg, f, start):
        k = face_seg.get(f)
        if k is None:
            return -1
        d = (seg["end"][0] - segs[k]["start"][0], seg["end"][1] - segs[k]["start"][1])
        if shorter_than(d[0], d[1], 10):
            if k == start:
                return start
            if added[k]:
                return -1
            return k
        return -1

    def next_segment(seg, start):
        if seg["vertex"] is None:
            if seg["other"] == -1:
                return -1
            return try_face(seg, seg["other"], start)
        result = -1
        for f in vf[seg["vertex"]]:
            r = try_face(seg, f, start)
            if r == start:
                return start
            if r != -1:
                result = r
        return result

    polygons, polylines = [], []
    for s in range(len(segs)):
        if added[s]:
            continue
        poly = [segs[s]["start"]]
        cur = s
        while True:
            poly.append(segs[cur]["end"])
            added[cur] = True
            cur = next_segment(segs[cur], s)
            if cur == s:
                polygons.append(poly)
                break
            if cur == -1:
                polylines.append(poly)
                break
    return polygons, polylines


# ---------------------------------------------------------------- stitching
def connect_open_polylines(polylines, max_dist, allow_reverse):
    """``connectOpenPolylinesImpl`` (spec 4.1) on a list of point lists, in place.

    Returns the polygons closed, in closing order; ``polylines`` keeps its slots
    (joined-away and closed ones become empty lists).
    """
    closed = []
    stitches = []
    ends = [(i, p[-1]) for i, p in enumerate(polylines) if p]
    starts = [(i, p[0]) for i, p in enumerate(polylines) if p]

    def d2(a, b):
        return (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2

    lim = max_dist * max_dist
    for i, e in ends:
        for j, s in starts:
            if d2(e, s) < lim:
                stitches.append((d2(e, s), 0, 2 * i + 1, 2 * j))
    if allow_reverse:
        for i, e in ends:
            for j, f in ends:
                if i != j and d2(e, f) < lim:
                    stitches.append((d2(e, f), 1, 2 * i + 1, 2 * j + 1))
        for i, e in starts:
            for j, f in starts:
                if i != j and d2(e, f) < lim:
                    stitches.append((d2(e, f), 1, 2 * i, 2 * j))
    heapq.heapify(stitches)
    old_to_cur = {t: t for t in range(2 * len(polylines))}
    cur_to_old = dict(old_to_cur)
    while stitches:
        _, _, a, b = heapq.heappop(stitches)
        t0, t1 = old_to_cur[a], old_to_cur[b]
        if t0 is None or t1 is None:
            continue
        if t0 // 2 == t1 // 2:
            closed.append(polylines[t0 // 2])
            polylines[t0 // 2] = []
            for t in (t0, t1):
                old_to_cur[cur_to_old[t]] = None
                cur_to_old[t] = None
            continue
        rev = [False, False]
        p0, p1 = polylines[t0 // 2], polylines[t1 // 2]
        if t0 % 2 == 1 and t1 % 2 == 1:
            if len(p0) < len(p1):
                t0, t1 = t1, t0
            rev[1] = True
        elif t0 % 2 == 0 and t1 % 2 == 1:
            t0, t1 = t1, t0
        elif t0 % 2 == 0 and t1 % 2 == 0:
            if len(p0) > len(p1):
                t0, t1 = t1, t0
            rev[0] = True
        i0, i1 = t0 // 2, t1 // 2
        first = polylines[i0][::-1] if rev[0] else polylines[i0]
        second = polylines[i1][::-1] if rev[1] else polylines[i1]
        polylines[i0] = first + second
        polylines[i1] = []
        cur = [2 * i0, 2 * i0 + 1, 2 * i1, 2 * i1 + 1]
        nxt = [2 * i0, None, None, 2 * i0 + 1]
        if rev[0]:
            nxt[0], nxt[1] = nxt[1], nxt[0]
        if rev[1]:
            nxt[2], nxt[3] = nxt[3], nxt[2]
        olds = [cur_to_old[c] for c in cur]
        for old, new in zip(olds, nxt, strict=True):
            if old is not None:
                old_to_cur[old] = new
        for old, new in zip(olds, nxt, strict=True):
            if new is not None:
                cur_to_old[new] = old
        cur_to_old[2 * i1] = cur_to_old[2 * i1 + 1] = None
    return closed


def slice_layer(vertices, faces, z, comp_limit):
    """Raw stage of one plane: (polygons, open polylines) as CuraEngine orders them.

    ``makeBasicPolygonLoops``, then ``connectOpenPolylines`` (20 µm, in order) and
    ``stitch`` (10 mm, with reversal); closed polygons first, then those the two
    stitching calls closed, in closing order; open polylines by index.
    """
    # addFace drops a face that repeats a vertex index
    faces = [f for f in faces if len(set(f)) == 3]
    neighbours = face_neighbours(vertices, faces)
    vf = connected_faces(faces, len(vertices))
    segs = layer_segments(vertices, faces, neighbours, z, comp_limit)
    polygons, polylines = basic_loops(segs, vf)
    polygons += connect_open_polylines(polylines, 20, False)
    polygons += connect_open_polylines(polylines, 10_000, True)
    return polygons, [p for p in polylines if p]


# ---------------------------------------------------------------- clean-up
def path_length(path) -> int:
    """Sum of ``vsize`` over consecutive points (no closing segment)."""
    return sum(vsize(b[0] - a[0], b[1] - a[1]) for a, b in zip(path, path[1:]))


def _degenerate(last, now, nxt) -> bool:
    a = (now[0] - last[0], now[1] - last[1])
    b = (nxt[0] - now[0], nxt[1] - now[1])
    return a[0] * b[0] + a[1] * b[1] == -vsize(*a) * vsize(*b)


def remove_degenerate_polyline(poly):
    """``removeDegenerateVerts`` for an open polyline (spec 4, step 9)."""
    if len(poly) < 3:
        return list(poly)
    result = [poly[0]]
    for idx in range(1, len(poly) - 1):
        nxt = poly[idx + 1]
        if _degenerate(result[-1], poly[idx], nxt):
            while len(result) > 1 and _degenerate(result[-2], result[-1], nxt):
                result.pop()
        else:
            result.append(poly[idx])
    result.append(poly[-1])
    return result


def open_polyline_stitcher(lines, max_dist=400, snap=10):
    """The open-polyline stitcher of ``createLayerWithParts`` (spec 6, step 1).

    Candidates are every line's first and last point, visited line by line (first
    before last); returns (closed chains, open chains) in creation order.
    """
    used = [False] * len(lines)
    closed, still_open = [], []
    endpoints = [(i, e) for i in range(len(lines)) for e in (0, 1)]
    for start in range(len(lines)):
        if used[start]:
            continue
        used[start] = True
        chain = list(lines[start])
        closing = False
        for backwards in (False, True):
            if backwards:
                chain.reverse()
            length = path_length(chain)
            while True:
                best, best_dist, best_closing = None, None, False
                for i, e in endpoints:
                    p = lines[i][0] if e == 0 else lines[i][-1]
                    dist = vsize(p[0] - chain[-1][0], p[1] - chain[-1][1])
                    if dist > max_dist:
                        continue
                    is_closing = False
                    gx, gy = p[0] - chain[0][0], p[1] - chain[0][1]
                    if gx * gx + gy * gy < snap * snap:
                        if length + dist < 3 * max_dist or len(chain) <= 2:
                            continue
                        is_closing = True
                        dist += 10
                    elif used[i]:
                        continue
                    if best_dist is None or dist < best_dist:
                        best, best_dist, best_closing = (i, e), dist, is_closing
                    if dist < snap:
                        break
                if best is None:
                    break
                if best_closing:
                    closing = True
                    break
                i, e = best
                piece = list(lines[i]) if e == 0 else list(reversed(lines[i]))
                gap = vsize(chain[-1][0] - piece[0][0], chain[-1][1] - piece[0][1])
                if gap < snap:
                    piece = piece[1:]
                for q in piece:
                    length += vsize(q[0] - chain[-1][0], q[1] - chain[-1][1])
                    chain.append(q)
                used[i] = True
            if closing:
                if backwards:
                    chain.reverse()
                break
        (closed if closing else still_open).append(chain)
    return closed, still_open

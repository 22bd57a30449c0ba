"""Slow, obviously-correct references for the slicing kernels (pure Python ints).

Simplification has its own reference in ``reference_simplify.py``.
"""

from __future__ import annotations

from collections import defaultdict


def round_div(num: int, den: int) -> int:
    """num / den rounded to nearest, ties away from zero (den > 0)."""
    q, r = divmod(abs(num), den)
    if 2 * r >= den:
        q += 1
    return q if num >= 0 else -q


def ring_area2(coords, ring_offsets) -> list[int]:
    out = []
    for r in range(len(ring_offsets) - 1):
        ring = coords[ring_offsets[r] : ring_offsets[r + 1]]
        ring = [tuple(map(int, p)) for p in ring]
        acc = 0
        for i in range(len(ring)):
            (x0, y0), (x1, y1) = ring[i], ring[(i + 1) % len(ring)]
            acc += x0 * y1 - x1 * y0
        out.append(acc if -(2**63) < acc < 2**63 else -(2**63))  # beyond int64
    return out


def crossing(a, b, z: int) -> tuple[int, int]:
    """Crossing of edge a-b (any order) with plane z, rounded once."""
    if a[2] > b[2]:
        a, b = b, a
    t, den = z - a[2], b[2] - a[2]
    return (a[0] + round_div((b[0] - a[0]) * t, den),
            a[1] + round_div((b[1] - a[1]) * t, den))


def slice_layer(vertices, faces, z: int):
    """Closed loops and open chains of one plane, by dict linking on edges.

    Returns ``(loops, chains)``, lists of lists of (x, y). Only for meshes where
    every crossing has at most one segment in and one out (edge-manifold).
    """
    v = [tuple(map(int, p)) for p in vertices]
    seg = {}
    for f in faces:
        f = [int(i) for i in f]
        above = [v[i][2] > z for i in f]
        if all(above) or not any(above):
            continue
        down = up = None
        for j in range(3):
            a, b = f[j], f[(j + 1) % 3]
            if above[j] and not above[(j + 1) % 3]:
                down = frozenset((a, b))
            if not above[j] and above[(j + 1) % 3]:
                up = frozenset((a, b))
        seg[down] = up  # keyed by the edge the segment starts at
    point = {}
    for e in set(seg) | set(seg.values()):
        a, b = tuple(e)
        point[e] = crossing(v[a], v[b], z)
    starts = set(seg) - set(seg.values())
    chains, seen = [], set()
    for s in sorted(starts, key=lambda e: sorted(e)):
        chain, e = [], s
        while e in seg:
            seen.add(e)
            chain.append(point[e])
            e = seg[e]
        chain.append(point[e])
        chains.append(chain)
    loops = []
    for s in sorted(seg, key=lambda e: sorted(e)):
        if s in seen:
            continue
        loop, e = [], s
        while e not in seen:
            seen.add(e)
            loop.append(point[e])
            e = seg[e]
        loops.append(loop)
    return loops, chains


def canonical_loop(loop) -> tuple:
    """Lexicographically smallest rotation of a closed loop."""
    pts = [tuple(map(int, p)) for p in loop]
    return min(tuple(pts[i:] + pts[:i]) for i in range(len(pts)))


def canonical_layer(loops) -> list:
    """A layer's loops as a sorted list of canonical rotations."""
    return sorted(canonical_loop(lp) for lp in loops)


def successors(seg_from, seg_to, n_crossings):
    """Successor of each segment by crossing ids alone (no topology).

    At each crossing the k-th segment ending there (by segment index) is joined to
    the k-th segment starting there. Returns (next, has_prev) as lists.
    """
    starts = defaultdict(list)
    ends = defaultdict(list)
    for s, (a, b) in enumerate(zip(seg_from.tolist(), seg_to.tolist())):
        starts[a].append(s)
        ends[b].append(s)
    nxt = [-1] * len(seg_from)
    has_prev = [False] * len(seg_from)
    for c in range(n_crossings):
        for s_in, s_out in zip(ends.get(c, []), starts.get(c, [])):
            nxt[s_in] = s_out
            has_prev[s_out] = True
    return nxt, has_prev


def record_starts(data: bytes, start: int, n_records: int, props, big_endian: bool):
    """Where each PLY record starts; see vecslice._kernels.ply.record_starts."""
    starts = [start]
    pos = start
    for r in range(n_records):
        for width, size, signed, least in props:
            if width == 0:
                pos += size
                continue
            if pos + width > len(data):
                return starts, r
            count = int.from_bytes(data[pos : pos + width],
                                   "big" if big_endian else "little",
                                   signed=bool(signed))
            if count < least:
                return starts, r
            pos += width + count * size
        if pos > len(data):
            return starts, r
        starts.append(pos)
    return starts, n_records


def boxes_inside(boxes, live, queries, start: int):
    """The first query from ``start`` with live boxes inside; see kernels/boxes.py."""
    for k in range(start, len(queries)):
        q = [int(x) for x in queries[k]]
        rows = [r for r in range(len(boxes)) if live[r]
                and all(q[c] <= int(boxes[r][c]) for c in range(3))
                and all(int(boxes[r][c]) <= q[c] for c in range(3, 6))
                and [int(x) for x in boxes[r]] != q]
        if rows:
            return k, rows
    return len(queries), []

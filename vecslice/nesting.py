"""Which closed shells of a mesh lie inside which: exact ray parity on integers.

A point is inside a closed shell when a ray from it crosses the shell an odd
number of times. The ray here runs straight up (+z) from the point moved by an
infinitesimal ``(ε, ε²)`` in x and y (simulation of simplicity): every tie of
the exact integer orientation tests (the ray through a vertex or along an edge)
is decided by the perturbation, consistently for the two faces of an edge, so no
crossing is counted twice or missed and no epsilon is needed. A point on the
shell's surface (exactly on the plane of a face, within it) is reported as
such, not guessed.

Orientation products of coordinate differences (|d| < 2**31) fit int64 in 2D;
the height test, a 3x3 determinant, is computed with Python integers for the
few faces above the point.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["ON_SURFACE", "nesting_depth", "outermost_container", "points_in_shell"]

ON_SURFACE = -1
"""Result of :func:`points_in_shell` for a point on the shell's surface."""

_SAMPLES = 16  # vertices of a shell tested against a shell that may contain it
_CHUNK = 1 << 22  # (point, face) pairs per step, about
_DENSE_BOXES = 64  # up to this many faces, compared with every point


def _edge_sign(ux, uy, vx, vy, px, py):  # type: ignore[no-untyped-def]
    """Sign of orient2d(u, v, p + (ε, ε²)), never 0 unless u == v (int64 arrays)."""
    dx, dy = vx - ux, vy - uy
    d = dx * (py - uy) - dy * (px - ux)
    return np.where(d != 0, np.sign(d), np.where(dy != 0, -np.sign(dy), np.sign(dx)))


def _det(t: NDArray[np.int64], q: NDArray[np.int64]) -> NDArray[np.int64]:
    """Sign of det[b - a, c - a, q - a] per row, exactly.

    ``n = (b - a) x (c - a)`` is exact in int64 (differences below 2**31), and
    ``w . n`` (``w = q - a``) in float64 is within ``1e-15 * sum |w_i n_i|``
    of the exact value (four roundings); rows within that bound of zero are
    computed again with Python integers.
    """
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    n = np.cross(e1, e2)
    w = q - t[:, 0]
    terms = w.astype(np.float64) * n.astype(np.float64)
    det = terms.sum(axis=1)
    out = np.sign(det).astype(np.int64)
    unsure = np.flatnonzero(np.abs(det) <= 1e-15 * np.abs(terms).sum(axis=1))
    if unsure.size:
        wo, no = w[unsure].astype(object), n[unsure].astype(object)
        exact = wo[:, 0] * no[:, 0] + wo[:, 1] * no[:, 1] + wo[:, 2] * no[:, 2]
        out[unsure] = [(d > 0) - (d < 0) for d in exact]
    return out


class _Boxes:
    """Axis-aligned boxes, for finding the (point, box) pairs that meet.

    Output-sensitive: the boxes are filed in a uniform x-y grid of about one
    box per cell (coarser where large boxes would fill too many cells: at most
    8 cells per box on average), and a point meets only the boxes of its cell
    (a box holding a point covers the point's cell). Few boxes are compared all
    against all.
    """

    def __init__(self, lo: NDArray[np.int64], hi: NDArray[np.int64]) -> None:
        self.lo, self.hi = lo, hi
        n = lo.shape[0]
        self.grid = n > _DENSE_BOXES
        if not self.grid:
            return
        self.base = lo[:, :2].min(axis=0)
        g = int(np.sqrt(n))
        while True:  # coarser while large boxes (a fan's) fill too many cells
            self.cell = np.maximum((hi[:, :2].max(axis=0) - self.base) // g + 1, 1)
            c0 = (lo[:, :2] - self.base) // self.cell  # 0 .. g
            span = (hi[:, :2] - self.base) // self.cell - c0 + 1
            per = span[:, 0] * span[:, 1]
            if g == 1 or int(per.sum()) <= 8 * n:
                break
            g //= 2
        self.g = g
        box = np.repeat(np.arange(n), per)
        k = np.arange(box.shape[0]) - np.repeat(np.cumsum(per) - per, per)
        key = (c0[box, 0] + k // span[box, 1]) * (g + 1) + c0[box, 1] + k % span[box, 1]
        order = np.argsort(key, kind="stable")
        self.key, self.box = key[order], box[order]

    def step(self) -> int:
        """Points per call of :meth:`pairs` that keep its scratch within _CHUNK."""
        return max(1, _CHUNK // (16 if self.grid else max(self.lo.shape[0], 1)))

    def pairs(self, p: NDArray[np.int64],
              dims: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """(point, box) index pairs whose first ``dims`` coordinates meet."""
        lo, hi = self.lo, self.hi
        if not self.grid:
            near = ((p[:, None, :dims] >= lo[None, :, :dims])
                    & (p[:, None, :dims] <= hi[None, :, :dims])).all(axis=2)
            pi, bi = np.nonzero(near)
            return pi.astype(np.int64), bi.astype(np.int64)
        g = self.g
        pc = (p[:, :2] - self.base) // self.cell
        inside = ((pc >= 0) & (pc <= g)).all(axis=1)
        pkey = np.where(inside, pc[:, 0] * (g + 1) + pc[:, 1], -1)
        left = np.searchsorted(self.key, pkey, side="left")
        cnt = np.where(inside, np.searchsorted(self.key, pkey, side="right") - left, 0)
        pi = np.repeat(np.arange(p.shape[0]), cnt)
        bi = self.box[np.arange(pi.shape[0]) - np.repeat(np.cumsum(cnt) - cnt, cnt)
                      + np.repeat(left, cnt)]
        ok = ((p[pi, :dims] >= lo[bi, :dims]) & (p[pi, :dims] <= hi[bi, :dims])).all(
            axis=1)
        return pi[ok], bi[ok]


def _on_faces(q: NDArray[np.int64], t: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Whether point ``q[i]`` lies on the closed triangle ``t[i]`` (exact).

    The plane test (a determinant) is made only for points within the triangle
    as seen along its normal's largest axis.
    """
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    n = np.cross(e1, e2)  # |components| < 2**63: differences below 2**31
    k = np.argmax(np.abs(n), axis=1)  # drop the normal's largest axis
    keep = np.array([[1, 2], [0, 2], [0, 1]])[k]
    t2 = np.take_along_axis(t, keep[:, None, :], axis=2)
    q2 = np.take_along_axis(q, keep, axis=1)
    s = []
    for j in range(3):
        u, v = t2[:, j], t2[:, (j + 1) % 3]
        s.append(np.sign((v[:, 0] - u[:, 0]) * (q2[:, 1] - u[:, 1])
                         - (v[:, 1] - u[:, 1]) * (q2[:, 0] - u[:, 0])))
    s = np.stack(s, axis=1)
    inside = ((s >= 0).all(axis=1) | (s <= 0).all(axis=1)) & (np.abs(n).max(axis=1) > 0)
    on = np.zeros(q.shape[0], dtype=bool)
    pick = np.flatnonzero(inside)
    on[pick] = _det(t[pick], q[pick]) == 0
    return on


def points_in_shell(
    points: NDArray[np.int64], tri: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Ray parity of each point against a closed shell.

    Parameters
    ----------
    points : ndarray of shape (K, 3), int64
        Query points in µm.
    tri : ndarray of shape (M, 3, 3), int64
        The shell's triangles (corner coordinates, any winding); every edge must
        be used an even number of times (a closed surface).

    Returns
    -------
    ndarray of shape (K,), int64
        1 inside, 0 outside, :data:`ON_SURFACE` on a face (exactly: the point
        lies on the plane of a face, within it).
    """
    on, crossing = _meetings(points, tri)
    crossings = np.bincount(crossing[0], minlength=points.shape[0])
    at = np.zeros(points.shape[0], dtype=bool)
    at[on[0]] = True
    return np.where(at, ON_SURFACE, crossings % 2)


def _meetings(points: NDArray[np.int64], tri: NDArray[np.int64]) -> tuple[
        tuple[NDArray[np.int64], NDArray[np.int64]],
        tuple[NDArray[np.int64], NDArray[np.int64]]]:
    """The (point, face) pairs where the point lies on the face, and the crossings.

    A crossing is a (point, face) pair where the ray up from the point crosses
    the face (see the module's docstring).
    """
    lo3, hi3 = tri.min(axis=1), tri.max(axis=1)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (
        c[:, 0] - a[:, 0])
    flat = np.flatnonzero(area != 0)  # vertical faces: no generic vertical ray
    every, lying = _Boxes(lo3, hi3), _Boxes(lo3[flat], hi3[flat])
    step = min(every.step(), lying.step())
    on: list[tuple[NDArray[np.int64], NDArray[np.int64]]] = []
    cross: list[tuple[NDArray[np.int64], NDArray[np.int64]]] = []
    for s in range(0, points.shape[0], step):
        p = points[s : s + step]
        pi, fi = every.pairs(p, 3)
        hit = _on_faces(p[pi], tri[fi])
        on.append((s + pi[hit], fi[hit]))
        pi, fi = lying.pairs(p, 2)
        fi = flat[fi]
        q, t, o = p[pi], tri[fi], np.sign(area[fi])
        px, py = q[:, 0], q[:, 1]
        inside = np.ones(pi.shape[0], dtype=bool)
        for j in range(3):
            u, v = t[:, j], t[:, (j + 1) % 3]
            inside &= _edge_sign(u[:, 0], u[:, 1], v[:, 0], v[:, 1], px, py) == o
        pi, fi, q, t, o = pi[inside], fi[inside], q[inside], t[inside], o[inside]
        above = _det(t, q) * o < 0  # the face is above the point
        cross.append((s + pi[above], fi[above]))

    def joined(parts):  # type: ignore[no-untyped-def]
        if not parts:
            return np.empty(0, np.int64), np.empty(0, np.int64)
        return (np.concatenate([x for x, _ in parts]).astype(np.int64),
                np.concatenate([y for _, y in parts]).astype(np.int64))

    return joined(on), joined(cross)


def _samples(v: NDArray[np.int64]) -> NDArray[np.int64]:
    """Up to ``_SAMPLES`` vertices: the lowest (lexicographic), then spread out."""
    first = np.lexsort((v[:, 2], v[:, 1], v[:, 0]))[0]
    idx = np.unique(np.linspace(0, v.shape[0] - 1, _SAMPLES - 1).astype(np.int64))
    return np.concatenate([v[first : first + 1], v[idx]])


def _box_pairs(
    lo: NDArray[np.int64], hi: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Pairs ``(a, b)``, a != b, with box ``a`` inside box ``b`` (bounds included).

    A loose grid keeps this output-sensitive: box ``b`` is filed under the cells
    of size ``2**level`` (its extent rounded up to a power of two) that it
    touches, at most 8; a box inside ``b`` has its lower corner in one of them
    and a level no higher. Cell keys are hashed into int64 (wrapping); a
    collision only adds a candidate, which the exact box test then drops.
    """
    ext = np.maximum((hi - lo).max(axis=1), 1)
    level = np.ceil(np.log2(ext.astype(np.float64))).astype(np.int64)
    off = lo + 2**30, hi + 2**30  # non-negative

    def key(lev, c):  # type: ignore[no-untyped-def]
        with np.errstate(over="ignore"):
            return ((lev * 1_000_003 + c[:, 0]) * 998_244_353 + c[:, 1]) \
                * 1_000_000_007 + c[:, 2]

    keys, owner = [], []
    for corner in range(8):  # the cells of the 8 box corners (often the same)
        pick = [(corner >> d) & 1 for d in range(3)]
        c = np.stack([np.where(pick[d], off[1][:, d], off[0][:, d]) >> level
                      for d in range(3)], axis=1)
        keys.append(key(level, c))
        owner.append(np.arange(lo.shape[0]))
    k, o = np.concatenate(keys), np.concatenate(owner)
    order = np.lexsort((o, k))
    k, o = k[order], o[order]
    dup = np.zeros(k.shape[0], dtype=bool)
    dup[1:] = (k[1:] == k[:-1]) & (o[1:] == o[:-1])
    k, o = k[~dup], o[~dup]
    pa, pb = [], []
    for lev in np.unique(level):
        q = np.flatnonzero(level <= lev)
        qk = key(np.full(q.shape[0], lev), off[0][q] >> lev)
        left = np.searchsorted(k, qk, side="left")
        right = np.searchsorted(k, qk, side="right")
        cnt = right - left
        a = np.repeat(q, cnt)
        pos = np.arange(a.shape[0]) - np.repeat(np.cumsum(cnt) - cnt, cnt) \
            + np.repeat(left, cnt)
        b = o[pos]
        keep = (level[b] == lev) & (a != b)
        pa.append(a[keep])
        pb.append(b[keep])
    a, b = np.concatenate(pa), np.concatenate(pb)
    ok = ((lo[a] >= lo[b]) & (hi[a] <= hi[b])).all(axis=1)
    return a[ok], b[ok]


def _parents(
    vertices: NDArray[np.int64],
    faces: NDArray[np.int64],
    shell: NDArray[np.int64],
    closed: NDArray[np.bool_],
) -> NDArray[np.int64]:
    """The smallest closed shell containing each closed shell (-1: none, or open).

    See :func:`nesting_depth` for what "containing" means.
    """
    n = closed.shape[0]
    parent_of = np.full(n, -1, dtype=np.int64)
    ids = np.flatnonzero(closed)
    if ids.shape[0] < 2:
        return parent_of
    order = np.argsort(shell, kind="stable")
    starts = np.searchsorted(shell[order], np.arange(n + 1))
    corner = vertices[faces[order]]  # (F, 3, 3), faces grouped by shell
    # every label 0 .. S-1 has faces, so each reduceat segment is one shell
    lo = np.minimum.reduceat(corner.min(axis=1), starts[:-1])[ids]
    hi = np.maximum.reduceat(corner.max(axis=1), starts[:-1])[ids]
    pa, pb = _box_pairs(lo, hi)
    same = ((lo[pa] == lo[pb]) & (hi[pa] == hi[pb])).all(axis=1)
    pa, pb = pa[~same], pb[~same]
    if pa.shape[0] == 0:
        return parent_of
    size = (hi - lo).astype(np.float64).prod(axis=1)
    by = np.lexsort((size[pb], pa))  # for each shell, smallest container first
    pa, pb = pa[by], pb[by]
    # every candidate pair is tested, a container's pairs in one call, and first
    # with one sample each: a pair whose first sample is outside fails whatever
    # the others (400 concentric frames took 46 s, one pair and 16 samples at
    # a time)
    inner = np.unique(pa)
    samples = dict(zip(inner.tolist(), (_samples(vertices[np.unique(
        faces[order[starts[ids[i]] : starts[ids[i] + 1]]])]) for i in inner),
        strict=True))
    holds = np.zeros(pa.shape[0], dtype=bool)
    by_container = np.argsort(pb, kind="stable")
    for group in np.split(by_container, np.flatnonzero(np.diff(pb[by_container])) + 1):
        b = ids[pb[group[0]]]
        tri = corner[starts[b] : starts[b + 1]]
        r0 = points_in_shell(np.stack([samples[i][0] for i in pa[group].tolist()]), tri)
        group = group[r0 != 0]
        if not group.size:
            continue
        rest = [samples[i][1:] for i in pa[group].tolist()]
        r = points_in_shell(np.concatenate(rest), tri)
        at = np.cumsum([0, *(len(x) for x in rest)])[:-1]
        has = np.array([len(x) > 0 for x in rest])
        inside = (r0[r0 != 0] == 1) | (has & np.logical_or.reduceat(r == 1, at))
        outside = has & np.logical_or.reduceat(r == 0, at)
        holds[group] = inside & ~outside
    # each shell's parent: its first candidate (the smallest) that holds it
    first = np.full(ids.shape[0], pa.shape[0], dtype=np.int64)
    np.minimum.at(first, pa[holds], np.flatnonzero(holds))
    parent = np.where(first < pa.shape[0], pb[np.minimum(first, pa.shape[0] - 1)], -1)
    parent_of[ids] = np.where(parent >= 0, ids[np.maximum(parent, 0)], -1)
    return parent_of


def _walk_up(parent: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Depth and outermost ancestor of every node of a forest of parent links.

    Containers have strictly larger boxes, so parent links never cycle.
    """
    n = parent.shape[0]
    depth = np.full(n, -1, dtype=np.int64)
    root = np.arange(n, dtype=np.int64)
    for i in range(n):
        chain = []
        while i >= 0 and depth[i] < 0:
            chain.append(i)
            i = int(parent[i])
        base, top = (int(depth[i]), int(root[i])) if i >= 0 else (-1, chain[-1])
        for k in reversed(chain):
            base += 1
            depth[k] = base
            root[k] = top
    return depth, root


def nesting_depth(
    vertices: NDArray[np.int64],
    faces: NDArray[np.int64],
    shell: NDArray[np.int64],
    closed: NDArray[np.bool_],
) -> NDArray[np.int64]:
    """How many closed shells contain each closed shell.

    Shell ``a`` is inside shell ``b`` when its bounding box lies within b's (and
    is not the same box) and sampled vertices of ``a`` (its lowest one and up to
    15 more) are inside ``b`` by exact ray parity, none outside; vertices on b's
    surface do not count. Shells that cross each other (samples on both sides)
    are not nested. The depth of ``a`` is one more than that of its smallest
    container (by bounding-box volume), so nested shells cost one test each.

    Parameters
    ----------
    vertices : ndarray of shape (V, 3), int64
    faces : ndarray of shape (F, 3), int64
    shell : ndarray of shape (F,), int64
        Shell label of each face, ``0 .. S-1``.
    closed : ndarray of shape (S,), bool
        Which shells are closed (only those contain or are contained).

    Returns
    -------
    ndarray of shape (S,), int64
        Nesting depth; 0 for open shells and outermost closed shells.
    """
    return _walk_up(_parents(vertices, faces, shell, closed))[0]


def outermost_container(
    vertices: NDArray[np.int64],
    faces: NDArray[np.int64],
    shell: NDArray[np.int64],
    closed: NDArray[np.bool_],
) -> NDArray[np.int64]:
    """The outermost closed shell containing each shell (itself if none contains it).

    Same arguments and containment rule as :func:`nesting_depth`; open shells are
    their own outermost container.
    """
    return _walk_up(_parents(vertices, faces, shell, closed))[1]

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


_LEAF = 8  # boxes per leaf of a _BoxTree, about


class _BoxTree:
    """Boxes in a balanced binary tree, for the live boxes inside a query box.

    The layout :func:`vecslice._kernels.boxes.boxes_inside` walks: each node is
    split at the median of the coordinate (of the 6 of ``lo`` and ``hi``) its
    boxes spread most in. Boxes are killed (:meth:`kill`) once they need no
    more queries, and the subtrees without live boxes are then skipped.
    """

    def __init__(self, boxes: NDArray[np.int64]) -> None:
        n = boxes.shape[0]
        self.depth = depth = max(n // _LEAF, 1).bit_length() - 1  # 2**depth <= n
        rows = np.arange(n, dtype=np.int64)
        for d in range(depth):  # node j of level d: rows j * n >> d ..
            cut = (np.arange((1 << d) + 1, dtype=np.int64) * n) >> d
            b = boxes[rows]
            spread = np.maximum.reduceat(b, cut[:-1]) - np.minimum.reduceat(b, cut[:-1])
            node = np.repeat(np.arange(1 << d), np.diff(cut))
            along = b[np.arange(n), np.argmax(spread, axis=1)[node]]
            rows = rows[np.lexsort((along, node))]
        self.rows = rows  # tree position -> box
        self.boxes = np.ascontiguousarray(boxes[rows])
        cut = (np.arange((1 << depth) + 1, dtype=np.int64) * n) >> depth
        levels = [np.concatenate([np.maximum.reduceat(self.boxes[:, :3], cut[:-1]),
                                  np.minimum.reduceat(self.boxes[:, 3:], cut[:-1])],
                                 axis=1)]
        counts = [np.diff(cut)]
        for _ in range(depth):  # parents from pairs of children, up to the root
            b, c = levels[0], counts[0]
            levels.insert(0, np.concatenate([np.maximum(b[0::2, :3], b[1::2, :3]),
                                             np.minimum(b[0::2, 3:], b[1::2, 3:])],
                                            axis=1))
            counts.insert(0, c[0::2] + c[1::2])
        self.bounds = np.ascontiguousarray(np.concatenate(levels))
        self.live_below = np.concatenate(counts)
        self.live = np.ones(n, dtype=bool)
        self.n = n

    def kill(self, at: NDArray[np.int64]) -> None:
        """Mark the boxes at tree positions ``at`` (distinct, live) dead."""
        self.live[at] = False
        depth = self.depth
        leaf = (((at + 1) << depth) - 1) // self.n  # position j * n >> depth ..
        for d in range(depth + 1):
            np.subtract.at(self.live_below, (1 << d) - 1 + (leaf >> (depth - d)), 1)


def _parents(
    vertices: NDArray[np.int64],
    faces: NDArray[np.int64],
    shell: NDArray[np.int64],
    closed: NDArray[np.bool_],
) -> NDArray[np.int64]:
    """The smallest closed shell containing each closed shell (-1: none, or open).

    See :func:`nesting_depth` for what "containing" means. The candidates for
    holding shell ``a`` are the shells whose bounding box holds a's (and is not
    the same box), tried smallest box first (by volume; then by the power of
    two at or above the box's largest extent, then by shell number), and a's
    parent is the first that holds it. The containers are gone through in that
    order, each tested at once against every shell inside its box that no
    smaller container holds yet (found through a :class:`_BoxTree`): shells
    nested ``n`` deep cost ``n`` tests, not ``n**2`` (8,000 nested tetrahedra
    took 218 s and 3.6 GB when every nested pair of boxes was tested).
    """
    from vecslice._kernels.boxes import boxes_inside

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
    size = (hi - lo).astype(np.float64).prod(axis=1)
    ext = np.maximum((hi - lo).max(axis=1), 1)
    level = np.ceil(np.log2(ext.astype(np.float64))).astype(np.int64)
    by = np.lexsort((np.arange(ids.shape[0]), level, size))  # smallest box first
    boxes = np.concatenate([lo, hi], axis=1)
    tree = _BoxTree(boxes)
    queries = np.ascontiguousarray(boxes[by])
    parent = np.full(ids.shape[0], -1, dtype=np.int64)
    samples: dict[int, NDArray[np.int64]] = {}

    def sample(i: int) -> NDArray[np.int64]:
        if i not in samples:
            s = ids[i]
            samples[i] = _samples(vertices[np.unique(faces[order[starts[s]:
                                                                  starts[s + 1]]])])
        return samples[i]

    k = 0
    while True:
        k, at = boxes_inside(tree.boxes, tree.bounds, tree.live_below, tree.live,
                             queries, k)
        if k == by.shape[0]:
            break
        b = ids[by[k]]
        tri = corner[starts[b] : starts[b + 1]]
        inner = tree.rows[at]
        # first with one sample each: a shell whose first sample is outside is
        # not held whatever the others (400 concentric frames took 46 s, one pair
        # and 16 samples at a time)
        r0 = points_in_shell(np.stack([sample(i)[0] for i in inner.tolist()]), tri)
        near = np.flatnonzero(r0 != 0)
        if near.size:
            rest = [sample(i)[1:] for i in inner[near].tolist()]
            r = points_in_shell(np.concatenate(rest), tri)
            first = np.cumsum([0, *(len(x) for x in rest)])[:-1]
            has = np.array([len(x) > 0 for x in rest])
            inside = (r0[near] == 1) | (has & np.logical_or.reduceat(r == 1, first))
            outside = has & np.logical_or.reduceat(r == 0, first)
            held = near[inside & ~outside]
            parent[inner[held]] = by[k]
            tree.kill(at[held])
        k += 1
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

"""Reference for ``vecslice.nesting._parents``: the version before audit D04.

Kept verbatim (only its imports changed) as the reference the new version must
equal on every input. It lists every pair of shells whose bounding boxes nest
and tests each: O(n**2) time and memory for n nested shells (8,000 nested
tetrahedra took 218 s and 3.6 GB). Use it on small inputs only.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vecslice.nesting import _samples, points_in_shell


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

"""The vertex merge by sorting that vecslice used before its hashed kernel.

Kept verbatim as the reference for ``vecslice._kernels.vertices.clean_mesh``: the
same results (first occurrence kept, order kept) by an independent method.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def clean_arrays(
    v: NDArray[np.int64], f: NDArray[np.int64], *, merge: bool = True
) -> tuple[NDArray[np.int64], NDArray[np.int64], int, int, int]:
    """Merge equal positions, drop repeated-index faces and unused vertices.

    Kept vertices stay in order of first occurrence, so a clean mesh is unchanged.
    Returns ``(vertices, faces, n_merged, n_unused, n_degenerate)``.
    """
    n_v = v.shape[0]
    if merge:
        # |c| < 2**30, so x and y pack into one int64 sort key; stable sort: the
        # first original index of each position leads its run
        xy = (v[:, 0] + 2**30) * np.int64(2**31) + (v[:, 1] + 2**30)
        order = np.lexsort((v[:, 2], xy))
        sv = v[order]
        new = np.ones(n_v, dtype=bool)
        new[1:] = (sv[1:] != sv[:-1]).any(axis=1)
    else:
        order = np.arange(n_v)
        new = np.ones(n_v, dtype=bool)
    rep = order[new]  # first original index of each position
    gid = np.empty(n_v, dtype=np.int64)
    gid[order] = np.cumsum(new) - 1
    g = gid[f]
    deg = (g[:, 0] == g[:, 1]) | (g[:, 1] == g[:, 2]) | (g[:, 2] == g[:, 0])
    g = g[~deg]
    used = np.zeros(rep.shape[0], dtype=bool)
    used[g.reshape(-1)] = True
    kept = np.flatnonzero(used)
    kept = kept[np.argsort(rep[kept], kind="stable")]
    new_id = np.full(rep.shape[0], -1, dtype=np.int64)
    new_id[kept] = np.arange(kept.shape[0])
    n_merged = n_v - rep.shape[0]
    return (v[rep[kept]], new_id[g], n_merged, rep.shape[0] - kept.shape[0],
            int(deg.sum()))

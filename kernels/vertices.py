"""Kernels merging equal vertex positions and cleaning the faces that index them."""

import numpy as np
from numba import types

from ._jit import kernel, run_serial
from ._types import I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .sorting import mix_hash, table_bits

_PART_SIZE = 2048  # about this many vertices per partition: its table stays in cache
_CHUNK_PARTS = 64  # partitions per chunk of matching
_CHUNK_FACES = 1 << 16  # faces per chunk of the face passes


@kernel(types.Tuple((I64_1D_OUT, I64))(I64_2D, types.int64[::1], types.uint64[::1]))
def _partition_vertices(vertices, out_order, out_hashes):
    """Vertices partitioned by the top bits of a hash of their position.

    Returns ``(part_offsets, pbits)``: partition ``p`` holds the vertices
    ``out_order[part_offsets[p]:part_offsets[p + 1]]`` in index order (a
    counting sort), their hashes beside them in ``out_hashes`` (both (V,), given
    by the caller: numpy puts large arrays on huge pages, where numba's own
    allocations take a page fault per 4 kB of fresh memory), ``2**pbits``
    partitions.
    """
    n = vertices.shape[0]
    pbits = 0
    while (np.int64(1) << pbits) * _PART_SIZE < n and pbits < 20:
        pbits += 1
    n_parts = np.int64(1) << pbits
    pshift = np.uint64(64 - pbits) if pbits > 0 else np.uint64(63)
    part_offsets = np.zeros(n_parts + 1, dtype=np.int64)
    for i in range(n):
        h = mix_hash(vertices[i, 0], vertices[i, 1], vertices[i, 2])
        p = np.int64(h >> pshift) if pbits > 0 else 0
        part_offsets[p + 1] += 1
    for p in range(n_parts):
        part_offsets[p + 1] += part_offsets[p]
    fill = part_offsets[:-1].copy()
    # the hashes beside the order: no random reads when matching
    for i in range(n):
        h = mix_hash(vertices[i, 0], vertices[i, 1], vertices[i, 2])
        p = np.int64(h >> pshift) if pbits > 0 else 0
        out_order[fill[p]] = i
        out_hashes[fill[p]] = h
        fill[p] += 1
    return part_offsets, pbits


_U64_1D = types.Array(types.uint64, 1, "C", readonly=True)


@kernel(types.void(I64_2D, I64_1D, I64_1D, _U64_1D, I64, I64, I64, types.int64[::1]))
def _match_partitions(vertices, part_offsets, order, hashes, pbits, p0, p1, out_rep):
    """``out_rep[i]``, the first vertex at vertex ``i``'s position, in partitions p0:p1.

    Each partition finds it with its own small hash table (open addressing, linear
    probing, exact comparison of all three coordinates).
    """
    for p in range(p0, p1):
        start = part_offsets[p]
        m = part_offsets[p + 1] - start
        if m == 0:
            continue
        mask = (np.int64(1) << table_bits(m)) - 1
        table = np.full(mask + 1, -1, dtype=np.int64)  # positions q in order
        for q in range(start, start + m):
            i = order[q]
            h = hashes[q]
            s = np.int64(h >> np.uint64(pbits)) & mask
            while True:
                t = table[s]
                if t < 0:
                    table[s] = q
                    out_rep[i] = i
                    break
                if hashes[t] == h:
                    j = order[t]
                    if (vertices[j, 0] == vertices[i, 0]
                            and vertices[j, 1] == vertices[i, 1]
                            and vertices[j, 2] == vertices[i, 2]):
                        out_rep[i] = j  # j < i: a partition is in index order
                        break
                s = (s + 1) & mask


@kernel(I64(I64_1D, types.int64[::1], types.int64[::1]))
def _number_groups(rep, out_group, out_first):
    """Groups from the first vertex ``rep[i]`` of every position; returns their number.

    ``out_group[i]`` is vertex ``i``'s group, ``out_first[g]`` the first vertex of
    group ``g`` (for the groups there are); both (V,), given by the caller.
    """
    n = rep.shape[0]
    n_groups = 0
    for i in range(n):
        j = rep[i]
        if j == i:
            out_group[i] = n_groups
            out_first[n_groups] = i
            n_groups += 1
        else:
            out_group[i] = out_group[j]
    return n_groups


def merge_vertices(vertices, run=run_serial):
    """Group vertices with exactly equal positions, in linear expected time.

    Returns ``(group, first)``: ``group[i]`` is the group of vertex ``i``, groups
    numbered in order of first occurrence, and ``first[g]`` the first vertex of
    group ``g`` (increasing).

    The vertices are partitioned by the top bits of a hash of their position
    (a counting sort, keeping index order within each partition), so that equal
    positions share a partition; each partition then finds, with its own small
    hash table, the first vertex of every position, chunks of partitions given to
    ``run`` (``run(fn, bounds)`` calls ``fn(lo, hi)`` for every chunk
    ``bounds[c]:bounds[c + 1]``, in any order or at once; by default one after
    another). A last pass numbers the groups in index order.
    """
    n = vertices.shape[0]
    order = np.empty(n, dtype=np.int64)
    hashes = np.empty(n, dtype=np.uint64)
    part_offsets, pbits = _partition_vertices(vertices, order, hashes)
    rep = np.empty(n, dtype=np.int64)
    n_parts = part_offsets.shape[0] - 1
    bounds = np.append(np.arange(0, n_parts, _CHUNK_PARTS), n_parts)
    run(lambda p0, p1: _match_partitions(vertices, part_offsets, order, hashes,
                                         pbits, p0, p1, rep), bounds)
    group = np.empty(n, dtype=np.int64)
    first = np.empty(n, dtype=np.int64)
    n_groups = _number_groups(rep, group, first)
    return group, first if n_groups == n else first[:n_groups].copy()


@kernel(I64(I64_2D, I64_1D, I64, I64, types.int64[::1]))
def _mark_used(faces, group, f0, f1, out_used):
    """Mark the groups used by the faces ``f0:f1``; count the degenerate ones.

    A face with a repeated group is degenerate: it marks nothing.
    """
    count = 0
    for f in range(f0, f1):
        a = group[faces[f, 0]]
        b = group[faces[f, 1]]
        e = group[faces[f, 2]]
        if a == b or b == e or e == a:
            count += 1
        else:  # every writer stores the same value
            out_used[a] = 1
            out_used[b] = 1
            out_used[e] = 1
    return count


@kernel(types.Tuple((I64_2D_OUT, I64))(I64_2D, I64_1D, types.int64[::1]))
def _kept_vertices(vertices, first, io_used):
    """Number the used groups in group order; return their first vertices.

    ``io_used`` is renumbered in place (-1 for unused groups). Returns
    ``(vertices, n_kept)``.
    """
    n_groups = first.shape[0]
    n_kept = 0
    for g in range(n_groups):
        if io_used[g]:
            io_used[g] = n_kept
            n_kept += 1
        else:
            io_used[g] = -1
    out_v = np.empty((n_kept, 3), dtype=np.int64)
    for g in range(n_groups):
        k = io_used[g]
        if k >= 0:
            out_v[k, 0] = vertices[first[g], 0]
            out_v[k, 1] = vertices[first[g], 1]
            out_v[k, 2] = vertices[first[g], 2]
    return out_v, n_kept


@kernel(types.void(I64_2D, I64_1D, I64_1D, I64, I64, I64, types.int64[:, ::1]))
def _write_faces(faces, group, new_id, f0, f1, j, out_faces):
    """Write the kept faces of ``f0:f1`` (renumbered) from row ``j`` on."""
    for f in range(f0, f1):
        a = group[faces[f, 0]]
        b = group[faces[f, 1]]
        e = group[faces[f, 2]]
        if not (a == b or b == e or e == a):
            out_faces[j, 0] = new_id[a]
            out_faces[j, 1] = new_id[b]
            out_faces[j, 2] = new_id[e]
            j += 1


def clean_mesh(vertices, faces, merge, run=run_serial):
    """Merge equal positions, drop faces with a repeated vertex and unused vertices.

    Returns ``(vertices, faces, n_merged, n_unused, n_degenerate)``. Kept vertices
    are the first occurrence of each position, in their original order; kept faces
    keep their order and winding. Without ``merge`` only repeated indices and
    unused vertices are removed. The passes over the faces go in chunks to
    ``run`` (as :func:`merge_vertices`).

    Where nothing changes (no position repeated, no degenerate face, every vertex
    used) the arrays given are returned themselves, not copies: a clean mesh,
    the usual input, costs no new arrays (and no fresh pages to fault in).

    Preconditions: 0 <= faces < len(vertices).
    """
    n_v = vertices.shape[0]
    if merge:
        group, first = merge_vertices(vertices, run)
    else:
        group = np.arange(n_v, dtype=np.int64)
        first = group
    n_groups = first.shape[0]
    n_faces = faces.shape[0]
    used = np.zeros(n_groups + 1, dtype=np.int64)
    bounds = np.append(np.arange(0, n_faces, _CHUNK_FACES), n_faces)
    n_chunks = bounds.shape[0] - 1
    deg = np.zeros(n_chunks + 1, dtype=np.int64)  # then: degenerate faces before

    def mark(f0, f1):
        deg[1 + f0 // _CHUNK_FACES] = _mark_used(faces, group, f0, f1, used)

    run(mark, bounds)
    np.cumsum(deg, out=deg)
    n_deg = int(deg[n_chunks])
    if n_groups == n_v and n_deg == 0 and used[:n_groups].all():
        return vertices, faces, 0, 0, 0  # every group is its own vertex, all used
    # groups are in order of their first vertex: numbering the used ones in group
    # order keeps the original vertex order
    out_v, n_kept = _kept_vertices(vertices, first, used)
    out_f = np.empty((n_faces - n_deg, 3), dtype=np.int64)
    run(lambda f0, f1: _write_faces(faces, group, used, f0, f1,
                                    f0 - deg[f0 // _CHUNK_FACES], out_f), bounds)
    return out_v, out_f, n_v - n_groups, n_groups - int(n_kept), n_deg

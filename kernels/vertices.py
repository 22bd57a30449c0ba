"""Kernels merging equal vertex positions and cleaning the faces that index them."""

import numpy as np
from numba import types

from ._jit import kernel, run_serial
from ._types import I64, I64_1D, I64_2D, I64_2D_OUT, U8_1D
from .sorting import mix_hash, table_bits

_PART_SIZE = 2048  # about this many vertices per partition: its table stays in cache
_CHUNK_PARTS = 64  # partitions per chunk of matching
_CHUNK_FACES = 1 << 16  # faces per chunk of the face passes


@kernel(inline="always")
def _part_of(vertices, i, pshift, pbits):
    """Hash of vertex ``i``'s position and its partition (its top ``pbits`` bits)."""
    h = mix_hash(vertices[i, 0], vertices[i, 1], vertices[i, 2])
    return h, (np.int64(h >> pshift) if pbits > 0 else np.int64(0))


@kernel(types.void(I64_2D, I64, I64, I64, types.int64[::1]))
def _count_parts(vertices, pbits, i0, i1, out_counts):
    """Add the vertices ``i0:i1`` of every partition to ``out_counts`` (zeros)."""
    pshift = np.uint64(64 - pbits) if pbits > 0 else np.uint64(63)
    for i in range(i0, i1):
        out_counts[_part_of(vertices, i, pshift, pbits)[1]] += 1


@kernel(types.void(I64_2D, I64, I64, I64, types.int64[::1], types.int64[::1],
                   types.uint64[::1]))
def _fill_parts(vertices, pbits, i0, i1, io_fill, out_order, out_hashes):
    """Write the vertices ``i0:i1`` at their partitions' places ``io_fill``.

    ``io_fill[p]`` is where partition ``p``'s next vertex of this chunk goes
    (advanced here); the hash goes beside it in ``out_hashes``, so that matching
    reads no vertex it does not compare.
    """
    pshift = np.uint64(64 - pbits) if pbits > 0 else np.uint64(63)
    for i in range(i0, i1):
        h, p = _part_of(vertices, i, pshift, pbits)
        out_order[io_fill[p]] = i
        out_hashes[io_fill[p]] = h
        io_fill[p] += 1


_CHUNK_VERTICES = 1 << 17  # vertices per chunk of partitioning (at least)
_COUNTS_LIMIT = 1 << 22  # counts of all chunks and partitions (32 MiB)


def _partition(vertices, run=run_serial):
    """Vertices partitioned by the top bits of a hash of their position.

    Returns ``(order, hashes, part_offsets, pbits)``: partition ``p`` holds the
    vertices ``order[part_offsets[p]:part_offsets[p + 1]]`` in index order, their
    hashes beside them in ``hashes``; ``2**pbits`` partitions. A counting sort in
    chunks of vertices given to ``run``: each chunk counts its vertices per
    partition, and then writes them after those of the chunks before it (so a
    partition stays in index order whatever order the chunks run in). Chunks
    are fewer where the partitions are very many: at most ``_COUNTS_LIMIT``
    counts in all.
    """
    n = vertices.shape[0]
    pbits = 0  # about _PART_SIZE vertices per partition
    while (1 << pbits) * _PART_SIZE < n and pbits < 20:
        pbits += 1
    n_parts = 1 << pbits
    n_chunks = max(1, min(-(-n // _CHUNK_VERTICES), _COUNTS_LIMIT // n_parts))
    bounds = (n * np.arange(n_chunks + 1, dtype=np.int64)) // n_chunks
    counts = np.zeros((n_chunks, n_parts), dtype=np.int64)
    index = {int(bounds[c]): c for c in range(n_chunks)}
    run(lambda i0, i1: _count_parts(vertices, pbits, i0, i1, counts[index[i0]]),
        bounds)
    part_offsets = np.zeros(n_parts + 1, dtype=np.int64)
    np.cumsum(counts.sum(axis=0), out=part_offsets[1:])
    # chunk c's first place in partition p: the partition's start, then the
    # vertices of p in the chunks before c
    fill = np.cumsum(counts, axis=0)
    fill -= counts
    fill += part_offsets[:-1]
    order = np.empty(n, dtype=np.int64)
    hashes = np.empty(n, dtype=np.uint64)
    run(lambda i0, i1: _fill_parts(vertices, pbits, i0, i1, fill[index[i0]], order,
                                   hashes), bounds)
    return order, hashes, part_offsets, pbits


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


@kernel(I64(types.int64[::1]))
def _number_groups(io_rep):
    """Turn ``io_rep`` into the vertices' groups, in place; return their number.

    ``io_rep[i]`` is the first vertex at vertex ``i``'s position (``i`` itself
    for a first occurrence, else an earlier vertex, already renumbered): a first
    occurrence opens the next group, any other vertex takes its first's group.
    Groups are thus numbered in order of first occurrence.
    """
    n_groups = 0
    for i in range(io_rep.shape[0]):
        j = io_rep[i]
        if j == i:
            io_rep[i] = n_groups
            n_groups += 1
        else:
            io_rep[i] = io_rep[j]
    return n_groups


@kernel(types.void(I64_1D, types.int64[::1]), _nrt=False)
def _first_of_groups(group, out_first):
    """``out_first[g]``, the first vertex of group ``g``, for every group.

    Groups are numbered in order of first occurrence: group ``g`` first appears
    at the first ``i`` with ``group[i] == g``, after the first vertex of group
    ``g - 1``, so one pass finds them all. ``out_first`` (one entry per group)
    is given by the caller (numpy puts large arrays on huge pages, where numba's
    own allocations take a page fault per 4 kB of fresh memory).
    """
    g = 0
    for i in range(group.shape[0]):
        if group[i] == g:
            out_first[g] = i
            g += 1


def _groups(vertices, run=run_serial):
    """``(group, n_groups)`` of :func:`merge_vertices`, without ``first``."""
    n = vertices.shape[0]
    order, hashes, part_offsets, pbits = _partition(vertices, run)
    group = np.empty(n, dtype=np.int64)  # first the first vertex at each position
    n_parts = part_offsets.shape[0] - 1
    bounds = np.append(np.arange(0, n_parts, _CHUNK_PARTS), n_parts)
    run(lambda p0, p1: _match_partitions(vertices, part_offsets, order, hashes,
                                         pbits, p0, p1, group), bounds)
    return group, _number_groups(group)


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
    another). A last pass numbers the groups in index order, in place of the
    first vertices it reads. The partitioning goes in chunks of vertices to
    ``run`` too.
    """
    group, n_groups = _groups(vertices, run)
    first = np.empty(n_groups, dtype=np.int64)
    _first_of_groups(group, first)
    return group, first


@kernel(I64(I64_2D, I64_1D, I64, I64, types.uint8[::1]))
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


@kernel(types.Tuple((I64_2D_OUT, I64))(I64_2D, I64_1D, U8_1D, types.int64[::1]))
def _kept_vertices(vertices, first, used, out_new_id):
    """Number the used groups in group order; return their first vertices.

    ``out_new_id[g]`` is the kept vertex of group ``g`` (-1 for unused groups,
    those with ``used[g] == 0``). Returns ``(vertices, n_kept)``.
    """
    n_groups = first.shape[0]
    n_kept = 0
    for g in range(n_groups):
        if used[g]:
            out_new_id[g] = n_kept
            n_kept += 1
        else:
            out_new_id[g] = -1
    out_v = np.empty((n_kept, 3), dtype=np.int64)
    for g in range(n_groups):
        k = out_new_id[g]
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
    the usual input, costs no new arrays (and no fresh pages to fault in); its
    scratch is then the partitioning's (order and hashes), the groups and one
    byte per vertex.

    Preconditions: 0 <= faces < len(vertices).
    """
    n_v = vertices.shape[0]
    if merge:
        group, n_groups = _groups(vertices, run)
    else:
        group = np.arange(n_v, dtype=np.int64)
        n_groups = n_v
    n_faces = faces.shape[0]
    used = np.zeros(n_groups, dtype=np.uint8)
    bounds = np.append(np.arange(0, n_faces, _CHUNK_FACES), n_faces)
    n_chunks = bounds.shape[0] - 1
    deg = np.zeros(n_chunks + 1, dtype=np.int64)  # then: degenerate faces before

    def mark(f0, f1):
        deg[1 + f0 // _CHUNK_FACES] = _mark_used(faces, group, f0, f1, used)

    run(mark, bounds)
    np.cumsum(deg, out=deg)
    n_deg = int(deg[n_chunks])
    if n_groups == n_v and n_deg == 0 and used.all():
        return vertices, faces, 0, 0, 0  # every group is its own vertex, all used
    # groups are in order of their first vertex: numbering the used ones in group
    # order keeps the original vertex order
    first = group
    if merge:
        first = np.empty(n_groups, dtype=np.int64)
        _first_of_groups(group, first)
    new_id = np.empty(n_groups, dtype=np.int64)
    out_v, n_kept = _kept_vertices(vertices, first, used, new_id)
    out_f = np.empty((n_faces - n_deg, 3), dtype=np.int64)
    run(lambda f0, f1: _write_faces(faces, group, new_id, f0, f1,
                                    f0 - deg[f0 // _CHUNK_FACES], out_f), bounds)
    return out_v, out_f, n_v - n_groups, n_groups - int(n_kept), n_deg

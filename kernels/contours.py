"""From faces to loops: crossings, segments, linking and grouping fused.

:func:`trace_contours` gives what the step kernels give chained
(:func:`.crossings.crossing_points`, :func:`.crossings.face_segments`,
:func:`.loops.link_segments`, :func:`.rings.group_rings`), without their
per-crossing and per-segment arrays: it walks each loop from face to twin face,
computes each crossing point when the loop reaches it (every crossing is the start
of exactly one segment, so each point is computed once) and writes it straight to
its place in the output. Scratch: a byte per segment and per output vertex, and
two numbers per face.

:func:`trace_contours` is a short Python driver over plain kernels: the closed
loops are traced in chunks of planes given to a ``run`` function (a thread pool in
the library), and the open ends are paired and the open chains traced only when
the mesh has edges without a twin. A first run of a closed mesh therefore compiles
two small kernels, and no parfor.
"""

import numpy as np
from numba import types

from ._jit import even_chunks, kernel, run_serial
from ._types import B1, B1_1D, B1_1D_OUT, I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .crossings import DOWN_EDGE, UP_EDGE
from .sorting import lower_bound, stable_argsort


@kernel(inline="always")
def _code(l0, l1, l2, k):
    """Above-code of a face at plane k: bit j set when vertex j is above it."""
    return (1 if k < l0 else 0) + (2 if k < l1 else 0) + (4 if k < l2 else 0)


@kernel(inline="always")
def _down_edge(faces, vert_layer, down_of, f, k):
    """Face f's down edge at plane k, from its code (``down_of``: ``DOWN_EDGE``).

    ``faces`` flat (face ``f`` at ``3 * f``), as in the kernels below.
    """
    return down_of[_code(vert_layer[faces[3 * f]], vert_layer[faces[3 * f + 1]],
                         vert_layer[faces[3 * f + 2]], k)]


_I64_FLAT = types.Array(types.int64, 1, "C", readonly=True)


@kernel(types.UniTuple(I64, 2)(_I64_FLAT, I64, I64, I64))
def _point(vertices, p, q, zk):
    """Crossing of edge p-q with plane zk, from its lower end (as crossing_points).

    ``vertices`` flat (x, y, z of vertex ``v`` at ``3 * v``). Branch-free: which
    end is lower is data, not a jump (it is unpredictable along a chain); then
    :func:`_point_up`.
    """
    swap = vertices[3 * p + 2] > vertices[3 * q + 2]
    return _point_up(vertices, 3 * (q if swap else p), 3 * (p if swap else q), zk)


@kernel(inline="always")
def _point_up(vertices, a, b, zk):
    """Crossing of the edge from a (below or on zk) to b (above zk) with plane zk.

    ``vertices`` flat, the ends given by their places ``a`` and ``b`` in it
    (three times their vertex ids). ``a + round((b - a) * t / dz)`` per
    coordinate: the offset from a rounded to nearest (ties away from zero), as
    ``crossings.crossing_points``; both quotients from one reciprocal
    (:func:`round_div_by`). The indices are unsigned: no wraparound code.
    """
    za = vertices[np.uint64(a + 2)]
    dz = vertices[np.uint64(b + 2)] - za
    xa = vertices[np.uint64(a)]
    ya = vertices[np.uint64(a + 1)]
    t = zk - za
    inv = 1.0 / np.float64(dz)
    return (xa + round_div_by(vertices[np.uint64(b)] - xa, t, dz, inv),
            ya + round_div_by(vertices[np.uint64(b + 1)] - ya, t, dz, inv))


@kernel(inline="always")
def round_div_by(d, t, dz, inv):
    """``d * t / dz`` rounded to nearest, ties away from zero, exactly.

    For |d| < 2**31, 0 <= t < dz < 2**31 and ``inv = 1.0 / dz`` (a double),
    without a 64-bit integer division. The double quotient ``(d * t) * inv`` is
    within three roundings (2**-51 relative) of the exact one, which is below
    2**31 in magnitude, so it is off by less than 2**-20, and its floor ``q`` is
    the exact floor ``f``, or one off where the exact quotient lies within 2**-20
    of an integer. The exact remainder ``r = d * t - q * dz`` then decides:

    * ``q == f``: ``0 <= r < dz``, the usual test (``2r > dz``, or a tie and
      ``d * t >= 0``);
    * ``q == f - 1``: the quotient is just above ``f``, which is the answer, and
      ``r >= dz`` so ``2r > dz`` adds the one;
    * ``q == f + 1``: the quotient is just below ``f + 1``, the answer, and
      ``r < 0`` so nothing is added.

    (tests/kernels/test_contours.py builds quotients 1/dz from an integer, where
    the double's floor is one off both ways.)
    """
    n = d * t
    q = np.int64(np.floor(np.float64(n) * inv))
    r2 = 2 * (n - q * dz)
    return q + np.int64((r2 > dz) | ((r2 == dz) & (n >= 0)))


_U8_W = types.uint8[::1]
_I32_W = types.int32[::1]
_I64_W = types.int64[::1]
_I32_1D = types.Array(types.int32, 1, "C", readonly=True)
_U64_R = types.Array(types.uint64, 1, "C", readonly=True)
_ALL_VISITED = np.uint64(0x0101010101010101)  # eight visited marks read as one word


@kernel(I64(I64_1D, I64_1D, I64_1D, I64))
def _paired(in_seg, in_pair, out_face, s):
    """Face of the segment joined to open end ``s`` (-1: the chain ends there).

    ``s`` is one of ``in_seg`` (sorted, distinct): found by binary search.
    """
    j = in_pair[lower_bound(in_seg, 0, in_seg.shape[0], s)]
    return -1 if j < 0 else out_face[j]


BLOCK_BITS = 4
BLOCK = 1 << BLOCK_BITS  # faces per block of the plan's block summaries


_I32_2D_W = types.int32[:, ::1]


_I32_2D = types.Array(types.int32, 2, "C", readonly=True)


@kernel(types.void(_I32_1D, _I32_1D, I64_1D, I64, I64, I64, B1, _I32_W, _I64_W,
                   _I64_W, _I32_2D_W, _I64_W))
def _plan_range(faces, twin, vert_layer, f0, f1, n_planes, closed, out_face_lo,
                out_face_offsets, out_per_plane, out_blocks, out_counts):
    """:func:`segment_plan` of faces ``f0:f1`` (``f0`` a multiple of ``BLOCK``).

    Writes ``out_face_lo[f0:f1]``; ``out_face_offsets[f0 + 1:f1 + 1]`` counted from
    0 at ``f0`` (the caller adds the segments of the faces before ``f0``); the
    planes' difference counts (+1 at a face's low plane, -1 at its high one) to
    ``out_per_plane`` (``n_planes + 1``, zeros, this range's own); the blocks of
    these faces; ``out_counts`` = (segments, starts on an edge without a twin,
    ends on one). ``faces`` are the mesh's faces as int32 (see
    :func:`narrow_faces`), flat (face ``f`` at ``3 * f``, as in
    :func:`_trace_closed`). ``closed``: every half-edge has its twin, so no
    end is open and the twins are not read (a fifth of the time).
    """
    down_of = np.array(DOWN_EDGE, dtype=np.int64)
    up_of = np.array(UP_EDGE, dtype=np.int64)
    total = 0
    n_in = 0
    n_out = 0
    b_lo = n_planes
    b_hi = 0
    for f in range(f0, f1):
        if f & (BLOCK - 1) == 0:  # a block starts
            b_lo = n_planes
            b_hi = 0
        l0 = vert_layer[np.uint64(faces[3 * f])]
        l1 = vert_layer[np.uint64(faces[3 * f + 1])]
        l2 = vert_layer[np.uint64(faces[3 * f + 2])]
        lo = min(l0, min(l1, l2))
        hi = max(l0, max(l1, l2))
        out_face_lo[f] = lo
        total += hi - lo
        out_face_offsets[f + 1] = total
        if hi > lo:
            b_lo = min(b_lo, lo)
            b_hi = max(b_hi, hi)
        out_blocks[f >> BLOCK_BITS, 0] = b_lo  # (rewritten until the block ends)
        out_blocks[f >> BLOCK_BITS, 1] = b_hi
        if hi > lo:
            out_per_plane[lo] += 1
            out_per_plane[hi] -= 1
            if not closed and (twin[3 * f] < 0 or twin[3 * f + 1] < 0
                               or twin[3 * f + 2] < 0):
                for k in range(lo, hi):
                    code = _code(l0, l1, l2, k)
                    if twin[3 * f + up_of[code]] < 0:
                        n_in += 1
                    if twin[3 * f + down_of[code]] < 0:
                        n_out += 1
    out_counts[0] = total
    out_counts[1] = n_in
    out_counts[2] = n_out


@kernel(types.void(_I64_W, I64, I64, I64))
def _shift(a, lo, hi, by):
    """Add ``by`` to ``a[lo:hi]``."""
    for i in range(lo, hi):
        a[i] += by


_PLAN_SCRATCH = 1 << 22  # plane counts of all ranges of segment_plan (32 MiB)


def segment_plan(faces, twin, vert_layer, n_planes, n_chunks=1, run=run_serial,
                 closed=False):
    """Where each face's segments go, segments per plane, open ends counted.

    Returns ``(face_lo, face_offsets, per_plane, n_in, n_out, blocks)``: face
    ``f`` crosses planes ``face_lo[f]`` and up, its segments are
    ``face_offsets[f]:face_offsets[f + 1]``; ``per_plane[k]`` is the number of
    segments on plane ``k``; ``n_in`` (``n_out``) segments start (end) on an edge
    without a twin; the faces ``BLOCK * b`` up to ``BLOCK * (b + 1)`` cross
    planes ``blocks[b, 0]`` up to ``blocks[b, 1]`` only (empty when low >= high),
    so that a chunk of planes skips the blocks that cannot meet it.

    The faces are planned in up to ``n_chunks`` ranges of whole blocks given to
    ``run`` (``run(fn, bounds)`` calls ``fn(lo, hi)`` for every range, in any
    order or at once); each range's offsets, counted from 0, are then moved up
    by the segments of the ranges before it. Each range counts its planes'
    segments in its own row, so there are fewer ranges where the planes are
    very many (at most ``_PLAN_SCRATCH`` counts in all). ``faces`` may be int64
    or already int32 (:func:`narrow_faces`). ``closed=True`` promises that
    ``twin`` has no -1 (the open ends are then not looked for).
    """
    faces = narrow_faces(faces, run)
    n_faces = faces.shape[0]
    flat_faces = faces.reshape(-1)
    n_blocks = (n_faces + BLOCK - 1) // BLOCK
    # each range counts its own planes: at most _PLAN_SCRATCH counts in all
    n_chunks = max(1, min(int(n_chunks), n_blocks, _PLAN_SCRATCH // (n_planes + 1)))
    bounds = np.minimum(
        BLOCK * ((n_blocks * np.arange(n_chunks + 1, dtype=np.int64)) // n_chunks),
        n_faces)
    face_lo = np.empty(n_faces, dtype=np.int32)
    face_offsets = np.empty(n_faces + 1, dtype=np.int64)
    face_offsets[0] = 0
    blocks = np.empty((n_blocks, 2), dtype=np.int32)
    per_plane = np.zeros((n_chunks, n_planes + 1), dtype=np.int64)
    counts = np.zeros((n_chunks, 3), dtype=np.int64)
    chunk_of = {int(bounds[c]): c for c in range(n_chunks)}

    def plan(f0, f1):
        c = chunk_of[f0]
        _plan_range(flat_faces, twin, vert_layer, f0, f1, n_planes, closed, face_lo,
                    face_offsets, per_plane[c], blocks, counts[c])

    run(plan, bounds)
    if n_chunks > 1:
        before = np.cumsum(counts[:, 0]) - counts[:, 0]
        base_of = {int(bounds[c]): int(before[c]) for c in range(n_chunks)}
        run(lambda f0, f1: _shift(face_offsets, f0 + 1, f1 + 1, base_of[f0]),
            bounds)
    planes = np.cumsum(per_plane.sum(axis=0)[:n_planes])
    return (face_lo, face_offsets, planes, int(counts[:, 1].sum()),
            int(counts[:, 2].sum()), blocks)


_ENDS = types.Tuple((I64_1D_OUT, I64_1D_OUT, I64_1D_OUT, I64_1D_OUT, I64_1D_OUT,
                     I64_1D_OUT))


@kernel(_ENDS(I64_2D, _I32_1D, I64_1D, _I32_1D, I64_1D, I64, I64))
def _open_ends(faces, twin, vert_layer, face_lo, face_offsets, n_in, n_out):
    """The open ends, in segment order, keyed by their crossing (edge, plane).

    Returns ``(in_seg, in_key, in_k, out_face, out_key, out_k)``: the ``n_in``
    segments that start, and the ``n_out`` that end, on an edge without a twin
    (counted by :func:`segment_plan`); a start by its segment, an end by its
    face.
    """
    n_faces = faces.shape[0]
    n_vertices = vert_layer.shape[0]
    down_of = np.array(DOWN_EDGE, dtype=np.int64)
    up_of = np.array(UP_EDGE, dtype=np.int64)
    in_seg = np.empty(n_in, dtype=np.int64)
    in_key = np.empty(n_in, dtype=np.int64)
    in_k = np.empty(n_in, dtype=np.int64)
    out_face = np.empty(n_out, dtype=np.int64)
    out_key = np.empty(n_out, dtype=np.int64)
    out_k = np.empty(n_out, dtype=np.int64)
    i = 0
    o = 0
    for f in range(n_faces):
        if not (twin[3 * f] < 0 or twin[3 * f + 1] < 0 or twin[3 * f + 2] < 0):
            continue
        l0 = vert_layer[faces[f, 0]]
        l1 = vert_layer[faces[f, 1]]
        l2 = vert_layer[faces[f, 2]]
        lo = np.int64(face_lo[f])
        for k in range(lo, lo + face_offsets[f + 1] - face_offsets[f]):
            code = _code(l0, l1, l2, k)
            ju = up_of[code]
            jd = down_of[code]
            if twin[3 * f + ju] < 0:
                p = faces[f, ju]
                q = faces[f, (ju + 1) % 3]
                in_seg[i] = face_offsets[f] + k - lo
                in_key[i] = min(p, q) * n_vertices + max(p, q)
                in_k[i] = k
                i += 1
            if twin[3 * f + jd] < 0:
                p = faces[f, jd]
                q = faces[f, (jd + 1) % 3]
                out_face[o] = f
                out_key[o] = min(p, q) * n_vertices + max(p, q)
                out_k[o] = k
                o += 1
    return in_seg, in_key, in_k, out_face, out_key, out_k


@kernel(I64_1D_OUT(I64_1D, I64_1D))
def _by_key_then_plane(key, k):
    """Order of the ends by (key, plane), ties in index order (stable sorts)."""
    n = key.shape[0]
    by_plane = stable_argsort(k)
    gathered = np.empty(n, dtype=np.int64)
    for i in range(n):
        gathered[i] = key[by_plane[i]]
    p = stable_argsort(gathered)
    for i in range(n):
        gathered[i] = by_plane[p[i]]
    return gathered


@kernel(types.Tuple((I64_1D_OUT, B1_1D_OUT))(I64_1D, I64_1D, I64_1D, I64_1D))
def _pair_ends(in_key, in_k, out_key, out_k):
    """Join open ends: the k-th end at a crossing (by segment) joins the k-th start.

    Returns ``(in_pair, out_has_prev)``: ``in_pair[i]`` the end joined to start
    ``i`` (-1: none), ``out_has_prev[o]`` whether end ``o`` was joined.
    """
    n_in = in_key.shape[0]
    n_out = out_key.shape[0]
    in_pair = np.full(n_in, -1, dtype=np.int64)
    out_has_prev = np.zeros(n_out, dtype=np.bool_)
    if n_in > 0 and n_out > 0:
        order_in = _by_key_then_plane(in_key, in_k)
        order_out = _by_key_then_plane(out_key, out_k)
        i = 0
        o = 0
        while i < n_in and o < n_out:
            a = order_in[i]
            b = order_out[o]
            ka = in_key[a]
            kb = out_key[b]
            if ka < kb or (ka == kb and in_k[a] < out_k[b]):
                i += 1
            elif ka > kb or in_k[a] > out_k[b]:
                o += 1
            else:
                in_pair[a] = b
                out_has_prev[b] = True
                i += 1
                o += 1
    return in_pair, out_has_prev


_OPEN = types.Tuple((I64_2D_OUT, I64_1D_OUT, I64_1D_OUT, I64_1D_OUT))


@kernel(_OPEN(_I64_FLAT, I64_2D, _I32_1D, I64_1D, I64_1D, I64_1D, _I32_1D, I64_1D,
              I64_1D, I64_1D, I64_1D, I64_1D, B1_1D, _U8_W))
def _trace_open(vertices, faces, twin, vert_layer, z, out_layer, face_lo,
                face_offsets, in_seg, in_pair, out_face, out_k, out_has_prev,
                out_visited):
    """The open chains, grouped by output layer, and their segments marked visited.

    ``vertices`` flat (see :func:`_point`).

    Returns ``(open_coords, open_offsets, open_rings, chain_segs)``: a chain starts
    at every end without a predecessor, in the order of those ends; ``open_rings``
    are the layer offsets of the chains, ``chain_segs[k]`` the number of segments
    of plane ``k`` in chains.
    """
    n_planes = z.shape[0]
    n_out = out_face.shape[0]
    down_of = np.array(DOWN_EDGE, dtype=np.int64)
    up_of = np.array(UP_EDGE, dtype=np.int64)
    n_chains = 0
    for b in range(n_out):
        if not out_has_prev[b]:
            n_chains += 1
    chain_start = np.empty(n_chains, dtype=np.int64)
    chain_len = np.empty(n_chains, dtype=np.int64)
    chain_segs = np.zeros(n_planes, dtype=np.int64)
    open_rings = np.zeros(n_planes + 1, dtype=np.int64)
    c = 0
    for b in range(n_out):
        if out_has_prev[b]:
            continue
        chain_start[c] = b
        k = out_k[b]
        f = out_face[b]
        n = 0
        while f >= 0:
            l0 = vert_layer[faces[f, 0]]
            l1 = vert_layer[faces[f, 1]]
            l2 = vert_layer[faces[f, 2]]
            s = face_offsets[f] + k - face_lo[f]
            out_visited[s] = 1
            n += 1
            tw = np.int64(twin[3 * f + up_of[_code(l0, l1, l2, k)]])
            f = tw // 3 if tw >= 0 else _paired(in_seg, in_pair, out_face, s)
        chain_len[c] = n + 1
        chain_segs[k] += n
        open_rings[out_layer[k] + 1] += 1
        c += 1
    for k in range(n_planes):
        open_rings[k + 1] += open_rings[k]
    open_fill = open_rings[:-1].copy()
    chain_slot = np.empty(n_chains, dtype=np.int64)
    for c in range(n_chains):
        lay = out_layer[out_k[chain_start[c]]]
        chain_slot[open_fill[lay]] = c
        open_fill[lay] += 1
    open_offsets = np.zeros(n_chains + 1, dtype=np.int64)
    for r in range(n_chains):
        open_offsets[r + 1] = open_offsets[r] + chain_len[chain_slot[r]]
    open_coords = np.empty((open_offsets[n_chains], 2), dtype=np.int64)
    for r in range(n_chains):
        b = chain_start[chain_slot[r]]
        k = out_k[b]
        zk = z[k]
        f = out_face[b]
        pos = open_offsets[r]
        while True:
            l0 = vert_layer[faces[f, 0]]
            l1 = vert_layer[faces[f, 1]]
            l2 = vert_layer[faces[f, 2]]
            code = _code(l0, l1, l2, k)
            jd = down_of[code]
            x, y = _point(vertices, faces[f, jd], faces[f, (jd + 1) % 3], zk)
            open_coords[pos, 0] = x
            open_coords[pos, 1] = y
            pos += 1
            ju = up_of[code]
            tw = np.int64(twin[3 * f + ju])
            if tw >= 0:
                f = tw // 3
                continue
            s = face_offsets[f] + k - face_lo[f]
            g = _paired(in_seg, in_pair, out_face, s)
            if g < 0:
                x, y = _point(vertices, faces[f, ju], faces[f, (ju + 1) % 3], zk)
                open_coords[pos, 0] = x
                open_coords[pos, 1] = y
                break
            f = g
    return open_coords, open_offsets, open_rings, chain_segs


@kernel(
    types.void(_I64_FLAT, _I32_1D, _I32_1D, I64_1D, I64_1D, I64_1D, _I32_1D, I64_1D,
               _I32_2D, I64_1D, I64, I64, I64_1D, I64_1D, I64_1D, _U8_W,
               _I64_W, _U8_W, _I64_W, _U8_W, _U64_R),
)
def _trace_closed(vertices, faces, twin, vert_layer, z, out_layer, face_lo,
                  face_offsets, blocks, layer_start, k0, k1, in_seg, in_pair,
                  out_face, out_visited, out_coords, out_ring_start, out_rings_of,
                  out_broken, visited_words):
    """Trace the closed loops of planes ``k0:k1`` (one chunk; chunks may run at once).

    Faces are scanned in order (skipping the blocks of faces that do not meet
    the chunk, by the plan's ``blocks``) and a loop is traced from every
    segment not yet visited, writing its points at its plane's cursor (which
    starts at ``layer_start[out_layer[k]]``) and flagging its first point in
    ``out_ring_start``. A chunk writes only its planes' segments and vertices.

    A block whose faces cross only planes of the chunk has its visited marks in
    one run; when all of them are set (as for most blocks: the loops through
    its faces started earlier) the block is passed over without visiting its
    faces one by one. ``visited_words`` is ``out_visited`` read as uint64 (its
    length a multiple of 8), so the run is read 8 marks at a time. (The scan
    alone took 12.9 ms of a serial trace of five Benchies face by face, 5.3 ms
    so.)

    ``vertices`` (x, y, z of vertex ``v`` at ``3 * v``), ``faces`` (int32, see
    :func:`narrow_faces`; face ``f`` at ``3 * f``) and ``out_coords`` (x, y of
    output vertex ``i`` at ``2 * i``) are flat: the addresses of the walk are
    then constant multiples, where 2-D arrays multiply by a stride read at run
    time. Inside the walk the indices are unsigned (every one is >= 0), which
    spares numba's wraparound of negative ones; together about a sixth less
    time on five Benchies. From face to face the walk waits for two loads in a
    row (the third corner, then its layer): both candidate twins are loaded
    beside the corners and one is kept by a mask (about 7% less time).
    """
    if k1 <= k0:
        return
    n_faces = faces.shape[0] // 3
    down_of = np.array(DOWN_EDGE, dtype=np.int64)
    cursor = np.empty(k1 - k0, dtype=np.int64)
    for k in range(k0, k1):
        cursor[k - k0] = layer_start[out_layer[k]]
    for blk in range(blocks.shape[0]):
        if blocks[blk, 0] >= k1 or blocks[blk, 1] <= k0:
            continue  # no face of this block meets the chunk's planes
        fa = BLOCK * blk
        fb = min(fa + BLOCK, n_faces)
        if blocks[blk, 0] >= k0 and blocks[blk, 1] <= k1:
            # every segment of the block is the chunk's, and they are one run
            # of the marks: when all are visited (most blocks, by loops that
            # started before) the block holds no start
            s = face_offsets[fa]
            s_end = face_offsets[fb]
            while s < s_end and s & 7 and out_visited[s]:
                s += 1
            while s + 8 <= s_end and visited_words[s >> 3] == _ALL_VISITED:
                s += 8
            while s < s_end and out_visited[s]:
                s += 1
            if s == s_end:
                continue
            while face_offsets[fa + 1] <= s:  # the faces before s hold no start
                fa += 1
        for f0 in range(fa, fb):
            lo0 = np.int64(face_lo[f0])
            hi0 = lo0 + face_offsets[f0 + 1] - face_offsets[f0]
            for k in range(max(lo0, k0), min(hi0, k1)):
                if out_visited[face_offsets[f0] + k - lo0]:
                    continue
                zk = z[k]
                pos = cursor[k - k0]
                out_ring_start[pos] = 1
                out_rings_of[k] += 1
                # the loop enters face f by its down edge e (vertex e above the
                # plane, e + 1 below), found from the face's code only where a
                # loop starts or an open end is joined; inside a loop it is the
                # twin's edge. The up edge is then e + 1 if the third vertex is
                # above, else e + 2: one vertex layer read per crossing
                f = f0
                e = _down_edge(faces, vert_layer, down_of, f, k)
                while True:
                    u = np.uint64(f)
                    s = face_offsets[u] + k - face_lo[u]
                    if out_visited[np.uint64(s)]:
                        break
                    out_visited[np.uint64(s)] = 1
                    e1 = e + 1 - 3 * (e >> 1)  # (e + 1) % 3 and (e + 2) % 3
                    e2 = e + 2 - 3 * ((e + 1) >> 1)  # without jumps: e is data
                    h = 3 * f
                    t1 = np.int64(twin[np.uint64(h + e1)])  # both: no wait on
                    t2 = np.int64(twin[np.uint64(h + e2)])  # the layer
                    a = 3 * np.int64(faces[np.uint64(h + e1)])  # below the plane
                    b = 3 * np.int64(faces[np.uint64(h + e)])  # above it
                    # the next face first: its loads do not wait for the stores
                    c = faces[np.uint64(h + e2)]
                    # pick by a mask, not ``t1 if ... else t2``: LLVM turns that
                    # into one load from a selected address, which then waits
                    # for the layer (a third load in a row from face to face)
                    up = -np.int64(k < vert_layer[np.uint64(c)])
                    tw = t2 ^ ((t1 ^ t2) & up)
                    x, y = _point_up(vertices, a, b, zk)
                    out_coords[np.uint64(2 * pos)] = x
                    out_coords[np.uint64(2 * pos + 1)] = y
                    pos += 1
                    if tw >= 0:
                        f = tw // 3
                        e = tw - 3 * f
                    else:
                        f = _paired(in_seg, in_pair, out_face, s)
                        if f < 0:  # cannot happen: only chains end
                            out_broken[k] = 1
                            break
                        e = _down_edge(faces, vert_layer, down_of, f, k)
                cursor[k - k0] = pos


NARROW_LIMIT = 1 << 31  # vertices: the face indices of at most this many fit int32


_NARROW_CHUNK = 1 << 18  # faces per chunk of narrow_faces


def narrow_faces(faces, run=run_serial):
    """``faces`` as int32 (the same array when it is int32 already).

    Copied in chunks of faces given to ``run`` (``run(fn, bounds)`` calls
    ``fn(lo, hi)`` for every chunk, in any order or at once; by default one
    after another). Precondition: every index is below 2**31 (at most
    ``NARROW_LIMIT`` vertices).
    """
    if faces.dtype == np.int32:
        return faces
    out = np.empty(faces.shape, dtype=np.int32)
    run(lambda lo, hi: np.copyto(out[lo:hi], faces[lo:hi], casting="unsafe"),
        even_chunks(faces.shape[0], _NARROW_CHUNK))
    return out


def trace_contours(vertices, faces, twin, vert_layer, z, out_layer, n_chunks,
                   run=run_serial, faces32=None, closed=False):
    """Closed loops and open chains of a mesh cut at every plane, grouped by layer.

    Returns ``(coords, ring_offsets, layer_offsets, open_coords, open_ring_offsets,
    open_layer_offsets)``: the closed loops, then the open chains, each grouped by
    output layer ``out_layer[k]`` of plane ``k``. Equal to chaining
    ``crossing_points``, ``face_segments``, ``link_segments`` and ``group_rings``:
    a closed loop starts at its first segment (segments ordered by face, then
    plane), loops of a layer come in that order, open chains start where no
    segment ends and come in the order of their first segment. Ends on edges
    without a twin are joined by crossing (edge and plane) as
    :func:`.loops.pair_open_ends` joins them.

    Closed loops are traced in up to ``n_chunks`` chunks of consecutive planes
    with about equal numbers of segments: a loop lies in one plane, and each
    plane's vertices have their own range of the output. ``run(fn, bounds)``
    calls ``fn(k0, k1)`` for every chunk of planes ``bounds[c]:bounds[c + 1]``
    (in any order, or at once: e.g. ``vecslice._threads.run_chunks``); by
    default one after another.

    Preconditions: ``z`` sorted; ``vert_layer[v]`` the number of planes strictly
    below vertex ``v``; ``twin`` from :func:`.topology.half_edge_twins`;
    ``out_layer`` a permutation of ``range(len(z))``; |coordinates| < 2**30;
    at most ``NARROW_LIMIT`` vertices. ``faces32``: ``faces`` as int32, when
    the caller keeps them (``vecslice.Mesh`` does); else made here.
    ``closed=True``: the caller knows that ``twin`` has no -1 (``vecslice.Mesh``
    caches it), and the plan does not read the twins to count open ends.
    """
    n_planes = z.shape[0]
    faces32 = narrow_faces(faces if faces32 is None else faces32, run)
    face_lo, face_offsets, per_plane, n_in, n_out, blocks = segment_plan(
        faces32, twin, vert_layer, n_planes, n_chunks, run, closed)
    flat_vertices = np.ascontiguousarray(vertices).reshape(-1)  # see _point
    n_seg = int(face_offsets[-1])
    visited = np.zeros(n_seg + (-n_seg) % 8, dtype=np.uint8)  # whole words
    if n_in + n_out == 0:  # a closed mesh: the open-end kernels are not compiled
        in_seg = in_pair = out_face = np.empty(0, dtype=np.int64)
        open_coords = np.empty((0, 2), dtype=np.int64)
        open_offsets = np.zeros(1, dtype=np.int64)
        open_rings = np.zeros(n_planes + 1, dtype=np.int64)
        chain_segs = np.zeros(n_planes, dtype=np.int64)
    else:
        in_seg, in_key, in_k, out_face, out_key, out_k = _open_ends(
            faces, twin, vert_layer, face_lo, face_offsets, n_in, n_out)
        in_pair, out_has_prev = _pair_ends(in_key, in_k, out_key, out_k)
        open_coords, open_offsets, open_rings, chain_segs = _trace_open(
            flat_vertices, faces, twin, vert_layer, z, out_layer, face_lo,
            face_offsets, in_seg, in_pair, out_face, out_k, out_has_prev, visited)

    # closed loops: every other segment starts one vertex; each plane's vertices
    # go to its output layer's range, in the order the loops are found
    layer_start = np.zeros(n_planes + 1, dtype=np.int64)
    layer_start[out_layer + 1] = per_plane - chain_segs
    np.cumsum(layer_start, out=layer_start)
    n_closed = int(layer_start[n_planes])
    coords = np.empty((n_closed, 2), dtype=np.int64)
    ring_start = np.zeros(n_closed, dtype=np.uint8)
    rings_of = np.zeros(n_planes, dtype=np.int64)
    broken = np.zeros(n_planes, dtype=np.uint8)
    # chunks of consecutive planes with about equal numbers of segments: chunk c
    # starts at the first plane with at least n_seg * c // n_chunks segments below
    n_chunks = max(1, min(n_planes, int(n_chunks)))
    below = np.zeros(n_planes + 1, dtype=np.int64)
    np.cumsum(per_plane, out=below[1:])
    targets = (n_seg * np.arange(n_chunks + 1, dtype=np.int64)) // n_chunks
    bounds = np.minimum(np.searchsorted(below, targets, side="left"), n_planes)
    bounds[0] = 0
    bounds[n_chunks] = n_planes

    # flat views for the walk (see _trace_closed)
    flat_faces = faces32.reshape(-1)
    flat_coords = coords.reshape(-1)

    def closed(k0, k1):
        _trace_closed(flat_vertices, flat_faces, twin, vert_layer, z, out_layer,
                      face_lo, face_offsets, blocks, layer_start, k0, k1, in_seg,
                      in_pair, out_face, visited, flat_coords, ring_start, rings_of,
                      broken, visited.view(np.uint64))

    run(closed, bounds)
    if broken.any():
        raise RuntimeError("trace_contours: a loop without a successor")
    # (0/1 bytes: numpy finds the ones of a bool view several times faster)
    ring_offsets = np.append(np.flatnonzero(ring_start.view(np.bool_)),
                             n_closed).astype(np.int64)
    layer_offsets = np.zeros(n_planes + 1, dtype=np.int64)
    layer_offsets[out_layer + 1] = rings_of
    np.cumsum(layer_offsets, out=layer_offsets)
    return (coords, ring_offsets, layer_offsets, open_coords, open_offsets,
            open_rings)


@kernel(types.void(I64_2D, I64_1D, I64, I64, I64, I64, _I64_W))
def _vertex_layers_range(vertices, z, even, dz, v0, v1, out):
    """:func:`vertex_layers` of vertices ``v0:v1``, written to ``out``.

    Planes ``even`` and up are evenly spaced, ``dz > 0`` apart (``even == len(z)``:
    none are). Above plane ``even`` the count is a division: the planes
    ``even + j`` with ``z[even] + j * dz < vz`` number ``ceil((vz - z[even]) / dz)``
    (at most ``len(z) - even``), and every plane before ``even`` is lower still.
    Elsewhere the count is that of the planes before ``even`` (or of all planes):
    a binary search without branches on the data (the halving steps depend only
    on the number of planes; which half is kept is a select), so that the
    unpredictable comparisons cost no mispredicted jumps.
    """
    n_planes = z.shape[0]
    z_even = z[even] if even < n_planes else 0
    for v in range(v0, v1):
        vz = vertices[v, 2]
        if even < n_planes and vz > z_even:
            out[v] = even + min((vz - z_even + dz - 1) // dz, n_planes - even)
            continue
        n = even  # z[even] >= vz: no plane from ``even`` on is below vz
        if n == 0:
            out[v] = 0
            continue
        base = 0
        while n > 1:  # the answer lies in base .. base + n
            half = n >> 1
            base = base + half if z[base + half - 1] < vz else base
            n -= half
        out[v] = base + (1 if z[base] < vz else 0)


_VERTEX_CHUNK = 1 << 16  # vertices per chunk of vertex_layers


@kernel(types.UniTuple(I64, 2)(I64_1D))
def _even_suffix(z):
    """The evenly spaced planes at the end of ``z``, as ``(even, dz)``.

    Planes ``even`` and up are ``dz > 0`` apart, ``even`` as small as that allows;
    ``(len(z), 0)`` when fewer than two planes, or the last two equal.
    """
    n = z.shape[0]
    if n < 2 or z[n - 1] <= z[n - 2]:
        return n, 0
    dz = z[n - 1] - z[n - 2]
    even = n - 2
    while even > 0 and z[even] - z[even - 1] == dz:
        even -= 1
    return even, dz


def vertex_layers(vertices, z, run=run_serial):
    """Number of planes strictly below each vertex: ``searchsorted(z, vz, "left")``.

    A vertex is above plane ``k`` iff ``k < vert_layer[v]`` (on the plane counts as
    below). Where the planes end evenly spaced (a layer schedule: a first layer,
    then one height) a vertex above the first of those is counted by a division,
    elsewhere by a binary search; chunks of vertices are given to ``run``
    (``run(fn, bounds)`` calls ``fn(lo, hi)`` for every chunk, in any order or at
    once; by default one after another). Precondition: ``z`` sorted.
    """
    n = vertices.shape[0]
    out = np.empty(n, dtype=np.int64)
    even, dz = _even_suffix(z)
    bounds = np.append(np.arange(0, n, _VERTEX_CHUNK), n)
    run(lambda v0, v1: _vertex_layers_range(vertices, z, even, dz, v0, v1, out),
        bounds)
    return out

"""Kernels of CuraEngine's adaptive layer heights (spec/ADAPTIVE.md).

Bit-exactness: every float operation below is one IEEE float64 operation in the
spec's order. Kernels never use fastmath, so LLVM neither reassociates nor fuses a
multiply and an add into an FMA (``tests/kernels/test_adaptive.py`` checks the
machine code); ``math.acos``/``math.tan`` call the platform libm, as CuraEngine does.
"""

import math

import numpy as np
from numba import types

from ._jit import kernel
from ._types import (
    B1,
    F64_1D,
    F64_1D_OUT,
    F64_1D_W,
    I64,
    I64_1D,
    I64_1D_OUT,
    I64_2D,
    I64_2D_OUT,
    I64_2D_W,
)

TAU = 2.0 * math.pi  # 6.283185307179586, the period of CuraEngine's angle type
FLAT = math.fmod(math.fmod(math.pi, TAU) + TAU, TAU)  # == math.pi
DBL_MAX = 1.7976931348623157e308


@kernel(inline="always")
def _face_slope(vertices, faces, dz, f, out_face_z, out_slope):
    """Write face ``f``'s z range and slope (see :func:`face_slopes`).

    Inlined into its two callers, so the machine code that
    ``tests/kernels/test_adaptive.py`` checks for FMAs is theirs.
    """
    i0, i1, i2 = faces[f, 0], faces[f, 1], faces[f, 2]
    z0 = vertices[i0, 2] - dz
    z1 = vertices[i1, 2] - dz
    z2 = vertices[i2, 2] - dz
    out_face_z[f, 0] = min(z0, min(z1, z2))
    out_face_z[f, 1] = max(z0, max(z1, z2))
    # millimetres: multiply by the double 0.001 (not divide by 1000)
    x0 = float(vertices[i0, 0]) * 0.001
    y0 = float(vertices[i0, 1]) * 0.001
    w0 = float(z0) * 0.001
    ax = float(vertices[i1, 0]) * 0.001 - x0
    ay = float(vertices[i1, 1]) * 0.001 - y0
    az = float(z1) * 0.001 - w0
    bx = float(vertices[i2, 0]) * 0.001 - x0
    by = float(vertices[i2, 1]) * 0.001 - y0
    bz = float(z2) * 0.001 - w0
    nx = ay * bz - az * by
    ny = az * bx - ax * bz
    nz = ax * by - ay * bx
    length = math.sqrt((nx * nx + ny * ny) + nz * nz)
    if length == 0.0:
        out_slope[f] = np.nan  # 0 / 0 in CuraEngine
    else:
        a = math.acos(abs(nz / length))
        # CuraEngine wraps the angle into [0, 2 pi): fmod(fmod(a, TAU) + TAU,
        # TAU). For 0 <= a <= pi/2 (acos of a value in [0, 1]) the inner fmod
        # is a itself and x = a + TAU lies in [TAU, 2 TAU), so fmod(x, TAU) is
        # x - TAU, which is exact (Sterbenz: TAU <= x <= 2 TAU). Same bits,
        # without two libm fmods.
        s = (a + TAU) - TAU
        out_slope[f] = FLAT if s == 0.0 else s


@kernel(types.Tuple((I64_2D_OUT, F64_1D_OUT))(I64_2D, I64_2D, I64))
def face_slopes(vertices, faces, dz):
    """Per face: integer z range and the float64 slope of spec section 3.

    Face ``f`` gets ``face_z[f] = (zmin, zmax)`` of its corners' ``z - dz`` (µm) and
    ``slope[f]`` in radians: the angle between the face and the horizontal plane,
    computed in millimetres from the shifted corners, wrapped into [0, 2 pi), with
    exactly 0 replaced by pi (a horizontal face) and NaN for a zero-area face.
    Serial; ``vecslice.adaptive`` runs :func:`face_slopes_range` over chunks of
    faces on a few threads instead (same results).

    Preconditions: 0 <= faces < len(vertices); |vertices|, |dz| < 2**30.
    """
    n = faces.shape[0]
    face_z = np.empty((n, 2), dtype=np.int64)
    slope = np.empty(n, dtype=np.float64)
    for f in range(n):
        _face_slope(vertices, faces, dz, f, face_z, slope)
    return face_z, slope


@kernel(types.void(I64_2D, I64_2D, I64, I64, I64, I64_2D_W, F64_1D_W))
def face_slopes_range(vertices, faces, dz, f0, f1, out_face_z, out_slope):
    """:func:`face_slopes` of faces ``f0:f1``, into rows ``f0:f1`` of the outputs.

    Serial: callers run disjoint ranges on several threads (the kernel releases
    the GIL); the other rows are left as they are.

    Preconditions: as :func:`face_slopes`; 0 <= f0 <= f1 <= len(faces); the
    outputs have ``len(faces)`` rows.
    """
    for f in range(f0, f1):
        _face_slope(vertices, faces, dz, f, out_face_z, out_slope)


@kernel(I64_1D_OUT(I64_1D))
def zmin_order(zmin):
    """A permutation sorting ``zmin`` ascending (stable).

    A counting sort when the values span at most ``4 * len + 1024`` (any sliceable
    model: its faces start within a few times their number of µm), else a merge
    sort.

    Preconditions: len(zmin) >= 1; |zmin| < 2**62.
    """
    n = zmin.shape[0]
    lo = zmin.min()
    span = zmin.max() - lo + 1
    if span > 4 * n + 1024:
        return np.argsort(zmin, kind="mergesort")
    start = np.zeros(span + 1, dtype=np.int64)
    for f in range(n):
        start[zmin[f] - lo + 1] += 1
    for k in range(span):
        start[k + 1] += start[k]
    order = np.empty(n, dtype=np.int64)
    for f in range(n):
        k = zmin[f] - lo
        order[start[k]] = f
        start[k] += 1
    return order


@kernel(
    types.Tuple((I64_1D_OUT, I64_1D_OUT))(
        I64_2D, F64_1D, I64, I64, I64, I64, I64, B1, I64
    )
)
def adaptive_layers(
    face_z, slope, first, hmax, hmin, step, threshold, middle, max_layers
):
    """CuraEngine's adaptive layer loop (spec section 4): ``(thickness, top)``.

    The allowed heights are ``hmax, hmax - step, ..., hmin``. Layer 0 is
    ``(first, first)``; layers are added while the last top is <= the highest face
    z, and at least two. A candidate ``h`` inspects the faces whose z range
    ``face_z[f] = (zmin, zmax)`` meets ``[z, z + h // 2]`` (``middle``) or
    ``[z, z + h]``, and the smallest of their ``slope`` (NaN ignored).

    Active window (spec section 10): the faces, sorted by zmin, that meet
    ``[z, z + band(hmax)]``, kept in zmin order, so the band of any candidate is a
    prefix of the window; a running minimum of their slopes (starting at DBL_MAX)
    is extended only as far as a candidate needs. The candidates more than one
    step thicker than the previous layer are skipped arithmetically: they would
    be skipped anyway, and if the band of one of them were empty so would be the
    band of the first candidate tested (bands shrink with ``h``).

    The loop stops after ``max_layers + 1`` layers: a result longer than
    ``max_layers`` means the schedule has more layers than that (the caller
    raises). Nine arguments rather than a packed array, so each keeps its name.

    Preconditions: F >= 1 faces in any order, ``zmin <= zmax``; ``slope`` aligned
    with ``face_z``; ``first > 0``; ``0 < hmin <= hmax`` and ``(hmax - hmin) %
    step == 0``; ``step > 0``; ``max_layers >= 1``; all values below 2**31 in
    size.
    """
    zmin, zmax, slopes = sort_faces(face_z, slope)
    return adaptive_layers_sorted(zmin, zmax, slopes, first, hmax, hmin, step,
                                  threshold, middle, max_layers, zmax.max())


@kernel(types.Tuple((I64_1D_OUT, I64_1D_OUT, F64_1D_OUT))(I64_2D, F64_1D))
def sort_faces(face_z, slope):
    """``(zmin, zmax, slope)`` of the faces in ascending zmin order (stable).

    What :func:`adaptive_layers_sorted` reads; it depends on the mesh (and its
    frame) only, so a caller may keep it for every schedule of that mesh.
    Precondition: F >= 1.
    """
    n_faces = face_z.shape[0]
    order = zmin_order(face_z[:, 0].copy())
    zmin = np.empty(n_faces, dtype=np.int64)
    zmax = np.empty(n_faces, dtype=np.int64)
    slopes = np.empty(n_faces, dtype=np.float64)
    for k in range(n_faces):
        f = order[k]
        zmin[k] = face_z[f, 0]
        zmax[k] = face_z[f, 1]
        slopes[k] = slope[f]
    return zmin, zmax, slopes


@kernel(
    types.Tuple((I64_1D_OUT, I64_1D_OUT))(
        I64_1D, I64_1D, F64_1D, I64, I64, I64, I64, I64, B1, I64, I64
    )
)
def adaptive_layers_sorted(
    zmin, zmax, slopes, first, hmax, hmin, step, threshold, middle, max_layers,
    max_z
):
    """:func:`adaptive_layers` on faces already in :func:`sort_faces` order.

    ``max_z`` is the model's top (CuraEngine's ``model_max_z``, the largest
    vertex z): layers are added while the last top is <= it. It is the highest
    face z, unless the model has vertices above its faces (a mesh read by
    CuraEngine's rules keeps the vertices of the faces its melding dropped);
    above the faces every band is empty, and the layers are ``hmin`` thick.
    """
    n_faces = zmin.shape[0]
    reach = hmax // 2 if middle else hmax
    last = (hmax - hmin) // step  # index of hmin
    limit = float(threshold)
    cap = 64
    thickness = np.empty(cap, dtype=np.int64)
    top = np.empty(cap, dtype=np.int64)
    thickness[0] = first
    top[0] = first
    n = 1
    window = np.empty(n_faces, dtype=np.int64)  # positions in zmin order, ascending
    prefix_min = np.empty(n_faces, dtype=np.float64)
    n_win = 0
    nxt = 0
    z = first
    prev = first
    while (z <= max_z or n < 2) and n <= max_layers:
        kept = 0
        for j in range(n_win):  # drop faces that ended below z
            if zmax[window[j]] >= z:
                window[kept] = window[j]
                kept += 1
        n_win = kept
        while nxt < n_faces and zmin[nxt] <= z + reach:
            if zmax[nxt] >= z:
                window[n_win] = nxt
                n_win += 1
            nxt += 1
        n_min = 0  # prefix_min[:n_min] is valid
        m = DBL_MAX
        i = 0
        if hmax - prev - step > 0:  # skip candidates more than a step thicker
            i = min((hmax - prev - 1) // step, last)
        chosen = hmin
        while i <= last:
            h = hmax - i * step
            band_top = z + (h // 2 if middle else h)
            # the band: window faces with zmin <= band_top, i.e. position < stop
            stop = np.searchsorted(zmin[:nxt], band_top, side="right")
            k = np.searchsorted(window[:n_win], stop, side="left")
            if k == 0:
                break  # empty band: hmin
            exceeded = prev > h and prev - h > step
            if not exceeded and h - prev > step and h > hmin:
                i += 1
                continue
            while n_min < k:
                s = slopes[window[n_min]]
                if s < m:  # NaN never compares smaller
                    m = s
                prefix_min[n_min] = m
                n_min += 1
            t = math.tan(prefix_min[k - 1])
            if t == 0.0 or float(h) / t <= limit or h == hmin or exceeded:
                chosen = h
                break
            i += 1
        z += chosen
        prev = chosen
        if n == cap:
            cap *= 2
            grown = np.empty(cap, dtype=np.int64)
            grown[:n] = thickness
            thickness = grown
            grown = np.empty(cap, dtype=np.int64)
            grown[:n] = top
            top = grown
        thickness[n] = chosen
        top[n] = z
        n += 1
    return thickness[:n].copy(), top[:n].copy()

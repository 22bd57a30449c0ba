"""Slow pure-Python reference of CuraEngine's adaptive layer heights (spec/ADAPTIVE.md).

Written from the spec, independently of ``kernels/adaptive.py``: Python ints for
every length, one ``float`` operation per step of the per-face slope (Python floats
are IEEE doubles, never fused), ``math.acos``/``math.tan``/``math.fmod`` (the
platform libm), and the layer loop exactly as section 4 writes it: a scan over all
allowed heights and, for each candidate, over all faces.
"""

from __future__ import annotations

import math

TAU = 2.0 * math.pi
FLAT = math.fmod(math.fmod(math.pi, TAU) + TAU, TAU)
DBL_MAX = 1.7976931348623157e308


def allowed_heights(base: int, variation: int, step: int) -> list[int]:
    """Section 2: the candidate heights, thickest first."""
    out = []
    h = base + variation
    while h >= base - variation:
        if h <= 0:
            break
        out.append(h)
        h -= step
    return out


def face_slope(p0, p1, p2) -> float:
    """Section 3: the float64 slope of one face (int µm corners)."""
    q0 = [float(c) * 0.001 for c in p0]
    q1 = [float(c) * 0.001 for c in p1]
    q2 = [float(c) * 0.001 for c in p2]
    ax, ay, az = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
    bx, by, bz = q2[0] - q0[0], q2[1] - q0[1], q2[2] - q0[2]
    nx = ay * bz - az * by
    ny = az * bx - ax * bz
    nz = ax * by - ay * bx
    length = math.sqrt((nx * nx + ny * ny) + nz * nz)
    if length == 0.0:
        return math.nan  # 0/0 in C; Python would raise
    c = abs(nz / length)
    a0 = math.acos(c)
    s = math.fmod(math.fmod(a0, TAU) + TAU, TAU)
    if s == 0.0:
        s = FLAT
    return s


def face_data(vertices, faces):
    """Per face ``(zmin, zmax, slope)`` as three lists."""
    zmin, zmax, slope = [], [], []
    for f in faces:
        p = [list(map(int, vertices[i])) for i in f]
        zs = [q[2] for q in p]
        zmin.append(min(zs))
        zmax.append(max(zs))
        slope.append(face_slope(*p))
    return zmin, zmax, slope


def layer_loop(
    zmin, zmax, slope, model_max_z, *, first, heights, step, threshold, tolerance
) -> list[tuple[int, int]]:
    """Section 4 on per-face data: ``[(thickness, z_top), ...]`` from layer 0 up."""
    hmin = heights[-1]
    z = first
    prev = first
    layers = [(first, first)]
    while z <= model_max_z or len(layers) < 2:
        chosen = None
        for h in heights:
            top = z + (h // 2 if tolerance == "middle" else h)
            band = [i for i in range(len(zmin)) if zmax[i] >= z and zmin[i] <= top]
            if not band:
                break
            m = DBL_MAX
            for i in band:
                if slope[i] < m:
                    m = slope[i]
            exceeded = prev > h and prev - h > step
            if not exceeded and h - prev > step and h > hmin:
                continue
            t = math.tan(m)
            if t == 0.0 or float(h) / t <= float(threshold) or h == hmin or exceeded:
                chosen = h
                break
        if chosen is None:
            chosen = hmin
        z += chosen
        prev = chosen
        layers.append((chosen, z))
    return layers


def adaptive_layers(
    vertices, faces, *, base, first, variation, step, threshold, tolerance
) -> list[tuple[int, int]]:
    """Sections 2-4 in the bed frame: ``[(thickness, z_top), ...]`` from layer 0 up."""
    zmin, zmax, slope = face_data(vertices, faces)
    model_max_z = max(int(vertices[i][2]) for f in faces for i in f)
    return layer_loop(
        zmin, zmax, slope, model_max_z, first=first,
        heights=allowed_heights(base, variation, step), step=step,
        threshold=threshold, tolerance=tolerance,
    )

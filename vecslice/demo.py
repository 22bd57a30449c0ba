"""A small built-in model, generated in integer µm (no file, no trimesh)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vecslice._validate import check_int
from vecslice.errors import InputValueError
from vecslice.mesh import Mesh

__all__ = ["demo_mesh"]


def _rectangle(x0: int, y0: int, x1: int, y1: int, per_side: int) -> NDArray[np.int64]:
    """CCW ring around a rectangle, corners included, ``per_side`` points per side."""
    t = np.arange(per_side) / per_side
    sx, sy = np.rint((x1 - x0) * t), np.rint((y1 - y0) * t)
    sides = [
        np.column_stack([x0 + sx, np.full(per_side, y0)]),
        np.column_stack([np.full(per_side, x1), y0 + sy]),
        np.column_stack([x1 - sx, np.full(per_side, y1)]),
        np.column_stack([np.full(per_side, x0), y1 - sy]),
    ]
    return np.concatenate(sides).astype(np.int64)


def _circle(cx: int, cy: int, r: int, n: int) -> NDArray[np.int64]:
    a = 2 * np.pi * np.arange(n) / n
    return np.column_stack([np.rint(cx + r * np.cos(a)),
                            np.rint(cy + r * np.sin(a))]).astype(np.int64)


def _prism(
    outer: NDArray[np.int64], inner: NDArray[np.int64] | None, z0: int, z1: int
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Closed, outward-wound prism over a CCW ring, with an optional matched hole.

    ``inner[i]`` must lie on the ray from the hole centre through ``outer[i]`` (so
    each cap quad is convex); without ``inner`` the caps are fans to the centroid.
    """
    n = outer.shape[0]
    i = np.arange(n)
    j = (i + 1) % n
    o0, o1 = i, i + n  # outer ring, bottom and top
    if inner is None:
        centre = np.rint(outer.mean(axis=0)).astype(np.int64)
        ring = np.concatenate([outer, outer, [centre, centre]])
        c0, c1 = np.full(n, 2 * n), np.full(n, 2 * n + 1)
        caps = [np.column_stack([c1, o1, j + n]), np.column_stack([c0, j, o0])]
    else:
        ring = np.concatenate([outer, outer, inner, inner])
        i0, i1 = i + 2 * n, i + 3 * n  # inner ring, bottom and top
        j0, j1 = j + 2 * n, j + 3 * n
        caps = [
            np.column_stack([o1, j + n, j1]), np.column_stack([o1, j1, i1]),  # top
            np.column_stack([o0, j0, j]), np.column_stack([o0, i0, j0]),  # bottom
            np.column_stack([i0, i1, j1]), np.column_stack([i0, j1, j0]),  # hole wall
        ]
    walls = [np.column_stack([o0, j, j + n]), np.column_stack([o0, j + n, o1])]
    z = np.repeat([z0, z1], n)
    if inner is None:
        z = np.concatenate([z, [z0, z1]])
    else:
        z = np.concatenate([z, z])
    vertices = np.column_stack([ring, z]).astype(np.int64)
    return vertices, np.concatenate(caps + walls).astype(np.int64)


MAX_SEGMENTS = 2**20  # 12 million faces, about 0.5 GB: refused above, not allocated


def demo_mesh(*, segments: int = 64) -> Mesh:
    """A 30 mm test part: a plate with a through-hole and a cylindrical boss.

    The plate is 30 x 20 x 5 mm with a 7 mm hole at x = -7 mm; a 8 mm boss, 10 mm
    tall, stands on it at x = +7.5 mm. They are two closed, outward-wound bodies
    that touch (the boss's bottom lies on the plate's top), centred on x = y = 0
    and resting on z = 0. All coordinates are exact integer µm.

    Parameters
    ----------
    segments : int, default 64
        Polygon sides of the hole and the boss; a multiple of 4, at least 8 and
        at most ``2**20`` (12 million faces).

    Returns
    -------
    Mesh
        ``12 * segments`` faces: ``8 * segments`` for the plate, ``4 * segments``
        for the boss.

    Examples
    --------
    >>> m = demo_mesh()
    >>> m.n_faces, m.n_bodies, m.is_watertight, m.bounds.tolist()
    (768, 2, True, [[-15000, -10000, 0], [15000, 10000, 15000]])
    """
    n = check_int(segments, "segments", minimum=8, maximum=MAX_SEGMENTS,
                  what="an integer number of polygon sides")
    if n % 4:
        raise InputValueError(f"`segments` must be a multiple of 4; got {n}")
    outer = _rectangle(-15000, -10000, 15000, 10000, n // 4)
    hole_c = np.array([-7000, 0])
    d = (outer - hole_c).astype(np.float64)
    inner = np.rint(hole_c + 3500 * d / np.hypot(d[:, 0], d[:, 1])[:, None])
    plate_v, plate_f = _prism(outer, inner.astype(np.int64), 0, 5000)
    boss_v, boss_f = _prism(_circle(7500, 0, 4000, n), None, 5000, 15000)
    vertices = np.concatenate([plate_v, boss_v])
    faces = np.concatenate([plate_f, boss_f + plate_v.shape[0]])
    return Mesh.from_arrays(vertices, faces)

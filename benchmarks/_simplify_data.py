"""Inputs for the simplify benchmarks (no pytest here): noisy circles with a fixed
seed, and the raw slice loops of five 3DBenchy copies at 0.1 mm (the real-mesh
input; needs ../shared/meshes).

Imported by ``bench_simplify.py`` (fixtures) and ``simplify_ratios.py`` (script).
"""

from __future__ import annotations

import numpy as np

SEED = 20240611
N_RINGS = 1_000
N_VERTS = 1_000
RADIUS = 20_000  # µm: 1000 vertices on a 20 mm radius -> ~126 µm edges
NOISE = 30  # µm, uniform radial noise
MAX_DEVIATION = 25  # µm, also the epsilon of the other libraries


def noisy_circles(n_rings: int = N_RINGS, n_verts: int = N_VERTS,
                  seed: int = SEED) -> tuple[np.ndarray, np.ndarray]:
    """(coords (n_rings*n_verts, 2) int64 µm, ring_offsets) of disjoint noisy CCW
    circles on a grid."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(n_rings)))
    ang = np.linspace(0.0, 2.0 * np.pi, n_verts, endpoint=False)
    idx = np.arange(n_rings)
    cx = (idx % side) * (3 * RADIUS)
    cy = (idx // side) * (3 * RADIUS)
    r = RADIUS + rng.integers(-NOISE, NOISE + 1, size=(n_rings, n_verts))
    x = np.rint(cx[:, None] + r * np.cos(ang)[None, :])
    y = np.rint(cy[:, None] + r * np.sin(ang)[None, :])
    coords = np.stack([x.ravel(), y.ravel()], axis=1).astype(np.int64)
    offsets = np.arange(n_rings + 1, dtype=np.int64) * n_verts
    return coords, offsets


def as_ring_list(coords: np.ndarray, offsets: np.ndarray) -> list[np.ndarray]:
    return [coords[offsets[i]:offsets[i + 1]] for i in range(len(offsets) - 1)]


def benchy_loops(copies: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """(coords, ring_offsets) of the raw closed loops of ``copies`` 3DBenchy copies
    sliced at 0.1 mm (2.7 M vertices for five copies), before any simplification.
    """
    import vecslice as vs
    from _workloads import heights, plate

    mesh = plate(copies)
    p = vs.slice_contours(mesh, heights(mesh)).paths()
    return np.ascontiguousarray(p.coords), np.ascontiguousarray(p.ring_offsets)


def vecslice_simplify(coords: np.ndarray, offsets: np.ndarray):
    """vecslice's way from its natural input, ragged int64 arrays: wrap, simplify.

    The wrapping (``vs.Paths`` checks the arrays) is timed with the simplification,
    as clipper2 converts its list of rings inside its call.
    """
    import vecslice as vs

    return vs.simplify(vs.Paths(coords, offsets))

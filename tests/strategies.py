"""Hypothesis strategies shared by the tests."""

from __future__ import annotations

import numpy as np
import trimesh
from hypothesis import strategies as st

_PRIMITIVES = ("box", "icosphere", "cylinder", "annulus", "two_boxes")


def _primitive(kind: str, rng: np.random.Generator) -> trimesh.Trimesh:
    if kind == "box":
        return trimesh.creation.box(rng.uniform(1, 30, 3))
    if kind == "icosphere":
        return trimesh.creation.icosphere(subdivisions=int(rng.integers(1, 3)),
                                          radius=float(rng.uniform(1, 20)))
    if kind == "cylinder":
        return trimesh.creation.cylinder(radius=float(rng.uniform(1, 15)),
                                         height=float(rng.uniform(1, 20)),
                                         sections=int(rng.integers(3, 40)))
    if kind == "annulus":
        r = float(rng.uniform(2, 15))
        return trimesh.creation.annulus(r_min=r / 2, r_max=r,
                                        height=float(rng.uniform(1, 20)),
                                        sections=int(rng.integers(3, 40)))
    a = trimesh.creation.box((5, 5, 5))
    b = trimesh.creation.box((5, 5, 8))
    b.apply_translation((12, 0, 1))
    return trimesh.util.concatenate([a, b])


@st.composite
def closed_meshes(draw):
    """(vertices_um int64 (V,3), faces int64 (F,3), slice_z int64) of a closed,
    consistently outward-wound mesh, randomly rotated, scaled and shifted, with
    planes that include exact vertex heights.
    """
    seed = draw(st.integers(0, 2**32 - 1))
    kind = draw(st.sampled_from(_PRIMITIVES))
    rng = np.random.default_rng(seed)
    m = _primitive(kind, rng)
    m.apply_transform(trimesh.transformations.random_rotation_matrix(rng.random(3)))
    m.apply_translation(rng.uniform(-100, 100, 3))
    scale = draw(st.sampled_from([1.0, 1000.0, 0.001 * 37]))
    v = np.rint(m.vertices * 1000 * scale).astype(np.int64)
    f = np.asarray(m.faces, dtype=np.int64)
    zs = v[:, 2]
    planes = list(rng.integers(zs.min() - 2, zs.max() + 3, size=6))
    planes += list(rng.choice(zs, size=3))  # exactly at vertex heights
    return v, f, np.array(planes, dtype=np.int64)


def run_reversed(fn, bounds):
    """A kernel driver's ``run``: the chunks last to first (as threads may)."""
    for c in reversed(range(len(bounds) - 1)):
        fn(int(bounds[c]), int(bounds[c + 1]))

"""Shared benchmark workloads: the same meshes and heights for every library."""

from __future__ import annotations

import os
from functools import cache
from pathlib import Path

import numpy as np

import vecslice as vs

ROOT = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("VECSLICE_SHARED", ROOT.parent / "shared"))
MESHES = SHARED / "meshes"
LAYER_HEIGHT = 100  # µm, the reference workload's 0.1 mm layers


@cache
def benchy() -> vs.Mesh:
    """One 3DBenchy, loaded and merged by vecslice."""
    return vs.load_mesh(MESHES / "3DBenchy.3mf")


@cache
def plate(copies: int) -> vs.Mesh:
    """``copies`` Benchies side by side, 5 mm apart (derived data, not a file).

    Five copies (about 1.13M triangles) are the reference workload of DESIGN.md.
    """
    one = benchy()
    width = int(np.ptp(one.vertices[:, 0])) + 5000
    verts = [one.vertices + np.array([i * width, 0, 0]) for i in range(copies)]
    faces = [one.faces + i * len(one.vertices) for i in range(copies)]
    return vs.Mesh.from_arrays(np.concatenate(verts), np.concatenate(faces))


@cache
def small() -> vs.Mesh:
    """The Voron calibration cube (3.4k triangles)."""
    return vs.load_mesh(MESHES / "Voron_Design_Cube_v7.stl")


WORKLOADS = {
    "voron": small,
    "benchy": benchy,
    "benchy5": lambda: plate(5),
}


def heights(mesh: vs.Mesh) -> np.ndarray:
    """0.1 mm layers, Cura's middle schedule."""
    z, _, _ = vs.layer_heights(mesh, vs.SliceSettings(layer_height=LAYER_HEIGHT))
    return z


def manifold_slices(mesh: vs.Mesh, z: np.ndarray) -> list:
    """manifold3d's way: build a Manifold, then slice at every height."""
    import manifold3d as m3

    m = m3.Manifold(m3.Mesh(vert_properties=mesh.vertices.astype(np.float32),
                            tri_verts=mesh.faces.astype(np.uint32)))
    return [m.slice(float(zk)) for zk in z]


def trimesh_sections(mesh: vs.Mesh, z: np.ndarray) -> list:
    """trimesh's way: section_multiplane at every height (µm as float units)."""
    import trimesh

    tm = trimesh.Trimesh(mesh.vertices.astype(np.float64), mesh.faces, process=False)
    return tm.section_multiplane(plane_origin=[0, 0, 0], plane_normal=[0, 0, 1],
                                 heights=z.astype(np.float64))

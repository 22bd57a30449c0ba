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


def mm_arrays(mesh: vs.Mesh, dtype=np.float32) -> tuple[np.ndarray, np.ndarray]:
    """The mesh as a peer's natural input: float millimetre vertices, faces."""
    return (mesh.vertices / 1000.0).astype(dtype), mesh.faces.copy()


def vecslice_contours(vertices_um: np.ndarray, faces: np.ndarray,
                      z: np.ndarray) -> vs.LayerPaths:
    """vecslice's way from int64 µm arrays: build a Mesh, cut every height."""
    return vs.slice_contours(vs.Mesh.from_arrays(vertices_um, faces), z)


def manifold_build_slice(vertices_mm: np.ndarray, faces: np.ndarray,
                         z_mm: np.ndarray) -> list:
    """manifold3d's way from float32 mm arrays: build a Manifold, slice each height."""
    import manifold3d as m3

    m = m3.Manifold(m3.Mesh(vert_properties=np.asarray(vertices_mm, np.float32),
                            tri_verts=np.asarray(faces, np.uint32)))
    return [m.slice(float(zk)) for zk in z_mm]


def meshlib_build_slice(vertices_mm: np.ndarray, faces: np.ndarray,
                        z_mm: np.ndarray) -> list:
    """MeshLib's way from float32 mm arrays: ``meshFromFacesVerts``, then per height
    ``extractXYPlaneSections`` and ``planeSectionsToContours2f`` (its default AABB
    tree is built by the first section, inside the timing)."""
    import meshlib.mrmeshnumpy as mn
    import meshlib.mrmeshpy as mm

    mesh = mn.meshFromFacesVerts(np.asarray(faces, np.int32),
                                 np.asarray(vertices_mm, np.float32))
    part = mm.MeshPart(mesh)
    xf = mm.AffineXf3f()
    return [mm.planeSectionsToContours2f(
        mesh, mm.extractXYPlaneSections(part, float(zk)), xf) for zk in z_mm]


def trimesh_build_sections(vertices_mm: np.ndarray, faces: np.ndarray,
                           z_mm: np.ndarray) -> list:
    """trimesh's way from float64 mm arrays: a Trimesh, section_multiplane."""
    import trimesh

    tm = trimesh.Trimesh(np.asarray(vertices_mm, np.float64), faces, process=False)
    return tm.section_multiplane(plane_origin=[0, 0, 0], plane_normal=[0, 0, 1],
                                 heights=np.asarray(z_mm, np.float64))


def manifold_slices(mesh: vs.Mesh, z: np.ndarray) -> list:
    """manifold3d build + slice of a vecslice Mesh (mm conversion included)."""
    v, f = mm_arrays(mesh)
    return manifold_build_slice(v, f, z / 1000.0)


def meshlib_slices(mesh: vs.Mesh, z: np.ndarray) -> list:
    """MeshLib build + sections of a vecslice Mesh (mm conversion included)."""
    v, f = mm_arrays(mesh)
    return meshlib_build_slice(v, f, z / 1000.0)


def trimesh_sections(mesh: vs.Mesh, z: np.ndarray) -> list:
    """trimesh section_multiplane of a vecslice Mesh (mm conversion included)."""
    v, f = mm_arrays(mesh, np.float64)
    return trimesh_build_sections(v, f, z / 1000.0)

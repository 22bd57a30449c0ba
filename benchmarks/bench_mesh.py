"""Reading mesh files: vecslice's readers beside trimesh.load on the same files.

vecslice's number includes what trimesh's does not: conversion to int64 µm and
the exact vertex merge (``repair=False``, so no orientation repair). The 3MF is
read by vecslice.threemf, the OBJ by vecslice.meshfile; trimesh gets
``process=False``.
"""

from __future__ import annotations

import pytest
import trimesh

import vecslice as vs
from _workloads import MESHES

FILES = {"3DBenchy.3mf": 225_154, "stanford-bunny.obj": 69_451}  # faces read


@pytest.fixture(params=list(FILES))
def path(request):
    p = MESHES / request.param
    if not p.exists():
        pytest.skip(f"{p} not found (../shared beside the project)")
    return p


@pytest.mark.benchmark(group="load-mesh")
def test_vecslice_load(benchmark, path):
    mesh = benchmark(vs.load_mesh, path, repair=False)
    assert mesh.load_info.faces_in == FILES[path.name]


@pytest.mark.benchmark(group="load-mesh")
def test_trimesh_load(benchmark, path):
    loaded = benchmark(trimesh.load, path, process=False)
    geoms = loaded.geometry.values() if isinstance(loaded, trimesh.Scene) else [loaded]
    assert sum(len(g.faces) for g in geoms) >= FILES[path.name]


@pytest.mark.benchmark(group="repair-mesh")
def test_vecslice_repair(benchmark, path):
    """Orientation repair (windings made consistent, shells turned outward)."""
    mesh = vs.load_mesh(path, repair=False)
    repaired = benchmark(mesh.repaired)
    assert repaired.n_faces <= mesh.n_faces

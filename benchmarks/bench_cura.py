"""slice_mesh with compat="cura" beside the default mode on the same triangles.

The compat mesh is CuraEngine's reading of the workload's triangles: the corners of
``plate(5)`` (int64 µm) melded at 30 µm through CuraEngine's hash cells
(``vecslice.cura_stl.cura_mesh_from_corners``), as ``load_mesh(path,
compat="cura")`` would after reading an STL of them (3DBenchy is a 3MF, which
CuraEngine does not read). ``python benchmarks/cura_ratios.py`` prints the ratio.
"""

from __future__ import annotations

from functools import cache

import numba
import numpy as np
import pytest
import trimesh

import vecslice as vs
from _workloads import WORKLOADS, heights
from vecslice.cura_stl import cura_mesh_from_corners

CURA = vs.SliceSettings(compat="cura")


@cache
def cura_mesh(name: str) -> vs.Mesh:
    """The workload's triangles as CuraEngine holds them after loading."""
    mesh = WORKLOADS[name]()
    return cura_mesh_from_corners(mesh.vertices[mesh.faces].reshape(-1, 3), name)


def warm_up() -> None:
    """Load every compat kernel from the JIT cache (an open box has open chains)."""
    box = trimesh.creation.box((10, 10, 10))
    vs.slice_mesh(vs.demo_mesh())
    vs.slice_mesh(vs.load_mesh(box, compat="cura"), CURA)
    open_box = trimesh.Trimesh(box.vertices, box.faces[2:], process=False)
    vs.slice_mesh(vs.load_mesh(open_box, compat="cura"), CURA)


@pytest.fixture(scope="module", params=list(WORKLOADS))
def workload(request):
    warm_up()
    mesh = WORKLOADS[request.param]()
    return request.param, mesh, cura_mesh(request.param), heights(mesh)


def _info(benchmark, name, mesh, z):
    benchmark.extra_info.update(mesh=name, faces=int(mesh.n_faces), layers=len(z),
                                threads=numba.get_num_threads())


@pytest.mark.benchmark(group="compat")
def test_slice_mesh_default(benchmark, workload):
    name, mesh, _, z = workload
    _info(benchmark, name, mesh, z)
    model = benchmark.pedantic(vs.slice_mesh, (mesh,), rounds=3, iterations=1)
    assert model.n_layers == len(z) and model.n_parts >= model.n_layers - 1


@pytest.mark.benchmark(group="compat")
def test_slice_mesh_compat_cura(benchmark, workload):
    name, _, mesh, z = workload
    _info(benchmark, name, mesh, z)
    times = vs.StageTimes()
    model = benchmark.pedantic(vs.slice_mesh, (mesh, CURA), {"times": times},
                               rounds=3, iterations=1)
    benchmark.extra_info.update({f"s_{k}": v for k, v in times.seconds.items()})
    assert model.n_layers == len(z) and (model.slice_z == z).all()
    assert model.n_parts >= model.n_layers - 1
    assert np.isfinite(model.layer_areas()).all()

"""slice_contours beside manifold3d (build + slice) and trimesh section_multiplane.

Same meshes, same heights, one run. The timed work starts from a freshly built
``vs.Mesh`` (vecslice derives its edge topology inside the timing, just as
manifold3d builds its ``Manifold``). ``python benchmarks/slicing_ratios.py`` prints
the ratios. trimesh takes about a minute on the reference workload, so its
``benchy5`` case runs only with VECSLICE_BENCH_FULL=1.
"""

from __future__ import annotations

import os

import numba
import pytest

import vecslice as vs
from _workloads import WORKLOADS, heights, manifold_slices, trimesh_sections

FULL = os.environ.get("VECSLICE_BENCH_FULL") == "1"


@pytest.fixture(scope="module", params=list(WORKLOADS))
def workload(request):
    mesh = WORKLOADS[request.param]()
    z = heights(mesh)
    vs.slice_contours(mesh, z[:2])  # load the JIT cache outside the timing
    return request.param, mesh, z


def _info(benchmark, name, mesh, z):
    benchmark.extra_info.update(mesh=name, faces=int(mesh.n_faces), layers=len(z),
                                threads=numba.get_num_threads())


@pytest.mark.benchmark(group="slice-contours")
def test_vecslice(benchmark, workload):
    name, mesh, z = workload
    _info(benchmark, name, mesh, z)
    loops = benchmark(vs.slice_contours, mesh, z)
    assert loops.n_layers == len(z)
    assert (loops.rings_per_layer() > 0).all()


@pytest.mark.benchmark(group="slice-contours")
def test_manifold3d(benchmark, workload):
    name, mesh, z = workload
    _info(benchmark, name, mesh, z)
    out = benchmark.pedantic(manifold_slices, (mesh, z), rounds=1, iterations=1)
    assert len(out) == len(z) and out[len(z) // 2].area() > 0


@pytest.mark.benchmark(group="slice-contours")
def test_trimesh(benchmark, workload):
    name, mesh, z = workload
    if name == "benchy5" and not FULL:
        pytest.skip("trimesh on the reference workload takes ~1 min; set "
                    "VECSLICE_BENCH_FULL=1 (slicing_ratios.py measures it)")
    _info(benchmark, name, mesh, z)
    out = benchmark.pedantic(trimesh_sections, (mesh, z), rounds=1, iterations=1)
    assert len(out) == len(z) and out[len(z) // 2] is not None

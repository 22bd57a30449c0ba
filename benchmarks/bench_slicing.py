"""slice_contours beside manifold3d, MeshLib (build + slice) and trimesh.

Same meshes, same heights, one run. Every library starts from its natural input
(vecslice: int64 µm arrays; the peers: float mm arrays) and builds its structures
inside the timing (``vs.Mesh.from_arrays`` with its merge and topology, manifold3d's
``Manifold``, MeshLib's mesh and AABB tree, a ``trimesh.Trimesh``).
``python benchmarks/report.py`` prints the ratios (interleaved, repeated, with the
spread). trimesh takes about a minute on the reference workload, so its
``benchy5`` case runs only with VECSLICE_BENCH_FULL=1.
"""

from __future__ import annotations

import os

import numba
import numpy as np
import pytest

import vecslice as vs
from _workloads import (
    WORKLOADS,
    heights,
    manifold_build_slice,
    meshlib_build_slice,
    mm_arrays,
    trimesh_build_sections,
    vecslice_contours,
)

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
    v, f = mesh.vertices.copy(), mesh.faces.copy()
    loops = benchmark(vecslice_contours, v, f, z)
    assert loops.n_layers == len(z)
    assert (loops.rings_per_layer() > 0).all()


@pytest.mark.benchmark(group="slice-contours")
def test_manifold3d(benchmark, workload):
    name, mesh, z = workload
    _info(benchmark, name, mesh, z)
    v, f = mm_arrays(mesh)
    out = benchmark.pedantic(manifold_build_slice, (v, f, z / 1000.0), rounds=1,
                             iterations=1)
    assert len(out) == len(z) and out[len(z) // 2].area() > 0


@pytest.mark.benchmark(group="slice-contours")
def test_meshlib(benchmark, workload):
    name, mesh, z = workload
    if name == "benchy5" and not FULL:
        pytest.skip("MeshLib on the reference workload takes a few seconds; set "
                    "VECSLICE_BENCH_FULL=1 (report.py measures it)")
    _info(benchmark, name, mesh, z)
    v, f = mm_arrays(mesh)
    out = benchmark.pedantic(meshlib_build_slice, (v, f, z / 1000.0), rounds=1,
                             iterations=1)
    assert len(out) == len(z) and len(out[len(z) // 2]) > 0


@pytest.mark.benchmark(group="slice-contours")
def test_vecslice_second_slice(benchmark, workload):
    # the topology is built by the first slice of a Mesh and reused after it
    name, mesh, z = workload
    _info(benchmark, name, mesh, z)
    loops = benchmark(vs.slice_contours, mesh, z + 50)
    assert loops.n_layers == len(z)


@pytest.mark.benchmark(group="slice-contours")
def test_trimesh(benchmark, workload):
    name, mesh, z = workload
    if name == "benchy5" and not FULL:
        pytest.skip("trimesh on the reference workload takes ~1 min; set "
                    "VECSLICE_BENCH_FULL=1 (slicing_ratios.py measures it)")
    _info(benchmark, name, mesh, z)
    v, f = mm_arrays(mesh, np.float64)
    out = benchmark.pedantic(trimesh_build_sections, (v, f, z / 1000.0), rounds=1,
                             iterations=1)
    assert len(out) == len(z) and out[len(z) // 2] is not None

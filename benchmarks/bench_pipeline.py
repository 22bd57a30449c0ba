"""Full slice_mesh (contours, stitch, simplify with Cura defaults, parts) beside
manifold3d building a Manifold and slicing every height: same mesh, same heights,
one run. vecslice is timed from the int64 µm arrays (``Mesh.from_arrays`` in every
round), as each peer builds its own structures inside the timing.
``python benchmarks/pipeline_ratios.py`` prints the ratio, the per-stage split and
the peak memory."""

from __future__ import annotations

import numba
import pytest

import vecslice as vs
from _workloads import WORKLOADS, heights, manifold_slices


@pytest.fixture(scope="module", params=list(WORKLOADS))
def workload(request):
    mesh = WORKLOADS[request.param]()
    vs.slice_mesh(vs.demo_mesh())  # load the JIT caches outside the timing
    return request.param, mesh, heights(mesh)


def _info(benchmark, name, mesh, z):
    benchmark.extra_info.update(mesh=name, faces=int(mesh.n_faces), layers=len(z),
                                threads=numba.get_num_threads())


@pytest.mark.benchmark(group="pipeline")
def test_vecslice_slice_mesh(benchmark, workload):
    name, mesh, z = workload
    _info(benchmark, name, mesh, z)
    times = vs.StageTimes()
    vertices, faces = mesh.vertices.copy(), mesh.faces.copy()

    def from_arrays():
        return vs.slice_mesh(vs.Mesh.from_arrays(vertices, faces), times=times)

    model = benchmark.pedantic(from_arrays, rounds=3, iterations=1)
    benchmark.extra_info.update({f"s_{k}": v for k, v in times.seconds.items()})
    assert model.n_layers == len(z) and (model.slice_z == z).all()
    assert model.n_parts >= model.n_layers - 1


@pytest.mark.benchmark(group="pipeline")
def test_manifold3d_slice_only(benchmark, workload):
    name, mesh, z = workload
    _info(benchmark, name, mesh, z)
    out = benchmark.pedantic(manifold_slices, (mesh, z), rounds=1, iterations=1)
    assert len(out) == len(z) and out[len(z) // 2].area() > 0

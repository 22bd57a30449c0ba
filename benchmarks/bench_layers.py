"""Adaptive layer heights beside slice_contours at the heights they produce.

Target (issue 9): the adaptive schedule of the reference workload (five 3DBenchy
copies) costs at most a quarter of ``slice_contours`` at the resulting heights.
``python benchmarks/layers_ratios.py`` prints the ratio.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

import vecslice as vs
from _workloads import WORKLOADS

ADAPTIVE = vs.SliceSettings(adaptive_layers=True)


@pytest.fixture(scope="module", params=list(WORKLOADS))
def workload(request):
    mesh = WORKLOADS[request.param]()
    z, _, _ = vs.layer_heights(mesh, ADAPTIVE)  # compiles / loads the JIT cache
    vs.slice_contours(mesh, z[:2])
    return request.param, mesh, z


def _info(benchmark, name, mesh, z):
    benchmark.extra_info.update(mesh=name, faces=int(mesh.n_faces), layers=len(z),
                                threads=numba.get_num_threads())


@pytest.mark.benchmark(group="adaptive-layers")
def test_adaptive_schedule(benchmark, workload):
    name, mesh, z = workload
    _info(benchmark, name, mesh, z)
    slice_z, print_z, thickness = benchmark(vs.layer_heights, mesh, ADAPTIVE)
    assert (slice_z == z).all()
    assert (np.cumsum(thickness) == print_z).all()
    assert set(thickness[1:].tolist()) <= set(range(10, 201, 10))


@pytest.mark.benchmark(group="adaptive-layers")
def test_contours_at_adaptive_heights(benchmark, workload):
    name, mesh, z = workload
    _info(benchmark, name, mesh, z)
    loops = benchmark(vs.slice_contours, mesh, z)
    assert loops.n_layers == len(z)
    assert loops.rings_per_layer()[-1] == 0  # the last layer ends above the model

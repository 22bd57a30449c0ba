"""A 12-combination XY sweep (vs.sweep, metrics included) beside 12 separate
slice_mesh calls on the reference workload (five 3DBenchy copies, 0.1 mm layers),
both from one prepared ``Mesh`` and from the int64 arrays (every separate call
builds its own ``Mesh``, the sweep one). Target: the sweep takes at most 0.7x the
time. ``python benchmarks/sweep_ratio.py`` alternates all four and prints the
ratios (wall and CPU)."""

from __future__ import annotations

import numba
import pytest

import vecslice as vs
from _workloads import plate
from sweep_ratio import GRID, combos, separate, separate_from_arrays, swept_from_arrays


@pytest.fixture(scope="module")
def reference():
    mesh = plate(5)
    vs.sweep(vs.demo_mesh(), {"max_deviation": [25]})  # JIT caches, dask imports
    return mesh


@pytest.mark.benchmark(group="sweep 12 XY settings")
def test_sweep_12_xy(benchmark, reference):
    benchmark.extra_info.update(faces=int(reference.n_faces),
                                threads=numba.get_num_threads())
    table = benchmark.pedantic(vs.sweep, ({"benchy5": reference}, GRID), rounds=1,
                               iterations=1)
    assert len(table) == 12 and (table["error"] == "").all()
    assert (table["layers"] == 478).all()
    assert table["max_deviation_um"].notna().all()


@pytest.mark.benchmark(group="sweep 12 XY settings")
def test_slice_mesh_12_times(benchmark, reference):
    benchmark.extra_info.update(faces=int(reference.n_faces),
                                threads=numba.get_num_threads())
    benchmark.pedantic(separate, (reference,), rounds=1, iterations=1)
    assert len(combos()) == 12


@pytest.mark.benchmark(group="sweep 12 XY settings, from arrays")
def test_sweep_12_xy_from_arrays(benchmark, reference):
    v, f = reference.vertices.copy(), reference.faces.copy()
    table = benchmark.pedantic(swept_from_arrays, (v, f), rounds=1, iterations=1)
    assert len(table) == 12 and (table["error"] == "").all()


@pytest.mark.benchmark(group="sweep 12 XY settings, from arrays")
def test_slice_mesh_12_times_from_arrays(benchmark, reference):
    v, f = reference.vertices.copy(), reference.faces.copy()
    benchmark.pedantic(separate_from_arrays, (v, f), rounds=1, iterations=1)

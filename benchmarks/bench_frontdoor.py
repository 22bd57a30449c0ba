"""The front door: `import vecslice` in a fresh interpreter, and the layer viewer
of the reference workload (five Benchies at 0.1 mm): time to write it, and its size
(``extra_info['bytes']``)."""

from __future__ import annotations

import subprocess
import sys

import pytest

import vecslice as vs
from _workloads import plate
from vecslice.viewer import viewer_html


@pytest.mark.benchmark(group="startup")
def test_import_vecslice(benchmark):
    # a fresh interpreter each round; compare with test_python_startup
    run = [sys.executable, "-c", "import vecslice"]
    benchmark.pedantic(subprocess.run, (run,), {"check": True}, rounds=5,
                       iterations=1)


@pytest.mark.benchmark(group="startup")
def test_python_startup(benchmark):
    run = [sys.executable, "-c", "pass"]
    benchmark.pedantic(subprocess.run, (run,), {"check": True}, rounds=5,
                       iterations=1)


@pytest.fixture(scope="module")
def benchy5_model():
    return vs.slice_mesh(plate(5))


@pytest.mark.benchmark(group="viewer")
def test_viewer_of_five_benchies(benchmark, benchy5_model):
    page = benchmark.pedantic(viewer_html, (benchy5_model,), rounds=3, iterations=1)
    benchmark.extra_info.update(bytes=len(page.encode()),
                                layers=benchy5_model.n_layers,
                                vertices=int(benchy5_model.coords.shape[0]))
    assert benchy5_model.n_layers == 478

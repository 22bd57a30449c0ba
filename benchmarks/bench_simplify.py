"""Throughput of vs.simplify beside clipper2, shapely and manifold3d (same input):
noisy circles, and (vecslice and clipper2) the raw loops of five Benchies at 0.1 mm."""

import clipper2
import manifold3d
import numba
import numpy as np
import pytest
import shapely

import vecslice as vs
from _simplify_data import (
    MAX_DEVIATION,
    as_ring_list,
    benchy_loops,
    noisy_circles,
    vecslice_simplify,
)


@pytest.fixture(scope="module")
def circles():
    coords, offsets = noisy_circles()
    paths = vs.Paths(coords, offsets)
    vs.simplify(paths)  # load / compile the JIT outside the timing
    return paths


@pytest.fixture(scope="module")
def benchy5_loops():
    """Raw loops of five Benchies at 0.1 mm (the real-mesh input)."""
    from _workloads import MESHES

    if not MESHES.exists():
        pytest.skip(f"shared meshes not found at {MESHES}")
    coords, offsets = benchy_loops(5)
    paths = vs.Paths(coords, offsets)
    vs.simplify(paths)
    return paths


def _info(benchmark, paths):
    benchmark.extra_info["vertices"] = int(paths.coords.shape[0])
    benchmark.extra_info["rings"] = len(paths)
    benchmark.extra_info["threads"] = numba.get_num_threads()


@pytest.mark.benchmark(group="simplify.noisy_circles")
def test_vecslice_simplify(benchmark, circles):
    _info(benchmark, circles)
    out = benchmark(vecslice_simplify, circles.coords, circles.ring_offsets)
    assert len(out) == len(circles)
    assert 0 < out.coords.shape[0] < circles.coords.shape[0] // 2


@pytest.mark.benchmark(group="simplify.noisy_circles")
def test_clipper2_simplify_paths(benchmark, circles):
    _info(benchmark, circles)
    rings = as_ring_list(circles.coords, circles.ring_offsets)
    out = benchmark(clipper2.simplify_paths, rings, float(MAX_DEVIATION), True)
    assert len(out) == len(rings)
    assert sum(len(r) for r in out) < circles.coords.shape[0] // 2


@pytest.mark.benchmark(group="simplify.noisy_circles")
def test_shapely_simplify(benchmark, circles):
    _info(benchmark, circles)
    rings = as_ring_list(circles.coords, circles.ring_offsets)
    frings = [r.astype(np.float64) for r in rings]
    # the polygons are shapely's structure: built inside the timing
    out = benchmark(lambda: shapely.simplify(shapely.polygons(frings),
                                             float(MAX_DEVIATION)))
    assert len(out) == len(rings)
    assert shapely.get_num_coordinates(out).sum() < circles.coords.shape[0] // 2


@pytest.mark.benchmark(group="simplify.noisy_circles")
def test_manifold3d_cross_section_simplify(benchmark, circles):
    _info(benchmark, circles)
    rings = as_ring_list(circles.coords, circles.ring_offsets)
    frings = [r.astype(np.float64) for r in rings]
    # the CrossSection is manifold3d's structure: built inside the timing
    out = benchmark(lambda: manifold3d.CrossSection(frings).simplify(
        float(MAX_DEVIATION)))
    assert out.num_contour() == len(rings)
    assert out.num_vert() < circles.coords.shape[0] // 2


@pytest.mark.benchmark(group="simplify.benchy5_loops")
def test_vecslice_simplify_benchy5_loops(benchmark, benchy5_loops):
    _info(benchmark, benchy5_loops)
    out = benchmark(vecslice_simplify, benchy5_loops.coords,
                    benchy5_loops.ring_offsets)
    assert len(out) == len(benchy5_loops)
    assert 0 < out.coords.shape[0] < benchy5_loops.coords.shape[0] // 2


@pytest.mark.benchmark(group="simplify.benchy5_loops")
def test_clipper2_simplify_paths_benchy5_loops(benchmark, benchy5_loops):
    _info(benchmark, benchy5_loops)
    rings = as_ring_list(benchy5_loops.coords, benchy5_loops.ring_offsets)
    out = benchmark(clipper2.simplify_paths, rings, float(MAX_DEVIATION), True)
    assert len(out) == len(rings)

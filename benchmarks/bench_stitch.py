"""vs.stitch on triangle soups (issue 8 A3) and on a million chain ends in one gap.

A soup of N random small triangles (corners within 1 mm) in a 10 mm cube, sliced
at Cura's default layers, gives about 5 N two-vertex open chains, up to N / 18 in a
layer, all within round 2's 10 mm gap. Listing every candidate pair took 0.4 s
(2k), 40 s (10k) and 300 s (20k triangles); the target for the whole slice of the
20k soup is 2 s. ``pytest benchmarks/bench_stitch.py --benchmark-only``.
"""

from __future__ import annotations

from functools import cache

import numba
import numpy as np
import pytest

import vecslice as vs


@cache
def soup(n: int, seed: int = 0) -> vs.Mesh:
    """``n`` random triangles (corners within 1 mm) in a 10 mm cube."""
    rng = np.random.default_rng(seed)
    corner = rng.integers(0, 10_000, (n, 1, 3))
    v = (corner + rng.integers(-500, 501, (n, 3, 3))).reshape(-1, 3)
    return vs.Mesh.from_arrays(v, np.arange(3 * n).reshape(n, 3))


@cache
def soup_chains(n: int) -> vs.LayerPaths:
    """The soup's raw slice: no loops, its open chains in ``.open``."""
    mesh = soup(n)
    z, _, _ = vs.layer_heights(mesh, vs.SliceSettings())
    return vs.slice_contours(mesh, z, stitch=False)


def _info(benchmark, raw):
    per_layer = raw.open.rings_per_layer()
    benchmark.extra_info.update(chains=int(per_layer.sum()),
                                max_chains_per_layer=int(per_layer.max()),
                                layers=raw.n_layers, threads=numba.get_num_threads())


@pytest.mark.benchmark(group="stitch.soup")
@pytest.mark.parametrize("n", [2_000, 10_000, 20_000])
def test_stitch_soup(benchmark, n):
    raw = soup_chains(n)
    vs.stitch(soup_chains(50))  # load the JIT cache outside the timing
    _info(benchmark, raw)
    loops, gaps = benchmark(vs.stitch, raw)
    assert gaps.sum() > 4 * n and loops.n_rings > 0


@pytest.mark.benchmark(group="stitch.soup-slice")
def test_slice_mesh_soup_20k(benchmark):
    # the target: the whole slice of the 20k soup in <= 2 s
    mesh = soup(20_000)
    vs.slice_mesh(soup(50))
    _info(benchmark, soup_chains(20_000))
    model = benchmark.pedantic(vs.slice_mesh, (mesh,), rounds=3, iterations=1)
    assert model.stitched_gaps.sum() > 80_000


@pytest.mark.benchmark(group="stitch.million-ends")
def test_stitch_million_ends_in_one_gap(benchmark):
    # 500,000 two-vertex chains in one 5 mm layer: 10**6 ends, 5 * 10**11
    # candidate pairs within 10 mm that the old kernel would have listed
    rng = np.random.default_rng(1)
    n = 500_000
    chains = vs.LayerPaths(rng.integers(0, 5_000, (2 * n, 2)),
                           np.arange(0, 2 * n + 1, 2), [0, n])
    raw = vs.LayerPaths(np.empty((0, 2), np.int64), [0], [0, 0], open=chains)
    vs.stitch(soup_chains(50))
    benchmark.extra_info.update(chain_ends=2 * n, threads=numba.get_num_threads())
    loops, gaps = benchmark.pedantic(vs.stitch, (raw,), rounds=1, iterations=1)
    assert gaps.tolist() == [n] and loops.open.n_rings == 0

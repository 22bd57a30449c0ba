"""make_parts throughput on synthetic layers (wobbly circles), against manifold3d alone.

Layouts per layer (10 rings of V vertices):
* ``disjoint``: 10 separate discs (no hole: no nesting work);
* ``holes``: 5 discs each with a hole (nesting by bounding boxes);
* ``islands``: a disc, a hole, an island with a hole... (manifold3d ``decompose``).

``manifold_only`` times the floor: one ``CrossSection`` + ``to_polygons`` per layer.
Run: ``pytest benchmarks/bench_parts.py --benchmark-only``.
"""

from __future__ import annotations

import itertools

import manifold3d
import numpy as np
import pytest

import vecslice as vs

SIZES = [(50, 100), (500, 1000)]  # (layers, vertices per ring); 10 rings per layer


def _layers(kind: str, n_layers: int, n_vertices: int) -> vs.LayerPaths:
    rng = np.random.default_rng(20240611)
    t = np.linspace(0.0, 2 * np.pi, n_vertices, endpoint=False)
    rings = []
    for k in range(n_layers):
        for r in range(10):
            if kind == "disjoint":
                cx, cy, rad, sign = (r % 5) * 12000, (r // 5) * 12000, 4000, 1
            elif kind == "holes":
                cx, cy = (r // 2 % 5) * 12000, (r // 10) * 12000
                rad, sign = (4000, 1) if r % 2 == 0 else (2000, -1)
            else:  # nested rings alternating orientation: islands in holes
                cx, cy, rad, sign = 0, 0, 5000 - 450 * r, 1 if r % 2 == 0 else -1
            rad *= 1 + 0.04 * np.sin(7 * t + k + rng.uniform(0, 1))
            ring = np.c_[cx + rad * np.cos(t), cy + sign * rad * np.sin(t)]
            rings.append(np.rint(ring).astype(np.int64))
    n = n_layers * 10
    return vs.LayerPaths(
        np.concatenate(rings),
        np.arange(0, n * n_vertices + 1, n_vertices, dtype=np.int64),
        np.arange(0, n + 1, 10, dtype=np.int64),
    )


EXPECTED_PARTS = {"disjoint": 10, "holes": 5, "islands": 5}


@pytest.fixture(
    scope="module",
    params=[(kind, *size) for kind in EXPECTED_PARTS for size in SIZES],
    ids=lambda p: f"{p[0]}-{p[1]}x10x{p[2]}",
)
def layers(request):
    kind, n_layers, n_vertices = request.param
    loops = _layers(kind, n_layers, n_vertices)
    vs.make_parts(_layers(kind, 2, 8))  # warm up numba kernels (ring_area2)
    return kind, loops


def _rounds(loops: vs.LayerPaths) -> dict[str, int]:
    big = loops.coords.shape[0] > 1_000_000
    return {"rounds": 3 if big else 10, "iterations": 1, "warmup_rounds": 0}


@pytest.mark.benchmark(group="make_parts")
def test_make_parts(benchmark, layers):
    kind, loops = layers
    benchmark.extra_info["vertices"] = int(loops.coords.shape[0])
    parts = benchmark.pedantic(vs.make_parts, args=(loops,), **_rounds(loops))
    per_layer = np.diff(parts.layer_offsets)
    assert (per_layer == EXPECTED_PARTS[kind]).all()  # fast and wrong is no result
    assert parts.ring_offsets.shape[0] - 1 == loops.n_rings


@pytest.mark.benchmark(group="make_parts")
def test_manifold_only(benchmark, layers):
    _, loops = layers
    benchmark.extra_info["vertices"] = int(loops.coords.shape[0])

    def run():
        f = loops.coords.astype(np.float64)
        ro, lo = loops.ring_offsets.tolist(), loops.layer_offsets.tolist()
        rings = [f[a:b] for a, b in itertools.pairwise(ro)]
        rule = manifold3d.FillRule.NonZero
        return [
            manifold3d.CrossSection(rings[lo[k] : lo[k + 1]], rule).to_polygons()
            for k in range(len(lo) - 1)
        ]

    out = benchmark.pedantic(run, **_rounds(loops))
    assert sum(map(len, out)) == loops.n_rings

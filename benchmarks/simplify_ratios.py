"""Print vertices/s of vs.simplify, clipper2, shapely and manifold3d on noisy circles,
and of vs.simplify and clipper2 on the raw loops of five 3DBenchy copies at 0.1 mm.

Run: ``python benchmarks/simplify_ratios.py`` (best of ``--repeat`` runs each;
``--no-mesh`` skips the real-mesh input, which takes a few seconds to slice). Each
library starts from its natural input (vecslice ragged int64 arrays, clipper2 a list
of rings, shapely and manifold3d float64 rings) and builds its structures inside the
timing.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path[:0] = [str(Path(__file__).parent), str(Path(__file__).parents[1])]

import clipper2  # noqa: E402
import manifold3d  # noqa: E402
import numba  # noqa: E402
import numpy as np  # noqa: E402
import shapely  # noqa: E402

from _simplify_data import (  # noqa: E402
    MAX_DEVIATION,
    as_ring_list,
    benchy_loops,
    noisy_circles,
    vecslice_simplify,
)


def best_of(fn, repeat):
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rings", type=int, default=1000)
    ap.add_argument("--verts", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--no-mesh", action="store_true")
    args = ap.parse_args()
    coords, offsets = noisy_circles(args.rings, args.verts)
    rings = as_ring_list(coords, offsets)
    frings = [r.astype(np.float64) for r in rings]  # shapely's, manifold3d's input
    eps = float(MAX_DEVIATION)
    vecslice_simplify(coords, offsets)  # warm the JIT
    # each library from its natural input, building its structures in the timing
    runs = {
        "vecslice": lambda: vecslice_simplify(coords, offsets),
        "clipper2": lambda: clipper2.simplify_paths(rings, eps, True),
        "shapely": lambda: shapely.simplify(shapely.polygons(frings), eps),
        "manifold3d": lambda: manifold3d.CrossSection(frings).simplify(eps),
    }
    n = coords.shape[0]
    print(f"{args.rings} noisy circles x {args.verts} vertices = {n} vertices; "
          f"numba threads {numba.get_num_threads()}")
    rate = {}
    for name, fn in runs.items():
        t = best_of(fn, args.repeat)
        rate[name] = n / t
        print(f"{name:>11}: {t * 1e3:9.1f} ms  {rate[name] / 1e6:8.2f} M vertices/s")
    print(f"ratio vecslice/clipper2 = {rate['vecslice'] / rate['clipper2']:.3f}")
    if not args.no_mesh:
        mesh_ratio(args.repeat)


def mesh_ratio(repeat: int) -> None:
    """vs.simplify against clipper2 on the raw loops of five Benchies at 0.1 mm."""
    coords, offsets = benchy_loops(5)
    rings = as_ring_list(coords, offsets)
    vecslice_simplify(coords, offsets)
    runs = {
        "vecslice": lambda: vecslice_simplify(coords, offsets),
        "clipper2": lambda: clipper2.simplify_paths(rings, float(MAX_DEVIATION), True),
    }
    n = coords.shape[0]
    print(f"raw loops of 5 Benchies at 0.1 mm: {len(rings)} rings, {n} vertices")
    rate = {}
    for name, fn in runs.items():
        t = best_of(fn, repeat)
        rate[name] = n / t
        print(f"{name:>11}: {t * 1e3:9.1f} ms  {rate[name] / 1e6:8.2f} M vertices/s")
    print(f"ratio vecslice/clipper2 = {rate['vecslice'] / rate['clipper2']:.3f}")


if __name__ == "__main__":
    main()

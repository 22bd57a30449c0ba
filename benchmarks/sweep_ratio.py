"""A 12-combination XY sweep (vs.sweep, metrics included) against 12 separate
``slice_mesh`` calls, on the reference workload (five 3DBenchy copies, 0.1 mm).

Runs alternate (sweep, 12 calls, sweep, ...) so that load on a shared machine
hits both alike; prints each run's wall and CPU time and the ratio of the best.
``python benchmarks/sweep_ratio.py [copies] [rounds]``
"""

from __future__ import annotations

import sys
import time

import numba

import vecslice as vs
from _workloads import plate

GRID = {"max_resolution": [250, 500, 1000, 2000], "max_deviation": [10, 25, 50]}


def combos() -> list[vs.SliceSettings]:
    return [vs.SliceSettings(max_resolution=r, max_deviation=d)
            for r in GRID["max_resolution"] for d in GRID["max_deviation"]]


def separate(mesh: vs.Mesh) -> None:
    for s in combos():
        vs.slice_mesh(mesh, s)


def swept(mesh: vs.Mesh) -> object:
    return vs.sweep({"plate": mesh}, GRID)


def timed(fn, *args) -> tuple[float, float]:
    w, c = time.perf_counter(), time.process_time()
    fn(*args)
    return time.perf_counter() - w, time.process_time() - c


def main() -> None:
    copies = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    mesh = plate(copies)
    swept(vs.demo_mesh())  # JIT caches and dask outside the timing
    separate(vs.demo_mesh())
    best = {"sweep": (1e9, 1e9), "slice_mesh x12": (1e9, 1e9)}
    for _ in range(rounds):
        for name, fn in (("sweep", swept), ("slice_mesh x12", separate)):
            w, c = timed(fn, mesh)
            print(f"{name:15s} wall {w:6.2f} s  cpu {c:6.2f} s", flush=True)
            best[name] = (min(best[name][0], w), min(best[name][1], c))
    (sw, sc), (pw, pc) = best["sweep"], best["slice_mesh x12"]
    print(f"{copies} Benchies, {mesh.n_faces} faces, threads "
          f"{numba.get_num_threads()}: sweep / 12 slice_mesh = {sw / pw:.2f} (wall), "
          f"{sc / pc:.2f} (cpu)")


if __name__ == "__main__":
    main()

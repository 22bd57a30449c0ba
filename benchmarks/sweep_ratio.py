"""A 12-combination XY sweep (vs.sweep, metrics included) against 12 separate
``slice_mesh`` calls, on the reference workload (five 3DBenchy copies, 0.1 mm).

Two baselines, because "separate calls" can start from two places:

* **one Mesh**: the 12 calls share one ``vs.Mesh``, so they share its cached
  topology (built once per mesh) and redo only the contours, simplify and parts;
  the sweep gets the same ``Mesh``.
* **from arrays** (the convention of ``benchmarks/report.py``: vecslice timed from
  ``Mesh.from_arrays`` of the int64 arrays): every call builds its own ``Mesh``
  (vertex merge, checks, topology) as an independent call does; the sweep builds
  one, inside its timing.

Runs alternate (sweep, 12 calls, ...) so that load on a shared machine hits all
alike; prints each run's wall and CPU time and, per baseline, the ratio of the
medians with the range of the per-round ratios.
``python benchmarks/sweep_ratio.py [copies] [rounds]``
"""

from __future__ import annotations

import statistics
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


def separate_from_arrays(v, f) -> None:
    for s in combos():
        vs.slice_mesh(vs.Mesh.from_arrays(v, f), s)


def swept_from_arrays(v, f) -> object:
    return vs.sweep({"plate": vs.Mesh.from_arrays(v, f)}, GRID)


def timed(fn, *args) -> tuple[float, float]:
    w, c = time.perf_counter(), time.process_time()
    fn(*args)
    return time.perf_counter() - w, time.process_time() - c


def main() -> None:
    copies = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    mesh = plate(copies)
    v, f = mesh.vertices.copy(), mesh.faces.copy()
    swept(vs.demo_mesh())  # JIT caches and dask outside the timing
    separate(vs.demo_mesh())
    runs = [("sweep", swept, (mesh,)), ("slice_mesh x12", separate, (mesh,)),
            ("sweep, from arrays", swept_from_arrays, (v, f)),
            ("slice_mesh x12, from arrays", separate_from_arrays, (v, f))]
    wall: dict[str, list[float]] = {name: [] for name, _, _ in runs}
    cpu: dict[str, list[float]] = {name: [] for name, _, _ in runs}
    for _ in range(rounds):
        for name, fn, args in runs:
            w, c = timed(fn, *args)
            print(f"{name:28s} wall {w:6.2f} s  cpu {c:6.2f} s", flush=True)
            wall[name].append(w)
            cpu[name].append(c)
    print(f"{copies} Benchies, {mesh.n_faces} faces, numba threads "
          f"{numba.get_num_threads()}, {rounds} rounds:")
    for label, a, b in (("one Mesh", "sweep", "slice_mesh x12"),
                        ("from arrays", "sweep, from arrays",
                         "slice_mesh x12, from arrays")):
        per = [x / y for x, y in zip(wall[a], wall[b], strict=True)]
        print(f"  {label:12s} sweep / 12 slice_mesh = "
              f"{statistics.median(wall[a]) / statistics.median(wall[b]):.2f} wall "
              f"(rounds {min(per):.2f}-{max(per):.2f}), "
              f"{statistics.median(cpu[a]) / statistics.median(cpu[b]):.2f} cpu")


if __name__ == "__main__":
    main()

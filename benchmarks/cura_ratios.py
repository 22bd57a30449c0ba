"""Print slice_mesh's time with compat="cura" against the default mode.

Usage: python benchmarks/cura_ratios.py [--copies 5] [--repeats 5]

Default: ``slice_mesh(plate(copies))`` with Cura's default settings. Compat: the
same triangles melded the way CuraEngine loads them (see ``bench_cura.py``), sliced
with ``SliceSettings(compat="cura")``; and, for reference, the compat settings on
the default mesh. Runs are interleaved (default, compat, compat on the default
mesh, repeated) so machine load hits all alike; the best and the median of each
are printed with the per-stage split of the best compat run.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_cura import CURA, warm_up  # noqa: E402

import vecslice as vs  # noqa: E402
from _workloads import plate  # noqa: E402
from vecslice.cura_stl import cura_mesh_from_corners  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    mesh = plate(args.copies)
    cura = cura_mesh_from_corners(mesh.vertices[mesh.faces].reshape(-1, 3), "plate")
    warm_up()
    runs = {"default": (mesh, vs.SliceSettings()), "compat": (cura, CURA),
            "compat, default mesh": (mesh, CURA)}
    seconds: dict[str, list[float]] = {k: [] for k in runs}
    stages: dict[str, vs.StageTimes] = {}
    for _ in range(args.repeats):
        for name, (m, s) in runs.items():
            times = vs.StageTimes()
            t = time.perf_counter()
            vs.slice_mesh(m, s, times=times)
            t = time.perf_counter() - t
            if not seconds[name] or t < min(seconds[name]):
                stages[name] = times
            seconds[name].append(t)
    print(f"mesh: {args.copies} x 3DBenchy, default {mesh.n_faces:,} faces, "
          f"CuraEngine's melding {cura.n_faces:,} faces")
    med = {k: statistics.median(v) for k, v in seconds.items()}
    for name, ts in seconds.items():
        print(f"{name:22s}: best {min(ts):6.3f} s, median {med[name]:6.3f} s"
              f"  ({stages[name]})")
    for name in ("compat", "compat, default mesh"):
        best = min(seconds[name]) / min(seconds["default"])
        print(f"ratio {name} / default: best {best:.2f}, "
              f"median {med[name] / med['default']:.2f}")


if __name__ == "__main__":
    main()

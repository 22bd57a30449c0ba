"""Print what the adaptive schedule costs beside slicing at its heights, in one run.

Usage: python benchmarks/layers_ratios.py [--copies 5] [--repeat 7]

Times ``vs.layer_heights`` with ``adaptive_layers=True`` (CuraEngine's defaults)
and ``vs.slice_contours`` at the heights it returns, on ``copies`` 3DBenchy side by
side, interleaved and repeated (best of ``repeat`` each), after one warm-up call
of both. Target (issue 9): the schedule costs at most a quarter of the contours.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numba
import numpy as np

import vecslice as vs
from _workloads import plate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    mesh = plate(args.copies)
    settings = vs.SliceSettings(adaptive_layers=True)
    z, _, thickness = vs.layer_heights(mesh, settings)
    vs.slice_contours(mesh, z)
    t_layers, t_contours = [], []
    for _ in range(args.repeat):  # interleaved, so load changes hit both alike
        t = time.perf_counter()
        vs.layer_heights(mesh, settings)
        t_layers.append(time.perf_counter() - t)
        t = time.perf_counter()
        vs.slice_contours(mesh, z)
        t_contours.append(time.perf_counter() - t)
    a, b = min(t_layers), min(t_contours)
    counts = np.unique(thickness[1:], return_counts=True)
    common = counts[0][np.argsort(-counts[1])[:3]].tolist()
    print(f"mesh: {args.copies} x 3DBenchy, {mesh.n_faces:,} faces; adaptive schedule "
          f"{len(z)} layers (most common thicknesses {common} µm); numba threads "
          f"{numba.get_num_threads()}")
    print(f"adaptive layer_heights      : {a:8.3f} s")
    print(f"slice_contours at its z     : {b:8.3f} s")
    print(f"ratio schedule / contours   : {a / b:8.3f}   (target <= 0.25)")


if __name__ == "__main__":
    main()

"""Where the time of the reference workload goes: a pyinstrument profile.

Usage: ``python benchmarks/profile_slicing.py [--copies 5] [--repeat 3]``

Profiles ``Mesh.from_arrays`` of int64 µm arrays, ``slice_contours`` of the fresh
mesh (topology built), a second ``slice_contours`` at other heights (topology
reused) and ``slice_mesh``, on ``copies`` 3DBenchy side by side at 0.1 mm layers,
and prints pyinstrument's call tree (numba kernels show as the Python function that
calls them). Needs the ``bench`` extra.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]

from pyinstrument import Profiler  # noqa: E402

import vecslice as vs  # noqa: E402
from _workloads import heights, plate  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    mesh = plate(args.copies)
    z = heights(mesh)
    v, f = mesh.vertices.copy(), mesh.faces.copy()
    vs.slice_mesh(vs.Mesh.from_arrays(v, f))  # JIT caches loaded outside the profile
    profiler = Profiler(interval=0.0005)
    profiler.start()
    for _ in range(args.repeat):
        fresh = vs.Mesh.from_arrays(v, f)
        vs.slice_contours(fresh, z)
        vs.slice_contours(fresh, z + 50)
        vs.slice_mesh(fresh)
    profiler.stop()
    print(profiler.output_text(unicode=False, color=False))


if __name__ == "__main__":
    main()

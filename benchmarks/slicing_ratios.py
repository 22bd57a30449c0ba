"""Print how much faster slice_contours is than manifold3d and trimesh, in one run.

Usage: python benchmarks/slicing_ratios.py [--copies 5] [--no-trimesh]

Times each library on the same mesh (``copies`` 3DBenchy side by side) and the same
0.1 mm heights: vecslice from the int64 µm arrays (``Mesh.from_arrays``, which merges
vertices and whose first slice builds the topology, then ``slice_contours``; best of
5), manifold3d building its Manifold and slicing every height (best of 3), trimesh
section_multiplane (once; it is slow). Then times vecslice on twice the copies to
show how the time scales. A quick look, not interleaved: ``benchmarks/report.py``
prints the README's table (interleaved repeats, medians and ranges, MeshLib too).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numba

import vecslice as vs
from _workloads import (
    heights,
    manifold_slices,
    plate,
    trimesh_sections,
    vecslice_contours,
)


def best(fn, *args, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn(*args)
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=5)
    ap.add_argument("--no-trimesh", action="store_true")
    args = ap.parse_args()
    mesh = plate(args.copies)
    z = heights(mesh)
    vs.slice_contours(mesh, z[:2])
    loops = vs.slice_contours(mesh, z)
    print(f"mesh: {args.copies} x 3DBenchy, {mesh.n_faces:,} faces, {len(z)} layers, "
          f"{loops.coords.shape[0]:,} crossings, numba threads "
          f"{numba.get_num_threads()}")
    v, f = mesh.vertices.copy(), mesh.faces.copy()  # a new Mesh in every call
    t_vs = best(vecslice_contours, v, f, z, repeat=5)
    t_mf = best(manifold_slices, mesh, z, repeat=3)
    print(f"vecslice from arrays    : {t_vs:8.3f} s")
    print(f"manifold3d build+slice  : {t_mf:8.3f} s   ratio {t_mf / t_vs:6.1f}x")
    if not args.no_trimesh:
        t_tm = best(trimesh_sections, mesh, z, repeat=1)
        print(f"trimesh multiplane      : {t_tm:8.3f} s   ratio {t_tm / t_vs:6.1f}x")
    double = plate(2 * args.copies)
    v2, f2 = double.vertices.copy(), double.faces.copy()
    t_2 = best(vecslice_contours, v2, f2, z, repeat=3)
    print(f"vecslice on {2 * args.copies} copies    : {t_2:8.3f} s   "
          f"{t_2 / t_vs:.2f}x the time for 2x the work")


if __name__ == "__main__":
    main()

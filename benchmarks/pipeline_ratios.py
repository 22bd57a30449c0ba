"""Print the full slice_mesh time against manifold3d's slicing alone, per stage.

Usage: python benchmarks/pipeline_ratios.py [--copies 5]

Same mesh (``copies`` 3DBenchy side by side), same 0.1 mm heights, one run: vecslice
slice_mesh with Cura's default settings from the int64 µm arrays (``Mesh.from_arrays``
inside the timing, as ``benchmarks/report.py`` times it; best of 3, stages timed;
the stages do not include building the Mesh) and manifold3d
building its Manifold and slicing every height (best of 3). Then the peak memory
of slice_mesh, measured in a fresh process (holding only the mesh) as the growth
of its peak RSS (Linux: VmHWM after resetting it).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

import vecslice as vs  # noqa: E402
from _workloads import heights, manifold_slices, plate  # noqa: E402

_PEAK = """
import numpy as np
import vecslice as vs

def hwm():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM"):
            return int(line.split()[1])

def rss():
    for line in open("/proc/self/status"):
        if line.startswith("VmRSS"):
            return int(line.split()[1])

vs.slice_mesh(vs.demo_mesh())  # JIT caches loaded
arrays = np.load({path!r})
# already merged and valid: wrap without from_arrays' merge, whose own peak
# would hide the slicer's
mesh = vs.Mesh._trusted(arrays["vertices"], arrays["faces"], None)
with open("/proc/self/clear_refs", "w") as f:
    f.write("5")  # reset the peak (VmHWM) to the current RSS
before = rss()
model = vs.slice_mesh(mesh)
print(before, hwm(), model.nbytes, model.coords.shape[0])
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=5)
    args = ap.parse_args()
    mesh = plate(args.copies)
    z = heights(mesh)
    vs.slice_mesh(vs.demo_mesh())
    best: vs.StageTimes | None = None
    total = float("inf")
    for _ in range(3):
        times = vs.StageTimes()
        v, f = mesh.vertices.copy(), mesh.faces.copy()
        t = time.perf_counter()
        model = vs.slice_mesh(vs.Mesh.from_arrays(v, f), times=times)
        t = time.perf_counter() - t
        if t < total:
            total, best = t, times
    t_mf = float("inf")
    for _ in range(3):
        t = time.perf_counter()
        manifold_slices(mesh, z)
        t_mf = min(t_mf, time.perf_counter() - t)
    print(f"mesh: {args.copies} x 3DBenchy, {mesh.n_faces:,} faces, {len(z)} layers")
    print(f"vecslice from arrays     : {total:7.3f} s  (slice_mesh: {best})")
    print(f"manifold3d build+slice   : {t_mf:7.3f} s")
    print(f"ratio manifold3d / vecslice: {t_mf / total:.2f}x")
    print(f"model: {model}, {model.nbytes / model.coords.shape[0]:.2f} bytes/vertex")
    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / "plate.npz")
        np.savez(path, vertices=mesh.vertices, faces=mesh.faces)
        out = subprocess.run([sys.executable, "-c", _PEAK.format(path=path)],
                             capture_output=True, text=True, check=True).stdout.split()
    before, after = int(out[0]), int(out[1])
    print(f"peak RSS growth of slice_mesh: {(after - before) / 1024:.0f} MiB "
          f"(process peak {after / 1024:.0f} MiB)")


if __name__ == "__main__":
    main()

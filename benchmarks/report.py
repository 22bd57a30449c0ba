"""Measure vecslice against its peers and print the README's performance table.

Usage: ``python benchmarks/report.py`` (about 5 minutes on a quiet 2-core machine;
``--repeat``, ``--copies``; ``--quick`` for a one-repeat smoke run on one copy).

Every library gets its natural input and builds its own structures inside the
timing: vecslice ``Mesh.from_arrays`` of int64 µm arrays (merge, checks, topology)
then ``slice_contours``; manifold3d a ``Manifold`` from float32 mm arrays, then
``slice`` per height; MeshLib ``meshFromFacesVerts`` from float32 mm arrays, then
``extractXYPlaneSections`` + ``planeSectionsToContours2f`` per height; trimesh a
``Trimesh`` from float64 mm arrays, then ``section_multiplane``. Same mesh (copies
of 3DBenchy side by side), same 0.1 mm heights. manifold3d's ``slice`` does more
than raw contours: it unions each layer's polygons (Clipper2, positive fill), as
the rows say. Before anything is timed, every peer's sections are checked against
vecslice's (contours and area per layer, ``_agree.py``); no table is printed if
they disagree.

The libraries are interleaved within each repeat (so a change of machine load hits
all of them alike); ratios are taken within a repeat and reported as the median
with the range over repeats (a repeat of the scaling row is each size's median
over ``SCALING_ROUNDS`` interleaved rounds, and one of the second-slice row the
medians of ``SLICE_ROUNDS`` first and second slices, each pair on a new
``Mesh``). The table ends with the machine, its
load while measuring, the thread pools each library started and the CPU time / wall
time each used (its effective parallelism), and the library versions. Notes
under the table split the scaling row's CPU time into user and system time, and
give the same sizes sliced once each in a fresh process, where no call can reuse
memory that an earlier one freed.
"""

from __future__ import annotations

import argparse
import datetime
import itertools
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from importlib import metadata
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]

import numba  # noqa: E402
import numpy as np  # noqa: E402
from _agree import check_agreement  # noqa: E402

import vecslice as vs  # noqa: E402
from _simplify_data import (  # noqa: E402
    MAX_DEVIATION,
    as_ring_list,
    noisy_circles,
    vecslice_simplify,
)
from _workloads import (  # noqa: E402
    benchy,
    heights,
    manifold_build_slice,
    meshlib_build_slice,
    mm_arrays,
    plate,
    trimesh_build_sections,
    vecslice_contours,
)

_PEAK = """
import sys
import numpy as np
import vecslice as vs

def status(key):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1]) * 1024

a = np.load(sys.argv[1])
v, f, z = a["vertices"], a["faces"], a["z"]
vs.slice_contours(vs.Mesh.from_arrays(v[:3], np.array([[0, 1, 2]])), z[:1])  # JIT
mesh = vs.Mesh.from_arrays(v, f)
with open("/proc/self/clear_refs", "w") as fh:
    fh.write("5")  # reset the peak (VmHWM) to the current RSS
before = status("VmRSS")
loops = vs.slice_contours(mesh, z)
peak = status("VmHWM")
out = sum(x.nbytes for x in (loops.coords, loops.ring_offsets, loops.layer_offsets,
                             loops.open.coords, loops.open.ring_offsets,
                             loops.open.layer_offsets))
print(peak - before, mesh.vertices.nbytes + mesh.faces.nbytes, out)
"""

_FRESH = """
import resource
import sys
import time
import numpy as np
import vecslice as vs
from vecslice._threads import run_chunks

a = np.load(sys.argv[1])
v, f, z = a["vertices"], a["faces"], a["z"]
vs.slice_contours(vs.Mesh.from_arrays(v[:3], np.array([[0, 1, 2]])), z[:1])  # JIT
run_chunks(lambda lo, hi: None, [0, 1, 2, 3, 4])  # the worker threads started
r = resource.getrusage(resource.RUSAGE_SELF).ru_stime
t = time.perf_counter()
vs.slice_contours(vs.Mesh.from_arrays(v, f), z)
wall = time.perf_counter() - t
print(wall, resource.getrusage(resource.RUSAGE_SELF).ru_stime - r)
"""


class Timer:
    """Wall and CPU seconds of one call."""

    def __call__(self, fn, *args):
        c = time.process_time()
        t = time.perf_counter()
        out = fn(*args)
        wall = time.perf_counter() - t
        cpu = time.process_time() - c
        return out, wall, cpu


def _os_threads() -> int:
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return threading.active_count()


class Series:
    """Repeated measurements of one thing: wall times and CPU times."""

    def __init__(self) -> None:
        self.wall: list[float] = []
        self.cpu: list[float] = []

    def add(self, timer: Timer, fn, *args):
        out, wall, cpu = timer(fn, *args)
        self.record(timer, wall, cpu)
        return out

    def record(self, timer: Timer, wall: float, cpu: float) -> None:
        """One sample: wall and CPU seconds."""
        self.wall.append(wall)
        self.cpu.append(cpu)

    @property
    def median(self) -> float:
        return statistics.median(self.wall)

    @property
    def parallelism(self) -> float:
        return sum(self.cpu) / sum(self.wall)


SCALING_ROUNDS = 3  # rounds of the three sizes per repeat of the scaling row
SLICE_ROUNDS = 3  # first/second slice pairs per repeat of the second-slice row


def scaling_repeat(timer: Timer, S: dict[str, Series], size_arrays: dict,
                   split: dict[int, list[tuple[float, float]]]) -> None:
    """One repeat of the scaling row: each size's median over interleaved rounds.

    A run of 2 copies takes a twentieth of a second, so one call per size and
    repeat leaves the step ratios at the mercy of a moment's memory traffic on
    the machine; ``SCALING_ROUNDS`` rounds of (2, 4, 8 copies), each size's median
    taken, give the repeat's sample (the same for every size). Every call's user
    and system CPU seconds go to ``split[copies]`` (see :func:`scaling_note`).
    """
    walls: dict[int, list[float]] = {c: [] for c in size_arrays}
    cpus: dict[int, list[float]] = {c: [] for c in size_arrays}
    for _ in range(SCALING_ROUNDS):
        for c, (v, faces, zc) in size_arrays.items():
            r0 = resource.getrusage(resource.RUSAGE_SELF)
            _, wall, cpu = timer(vecslice_contours, v, faces, zc)
            r1 = resource.getrusage(resource.RUSAGE_SELF)
            walls[c].append(wall)
            cpus[c].append(cpu)
            split[c].append((r1.ru_utime - r0.ru_utime, r1.ru_stime - r0.ru_stime))
    for c in size_arrays:
        S[f"s{c}"].record(timer, statistics.median(walls[c]),
                          statistics.median(cpus[c]))


def _system_ms(times: dict[int, list[tuple[float, float]]]) -> str:
    """Each size's median system time in ms, in order of size: "3, 22.2, 150"."""
    return ", ".join(f"{1e3 * statistics.median(s for _, s in times[c]):.3g}"
                     for c in sorted(times))


def scaling_note(split: dict[int, list[tuple[float, float]]]) -> str:
    """The scaling row's CPU time per call split into user and system time.

    Medians over all calls of each size. The system time is mostly the kernel
    handing the process memory it has not used before (zeroed pages: most of the
    kernel's samples in ``perf`` are ``clear_page``), which can grow faster than
    the work (arrays past glibc's 32 MiB mmap threshold are mapped afresh on every
    call, and on a virtual machine fresh memory may cost more per MB the more of
    it a call takes); it shows a reader how much of a scaling step is the
    memory's.
    """
    sizes = sorted(split)
    user = ", ".join(f"{statistics.median(u for u, _ in split[c]):.3g}" for c in sizes)
    system = _system_ms(split)
    names = ", ".join(str(c) for c in sizes[:-1]) + f" and {sizes[-1]}"
    return (f"Scaling row, CPU time per call (medians) at {names} copies: user "
            f"{user} s, system {system} ms (mostly the kernel zeroing memory new "
            "to the process).")


def ratio(a: Series, b: Series) -> tuple[float, float, float]:
    """Median and range of b/a over the repeats (each repeat's pair interleaved)."""
    r = [y / x for x, y in zip(a.wall, b.wall)]
    return statistics.median(r), min(r), max(r)


def fmt_s(s: Series) -> str:
    return f"{s.median:.3g} s"


def fmt_ratio(r: tuple[float, float, float]) -> str:
    return f"{r[0]:.3g}× ({r[1]:.3g}–{r[2]:.3g})"


def _load() -> str:
    try:
        return ", ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "not installed"


@numba.njit(parallel=True, nogil=True, cache=True)
def _floor_pass(vertices, faces, vert_layer, face_offsets, z, out):
    """The floor: one bare parallel pass over faces computing every segment's
    point (its start crossing, rounded as vecslice rounds it), no linking."""
    for f in numba.prange(faces.shape[0]):
        l0 = vert_layer[faces[f, 0]]
        l1 = vert_layer[faces[f, 1]]
        l2 = vert_layer[faces[f, 2]]
        lo = min(l0, l1, l2)
        for s in range(face_offsets[f], face_offsets[f + 1]):
            k = lo + s - face_offsets[f]
            code = (1 if k < l0 else 0) + (2 if k < l1 else 0) + (4 if k < l2 else 0)
            j = (0, 0, 1, 1, 2, 0, 2, 0)[code]
            p = faces[f, j]
            q = faces[f, (j + 1) % 3]
            if vertices[p, 2] > vertices[q, 2]:
                p, q = q, p
            t = z[k] - vertices[p, 2]
            dz = vertices[q, 2] - vertices[p, 2]
            for c in range(2):
                num = (vertices[q, c] - vertices[p, c]) * t
                r = num // dz
                r2 = 2 * (num - r * dz)
                if r2 > dz or (r2 == dz and num >= 0):
                    r += 1
                out[s, c] = vertices[p, c] + r


def floor_inputs(mesh: vs.Mesh, z: np.ndarray):
    vl = np.searchsorted(z, mesh.vertices[:, 2]).astype(np.int64)
    fl = vl[mesh.faces]
    offsets = np.zeros(mesh.n_faces + 1, dtype=np.int64)
    np.cumsum(fl.max(axis=1) - fl.min(axis=1), out=offsets[1:])
    out = np.empty((int(offsets[-1]), 2), dtype=np.int64)
    return mesh.vertices, mesh.faces, vl, offsets, z, out


def measure(args) -> tuple[list[tuple[str, str, str, str]], list[str]]:
    timer = Timer()
    load_start = _load()
    five = plate(args.copies)
    z = heights(five)
    z_mm = z / 1000.0
    v_um, f = five.vertices.copy(), five.faces.copy()
    v32, f32 = mm_arrays(five)
    one = benchy()
    z1 = heights(one)
    v1_um, f1 = one.vertices.copy(), one.faces.copy()
    v1_64, f1_64 = mm_arrays(one, np.float64)
    circles = noisy_circles()
    circle_rings = as_ring_list(*circles)
    sizes = {c: plate(c) for c in (2, 4, 8)} if not args.quick else {}
    size_arrays = {c: (m.vertices.copy(), m.faces.copy(), heights(m))
                   for c, m in sizes.items()}

    import clipper2

    def full_slice(v, faces):
        return vs.slice_mesh(vs.Mesh.from_arrays(v, faces))

    def first_and_second(v, faces):
        """Medians of SLICE_ROUNDS first and second slices, each pair on a new Mesh."""
        firsts, seconds = [], []
        for _ in range(SLICE_ROUNDS):
            mesh = vs.Mesh.from_arrays(v, faces)
            t = time.perf_counter()
            vs.slice_contours(mesh, z)
            firsts.append(time.perf_counter() - t)
            t = time.perf_counter()
            vs.slice_contours(mesh, z + 50)  # other heights, same mesh
            seconds.append(time.perf_counter() - t)
            del mesh
        return statistics.median(firsts), statistics.median(seconds)

    eps = float(MAX_DEVIATION)
    # warm-up: JIT caches and lazy imports, and the thread pools each starts
    pools = {}
    for name, fn, fargs in [
        ("vecslice", vecslice_contours, (v1_um, f1, z1)),
        ("manifold3d", manifold_build_slice, (mm_arrays(one)[0], f1, z1 / 1000.0)),
        ("MeshLib", meshlib_build_slice, (mm_arrays(one)[0], f1, z1 / 1000.0)),
        ("trimesh", trimesh_build_sections, (v1_64, f1_64, z1[:5] / 1000.0)),
        ("clipper2", clipper2.simplify_paths, (circle_rings[:10], eps, True)),
    ]:
        before = _os_threads()
        fn(*fargs)
        pools[name] = _os_threads() - before
    agreement = check_agreement(five, one, trimesh=not args.no_trimesh)
    full_slice(v1_um, f1)
    vecslice_simplify(*circles)
    floor_args = floor_inputs(five, z)
    _floor_pass(*floor_args)
    raw = vecslice_contours(v_um, f, z).paths()
    raw_loops = (np.ascontiguousarray(raw.coords),
                 np.ascontiguousarray(raw.ring_offsets))
    raw_rings = as_ring_list(*raw_loops)

    S = {k: Series() for k in (
        "vs", "mf", "ml", "vs1", "tm", "full", "mf_full", "first", "second",
        "simp_c", "clip_c", "simp_b", "clip_b", "s2", "s4", "s8", "floor")}
    seconds: dict[str, list[float]] = {"first": [], "second": []}
    split: dict[int, list[tuple[float, float]]] = {c: [] for c in size_arrays}
    for rep in range(args.repeat):
        print(f"repeat {rep + 1}/{args.repeat} (load {_load()})", file=sys.stderr)
        S["vs"].add(timer, vecslice_contours, v_um, f, z)
        S["floor"].add(timer, _floor_pass, *floor_args)
        S["mf"].add(timer, manifold_build_slice, v32, f32, z_mm)
        S["ml"].add(timer, meshlib_build_slice, v32, f32, z_mm)
        S["full"].add(timer, full_slice, v_um, f)
        S["mf_full"].add(timer, manifold_build_slice, v32, f32, z_mm)
        a, b = first_and_second(v_um, f)
        seconds["first"].append(a)
        seconds["second"].append(b)
        S["simp_c"].add(timer, vecslice_simplify, *circles)
        S["clip_c"].add(timer, clipper2.simplify_paths, circle_rings, eps, True)
        S["simp_b"].add(timer, vecslice_simplify, *raw_loops)
        S["clip_b"].add(timer, clipper2.simplify_paths, raw_rings, eps, True)
        scaling_repeat(timer, S, size_arrays, split)
        if not args.no_trimesh and rep < args.trimesh_repeat:
            S["vs1"].add(timer, vecslice_contours, v1_um, f1, z1)
            S["tm"].add(timer, trimesh_build_sections, v1_64, f1_64, z1 / 1000.0)
    fresh = fresh_rounds(size_arrays, args.repeat) if size_arrays else {}
    S["first"].wall = seconds["first"]
    S["second"].wall = seconds["second"]

    n_faces = f.shape[0]
    rows = [
        ("raw contours, from arrays (`Mesh.from_arrays` + `slice_contours`)",
         fmt_s(S["vs"]),
         f"manifold3d build + `slice` (unions each layer) {fmt_s(S['mf'])}",
         fmt_ratio(ratio(S["vs"], S["mf"]))),
        ("raw contours, from arrays", fmt_s(S["vs"]),
         f"MeshLib build + `extractXYPlaneSections` {fmt_s(S['ml'])}",
         fmt_ratio(ratio(S["vs"], S["ml"]))),
    ]
    rows.append(("floor: one bare parallel pass computing every segment's point",
                 fmt_s(S["floor"]), f"vecslice raw contours {fmt_s(S['vs'])}",
                 fmt_ratio(ratio(S["floor"], S["vs"]))))
    if S["tm"].wall:
        rows.append(("raw contours, one Benchy", fmt_s(S["vs1"]),
                     f"trimesh `section_multiplane` {fmt_s(S['tm'])}",
                     fmt_ratio(ratio(S["vs1"], S["tm"]))))
    r = ratio(S["second"], S["first"])
    rows += [
        ("second `slice_contours` of the same `Mesh` (other heights)",
         fmt_s(S["second"]), f"its first slice {fmt_s(S['first'])}",
         fmt_ratio((1 / r[0], 1 / r[2], 1 / r[1]))),
        ("full `slice_mesh` (contours, simplify, parts), from arrays",
         fmt_s(S["full"]), f"manifold3d build + `slice` {fmt_s(S['mf_full'])}",
         fmt_ratio(ratio(S["full"], S["mf_full"]))),
    ]
    for key, clip, label, n in [
        ("simp_c", "clip_c", "1,000 noisy circles × 1,000", circles[0].shape[0]),
        ("simp_b", "clip_b", "the Benchy raw loops", raw_loops[0].shape[0]),
    ]:
        rows.append((f"`simplify`, CuraEngine rules, {label}",
                     f"{n / S[key].median / 1e6:.3g} M vertices/s",
                     f"clipper2 `simplify_paths` {n / S[clip].median / 1e6:.3g} M/s",
                     fmt_ratio(ratio(S[key], S[clip]))))
    if size_arrays:
        r24 = ratio(S["s2"], S["s4"])
        r48 = ratio(S["s4"], S["s8"])
        rows.append(("time for 2× the work (2 → 4 → 8 copies)",
                     f"{fmt_s(S['s2'])} → {fmt_s(S['s4'])} → {fmt_s(S['s8'])}", "—",
                     f"{fmt_ratio(r24)} / {fmt_ratio(r48)}"))
        grow, n_in, n_out = peak_memory(*size_arrays[8])
        mib = 2.0**20
        rows.append(("peak extra memory of `slice_contours`, 8 copies",
                     f"{grow / mib:.0f} MiB",
                     f"in + out {(n_in + n_out) / mib:.0f} MiB",
                     f"{grow / (n_in + n_out):.2f}× (in + out)"))

    par = ", ".join(f"{name} {S[k].parallelism:.2f}" for name, k in [
        ("vecslice", "vs"), ("manifold3d", "mf"), ("MeshLib", "ml"),
        ("trimesh", "tm"), ("clipper2", "clip_c")] if S[k].wall)
    # vecslice's numba pool may already run (building the workload uses kernels)
    pools["vecslice"] = max(pools["vecslice"], numba.get_num_threads() - 1)
    started = ", ".join(f"{k} {v}" for k, v in pools.items())
    loops = vecslice_contours(v_um, f, z)
    what = ("one 3DBenchy" if args.copies == 1
            else f"{args.copies} × 3DBenchy side by side")
    how = [f"{args.repeat} interleaved repeat{'' if args.repeat == 1 else 's'}; "
           "times are medians, ratios the "
           "median over repeats with their range"]
    if not args.no_trimesh:  # the slow trimesh case runs in the first repeats only
        how.append(f"the trimesh row {min(args.repeat, args.trimesh_repeat)} of them")
    how.append(f"in the second-slice row a repeat is the median of {SLICE_ROUNDS} "
               "pairs, each on a new `Mesh`")
    if size_arrays:
        how.append(f"in the scaling row a repeat is the median of {SCALING_ROUNDS} "
                   "interleaved rounds of the sizes")
    scaling = (" and the scaling row (each size over the one before)"
               if size_arrays else "")
    notes = [
        "Ratios are the peer's time over vecslice's (above 1: vecslice is faster), "
        "except the floor row (vecslice over the floor), the second-slice row "
        f"(second over first slice){scaling}; simplify rates are vertices per "
        "second.",
        f"Measured {datetime.date.today().isoformat()} with `python benchmarks/"
        f"report.py{' --quick' if args.quick else ''}` ({'; '.join(how)}).",
        f"Workload: {what}, {n_faces:,} faces, "
        f"{len(z)} layers at 0.1 mm, {loops.coords.shape[0] / 1e6:.2f} M crossings.",
        f"Machine: {platform.machine()}, {os.cpu_count()} cores "
        f"({len(os.sched_getaffinity(0))} usable), load average {load_start} at the "
        f"start and {_load()} at the end (a loaded machine stretches wall times); "
        f"numba {numba.get_num_threads()} threads ({numba.threading_layer()} layer).",
        f"Worker threads each library started (besides the calling one): {started}; "
        f"CPU time / wall time while timed: {par}.",
        *([scaling_note(split), fresh_note(fresh)] if size_arrays else []),
        "Outputs checked before timing (closed contours and net area per layer "
        "against vecslice's raw loops): " + "; ".join(agreement) + ".",
        "Versions: " + ", ".join(f"{d} {_version(d)}" for d in (
            "vecslice", "numpy", "numba", "manifold3d", "meshlib", "trimesh",
            "clipper2-py")) + f", Python {platform.python_version()}.",
    ]
    return rows, notes


def _npz(folder: str, name: str, v, f, z) -> str:
    """The arrays saved to ``folder`` as ``name``.npz for a child process; its path."""
    path = str(Path(folder) / f"{name}.npz")
    np.savez(path, vertices=v, faces=f, z=z)
    return path


def _child(script: str, path: str) -> str:
    """Stdout of ``script`` run in a fresh process on the arrays saved at ``path``."""
    env = dict(os.environ, PYTHONPATH=str(HERE.parent))
    return subprocess.run([sys.executable, "-c", script, path], env=env,
                          capture_output=True, text=True, check=True).stdout


def fresh_rounds(size_arrays: dict,
                 rounds: int) -> dict[int, list[tuple[float, float]]]:
    """Wall and system seconds of ``Mesh.from_arrays`` + ``slice_contours`` of
    each size as the first call of a fresh process, in ``rounds`` rounds of the
    sizes (kernels loaded and worker threads started before the call, and no
    memory that an earlier call of the process freed to reuse)."""
    fresh: dict[int, list[tuple[float, float]]] = {c: [] for c in size_arrays}
    with tempfile.TemporaryDirectory() as tmp:
        paths = {c: _npz(tmp, f"copies_{c}", *arrays)
                 for c, arrays in size_arrays.items()}
        for rep in range(rounds):
            print(f"fresh processes, round {rep + 1}/{rounds}", file=sys.stderr)
            for c, path in paths.items():
                wall, system = (float(x) for x in _child(_FRESH, path).split())
                fresh[c].append((wall, system))
    return fresh


def fresh_note(fresh: dict[int, list[tuple[float, float]]]) -> str:
    """The scaling row's sizes each sliced once per fresh process (rounds of
    the sizes): median wall and system time, and each step's ratio of the
    medians with the range of the rounds' ratios."""
    sizes = sorted(fresh)
    walls = {c: [w for w, _ in fresh[c]] for c in sizes}
    times = " → ".join(f"{statistics.median(walls[c]):.3g} s" for c in sizes)
    system = _system_ms(fresh)
    steps = []
    for a, b in itertools.pairwise(sizes):
        r = [y / x for x, y in zip(walls[a], walls[b])]
        step = statistics.median(walls[b]) / statistics.median(walls[a])
        steps.append(fmt_ratio((step, min(r), max(r))))
    return (f"The same sizes sliced once each in a fresh process, where all memory is "
            f"new (medians of {len(walls[sizes[0]])} rounds): {times}, "
            f"{' / '.join(steps)} per doubling; system {system} ms.")


def peak_memory(v, f, z) -> tuple[int, int, int]:
    """Peak RSS growth of slice_contours on a fresh Mesh, in a fresh process."""
    with tempfile.TemporaryDirectory() as tmp:
        out = _child(_PEAK, _npz(tmp, "mesh", v, f, z))
    grow, n_in, n_out = (int(x) for x in out.split())
    return grow, n_in, n_out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--trimesh-repeat", type=int, default=3,
                    help="repeats of the (slow) trimesh case")
    ap.add_argument("--no-trimesh", action="store_true")
    ap.add_argument("--quick", action="store_true",
                    help="smoke run: one copy, one repeat, no trimesh, no scaling, no "
                         "peak memory")
    args = ap.parse_args()
    if args.quick:
        args.copies, args.repeat, args.no_trimesh = 1, 1, True
    rows, notes = measure(args)
    print("| what | vecslice | peer | ratio (range) |")
    print("|---|---|---|---|")
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print()
    for line in notes:
        print(line)


if __name__ == "__main__":
    main()

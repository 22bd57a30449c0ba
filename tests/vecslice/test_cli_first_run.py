"""What a first run of ``vecslice`` (the demo) compiles: a fixed, small set of kernels.

A cold first run spends nearly all its time compiling kernels, so a kernel that
joins the demo's path, or a kernel on it that turns ``parallel=True`` (parfors cost
seconds to compile), makes the first run slower by seconds. These tests count what
the run makes ready, not how long it takes (timings belong in benchmarks); the
cold-start time itself is measured as the README says.
"""

import json
import subprocess
import sys

import numba
import pytest

pytestmark = pytest.mark.skipif(numba.config.DISABLE_JIT,
                                reason="NUMBA_DISABLE_JIT=1: no kernels")

_SCRIPT = r"""
import importlib, json, pkgutil, threading
from numba.core.registry import CPUDispatcher
from vecslice._kernels import _jit
made, depth = [], threading.local()
def listen(event, name, seconds):
    # kernels called by a kernel are made ready inside their caller's compile
    # (on a cold cache only: a cached caller holds its callees' code)
    d = getattr(depth, "n", 0)
    depth.n = d + 1 if event == "start" else d - 1
    if event == "end":
        made.append([name, d - 1])
_jit.compile_listeners.append(listen)
from vecslice.cli import main
assert main(ARGS) == 0
import vecslice._kernels as kernels
compiled = []
for info in pkgutil.iter_modules(kernels.__path__):
    module = importlib.import_module(f"vecslice._kernels.{info.name}")
    for name, obj in vars(module).items():
        if (isinstance(obj, CPUDispatcher) and obj.__module__ == module.__name__
                and obj.signatures):
            compiled.append(f"{info.name}.{name}")
print(json.dumps({"made": made, "compiled": compiled}))
"""

# The kernels a first `vecslice` (demo model) calls from Python, by module, and
# the kernels they call. A change here is a change of the cold first run: measure
# it (README, "first run") before adding a kernel.
DEMO_KERNELS = {
    # (the demo mesh is clean: its arrays are kept as given, nothing is rewritten)
    "vertices": {"_count_parts", "_fill_parts", "_match_partitions", "_number_groups",
                 "_mark_used"},
    "topology": {"_pack_half_edges", "_match_buckets"},
    "contours": {"_vertex_layers_range", "_even_suffix", "_plan_range",
                 "_trace_closed"},
    "rings": {"ring_area2"},  # (the demo keeps every loop: nothing to take out)
}
DEMO_CALLEES = {
    "topology": {"_heapsort"},
    "contours": {"_paired"},
}
# kernels/simplify.py (and the geometry helpers it calls) is tuned for its own
# compile time by its owner; its kernels are not listed here
OTHER_MODULES = {"simplify", "geometry"}


def _first_run(tmp_path, args):
    code = _SCRIPT.replace("ARGS", repr(list(args)))
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, text=True,
                       capture_output=True, timeout=600)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_the_demo_compiles_only_its_kernels(tmp_path):
    got = _first_run(tmp_path, [])
    entry = {f"{m}.{k}" for m, ks in DEMO_KERNELS.items() for k in ks}
    callee = {f"{m}.{k}" for m, ks in DEMO_CALLEES.items() for k in ks}
    compiled = set(got["compiled"])
    mine = {k for k in compiled if k.split(".")[0] not in OTHER_MODULES}
    # every entry kernel, and nothing but them and their callees
    assert entry <= mine, entry - mine
    assert mine <= entry | callee, mine - entry - callee
    # the listeners heard of each entry kernel outside any other compile
    top = {name for name, d in got["made"] if d == 0}
    assert {k.split(".")[1] for k in entry} <= top
    # reference kernels kept for the tests stay off the run path
    for ref in ("topology.edge_topology", "topology._bucket_edges",
                "contours._open_ends", "contours._pair_ends", "contours._trace_open",
                "contours._by_key_then_plane",
                "crossings.crossing_points", "crossings.face_segments",
                "loops.link_segments", "rings.group_rings"):
        assert ref not in compiled


def test_the_demo_kernels_are_not_parfors():
    # parallel=True costs seconds of compile per kernel: the demo's kernels are
    # plain and get their parallelism from vecslice._threads.run_chunks
    import importlib

    for table in (DEMO_KERNELS, DEMO_CALLEES):
        for module, kernels in table.items():
            mod = importlib.import_module(f"vecslice._kernels.{module}")
            for name in kernels:
                opts = getattr(mod, name).targetoptions
                assert not opts.get("parallel"), f"{module}.{name}"
                assert opts.get("inline") != "always", f"{module}.{name}"

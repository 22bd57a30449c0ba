"""Ctrl-C and the first-run compile notice of the `vecslice` command."""

import os
import signal
import subprocess
import sys
import threading
import time

import pytest

from conftest import MESHES
from vecslice._cli_support import COMPILE_MESSAGE

# generous for a loaded 2-core machine; the worker polls every 0.05 s
STOP_WITHIN_S = 3.0


def _start(args, cwd, env=None):
    return subprocess.Popen(
        [sys.executable, "-m", "vecslice", *map(str, args)], cwd=cwd,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})},
    )


def _wait_for_line(stream, fragment, timeout):
    """Read ``stream`` until a line contains ``fragment``; return what was read."""
    found, seen = threading.Event(), []

    def read():
        for line in stream:
            seen.append(line)
            if fragment in line:
                found.set()
                return

    threading.Thread(target=read, daemon=True).start()
    assert found.wait(timeout), f"{fragment!r} not seen in {seen!r}"
    return seen


def _interrupt(proc):
    """SIGINT; return (seconds until exit, stderr rest)."""
    t = time.monotonic()
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail("vecslice did not stop within 60 s of Ctrl-C")
    return time.monotonic() - t, err


def test_ctrl_c_while_kernels_compile_stops_at_once(tmp_path):
    """The first run compiles for tens of seconds; Ctrl-C must not wait for it."""
    cache = tmp_path / "numba-cache"  # empty: every kernel compiles
    proc = _start(["--no-progress", "-o", "demo.npz"], tmp_path,
                  {"NUMBA_CACHE_DIR": str(cache)})
    seen = _wait_for_line(proc.stderr, COMPILE_MESSAGE, timeout=240)
    time.sleep(1.0)  # inside a compilation now
    assert proc.poll() is None, "the cold run ended before it could be interrupted"
    seconds, err = _interrupt(proc)
    err = "".join(seen) + err
    assert proc.returncode == 130, err
    assert seconds < STOP_WITHIN_S, f"took {seconds:.1f} s"
    assert err.rstrip().endswith("vecslice: interrupted")
    assert "Traceback" not in err and "SystemError" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["numba-cache"]


def test_ctrl_c_while_a_kernel_runs_stops_at_once(tmp_path):
    """A long slice (3DBenchy in 48,000 layers of 1 µm: tens of seconds of
    kernels, however fast the machine) with warm kernels."""
    path = MESHES / "3DBenchy.3mf"
    if not path.exists():
        pytest.skip(f"{path} not found")
    proc = _start([path, "--layer-height", "0.001", "--no-progress", "-o", "p.npz"],
                  tmp_path)
    _wait_for_line(proc.stdout, "model ", timeout=240)  # loaded: slicing starts
    time.sleep(1.0)
    assert proc.poll() is None, "the slice ended before it could be interrupted"
    seconds, err = _interrupt(proc)
    assert proc.returncode == 130, err
    assert seconds < STOP_WITHIN_S, f"took {seconds:.1f} s"
    assert err.strip().splitlines()[-1] == "vecslice: interrupted"
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []  # no output, no temporary file


def test_compile_notice_never_on_a_warm_run(tmp_path):
    first = _start(["--no-progress"], tmp_path)  # warms the cache if it was cold
    first.communicate(timeout=600)
    assert first.returncode == 0
    again = _start(["--no-progress"], tmp_path)
    out, err = again.communicate(timeout=600)
    assert again.returncode == 0 and "layers    148" in out
    assert COMPILE_MESSAGE not in err and "compiled kernels" not in err
    assert err == ""

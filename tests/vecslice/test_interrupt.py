import os
import signal
import threading
import time

import pytest

import vecslice as vs
from vecslice.interrupt import _interrupted, keyboard_interrupts, run_interruptible


def test_returns_the_value_and_passes_arguments():
    assert run_interruptible(divmod, 17, 5) == (3, 2)
    assert run_interruptible(sorted, [3, 1, 2], reverse=True) == [3, 2, 1]


def test_reraises_the_call_s_exception():
    with pytest.raises(vs.SettingsError, match="`layer_height` must be >= 1"):
        run_interruptible(vs.SliceSettings, layer_height=0)


def test_runs_in_a_worker_thread():
    assert run_interruptible(threading.current_thread) is not threading.main_thread()


def test_ctrl_c_reaches_the_caller_at_once():
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    t = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        run_interruptible(time.sleep, 20)  # sleep releases the GIL, as kernels do
    assert time.monotonic() - t < 5.0


# ---------------------------------------------------------------------------
# Ctrl-C while a kernel runs in the main thread (audit s25 api D2)
# ---------------------------------------------------------------------------

numba = pytest.importorskip("numba")
np = pytest.importorskip("numpy")


@numba.njit(nogil=True)
def _busy(started, n):
    """Say it started, spin ``n`` steps, return a tuple of arrays: numba calls
    Python code when it boxes these, where a pending SIGINT is handled."""
    started[0] = 1
    s = 0
    for i in range(n):
        s = (s * 31 + i) % 1000003
    out = np.zeros(2, np.int64)
    out[0] = s
    return out, out.copy()


def _interrupted_kernel():
    """Run :func:`_busy` in this (the main) thread; SIGINT arrives while it runs."""
    started = np.zeros(1, np.int64)
    _busy(started, 10)
    started[0] = 0

    def send():
        deadline = time.monotonic() + 10
        while not started[0] and time.monotonic() < deadline:
            time.sleep(0.001)
        signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)

    threading.Thread(target=send, daemon=True).start()
    return _busy(started, 100_000_000)  # about 0.6 s


@pytest.fixture
def main_thread():
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")


def test_numba_reports_ctrl_c_in_a_kernel_as_system_error(main_thread):
    """What keyboard_interrupts undoes (numba 0.60 - 0.68)."""
    with pytest.raises(SystemError) as info:
        _interrupted_kernel()
    assert _interrupted(info.value)


def test_keyboard_interrupts_raises_the_interrupt(main_thread):
    t = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        keyboard_interrupts(_interrupted_kernel)()
    assert time.monotonic() - t < 5.0


def test_keyboard_interrupts_passes_other_errors_and_values():
    def other():
        raise SystemError("something else")

    with pytest.raises(SystemError, match="something else"):
        keyboard_interrupts(other)()
    assert keyboard_interrupts(divmod)(17, 5) == (3, 2)


def test_slice_mesh_raises_keyboard_interrupt(main_thread, monkeypatch):
    """A user's ``except KeyboardInterrupt`` caught nothing: the SystemError went by."""
    import trimesh

    from vecslice import pipeline

    def interrupted(*args, **kwargs):
        _interrupted_kernel()

    monkeypatch.setattr(pipeline, "apply_slicing_tolerance", interrupted)
    mesh = vs.load_mesh(trimesh.creation.box((10, 10, 1)))
    with pytest.raises(KeyboardInterrupt):
        vs.slice_mesh(mesh)


PUBLIC_CALLS = [
    "adaptive_layer_heights", "check_mesh", "clean_loops", "layer_heights",
    "load_mesh", "load_sliced", "make_parts", "resolution_stats", "simplify",
    "slice_contours", "slice_mesh", "stitch", "sweep",
]


@pytest.mark.parametrize("name", PUBLIC_CALLS)
def test_public_calls_turn_the_system_error_back(name):
    code = keyboard_interrupts(divmod).__code__
    assert getattr(vs, name).__code__ is code


@pytest.mark.parametrize("call", [
    "Mesh.from_arrays", "Mesh.repaired", "metrics.contour_errors",
    "metrics.simplification_errors", "metrics.layer_xor_areas", "metrics.move_stats",
    "metrics.volume_error",
])
def test_other_public_calls_turn_the_system_error_back(call):
    import vecslice.metrics  # noqa: F401

    owner, attr = call.split(".")
    fn = getattr(getattr(vs, owner), attr)
    assert getattr(fn, "__func__", fn).__code__ is keyboard_interrupts(divmod).__code__

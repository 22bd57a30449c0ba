import os
import signal
import threading
import time

import pytest

import vecslice as vs
from vecslice.interrupt import run_interruptible


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

"""STYLE.md conventions as tests: every kernel is typed, cached, nogil, exact."""

import ast
import importlib
import inspect
import pkgutil
from pathlib import Path

import numba
import numpy as np
import pytest
from numba.core.caching import NullCache
from numba.core.registry import CPUDispatcher

import vecslice._kernels as kernels
from vecslice._kernels._jit import kernel


def _kernels():
    for info in pkgutil.iter_modules(kernels.__path__):
        module = importlib.import_module(f"vecslice._kernels.{info.name}")
        for name, obj in vars(module).items():
            if isinstance(obj, CPUDispatcher) and obj.__module__ == module.__name__:
                yield pytest.param(obj, id=f"{info.name}.{name}")


KERNELS = list(_kernels())
DECLARED = [p for p in KERNELS if p.values[0].targetoptions.get("inline") != "always"]

# parfors cost seconds each to compile on a first run, and numba's workqueue
# threading layer (its fallback without OpenMP or TBB) aborts the process when two
# threads run parfors at once; parallel work is a plain nogil kernel over a chunk
# (lo, hi) and a driver whose `run` runs the chunks (vecslice._threads.run_chunks).
# No kernel uses parallel=True:
PARALLEL_ALLOWED: set[str] = set()


def _drivers():
    for info in pkgutil.iter_modules(kernels.__path__):
        if info.name.startswith("_"):  # _jit, _types: the machinery
            continue
        module = importlib.import_module(f"vecslice._kernels.{info.name}")
        for name, obj in vars(module).items():
            if (inspect.isfunction(obj) and obj.__module__ == module.__name__
                    and not isinstance(obj, CPUDispatcher)):
                yield pytest.param(obj, id=f"{info.name}.{name}")


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="NUMBA_DISABLE_JIT=1: no kernels")
def test_kernels_are_found():
    assert len(DECLARED) >= 30


@pytest.mark.parametrize("kernel", KERNELS)
def test_kernel_is_cached_nogil_and_without_fastmath(kernel):
    assert not isinstance(kernel._cache, NullCache), "use cache=True"
    assert kernel.targetoptions.get("nogil"), "use nogil=True"
    assert not kernel.targetoptions.get("fastmath"), "no fastmath"


@pytest.mark.parametrize("kernel", KERNELS)
def test_kernel_sets_reference_counting_explicitly(kernel):
    # numba lets a kernel without an explicit _nrt inherit its first caller's:
    # an allocating kernel first typed inside an _nrt=False one would not compile
    assert kernel.targetoptions.get("_nrt") in (True, False)


@pytest.mark.parametrize("kernel", DECLARED)
def test_kernels_declare_one_signature_and_compile_only_it(kernel):
    # inline helpers are compiled into their callers; every other kernel declares
    # its signature and, once used, holds exactly that one compiled version
    sig = getattr(kernel, "declared_signature", None)
    assert sig is not None, "declare an explicit signature from _types"
    assert kernel.signatures in ([], [sig.args])
    if not kernel.signatures:
        kernel.get_call_template(sig.args, {})  # what a calling kernel does
    assert kernel.signatures == [sig.args]
    assert not kernel._can_compile, "no further specialisations"


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="NUMBA_DISABLE_JIT=1: no kernels")
def test_first_call_compiles_the_declared_signature_only():
    # a fresh kernel: importing compiles nothing, the first call compiles the
    # declared (read-only) signature, which writeable arrays also fit, and
    # arguments of another type are refused instead of compiled
    from vecslice._kernels._types import I64, I64_1D

    @kernel(I64(I64_1D))
    def total(a):
        s = 0
        for x in a:
            s += x
        return s

    assert total.signatures == []
    a = np.arange(5, dtype=np.int64)
    assert total(a) == 10
    a.flags.writeable = False
    assert total(a) == 10
    assert total.signatures == [total.declared_signature.args]
    with pytest.raises(TypeError, match="No matching definition"):
        total(np.arange(3.0))


def test_fastmath_is_refused():
    with pytest.raises(ValueError, match="fastmath"):
        kernel(fastmath=True)


def test_only_the_listed_kernels_are_parfors():
    parallel = {p.id for p in KERNELS if p.values[0].targetoptions.get("parallel")}
    assert parallel <= PARALLEL_ALLOWED, parallel - PARALLEL_ALLOWED


def _parfor_uses(path):
    """``prange`` names and ``parallel=True`` arguments in a module's code."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Name | ast.Attribute | ast.alias):
            name = getattr(node, "id", None) or getattr(node, "attr", None) or (
                getattr(node, "name", ""))
            if name.split(".")[-1] == "prange":
                found.append(f"{path.name}:{getattr(node, 'lineno', '?')} prange")
        if isinstance(node, ast.keyword) and node.arg == "parallel":
            if not (isinstance(node.value, ast.Constant) and not node.value.value):
                found.append(f"{path.name}:{node.lineno} parallel=")
    return found


def test_no_kernel_module_uses_parfors():
    # the source, not the dispatchers: also true under NUMBA_DISABLE_JIT and for
    # inline helpers
    paths = sorted(Path(kernels.__path__[0]).glob("*.py"))
    assert len(paths) > 10
    found = [use for path in paths for use in _parfor_uses(path)]
    assert not found, found


@pytest.mark.parametrize("driver", list(_drivers()))
def test_plain_functions_in_kernels_are_chunk_drivers(driver):
    # besides kernels, a kernel module holds only drivers: Python that chains
    # kernels and hands chunks of work to `run` (serial unless the caller passes
    # a thread pool), so that the library's calls run the chunks on threads
    from vecslice._kernels._jit import run_serial

    run = inspect.signature(driver).parameters.get("run")
    assert run is not None and run.default is run_serial, "add run=run_serial"

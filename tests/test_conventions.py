"""STYLE.md conventions turned into tests: every public kernel is eager and cached."""

import importlib
import pkgutil

import pytest
from numba.core.caching import NullCache
from numba.core.registry import CPUDispatcher

import vecslice._kernels as kernels


def _kernels():
    for info in pkgutil.iter_modules(kernels.__path__):
        module = importlib.import_module(f"vecslice._kernels.{info.name}")
        for name, obj in vars(module).items():
            if isinstance(obj, CPUDispatcher) and obj.__module__ == module.__name__:
                yield pytest.param(obj, id=f"{info.name}.{name}")


@pytest.mark.parametrize("kernel", list(_kernels()))
def test_kernel_is_cached_nogil_and_without_fastmath(kernel):
    assert not isinstance(kernel._cache, NullCache), "use cache=True"
    assert kernel.targetoptions.get("nogil"), "use nogil=True"
    assert not kernel.targetoptions.get("fastmath"), "no fastmath"


@pytest.mark.parametrize(
    "kernel",
    [p for p in _kernels()
     if not p.values[0].targetoptions.get("inline") == "always"],
)
def test_public_kernels_have_explicit_signatures(kernel):
    # inline helpers are compiled into their callers; every other kernel is eager
    assert kernel.signatures, "declare an explicit signature from _types"

"""Shared fixtures: paths to ../shared, hypothesis profiles."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

ROOT = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("VECSLICE_SHARED", ROOT.parent / "shared"))
MESHES = SHARED / "meshes"
TESTDATA = SHARED / "testdata"

settings.register_profile(
    "default", deadline=None, max_examples=100,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "ci", deadline=None, max_examples=200, derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("ci" if os.environ.get("CI") else "default")


def _need(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"shared data not found at {path} (../shared beside the project)")
    return path


@pytest.fixture(scope="session")
def meshes_dir() -> Path:
    """../shared/meshes; skips (with the reason) only where it is absent."""
    return _need(MESHES)


@pytest.fixture(scope="session")
def testdata_dir() -> Path:
    """../shared/testdata; skips (with the reason) only where it is absent."""
    return _need(TESTDATA)


def load_testdata(name: str) -> object:
    """Parse ../shared/testdata/<name>, skipping if the folder is absent."""
    return json.loads(_need(TESTDATA / name).read_text())


@pytest.fixture
def write_when_copied(monkeypatch):
    """Another thread's write to a caller's array, just before vecslice copies it.

    ``arm(target, index, value)`` makes ``target[index] = value`` happen once,
    when vecslice adopts ``target`` or a view of it (``vecslice.ragged.adopt``,
    or the copy ``ragged.private_int_extremes`` takes: the copy a container or
    function keeps). A check made on the caller's memory
    before that copy misses the write; one made on the copy sees it. No copy, no
    write. ``arm`` returns the list of the writes done so far (all arms).
    """
    import importlib

    import numpy as np

    ragged = importlib.import_module("vecslice.ragged")
    real = ragged.adopt
    armed: list[tuple[np.ndarray, object, object]] = []
    done: list[object] = []

    def write(given):
        for entry in list(armed):
            target, index, value = entry
            if given is target or (isinstance(given, np.ndarray)
                                   and np.may_share_memory(given, target)):
                target[index] = value
                done.append(index)
                armed.remove(entry)

    def adopt(new, given):
        write(given)
        return real(new, given)

    real_copy = ragged._copy_extremes

    def copy_extremes(src, dst):  # the copy that private_int_extremes keeps
        if dst is not None:
            write(src)
        return real_copy(src, dst)

    monkeypatch.setattr(ragged, "_copy_extremes", copy_extremes)

    # every module that took the name (imported first, so none keeps the patch)
    for name in ("cura_slicing", "cura_stl", "layerparts", "mesh", "metrics",
                 "paths", "ragged", "simplify", "slicing", "storage"):
        module = importlib.import_module(f"vecslice.{name}")
        if getattr(module, "adopt", None) is real:
            monkeypatch.setattr(module, "adopt", adopt)

    def arm(target, index, value):
        armed.append((target, index, value))
        return done

    return arm

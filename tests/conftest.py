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

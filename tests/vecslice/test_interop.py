"""Tests of vecslice.interop (to_shapely); its results are tested with the
containers that call it (test_storage, test_parts)."""

import sys

import pytest

import vecslice as vs


def test_without_shapely_the_error_names_the_extra(monkeypatch):
    """Audit s25 docs D3: a plain ImportError saying 'pip install shapely'."""
    model = vs.slice_mesh(vs.demo_mesh())
    monkeypatch.setitem(sys.modules, "shapely", None)
    with pytest.raises(vs.MissingDependencyError,
                       match=r"to_shapely needs shapely, which is not installed: pip "
                             r"install 'vecslice\[shapely\]'"):
        model.to_shapely(0)

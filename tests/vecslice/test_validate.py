"""Tests for vecslice._validate: shared checks, used the same way everywhere."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import vecslice as vs
from vecslice._validate import check_bool


def _calls(tmp_path):
    mesh = vs.load_mesh(trimesh.creation.box((10, 10, 2)))
    loops = vs.slice_contours(mesh, [0])
    model = vs.slice_mesh(mesh)
    return {
        "SliceSettings": lambda v: vs.SliceSettings(union_overlapping_volumes=v),
        "make_parts": lambda v: vs.make_parts(loops, union_overlapping_volumes=v),
        "save": lambda v: model.save(tmp_path / "m.npz", compress=v),
        "slice_mesh": lambda v: vs.slice_mesh(mesh, progress=v),
        "slice_contours": lambda v: vs.slice_contours(mesh, [0], stitch=v),
    }


@pytest.mark.parametrize("value", ["no", "yes", 0, 1, None, [True]])
def test_every_boolean_option_refuses_truthiness_the_same_way(value, tmp_path):
    """Issue 8 D8: one rule and one message for every boolean option."""
    for name, call in _calls(tmp_path).items():
        with pytest.raises(vs.InputTypeError,
                           match=r"` must be True or False; got ") as info:
            call(value)
        assert isinstance(info.value, TypeError), name
    assert not (tmp_path / "m.npz").exists()


def test_check_bool_accepts_numpy_bools():
    assert check_bool(np.True_, "x") is True and check_bool(False, "x") is False

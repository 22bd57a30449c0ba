"""Tests for vecslice.settings: SliceSettings validation."""

from __future__ import annotations

import numpy as np
import pytest

import vecslice as vs


@pytest.mark.parametrize("value", ["no", "False", 0, 1, None])
def test_bool_settings_refuse_truthiness(value):
    with pytest.raises(vs.InputTypeError,
                       match="`union_overlapping_volumes` must be True or False"):
        vs.SliceSettings(union_overlapping_volumes=value)


def test_numpy_bools_are_stored_as_bools():
    s = vs.SliceSettings(union_overlapping_volumes=np.False_)
    assert s.union_overlapping_volumes is False

"""Tests for vecslice.units: to_microns."""

from __future__ import annotations

import numpy as np
import pytest

import vecslice as vs
from vecslice import InputTypeError, InputValueError


def test_rounds_half_away_from_zero():
    assert vs.to_microns([0.0005, -0.0005, 1.25, 2]).tolist() == [1, -1, 1250, 2000]
    assert vs.to_microns(np.float32(0.5)) == 500
    assert vs.to_microns(np.array([[1, 2]], np.int32)).tolist() == [[1000, 2000]]
    from decimal import Decimal

    assert vs.to_microns([Decimal("0.25")]).tolist() == [250]


@pytest.mark.parametrize(
    ("mm", "fragment"),
    [
        # Issue 8 C3: raw ValueError / TypeError before
        ([1.5, "a"], "`mm` must be a number or an array of numbers .* holding strings"),
        (object(), "got object with a non-number"),
        (None, "got NoneType None"),
        ("1.5", "got str '1.5'"),
        ([[1.0], [1.0, 2.0]], "got list that numpy cannot convert"),
        ([True, False], "got list of dtype bool"),
        ([1 + 2j], "got list of dtype complex128"),
        ([object()], "got list with a non-number"),
    ],
)
def test_non_numbers_are_type_errors(mm, fragment):
    with pytest.raises(InputTypeError, match=fragment) as info:
        vs.to_microns(mm)
    assert isinstance(info.value, TypeError)


@pytest.mark.parametrize(
    ("mm", "fragment"),
    [
        ([1.5, None], r"got list with NoneType None at flat index 1"),
        (np.array([None], dtype=object), r"got ndarray with NoneType None at flat "
                                         r"index 0"),
        (np.array([1.5, "2.5"], dtype=object), r"got ndarray with str '2\.5' at "
                                               r"flat index 1"),
        (np.array([[1.5], [True]], dtype=object), r"with bool True at flat index 1"),
    ],
)
def test_non_numbers_among_objects_are_type_errors(mm, fragment):
    """Audit s35 api D2: None in a list became NaN (an InputValueError saying
    "must be finite; got nan"), and a string or a bool in an object array was
    converted silently ("2.5" became 2500 µm), though to_microns refuses both."""
    with pytest.raises(InputTypeError, match=fragment) as info:
        vs.to_microns(mm)
    assert isinstance(info.value, TypeError)


def test_bad_values_name_the_argument():
    with pytest.raises(InputValueError, match="`scale` must be finite; got nan"):
        vs.to_microns([1.0, float("nan")], name="scale")
    with pytest.raises(InputValueError, match="must be below") as info:
        vs.to_microns(2e6)
    assert "got 2000000.0 mm at flat index 0" in str(info.value)  # no np.float64(…)


def test_an_integer_beyond_float_range_is_refused_as_too_large():
    """Audit s25 api D3: a plain OverflowError escaped (not a VecsliceError)."""
    for value, shown, at in [(10**400, "10", 0), ([1, -10**5000], "-10", 1)]:
        with pytest.raises(vs.InputValueError,
                           match=rf"`mm` must be below .* mm in magnitude .*got about "
                                 rf"{shown}\*\*\d+ at flat index {at}"):
            vs.to_microns(value)

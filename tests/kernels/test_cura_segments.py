"""CuraEngine's interpolate and per-face segments (kernels/cura_segments.py)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import reference_cura as ref
from vecslice._kernels.cura_segments import interpolate

COORD = st.integers(-(2**30) + 1, 2**30 - 1)


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        # the spec's examples: the bias is asymmetric when x1 < x0
        ((100, 10000, 0, 0, 10000), 9899),  # exact 9900
        ((0, 10000, 0, 0, 10000), 9999),  # exact 10000
        ((100, 0, 10000, 0, 10000), 100),
        # num < 0 with dx > 0: the bias is subtracted, then truncation toward zero
        ((100, 0, 10000, 0, -10000), -100),
        ((1, 0, 3, 0, -2), 0),  # exact -2/3; dx / 4 == 0, truncated toward zero
        ((1, 3, 0, 0, 20), 13),  # exact 13.33; num -40, bias +0, -40 / -3
        ((2, 10, 0, 0, 80), 63),  # exact 64; num -640 + 2 = -638, / -10 -> 63
    ],
)
def test_interpolate_examples(args, expected):
    assert interpolate(*args) == expected == ref.interpolate(*args)


def test_interpolate_is_not_symmetric():
    # the same edge walked from either end can give points 1 µm apart
    a = interpolate(100, 0, 10000, 0, 10000)
    b = interpolate(100, 10000, 0, 10000, 0)
    assert (a, b) == (100, 101)


@given(st.integers(-(2**30), 2**30), COORD, COORD, COORD, COORD)
def test_interpolate_matches_reference(x, x0, x1, y0, y1):
    if x1 == x0:
        x1 += 1
    assert interpolate(x, x0, x1, y0, y1) == ref.interpolate(x, x0, x1, y0, y1)


@given(st.integers(-(2**20), 2**20), st.integers(1, 2**20), COORD, COORD)
def test_interpolate_between_ends_stays_within_a_micron(t, dz, y0, y1):
    # on the edge (x0 <= x <= x1) the result is within 1 µm of the exact value
    x = abs(t) % (dz + 1)
    got = interpolate(x, 0, dz, y0, y1)
    exact = y0 + (y1 - y0) * x / dz
    assert abs(got - exact) <= 1 + 1e-9 * abs(y1 - y0)
    assert np.int64(got) == got

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

import reference_simplify as ref
from conftest import load_testdata
from vecslice._kernels.geometry import (
    dist2_from_line,
    dist2_from_segment,
    dist_from_line,
    line_line_intersection,
    tdiv,
    vsize,
    vsize2,
)

PRIMITIVES = load_testdata("cura_geometry_primitives.json")
LIMIT = 2**30 - 1
coord = st.one_of(
    st.integers(-20, 20), st.integers(-100_000, 100_000), st.integers(-LIMIT, LIMIT)
)
point = st.tuples(coord, coord)


def _case_id(case):
    return case["fn"]


@pytest.mark.parametrize("case", PRIMITIVES["cases"], ids=_case_id)
def test_primitive_vectors(case):
    fn = case["fn"]
    if fn == "vSize":
        assert vsize(*case["p"]) == case["result"]
    elif fn == "getDistFromLine":
        args = (*case["p"], *case["a"], *case["b"])
        assert dist_from_line(*args) == case["result"]
        assert dist2_from_line(*args) == case["dist2_result"]
    elif fn == "getDist2FromLineSegment":
        args = (*case["a"], *case["b"], *case["c"])
        assert dist2_from_segment(*args) == case["result"]
    elif fn == "lineLineIntersection":
        pts = (*case["a"], *case["b"], *case["c"], *case["d"])
        ok, x, y = line_line_intersection(*pts)
        assert ok == case["ok"]
        if ok:
            assert [x, y] == case["result"]
    else:
        pytest.fail(f"unknown primitive {fn}")


def test_every_primitive_function_is_covered():
    fns = {c["fn"] for c in PRIMITIVES["cases"]}
    assert fns == {"vSize", "getDistFromLine", "getDist2FromLineSegment",
                   "lineLineIntersection"}


@pytest.mark.parametrize(
    "case", PRIMITIVES["upstream_getDist2FromLineSegment_cases"], ids=_case_id
)
def test_upstream_dist2_from_segment_cases(case):
    got = dist2_from_segment(*case["line_start"], *case["point"], *case["line_end"])
    assert got == case["exact_result"]
    # CuraEngine's own test tolerance holds as well
    assert abs(math.sqrt(got) - math.sqrt(case["upstream_expected_distance2"])) <= 10


@given(st.integers(-(2**62), 2**62), st.integers(-(2**62), 2**62).filter(bool))
def test_tdiv_truncates_toward_zero(a, b):
    q = tdiv(a, b)
    assert q == ref.tdiv(a, b)
    assert abs(q * b) <= abs(a)


def test_tdiv_on_negatives_is_not_floor():
    assert tdiv(-7, 2) == -3 and tdiv(7, -2) == -3 and tdiv(-7, -2) == 3
    assert tdiv(-(2**63), 3) == -3074457345618258602


def test_vsize_rounds_half_to_even_of_the_double_sqrt():
    assert vsize(1, 1) == 1  # sqrt(2)
    assert vsize(2, 3) == 4  # sqrt(13) = 3.6
    assert vsize(707, 707) == 1000
    assert vsize(0, 0) == 0
    big = 2**31 - 1
    assert vsize(big, big) == ref.vsize(big, big) == round(math.sqrt(2.0 * big * big))


@given(point, point, point)
def test_distance_helpers_match_reference(p, a, b):
    assert vsize2(p[0] - a[0], p[1] - a[1]) == ref.vsize2(p[0] - a[0], p[1] - a[1])
    assert vsize(p[0] - a[0], p[1] - a[1]) == ref.vsize(p[0] - a[0], p[1] - a[1])
    assert dist_from_line(*p, *a, *b) == ref.dist_from_line(p, a, b)
    assert dist2_from_line(*p, *a, *b) == ref.dist2_from_line(p, a, b)
    assert dist2_from_segment(*a, *p, *b) == ref.dist2_from_segment(a, p, b)


@given(point, point, point)
def test_dist2_from_line_is_a_perfect_square(p, a, b):
    d2 = dist2_from_line(*p, *a, *b)
    assert math.isqrt(d2) ** 2 == d2


@given(point, point, point, point)
def test_line_line_intersection_matches_float32_reference(a, b, c, d):
    ok, x, y = line_line_intersection(*a, *b, *c, *d)
    want = ref.line_line_intersection(a, b, c, d)
    assert ok == (want is not None)
    if ok:
        assert (x, y) == want
        assert abs(x) <= 2**31 - 1 and abs(y) <= 2**31 - 1


def test_line_line_intersection_parallel_and_far():
    assert not line_line_intersection(0, 0, 0, 10000, 10, 10000, 10, 0)[0]
    # nearly parallel: the intersection lies beyond the int32 range
    assert not line_line_intersection(0, 0, 10**9, 1, 0, 10, 10**9, 12)[0]


def test_float32_rounding_is_per_operation():
    # a case where double arithmetic differs from float32 arithmetic
    case = next(c for c in PRIMITIVES["cases"] if c["fn"] == "lineLineIntersection"
                and c["a"] == [-180737, 71595])
    a, b, c, d = case["a"], case["b"], case["c"], case["d"]
    x13, y13 = a[0] - c[0], a[1] - c[1]
    x34, y34 = c[0] - d[0], c[1] - d[1]
    x12, y12 = a[0] - b[0], a[1] - b[1]
    t64 = (x13 * y34 - y13 * x34) / (x12 * y34 - y12 * x34)
    as_double = [a[0] + round((b[0] - a[0]) * t64), a[1] + round((b[1] - a[1]) * t64)]
    ok, x, y = line_line_intersection(*a, *b, *c, *d)
    assert ok and [x, y] == case["result"] != as_double

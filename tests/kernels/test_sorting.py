import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from vecslice._kernels.sorting import stable_argsort

int64 = st.integers(-(2**63), 2**63 - 1)


@given(st.lists(st.one_of(st.integers(-3, 3), int64), max_size=300))
def test_stable_argsort_is_numpys_stable_argsort(values):
    key = np.array(values, dtype=np.int64)
    assert stable_argsort(key).tolist() == np.argsort(key, kind="stable").tolist()


def test_stable_argsort_of_long_runs_of_ties_and_reversed_keys():
    rng = np.random.default_rng(5)
    for key in (rng.integers(0, 4, 10_000), np.arange(5_000)[::-1].copy(),
                np.zeros(1_000, dtype=np.int64), rng.integers(-9, 9, 33)):
        key = key.astype(np.int64)
        assert stable_argsort(key).tolist() == np.argsort(key, kind="stable").tolist()


@given(st.lists(st.integers(-50, 50), max_size=40), st.integers(-60, 60),
       st.integers(0, 45), st.integers(0, 45))
def test_lower_bound_is_bisect_left(values, x, lo, hi):
    import bisect

    from vecslice._kernels.sorting import lower_bound

    a = np.array(sorted(values), dtype=np.int64)
    lo, hi = min(lo, len(a)), min(hi, len(a))
    hi = max(lo, hi)
    assert lower_bound(a, lo, hi, x) == bisect.bisect_left(a.tolist(), x, lo, hi)


@given(st.integers(0, 2**40))
def test_table_bits_is_the_fewest_bits_for_a_half_full_table(m):
    from vecslice._kernels.sorting import table_bits

    b = table_bits(m)
    assert b >= 1 and 2**b >= 2 * m
    assert b == 1 or 2 ** (b - 1) < 2 * m


def _mix_reference(x, y, z):
    """mix_hash in Python integers, wrapped to 64 bits as int64 arithmetic wraps."""
    mask = 2**64 - 1
    h = (x * 0x9E3779B97F4A7C15 + y * 0xBF58476D1CE4E5B9
         + z * 0x94D049BB133111EB) & mask
    signed = h - 2**64 if h >> 63 else h
    h = (h ^ ((signed >> 29) & mask)) & mask  # arithmetic shift, as int64's
    return (h * 0x9E3779B97F4A7C15) & mask


@given(int64, int64, int64)
def test_mix_hash_is_its_definition_in_wrapping_arithmetic(x, y, z):
    from vecslice._kernels.sorting import mix_hash

    h = mix_hash(np.int64(x), np.int64(y), np.int64(z))
    assert int(h) == _mix_reference(x, y, z)

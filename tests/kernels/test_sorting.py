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

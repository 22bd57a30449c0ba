"""Chunk bounds for the kernel drivers' ``run`` (kernels/_jit.py)."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from vecslice._kernels._jit import cost_chunks, even_chunks


@given(st.integers(0, 1000), st.integers(1, 300))
def test_even_chunks_cover_the_items_in_equal_steps(n, size):
    bounds = even_chunks(n, size).tolist()
    assert bounds[0] == 0 and bounds[-1] == n
    steps = np.diff(bounds)
    assert (steps > 0).all() and (steps[:-1] == size).all()
    assert len(bounds) == max(1, -(-n // size)) + (n > 0)


@given(st.lists(st.integers(0, 50), max_size=60), st.integers(1, 80))
def test_cost_chunks_cut_at_item_boundaries_by_cost(sizes, cost):
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    bounds = cost_chunks(offsets, cost)
    n = len(sizes)
    assert bounds.dtype == np.int64
    assert bounds.tolist()[0] == 0 and bounds.tolist()[-1] == n
    assert (np.diff(bounds) > 0).all()  # no empty chunk; none for no items
    # an item costs 1 plus its size: every chunk but the last reaches the next
    # multiple of `cost` with its last item, and not before it
    total = offsets + np.arange(n + 1)
    for c, hi in enumerate(bounds[1:-1].tolist()):
        target = cost * (total[bounds[c]] // cost + 1)
        assert total[hi] >= target and total[hi - 1] < target

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import reference
from vecslice._kernels.boxes import boxes_inside
from vecslice.nesting import _BoxTree


@st.composite
def boxes(draw, n):
    lo = np.array(draw(st.lists(st.tuples(*[st.integers(0, 6)] * 3), min_size=n,
                                max_size=n)), dtype=np.int64).reshape(-1, 3)
    ext = np.array(draw(st.lists(st.tuples(*[st.integers(0, 6)] * 3), min_size=n,
                                 max_size=n)), dtype=np.int64).reshape(-1, 3)
    return np.concatenate([lo, lo + ext], axis=1)


@st.composite
def cases(draw):
    n = draw(st.integers(1, 70))  # trees of depth 0 .. 3
    b = draw(boxes(n))
    dead = draw(st.lists(st.integers(0, n - 1), unique=True))
    q = draw(boxes(draw(st.integers(0, 8))))
    if n and draw(st.booleans()):  # queries equal to boxes (themselves excluded)
        q = np.concatenate([q, b[: draw(st.integers(1, n))]])
    return b, np.array(dead, dtype=np.int64), q, draw(st.integers(0, 3))


@given(cases())
def test_boxes_inside_matches_reference(case):
    b, dead, q, start = case
    tree = _BoxTree(b)
    where = np.argsort(tree.rows)  # box -> tree position
    tree.kill(where[dead])
    assert tree.live_below[0] == len(b) - len(dead)
    k, rows = boxes_inside(tree.boxes, tree.bounds, tree.live_below, tree.live, q,
                           start)
    want_k, want_rows = reference.boxes_inside(tree.boxes, tree.live, q, start)
    assert (k, rows.tolist()) == (want_k, want_rows)


def test_boxes_inside_skips_dead_and_equal_boxes():
    # boxes 0 .. 39 nested, each inside the next; query each in turn
    k = np.arange(1, 41, dtype=np.int64)[:, None]
    b = np.concatenate([-k.repeat(3, axis=1), k.repeat(3, axis=1)], axis=1)
    tree = _BoxTree(b)
    assert tree.depth == 2
    where = np.argsort(tree.rows)
    got = []
    for i in range(1, 40):
        at, rows = boxes_inside(tree.boxes, tree.bounds, tree.live_below, tree.live,
                                b, i)
        got.append((int(at), tree.rows[rows].tolist()))
        tree.kill(rows)  # the next one out holds it
    assert got == [(i, [i - 1]) for i in range(1, 40)]
    assert tree.live_below[0] == 1 and tree.live[where[39]]
    at, rows = boxes_inside(tree.boxes, tree.bounds, tree.live_below, tree.live, b, 0)
    assert at == 40 and rows.tolist() == []

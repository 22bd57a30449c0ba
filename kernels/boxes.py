"""Kernels over axis-aligned boxes: the live boxes inside a query box."""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1_1D, I64, I64_1D, I64_1D_OUT, I64_2D


@kernel(types.Tuple((I64, I64_1D_OUT))(I64_2D, I64_2D, I64_1D, B1_1D, I64_2D, I64))
def boxes_inside(boxes, bounds, live_below, live, queries, start):
    """The first query box from ``start`` with live boxes inside it, and those boxes.

    ``boxes`` has a row ``lo x, lo y, lo z, hi x, hi y, hi z`` per box, in the
    order of a balanced binary tree of depth ``D`` (``len(bounds) == 2**(D + 1) -
    1``): node ``j`` of level ``d`` (row ``2**d - 1 + j`` of ``bounds`` and
    ``live_below``) holds boxes ``j * n >> d`` to ``(j + 1) * n >> d`` (exclusive;
    ``n`` boxes), and its children are nodes ``2j`` and ``2j + 1`` of level
    ``d + 1``. ``bounds`` holds per node the largest ``lo`` and the smallest
    ``hi`` of its boxes (6 columns), ``live_below`` how many of them are live,
    ``live`` whether each box is.

    Box ``a`` is inside query ``q`` when ``q.lo <= a.lo`` and ``a.hi <= q.hi``
    in every coordinate and ``a != q``. Returns ``(k, rows)``: ``k`` the first
    query index ``>= start`` with a live box inside it, ``rows`` those boxes'
    rows, ascending; ``(len(queries), [])`` when no query from ``start`` has one.

    A subtree is skipped when none of its boxes is live or its bounds show that
    none can be inside ``q``, so a query costs about the depth of the tree when
    few live boxes are near it.

    Preconditions: ``len(bounds) == 2**(D + 1) - 1`` with ``2**D <= n``;
    ``live_below`` counts ``live`` as described; ``0 <= start``.
    """
    n = boxes.shape[0]
    depth = 0
    while (2 << depth) - 1 < bounds.shape[0]:
        depth += 1
    out = np.empty(n, dtype=np.int64)
    stack = np.empty(depth + 2, dtype=np.int64)  # node rows; depth-first
    for k in range(start, queries.shape[0]):
        found = 0
        stack[0] = 0
        top = 1
        while top > 0:
            top -= 1
            h = stack[top]
            if live_below[h] == 0:
                continue
            skip = False
            for c in range(6):
                b, q = bounds[h, c], queries[k, c]
                if (b < q) if c < 3 else (b > q):
                    skip = True
            if skip:
                continue
            level = 0
            while (2 << level) - 1 <= h:
                level += 1
            if level < depth:
                stack[top] = 2 * h + 2  # the right child below the left: left first
                stack[top + 1] = 2 * h + 1
                top += 2
                continue
            j = h - ((1 << level) - 1)
            for r in range((j * n) >> level, ((j + 1) * n) >> level):
                if not live[r]:
                    continue
                inside = True
                same = True
                for c in range(6):
                    a, q = boxes[r, c], queries[k, c]
                    if (a < q) if c < 3 else (a > q):
                        inside = False
                    if a != q:
                        same = False
                if inside and not same:
                    out[found] = r
                    found += 1
        if found:
            return k, out[:found].copy()
    return queries.shape[0], np.empty(0, dtype=np.int64)

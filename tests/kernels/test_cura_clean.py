"""Lengths and degenerate vertices of open paths (kernels/cura_clean.py)."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import reference_cura as ref
from vecslice._kernels.cura_clean import (
    path_lengths,
    remove_degenerate_polyline_vertices,
)

# points on a line and back (exact reversals) or anywhere
POINT = st.one_of(st.tuples(st.integers(-3, 3).map(lambda v: 10 * v), st.just(0)),
                  st.tuples(st.integers(-50, 50), st.integers(-50, 50)))
PATHS = st.lists(st.lists(POINT, max_size=8), max_size=6)


def _pack(paths):
    pts = [p for path in paths for p in path]
    coords = np.array(pts, dtype=np.int64).reshape(-1, 2)
    offsets = np.cumsum([0] + [len(p) for p in paths]).astype(np.int64)
    return coords, offsets


@given(PATHS)
def test_path_lengths_match_reference(paths):
    coords, offsets = _pack(paths)
    assert path_lengths(coords, offsets).tolist() == [ref.path_length(p)
                                                      for p in paths]


def test_path_length_has_no_closing_segment():
    coords, offsets = _pack([[(0, 0), (3, 4), (0, 0)], [(0, 0), (3, 4)], [(1, 1)]])
    # vsize rounds each step: 5 + 5, 5, 0
    assert path_lengths(coords, offsets).tolist() == [10, 5, 0]


@given(PATHS)
def test_remove_degenerate_polyline_matches_reference(paths):
    coords, offsets = _pack(paths)
    out, out_offsets = remove_degenerate_polyline_vertices(coords, offsets)
    assert out_offsets[0] == 0 and out_offsets[-1] == len(out)
    got = [[tuple(map(int, p)) for p in out[a:b]]
           for a, b in zip(out_offsets[:-1], out_offsets[1:], strict=True)]
    assert got == [ref.remove_degenerate_polyline(p) for p in paths]


def test_degenerate_polyline_keeps_its_ends():
    # a spike out and back: the tip goes, then the stack pops while degenerate;
    # endpoints stay even where the path reverses at them
    coords, offsets = _pack([[(0, 0), (10, 0), (20, 0), (10, 0), (30, 0)]])
    out, out_offsets = remove_degenerate_polyline_vertices(coords, offsets)
    assert out.tolist() == [[0, 0], [10, 0], [30, 0]]
    coords, offsets = _pack([[(0, 0), (10, 0), (0, 0)]])
    out, _ = remove_degenerate_polyline_vertices(coords, offsets)
    assert out.tolist() == [[0, 0], [0, 0]]

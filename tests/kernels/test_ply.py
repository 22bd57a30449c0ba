import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import reference
from vecslice._kernels.ply import record_starts

WIDTH = st.sampled_from([1, 2, 4])
SIZE = st.sampled_from([1, 2, 4, 8])


@st.composite
def elements(draw):
    """A record layout, records written to match it, then maybe damaged."""
    props = draw(st.lists(st.one_of(
        st.tuples(st.just(0), SIZE, st.just(0), st.just(0)),
        st.tuples(WIDTH, SIZE, st.integers(0, 1), st.integers(0, 3))),
        min_size=1, max_size=4))
    big = draw(st.booleans())
    n = draw(st.integers(0, 6))
    out = bytearray(draw(st.binary(max_size=3)))  # bytes before the element
    start = len(out)
    for _ in range(n):
        for width, size, signed, _least in props:
            if width == 0:
                out += draw(st.binary(min_size=size, max_size=size))
                continue
            lo = -(2 ** (8 * width - 1)) if signed else 0
            count = draw(st.one_of(st.integers(0, 5), st.integers(lo, 5)))
            out += count.to_bytes(width, "big" if big else "little",
                                  signed=bool(signed))
            out += draw(st.binary(min_size=max(count, 0) * size,
                                  max_size=max(count, 0) * size))
    cut = draw(st.integers(0, 3))
    data = bytes(out[: len(out) - cut] if draw(st.booleans()) else out)
    data += draw(st.binary(max_size=3))
    return data, start, n, props, big


@given(elements())
def test_record_starts_matches_reference(case):
    data, start, n, props, big = case
    starts, done = record_starts(np.frombuffer(data, np.uint8), start, n,
                                 np.array(props, np.int64).reshape(-1, 4), big)
    want, want_done = reference.record_starts(data, start, n, props, big)
    assert done == want_done
    assert starts[: done + 1].tolist() == want
    assert (starts[done + 1 :] == 0).all()


def test_record_starts_of_triangles_and_quads():
    # Blender writes binary PLY faces of 3 and 4 corners, mixed
    faces = [[0, 1, 2], [0, 2, 3, 4], [4, 5, 6]]
    data = b"".join(bytes([len(f)]) + np.array(f, "<i4").tobytes() for f in faces)
    starts, done = record_starts(np.frombuffer(data, np.uint8), 0, 3,
                                 np.array([[1, 4, 0, 3]], np.int64), False)
    assert done == 3 and starts.tolist() == [0, 13, 30, 43]
    starts, done = record_starts(np.frombuffer(data[:-1], np.uint8), 0, 3,
                                 np.array([[1, 4, 0, 3]], np.int64), False)
    assert done == 2  # the last face runs past the end
    two = bytes([2]) + np.array([0, 1], "<i4").tobytes()
    starts, done = record_starts(np.frombuffer(data + two, np.uint8), 0, 4,
                                 np.array([[1, 4, 0, 3]], np.int64), False)
    assert done == 3  # a face of 2 corners is below the least count

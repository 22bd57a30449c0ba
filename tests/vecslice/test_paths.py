"""Tests for vecslice.paths: Paths and LayerPaths views, construction and errors."""

from __future__ import annotations

import numpy as np
import pytest

import vecslice as vs
from vecslice import InputIndexError, InputTypeError, InputValueError, LayerPaths, Paths

TRI = [[0, 0], [10, 0], [0, 10]]
SQ = [[0, 0], [10, 0], [10, 10], [0, 10]]


def two_rings():
    return Paths(TRI + SQ, [0, 3, 7])


def test_ring_negative_indices_count_from_the_end():
    """Issue 8 B6: ring(-1) returned an empty array."""
    p = two_rings()
    assert p.ring(-1).tolist() == SQ
    assert p.ring(-2).tolist() == TRI
    assert p.ring(1).tolist() == SQ
    assert [r.shape[0] for r in p.rings()] == [3, 4]


@pytest.mark.parametrize(
    ("i", "exc", "fragment"),
    [
        (2, InputIndexError, r"`i` must be a ring index in \[-2, 2\); got 2"),
        (-3, InputIndexError, r"`i` must be a ring index in \[-2, 2\); got -3"),
        (np.int64(5), InputIndexError, r"in \[-2, 2\); got 5$"),
        (0.5, InputTypeError, "`i` must be an integer ring index; got float 0.5"),
        ("0", InputTypeError, "`i` must be an integer ring index; got str '0'"),
        (True, InputTypeError, "got bool True"),
    ],
)
def test_ring_index_errors(i, exc, fragment):
    with pytest.raises(exc, match=fragment) as info:
        two_rings().ring(i)
    builtin = IndexError if exc is InputIndexError else TypeError
    assert isinstance(info.value, builtin) and isinstance(info.value, vs.VecsliceError)


def test_ring_of_empty_paths_is_an_index_error():
    with pytest.raises(IndexError, match=r"in \[0, 0\); got 0"):
        Paths(np.empty((0, 2), np.int64), [0]).ring(0)


def test_from_rings_builds_the_layout():
    p = Paths.from_rings([TRI, np.array(SQ, np.int32), [], np.empty((0, 2), int)])
    assert p.ring_offsets.tolist() == [0, 3, 7, 7, 7]
    assert p.coords.dtype == np.int64 and p.ring(1).tolist() == SQ
    assert Paths.from_rings([]).n_rings == 0
    assert Paths.from_rings(iter([TRI])).n_rings == 1


@pytest.mark.parametrize(
    ("rings", "exc", "fragment"),
    [
        # Issue 8 B7: 3-column rings were silently reshaped into garbage
        ([TRI, [[0, 0, 1], [5, 0, 1], [0, 5, 1]]], InputValueError,
         r"`rings\[1\]` must have shape \(N, 2\); got shape \(3, 3\)"),
        ([[0, 0, 10, 0, 0, 10]], InputValueError,
         r"`rings\[0\]` must have shape \(N, 2\); got shape \(6,\)"),
        ([[[0.5, 0], [1, 0], [0, 1]]], InputTypeError,
         r"`rings\[0\]` must be integer microns; got dtype float64"),
        ([TRI, [[2**30, 0], [0, 0], [0, 1]]], InputValueError,
         r"`rings\[1\]` must satisfy \|value\| < 2\*\*30"),
        # Issue 8 C3: raw TypeError
        (None, InputTypeError, "`rings` must be a sequence of .* got NoneType"),
        (5, InputTypeError, "got int"),
        ("abc", InputTypeError, "got str"),
        ([None], InputTypeError, r"`rings\[0\]` must be an integer array"),
    ],
)  # fmt: skip
def test_from_rings_errors_name_the_ring(rings, exc, fragment):
    with pytest.raises(exc, match=fragment):
        Paths.from_rings(rings)


def layered():
    return LayerPaths(TRI + SQ, [0, 3, 7], [0, 1, 1, 2])


def test_layer_views_and_negative_layers():
    lp = layered()
    assert [r.tolist() for r in lp.layer(0)] == [TRI]
    assert lp.layer(1) == []
    assert [r.tolist() for r in lp.layer(-1)] == [SQ]
    assert [r.tolist() for r in lp.layer(np.int32(2))] == [SQ]


@pytest.mark.parametrize(
    ("k", "exc", "fragment"),
    [
        # Issue 8 C3: layer(0.5) and layer('0') raised raw builtins
        (0.5, InputTypeError, "`k` must be an integer layer index; got float 0.5"),
        ("0", InputTypeError, "`k` must be an integer layer index; got str '0'"),
        (None, InputTypeError, "got NoneType None"),
        (3, InputIndexError, r"`k` must be a layer index in \[-3, 3\); got 3"),
        (-4, InputIndexError, r"got -4"),
    ],
)
def test_layer_index_errors(k, exc, fragment):
    with pytest.raises(exc, match=fragment):
        layered().layer(k)


@pytest.mark.parametrize(
    ("call", "exc", "fragment"),
    [
        # Issue 8 C3: raw builtins from the constructor and empty()
        (lambda: LayerPaths(TRI, [0, 3], [0, 1], open=[1, 2]), InputTypeError,
         "`open` must be a vecslice.LayerPaths or None; got list"),
        (lambda: LayerPaths.empty(1.5), InputTypeError,
         "`n_layers` must be an integer number of layers; got float 1.5"),
        (lambda: LayerPaths.empty("3"), InputTypeError, "`n_layers` must be"),
        (lambda: LayerPaths.empty(-1), InputValueError, "`n_layers` must be >= 0"),
        (lambda: LayerPaths(TRI, [0, 3], [0, 1], open=LayerPaths.empty(2)),
         vs.LayoutError, "`open` must have 1 layers; got 2"),
    ],
)  # fmt: skip
def test_layer_paths_argument_errors(call, exc, fragment):
    with pytest.raises(exc, match=fragment):
        call()


def test_empty_and_paths():
    e = LayerPaths.empty(3)
    assert e.n_layers == 3 and e.n_rings == 0 and e.layer(-1) == []
    assert LayerPaths.empty(np.int64(0)).n_layers == 0
    lp = layered()
    p = lp.paths()
    assert isinstance(p, Paths) and p.coords is lp.coords  # shared, no copy
    assert p.ring_lengths().tolist() == [3, 4]


def test_layer_area2_near_the_int64_limit_is_exact_or_refused():
    x = 2**30 - 1
    square = np.array([[-x, -x], [x, -x], [x, x], [-x, x]])
    one = vs.LayerPaths(square, [0, 4], [0, 1])
    assert one.layer_area2().tolist() == [2 * (2 * x) ** 2]  # just below 2**63
    two = vs.LayerPaths(np.vstack([square, square]), [0, 4, 8], [0, 2])
    with pytest.raises(vs.InputValueError, match="twice the area of layer 0 must fit"):
        two.layer_area2()  # it used to wrap around to a negative area


def test_raw_area_of_overlapping_huge_rings_does_not_wrap():
    from vecslice.metrics import simplification_errors

    x = 2**30 - 1
    square = np.array([[-x, -x], [x, -x], [x, x], [-x, x]])
    raw = vs.LayerPaths(np.vstack([square, square]), [0, 4, 8], [0, 2])
    err, _ = simplification_errors(raw)
    assert err.raw_area_um2.tolist() == [float(2 * (2 * x) ** 2)]


def test_area2_of_a_ring_wound_twice_near_the_limit_is_refused():
    # audit s24 D6: its twice-area (about 2**64) wrapped around in int64
    x = 2**30 - 1
    square = [[-x, -x], [x, -x], [x, x], [-x, x]]
    twice = np.array(square * 2)
    with pytest.raises(vs.InputValueError, match=r"twice the signed area of ring 0 "
                       r"must fit int64 \(\|value\| < 2\*\*63\); got "
                       r"18446744039349813264 µm² \(a ring that winds around more "
                       "than once near the coordinate limit\\)"):
        vs.Paths(twice, [0, 8]).area2()
    lp = vs.LayerPaths(np.vstack([square, twice[::-1]]), [0, 4, 12], [0, 1, 2])
    with pytest.raises(vs.InputValueError, match=r"ring 1 \(layer 1\) must fit int64"
                       r".*got -18446744039349813264 µm²"):
        lp.area2()
    with pytest.raises(vs.InputValueError, match=r"ring 1 \(layer 1\) must fit"):
        lp.layer_area2()
    assert vs.Paths(np.array(square), [0, 4]).area2().tolist() == [2 * (2 * x) ** 2]


def _ragged_arrays():
    c = np.array(TRI + SQ, np.int64)
    return c, np.array([0, 3, 7], np.int64), np.array([0, 1, 1, 2], np.int64)


@pytest.mark.parametrize(("make", "which", "index", "value", "fragment"), [
    (lambda c, r, lo: Paths(c, r), "c", (4, 0), 2**30,
     r"`coords` must satisfy \|value\| < 2\*\*30 µm .*got 1073741824 at row 4"),
    (lambda c, r, lo: Paths(c, r), "r", 1, 10**12,
     r"`ring_offsets` decreases at index 1: 1000000000000 > 7"),
    (lambda c, r, lo: LayerPaths(c, r, lo), "c", (0, 1), -(2**30),
     r"`coords` must satisfy \|value\| < 2\*\*30 µm .*got -1073741824 at row 0"),
    (lambda c, r, lo: LayerPaths(c, r, lo), "r", 1, 10**12,
     r"`ring_offsets` decreases at index 1"),
    (lambda c, r, lo: LayerPaths(c, r, lo), "lo", 2, -1,
     r"`layer_offsets` decreases at index 1: 1 > -1"),
])  # fmt: skip
def test_containers_check_the_copies_they_keep(write_when_copied, make, which, index,
                                               value, fragment):
    """Audit s26 state D2: Paths and LayerPaths checked the caller's arrays, then
    copied them; a write by another thread in between was kept unchecked (ring
    kernels then read out of bounds). The write lands just before the copy here."""
    c, r, lo = _ragged_arrays()
    writes = write_when_copied({"c": c, "r": r, "lo": lo}[which], index, value)
    with pytest.raises(InputValueError, match=fragment):
        make(c, r, lo)
    assert writes == [index]


def test_from_rings_checks_the_copy_it_keeps(monkeypatch):
    """D2: from_rings checked each ring, then concatenated the rings (the copy):
    a write in between was kept. The write lands after the rings were taken."""
    import vecslice.paths as paths_module

    ring = np.array(SQ, np.int64)
    real = paths_module.offsets_from_lengths

    def racing(lens):
        ring[2, 1] = 2**30  # another thread, once every ring was taken
        return real(lens)

    monkeypatch.setattr(paths_module, "offsets_from_lengths", racing)
    with pytest.raises(InputValueError,
                       match=r"`rings\[1\]` must satisfy \|value\| < 2\*\*30 µm "
                             r".*got 1073741824 at row 2"):
        Paths.from_rings([TRI, ring])

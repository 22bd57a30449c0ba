import threading

import numpy as np
import pytest

import vecslice as vs
import vecslice.errorcache as ec
from vecslice.errorcache import ErrorCache
from vecslice.metrics import _compare_rings, contour_errors
from vecslice.paths import LayerPaths
from vecslice.pipeline import _clean_closed

FIELDS = ("raw_to_simplified_um", "simplified_to_raw_um", "xor_area_um2", "linear",
          "ring_layer", "raw_area_um2")
SETTINGS = (vs.SliceSettings(max_resolution=500, max_deviation=10),
            vs.SliceSettings(max_resolution=1000, max_deviation=10),
            vs.SliceSettings(max_resolution=2000, max_deviation=50))


@pytest.fixture(scope="module")
def raw(meshes_dir):
    mesh = vs.load_mesh(meshes_dir / "3DBenchy.3mf")
    loops = vs.slice_contours(mesh, np.arange(300, 48000, 1500))
    return LayerPaths._trusted(loops.coords, loops.ring_offsets, loops.layer_offsets)


@pytest.fixture(scope="module")
def simplified(raw):
    return [_clean_closed(raw, s) for s in SETTINGS]


def _same(got, coords, offsets, raw):
    want = contour_errors(raw, LayerPaths._trusted(coords, offsets,
                                                   raw.layer_offsets.copy()))
    for f in FIELDS:
        assert np.array_equal(getattr(got, f), getattr(want, f), equal_nan=True), f


def test_repeated_rings_take_the_errors_measured_before(raw, simplified):
    cache = ErrorCache(raw)
    n = raw.n_rings
    (c0, o0), (c1, o1), (c2, o2) = simplified
    _same(cache.errors(c0, o0), c0, o0, raw)
    assert (cache.measured, cache.reused) == (n, 0)
    # the same rings again (fresh arrays): every pair is reused
    _same(cache.errors(c0.copy(), o0.copy()), c0, o0, raw)
    assert (cache.measured, cache.reused) == (n, n)
    # other settings: the rings that came out the same are reused, the rest
    # measured, and the numbers are those of measuring everything
    same = [np.array_equal(c0[o0[r]:o0[r + 1]], c1[o1[r]:o1[r + 1]])
            for r in range(n)]
    assert 0 < sum(same) < n
    _same(cache.errors(c1, o1), c1, o1, raw)
    assert cache.reused == n + sum(same)
    _same(cache.errors(c2, o2), c2, o2, raw)
    assert cache.measured + cache.reused == 4 * n


def test_shared_keys_are_confirmed_not_trusted(raw, simplified, monkeypatch):
    # every ring gets the same key: only confirmed pairs are reused
    monkeypatch.setattr(ec, "ring_keys",
                        lambda coords, offsets: np.zeros(len(offsets) - 1, np.int64))
    cache = ErrorCache(raw)
    for coords, offsets in (*simplified, *simplified):
        _same(cache.errors(coords, offsets), coords, offsets, raw)
    assert cache.reused > 0


def test_nothing_is_held_beyond_max_vertices(raw, simplified):
    (c0, o0), _, _ = simplified
    cache = ErrorCache(raw, max_vertices=c0.shape[0] - 1)
    for _ in range(2):
        _same(cache.errors(c0, o0), c0, o0, raw)
    assert cache.reused == 0 and cache.measured == 2 * raw.n_rings


def test_calls_from_threads_at_once(raw, simplified):
    cache = ErrorCache(raw)
    got = {}

    def measure(i):
        coords, offsets = simplified[i % 3]
        got[i] = cache.errors(coords, offsets, threads=1)

    threads = [threading.Thread(target=measure, args=(i,)) for i in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for i, errors in got.items():
        _same(errors, *simplified[i % 3], raw)
    assert cache.measured + cache.reused == 6 * raw.n_rings


def test_compare_rings_of_some_rings(raw, simplified):
    (coords, offsets), _, _ = simplified
    full = _compare_rings(raw.coords, raw.ring_offsets, coords, offsets)
    some = np.arange(0, raw.n_rings, 3)
    part = _compare_rings(raw.coords, raw.ring_offsets, coords, offsets, 1,
                          rings=some)
    rest = np.setdiff1d(np.arange(raw.n_rings), some)
    for a, b in zip(full, part, strict=True):
        assert np.array_equal(a[some], b[some], equal_nan=True)
    assert np.isnan(part[0][rest]).all() and not part[3][rest].any()

import math

import numpy as np
import pytest

import vecslice as vs
from conftest import load_testdata
from vecslice.simplify import remove_degenerate_vertices, ring_perimeters, simplify

VECTORS = load_testdata("cura_simplify_vectors.json")


def _vsize(dx, dy):
    return round(math.sqrt(float(dx * dx + dy * dy)))  # llrint: half to even


def _closest_on_closed_boundary(p, poly):
    """Closest point (rounded to integers) of closed polygon ``poly`` to ``p``."""
    best, best_d2 = None, math.inf
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        abx, aby = b[0] - a[0], b[1] - a[1]
        l2 = abx * abx + aby * aby
        t = 0.0 if l2 == 0 else ((p[0] - a[0]) * abx + (p[1] - a[1]) * aby) / l2
        t = min(1.0, max(0.0, t))
        q = (round(a[0] + t * abx), round(a[1] + t * aby))
        d2 = (q[0] - p[0]) ** 2 + (q[1] - p[1]) ** 2
        if d2 < best_d2:
            best, best_d2 = q, d2
    return best


def _check(check, vec, out):
    inp = vec["input"]
    kind = check["type"]
    if kind == "equals_input":
        assert out == inp
    elif kind == "equals_expected_output":
        assert out == vec["expected_output"]
    elif kind == "size_eq":
        assert len(out) == check["value"]
    elif kind == "segment_lengths_ge":
        n = len(out)
        last = {"n-1": n - 1, "n": n}[check["last_index_exclusive"]]
        for i in range(check["first_index"], last):
            d = _vsize(out[i][0] - out[i - 1][0], out[i][1] - out[i - 1][1])
            assert d >= check["value"], (i, d)
    elif kind == "tail_unchanged":
        k = 0
        while len(inp) - 1 - k >= check["min_input_index"]:
            assert out[len(out) - 1 - k] == inp[len(inp) - 1 - k], k
            k += 1
    elif kind == "long_segment_start_points_within":
        for i in range(len(inp) - 1):
            a, b = inp[i], inp[i + 1]
            if _vsize(b[0] - a[0], b[1] - a[1]) > vec["max_resolution"]:
                q = _closest_on_closed_boundary(a, out)
                assert _vsize(q[0] - a[0], q[1] - a[1]) <= check["value"], i
    elif kind == "vertices_within_distance_of_other_boundary":
        assert check["direction"] == "both"
        for src, dst in ((inp, out), (out, inp)):
            for p in src:
                q = _closest_on_closed_boundary(p, dst)
                assert _vsize(q[0] - p[0], q[1] - p[1]) <= check["value"], p
    else:
        pytest.fail(f"unknown check type {kind}")


@pytest.mark.parametrize("vec", VECTORS, ids=lambda v: v["name"])
def test_vector_through_public_api(vec):
    out = simplify(np.array(vec["input"], dtype=np.int64).reshape(-1, 2),
                   max_resolution=vec["max_resolution"],
                   max_deviation=vec["max_deviation"],
                   max_area_deviation=vec["max_area_deviation"],
                   closed=vec["kind"] == "polygon")
    assert out.dtype == np.int64 and out.ndim == 2 and out.shape[1] == 2
    got = out.tolist()
    assert got == vec["expected_output"]
    checks = vec["expectation"]["checks"]
    assert checks
    for check in checks:
        _check(check, vec, got)


def test_every_check_type_is_understood():
    kinds = {c["type"] for v in VECTORS for c in v["expectation"]["checks"]}
    assert kinds == {
        "equals_input", "equals_expected_output", "size_eq", "segment_lengths_ge",
        "tail_unchanged", "long_segment_start_points_within",
        "vertices_within_distance_of_other_boundary",
    }


def test_all_vectors_in_one_paths_call():
    """Polygons and polylines batched into Paths give the per-vector results."""
    for closed in (True, False):
        vecs = [v for v in VECTORS if (v["kind"] == "polygon") == closed
                and v["max_resolution"] == 1000 and v["max_deviation"] == 100]
        paths = vs.Paths.from_rings([np.array(v["input"]).reshape(-1, 2)
                                     for v in vecs])
        out = vs.simplify(paths, max_resolution=1000, max_deviation=100,
                          max_area_deviation=20000, closed=closed)
        assert isinstance(out, vs.Paths)
        want = [v["expected_output"] for v in vecs if v["expected_output"]]
        assert [r.tolist() for r in out.rings()] == want


def test_paths_in_paths_out_drops_empty_results():
    p = vs.Paths([[0, 0], [10, 0], [0, 10], [0, 0], [2, 0], [0, 2]], [0, 3, 6])
    out = vs.simplify(p)
    assert isinstance(out, vs.Paths)
    assert out.ring_offsets.tolist() == [0, 3]
    assert not out.coords.flags.writeable


def test_array_in_array_out_possibly_empty():
    out = simplify([[0, 0], [4, 0]], closed=False)
    assert out.shape == (0, 2) and out.dtype == np.int64
    out = simplify(np.empty((0, 2), np.int64))
    assert out.shape == (0, 2)


def test_accepts_other_integer_dtypes_and_read_only_arrays():
    a = np.array([[0, 0], [500, 3], [1000, 0], [1000, 1000], [0, 1000]], np.int32)
    a.flags.writeable = False
    assert simplify(a).tolist() == [[0, 0], [1000, 0], [1000, 1000], [0, 1000]]


def test_widths_round_trip():
    coords = [[0, 0], [1000, 0], [3000, 0]]
    out, w = simplify(coords, closed=False, widths=[400, 600, 600])
    assert out.tolist() == coords and w.tolist() == [400, 600, 600]
    out, w = simplify(coords, closed=False, widths=[400, 400, 400])
    assert out.tolist() == [[0, 0], [3000, 0]] and w.tolist() == [400, 400]
    p = vs.Paths(coords, [0, 3])
    out, w = simplify(p, closed=False, widths=[400, 401, 400])
    assert isinstance(out, vs.Paths) and len(w) == out.coords.shape[0]


def test_public_name_and_signature():
    assert "simplify" in vs.__all__ and vs.simplify is simplify
    import inspect

    sig = inspect.signature(vs.simplify)
    assert {k: v.default for k, v in sig.parameters.items() if k != "paths"} == {
        "max_resolution": 500, "max_deviation": 25, "max_area_deviation": 50000,
        "closed": True, "widths": None,
    }
    assert all(sig.parameters[k].kind is inspect.Parameter.KEYWORD_ONLY
               for k in sig.parameters if k != "paths")


def test_ring_perimeters_public():
    p = vs.Paths([[0, 0], [3, 0], [3, 4], [0, 0], [1, 1]], [0, 3, 5])
    got = ring_perimeters(p)
    assert got.dtype == np.int64 and got.tolist() == [12, 2]


def test_remove_degenerate_vertices_public():
    p = vs.Paths([[0, 0], [10, 0], [20, 0], [10, 0], [10, 10],
                  [0, 0], [10, 0], [0, 0]], [0, 5, 8])
    out = remove_degenerate_vertices(p)
    assert isinstance(out, vs.Paths)
    assert [r.tolist() for r in out.rings()] == [[[0, 0], [10, 0], [10, 10]]]


SQ = [[0, 0], [10, 0], [10, 10]]


@pytest.mark.parametrize(("kwargs", "error", "fragment"), [
    ({"paths": [[0.0, 0.5], [1.0, 0.0], [0.0, 1.0]]}, vs.InputTypeError,
     r"`paths` must be integer microns; got dtype float64\. Convert millimetres"),
    ({"paths": "abc"}, vs.InputTypeError, r"`paths` must be an integer array"),
    ({"paths": None}, vs.InputTypeError, r"`paths` must be an integer array"),
    ({"paths": [[0, 0], [1, 2, 3]]}, vs.InputTypeError, r"`paths`"),
    ({"paths": [0, 1, 2]}, vs.InputValueError, r"`paths` must have shape \(N, 2\)"),
    ({"paths": [[0, 0, 0]]}, vs.InputValueError, r"`paths` must have shape \(N, 2\)"),
    ({"paths": [[0, 0], [2**30, 0]]}, vs.InputValueError,
     r"`paths` must satisfy \|value\| < 2\*\*30.*got 1073741824 at row 1"),
    ({"paths": [[0, -(2**30)]]}, vs.InputValueError, r"got -1073741824 at row 0"),
    ({"max_resolution": -1}, vs.SettingsError,
     r"`max_resolution` must be >= 0; got -1"),
    ({"max_deviation": -5}, vs.SettingsError, r"`max_deviation` must be >= 0; got -5"),
    ({"max_deviation": 2**31}, vs.SettingsError,
     r"`max_deviation` must be <= 2147483647; got 2147483648"),
    ({"max_area_deviation": -1}, vs.SettingsError,
     r"`max_area_deviation` must be >= 0; got -1"),
    ({"max_resolution": 0.5}, vs.InputTypeError,
     r"`max_resolution` must be an integer number of µm; got float 0\.5"),
    ({"max_deviation": "25"}, vs.InputTypeError, r"`max_deviation` must be an integer"),
    ({"max_deviation": True}, vs.InputTypeError, r"`max_deviation` must be an integer"),
    ({"closed": 1}, vs.InputTypeError, r"`closed` must be a bool; got 1"),
    ({"closed": "yes"}, vs.InputTypeError, r"`closed` must be a bool; got 'yes'"),
    ({"widths": [1, 2]}, vs.LayoutError,
     r"`widths` must have one entry per vertex \(3\); got 2"),
    ({"widths": [1.0, 2.0, 3.0]}, vs.InputTypeError, r"`widths` must be integer"),
    ({"widths": [[1, 2, 3]]}, vs.InputValueError, r"`widths` must have shape \(N\)"),
    ({"widths": [400, -1, 400]}, vs.InputValueError,
     r"`widths` must satisfy 0 <= width < 2\*\*30 µm; got -1 at index 1"),
])
def test_bad_input(kwargs, error, fragment):
    args = {"paths": SQ, **kwargs}
    paths = args.pop("paths")
    with pytest.raises(error, match=fragment):
        simplify(paths, **args)


@pytest.mark.parametrize("fn", [ring_perimeters, remove_degenerate_vertices])
def test_helpers_want_paths(fn):
    with pytest.raises(vs.InputTypeError, match=r"`paths` must be a vecslice.Paths"):
        fn(np.zeros((3, 2), np.int64))


def test_errors_are_builtin_subclasses():
    with pytest.raises(TypeError):
        simplify(SQ, closed=None)
    with pytest.raises(ValueError):
        simplify(SQ, max_resolution=-1)


@pytest.mark.parametrize("closed", [True, False])
@pytest.mark.parametrize("with_widths", [False, True])
def test_threaded_simplify_rings_matches_the_serial_kernel(monkeypatch, closed,
                                                           with_widths):
    import sys

    from vecslice._kernels.simplify import simplify_rings as kernel
    from vecslice._kernels.simplify import simplify_rings_w as kernel_w
    from vecslice._threads import chunk_bounds

    vsimp = sys.modules["vecslice.simplify"]  # vs.simplify is the function
    # many small chunks on two threads, whatever the machine's thread count
    monkeypatch.setattr(vsimp, "chunk_bounds",
                        lambda offs: chunk_bounds(offs, threads=2, min_chunk=200))
    rng = np.random.default_rng(11)
    lengths = rng.integers(0, 120, 400)
    offs = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    ang = rng.uniform(0, 2 * np.pi, offs[-1])
    coords = np.stack([np.rint(3000 * np.cos(ang)) + rng.integers(-40, 41, ang.size),
                       np.rint(3000 * np.sin(ang))], 1).astype(np.int64)
    coords = coords[np.lexsort((ang, np.repeat(np.arange(400), lengths)))]
    assert len(chunk_bounds(offs, threads=2, min_chunk=200)) > 3
    if with_widths:
        w = rng.integers(300, 500, offs[-1]).astype(np.int64)
        got = vsimp.simplify_rings(coords, offs, closed, 500, 25, 2000, widths=w)
        want = kernel_w(coords, w, offs, closed, 500, 25, 2000)
    else:
        got = vsimp.simplify_rings(coords, offs, closed, 500, 25, 50000)
        want = kernel(coords, offs, closed, 500, 25, 50000)
    assert len(got) == len(want)
    assert np.diff(want[-1]).min() == 0 and want[-1][-1] < offs[-1]  # some removed
    for g, x in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, x)


def test_a_vertex_moved_beyond_the_coordinate_limit_is_refused():
    """The short-edge rule can place an intersection up to max_deviation away:
    near the limit that used to give coordinates vs.Paths itself refuses."""
    x = 2**30 - 1
    ring = np.array([[-x, 1250], [0, 0], [x, 1000], [x, 1500], [0, 2500]])
    with pytest.raises(vs.InputValueError, match=r"`max_deviation` \(1073741824 µm\)"
                       r" let the simplification move a vertex to 1342177280 µm"):
        simplify(vs.Paths(ring, [0, 5]), max_resolution=600, max_deviation=2**30)
    # the same ring away from the limit simplifies, and stays in range
    out = simplify(vs.Paths(ring // 4, [0, 5]), max_resolution=600,
                   max_deviation=2**30)
    assert np.abs(out.coords).max() < 2**30


def test_a_layer_container_gets_a_hint_not_a_dtype_message():
    """Audit s25 api D3: ``simplify(loops)`` said "integer microns; got dtype
    object"."""
    loops = vs.slice_contours(vs.demo_mesh(), [2000])
    with pytest.raises(vs.InputTypeError,
                       match=r"`paths` must be a vecslice.Paths or an \(n, 2\) integer "
                             r"array; got LayerPaths .*simplify\(loops.paths\(\)\).*"
                             r"vs.clean_loops"):
        vs.simplify(loops)
    assert vs.simplify(loops.paths()).n_rings == loops.n_rings


def test_simplify_checks_the_copy_it_simplifies(write_when_copied):
    """Audit s26 state D2: an array passed to simplify was range-checked in the
    caller's memory, which the kernel then read: a write by another thread in
    between reached the kernel unchecked. The write lands just before the copy."""
    coords = np.array([[0, 0], [500, 3], [1000, 0], [1000, 1000]], np.int64)
    writes = write_when_copied(coords, (1, 0), 2**30)
    with pytest.raises(vs.InputValueError,
                       match=r"`paths` must satisfy \|value\| < 2\*\*30 .* at row 1"):
        simplify(coords)
    assert writes == [(1, 0)]
    widths = np.array([400, 600, 600, 400], np.int64)
    writes = write_when_copied(widths, 2, -1)
    with pytest.raises(vs.InputValueError,
                       match=r"`widths` must satisfy 0 <= width < 2\*\*30 µm; got -1 "
                             r"at index 2"):
        simplify(vs.Paths([[0, 0], [500, 3], [1000, 0]], [0, 3]), closed=False,
                 widths=widths[:3])
    assert writes == [(1, 0), 2]

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import reference_simplify as ref
from conftest import load_testdata
from vecslice._kernels.simplify import (
    remove_degenerate_vertices,
    ring_perimeters,
    simplify_rings,
    simplify_rings_w,
)

VECTORS = load_testdata("cura_simplify_vectors.json")
LIMIT = 2**30 - 1


def _run(coords, closed, res, dev, area):
    c = np.asarray(coords, dtype=np.int64).reshape(-1, 2)
    out, offs = simplify_rings(c, np.array([0, len(c)], np.int64), closed,
                               res, dev, area)
    assert offs.tolist() == [0, len(out)]
    return out


@pytest.mark.parametrize("vec", VECTORS, ids=lambda v: v["name"])
def test_vector_expected_output_exact(vec):
    out = _run(vec["input"], vec["kind"] == "polygon", vec["max_resolution"],
               vec["max_deviation"], vec["max_area_deviation"])
    assert out.tolist() == vec["expected_output"]


def test_all_27_vectors_present():
    assert len(VECTORS) == 27


# --------------------------------------------------------------------------
# hypothesis: kernel == reference


@st.composite
def paths(draw, max_len=14):
    scale = draw(st.sampled_from([6, 60, 1500, 30_000, LIMIT]))
    n = draw(st.one_of(st.integers(0, 4), st.integers(0, max_len)))
    pts = []
    for _ in range(n):
        kind = draw(st.integers(0, 5))
        if pts and kind == 0:  # duplicate point
            pts.append(pts[-1])
        elif len(pts) >= 2 and kind == 1:  # continue collinearly
            p = (2 * pts[-1][0] - pts[-2][0], 2 * pts[-1][1] - pts[-2][1])
            if max(abs(p[0]), abs(p[1])) > LIMIT:
                p = pts[-1]
            pts.append(p)
        elif pts and kind == 2:  # small step
            d = draw(st.tuples(st.integers(-40, 40), st.integers(-40, 40)))
            p = (pts[-1][0] + d[0], pts[-1][1] + d[1])
            if max(abs(p[0]), abs(p[1])) > LIMIT:
                p = pts[-1]
            pts.append(p)
        else:
            c = st.integers(-scale, scale)
            pts.append(draw(st.tuples(c, c)))
    return pts


params = st.fixed_dictionaries({
    "closed": st.booleans(),
    "res": st.sampled_from([0, 5, 100, 500, 1000, 10**6, 2**31 - 1]),
    "dev": st.sampled_from([0, 5, 25, 100, 10**4, 10**6]),
    "area": st.sampled_from([0, 1000, 50000, 10**9]),
})


def _ragged(rings):
    lens = [len(r) for r in rings]
    offs = np.zeros(len(rings) + 1, np.int64)
    np.cumsum(lens, out=offs[1:])
    pts = [p for r in rings for p in r]
    return np.array(pts, np.int64).reshape(-1, 2), offs


def _rings_of(coords, offs):
    return [coords[offs[i]:offs[i + 1]].tolist() for i in range(len(offs) - 1)]


@given(st.lists(paths(), min_size=1, max_size=4), params)
def test_kernel_matches_reference(rings, p):
    coords, offs = _ragged(rings)
    out, new_offs = simplify_rings(coords, offs, p["closed"], p["res"], p["dev"],
                                   p["area"])
    want = [ref.simplify(r, closed=p["closed"], max_resolution=p["res"],
                         max_deviation=p["dev"], max_area_deviation=p["area"])
            for r in rings]
    assert _rings_of(out, new_offs) == want


@st.composite
def paths_with_widths(draw):
    pts = draw(paths())
    base = draw(st.sampled_from([0, 1, 400]))
    ws = [base + draw(st.sampled_from([0, 1, 2, 50, 300, 5000])) for _ in pts]
    return pts, ws


@given(st.lists(paths_with_widths(), min_size=1, max_size=3), params)
def test_width_kernel_matches_reference(cases, p):
    rings = [c[0] for c in cases]
    coords, offs = _ragged(rings)
    widths = np.array([w for c in cases for w in c[1]], np.int64)
    out, out_w, new_offs = simplify_rings_w(coords, widths, offs, p["closed"],
                                            p["res"], p["dev"], p["area"])
    got = [[[*xy, w] for xy, w in zip(out[a:b].tolist(), out_w[a:b].tolist(),
                                       strict=True)]
           for a, b in zip(new_offs[:-1], new_offs[1:], strict=True)]
    want = [ref.simplify(pts, closed=p["closed"], max_resolution=p["res"],
                         max_deviation=p["dev"], max_area_deviation=p["area"],
                         widths=ws)
            for pts, ws in cases]
    assert got == want


def _noisy_ring(rng, n, radius, noise):
    a = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = radius + rng.integers(-noise, noise + 1, n)
    return np.stack([np.rint(r * np.cos(a)), np.rint(r * np.sin(a))], 1).astype(
        np.int64)


@pytest.mark.parametrize("closed", [True, False])
def test_noisy_rings_match_reference(closed):
    rng = np.random.default_rng(20240611)
    rings = [_noisy_ring(rng, int(rng.integers(3, 250)),
                         int(rng.integers(500, 200_000)), int(rng.integers(0, 60)))
             for _ in range(40)]
    coords, offs = _ragged([r.tolist() for r in rings])
    out, new_offs = simplify_rings(coords, offs, closed, 500, 25, 50000)
    want = [ref.simplify(r.tolist(), closed=closed) for r in rings]
    assert _rings_of(out, new_offs) == want


@pytest.mark.parametrize("closed", [True, False])
@pytest.mark.parametrize("dev", [0, 3, 25, 64, 65, 300])
def test_large_noisy_rings_match_reference(closed, dev):
    # long rings (several bitmap words per bucket), the bucket-queue boundary
    # (max_deviation 64 / 65) and the heap alone (300); widths too
    rng = np.random.default_rng(1000 + dev)
    rings = [_noisy_ring(rng, int(rng.integers(200, 1300)),
                         int(rng.integers(2_000, 60_000)), int(rng.integers(5, 80)))
             for _ in range(4)]
    coords, offs = _ragged([r.tolist() for r in rings])
    out, new_offs = simplify_rings(coords, offs, closed, 400, dev, 50000)
    want = [ref.simplify(r.tolist(), closed=closed, max_resolution=400,
                         max_deviation=dev) for r in rings]
    assert _rings_of(out, new_offs) == want
    widths = rng.integers(380, 420, len(coords)).astype(np.int64)
    out, out_w, new_offs = simplify_rings_w(coords, widths, offs, closed, 400, dev,
                                            2000)
    got = [[[*xy, w] for xy, w in zip(out[a:b].tolist(), out_w[a:b].tolist(),
                                       strict=True)]
           for a, b in zip(new_offs[:-1], new_offs[1:], strict=True)]
    want = [ref.simplify(r.tolist(), closed=closed, max_resolution=400,
                         max_deviation=dev, max_area_deviation=2000,
                         widths=widths[offs[k]:offs[k + 1]].tolist())
            for k, r in enumerate(rings)]
    assert got == want


def test_widths_change_the_result_where_area_deviation_is_large():
    # spec example: A=(0,0,w400) B=(1000,0,w600) C=(3000,0,w600): 134000 > 50000
    assert ref.area_deviation((0, 0, 400), (1000, 0, 600), (3000, 0, 600)) == 134000
    coords = np.array([[0, 0], [1000, 0], [3000, 0]], np.int64)
    offs = np.array([0, 3], np.int64)
    w = np.array([400, 600, 600], np.int64)
    out, out_w, _ = simplify_rings_w(coords, w, offs, False, 500, 25, 50000)
    assert out.tolist() == coords.tolist() and out_w.tolist() == [400, 600, 600]
    out, _ = simplify_rings(coords, offs, False, 500, 25, 50000)
    assert out.tolist() == [[0, 0], [3000, 0]]


def test_intersection_vertex_gets_mean_width():
    # micro_chamfer_100_replaced with widths. Vertices 1 and 2 tie at importance
    # 9801; vertex 1 goes first, its short edge is the one after it, so vertex 2
    # moves to (10100, 0) and gets tdiv(w[0] + w[2], 2) of vertex 1's neighbours.
    coords = np.array([[0, 0], [10000, 0], [10100, 100], [10100, 10000], [0, 10000]],
                      np.int64)
    w = np.array([500, 400, 401, 403, 400], np.int64)
    out, out_w, _ = simplify_rings_w(coords, w, np.array([0, 5], np.int64), True,
                                     1000, 100, 10**9)
    assert out.tolist() == [[0, 0], [10100, 0], [10100, 10000], [0, 10000]]
    assert out_w.tolist() == [500, (500 + 401) // 2, 403, 400]



# --------------------------------------------------------------------------
# properties


@given(st.lists(paths(), min_size=1, max_size=3), params)
def test_properties(rings, p):
    coords, offs = _ragged(rings)
    args = (p["closed"], p["res"], p["dev"], p["area"])
    out, new_offs = simplify_rings(coords, offs, *args)
    assert new_offs[0] == 0 and new_offs[-1] == len(out)
    assert np.all(np.diff(new_offs) >= 0)
    for r, ring in enumerate(rings):
        res = out[new_offs[r]:new_offs[r + 1]]
        # never more vertices than the input
        assert len(res) <= len(ring)
        if len(res):
            assert len(res) >= (3 if p["closed"] else 2)
            if not p["closed"]:  # polyline end points never move
                assert res[0].tolist() == list(ring[0])
                assert res[-1].tolist() == list(ring[-1])
    # idempotent: simplifying the result changes nothing (see the docstring of
    # vecslice.simplify.simplify for why this holds for CuraEngine's algorithm)
    again, again_offs = simplify_rings(out, new_offs, *args)
    assert again.tolist() == out.tolist()
    assert again_offs.tolist() == new_offs.tolist()


@pytest.mark.parametrize("vec", VECTORS, ids=lambda v: v["name"])
def test_vectors_are_idempotent(vec):
    args = (vec["kind"] == "polygon", vec["max_resolution"], vec["max_deviation"],
            vec["max_area_deviation"])
    once = _run(vec["input"], *args)
    assert _run(once, *args).tolist() == once.tolist()


def test_explicitly_closed_input_loses_its_duplicate():
    sq = [[0, 0], [1000, 0], [1000, 1000], [0, 1000], [0, 0]]
    out = _run(sq, True, 500, 25, 50000).tolist()
    assert out == [[1000, 0], [1000, 1000], [0, 1000], [0, 0]]


def test_empty_and_tiny_rings():
    coords = np.array([[0, 0], [1, 1], [5, 0], [0, 0], [3, 0], [0, 4]], np.int64)
    offs = np.array([0, 0, 1, 3, 6], np.int64)  # empty, 1 vertex, segment, 3-4-5
    out, new_offs = simplify_rings(coords, offs, True, 500, 25, 50000)
    assert new_offs.tolist() == [0, 0, 0, 0, 3]
    assert out.tolist() == [[0, 0], [3, 0], [0, 4]]
    out, new_offs = simplify_rings(coords, offs, False, 500, 25, 50000)
    # open: the segment (1,1)-(5,0) has a squared side of 17 < 25: dropped; in
    # 3-4-5, (3,0) lies 3 from the line: removed, and (0,0)-(0,4) is too small
    assert new_offs.tolist() == [0, 0, 0, 0, 0]


def test_vertex_popped_in_two_passes_is_tracked_per_pass():
    # needs several passes: a vertex whose entry was popped in one pass and
    # enters the queue of a later one is "popped" there only after its pop
    ring = [[-3, 2], [1, -2], [-3, -2], [-1, -1], [-3, 0], [1, 1], [-2, -1],
            [-2, 0], [0, -2], [1, 2]]
    want = ref.simplify(ring, closed=True, max_resolution=2000, max_deviation=1,
                        max_area_deviation=5)
    assert want == [[-3, 2], [1, -2], [1, 2]]
    assert _run(ring, True, 2000, 1, 5).tolist() == want


@pytest.mark.parametrize("dev", [1, 2, 4])
def test_dense_tiny_rings_over_many_passes_match_reference(dev):
    # small coordinates and deviations: many passes, many stale entries
    rng = np.random.default_rng(77 + dev)
    rings = [(rng.integers(-4, 5, (int(rng.integers(3, 60)), 2))
              * int(rng.choice([1, 2, 5]))).tolist() for _ in range(150)]
    coords, offs = _ragged(rings)
    for closed in (True, False):
        out, new_offs = simplify_rings(coords, offs, closed, 2000, dev, 5)
        want = [ref.simplify(r, closed=closed, max_resolution=2000,
                             max_deviation=dev) for r in rings]
        assert _rings_of(out, new_offs) == want


def test_large_ring_with_all_vertices_collinear_terminates():
    n = 20_000
    coords = np.stack([np.arange(n), np.zeros(n, np.int64)], 1).astype(np.int64)
    out, offs = simplify_rings(coords, np.array([0, n], np.int64), True, 500, 25,
                               50000)
    assert len(out) <= 3


# --------------------------------------------------------------------------
# perimeters and degenerate vertices


@given(st.lists(paths(), min_size=0, max_size=4))
def test_ring_perimeters_match_reference(rings):
    coords, offs = _ragged(rings)
    assert ring_perimeters(coords, offs).tolist() == [ref.polygon_length(r)
                                                      for r in rings]


def test_ring_perimeters_examples():
    coords = np.array([[0, 0], [3, 0], [3, 4], [7, 7], [0, 0], [1, 1]], np.int64)
    offs = np.array([0, 3, 4, 4, 6], np.int64)
    assert ring_perimeters(coords, offs).tolist() == [12, 0, 0, 2]


@given(st.lists(paths(max_len=10), min_size=0, max_size=4))
def test_remove_degenerate_vertices_matches_reference(rings):
    coords, offs = _ragged(rings)
    out, new_offs = remove_degenerate_vertices(coords, offs)
    want = [ref.remove_degenerate_verts(r) for r in rings]
    assert _rings_of(out, new_offs) == [w if w is not None else [] for w in want]


@pytest.mark.parametrize(("ring", "want"), [
    ([[0, 0], [10, 0], [20, 0], [10, 0], [10, 10]], [[0, 0], [10, 0], [10, 10]]),
    ([[0, 0], [0, 0], [10, 0], [0, 10]], [[0, 0], [10, 0], [0, 10]]),  # zero edge
    ([[0, 0], [10, 0], [0, 0]], []),  # collapses: dropped
    ([[0, 0], [10, 0], [10, 10], [0, 10]], [[0, 0], [10, 0], [10, 10], [0, 10]]),
    # dot = -50 but vsize(5,5)**2 = 49: not degenerate; unchanged rings are kept
    ([[0, 0], [5, 5]], [[0, 0], [5, 5]]),
    # vsize(1,1) = 1 makes (0,9)->(0,0)->(1,1) and (1,1)->(0,0)->(9,0) "degenerate"
    ([[0, 0], [1, 1], [0, 0], [9, 0], [0, 9]], [[1, 1], [9, 0], [0, 9]]),
])
def test_remove_degenerate_vertices_examples(ring, want):
    coords, offs = _ragged([ring])
    out, new_offs = remove_degenerate_vertices(coords, offs)
    assert out.tolist() == want
    assert new_offs.tolist() == [0, len(want)]


# int64 overflow at the coordinate limit wraps, as the spec's int64 arithmetic
# does (numba's signed * and + would let LLVM assume it cannot happen)
_WRAP_CASES = [
    # the neighbours' line is 1 µm long: d = 3221224468, and d*d wraps negative
    ([(-1, 1073741822), (1073740823, -1073741822), (0, 1073741823)], 1000, 5),
    # a removal moves a vertex beyond 2**30; its edges' squared lengths wrap
    ([(-1073741822, 1073741822), (-3, 1073740823), (1073741822, -1073741822),
      (1073740823, -1073741822), (-1073740823, 1073740823)], 5000, 10000),
]


@pytest.mark.parametrize(("pts", "res", "dev"), _WRAP_CASES)
def test_overflow_wraps_as_the_reference(pts, res, dev):
    want = ref.simplify(pts, closed=False, max_resolution=res, max_deviation=dev)
    got = _run(np.array(pts, np.int64), False, res, dev, 50000)
    assert [list(map(int, q)) for q in got] == [list(q) for q in want]
    assert len(want) in (0, 2)  # the wrap decides: without it V is kept


def test_interpreted_kernel_gives_the_compiled_result(tmp_path):
    # NUMBA_DISABLE_JIT=1 (coverage runs) runs the kernel bodies as Python: the
    # bucket queue (max_deviation < 65) and the wrapping products must work there
    import json
    import subprocess
    import sys

    rng = np.random.default_rng(7)
    ang = np.sort(rng.uniform(0, 2 * np.pi, 300))
    rad = 20000 + rng.integers(-40, 41, 300)
    ring = np.rint(np.stack([rad * np.cos(ang), rad * np.sin(ang)], 1)).astype(np.int64)
    cases = [(ring.tolist(), True, 500, 25)]
    cases += [(p, False, r, d) for p, r, d in _WRAP_CASES]
    script = tmp_path / "interp.py"
    script.write_text(
        "import json, sys, warnings\nimport numpy as np\nimport vecslice as vs\n"
        "warnings.simplefilter('ignore')\n"
        "out = [vs.simplify(np.array(p, np.int64), closed=c, max_resolution=r,"
        " max_deviation=d).tolist() for p, c, r, d in json.load(sys.stdin)]\n"
        "print(json.dumps(out))\n")
    env = {**__import__("os").environ, "NUMBA_DISABLE_JIT": "1"}
    done = subprocess.run([sys.executable, str(script)], input=json.dumps(cases),
                          capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    got = json.loads(done.stdout)
    import vecslice as vs
    want = [vs.simplify(np.array(p, np.int64), closed=c, max_resolution=r,
                        max_deviation=d).tolist() for p, c, r, d in cases]
    assert got == want and len(want[0]) < 300

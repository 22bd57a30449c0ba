"""The neighbour side tests recorded by ``metrics._run`` against the former scans.

``pieces._neighbours_apart`` looks up side tests that ``metrics._run`` makes on
every vertex of a run in its one pass. Before, each call scanned the two runs
itself from their shared vertex and stopped early once the distance along a
monotone run's chord alone kept the rest on the right side (``reach``). These
tests rebuild both former scans in Python (with and without that shortcut) from
the kernels' run records and require the same booleans for every run.
"""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vecslice._kernels.metrics import _compare_one, _match
from vecslice._kernels.pieces import (
    _AP,
    _AQ,
    _GX,
    _GY,
    _H,
    _KIND,
    _NF,
    _NI,
    _P,
    _Q,
    _SCALE,
    _SIDE,
    _separator,
)
from vecslice._kernels.simplify import remove_degenerate_vertices, simplify_rings


def _old_direction(sc, m, v):
    """The former ``_neighbours_apart`` up to its side scans: (dx, dy, sigma)."""
    vb = v - 1 if v > 0 else m - 1
    va = v + 1 if v + 1 < m else 0
    ox, oy = int(sc[v, 0]), int(sc[v, 1])
    ux, uy = float(ox - int(sc[vb, 0])), float(oy - int(sc[vb, 1]))
    wx, wy = float(int(sc[va, 0]) - ox), float(int(sc[va, 1]) - oy)
    lu = math.sqrt(ux * ux + uy * uy)
    lw = math.sqrt(wx * wx + wy * wy)
    if lu == 0.0 or lw == 0.0:
        return None
    bx = ux / lu + wx / lw
    by = uy / lu + wy / lw
    lb = math.sqrt(bx * bx + by * by)
    if lb < 1e-6:
        return None
    dx = int(np.rint(-by / lb * _SCALE))
    dy = int(np.rint(bx / lb * _SCALE))
    sb = dx * (int(sc[vb, 1]) - oy) - dy * (int(sc[vb, 0]) - ox)
    sa = dx * (int(sc[va, 1]) - oy) - dy * (int(sc[va, 0]) - ox)
    if sb == 0 or sa == 0 or (sb > 0) == (sa > 0):
        return None
    return dx, dy, 1 if sb > 0 else -1


_SHORTCUTS = [0]  # scans the shortcut ended early (the real layers must have some)


def _old_one_side(rc, sc, wi, wf, t, at_q, o, d, sigma, shortcut):
    """The former ``_one_side``: every vertex v of run t has sigma * cross(d, v - o)
    >= 0, scanning from o; ``shortcut``: stop at ``reach`` as it did."""
    n, m = len(rc), len(sc)
    b = _NI * t
    p, q, ap, aq = (int(wi[b + i]) for i in (_P, _Q, _AP, _AQ))
    ox, oy = o
    dx, dy = d
    reach = math.inf
    ex = ey = 0
    if shortcut and wi[b + _KIND] == 1:
        far = q if not at_q else p
        ex, ey = int(sc[far, 0]) - ox, int(sc[far, 1]) - oy
        fd, fe = float(dx), float(dy)
        len_e = math.sqrt(float(ex * ex + ey * ey))
        a = sigma * (fd * float(ey) - fe * float(ex)) / len_e
        bb = abs(fd * float(ex) + fe * float(ey)) / len_e
        if a > 0.0:
            reach = wf[_NF * t + _H] * bb / a * len_e * (1.0 + 1e-9) + 1.0
    for i in range(aq - ap + 1):
        kk = aq - i if at_q else ap + i
        k = kk if kk < n else kk - n
        vx, vy = int(rc[k, 0]) - ox, int(rc[k, 1]) - oy
        if sigma * (dx * vy - dy * vx) < 0:
            return False
        if reach < math.inf and float(vx * ex + vy * ey) > reach:
            _SHORTCUTS[0] += i < aq - ap
            return True
    j = p + 1 if p + 1 < m else 0
    while j != q:
        if sigma * (dx * (int(sc[j, 1]) - oy) - dy * (int(sc[j, 0]) - ox)) < 0:
            return False
        j = j + 1 if j + 1 < m else 0
    return True


def _old_apart(rc, sc, wi, wf, t, npc, shortcut):
    tl = t - 1 if t > 0 else npc - 1
    v = int(wi[_NI * t + _P])
    sep = _old_direction(sc, len(sc), v)
    if sep is None:
        return False
    dx, dy, sigma = sep
    o = (int(sc[v, 0]), int(sc[v, 1]))
    return (_old_one_side(rc, sc, wi, wf, tl, True, o, (dx, dy), sigma, shortcut)
            and _old_one_side(rc, sc, wi, wf, t, False, o, (dx, dy), -sigma,
                              shortcut))


def _records(raw, simp):
    """(wi, wf, npc) of the ring pair after ``_compare_one``, or None when the
    pass over runs does not apply (no correspondence)."""
    n, m = len(raw), len(simp)
    size = n + m + 1
    anchor = np.empty(size, np.int64)
    if m == 0 or not _match(raw, 0, n, simp, 0, m, anchor):
        return None
    npc = int((anchor[:m] >= 0).sum())
    if npc < 2:
        return None
    wi = np.empty(_NI * size, np.int64)
    wf = np.empty(_NF * size, np.float64)
    _compare_one(raw, 0, n, simp, 0, m, anchor, wi, wf, np.empty(size),
                 np.empty((size, 4), np.int64))
    return wi, wf, npc


def _check_ring(raw, simp, seen):
    rec = _records(raw, simp)
    if rec is None:
        return
    wi, wf, npc = rec
    for t in range(npc):
        b = _NI * t
        sep = _old_direction(simp, len(simp), int(wi[b + _P]))
        want = (0, 0) if sep is None else (sep[0] * sep[2], sep[1] * sep[2])
        assert (wi[b + _GX], wi[b + _GY]) == want
        assert tuple(_separator(simp, 0, len(simp), wi[b + _P])) == want
        tl = t - 1 if t > 0 else npc - 1
        got = ((wi[b + _GX] != 0 or wi[b + _GY] != 0) and (wi[b + _SIDE] & 1) != 0
               and (wi[_NI * tl + _SIDE] & 2) != 0)
        full = _old_apart(raw, simp, wi, wf, t, npc, False)
        early = _old_apart(raw, simp, wi, wf, t, npc, True)
        assert got == full == early, (t, got, full, early)
        seen.add(bool(got))


@st.composite
def jagged_rings(draw):
    """An integer ring: a star polygon with fine jitter (or a self-crossing one)."""
    n = draw(st.integers(3, 40))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scale = draw(st.sampled_from([50, 1000, 30000]))
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    if draw(st.booleans()):
        ang = rng.permutation(ang)
    rad = scale * rng.uniform(0.5, 1.0, n)
    if draw(st.booleans()):
        rad = scale * (0.9 + 0.1 * rng.uniform(0, 1, n))
    pts = np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1)
    return np.rint(pts).astype(np.int64) + draw(st.integers(-10**6, 10**6))


@settings(max_examples=150)
@given(jagged_rings(), st.integers(0, 3000), st.integers(0, 400), st.integers(0, 39),
       st.integers(-200, 200), st.integers(-200, 200))
def test_recorded_side_tests_equal_the_former_scans(ring, max_res, max_dev, i, dx,
                                                    dy):
    offs = np.array([0, len(ring)])
    sc, so = simplify_rings(ring, offs, True, max_res, max_dev, 50000)
    sc, so = remove_degenerate_vertices(sc, so)
    _check_ring(ring, sc, set())
    if len(sc) > 2:  # a moved vertex, as the intersection rule makes
        moved = sc.copy()
        moved[i % len(sc)] += (dx, dy)
        _check_ring(ring, moved, set())


def test_recorded_side_tests_on_real_layers(meshes_dir):
    import vecslice as vs

    mesh = vs.load_mesh(meshes_dir / "3DBenchy.3mf")
    z, _, _ = vs.layer_heights(mesh, vs.SliceSettings(layer_height=3000))
    raw = vs.slice_contours(mesh, z)
    seen = set()
    _SHORTCUTS[0] = 0
    for res, dev in ((250, 10), (2000, 100)):
        sc, so = simplify_rings(raw.coords, raw.ring_offsets, True, res, dev, 50000)
        for r in range(raw.n_rings):
            _check_ring(raw.coords[raw.ring_offsets[r]:raw.ring_offsets[r + 1]],
                        sc[so[r]:so[r + 1]], seen)
    assert seen == {False, True} and _SHORTCUTS[0] > 100


@settings(max_examples=60)
@given(st.integers(4, 90), st.integers(0, 2**32 - 1), st.sampled_from([50, 400, 3000]))
def test_box_sweep_joins_every_overlapping_pair(npc, seed, size):
    # runs without a band (H = inf) are joined whenever they are not neighbours
    # and their boxes overlap: the sweep over boxes sorted by x0 (by insertion up
    # to 64 runs, numba's sort above) must find every such pair
    from vecslice._kernels.pieces import _X0, _X1, _Y0, _Y1, _find, _others_conflicts

    rng = np.random.default_rng(seed)
    x0 = rng.integers(-10000, 10000, npc)
    y0 = rng.integers(-10000, 10000, npc)
    x1 = x0 + rng.integers(0, size, npc)
    y1 = y0 + rng.integers(0, size, npc)
    wi = np.zeros(_NI * (2 * npc + 1), np.int64)
    wf = np.zeros(_NF * (npc + 1), np.float64)
    for t in range(npc):
        wi[_NI * t + _KIND] = 2
        wi[_NI * t + _X0], wi[_NI * t + _Y0] = x0[t], y0[t]
        wi[_NI * t + _X1], wi[_NI * t + _Y1] = x1[t], y1[t]
        wf[_NF * t + _H] = np.inf
    parent = np.arange(npc, dtype=np.int64)
    no_coords = np.zeros((1, 2), np.int64)
    if not _others_conflicts(no_coords, 0, 1, no_coords, 0, 1, wi, wf, parent, npc):
        return  # over its pair budget: the caller sweeps the whole ring instead
    want = np.arange(npc)  # brute force: every pair, then union-find

    def root(t):
        while want[t] != t:
            t = want[t]
        return t

    for i in range(npc):
        for j in range(i + 1, npc):
            if j - i in (1, npc - 1):
                continue
            if x0[j] > x1[i] or x0[i] > x1[j] or y0[j] > y1[i] or y0[i] > y1[j]:
                continue
            ri, rj = root(i), root(j)
            want[max(ri, rj)] = min(ri, rj)
    got = [_find(parent, t) for t in range(npc)]
    assert got == [root(t) for t in range(npc)]

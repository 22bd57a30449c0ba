import numba
import numpy as np
import pytest
import reference_stitch_quadratic
from hypothesis import given, settings
from hypothesis import strategies as st

import reference_stitch
from vecslice._kernels.stitch import stitch_chains

# the large inputs take minutes when kernels run as plain Python (coverage runs)
needs_jit = pytest.mark.skipif(numba.config.DISABLE_JIT,
                               reason="NUMBA_DISABLE_JIT=1: too slow as plain Python")


def _pack(layers):
    """Layers of chains of (x, y) -> coords, ring_offsets, layer_offsets."""
    pts, ro, lo = [], [0], [0]
    for chains in layers:
        for c in chains:
            pts.extend(c)
            ro.append(len(pts))
        lo.append(len(ro) - 1)
    coords = np.array(pts, dtype=np.int64).reshape(-1, 2)
    return coords, np.array(ro, dtype=np.int64), np.array(lo, dtype=np.int64)


def _unpack(coords, ring_offsets, layer_offsets):
    out = []
    for k in range(len(layer_offsets) - 1):
        out.append([
            [tuple(map(int, p)) for p in coords[ring_offsets[i] : ring_offsets[i + 1]]]
            for i in range(layer_offsets[k], layer_offsets[k + 1])
        ])
    return out


def _run(layers, g1=20, g2=10_000):
    """Kernel result as per layer (loops, open, n), checked against the reference."""
    coords, ro, lo = _pack(layers)
    out = _same_as_quadratic(coords, ro, lo, g1, g2)
    cc, cr, cl, oc, orr, ol, n = out
    for offs, below in ((cr, len(cc)), (orr, len(oc)), (cl, len(cr) - 1),
                        (ol, len(orr) - 1)):
        assert offs[0] == 0 and offs[-1] == below and (np.diff(offs) >= 0).all()
    assert len(cl) == len(ol) == len(lo) and len(n) == len(lo) - 1
    got = list(zip(_unpack(cc, cr, cl), _unpack(oc, orr, ol), n.tolist(), strict=True))
    assert got == [tuple(x) for x in reference_stitch.stitch(coords, ro, lo, g1, g2)]
    return got


def _same_as_quadratic(coords, ro, lo, g1, g2):
    """Kernel outputs, checked array by array against the pre-issue-8 kernel."""
    out = stitch_chains(coords, ro, lo, g1, g2)
    ref = reference_stitch_quadratic.stitch_chains(coords, ro, lo, g1, g2)
    for got, want in zip(out, ref, strict=True):
        assert got.dtype == want.dtype and np.array_equal(got, want)
    return out


def _rotations(ring):
    return [ring[i:] + ring[:i] for i in range(len(ring))]


# ---------------------------------------------------------------- strategies

def points(span):
    return st.tuples(st.integers(-span, span), st.integers(-span, span))


@st.composite
def cut_polygon(draw, reverse=False):
    """(polygon, pieces): a polygon of lattice points (spacing 100, plus a short
    edge < 20 µm at each gap cut) cut into shuffled pieces, cuts either sharing a
    vertex or leaving the short edge as the gap; optionally some pieces reversed."""
    n = draw(st.integers(3, 12))
    cells = draw(st.lists(st.tuples(st.integers(-20, 20), st.integers(-20, 20)),
                          min_size=n, max_size=n, unique=True))
    lattice = [(100 * x, 100 * y) for x, y in cells]
    cuts = sorted(draw(st.sets(st.integers(0, n - 1), min_size=1, max_size=n)))
    poly, starts = [], []  # starts: index in poly where a piece begins
    for i, p in enumerate(lattice):
        poly.append(p)
        if i in cuts:
            if draw(st.booleans()):  # shared vertex: next piece starts at p too
                starts.append(-(len(poly) - 1) - 1)
            else:
                d = draw(st.tuples(st.integers(-14, 14), st.integers(-14, 14))
                         .filter(lambda t: t != (0, 0)))
                poly.append((p[0] + d[0], p[1] + d[1]))
                starts.append(len(poly) - 1)
    m = len(poly)
    pieces = []
    for k, s in enumerate(starts):
        nxt = starts[(k + 1) % len(starts)]
        begin = -s - 1 if s < 0 else s
        end = -nxt - 1 if nxt < 0 else nxt - 1  # inclusive last index
        length = (end - begin) % m + 1
        if s < 0 and nxt == s:  # a single shared cut: the whole ring, p repeated
            length = m + 1
        pieces.append([poly[(begin + j) % m] for j in range(length)])
    order = draw(st.permutations(range(len(pieces))))
    pieces = [pieces[i] for i in order]
    if reverse:
        flips = draw(st.lists(st.booleans(), min_size=len(pieces),
                              max_size=len(pieces)))
        pieces = [p[::-1] if f else p for p, f in zip(pieces, flips, strict=True)]
    return poly, pieces


@st.composite
def random_layers(draw):
    """Layers of short chains in a small box (so gaps tie often), with duplicates,
    empty and 1-2 vertex chains and pieces of cut polygons mixed in."""
    layers = []
    point = points(draw(st.sampled_from([3, 40, 400])))
    for _ in range(draw(st.integers(0, 3))):
        chains = draw(st.lists(st.lists(point, min_size=0, max_size=5), max_size=10))
        if chains and draw(st.booleans()):
            chains += draw(st.lists(st.sampled_from(chains), max_size=3))
        if draw(st.booleans()):
            _, pieces = draw(cut_polygon(reverse=draw(st.booleans())))
            chains += pieces
        layers.append(draw(st.permutations(chains)))
    return layers


gaps = st.sampled_from([(20, 10_000), (0, 10_000), (0, 0), (0, 30), (5, 30), (30, 0),
                        (1, 1), (20, 2**40)])


# ---------------------------------------------------------------- properties

@given(random_layers(), gaps)
def test_matches_reference(layers, g):
    _run(layers, *g)


@given(st.integers(0, 2**32 - 1), gaps)
def test_matches_reference_dense(seed, g):
    # many short chains on a tiny grid: equal gaps, shared and coincident ends
    rng = np.random.default_rng(seed)
    layers = []
    for _ in range(3):
        span = int(rng.choice([2, 5, 40]))
        n = int(rng.integers(0, 16))
        layers.append([
            [tuple(map(int, rng.integers(-span, span + 1, 2)))
             for _ in range(int(rng.integers(0, 5)))]
            for _ in range(n)
        ])
    _run(layers, *g)


@st.composite
def many_layers(draw):
    """Up to 12 layers, many of them empty, each a random_layers layer."""
    layers = []
    for _ in range(draw(st.integers(0, 12))):
        if draw(st.booleans()):
            layers.append([])
        else:
            layers.extend(draw(random_layers())[:1] or [[]])
    return layers


@given(many_layers(), gaps)
def test_many_layers_match_references(layers, g):
    _run(layers, *g)


def _crowd(rng, n, span, max_len=4, spread=None):
    """n chains of 1..max_len vertices with ends in a span x span box (the rest
    of their vertices within ``spread``), some exact duplicates and reversals."""
    spread = span if spread is None else spread
    chains = []
    for _ in range(n):
        k = int(rng.integers(1, max_len + 1))
        c = rng.integers(0, span + 1, (k, 2))
        if k > 2:
            c[1:-1] = rng.integers(-spread, spread + 1, (k - 2, 2))
        chains.append([tuple(map(int, p)) for p in c])
        if rng.random() < 0.1:
            chains.append(chains[-1][::-1] if rng.random() < 0.5 else chains[-1])
    return chains


@needs_jit
@given(st.integers(0, 2**32 - 1), st.sampled_from([1, 3, 30, 1000, 8000]), gaps)
def test_crowded_layers_match_quadratic_kernel(seed, span, g):
    # hundreds of chain ends within one gap (ties galore on the small boxes):
    # the pre-issue-8 kernel is the reference (it is compared with the pure-Python
    # one above; that one is too slow here)
    rng = np.random.default_rng(seed)
    layers = [_crowd(rng, int(rng.integers(0, 300)), span) for _ in range(3)]
    _same_as_quadratic(*_pack(layers), *g)


@settings(max_examples=40)
@given(st.integers(0, 2**32 - 1), st.sampled_from([1, 3, 30, 3000]), gaps)
def test_crowded_layers_match_both_references(seed, span, g):
    # up to 50 chains (100 ends) within one gap: both references, ties included
    rng = np.random.default_rng(seed)
    layers = [_crowd(rng, int(rng.integers(0, 50)), span) for _ in range(2)]
    _run(layers, *g)


@needs_jit
def test_thousands_of_ends_within_one_gap_match_quadratic_kernel():
    # 3,000 chains (6,000 ends, 18 M candidate pairs within 10 mm) in a 2 mm box,
    # on a coarse lattice so that equal gaps and coincident ends abound
    rng = np.random.default_rng(8)
    layers = [
        _crowd(rng, 3000, 2000, spread=5000),
        [[(10 * x, 10 * y) for x, y in c] for c in _crowd(rng, 2000, 40)],
    ]
    coords, ro, lo = _pack(layers)
    *_, n = _same_as_quadratic(coords, ro, lo, 20, 10_000)
    assert (n > 1000).all()


@needs_jit
def test_coincident_ends_need_no_candidate_list():
    # issue 8 A3: 100,000 one-vertex chains at one point form 10**10 candidate
    # pairs; the old kernel listed them all (MemoryError after minutes). Smallest
    # key first, chain i's end meets chain i's own start: every chain closes.
    n = 100_000
    coords = np.zeros((n, 2), dtype=np.int64)
    ro = np.arange(n + 1, dtype=np.int64)
    lo = np.array([0, n], dtype=np.int64)
    cc, cr, cl, oc, orr, ol, cnt = stitch_chains(coords, ro, lo, 20, 10_000)
    assert (cc == 0).all() and cr.tolist() == list(range(n + 1))
    assert cl.tolist() == [0, n] and len(oc) == 0 and cnt.tolist() == [n]


@given(random_layers(), gaps)
def test_nothing_lost(layers, g):
    for chains, (loops, still_open, n) in zip(layers, _run(layers, *g), strict=True):
        before = [p for c in chains for p in c]
        after = [p for c in loops + still_open for p in c]
        assert set(after) == set(before)
        assert len(after) <= len(before)
        n_in = sum(1 for c in chains if c)
        # every join removes a chain; every closure turns one into a loop
        assert n == n_in - len(still_open)
        assert len(loops) + len(still_open) <= n_in


@given(cut_polygon())
def test_cut_polygon_is_restored_in_round_1(case):
    poly, pieces = case
    ((loops, still_open, n),) = _run([pieces], 20, 0)
    assert still_open == [] and len(loops) == 1
    assert loops[0] in _rotations(poly)
    assert n == len(pieces)


@given(cut_polygon(reverse=True))
def test_reversed_pieces_are_joined_in_round_2(case):
    poly, pieces = case
    ((loops, still_open, _),) = _run([pieces])
    assert still_open == [] and len(loops) == 1
    assert loops[0] in _rotations(poly) + _rotations(poly[::-1])


@st.composite
def far_chain(draw):
    """A chain whose own ends are >= 10 mm apart, within x in [0, 20 mm]."""
    first = (draw(st.integers(0, 5_000)), draw(st.integers(0, 20_000)))
    last = (draw(st.integers(15_000, 20_000)), draw(st.integers(0, 20_000)))
    mid = draw(st.lists(st.tuples(st.integers(0, 20_000), st.integers(0, 20_000)),
                        max_size=3))
    chain = [first, *mid, last]
    return chain[::-1] if draw(st.booleans()) else chain


@given(st.lists(far_chain(), max_size=6))
def test_far_chains_stay_open(chains):
    # chain i sits at x + 50 mm * i: ends of different chains are >= 30 mm apart
    placed = [[(x + 50_000 * i, y) for x, y in c] for i, c in enumerate(chains)]
    ((loops, still_open, n),) = _run([placed])
    assert loops == [] and n == 0 and still_open == placed


# ---------------------------------------------------------------- examples

def test_empty_inputs():
    assert _run([]) == []
    assert _run([[], [[]]]) == [([], [], 0), ([], [], 0)]


def test_self_closing_small_loops_are_kept():
    ((loops, still_open, n),) = _run([[[(5, 5)], [(0, 100), (10, 100)],
                                       [(0, 300), (0, 300)]]])
    # a 1-vertex chain closes on itself; so do the others (gap 10 and 0)
    assert loops == [[(5, 5)], [(0, 100), (10, 100)], [(0, 300)]]
    assert still_open == [] and n == 3


def test_thresholds_are_strict():
    chains = [[(0, 0), (100, 0)], [(120, 0), (200, 50)]]  # gap exactly 20
    assert _run([chains], 20, 0) == [([], chains, 0)]
    joined = [(0, 0), (100, 0), (120, 0), (200, 50)]
    assert _run([chains], 21, 0) == [([], [joined], 1)]
    assert _run([chains], 20, 21) == [([], [joined], 1)]
    far = [[(-10_000, 1), (0, 1)], [(10_000, 1), (20_000, 1)]]  # gaps >= 10 mm
    assert _run([far]) == [([], far, 0)]


def test_identical_joint_vertex_kept_once():
    ((_, still_open, _),) = _run([[[(0, 0), (50, 0)], [(50, 0), (90, 0)]]], 20, 0)
    assert still_open == [[(0, 0), (50, 0), (90, 0)]]


def test_smallest_gap_first():
    # chain 0's end is 5 from chain 2's start and 3 from chain 1's start
    a, b, c = [(0, 0), (100, 0)], [(103, 0), (200, 90)], [(105, 0), (300, 90)]
    ((_, still_open, n),) = _run([[a, c, b]], 20, 0)
    assert still_open == [a + b, c] and n == 1


def test_tie_lower_index_first():
    # ends of chains 0 and 1 both 10 from chain 2's start: chain 0 wins
    a, b, c = [(0, 500), (0, 10)], [(0, -500), (0, -10)], [(0, 0), (700, 0)]
    ((_, still_open, _),) = _run([[a, b, c]], 20, 0)
    assert still_open == [a + c, b]
    ((_, still_open, _),) = _run([[b, a, c]], 20, 0)
    assert still_open == [b + c, a]


def test_tie_in_order_before_reversed():
    # chain 0's end meets chain 1's start (in order) and chain 2's end (reversed),
    # both at gap 10: the in-order join wins even though it is listed later
    a = [(0, 500), (0, 0)]
    b = [(10, 0), (500, 0)]
    c = [(900, 900), (800, 800), (-10, 0)]
    ((_, still_open, _),) = _run([[a, c, b]], 0, 100)
    assert still_open == [a + b, c]


def test_round_2_reverses_the_shorter_chain():
    long = [(0, 500), (0, 300), (0, 0)]
    short = [(800, 0), (50, 0)]
    # last to last: the shorter (chain 1) is reversed and appended
    ((_, still_open, _),) = _run([[long, short]], 0, 100)
    assert still_open == [long + short[::-1]]
    # first to first: the shorter is reversed and goes first
    ((_, still_open, _),) = _run([[long[::-1], short[::-1]]], 0, 100)
    assert still_open == [short + long[::-1]]
    # the shorter chain has the lower index: still the one reversed
    ((_, still_open, _),) = _run([[short, long]], 0, 100)
    assert still_open == [long + short[::-1]]


def test_round_2_equal_lengths_reverse_the_higher_id():
    a = [(0, 500), (0, 0)]
    b = [(800, 0), (50, 0)]
    ((_, still_open, _),) = _run([[a, b]], 0, 100)  # last to last
    assert still_open == [a + b[::-1]]
    ((_, still_open, _),) = _run([[a[::-1], b[::-1]]], 0, 100)  # first to first
    assert still_open == [b + a[::-1]]


def test_round_2_closes_after_reversal():
    # a square in two halves, the second reversed
    h1 = [(0, 0), (1000, 0), (1000, 1000)]
    h2 = [(0, 5), (0, 1000), (1000, 1005)]
    ((loops, still_open, n),) = _run([[h1, h2]])
    assert still_open == [] and n == 2
    # start-start and end-end tie at gap 5: start-start first, equal lengths, so
    # the higher id (h2) is reversed and goes first; end-end then closes the loop
    assert loops == [h2[::-1] + h1]


def test_layers_are_independent():
    a, b = [(0, 0), (100, 0)], [(105, 0), (0, 3)]
    got = _run([[a], [b], [a, b]], 20, 0)
    assert got[0] == ([], [a], 0) and got[1] == ([], [b], 0)
    assert got[2] == ([b + a], [], 2)  # gap 3 (b to a) first: b is the head


@pytest.mark.parametrize("n", [2_000])
def test_many_chains_scale(n):
    # a big polygon cut into n pieces, shuffled: round 1 restores it
    rng = np.random.default_rng(7)
    t = np.linspace(0, 2 * np.pi, 4 * n, endpoint=False)
    ring = np.stack([np.rint(1e6 * np.cos(t)), np.rint(1e6 * np.sin(t))], 1)
    ring = ring.astype(np.int64)
    pieces = [ring[4 * i : 4 * i + 5] if i < n - 1 else np.vstack([ring[-4:], ring[:1]])
              for i in range(n)]
    order = rng.permutation(n)
    coords = np.ascontiguousarray(np.vstack([pieces[i] for i in order]))
    ro = np.arange(0, 5 * n + 1, 5, dtype=np.int64)
    lo = np.array([0, n], dtype=np.int64)
    cc, cr, cl, oc, orr, ol, cnt = stitch_chains(coords, ro, lo, 20, 10_000)
    assert cr.tolist() == [0, 4 * n] and len(oc) == 0 and cnt.tolist() == [n]
    start = int(np.flatnonzero((ring == cc[0]).all(1))[0])
    assert (np.roll(ring, -start, axis=0) == cc).all()


def test_extreme_coordinates_do_not_overflow():
    big = 2**30 - 1
    a = [(-big, -big), (big, big)]
    b = [(big, -big), (-big, big)]
    ((loops, still_open, n),) = _run([[a, b]], 20, 2**40)
    # squared gaps up to 8 * big**2 < 2**63: every pair is a candidate
    assert n == 2 and still_open == [] and len(loops) == 1
    assert sorted(loops[0]) == sorted(a + b)

import numba
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import reference_stitch
from vecslice._kernels.chain_ends import match_ends

# the large inputs take minutes when kernels run as plain Python (coverage runs)
needs_jit = pytest.mark.skipif(numba.config.DISABLE_JIT,
                               reason="NUMBA_DISABLE_JIT=1: too slow as plain Python")


def _arrays(ends):
    xy = np.array([e[0] for e in ends], dtype=np.int64).reshape(-1, 2)
    gid = np.array([e[1] for e in ends], dtype=np.int64)
    role = np.array([e[2] for e in ends], dtype=np.int64)
    return xy, gid, role


def _match(ends, gap2, allow_reverse):
    """Kernel pairs as a set, checked against the brute-force reference."""
    xy, gid, role = _arrays(ends)
    pairs = match_ends(xy, gid, role, gap2, allow_reverse)
    assert pairs.dtype == np.int64 and pairs.shape[1] == 2
    got = {frozenset(map(int, p)) for p in pairs}
    assert len(got) == len(pairs) and all(len(p) == 2 for p in got)
    used = [t for p in got for t in p]
    assert len(set(used)) == len(used)  # a matching: every terminus at most once
    assert got == reference_stitch.match_ends(xy, gid, role, gap2, allow_reverse)
    return got


@st.composite
def termini(draw, max_groups=40):
    """Chain ends: per group (distinct gids) a start, an end or both; positions on
    a small lattice (ties and coincident ends) or spread out."""
    span = draw(st.sampled_from([0, 1, 3, 30, 3000]))
    point = st.tuples(st.integers(-span, span), st.integers(-span, span))
    gids = draw(st.lists(st.integers(0, 200), unique=True, max_size=max_groups))
    ends = []
    for g in gids:
        roles = draw(st.sampled_from([(0,), (1,), (0, 1), (0, 1)]))
        shared = draw(point)
        for r in roles:
            # sometimes both ends of a group at one point (a chain that closes)
            ends.append((shared if draw(st.booleans()) else draw(point), g, r))
    return draw(st.permutations(ends))


gap2s = st.sampled_from([0, 1, 2, 5, 100, 10**4, 10**8, 2**63 - 1])


@given(termini(), gap2s, st.booleans())
def test_matches_brute_force_greedy(ends, gap2, allow_reverse):
    _match(ends, gap2, allow_reverse)


@given(st.integers(0, 2**32 - 1), st.sampled_from([1, 2, 4, 40]), st.booleans())
def test_crowded_and_coincident_match_brute_force(seed, span, allow_reverse):
    # a few hundred ends within one gap, many at the same point
    rng = np.random.default_rng(seed)
    n_groups = int(rng.integers(50, 150))
    ends = []
    for g in rng.permutation(4 * n_groups)[:n_groups]:
        for r in (0, 1):
            if rng.random() < 0.8:
                ends.append((tuple(map(int, rng.integers(0, span + 1, 2))), int(g), r))
    _match(ends, 10**8, allow_reverse)


def test_empty_and_single():
    assert _match([], 100, True) == set()
    assert _match([((0, 0), 3, 1)], 100, True) == set()
    # a group's own start and end (in order) close it
    assert _match([((0, 0), 3, 1), ((0, 5), 3, 0)], 100, False) == {frozenset((0, 1))}


def test_gap_is_strict():
    ends = [((0, 0), 0, 1), ((3, 4), 1, 0)]  # d2 = 25
    assert _match(ends, 25, False) == set()
    assert _match(ends, 26, False) == {frozenset((0, 1))}


def test_two_starts_join_only_when_reversing():
    ends = [((0, 0), 0, 0), ((1, 0), 1, 0)]
    assert _match(ends, 100, False) == set()
    assert _match(ends, 100, True) == {frozenset((0, 1))}


def test_ties_lower_gid_then_in_order_first():
    # three ends at one point: the start of group 5 meets the ends of groups 7 and
    # 2 at d2 = 0; the lower gid (2) wins
    ends = [((0, 0), 5, 0), ((0, 0), 7, 1), ((0, 0), 2, 1)]
    assert _match(ends, 1, False) == {frozenset((0, 2))}
    # at equal distance an in-order pair beats a reversed one with lower ids
    ends = [((0, 0), 1, 1), ((0, 3), 0, 1), ((3, 0), 9, 0)]
    assert _match(ends, 100, True) == {frozenset((0, 2))}


@needs_jit
@pytest.mark.parametrize("n", [200_000])
def test_many_coincident_ends_are_fast_and_greedy(n):
    # every terminus at one point (4 * 10**10 candidate pairs for a full list):
    # keys (0, 0, end gid, start gid) make each group close on itself, in gid order
    gid = np.arange(n, dtype=np.int64) // 2
    role = np.arange(n, dtype=np.int64) % 2
    xy = np.zeros((n, 2), dtype=np.int64)
    pairs = match_ends(xy, gid, role, 1, False)
    assert pairs.shape == (n // 2, 2)
    assert sorted(map(tuple, np.sort(pairs, axis=1).tolist())) == [
        (2 * g, 2 * g + 1) for g in range(n // 2)
    ]

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import reference
from vecslice._kernels.loops import link_segments


def _link(frm, to, layer, n_c):
    frm, to, layer = (np.asarray(x, dtype=np.int64) for x in (frm, to, layer))
    nxt, has_prev = reference.successors(frm, to, n_c)
    return link_segments(np.array(nxt, np.int64), np.array(has_prev, np.bool_),
                         frm, to, layer)


def test_square_and_chain():
    cv, cr, cl, ov, orr, ol = _link([0, 1, 2, 3, 4, 5], [1, 2, 3, 0, 5, 6],
                                    [0, 0, 0, 0, 1, 1], 7)
    assert cv.tolist() == [0, 1, 2, 3] and cr.tolist() == [0, 4]
    assert cl.tolist() == [0]
    assert ov.tolist() == [4, 5, 6] and orr.tolist() == [0, 3] and ol.tolist() == [1]


def test_non_manifold_crossing_links_pairwise():
    # two triangles of segments sharing crossing 0 (4 segments touch it)
    frm = [0, 1, 2, 0, 3, 4]
    to = [1, 2, 0, 3, 4, 0]
    cv, cr, _, ov, _, _ = _link(frm, to, [0] * 6, 5)
    assert len(ov) == 0
    assert sorted(np.diff(cr).tolist()) in ([3, 3], [6])
    assert sorted(cv.tolist()) == [0, 0, 1, 2, 3, 4]


@st.composite
def permutation_cycles(draw):
    n = draw(st.integers(1, 60))
    perm = draw(st.permutations(list(range(n))))
    cut = draw(st.sets(st.integers(0, n - 1), max_size=5))
    return np.array(perm, dtype=np.int64), sorted(cut)


@given(permutation_cycles())
def test_every_segment_is_used_exactly_once(case):
    # segment s runs s -> perm[s]; removing some segments opens cycles into chains
    perm, cut = case
    keep = np.array([s for s in range(len(perm)) if s not in cut], dtype=np.int64)
    frm, to = keep, perm[keep]
    n = len(perm)
    cv, cr, cl, ov, orr, ol = _link(frm, to, np.zeros(len(keep), np.int64), n)
    # closed: n segments -> n vertices; open: +1 vertex per chain
    assert len(cv) + len(ov) - (len(orr) - 1) == len(keep)
    # each closed loop follows the permutation and closes
    for i in range(len(cr) - 1):
        ring = cv[cr[i]:cr[i + 1]].tolist()
        for a, b in zip(ring, ring[1:] + ring[:1]):
            assert perm[a] == b
    for i in range(len(orr) - 1):
        chain = ov[orr[i]:orr[i + 1]].tolist()
        for a, b in zip(chain, chain[1:]):
            assert perm[a] == b
        assert chain[0] not in set(to.tolist())  # starts where nothing ends
    nxt, has_prev = reference.successors(frm, to, n)
    linked = [t for t in nxt if t >= 0]
    assert len(set(linked)) == len(linked) == sum(has_prev)  # injective

"""Slow pure-Python reference for stitching open chains (``kernels/stitch.py``).

Written from the rules, not from the kernel: every joined chain is a Python list of
points, every candidate pair is listed by brute force and sorted, and joining is
list concatenation.

Rules (per layer, two rounds, smallest gap first):

* round 1, gaps < ``gap_in_order``: last vertex of a line to first vertex of a line
  (the same line closes it);
* round 2, gaps < ``gap_any``: the same, plus last-to-last and first-to-first of two
  different lines, reversing the line with fewer points (tie: the higher id).

Candidate order: ``(gap², reversed, i, j, sub)`` with ``i, j`` the line ids when the
round starts (in order: the line whose last point, then the line whose first point;
reversed: the lower id first), ``sub`` 0 for first-to-first and 1 for last-to-last.
A line's id is the smallest input index it contains. A candidate is used only if
both its ends are still the free ends of open lines. Identical joint points are kept
once; a loop whose last point equals its first drops the last (if it has >= 2).
"""

from __future__ import annotations

from dataclasses import dataclass, field

Point = tuple[int, int]
End = tuple[int, int]  # (input chain index, 0 = its first vertex / 1 = its last)


@dataclass
class _Line:
    points: list[Point]
    gid: int
    head: End  # the input chain end at points[0]
    tail: End  # the input chain end at points[-1]
    closed: bool = False
    alive: bool = field(default=True)


def _d2(p: Point, q: Point) -> int:
    return (p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2


def _concat(first: _Line, second: _Line) -> _Line:
    pts = first.points + (
        second.points[1:] if first.points[-1] == second.points[0] else second.points
    )
    return _Line(pts, min(first.gid, second.gid), first.head, second.tail)


def _reversed(line: _Line) -> _Line:
    return _Line(line.points[::-1], line.gid, line.tail, line.head)


def _round(lines: list[_Line], gap: int, allow_reverse: bool) -> int:
    live = [ln for ln in lines if ln.alive and not ln.closed]
    g2 = gap * gap
    cands = []
    for a in live:
        for b in live:
            d = _d2(a.points[-1], b.points[0])
            if d < g2:
                cands.append(((d, 0, a.gid, b.gid, 0), a.tail, b.head))
            if allow_reverse and a.gid < b.gid:
                d = _d2(a.points[0], b.points[0])
                if d < g2:
                    cands.append(((d, 1, a.gid, b.gid, 0), a.head, b.head))
                d = _d2(a.points[-1], b.points[-1])
                if d < g2:
                    cands.append(((d, 1, a.gid, b.gid, 1), a.tail, b.tail))
    cands.sort(key=lambda c: c[0])

    def holder(end: End) -> tuple[_Line | None, bool]:
        for ln in lines:
            if ln.alive and not ln.closed:
                if ln.tail == end:
                    return ln, True
                if ln.head == end:
                    return ln, False
        return None, False

    n = 0
    for _, ea, eb in cands:
        la, a_is_tail = holder(ea)
        lb, b_is_tail = holder(eb)
        if la is None or lb is None:
            continue
        n += 1
        if la is lb:
            la.closed = True
            if len(la.points) >= 2 and la.points[0] == la.points[-1]:
                la.points.pop()
            continue
        if a_is_tail and not b_is_tail:
            new = _concat(la, lb)
        elif b_is_tail and not a_is_tail:
            new = _concat(lb, la)
        else:
            rev_a = len(la.points) < len(lb.points) or (
                len(la.points) == len(lb.points) and la.gid > lb.gid
            )
            if a_is_tail:  # last to last: the reversed one goes second
                first, second = (lb, _reversed(la)) if rev_a else (la, _reversed(lb))
            else:  # first to first: the reversed one goes first
                first, second = (_reversed(la), lb) if rev_a else (_reversed(lb), la)
            new = _concat(first, second)
        la.alive = lb.alive = False
        lines.append(new)
    return n


def stitch_layer(
    chains: list[list[Point]], gap_in_order: int, gap_any: int
) -> tuple[list[list[Point]], list[list[Point]], int]:
    """(new loops, chains left open, joins + closures) of one layer."""
    lines = [
        _Line([tuple(map(int, p)) for p in c], i, (i, 0), (i, 1))
        for i, c in enumerate(chains)
        if len(c)
    ]
    n = 0
    if gap_in_order > 0:
        n += _round(lines, gap_in_order, False)
    if gap_any > 0:
        n += _round(lines, gap_any, True)
    done = sorted((ln for ln in lines if ln.alive), key=lambda ln: ln.gid)
    loops = [ln.points for ln in done if ln.closed]
    still_open = [ln.points for ln in done if not ln.closed]
    return loops, still_open, n


def stitch(coords, ring_offsets, layer_offsets, gap_in_order: int, gap_any: int):
    """Per layer ``(loops, open_chains, n_stitched)``, points as (x, y) tuples."""
    out = []
    for k in range(len(layer_offsets) - 1):
        chains = [
            [tuple(map(int, p)) for p in coords[ring_offsets[i] : ring_offsets[i + 1]]]
            for i in range(layer_offsets[k], layer_offsets[k + 1])
        ]
        out.append(stitch_layer(chains, gap_in_order, gap_any))
    return out


def match_ends(xy, gid, role, gap2: int, allow_reverse: bool) -> set[frozenset[int]]:
    """Greedy matching of chain ends (``kernels/chain_ends.py``), by brute force.

    Lists every joinable pair of termini with the stitcher's key ``(d2, reversed,
    i, j, sub)`` (in order: the end's gid, then the start's; reversed: lower gid
    first, ``sub`` = their role), sorts the keys and takes a pair when both its
    termini are still free. Returns the pairs taken as sets of two terminus indices.
    """
    n = len(xy)
    cands = []
    for q in range(n):
        for p in range(q + 1, n):
            d2 = int(xy[q][0] - xy[p][0]) ** 2 + int(xy[q][1] - xy[p][1]) ** 2
            if d2 >= gap2:
                continue
            if role[q] != role[p]:
                end, start = (q, p) if role[q] == 1 else (p, q)
                key = (d2, 0, int(gid[end]), int(gid[start]), 0)
            elif allow_reverse:
                lo, hi = sorted((int(gid[q]), int(gid[p])))
                key = (d2, 1, lo, hi, int(role[q]))
            else:
                continue
            cands.append((key, q, p))
    keys = [c[0] for c in cands]
    assert len(set(keys)) == len(keys), "keys are distinct"
    cands.sort()
    free = [True] * n
    taken = set()
    for _, q, p in cands:
        if free[q] and free[p]:
            free[q] = free[p] = False
            taken.add(frozenset((q, p)))
    return taken

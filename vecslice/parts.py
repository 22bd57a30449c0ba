"""Layer parts: union each layer's loops and split it into outline + holes.

This is the only module that uses manifold3d (imported inside the functions that
call it, so ``import vecslice`` does not load it). Rings go to manifold3d's
``CrossSection`` (Clipper2 inside) as float64 arrays, which are exact for integers
below ``2**30``; results come back through one ``np.concatenate`` and are rounded
to int64 µm once. Everything after the manifold3d calls (orientation, degenerate
rings, ordering) is whole-array numpy over all layers at once.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from vecslice._kernels.rings import ring_area2
from vecslice._validate import check_bool, check_option
from vecslice.errors import InputTypeError
from vecslice.interop import to_shapely as to_shapely  # moved; re-exported
from vecslice.interrupt import keyboard_interrupts
from vecslice.layerparts import LayerParts as LayerParts  # moved; re-exported
from vecslice.paths import LayerPaths
from vecslice.ragged import offsets_from_lengths as _offsets
from vecslice.ragged import ragged_take

if TYPE_CHECKING:
    import manifold3d

__all__ = ["apply_slicing_tolerance", "make_parts"]

_BATCH_LAYERS = 1024  # layers per manifold3d batch (see _batches)
_MAX_PAIRS = 10_000_000  # (hole, outline) box tests before falling back to decompose
_PAIR_CHUNK = 1 << 18  # (hole, outline) pairs listed at a time (about 16 MB)
_KEY_SHIFT = np.int64(2**31)  # |y| < 2**30, so x * 2**31 + y orders like (x, y)


def _check_loops(loops: Any) -> LayerPaths:
    if not isinstance(loops, LayerPaths):
        raise InputTypeError(
            f"`loops` must be a vecslice.LayerPaths (see vecslice.slice_contours); "
            f"got {type(loops).__name__}"
        )
    return loops


def _batches(n_layers: int) -> list[tuple[int, int]]:
    """Layer ranges ``[k0, k1)`` handed to manifold3d together.

    manifold3d needs Python objects per layer (a CrossSection, its polygons); in
    batches, only one batch's objects are alive at a time, so memory per layer
    is that of the arrays only, however many layers there are.
    """
    return [(k, min(k + _BATCH_LAYERS, n_layers))
            for k in range(0, n_layers, _BATCH_LAYERS)]


def _cross_sections(
    loops: LayerPaths,
    fillrule: manifold3d.FillRule,
    k0: int = 0,
    k1: int | None = None,
) -> list[manifold3d.CrossSection]:
    """One CrossSection per layer ``k0 <= k < k1`` (default all): its rings.

    One float64 conversion for the vertices of these layers; rings are views
    sliced from it (plain slicing: ``np.split`` costs several µs per ring).
    """
    import manifold3d

    k1 = loops.n_layers if k1 is None else k1
    lo = loops.layer_offsets[k0 : k1 + 1].tolist()
    ro = loops.ring_offsets[lo[0] : lo[-1] + 1]
    f = loops.coords[ro[0] : ro[-1]].astype(np.float64)
    rings = [f[a:b] for a, b in itertools.pairwise((ro - ro[0]).tolist())]
    cs = manifold3d.CrossSection
    return [cs(rings[lo[k] - lo[0] : lo[k + 1] - lo[0]], fillrule)
            for k in range(k1 - k0)]


def _gather(polys: list[Any]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Concatenate float (n, 2) polygons in one call; return coords and lengths."""
    if not polys:
        return np.empty((0, 2), np.float64), np.empty(0, np.int64)
    lens = np.fromiter((len(p) for p in polys), np.int64, len(polys))
    return np.concatenate(polys), lens


def _polygons(
    sections: list[Any],
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """Float coords, ring lengths and (batch-local) layer of every output ring."""
    polys = [cs.to_polygons() for cs in sections]
    f, lens = _gather([p for layer_polys in polys for p in layer_polys])
    layer = np.repeat(np.arange(len(polys), dtype=np.int64),
                      np.fromiter(map(len, polys), np.int64, len(polys)))
    return f, lens, layer


def _concat(pieces: list[tuple[NDArray[Any], ...]]) -> list[NDArray[Any]]:
    """Concatenate the per-batch arrays field by field (no copy for one batch)."""
    if len(pieces) == 1:
        return list(pieces[0])
    return [np.concatenate(field) for field in zip(*pieces, strict=True)]


def _vertex_keys(coords: NDArray[np.int64]) -> NDArray[np.int64]:
    """``x * 2**31 + y``: one int64 per vertex, ordered like (x, y) tuples."""
    key = np.multiply(coords[:, 0], _KEY_SHIFT)
    key += coords[:, 1]
    return key


def _dedupe(
    coords: NDArray[np.int64], key: NDArray[np.int64], lens: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Drop repeated and collinear vertices of the rounded union output.

    A vertex equal to its cyclic predecessor (rounding can merge them) goes
    first; then a vertex on one line with its two neighbours, whether it lies
    between them or the path turns back there (the tip of a zero-width spike):
    rounding makes such points, and Clipper2 keeps collinear input points where
    CuraEngine's union (Clipper 6, collinear points not preserved: it removes
    every vertex whose neighbours' slopes are equal) and ``spec/SLICING.md``
    remove them. Two layers' outlines along one wall, united by the 'inclusive'
    tolerance, left 472 straight-through points on 3DBenchy; a sliver 0.11 µm
    wide in manifold3d's output on ``openscad-nonmanifold-crash.obj`` rounds to
    a spike 1.5 mm long into the part. Removing a spike's tip makes its base
    vertices repeat, so both steps run again until nothing is dropped (each
    round drops at least one vertex). Exact int64 tests.
    """
    while True:
        coords, key, lens = _drop(coords, key, lens, _repeated(key, lens))
        drop = _collinear(coords, lens)
        if drop is None:
            return coords, key, lens
        coords, key, lens = _drop(coords, key, lens, drop)


def _drop(
    coords: NDArray[np.int64], key: NDArray[np.int64], lens: NDArray[np.int64],
    drop: NDArray[np.bool_] | None,
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """The rings without the vertices ``drop`` marks (None: nothing dropped)."""
    if drop is None:
        return coords, key, lens
    keep = ~drop
    ring = np.repeat(np.arange(lens.shape[0]), lens)
    lens = np.bincount(ring[keep], minlength=lens.shape[0]).astype(np.int64)
    return np.compress(keep, coords, axis=0), key[keep], lens


def _repeated(
    key: NDArray[np.int64], lens: NDArray[np.int64]
) -> NDArray[np.bool_] | None:
    """Vertices equal to their cyclic predecessor, or None if there are none."""
    if key.shape[0] == 0:
        return None
    offsets = _offsets(lens)
    same = np.empty(key.shape[0], dtype=bool)
    same[0] = False
    np.equal(key[1:], key[:-1], out=same[1:])
    nz = lens > 0
    same[offsets[:-1][nz]] = key[offsets[:-1][nz]] == key[offsets[1:][nz] - 1]
    return same if same.any() else None


def _collinear(
    coords: NDArray[np.int64], lens: NDArray[np.int64]
) -> NDArray[np.bool_] | None:
    """Vertices on one line with their cyclic neighbours, or None.

    Straight through (strictly between the neighbours) or turning back (a
    spike's tip). Neighbours are distinct (repeats dropped first),
    |coordinates| < 2**30: the cross products fit int64. A ring of 1 or 2
    vertices is left alone (it has no area and is dropped later).
    """
    if coords.shape[0] == 0:
        return None
    offsets = _offsets(lens)
    nz = lens > 0
    first, last = offsets[:-1][nz], offsets[1:][nz] - 1
    # e[i]: the edge from vertex i to the next one of its ring
    e = np.empty_like(coords)
    np.subtract(coords[1:], coords[:-1], out=e[:-1])
    e[last] = coords[first] - coords[last]
    # the edge into vertex i: e[i - 1], or its ring's last edge at its first vertex
    ein = np.empty_like(coords)
    ein[1:] = e[:-1]
    ein[first] = e[last]
    cross = ein[:, 0] * e[:, 1]
    cross -= ein[:, 1] * e[:, 0]
    drop = cross == 0
    drop &= np.repeat(lens > 2, lens)
    return drop if drop.any() else None


def _signed_area(coords: NDArray[np.float64], lens: NDArray[np.int64]) -> NDArray[Any]:
    """Twice the signed area of float rings (trapezoids, y relative to the ring).

    Only its sign is used: it is manifold3d's orientation before rounding.
    """
    out = np.zeros(lens.shape[0])
    nz = lens > 0
    if not nz.any():
        return out
    offsets = _offsets(lens)
    starts, ends = offsets[:-1][nz], offsets[1:][nz]
    x, y = coords[:, 0], coords[:, 1] - np.repeat(coords[starts, 1], lens[nz])
    dx = np.empty_like(x)
    np.subtract(x[1:], x[:-1], out=dx[:-1])
    dx[ends - 1] = x[starts] - x[ends - 1]  # closing edges
    ys = np.empty_like(y)
    np.add(y[1:], y[:-1], out=ys[:-1])
    ys[ends - 1] = y[starts] + y[ends - 1]
    dx *= ys
    out[nz] = -np.add.reduceat(dx, starts)
    return out


def _ring_keys(
    key: NDArray[np.int64], lens: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Key and position of each ring's smallest (x, y) vertex (0 for empty rings)."""
    ring_min = np.zeros(lens.shape[0], dtype=np.int64)
    shift = np.zeros(lens.shape[0], dtype=np.int64)
    nz = lens > 0
    if not nz.any():
        return ring_min, shift
    starts = _offsets(lens)[:-1]
    ring_min[nz] = np.minimum.reduceat(key, starts[nz])
    hits = np.flatnonzero(key == np.repeat(ring_min, lens))
    ring = np.repeat(np.arange(lens.shape[0]), lens)[hits]
    first = np.ones(hits.shape[0], dtype=bool)
    np.not_equal(ring[1:], ring[:-1], out=first[1:])
    shift[nz] = hits[first] - starts[nz]
    return ring_min, shift


def _take_rings(
    coords: NDArray[np.int64],
    offsets: NDArray[np.int64],
    order: NDArray[np.int64],
    shift: NDArray[np.int64],
    flip: NDArray[np.bool_],
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Gather rings ``order`` (one numpy gather for all).

    Ring ``r`` starts at its vertex ``shift[r]`` and is reversed (keeping that
    start) where ``flip[r]``.
    """
    lens = np.diff(offsets)[order]
    new_offsets = _offsets(lens)
    sh = shift[order]
    # position in the ring, counted from the start vertex: in [0, 2 * len)
    src = np.arange(new_offsets[-1], dtype=np.int64)
    src -= np.repeat(new_offsets[:-1] - sh, lens)
    ln = np.repeat(lens, lens)
    np.subtract(src, ln, out=src, where=src >= ln)
    fl = np.flatnonzero(flip[order])
    if fl.size:  # reversed rings: position (shift - local) mod len
        fo, idx = ragged_take(new_offsets, fl)
        local = idx - np.repeat(new_offsets[fl], np.diff(fo))
        src[idx] = (np.repeat(sh[fl], np.diff(fo)) - local) % np.repeat(
            lens[fl], np.diff(fo)
        )
    src += np.repeat(offsets[:-1][order], lens)
    return np.take(coords, src, axis=0), new_offsets


def _assemble(
    coords: NDArray[np.int64],
    lens: NDArray[np.int64],
    layer: NDArray[np.int64],
    pid: NDArray[np.int64],
    area_f: NDArray[Any],
    n_layers: int,
) -> LayerParts:
    """Rings labelled by layer and part id → sorted, oriented LayerParts.

    The outline of a part is its ring of largest float area magnitude; outlines
    are made CCW and holes CW, zero-area holes and parts with a zero-area outline
    are dropped, every ring is rotated to start at its smallest (x, y) vertex, and
    parts are sorted by that vertex of their outline, holes likewise.
    """
    key = _vertex_keys(coords)
    coords, key, lens = _dedupe(coords, key, lens)
    offsets = _offsets(lens)
    area2 = ring_area2(coords, offsets)
    n = lens.shape[0]
    idx = np.arange(n, dtype=np.int64)
    _, pid = np.unique(pid, return_inverse=True)
    pid = pid.reshape(-1).astype(np.int64)
    order = np.lexsort((idx, -np.abs(area_f), pid))
    is_outline = np.zeros(n, dtype=bool)
    if n:
        head = np.ones(n, dtype=bool)
        head[1:] = pid[order[1:]] != pid[order[:-1]]
        is_outline[order[head]] = True
    outline_of = np.zeros(int(pid.max()) + 1 if n else 0, dtype=np.int64)
    outline_of[pid[is_outline]] = idx[is_outline]
    keep = (area2 != 0) & (area2[outline_of[pid]] != 0)
    flip = np.where(is_outline, area2 < 0, area2 > 0)
    ring_min, shift = _ring_keys(key, lens)
    part_key = ring_min[outline_of[pid]]
    kept = idx[keep]
    order = kept[
        np.lexsort((kept, ring_min[kept], ~is_outline[kept], pid[kept],
                    part_key[kept], layer[kept]))
    ]
    out_coords, new_offsets = _take_rings(coords, offsets, order, shift, flip)
    out_pid = pid[order]
    new_part = np.ones(order.shape[0], dtype=bool)
    new_part[1:] = out_pid[1:] != out_pid[:-1]
    part_offsets = np.append(np.flatnonzero(new_part), order.shape[0]).astype(np.int64)
    part_layer = layer[order][new_part]
    layer_offsets = _offsets(np.bincount(part_layer, minlength=n_layers))
    return LayerParts._trusted(out_coords, new_offsets, part_offsets, layer_offsets)


def _label_parts(
    f: NDArray[np.float64],
    lens: NDArray[np.int64],
    layer: NDArray[np.int64],
    area_f: NDArray[Any],
    n_layers: int,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Part id of every ring of manifold3d's output, without point-in-polygon.

    Rings are outlines (area > 0) or holes. In a layer with one outline every hole
    is in it; with no hole every outline is a part. Otherwise a hole whose bounding
    box lies in the box of exactly one outline of its layer belongs to that outline
    (its true parent is always such a candidate). Returns ``(pid, unresolved)``:
    part ids (the ring index of the outline) and the layers where some hole had
    several candidates.
    """
    n = lens.shape[0]
    idx = np.arange(n, dtype=np.int64)
    pos = area_f > 0
    n_pos = np.bincount(layer[pos], minlength=n_layers)
    n_neg = np.bincount(layer[~pos], minlength=n_layers)
    single = np.full(n_layers, -1, dtype=np.int64)
    one = n_pos[layer[pos]] == 1
    single[layer[pos][one]] = idx[pos][one]
    pid = np.where(single[layer] >= 0, single[layer], idx)
    ambiguous = (n_pos >= 2) & (n_neg >= 1)
    if not ambiguous.any():
        return pid, np.empty(0, np.int64)
    in_amb = ambiguous[layer]
    holes, outs = np.flatnonzero(in_amb & ~pos), np.flatnonzero(in_amb & pos)
    lo = np.searchsorted(layer[outs], layer[holes], side="left")
    cnt = np.searchsorted(layer[outs], layer[holes], side="right") - lo
    if int(cnt.sum()) > _MAX_PAIRS:
        return pid, np.flatnonzero(ambiguous)
    sub = f[np.repeat(in_amb, lens)]
    sub_starts = _offsets(lens[in_amb])[:-1]
    box = np.zeros((n, 4))
    box[in_amb] = np.stack([
        np.minimum.reduceat(sub[:, 0], sub_starts),
        np.minimum.reduceat(sub[:, 1], sub_starts),
        np.maximum.reduceat(sub[:, 0], sub_starts),
        np.maximum.reduceat(sub[:, 1], sub_starts),
    ], axis=1)
    n_cand = np.zeros(holes.shape[0], dtype=np.int64)
    # the pairs of consecutive holes, _PAIR_CHUNK at a time: a plate of 100
    # washers over 1,000 layers listed 10**7 pairs at once (657 MB)
    ends = np.cumsum(cnt)
    cuts = np.searchsorted(ends, np.arange(_PAIR_CHUNK, int(ends[-1]), _PAIR_CHUNK))
    for a, b in itertools.pairwise([0, *np.unique(cuts + 1).tolist(), holes.shape[0]]):
        if a >= b:
            continue
        c = cnt[a:b]
        hole_of_pair = a + np.repeat(np.arange(b - a), c)
        h = holes[hole_of_pair]
        o = outs[np.arange(hole_of_pair.shape[0])
                 - np.repeat(_offsets(c)[:-1] - lo[a:b], c)]
        ok = ((box[o, :2] <= box[h, :2]) & (box[o, 2:] >= box[h, 2:])).all(axis=1)
        n_cand += np.bincount(hole_of_pair[ok], minlength=holes.shape[0])
        pid[h[ok]] = o[ok]
    return pid, np.unique(layer[holes[n_cand != 1]])


@keyboard_interrupts
def make_parts(
    loops: LayerPaths, *, union_overlapping_volumes: bool = True
) -> LayerParts:
    """Union each layer's closed loops and split the result into parts.

    Parameters
    ----------
    loops : LayerPaths
        Closed rings per layer in µm (e.g. from :func:`vecslice.slice_contours`);
        ``loops.open`` is ignored.
    union_overlapping_volumes : bool, default True
        Fill rule of the union: NonZero (overlapping bodies merge) if True, else
        EvenOdd (overlaps cancel).

    Returns
    -------
    LayerParts
        ``L`` layers of parts: each an outline (CCW) followed by the holes directly
        inside it (CW). An island inside a hole is a separate part.

    Notes
    -----
    manifold3d's ``CrossSection`` (Clipper2) does the union, once per layer, and its
    ``decompose`` is called only for layers that have several outlines *and* holes.
    Coordinates are rounded back to int64 once; input vertices that survive the
    union keep their exact values. Rings that rounding makes zero-area are dropped.
    Parts in a layer are sorted by the smallest (x, y) vertex of their outline, holes
    likewise, and every ring starts at its smallest (x, y) vertex, so the result
    does not depend on manifold3d's internal order.

    Examples
    --------
    >>> outer = [[0, 0], [30, 0], [30, 30], [0, 30]]
    >>> hole = [[10, 10], [10, 20], [20, 20], [20, 10]]
    >>> loops = LayerPaths(outer + hole, [0, 4, 8], [0, 2])
    >>> parts = make_parts(loops)
    >>> parts.n_parts, parts.layer_areas().tolist()
    (1, [800.0])
    >>> outline, holes = parts.layer(0)[0]
    >>> outline.tolist(), [h.tolist() for h in holes]
    ([[0, 0], [30, 0], [30, 30], [0, 30]], [[[10, 10], [10, 20], [20, 20], [20, 10]]])
    """
    import manifold3d

    loops = _check_loops(loops)
    union_overlapping_volumes = check_bool(
        union_overlapping_volumes, "union_overlapping_volumes"
    )
    rule = (manifold3d.FillRule.NonZero if union_overlapping_volumes
            else manifold3d.FillRule.EvenOdd)
    pieces, n_ids = [], 0
    for k0, k1 in _batches(loops.n_layers) or [(0, 0)]:
        f, lens, layer, pid, area_f, n = _union_batch(loops, rule, k0, k1)
        pieces.append((f, lens, layer + k0, pid + n_ids, area_f))
        n_ids += n
    f, lens, layer, pid, area_f = _concat(pieces)
    del pieces  # memory: the batches are concatenated
    coords = np.rint(f, out=f).astype(np.int64)
    del f
    return _assemble(coords, lens, layer, pid, area_f, loops.n_layers)


def _union_batch(
    loops: LayerPaths, rule: manifold3d.FillRule, k0: int, k1: int
) -> tuple[Any, ...]:
    """Union layers ``k0 <= k < k1``: rings labelled by local layer and part.

    Returns ``(f, lens, layer, pid, area_f, n_ids)``: float coords, ring lengths,
    layer (counted from ``k0``), part id (< ``n_ids``) and float signed area.
    """
    n_layers = k1 - k0
    sections = _cross_sections(loops, rule, k0, k1)
    f, lens, layer = _polygons(sections)
    area_f = _signed_area(f, lens)
    pid, unresolved = _label_parts(f, lens, layer, area_f, n_layers)
    n_ids = lens.shape[0]
    if unresolved.size:  # islands in holes: let manifold3d nest these layers
        parts = [(k, q) for k in unresolved.tolist() for q in sections[k].decompose()]
        part_polys = [q.to_polygons() for _, q in parts]
        f2, lens2 = _gather([p for pp in part_polys for p in pp])
        per_part = np.fromiter(map(len, part_polys), np.int64, len(parts))
        keep = ~np.isin(layer, unresolved)
        f = np.concatenate([f[np.repeat(keep, lens)], f2])
        layer = np.concatenate([
            layer[keep], np.repeat(np.array([k for k, _ in parts], np.int64), per_part)
        ])
        pid = np.concatenate([
            pid[keep], lens.shape[0] + np.repeat(np.arange(len(parts)), per_part)
        ])
        area_f = np.concatenate([area_f[keep], _signed_area(f2, lens2)])
        lens = np.concatenate([lens[keep], lens2])
        n_ids += len(parts)
    return f, lens, layer, pid, area_f, n_ids


def apply_slicing_tolerance(
    loops: LayerPaths, mode: Literal["middle", "inclusive", "exclusive"]
) -> LayerPaths:
    """Post-process raw slices for CuraEngine's ``slicing_tolerance``.

    Parameters
    ----------
    loops : LayerPaths
        Raw closed loops per layer, sliced at the heights of ``mode``'s schedule
        (see :func:`vecslice.layer_heights`).
    mode : {'middle', 'inclusive', 'exclusive'}
        'middle' returns ``loops`` itself. 'inclusive' replaces layer ``n`` by the
        union of raw layers ``n`` and ``n + 1`` (each filled NonZero); the top
        layer stays raw. 'exclusive' replaces layer ``n`` by the intersection of
        raw layers ``n`` and ``n + 1`` (each filled EvenOdd) and clears the top
        layer.

    Returns
    -------
    LayerPaths
        Closed rings (outlines CCW, holes CW) with ``loops.open`` passed through.

    Examples
    --------
    >>> a = [[0, 0], [20, 0], [20, 10], [0, 10]]
    >>> b = [[10, 0], [30, 0], [30, 10], [10, 10]]
    >>> loops = LayerPaths(a + b, [0, 4, 8], [0, 1, 2])
    >>> apply_slicing_tolerance(loops, "inclusive").layer_area2().tolist()
    [600, 400]
    >>> apply_slicing_tolerance(loops, "exclusive").layer_area2().tolist()
    [200, 0]
    """
    import manifold3d

    loops = _check_loops(loops)
    check_option(mode, ("middle", "inclusive", "exclusive"), "mode")
    if mode == "middle" or loops.n_layers == 0:
        return loops
    n = loops.n_layers
    pieces = []
    for k0, k1 in _batches(n):  # layer k needs raw layer k + 1 too
        if mode == "inclusive":
            s = _cross_sections(loops, manifold3d.FillRule.NonZero, k0, min(k1 + 1, n))
            out = [a + b for a, b in itertools.pairwise(s)]
            top = s[-1]
        else:
            s = _cross_sections(loops, manifold3d.FillRule.EvenOdd, k0, min(k1 + 1, n))
            out = [a ^ b for a, b in itertools.pairwise(s)]
            top = manifold3d.CrossSection()
        f, lens, layer = _polygons([*out, top] if k1 == n else out)
        pieces.append((f, lens, layer + k0))
    f, lens, layer = _concat(pieces)
    area_f = _signed_area(f, lens)
    coords = np.rint(f).astype(np.int64)
    coords, _, lens = _dedupe(coords, _vertex_keys(coords), lens)
    offsets = _offsets(lens)
    area2 = ring_area2(coords, offsets)
    order = np.flatnonzero(area2 != 0)
    flip = (area2 > 0) != (area_f > 0)
    coords, ring_offsets = _take_rings(
        coords, offsets, order, np.zeros_like(lens), flip
    )
    layer_offsets = _offsets(np.bincount(layer[order], minlength=n))
    return LayerPaths._trusted(coords, ring_offsets, layer_offsets, loops.open)

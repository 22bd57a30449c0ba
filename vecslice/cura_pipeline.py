"""CuraEngine's per-layer clean-up and part building: ``SliceSettings(compat="cura")``.

After :func:`vecslice.cura_slicing.cura_raw`, CuraEngine's ``makePolygons`` drops
tiny polygons, simplifies and removes degenerate vertices (:func:`cura_clean`);
``createLayerWithParts`` then chains the open polylines (:func:`cura_before_union`)
and unions the polygons into parts. :func:`cura_stages` runs the whole chain and
returns every stage; :func:`vecslice.slice_mesh` uses the same functions.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vecslice._kernels.cura_clean import (
    path_lengths,
    remove_degenerate_polyline_vertices,
)
from vecslice._kernels.cura_polylines import stitch_open_polylines
from vecslice._kernels.simplify import remove_degenerate_vertices, ring_perimeters
from vecslice.cura_slicing import NO_COMPENSATION, CuraLayers, concat_layers, cura_raw
from vecslice.layers import layer_heights
from vecslice.parts import apply_slicing_tolerance, make_parts
from vecslice.paths import LayerPaths
from vecslice.pipeline import _keep_rings
from vecslice.settings import SliceSettings
from vecslice.simplify import simplify_rings

if TYPE_CHECKING:
    from vecslice.storage import SlicedModel

__all__ = [
    "WALL_LINE_WIDTH_0",
    "cura_before_union",
    "cura_clean",
    "cura_stages",
    "slice_mesh_cura",
]

WALL_LINE_WIDTH_0 = 400
"""Cura's default ``wall_line_width_0`` (µm): the open-polyline stitcher's reach."""
SNAP_DISTANCE = 10
"""The open-polyline stitcher's snap distance (µm)."""


def _select(paths: LayerPaths, keep: NDArray[np.bool_]) -> LayerPaths:
    """The rings of ``paths`` where ``keep``, layers preserved."""
    return _keep_rings(paths, np.ascontiguousarray(keep, dtype=np.bool_))


def _same_layers(
    paths: LayerPaths, coords: NDArray[np.int64], ring_offsets: NDArray[np.int64]
) -> LayerPaths:
    """One new ring per ring of ``paths`` (same layers), empty rings dropped."""
    out = LayerPaths._trusted(coords, ring_offsets, paths.layer_offsets.copy())
    return _select(out, np.diff(ring_offsets) > 0)


def cura_clean(raw: CuraLayers, settings: SliceSettings) -> CuraLayers:
    """CuraEngine's ``makePolygons`` after stitching: filter, simplify, degenerates.

    Polygons shorter than ``max(minimum_polygon_circumference, 1)`` are dropped,
    measured without their closing segment when explicitly closed (CuraEngine's
    rule: a loop closed by stitching is measured short), with it otherwise. The
    rest are simplified as closed polygons (an explicit closing point is simplified
    like any other vertex; empty results dropped), then vertices where a polygon
    exactly reverses are removed (polygons left with <= 2 vertices dropped). Open
    polylines are filtered by length and their degenerate vertices removed (they
    are simplified only after the open-polyline stitcher, see
    :func:`cura_before_union`).

    Parameters
    ----------
    raw : CuraLayers
        From :func:`vecslice.cura_slicing.cura_raw`.
    settings : SliceSettings
        Thresholds in µm.

    Returns
    -------
    CuraLayers
        Implicitly closed polygons (CuraEngine's ``SlicerLayer.polygons_``), with
        the open polylines in ``.polygons.open``.

    Examples
    --------
    >>> import trimesh, vecslice as vs
    >>> from vecslice.cura_slicing import cura_raw
    >>> box = trimesh.creation.box((2, 2, 2))
    >>> _ = box.apply_translation((1, 1, 1))
    >>> raw = cura_raw(vs.load_mesh(box, compat="cura"), [1000])
    >>> simp = cura_clean(raw, vs.SliceSettings(compat="cura"))
    >>> simp.polygons.layer(0)[0].tolist()
    [[0, 0], [2000, 0], [2000, 2000], [0, 2000]]
    """
    s = settings
    snap = max(s.minimum_polygon_circumference, 1)
    polys = raw.polygons
    length = np.where(raw.explicit, path_lengths(polys.coords, polys.ring_offsets),
                      ring_perimeters(polys.coords, polys.ring_offsets))
    kept = _select(polys, length >= snap)
    coords, offsets = simplify_rings(kept.coords, kept.ring_offsets, True,
                                     s.max_resolution, s.max_deviation,
                                     s.max_area_deviation)
    coords, offsets = remove_degenerate_vertices(coords, offsets)
    closed = _same_layers(kept, coords, offsets)
    chains = polys.open if polys.open is not None else LayerPaths.empty(
        polys.n_layers)
    chains = _select(chains, path_lengths(chains.coords, chains.ring_offsets) >= snap)
    coords, offsets = remove_degenerate_polyline_vertices(chains.coords,
                                                          chains.ring_offsets)
    chains = LayerPaths._trusted(coords, offsets, chains.layer_offsets.copy())
    out = LayerPaths._trusted(closed.coords, closed.ring_offsets,
                              closed.layer_offsets, chains)
    return CuraLayers(out, np.zeros(out.n_rings, dtype=bool))


def cura_before_union(
    clean: CuraLayers,
    settings: SliceSettings,
    *,
    max_stitch_distance: int = WALL_LINE_WIDTH_0,
) -> CuraLayers:
    """CuraEngine's ``createLayerWithParts`` up to the union.

    The open polylines are chained by the open-polyline stitcher
    (:func:`vecslice._kernels.cura_polylines.stitch_open_polylines`, reach
    ``max_stitch_distance`` µm, snap 10 µm); chains that close are appended to the
    layer's polygons as explicitly closed polygons (not simplified), the others are
    simplified as open polylines (empty results dropped).

    Parameters
    ----------
    clean : CuraLayers
        From :func:`cura_clean` (after the slicing tolerance).
    settings : SliceSettings
        Simplification thresholds (µm) for the open polylines.
    max_stitch_distance : int, default 400
        Cura's ``wall_line_width_0`` in µm.

    Returns
    -------
    CuraLayers
        The polygons handed to the union, and the layer's open polylines in
        ``.polygons.open``.

    Notes
    -----
    CuraEngine visits the candidate endpoints in its hash grid's order, which
    matters only between endpoints at equal distance or when one closer than
    10 µm ends the search; here they are visited line by line (first point before
    last), see :func:`vecslice._kernels.cura_polylines.stitch_open_polylines`.
    """
    s = settings
    polys = clean.polygons
    lines = polys.open if polys.open is not None else LayerPaths.empty(
        polys.n_layers)
    cc, cr, cl, oc, orr, ol = stitch_open_polylines(
        lines.coords, lines.ring_offsets, lines.layer_offsets, max_stitch_distance,
        SNAP_DISTANCE)
    new = LayerPaths._trusted(cc, cr, cl)
    explicit = clean.explicit
    if new.n_rings:
        base = LayerPaths._trusted(polys.coords, polys.ring_offsets,
                                   polys.layer_offsets)
        merged = concat_layers(base, new)
        flags = np.concatenate([clean.explicit, np.ones(new.n_rings, dtype=bool)])
        key = np.concatenate([2 * base.ring_layer(), 2 * new.ring_layer() + 1])
        explicit = flags[np.argsort(key, kind="stable")]
    else:
        merged = polys
    coords, offsets = simplify_rings(oc, orr, False, s.max_resolution,
                                     s.max_deviation, s.max_area_deviation)
    still_open = _same_layers(LayerPaths._trusted(oc, orr, ol), coords, offsets)
    out = LayerPaths._trusted(merged.coords, merged.ring_offsets,
                              merged.layer_offsets, still_open)
    return CuraLayers(out, explicit)


def cura_stages(mesh: Any, settings: SliceSettings) -> dict[str, Any]:
    """Every stage of CuraEngine's slicer on ``mesh``, for comparisons and tests.

    Returns
    -------
    dict
        ``slice_z``, ``print_z``, ``thickness``; ``raw``, ``simp`` and
        ``before_union`` (:class:`CuraLayers`, with the open polylines of the stage
        in ``.polygons.open``); ``parts`` (:class:`vecslice.parts.LayerParts`).

    Examples
    --------
    >>> import trimesh, vecslice as vs
    >>> box = trimesh.creation.box((2, 2, 2))
    >>> _ = box.apply_translation((1, 1, 1))
    >>> st = cura_stages(vs.load_mesh(box, compat="cura"),
    ...                  vs.SliceSettings(compat="cura"))
    >>> [st[k].polygons.coords.shape[0] for k in ("raw", "simp", "before_union")]
    [162, 72, 72]
    """
    slice_z, print_z, thickness = layer_heights(mesh, settings)
    raw = cura_raw_for(mesh, slice_z, settings)
    simp = cura_clean(raw, settings)
    before = cura_before_union(_tolerance(simp, settings.slicing_tolerance), settings)
    parts = make_parts(before.polygons,
                       union_overlapping_volumes=settings.union_overlapping_volumes)
    return {"slice_z": slice_z, "print_z": print_z, "thickness": thickness,
            "raw": raw, "simp": simp, "before_union": before, "parts": parts}


def _tolerance(simp: CuraLayers, mode: str) -> CuraLayers:
    """CuraEngine's slicing tolerance after ``makePolygons`` (flags kept if none)."""
    tol = apply_slicing_tolerance(simp.polygons, mode)  # type: ignore[arg-type]
    if tol is simp.polygons:
        return simp
    return CuraLayers(tol, np.zeros(tol.n_rings, dtype=bool))


def slice_mesh_cura(
    mesh: Any, settings: SliceSettings, st: Any, times: Any
) -> SlicedModel:
    """:func:`vecslice.slice_mesh` with ``compat="cura"`` (``st``: its stage timer)."""
    from vecslice.storage import SlicedModel

    try:
        slice_z, print_z, thickness = st.run("layers", layer_heights, mesh, settings)
        raw = st.run("contours", cura_raw_for, mesh, slice_z, settings)
        simp = st.run("simplify", cura_clean, raw, settings)
        simp = st.run("tolerance", _tolerance, simp, settings.slicing_tolerance)
        before = st.run("stitch", cura_before_union, simp, settings)
        parts = st.run("parts", make_parts, before.polygons,
                       union_overlapping_volumes=settings.union_overlapping_volumes)
        stats = raw.stats if raw.stats is not None else np.zeros((0, 4), np.int64)
        # chains left open by CuraEngine's stitching (stats[:, 2] counts them
        # before it), as the default mode counts them after vecslice's
        left = raw.polygons.open
        open_chains = (left.rings_per_layer() if left is not None
                       else np.zeros(raw.polygons.n_layers, np.int64))
        model = st.run("store", SlicedModel.from_parts, parts, slice_z=slice_z,
                       print_z=print_z, thickness=thickness,
                       open=before.polygons.open, open_chains=open_chains,
                       stitched_gaps=stats[:, 3])
    finally:
        st.close()
    if times is not None:
        times.seconds.update(st.times.seconds)
    return model


def cura_raw_for(mesh: Any, slice_z: Any, settings: SliceSettings) -> CuraLayers:
    """:func:`cura_raw` with the on-plane compensation ``settings`` ask for."""
    if settings.slicing_tolerance == "inclusive":
        return cura_raw(mesh, slice_z, compensate_below=NO_COMPENSATION)
    return cura_raw(mesh, slice_z)

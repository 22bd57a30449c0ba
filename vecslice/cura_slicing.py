"""CuraEngine's slicer, end to end up to the union: ``SliceSettings(compat="cura")``.

The stages of ``spec/CURA_COMPAT.md`` sections 3, 4 and 6, each returning
:class:`CuraLayers` so tests can compare them with CuraEngine's own output:

* :func:`cura_raw` -- per-face segments, ``makeBasicPolygonLoops``,
  ``connectOpenPolylines`` and ``stitch`` (the ``raw`` stage);
* :func:`cura_clean` -- circumference filter, simplification and degenerate
  vertices (the ``simp`` stage, CuraEngine's ``makePolygons`` result);
* :func:`cura_before_union` -- the open-polyline stitcher of
  ``createLayerWithParts`` (the ``before_union`` stage).

:func:`vecslice.slice_mesh` chains them when ``settings.compat == "cura"``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice._kernels.contours import vertex_layers
from vecslice._kernels.cura_loops import basic_loops, emit_rings
from vecslice._kernels.cura_segments import (
    classify_slots,
    face_ranges,
    fill_segments,
    order_by_layer,
)
from vecslice._kernels.cura_stitch import connect_open_polylines
from vecslice._threads import run_chunks
from vecslice.errors import InputValueError
from vecslice.paths import LayerPaths
from vecslice.ragged import freeze, reduce_frozen
from vecslice.slicing import _check_mesh, _check_slice_z

__all__ = ["NO_COMPENSATION", "STITCH_ROUNDS", "CuraLayers", "concat_layers",
           "cura_raw"]

NO_COMPENSATION = -(2**62)
"""``compensate_below`` value that disables the on-plane compensation."""

# connectOpenPolylinesImpl calls of SlicerLayer::makePolygons: (max_dist, cell,
# allow_reverse) = largest_neglected_gap_second_phase with cell 2 * first phase,
# then max_stitch1 = MM2INT(10.0) with reversal
STITCH_ROUNDS = np.array([[20, 20, 0], [10_000, 10_000, 1]], dtype=np.int64)


@dataclass(frozen=True, slots=True, eq=False)
class CuraLayers:
    """Polygons per layer at one stage of CuraEngine's slicer, with their flags.

    Attributes
    ----------
    polygons : LayerPaths
        Closed polygons per layer, in CuraEngine's order; ``polygons.open`` holds
        the open polylines of the stage.
    explicit : ndarray of shape (R,), bool
        Per polygon: explicitly closed (its last point repeats the first, within
        10 µm for loops closed by the mesh topology; a loop closed by stitching
        ends where the last chain ended).
    stats : ndarray of shape (L, 4), int64 or None
        Per layer (raw stage only): segments, loops closed by topology, open chains
        before stitching, joins and closures made by stitching.
    """

    polygons: LayerPaths
    explicit: NDArray[np.bool_]
    stats: NDArray[np.int64] | None = None

    def __post_init__(self) -> None:
        # held immutably, like every container's arrays (see ragged.freeze)
        object.__setattr__(self, "explicit", freeze(self.explicit))
        if self.stats is not None:
            object.__setattr__(self, "stats", freeze(self.stats))

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickles and copies hold read-only arrays too (see ragged.reduce_frozen)."""
        return reduce_frozen(self)


def concat_layers(a: LayerPaths, b: LayerPaths) -> LayerPaths:
    """Per layer, the rings of ``a`` followed by the rings of ``b`` (same layers).

    A layer's rings are one block of vertices, so the result is two block copies
    per layer (one allocation for all).
    """
    a_lo, b_lo = a.layer_offsets, b.layer_offsets
    a_at, b_at = a.ring_offsets[a_lo], b.ring_offsets[b_lo]  # vertex of each layer
    a_len, b_len = np.diff(a.ring_offsets), np.diff(b.ring_offsets)
    blocks: list[NDArray[np.int64]] = [np.empty((0, 2), dtype=np.int64)]
    lens: list[NDArray[np.int64]] = [np.empty(0, dtype=np.int64)]
    for k in range(a.n_layers):
        blocks += [a.coords[a_at[k]:a_at[k + 1]], b.coords[b_at[k]:b_at[k + 1]]]
        lens += [a_len[a_lo[k]:a_lo[k + 1]], b_len[b_lo[k]:b_lo[k + 1]]]
    ring_lens = np.concatenate(lens)
    offsets = np.zeros(ring_lens.shape[0] + 1, dtype=np.int64)
    np.cumsum(ring_lens, out=offsets[1:])
    return LayerPaths._trusted(np.concatenate(blocks), offsets, a_lo + b_lo)


def cura_raw(
    mesh: Any, slice_z: ArrayLike, *, compensate_below: int | None = None
) -> CuraLayers:
    """CuraEngine's polygons of every plane before its circumference filter.

    Parameters
    ----------
    mesh : Mesh
        Best loaded with ``load_mesh(path, compat="cura")``; any mesh is sliced
        as given.
    slice_z : array_like of shape (L,), int
        Plane heights in µm, sorted (non-decreasing).
    compensate_below : int, optional
        Vertices exactly on a plane lower than this (µm) are moved down 1 µm
        first; default: the mesh's lowest z + 1 (CuraEngine: planes at z <= 0 with
        the mesh on the bed). ``slicing_tolerance='inclusive'`` passes no
        compensation.

    Returns
    -------
    CuraLayers
        Explicitly closed loops and stitched polygons; ``.polygons.open`` holds
        the polylines left open.

    Raises
    ------
    InputTypeError
        If ``mesh`` is not a :class:`vecslice.Mesh` or ``slice_z`` not integer.
    InputValueError
        If ``slice_z`` is not sorted or beyond 2**30 µm.

    Notes
    -----
    Per plane, in CuraEngine's order: each face gives at most one segment from its
    own vertex order with CuraEngine's ``interpolate`` (the two faces of an edge
    may disagree by a micron); chains start at the lowest unused segment and
    append only segment ends, so a loop closed by the mesh topology repeats its
    first point within 10 µm (its *closing point*, kept); an end on a mesh vertex
    (a vertex exactly on the plane) tries every face around that vertex. Open
    chains are joined by ``connectOpenPolylines`` (end to start, < 20 µm) and
    ``stitch`` (< 10 mm, also reversing); joints keep both points.

    Planes at or below the mesh's lowest point stand for CuraEngine's ``z <= 0``
    (the mesh on the bed): there, vertices on the plane move 1 µm down.

    Examples
    --------
    A 2 mm box resting on z = 0, cut at 1 mm: 8 segments give 9 points, the last
    1 µm from the first; ``999`` and ``1001`` show ``interpolate``'s bias.

    >>> import trimesh, vecslice as vs
    >>> box = trimesh.creation.box((2, 2, 2))
    >>> _ = box.apply_translation((1, 1, 1))
    >>> raw = cura_raw(vs.load_mesh(box, compat="cura"), [1000])
    >>> raw.polygons.layer(0)[0].tolist()  # doctest: +NORMALIZE_WHITESPACE
    [[0, 1000], [0, 0], [999, 0], [2000, 0], [2000, 999], [2000, 2000],
     [1001, 2000], [0, 2000], [0, 1001]]
    >>> raw.explicit.tolist(), raw.stats.tolist()
    ([True], [[8, 1, 0, 0]])
    """
    vertices, faces = _check_mesh(mesh, True)
    z = _check_slice_z(slice_z)
    n_layers = z.shape[0]
    bad = np.flatnonzero(z[1:] < z[:-1])
    if bad.size:
        i = int(bad[0])
        raise InputValueError(
            f"`slice_z` must be sorted (non-decreasing); got {z[i]} > {z[i + 1]} at "
            f"index {i}"
        )
    limit = (mesh._corner_zrange()[0] + 1 if compensate_below is None
             else compensate_below)
    # built once per mesh; faces that repeat a vertex index are dropped, as
    # CuraEngine's addFace drops them (their corners still count for the limit)
    faces, vf_offsets, vf_faces, neighbours = mesh._cura_topology()
    vert_layer = vertex_layers(vertices, z, run=run_chunks)  # searchsorted, left
    face_lo, slot_offsets = face_ranges(vert_layer, faces)
    valid = classify_slots(vertices, faces, z, face_lo, slot_offsets, limit,
                           run=run_chunks)
    layer_offsets, slot_seg = order_by_layer(valid, face_lo, slot_offsets, n_layers)
    points, links = fill_segments(vertices, faces, neighbours, z, face_lo,
                                  slot_offsets, slot_seg, limit, run=run_chunks)
    seg_order, ring_start, closed = basic_loops(
        points, links, layer_offsets, face_lo, slot_offsets, slot_seg, vf_offsets,
        vf_faces, run=run_chunks,
    )
    lc, lr, ll, cc, cr, cl = emit_rings(points, seg_order, ring_start, closed,
                                        layer_offsets, run=run_chunks)
    loops = LayerPaths._trusted(lc, lr, ll)
    chains = LayerPaths._trusted(cc, cr, cl)
    stitched = np.zeros(n_layers, dtype=np.int64)
    n_open = chains.rings_per_layer()
    n_loops = loops.rings_per_layer()
    if chains.n_rings:
        cc, cr, cl, oc, orr, ol, stitched = connect_open_polylines(
            chains.coords, chains.ring_offsets, chains.layer_offsets, STITCH_ROUNDS)
        loops = concat_layers(loops, LayerPaths._trusted(cc, cr, cl))
        chains = LayerPaths._trusted(oc, orr, ol)
    stats = np.stack([np.diff(layer_offsets), n_loops, n_open, stitched], axis=1)
    polygons = LayerPaths._trusted(loops.coords, loops.ring_offsets,
                                   loops.layer_offsets, chains)
    return CuraLayers(polygons, np.ones(loops.n_rings, dtype=bool), stats)

"""Batched triangle–plane intersection: a mesh in, closed loops for every layer out."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice._kernels.crossings import crossing_points, face_segments, range_offsets
from vecslice._kernels.loops import link_segments
from vecslice._kernels.rings import group_rings
from vecslice._kernels.topology import edge_topology
from vecslice._validate import (
    as_int_array,
    check_bool,
    check_coord_range,
    check_int,
    check_layer_count,
)
from vecslice.errors import InputTypeError
from vecslice.paths import LayerPaths
from vecslice.settings import MAX_LAYERS
from vecslice.stitch import stitch as stitch_chains

__all__ = ["slice_contours"]


def _layer_of_vertices(
    vertices: NDArray[np.int64], z: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Number of (sorted) planes strictly below each vertex.

    A vertex is above plane ``k`` iff ``k < vert_layer[v]``, so an element whose
    vertices have layers ``l`` meets planes ``min(l) <= k < max(l)``.
    """
    return np.searchsorted(z, vertices[:, 2], side="left").astype(np.int64)


def _check_mesh(
    mesh: Any, stitch: object
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    from vecslice.mesh import Mesh

    check_bool(stitch, "stitch")
    if not isinstance(mesh, Mesh):
        raise InputTypeError(
            f"`mesh` must be a vecslice.Mesh (see vecslice.load_mesh); "
            f"got {type(mesh).__name__}"
        )
    return mesh.vertices, mesh.faces


def _check_slice_z(slice_z: ArrayLike) -> NDArray[np.int64]:
    z = as_int_array(slice_z, "slice_z", ndim=1)
    check_coord_range(z, "slice_z")
    return z


def slice_contours(
    mesh: Any, slice_z: ArrayLike, *, stitch: bool = True, max_layers: int = MAX_LAYERS
) -> LayerPaths:
    """Cut ``mesh`` at every height of ``slice_z`` into raw closed loops.

    Parameters
    ----------
    mesh : Mesh
        Triangle mesh in µm (see :func:`vecslice.load_mesh`).
    slice_z : array_like of shape (L,), int
        Heights in µm, in the mesh's frame. Any order and spacing; the result's
        layer ``k`` is the cut at ``slice_z[k]``.
    stitch : bool, default True
        Join the open chains of broken meshes by CuraEngine's rules (see
        :func:`vecslice.stitch`); ``False`` returns them as the topology left them.
    max_layers : int, default 100000 (``vecslice.settings.MAX_LAYERS``)
        More heights than this raise a :class:`SettingsError` before any work.

    Returns
    -------
    LayerPaths
        Closed loops per layer (outer loops CCW, holes CW, first vertex not
        repeated); ``.open`` holds the chains that did not close, per layer.
        No simplification and no union.

    Notes
    -----
    Each mesh edge is intersected once with every plane it crosses, and both faces
    sharing it use that one point, rounded once (half away from zero) in exact
    integer arithmetic: loops close by construction. A vertex exactly on a plane
    counts as below it, so a face meets plane z iff ``zmin <= z < zmax``: a plane at
    a model's bottom gives its bottom outline and a plane at its top gives nothing.
    Loops follow the mesh topology: each crossing is joined to the next face's
    segment through the edge they share (pairwise on non-manifold edges). Chains
    that do not close (open surfaces, flipped faces) are stitched; what stays open
    is returned in ``.open``, never dropped.

    Examples
    --------
    >>> import vecslice as vs
    >>> import trimesh
    >>> box = vs.load_mesh(trimesh.creation.box((10, 10, 10)))
    >>> loops = vs.slice_contours(box, [0, 4999])
    >>> [len(loops.layer(k)) for k in range(2)], loops.layer_area2().tolist()
    ([1, 1], [200000000, 200000000])
    """
    vertices, faces = _check_mesh(mesh, stitch)
    z = _check_slice_z(slice_z)
    limit = check_int(max_layers, "max_layers", minimum=1,
                      what="an integer number of layers")
    check_layer_count(z.shape[0], limit, f"{z.shape[0]} heights in `slice_z`",
                      "slice_contours(..., max_layers={n})")
    return _contours(vertices, faces, z, stitch, None)


def _mesh_topology(mesh: Any) -> tuple[NDArray[np.int64], ...]:
    """The edge topology :func:`slice_contours` builds, for reuse across calls.

    Pass it to ``_contours`` (as ``vecslice.sweep`` does) to slice one mesh at
    several schedules while building its topology once.
    """
    vertices, faces = _check_mesh(mesh, False)
    return tuple(edge_topology(faces, vertices.shape[0]))


def _contours(
    vertices: NDArray[np.int64],
    faces: NDArray[np.int64],
    z: NDArray[np.int64],
    stitch: bool,
    topology: tuple[NDArray[np.int64], ...] | None,
) -> LayerPaths:
    """:func:`slice_contours` on checked input, with an optional prebuilt topology."""
    order = np.argsort(z, kind="stable")
    is_sorted = bool(np.all(order == np.arange(z.shape[0])))
    zs = z if is_sorted else z[order]
    n_layers = zs.shape[0]
    if n_layers == 0 or faces.shape[0] == 0:
        empty = LayerPaths.empty(n_layers)
        return LayerPaths(empty.coords, empty.ring_offsets, empty.layer_offsets,
                          open=LayerPaths.empty(n_layers))

    if topology is None:
        topology = tuple(edge_topology(faces, vertices.shape[0]))
    face_edges, edge_vertices, twin = topology
    vert_layer = _layer_of_vertices(vertices, zs)
    edge_offsets = range_offsets(vert_layer, edge_vertices)
    points = crossing_points(vertices, edge_vertices, vert_layer, edge_offsets, zs)
    edge_base = edge_offsets[:-1] - np.minimum(
        vert_layer[edge_vertices[:, 0]], vert_layer[edge_vertices[:, 1]]
    )
    face_offsets = range_offsets(vert_layer, faces)
    seg_from, seg_to, seg_layer, nxt, has_prev = face_segments(
        faces, face_edges, vert_layer, edge_base, face_offsets, twin
    )
    cv, cr, cl, ov, orr, ol = link_segments(nxt, has_prev, seg_from, seg_to, seg_layer)
    if is_sorted:
        rank = np.arange(n_layers, dtype=np.int64)
    else:
        rank = np.empty_like(order)
        rank[order] = np.arange(n_layers, dtype=np.int64)
    closed = _group_by_layer(points, cv, cr, cl, rank)
    open_chains = _group_by_layer(points, ov, orr, ol, rank)
    loops = LayerPaths._trusted(
        closed.coords, closed.ring_offsets, closed.layer_offsets, open_chains
    )
    if stitch and open_chains.n_rings:
        loops = stitch_chains(loops).loops
    return loops


def _group_by_layer(
    points: NDArray[np.int64],
    verts: NDArray[np.int64],
    ring_offsets: NDArray[np.int64],
    ring_layer: NDArray[np.int64],
    rank: NDArray[np.int64],
) -> LayerPaths:
    """Group rings by output layer: sorted plane ``rank[i]`` becomes layer ``i``."""
    n_layers = rank.shape[0]
    out_layer = np.empty_like(rank)
    out_layer[rank] = np.arange(n_layers, dtype=np.int64)
    coords, new_ring_offsets, layer_offsets = group_rings(
        points, verts, ring_offsets, out_layer[ring_layer], n_layers
    )
    return LayerPaths._trusted(coords, new_ring_offsets, layer_offsets)

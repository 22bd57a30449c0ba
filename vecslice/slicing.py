"""Batched triangle–plane intersection: a mesh in, closed loops for every layer out."""

from __future__ import annotations

from typing import Any

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice._kernels.contours import trace_contours, vertex_layers
from vecslice._threads import run_chunks
from vecslice._validate import (
    check_bool,
    check_coord_range,
    check_int,
    check_layer_count,
)
from vecslice.errors import InputTypeError
from vecslice.interrupt import keyboard_interrupts
from vecslice.paths import LayerPaths
from vecslice.ragged import private_int_array
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
    return vertex_layers(vertices, z, run=run_chunks)


def _chunks_for(n_faces: int, n_planes: int) -> int:
    """Chunks of planes to trace on threads: 4 per worker, one for small work.

    Each chunk scans every face once, so a small mesh (or few planes) is traced
    in one chunk, on the calling thread.
    """
    if n_faces * min(n_planes, 64) < 2_000_000:
        return 1
    return 4 * numba.get_num_threads()


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
    """Private copy of ``slice_z``, checked after copying: the kernels read only it."""
    z = private_int_array(slice_z, "slice_z", ndim=1)
    check_coord_range(z, "slice_z")
    return z


@keyboard_interrupts
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

    Raises
    ------
    InputTypeError
        If ``mesh`` is not a :class:`Mesh`, ``stitch`` not a bool, or
        ``slice_z`` not integer.
    InputValueError
        If ``slice_z`` is not 1-D or reaches 2**30 µm, or the mesh has more
        than 715,827,882 faces (half-edges are numbered in int32) or more than
        2**31 vertices (face indices are read as int32).
    SettingsError
        If there are more than ``max_layers`` heights.

    Notes
    -----
    Each mesh edge is intersected once with every plane it crosses, and both faces
    sharing it use that one point, rounded once in exact integer arithmetic (its
    offset from the edge's lower end, half away from zero: slicing a translated
    mesh gives exactly translated loops): loops close by construction. A vertex
    exactly on a plane counts as below it, so a face meets plane z iff ``zmin <= z
    < zmax``: a plane at a model's bottom gives its bottom outline and a plane at
    its top gives nothing.
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
    _check_mesh(mesh, stitch)
    z = _check_slice_z(slice_z)
    limit = check_int(max_layers, "max_layers", minimum=1,
                      what="an integer number of layers")
    check_layer_count(z.shape[0], limit, f"{z.shape[0]} heights in `slice_z`",
                      "slice_contours(..., max_layers={n})")
    return _contours(mesh, z, stitch)


def _contours(mesh: Any, z: NDArray[np.int64], stitch: bool) -> LayerPaths:
    """:func:`slice_contours` on checked input.

    The mesh's half-edge twins (and whether it has open ends) and int32 faces
    are built on its first slice and cached on it, so every later slice of the
    same mesh (other heights, ``vecslice.sweep``) reuses them.
    """
    vertices, faces = mesh.vertices, mesh.faces
    order = np.argsort(z, kind="stable")
    is_sorted = bool(np.all(order == np.arange(z.shape[0])))
    zs = z if is_sorted else z[order]
    n_layers = zs.shape[0]
    if n_layers == 0 or faces.shape[0] == 0:
        empty = LayerPaths.empty(n_layers)
        return LayerPaths(empty.coords, empty.ring_offsets, empty.layer_offsets,
                          open=LayerPaths.empty(n_layers))

    # sorted plane k is input height order[k]: it becomes output layer order[k]
    out_layer = order.astype(np.int64)
    twin = mesh._half_edge_twins()
    faces32 = mesh._narrow_faces()
    vert_layer = _layer_of_vertices(vertices, zs)
    coords, ring_offsets, layer_offsets, o_coords, o_rings, o_layers = (
        trace_contours(vertices, faces, twin, vert_layer, zs, out_layer,
                       _chunks_for(faces.shape[0], zs.shape[0]), run=run_chunks,
                       faces32=faces32, closed=mesh._twins_closed())
    )
    open_chains = LayerPaths._trusted(o_coords, o_rings, o_layers)
    loops = LayerPaths._trusted(coords, ring_offsets, layer_offsets, open_chains)
    if stitch and open_chains.n_rings:
        loops = stitch_chains(loops).loops
    return loops


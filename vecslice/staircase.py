"""A sliced model's layer volume against its mesh (see :mod:`vecslice.metrics`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vecslice.errors import InputTypeError
from vecslice.interrupt import keyboard_interrupts
from vecslice.storage import SlicedModel, check_model

__all__ = ["VolumeStats", "volume_error"]


@dataclass(frozen=True, slots=True)
class VolumeStats:
    """The volume of a sliced model's layers against its mesh; the Z staircase.

    ``volume_error_mm3`` is what the model's layers (area x thickness) miss or
    add: the Z staircase, plus what simplification changed in the areas, plus
    the slicing tolerance's union or intersection with the next layer.
    ``staircase_error_mm3`` is the Z staircase alone: the same slabs filled by
    the mesh's exact sections at the model's cut heights.

    Attributes
    ----------
    layers : int
        Number of layers.
    mesh_volume_mm3 : float
        Volume of the solid the mesh bounds, mm³: its signed volume, with the
        windings repaired where they are inconsistent (see
        :func:`volume_error`); meaningful for closed meshes.
    staircase_volume_mm3 : float
        Sum over layers of layer area times the part of its slab inside the mesh's
        height, mm³.
    reference_volume_mm3 : float
        The mesh's volume below the top of the layer stack (all of it when the
        stack reaches the mesh's top), mm³.
    volume_error_mm3 : float
        ``staircase - reference`` volume, mm³: the model's volume error.
    relative_volume_error : float
        ``volume_error / reference`` (NaN for a zero reference).
    section_volume_mm3 : float
        As ``staircase_volume_mm3``, with each layer's area that of the mesh's
        section at the layer's cut height (``slice_z``; the raw loops' signed
        area), mm³.
    staircase_error_mm3 : float
        ``section - reference`` volume, mm³: the Z staircase alone, whatever
        the XY settings.
    relative_staircase_error : float
        ``staircase_error / reference`` (NaN for a zero reference).
    stack_height_um : int
        Top of the last layer above the mesh's lowest point, µm.
    height_um : int
        Height of the mesh, µm.
    """

    layers: int
    mesh_volume_mm3: float
    staircase_volume_mm3: float
    reference_volume_mm3: float
    volume_error_mm3: float
    relative_volume_error: float
    stack_height_um: int
    height_um: int
    section_volume_mm3: float
    staircase_error_mm3: float
    relative_staircase_error: float


@dataclass(frozen=True)
class _Solid:
    """The faces whose signed volume is the solid the slicer fills, and it (µm³)."""

    vertices: NDArray[np.int64]
    faces: NDArray[np.int64]
    volume_um3: float


def _solid(mesh: Any) -> _Solid:
    """What the staircase is measured against: the solid the slicer fills.

    The union fills a body whatever its faces' winding (NonZero), but the
    signed volume of faces wound inconsistently or inside out is not that
    body's: ``hourglass.stl`` read without repair (``compat="cura"``,
    ``repair=False``) has 1,622 of its 2,146 facets inside out and a signed
    volume of 7,858 mm³ for a solid of 34,297 mm³. A closed mesh wound
    consistently (every half-edge has its twin; the topology slicing caches) is
    measured as given, turned over if it is wholly inside out (a negative
    volume); any other is measured after :meth:`Mesh.repaired` (windings made
    consistent and outward shell by shell, duplicate faces dropped).
    """
    if mesh._twins_closed():
        vol = mesh.volume
        if vol >= 0:
            return _Solid(mesh.vertices, mesh.faces, vol)
        return _Solid(mesh.vertices, np.ascontiguousarray(mesh.faces[:, ::-1]), -vol)
    fixed = mesh.repaired()
    return _Solid(fixed.vertices, fixed.faces, fixed.volume)


def _volume_below(vertices: NDArray[np.int64], faces: NDArray[np.int64],
                  zmin: int, height: float) -> float:
    """Signed volume (µm³) of the closed mesh below ``z = zmin + height``.

    ``zmin`` is the mesh's lowest face corner. Divergence theorem with the field
    (x, 0, 0): the cut face is horizontal and contributes nothing, so the volume
    is the sum over the faces' parts below the plane of ``n_x * area *
    centroid_x`` (triangles clipped, in float64).
    """
    v = vertices.astype(np.float64)
    v -= v.mean(axis=0)
    v[:, 2] = vertices[:, 2] - zmin  # heights from the bottom
    tri = v[faces]
    below = tri[:, :, 2] <= height
    nb = below.sum(axis=1)

    def flux(a: NDArray[Any], b: NDArray[Any], c: NDArray[Any]) -> float:
        cx = (b[:, 1] - a[:, 1]) * (c[:, 2] - a[:, 2]) - (b[:, 2] - a[:, 2]) * (
            c[:, 1] - a[:, 1])
        return float((cx * (a[:, 0] + b[:, 0] + c[:, 0])).sum() / 6.0)

    def cut(p: NDArray[Any], q: NDArray[Any]) -> NDArray[Any]:
        t = (height - p[:, 2]) / (q[:, 2] - p[:, 2])
        return p + (q - p) * t[:, None]

    total = flux(tri[nb == 3, 0], tri[nb == 3, 1], tri[nb == 3, 2])
    for k in (1, 2):  # rotate so the lone vertex (below for 1, above for 2) is a
        sel = tri[nb == k]
        lone = below[nb == k] if k == 1 else ~below[nb == k]
        shift = np.argmax(lone, axis=1)
        idx = (shift[:, None] + np.arange(3)) % 3
        t3 = np.take_along_axis(sel, idx[:, :, None], axis=1)
        a, b, c = t3[:, 0], t3[:, 1], t3[:, 2]
        if k == 1:  # a below: triangle a, ab, ac
            total += flux(a, cut(a, b), cut(a, c))
        else:  # a above: quad b, c, ca, ab
            pab, pca = cut(b, a), cut(c, a)
            total += flux(b, c, pca) + flux(b, pca, pab)
    return total


@keyboard_interrupts
def volume_error(
    model: SlicedModel, mesh: Any, *, _solid_of_mesh: _Solid | None = None,
    _section_area_um2: NDArray[np.float64] | None = None,
) -> VolumeStats:
    """Volume of ``model``'s layers (area x thickness) against ``mesh``'s.

    Parameters
    ----------
    model : SlicedModel
        The model sliced from ``mesh`` (uniform or adaptive layers).
    mesh : Mesh
        Its mesh; the volume of the solid it bounds is the reference (its
        signed volume, after :meth:`~vecslice.Mesh.repaired` where it is open
        or wound inconsistently, turned over where it is wholly inside out:
        the slicer fills the body whatever the winding).

    Returns
    -------
    VolumeStats

    Notes
    -----
    Layer ``k`` stands for the slab ``[print_z - thickness, print_z]`` above the
    mesh's lowest point. Slabs are clipped to the mesh's height ``h``, and the
    reference is the mesh's volume below ``min(stack top, h)``, so neither error
    holds the rounding of the layer count (``stack_height_um`` against
    ``height_um`` shows that).

    The model's volume error (``volume_error_mm3``) holds the XY
    simplification too: on a smooth mesh at CuraEngine's default settings it
    can be several times the staircase. The staircase alone
    (``staircase_error_mm3``) fills the slabs with the mesh's exact sections at
    the cut heights (the raw loops of :func:`vecslice.slice_contours`, sliced
    here). A prism therefore has no staircase error at any layer height
    (unless a cut falls exactly on its top face, which gives an empty layer),
    and a cone cut at mid-layer loses ``A'' t^3 / 24`` per layer (``t``
    thickness, ``A(z)`` its section area).

    Examples
    --------
    A 10 mm x 10 mm x 2.04 mm box: 18 layers reach 2 mm, where the staircase
    matches the box exactly.

    >>> import trimesh, vecslice as vs
    >>> box = vs.load_mesh(trimesh.creation.box((10, 10, 2.04)))
    >>> st = volume_error(vs.slice_mesh(box), box)
    >>> st.layers, st.stack_height_um, st.height_um, st.volume_error_mm3
    (18, 2000, 2040, 0.0)
    >>> st.staircase_error_mm3
    0.0
    """
    from vecslice.mesh import Mesh

    check_model(model)
    if not isinstance(mesh, Mesh):
        raise InputTypeError(
            f"`mesh` must be a vecslice.Mesh; got {type(mesh).__name__}"
        )
    zmin, zmax = mesh._corner_zrange()  # the model: vertices of faces
    h = zmax - zmin
    top = np.clip(model.print_z, 0, h)
    bottom = np.clip(model.print_z - model.thickness, 0, h)
    stair = float((model.layer_areas() * (top - bottom)).sum()) * 1e-9
    if _section_area_um2 is None:
        from vecslice.metrics import _raw_area_um2
        from vecslice.slicing import slice_contours

        _section_area_um2 = _raw_area_um2(slice_contours(mesh, model.slice_z))
    sections = float((_section_area_um2 * (top - bottom)).sum()) * 1e-9
    solid = _solid(mesh) if _solid_of_mesh is None else _solid_of_mesh
    vol = solid.volume_um3 * 1e-9
    stack = int(model.print_z[-1]) if model.n_layers else 0
    ref = vol if stack >= h else _volume_below(solid.vertices, solid.faces, zmin,
                                               float(stack)) * 1e-9
    err = stair - ref
    z_err = sections - ref
    return VolumeStats(
        layers=model.n_layers,
        mesh_volume_mm3=vol,
        staircase_volume_mm3=stair,
        reference_volume_mm3=ref,
        volume_error_mm3=err,
        relative_volume_error=err / ref if ref else float("nan"),
        stack_height_um=stack,
        height_um=h,
        section_volume_mm3=sections,
        staircase_error_mm3=z_err,
        relative_staircase_error=z_err / ref if ref else float("nan"),
    )

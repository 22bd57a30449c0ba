"""Resolution metrics: vertex count and printer move rate against shape error."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecslice._kernels.simplify import ring_perimeters
from vecslice._validate import check_int
from vecslice.errors import InputTypeError
from vecslice.parts import layer_xor_areas
from vecslice.paths import LayerPaths
from vecslice.storage import SlicedModel

__all__ = ["ResolutionStats", "model_loops", "resolution_stats"]


def model_loops(model: SlicedModel) -> LayerPaths:
    """The rings of a :class:`SlicedModel` (outlines and holes) as a LayerPaths."""
    if not isinstance(model, SlicedModel):
        raise InputTypeError(
            f"`model` must be a vecslice.SlicedModel; got {type(model).__name__}"
        )
    layer_rings = model.part_offsets[model.layer_offsets]
    return LayerPaths._trusted(model.coords, model.ring_offsets, layer_rings.copy())


@dataclass(frozen=True, slots=True)
class ResolutionStats:
    """How a sliced model trades vertices against shape error.

    Attributes
    ----------
    vertices : int
        Stored vertices (each one a printer move along a contour).
    perimeter_um : int
        Total contour length in µm.
    mean_edge_um : float
        Mean move length in µm.
    moves_per_s : float
        Moves per second the printer must plan at ``speed_mm_s``.
    error_um2 : float
        Area of the symmetric difference with the reference, µm², all layers.
    relative_error : float
        ``error_um2`` over the sum of both areas (CuraEngine's relative Hamming
        distance).
    """

    vertices: int
    perimeter_um: int
    mean_edge_um: float
    moves_per_s: float
    error_um2: float
    relative_error: float


def resolution_stats(
    model: SlicedModel, reference: LayerPaths | SlicedModel, *, speed_mm_s: int = 60
) -> ResolutionStats:
    """Vertex count, move rate and shape error of ``model`` against ``reference``.

    Parameters
    ----------
    model : SlicedModel
        The simplified result (e.g. of :func:`vecslice.slice_mesh`).
    reference : LayerPaths or SlicedModel
        The same layers at full resolution, e.g. ``vs.slice_contours(mesh,
        model.slice_z)``.
    speed_mm_s : int, default 60
        Print speed along contours, mm/s, ``> 0``.

    Returns
    -------
    ResolutionStats

    Examples
    --------
    >>> import trimesh, vecslice as vs
    >>> mesh = vs.load_mesh(trimesh.creation.cylinder(radius=10, height=1))
    >>> model = vs.slice_mesh(mesh)
    >>> stats = resolution_stats(model, vs.slice_contours(mesh, model.slice_z))
    >>> stats.vertices, stats.mean_edge_um, bool(stats.relative_error < 1e-4)
    (256, 1960.0, True)
    """
    speed = check_int(speed_mm_s, "speed_mm_s", minimum=1)
    loops = model_loops(model)
    ref = model_loops(reference) if isinstance(reference, SlicedModel) else reference
    if not isinstance(ref, LayerPaths):
        raise InputTypeError(
            "`reference` must be a LayerPaths or SlicedModel; "
            f"got {type(reference).__name__}"
        )
    perim = int(ring_perimeters(loops.coords, loops.ring_offsets).sum())
    n = int(loops.coords.shape[0])
    mean_edge = perim / n if n else 0.0
    xor = layer_xor_areas(loops, ref)
    total = float(np.abs(loops.layer_area2()).sum() + np.abs(ref.layer_area2()).sum())
    err = float(xor.sum())
    return ResolutionStats(
        vertices=n,
        perimeter_um=perim,
        mean_edge_um=mean_edge,
        moves_per_s=speed * 1000.0 / mean_edge if mean_edge else 0.0,
        error_um2=err,
        relative_error=2 * err / total if total else 0.0,
    )

"""Exchange with other geometry libraries: layers as shapely geometries."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from vecslice.ragged import check_index, offsets_from_lengths

__all__ = ["to_shapely"]


def _close_rings(
    coords: NDArray[np.int64], offsets: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Rings ``offsets[i]:offsets[i + 1]`` with their first vertex repeated.

    GeoArrow/shapely layout; the returned offsets start at 0.
    """
    lens = np.diff(offsets)
    new_offsets = offsets_from_lengths(lens + 1)
    local = np.arange(new_offsets[-1], dtype=np.int64)
    local -= np.repeat(new_offsets[:-1], lens + 1)
    local %= np.maximum(np.repeat(lens, lens + 1), 1)
    return coords[local + np.repeat(offsets[:-1], lens + 1)], new_offsets


def to_shapely(parts: Any, k: int, *, scale: float = 1e-3) -> Any:
    """Layer ``k`` of a parts container as a shapely MultiPolygon.

    Parameters
    ----------
    parts : LayerParts or SlicedModel
        Anything with ``coords``, ``ring_offsets``, ``part_offsets`` and
        ``layer_offsets``.
    k : int
        Layer index (negative counts from the end).
    scale : float, default 1e-3
        Factor from µm to the output unit (default: millimetres).

    Returns
    -------
    shapely.MultiPolygon
        One polygon per part, rings closed as shapely requires.

    Notes
    -----
    The rings are the union's (Clipper2, through manifold3d) rounded to whole
    µm. As in CuraEngine, a ring may touch itself or another ring at a vertex,
    which is a valid Clipper polygon but not a valid OGC one, so shapely's
    ``is_valid`` can be False. On the shared meshes with the default settings
    that happens in about a third of the layers of the broken
    ``openscad-nonmanifold-crash.obj`` (where rounding also leaves a 1 µm² hole
    just outside its outline), in 4 of the 1,874 parts of the scanned
    ``bun_zipper_res2.ply`` (read in metres) and in no part of the others; with
    ``slicing_tolerance`` 'inclusive' or 'exclusive', in a layer here and
    there (one of 3DBenchy's 478). Where a shapely
    operation needs valid input, call ``shapely.make_valid`` first; its area
    can differ from :meth:`~vecslice.layerparts.LayerParts.layer_areas`, which
    sums the rings' signed areas as CuraEngine does.

    Examples
    --------
    >>> from vecslice.layerparts import LayerParts
    >>> p = LayerParts([[0, 0], [1000, 0], [0, 1000]], [0, 3], [0, 1], [0, 1])
    >>> to_shapely(p, 0).area
    0.5
    """
    try:
        import shapely
    except ImportError as exc:
        from vecslice.errors import MissingDependencyError

        raise MissingDependencyError(
            "to_shapely needs shapely, which is not installed: "
            "pip install 'vecslice[shapely]'"
        ) from exc
    k = check_index(k, parts.layer_offsets.shape[0] - 1, "k", "layer index")
    q0, q1 = (int(x) for x in parts.layer_offsets[k : k + 2])
    part_offsets = parts.part_offsets[q0 : q1 + 1]
    r0, r1 = int(part_offsets[0]), int(part_offsets[-1])
    offsets = parts.ring_offsets[r0 : r1 + 1]
    closed, ring_offsets = _close_rings(parts.coords, offsets)
    return shapely.from_ragged_array(
        shapely.GeometryType.MULTIPOLYGON,
        closed * scale,
        (ring_offsets, part_offsets - r0, np.array([0, q1 - q0], dtype=np.int64)),
    )[0]

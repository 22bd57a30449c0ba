"""CuraEngine's layer schedules: slice heights, print heights and thicknesses."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from vecslice._validate import check_int, check_layer_count, check_schedule_limits
from vecslice.adaptive import adaptive_layer_heights
from vecslice.errors import InputTypeError
from vecslice.interrupt import keyboard_interrupts
from vecslice.mesh import Mesh
from vecslice.settings import SliceSettings

__all__ = ["layer_count", "layer_heights", "layer_schedule"]


def _tdiv(a: int, b: int) -> int:
    """C-style integer division, truncating toward zero."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


def _round_divide(a: int, b: int) -> int:
    if (a >= 0) == (b >= 0):
        return _tdiv(a + _tdiv(b, 2), b)
    return _tdiv(a - _tdiv(b, 2), b)


def layer_count(height: int, settings: SliceSettings) -> int:
    """Number of layers CuraEngine slices for an object ``height`` µm tall.

    Examples
    --------
    >>> layer_count(10000, SliceSettings(initial_layer_height=200))
    99
    """
    h = check_int(height, "height", minimum=0)
    init, th = settings.initial_layer_height, settings.layer_height
    mode = settings.slicing_tolerance
    if mode == "middle":
        if h < init:
            return 1 if h > _tdiv(init, 2) else 0
        return _round_divide(h - init, th) + 1
    if mode == "exclusive":
        if h < init:
            return 0
        n = (h - 1 - init) // th + 1  # floor division, as Cura's floor_divide
        return n + 1 if n > 0 else n
    if h < init:  # inclusive
        return 1 if h > 0 else 0
    return -((init - h) // th) + 1  # ceil division


def layer_schedule(
    height: int, settings: SliceSettings
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """CuraEngine's schedule for an object resting on z = 0 and ``height`` µm tall.

    Returns ``(slice_z, print_z, thickness)``, int64 arrays of shape (L,) in µm,
    measured from the bed.

    Examples
    --------
    >>> s = SliceSettings(initial_layer_height=200, layer_height=100)
    >>> z, p, t = layer_schedule(10000, s)
    >>> z[:3].tolist(), z[-1].item(), p[:2].tolist(), t[:2].tolist()
    ([100, 250, 350], 9950, [200, 300], [200, 100])
    """
    n = layer_count(height, settings)
    init, th = settings.initial_layer_height, settings.layer_height
    check_layer_count(
        n, settings.max_layers,
        f"an object {height} µm tall at layer_height {th} µm",
        "SliceSettings(max_layers={n})",
    )
    idx = np.arange(n, dtype=np.int64)
    mode = settings.slicing_tolerance
    if mode == "middle":
        z = init + _tdiv(th, 2) + (idx - 1) * th
        first = _tdiv(init, 2)
    else:
        z = init + (idx - 1) * th
        first = max(0, init - th) if mode == "exclusive" else 0
    if n:
        z[0] = first
    print_z = init + idx * th
    thickness = np.full(n, th, dtype=np.int64)
    if n:
        thickness[0] = init
    return z, print_z, thickness


@keyboard_interrupts
def layer_heights(
    mesh: Any, settings: SliceSettings | None = None
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Slice heights for ``mesh`` following CuraEngine's schedule.

    The schedule is measured from the mesh's lowest point, as if it rested on the
    bed (``h = max z - min z``). It is uniform, or CuraEngine's adaptive schedule
    when ``settings.adaptive_layers`` is true.

    Parameters
    ----------
    mesh : Mesh
        The mesh to slice (int64 µm vertices).
    settings : SliceSettings, optional
        Layer heights and slicing tolerance; defaults to ``SliceSettings()``.

    Returns
    -------
    slice_z : ndarray of shape (L,), int64
        Absolute heights in the mesh's own frame (µm) at which to cut.
    print_z : ndarray of shape (L,), int64
        Top of each layer above the bed (µm).
    thickness : ndarray of shape (L,), int64
        Thickness of each layer (µm).

    Notes
    -----
    For a mesh resting on z = 0 this is exactly CuraEngine's schedule. Uniform
    layers: 'middle' cuts each layer at its middle; 'inclusive' and 'exclusive'
    cut at its bottom and are post-processed with the next layer when parts are
    made.

    Adaptive layers (:func:`vecslice.adaptive.adaptive_layer_heights`) are thin
    where the surface is shallow and thick where it is steep: each layer takes the
    thickest of ``layer_height ± adaptive_variation`` (in steps of
    ``adaptive_variation_step``) whose stair-step width ``thickness /
    tan(slope)`` on the shallowest face it meets stays within
    ``adaptive_threshold``. As in CuraEngine, bit for bit:

    * layer 0 is always ``initial_layer_height`` thick, whatever the mesh, and
      layer 1 is usually forced: with the defaults (300 µm, then at most 200 µm
      allowed) it takes the thickest allowed height, 200 µm, whatever the
      geometry; a small first layer instead ramps up one step per layer;
    * a layer is at most one step thicker than the one below it, so thick layers
      come back gradually after a shallow region; it is usually at most two steps
      thinner, so a short shallow feature may be passed before the layers have
      thinned, except that a layer meeting no face (a gap between two bodies,
      or below a floating model in the bed frame) takes the thinnest height at
      once, and a first layer thinner than the thinnest height jumps up to it;
    * every layer is cut at its **top** (``slice_z == print_z`` relative to the
      lowest point), in every slicing tolerance; 'middle' only makes each layer
      look at the lower half of its height, and 'inclusive'/'exclusive' still
      union/intersect each layer with the next one;
    * horizontal faces never thin a layer, and only the shallowest face in a
      layer counts (however small);
    * the last layer ends above the model (also when a layer ends exactly at the
      top), so its slice is empty; there are always at least two layers.

    Examples
    --------
    A cone 2 mm tall, 10 mm wide (slope about 22 degrees): layer 1 is 200 µm, then
    the layers thin by two steps each until 80 µm layers keep the stair-steps
    within 0.2 mm;
    the last layer ends above the tip at 2 mm:

    >>> import trimesh, vecslice as vs
    >>> cone = vs.load_mesh(trimesh.creation.cone(5, 2, sections=16))
    >>> z, p, t = layer_heights(cone, vs.SliceSettings(adaptive_layers=True))
    >>> t.tolist()
    [300, 200, 180, 160, 140, 120, 100, 80, 80, 80, 80, 80, 80, 80, 80, 80, 80, 80]
    >>> p[-2:].tolist(), (z - p).tolist() == [cone.zrange[0]] * len(z)
    ([2000, 2080], True)
    """
    if settings is None:
        settings = SliceSettings()
    if not isinstance(settings, SliceSettings):
        raise InputTypeError(
            "`settings` must be a vecslice.SliceSettings; "
            f"got {type(settings).__name__}"
        )
    if not isinstance(mesh, Mesh):  # a trimesh.Trimesh would be read as µm
        raise InputTypeError(
            f"`mesh` must be a vecslice.Mesh (see vecslice.load_mesh); got "
            f"{type(mesh).__name__}"
        )
    if settings.adaptive_layers:
        z, print_z, thickness = adaptive_layer_heights(mesh, settings)
    else:
        # the model's z range: face corners (a vertex no face uses is not sliced)
        zmin, zmax = mesh._corner_zrange()
        z, print_z, thickness = layer_schedule(zmax - zmin, settings)
        z = z + zmin
    check_schedule_limits(z, print_z, *mesh._corner_zrange(),
                          adaptive=settings.adaptive_layers)
    return z, print_z, thickness

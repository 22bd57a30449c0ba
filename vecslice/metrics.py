"""Resolution metrics: what simplification and layer heights cost and buy.

* :func:`contour_errors` / :func:`simplification_errors` — how far simplified
  contours are from the raw ones: the measured deviation (exact, both ways, per
  ring, layer and model) and the area of the symmetric difference.
* :func:`move_stats` — the printer moves a model asks for: lengths, durations
  at a contour speed, the share shorter than a controller's time per move.
* :func:`volume_error` — layer areas times thicknesses against the mesh volume:
  the model's (simplification included) and the Z staircase alone (the mesh's
  exact sections at the cut heights).
* :func:`layer_xor_areas` — symmetric difference of two whole layers (booleans).

All lengths are µm, areas µm², volumes µm³ unless a name says mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vecslice._kernels.metrics import compare_range
from vecslice._kernels.simplify import ring_perimeters
from vecslice._threads import chunk_bounds, run_chunks
from vecslice.errors import InputTypeError, InputValueError
from vecslice.interrupt import keyboard_interrupts
from vecslice.moves import MoveStats, _check_number, move_stats
from vecslice.paths import LayerPaths
from vecslice.ragged import adopt, freeze, reduce_frozen
from vecslice.settings import SliceSettings
from vecslice.staircase import VolumeStats, volume_error
from vecslice.storage import SlicedModel, check_model

__all__ = [
    "ContourErrors",
    "MoveStats",
    "ResolutionStats",
    "VolumeStats",
    "contour_errors",
    "layer_xor_areas",
    "model_loops",
    "move_stats",
    "resolution_stats",
    "simplification_errors",
    "volume_error",
]


def model_loops(model: SlicedModel) -> LayerPaths:
    """The rings of a :class:`SlicedModel` (outlines and holes) as a LayerPaths."""
    check_model(model)
    layer_rings = model.part_offsets[model.layer_offsets]
    return LayerPaths._trusted(model.coords, model.ring_offsets, layer_rings.copy())


def _check_layer_paths(value: Any, name: str) -> LayerPaths:
    if not isinstance(value, LayerPaths):
        raise InputTypeError(
            f"`{name}` must be a vecslice.LayerPaths; got {type(value).__name__}"
        )
    return value


@dataclass(frozen=True, slots=True, eq=False)
class ContourErrors:
    """Ring-by-ring errors of simplified contours against their raw rings.

    Attributes
    ----------
    raw_to_simplified_um : ndarray of shape (R,), float64
        Largest distance from a raw vertex to the simplified ring, µm; NaN where
        the ring was dropped (its simplified ring is empty).
    simplified_to_raw_um : ndarray of shape (R,), float64
        Largest distance from a simplified vertex to the raw ring, µm; NaN where
        dropped.
    xor_area_um2 : ndarray of shape (R,), float64
        ``∫ |w_raw - w_simplified| dA`` in µm² (winding numbers): the area of the
        symmetric difference of the two rings when both are simple and wound the
        same way (rings of opposite windings count their overlap twice); the
        whole raw area for a dropped ring.
    linear : ndarray of shape (R,), bool
        Whether the pass over the order correspondence settled the ring's XOR
        area (pieces that may overlap measured together by a sweep); where not,
        a sweep over the whole ring pair did.
    ring_layer : ndarray of shape (R,), int64
        Layer of each ring.
    raw_area_um2 : ndarray of shape (L,), float64
        Net raw area of each layer (signed ring areas summed: holes subtract).
    """

    raw_to_simplified_um: NDArray[np.float64]
    simplified_to_raw_um: NDArray[np.float64]
    xor_area_um2: NDArray[np.float64]
    linear: NDArray[np.bool_]
    ring_layer: NDArray[np.int64]
    raw_area_um2: NDArray[np.float64]

    def __post_init__(self) -> None:
        # read-only, like every container's arrays: writing into one would change
        # the maxima and sums computed from it (see ragged.freeze)
        for name in ("raw_to_simplified_um", "simplified_to_raw_um", "xor_area_um2",
                     "linear", "ring_layer", "raw_area_um2"):
            given = getattr(self, name)
            object.__setattr__(self, name, adopt(np.asarray(given), given))

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickles and copies hold read-only arrays too (see ragged.reduce_frozen)."""
        return reduce_frozen(self)

    @property
    def n_layers(self) -> int:
        """Number of layers ``L``."""
        return int(self.raw_area_um2.shape[0])

    @property
    def deviation_um(self) -> NDArray[np.float64]:
        """Measured deviation of each ring (larger direction), µm; NaN if dropped."""
        return np.fmax(self.raw_to_simplified_um, self.simplified_to_raw_um)

    @property
    def dropped(self) -> NDArray[np.bool_]:
        """Rings whose simplified ring is empty (filtered or simplified away)."""
        return np.isnan(self.raw_to_simplified_um)

    def layer_max_deviation_um(self) -> NDArray[np.float64]:
        """Largest measured deviation per layer, µm (NaN: no ring kept there)."""
        out = np.full(self.n_layers, np.nan)
        np.fmax.at(out, self.ring_layer, self.deviation_um)
        return out

    @property
    def max_deviation_um(self) -> float:
        """Largest measured deviation over the model, µm (NaN if no ring kept)."""
        dev = self.deviation_um
        kept = dev[~np.isnan(dev)]
        return float(kept.max()) if kept.size else float("nan")

    def layer_xor_area_um2(self) -> NDArray[np.float64]:
        """Summed ring XOR area per layer, µm²."""
        return np.bincount(self.ring_layer, weights=self.xor_area_um2,
                           minlength=self.n_layers).astype(np.float64)

    @property
    def area_error_um2(self) -> float:
        """Total XOR area over all rings and layers, µm²."""
        return float(self.xor_area_um2.sum())

    @property
    def relative_area_error(self) -> float:
        """``area_error_um2`` over the total net raw area (NaN if that is 0)."""
        total = float(np.abs(self.raw_area_um2).sum())
        return self.area_error_um2 / total if total else float("nan")

    def rings_beyond(self, limit_um: float) -> int:
        """Number of kept rings whose measured deviation exceeds ``limit_um``.

        ``limit_um``: a number >= 0, µm (e.g. the ``max_deviation`` setting).
        """
        limit_um = _check_number(limit_um, "limit_um", "µm", zero=True)
        dev = self.deviation_um
        return int((dev[~np.isnan(dev)] > limit_um).sum())


def _compare_rings(
    raw: NDArray[np.int64], raw_offsets: NDArray[np.int64],
    simp: NDArray[np.int64], simp_offsets: NDArray[np.int64],
    threads: int | None = None, rings: NDArray[np.int64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
           NDArray[np.bool_]]:
    """The kernel ``compare_rings`` on threads, same results.

    Chunks of ring pairs of about equal vertex counts, each measured by the
    kernel ``compare_range``; up to ``threads`` threads (default numba's).
    ``rings``: measure only these ring pairs (ascending indices); the other
    entries of the results are then unset (NaN, NaN, NaN, False).
    """
    n = raw_offsets.shape[0] - 1
    d1, d2 = np.empty(n, dtype=np.float64), np.empty(n, dtype=np.float64)
    area, linear = np.empty(n, dtype=np.float64), np.zeros(n, dtype=np.bool_)
    if rings is None:
        rings = np.arange(n, dtype=np.int64)
        sizes = raw_offsets + simp_offsets  # cumulative sizes of every pair
    else:
        for out in (d1, d2, area):
            out.fill(np.nan)
        sizes = np.zeros(rings.shape[0] + 1, dtype=np.int64)
        np.cumsum(np.diff(raw_offsets)[rings] + np.diff(simp_offsets)[rings],
                  out=sizes[1:])
    run_chunks(lambda i0, i1: compare_range(raw, raw_offsets, simp, simp_offsets,
                                            rings, i0, i1, d1, d2, area, linear),
               chunk_bounds(sizes, threads), threads)
    return d1, d2, area, linear


@keyboard_interrupts
def contour_errors(raw: LayerPaths, simplified: LayerPaths) -> ContourErrors:
    """Measure simplified rings against the raw rings they came from, ring by ring.

    Parameters
    ----------
    raw : LayerPaths
        Raw closed rings, e.g. of :func:`vecslice.slice_contours`.
    simplified : LayerPaths
        One ring per raw ring (same layers, same ring counts), each the
        simplification of its raw ring and possibly empty (dropped). See
        :func:`simplification_errors` for the pipeline's own clean-up.

    Returns
    -------
    ContourErrors

    Notes
    -----
    The deviation is exact: the largest over all (vertex, edge) pairs of the
    point-segment distance, both ways (raw vertices to the simplified ring,
    simplified vertices to the raw ring). The order correspondence of
    simplification (a simplified ring is its raw ring's subsequence, some kept
    vertices moved onto extensions of raw edges) gives every vertex a candidate
    bound in linear time; only vertices whose bound could be the maximum are
    measured against the whole ring, so the result equals the brute force.
    Rings without that correspondence (a ring against its reversal, another
    tool's output) get their bounds from short walks along the other ring, and
    the same exact pass follows (all pairs only at worst).
    It measures from vertices: the widest gap between two rings can also lie
    mid-edge (a raw vertex dropped from a thin sliver leaves the simplified edge
    far from the raw ring between vertices), so the deviation is a lower bound
    of the rings' Hausdorff distance, equal to it where the widest gap is at a
    vertex.

    The XOR area is a linear pass where the correspondence holds: between
    consecutive shared vertices the raw and simplified chains bound a piece whose
    area is exact (``∫|h| dt`` along its chord, or a sweep for irregular pieces);
    pieces proven not to overlap sum to the ring's XOR area, pieces that may
    overlap are swept together. Where nothing usable is left, the whole ring pair
    is swept (``linear`` is False there). Floating point enters only for square
    roots and rational intersection points.

    Examples
    --------
    A 1 mm square whose edge midpoint was pushed out by 7 µm, against the
    square:

    >>> raw = LayerPaths([[0, 0], [1000, 0], [1007, 500], [1000, 1000], [0, 1000]],
    ...                  [0, 5], [0, 1])
    >>> sq = LayerPaths([[0, 0], [1000, 0], [1000, 1000], [0, 1000]], [0, 4], [0, 1])
    >>> err = contour_errors(raw, sq)
    >>> err.max_deviation_um, err.area_error_um2
    (7.0, 3500.0)
    """
    return _contour_errors(raw, simplified)


def _contour_errors(raw: LayerPaths, simplified: LayerPaths,
                    raw_area_um2: NDArray[np.float64] | None = None,
                    threads: int | None = None) -> ContourErrors:
    """:func:`contour_errors`, given the raw layers' areas (µm²) if known.

    ``threads``: at most this many threads (default numba's).
    """
    raw = _check_layer_paths(raw, "raw")
    simplified = _check_layer_paths(simplified, "simplified")
    if raw.n_layers != simplified.n_layers or not np.array_equal(
        raw.layer_offsets, simplified.layer_offsets
    ):
        raw_per = np.diff(raw.layer_offsets)
        got_per = np.diff(simplified.layer_offsets)
        if raw.n_layers != simplified.n_layers:
            what = f"{simplified.n_layers} layers against {raw.n_layers} in `raw`"
        else:
            k = int(np.flatnonzero(raw_per != got_per)[0])
            what = (f"{int(got_per[k])} rings in layer {k} against "
                    f"{int(raw_per[k])} in `raw`")
        raise InputValueError(
            "`simplified` must have one ring per ring of `raw` in the same layers "
            f"(an empty ring where one was dropped); got {what}"
        )
    d1, d2, area, linear = _compare_rings(
        raw.coords, raw.ring_offsets, simplified.coords, simplified.ring_offsets,
        threads,
    )
    return _errors_of(raw, (d1, d2, area, linear), raw_area_um2)


def _errors_of(raw: LayerPaths,
               measured: tuple[NDArray[np.float64], NDArray[np.float64],
                               NDArray[np.float64], NDArray[np.bool_]],
               raw_area_um2: NDArray[np.float64] | None = None) -> ContourErrors:
    """:class:`ContourErrors` of ``raw`` from ``compare_rings``' four arrays."""
    d1, d2, area, linear = measured
    return ContourErrors(  # fresh arrays, handed over (frozen: not copied)
        raw_to_simplified_um=freeze(d1),
        simplified_to_raw_um=freeze(d2),
        xor_area_um2=freeze(area),
        linear=freeze(linear),
        ring_layer=freeze(raw.ring_layer()),
        raw_area_um2=freeze(_raw_area_um2(raw) if raw_area_um2 is None
                            else raw_area_um2),
    )


def _raw_area_um2(raw: LayerPaths) -> NDArray[np.float64]:
    """The net area of each layer of ``raw``, µm² (signed ring areas summed).

    Summed in float64 (the result is float): no int64 sum that could wrap.
    """
    return np.bincount(raw.ring_layer(), weights=raw.area2().astype(np.float64),
                       minlength=raw.n_layers) / 2


@keyboard_interrupts
def simplification_errors(
    raw: LayerPaths, settings: SliceSettings | None = None
) -> tuple[ContourErrors, LayerPaths]:
    """Clean ``raw`` as :func:`vecslice.slice_mesh` does and measure the result.

    Parameters
    ----------
    raw : LayerPaths
        Raw closed loops (:func:`vecslice.slice_contours`).
    settings : SliceSettings, optional
        ``minimum_polygon_circumference``, ``max_resolution``, ``max_deviation``
        and ``max_area_deviation`` are used; default ``SliceSettings()``.

    Returns
    -------
    errors : ContourErrors
        Per raw ring; rings dropped by the perimeter filter or simplified away
        count as dropped (their whole area is error).
    cleaned : LayerPaths
        The cleaned rings, one per raw ring (empty where dropped); without the
        empty rings this is :func:`vecslice.clean_loops`'s closed loops.

    Examples
    --------
    An 800 µm square with an edge midpoint pushed out by 7 µm (its 400 µm edges
    are below ``max_resolution``, so the midpoint goes):

    >>> raw = LayerPaths([[0, 0], [800, 0], [807, 400], [800, 800], [0, 800]],
    ...                  [0, 5], [0, 1])
    >>> err, cleaned = simplification_errors(raw)
    >>> cleaned.coords.tolist(), err.max_deviation_um, err.area_error_um2
    ([[0, 0], [800, 0], [800, 800], [0, 800]], 7.0, 2800.0)
    """
    from vecslice.pipeline import _clean_closed

    raw = _check_layer_paths(raw, "raw")
    if settings is None:
        settings = SliceSettings()
    if not isinstance(settings, SliceSettings):
        raise InputTypeError(
            "`settings` must be a vecslice.SliceSettings; "
            f"got {type(settings).__name__}"
        )
    coords, offsets = _clean_closed(raw, settings)
    cleaned = LayerPaths._trusted(coords, offsets, raw.layer_offsets.copy())
    return contour_errors(raw, cleaned), cleaned


@keyboard_interrupts
def layer_xor_areas(a: LayerPaths, b: LayerPaths) -> NDArray[np.float64]:
    """Area (µm²) of the symmetric difference of ``a`` and ``b``, per layer.

    Each layer of each input is filled with the NonZero rule first (manifold3d
    booleans), so this compares whole layers whatever their rings; see
    :func:`contour_errors` for the ring-by-ring measure without booleans.

    Examples
    --------
    >>> sq = [[0, 0], [10, 0], [10, 10], [0, 10]]
    >>> a = LayerPaths(sq, [0, 4], [0, 1])
    >>> b = LayerPaths([[5, 0], [15, 0], [15, 10], [5, 10]], [0, 4], [0, 1])
    >>> layer_xor_areas(a, b).tolist()
    [100.0]
    """
    import manifold3d  # the fill rule's enum; booleans go through vecslice.parts

    from vecslice.parts import _cross_sections

    a = _check_layer_paths(a, "a")
    b = _check_layer_paths(b, "b")
    if a.n_layers != b.n_layers:
        raise InputValueError(
            f"`b` must have as many layers as `a` ({a.n_layers}); got {b.n_layers}"
        )
    sa = _cross_sections(a, manifold3d.FillRule.NonZero)
    sb = _cross_sections(b, manifold3d.FillRule.NonZero)
    return np.array([(x - y).area() + (y - x).area() for x, y in zip(sa, sb,
                                                                     strict=True)],
                    dtype=np.float64)


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


@keyboard_interrupts
def resolution_stats(
    model: SlicedModel, reference: LayerPaths | SlicedModel, *,
    speed_mm_s: float = 60,
) -> ResolutionStats:
    """Vertex count, move rate and shape error of ``model`` against ``reference``.

    A one-model summary kept for existing code; :func:`vecslice.sweep` (many
    meshes and settings), :func:`contour_errors` (exact deviation) and
    :func:`move_stats` measure more.

    Parameters
    ----------
    model : SlicedModel
        The simplified result (e.g. of :func:`vecslice.slice_mesh`).
    reference : LayerPaths or SlicedModel
        The same layers at full resolution, e.g. ``vs.slice_contours(mesh,
        model.slice_z)``.
    speed_mm_s : float, default 60
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
    speed = _check_number(speed_mm_s, "speed_mm_s", "mm/s", zero=False)
    loops = model_loops(model)
    ref = model_loops(reference) if isinstance(reference, SlicedModel) else reference
    if not isinstance(ref, LayerPaths):
        raise InputTypeError(
            "`reference` must be a LayerPaths or SlicedModel; "
            f"got {type(reference).__name__}"
        )
    if ref.n_layers != loops.n_layers:
        raise InputValueError(
            f"`reference` must have as many layers as `model` ({loops.n_layers}); "
            f"got {ref.n_layers}"
        )
    perim = int(ring_perimeters(loops.coords, loops.ring_offsets).sum())
    n = int(loops.coords.shape[0])
    mean_edge = perim / n if n else 0.0
    xor = layer_xor_areas(loops, ref)
    # summed in float64: the int64 layer values can add up beyond int64
    total = float(sum(np.abs(x.layer_area2().astype(np.float64)).sum()
                      for x in (loops, ref)))
    err = float(xor.sum())
    return ResolutionStats(
        vertices=n,
        perimeter_um=perim,
        mean_edge_um=mean_edge,
        moves_per_s=speed * 1000.0 / mean_edge if mean_edge else 0.0,
        error_um2=err,
        relative_error=2 * err / total if total else 0.0,
    )

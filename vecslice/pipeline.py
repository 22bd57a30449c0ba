"""``slice_mesh``: a mesh in, CuraEngine-style layer parts out.

Stages: layer schedule -> raw loops (with stitching) -> perimeter filter ->
simplification -> degenerate-vertex removal -> slicing tolerance -> layer parts.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from vecslice._kernels.rings import take_rings
from vecslice._kernels.simplify import remove_degenerate_vertices, ring_perimeters
from vecslice._validate import check_bool
from vecslice.errors import InputTypeError
from vecslice.interrupt import keyboard_interrupts
from vecslice.layers import layer_heights
from vecslice.parts import _check_loops, apply_slicing_tolerance, make_parts
from vecslice.paths import LayerPaths
from vecslice.settings import SliceSettings
from vecslice.simplify import simplify_rings
from vecslice.slicing import slice_contours
from vecslice.stitch import stitch
from vecslice.storage import SlicedModel

__all__ = ["StageTimes", "clean_loops", "slice_mesh"]

T = TypeVar("T")


@dataclass
class StageTimes:
    """Wall-clock seconds spent in each stage of the last :func:`slice_mesh` call.

    ``counts`` holds sizes seen on the way: ``raw_vertices``, the vertices of the
    raw loops and open chains after stitching, before simplification.
    """

    seconds: dict[str, float] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)

    def __str__(self) -> str:
        total = sum(self.seconds.values())
        parts = ", ".join(f"{k} {v:.3f} s" for k, v in self.seconds.items())
        return f"{parts} (total {total:.3f} s)"


def _kept_layer_offsets(
    paths: LayerPaths, keep: NDArray[np.bool_]
) -> NDArray[np.int64]:
    """Layer offsets of the rings of ``paths`` where ``keep`` is true."""
    kept_before = np.zeros(keep.shape[0] + 1, dtype=np.int64)
    np.cumsum(keep, out=kept_before[1:])
    return kept_before[paths.layer_offsets]


def _keep_rings(paths: LayerPaths, keep: NDArray[np.bool_]) -> LayerPaths:
    """The rings of ``paths`` where ``keep`` is true, layers preserved."""
    coords, ring_offsets = take_rings(paths.coords, paths.ring_offsets, keep)
    return LayerPaths._trusted(coords, ring_offsets, _kept_layer_offsets(paths, keep))


def _with_rings(
    paths: LayerPaths, coords: NDArray[np.int64], ring_offsets: NDArray[np.int64]
) -> LayerPaths:
    """Same layers, one new ring per old ring; empty rings dropped.

    Empty rings have no vertices, so only the offsets change.
    """
    keep = ring_offsets[1:] > ring_offsets[:-1]
    kept_offsets = np.concatenate([ring_offsets[:1], ring_offsets[1:][keep]])
    return LayerPaths._trusted(coords, kept_offsets, _kept_layer_offsets(paths, keep))


def _kept_loops(loops: LayerPaths, minimum_circumference: int) -> NDArray[np.bool_]:
    """The perimeter filter: which loops are kept (µm perimeters, Cura's)."""
    perimeter = ring_perimeters(loops.coords, loops.ring_offsets)
    return perimeter >= minimum_circumference


def _clean_closed(
    loops: LayerPaths,
    s: SliceSettings,
    keep: NDArray[np.bool_] | None = None,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The closed-loop part of :func:`clean_loops`, one result ring per input ring.

    Returns ``(coords, ring_offsets)`` with ring ``i`` the cleaned loop ``i`` of
    ``loops``, empty where it was dropped (short perimeter, simplified away,
    degenerate): the correspondence that :mod:`vecslice.metrics` measures.
    ``keep`` is :func:`_kept_loops`'s result, when the caller has it already.

    Every loop is simplified (each on its own, so a kept loop's result does not
    depend on the others) and the dropped ones are left out afterwards, from the
    simplified rings: the raw loops, the largest arrays here, are never copied
    (five Benchies: 43 MB, 22-32 ms, for the 30 of 7,470 loops under 1 mm).
    """
    if keep is None:
        keep = _kept_loops(loops, s.minimum_polygon_circumference)
    coords, offsets = simplify_rings(
        loops.coords, loops.ring_offsets, True, s.max_resolution,
        s.max_deviation, s.max_area_deviation,
    )
    coords, offsets = remove_degenerate_vertices(coords, offsets)
    lens = np.diff(offsets)
    if not keep.all():
        coords = take_rings(coords, offsets, keep)[0]
        lens[~keep] = 0
    full = np.zeros(loops.n_rings + 1, dtype=np.int64)
    np.cumsum(lens, out=full[1:])
    return coords, full


@keyboard_interrupts
def clean_loops(loops: LayerPaths, settings: SliceSettings | None = None) -> LayerPaths:
    """CuraEngine's per-layer clean-up of raw loops, for all layers at once.

    Closed loops with a perimeter below ``minimum_polygon_circumference`` are
    dropped, the rest simplified as polygons (empty results dropped), then vertices
    where a loop exactly reverses are removed (loops left with <= 2 vertices are
    dropped). Open chains are simplified as polylines. See ``spec/SIMPLIFY.md``.

    Parameters
    ----------
    loops : LayerPaths
        Raw loops from :func:`vecslice.slice_contours`.
    settings : SliceSettings, optional
        The thresholds (µm); default ``SliceSettings()``.

    Returns
    -------
    LayerPaths
        Cleaned closed loops, with cleaned open chains in ``.open``.

    Raises
    ------
    InputTypeError
        If ``loops`` is not a LayerPaths or ``settings`` not a SliceSettings.
    """
    loops = _check_loops(loops)
    settings = _check_settings(settings)
    return _cleaned(loops, settings, *_clean_closed(loops, settings))


def _check_settings(settings: Any) -> SliceSettings:
    """``settings`` (default ``SliceSettings()``), or an InputTypeError."""
    if settings is None:
        return SliceSettings()
    if not isinstance(settings, SliceSettings):
        raise InputTypeError(
            "`settings` must be a vecslice.SliceSettings; "
            f"got {type(settings).__name__}"
        )
    return settings


def _cleaned(
    loops: LayerPaths,
    s: SliceSettings,
    coords: NDArray[np.int64],
    offsets: NDArray[np.int64],
) -> LayerPaths:
    """:func:`clean_loops` given its closed part (:func:`_clean_closed`)."""
    closed = _with_rings(loops, coords, offsets)
    chains = loops.open
    if chains is not None:
        coords, offsets = simplify_rings(
            chains.coords, chains.ring_offsets, False, s.max_resolution,
            s.max_deviation, s.max_area_deviation,
        )
        chains = _with_rings(chains, coords, offsets)
    return LayerPaths._trusted(
        closed.coords, closed.ring_offsets, closed.layer_offsets, chains
    )


class _Stages:
    """Times the stages and drives an optional progress bar."""

    def __init__(self, names: list[str], progress: bool) -> None:
        self.times = StageTimes()
        self.bar: Any = None
        if progress:
            from tqdm import tqdm

            self.bar = tqdm(total=len(names), desc="slicing", unit="stage")

    def run(self, name: str, fn: Callable[..., T], *args: Any, **kw: Any) -> T:
        if self.bar is not None:
            self.bar.set_description(name)
        t = time.perf_counter()
        out = fn(*args, **kw)
        self.times.seconds[name] = time.perf_counter() - t
        if self.bar is not None:
            self.bar.update(1)
        return out

    def close(self) -> None:
        if self.bar is not None:
            self.bar.set_description("done")
            self.bar.close()


_STAGES = [
    "layers", "contours", "stitch", "simplify", "tolerance", "parts", "store"
]


@keyboard_interrupts
def slice_mesh(
    mesh: Any,
    settings: SliceSettings | None = None,
    *,
    progress: bool = False,
    times: StageTimes | None = None,
) -> SlicedModel:
    """Slice ``mesh`` into layers of parts (outline + holes), as CuraEngine does.

    Parameters
    ----------
    mesh : Mesh
        Triangle mesh in µm (see :func:`vecslice.load_mesh`).
    settings : SliceSettings, optional
        Layer heights, slicing tolerance, simplification thresholds and the fill
        rule; defaults to ``SliceSettings()`` (Cura's defaults).
    progress : bool, default False
        Show a progress bar (tqdm) over the stages on stderr.
    times : StageTimes, optional
        If given, filled with the seconds spent in each stage.

    Returns
    -------
    SlicedModel
        Layers -> parts -> rings -> coords, with ``slice_z``, ``print_z``,
        ``thickness`` and the open polylines that could not be closed.

    Notes
    -----
    Stages: :func:`vecslice.layer_heights`; :func:`vecslice.slice_contours`
    (loops by mesh topology); :func:`vecslice.stitch` (open chains joined by
    CuraEngine's rules; per-layer counts kept in the model); :func:`clean_loops`
    (minimum circumference, CuraEngine simplification, degenerate vertices); the
    slicing tolerance ('inclusive' unions each layer with the next, 'exclusive'
    intersects them); :func:`vecslice.make_parts` (union with NonZero or EvenOdd,
    split into parts).

    With ``settings.compat == "cura"`` the stages before the union are
    CuraEngine's own (:mod:`vecslice.cura_pipeline`): per-face crossings, its loop
    building, stitching, filter, simplification and open-polyline stitcher, so a
    mesh loaded with ``load_mesh(path, compat="cura")`` reaches the union with the
    polygons CuraEngine makes. The union stays manifold3d's (see the README).

    Examples
    --------
    >>> import trimesh, vecslice as vs
    >>> box = vs.load_mesh(trimesh.creation.box((10, 10, 2)))
    >>> model = vs.slice_mesh(box)
    >>> model.n_layers, len(model.layer(0)), float(model.layer_areas()[0])
    (18, 1, 100000000.0)
    """
    settings = _check_settings(settings)
    progress = check_bool(progress, "progress")
    if times is not None and not isinstance(times, StageTimes):
        raise InputTypeError(
            f"`times` must be a vecslice.StageTimes or None; got {type(times).__name__}"
        )
    if settings.compat == "cura":
        from vecslice.cura_pipeline import slice_mesh_cura

        return slice_mesh_cura(mesh, settings, _Stages(_STAGES, progress), times)
    st = _Stages(_STAGES, progress)
    try:
        slice_z, print_z, thickness = st.run("layers", layer_heights, mesh, settings)
        raw = st.run("contours", slice_contours, mesh, slice_z, stitch=False,
                     max_layers=settings.max_layers)
        raw, stitched = st.run("stitch", stitch, raw)
        open_chains = raw.open.rings_per_layer() if raw.open is not None else None
        st.times.counts["raw_vertices"] = int(raw.coords.shape[0]) + (
            int(raw.open.coords.shape[0]) if raw.open is not None else 0)
        loops = st.run("simplify", clean_loops, raw, settings)
        del raw  # memory per layer: the raw loops are not needed any more
        loops = st.run("tolerance", apply_slicing_tolerance, loops,
                       settings.slicing_tolerance)
        parts = st.run("parts", make_parts, loops,
                       union_overlapping_volumes=settings.union_overlapping_volumes)
        model = st.run("store", SlicedModel.from_parts, parts, slice_z=slice_z,
                       print_z=print_z, thickness=thickness, open=loops.open,
                       open_chains=open_chains, stitched_gaps=stitched)
    finally:
        st.close()
    if times is not None:
        times.seconds.update(st.times.seconds)
        times.counts.update(st.times.counts)
    return model

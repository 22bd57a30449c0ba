"""``vs.sweep``: many meshes x a grid of settings -> one tidy table, run on Dask.

One Dask task per (mesh, layer schedule): the mesh is loaded and its topology
built once (a task of its own), the raw contours are cut once per schedule, and
every combination that differs only in simplification or union settings reuses
them on the same worker. Only result rows travel back. pandas and dask are
imported when :func:`sweep` is called, never by ``import vecslice``.
"""

from __future__ import annotations

import importlib
import math
import os
import sys
import threading
import time
import uuid
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from vecslice._validate import check_bool
from vecslice.errors import (
    InputTypeError,
    MissingDependencyError,
)
from vecslice.interrupt import keyboard_interrupts
from vecslice.settings import SliceSettings
from vecslice.sweep_grid import (
    XY_SETTINGS,
    _combinations,
    _scales,
    _schedule_groups,
    _sources,
)

__all__ = ["METRIC_COLUMNS", "XY_SETTINGS", "sweep"]

METRIC_COLUMNS = (
    "layers", "raw_vertices", "vertices", "parts", "max_deviation_um",
    "area_error_um2", "relative_area_error", "volume_error_mm3",
    "short_move_fraction", "moves_per_s", "seconds",
    # more detail
    "raw_rings", "rings", "dropped_rings", "rings_beyond_max_deviation",
    "raw_to_simplified_um", "simplified_to_raw_um", "xor_sweep_rings",
    "relative_volume_error", "staircase_error_mm3", "relative_staircase_error",
    "mesh_volume_mm3", "stack_height_um", "height_um",
    "open_chains", "moves", "shortest_move_um", "move_p1_um", "move_p5_um",
    "move_p50_um", "move_p50_ms", "prep_seconds",
)
"""Columns after ``mesh`` and the settings, in order (``error`` comes last)."""

_INT_COLUMNS = ("layers", "raw_vertices", "vertices", "parts", "raw_rings", "rings",
                "dropped_rings", "rings_beyond_max_deviation", "xor_sweep_rings",
                "stack_height_um", "height_um", "open_chains", "moves")


def _require() -> tuple[Any, Any]:
    missing = []
    for name in ("pandas", "dask"):
        try:
            importlib.import_module(name)
        except ImportError:
            missing.append(name)
    if missing:
        raise MissingDependencyError(
            f"vecslice.sweep needs pandas and dask ({' and '.join(missing)} "
            f"{'is' if len(missing) == 1 else 'are'} not installed): "
            "pip install 'vecslice[sweep]'"
        )
    import dask
    import pandas

    return pandas, dask


# --- the work (runs on the workers) ------------------------------------------


@dataclass(frozen=True)
class _Prepared:
    """A loaded mesh (half-edge twins cached on it), or why it failed to load."""

    mesh: Any
    error: str
    seconds: float


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def _prepare(source: Any, scale: float, compat: str = "vecslice") -> _Prepared:
    """Load ``source`` (path or Mesh) and build its topology, once per mesh.

    A path is read as ``compat`` says (``"cura"``: as CuraEngine reads it); a
    Mesh is taken as it is.
    """
    from vecslice.mesh import load_mesh

    t = time.perf_counter()
    try:
        if isinstance(source, (str, os.PathLike)):
            kw = {"compat": compat} if compat != "vecslice" else {}
            mesh = load_mesh(source, scale=scale, **kw)
        else:
            mesh = source
        mesh._half_edge_twins()  # built once here, cached on the mesh
    except Exception as exc:  # a bad mesh gives error rows, the sweep goes on
        return _Prepared(None, _describe(exc), time.perf_counter() - t)
    return _Prepared(mesh, "", time.perf_counter() - t)


def _error_cache(raw: Any, raw_area_um2: Any = None) -> Any:
    """An :class:`~vecslice.errorcache.ErrorCache` of ``raw``'s closed loops.

    Its ``errors(coords, offsets)`` measures ``_clean_closed``'s rings.
    """
    from vecslice.errorcache import ErrorCache
    from vecslice.paths import LayerPaths

    return ErrorCache(
        LayerPaths._trusted(raw.coords, raw.ring_offsets, raw.layer_offsets),
        raw_area_um2)


def _model(raw: Any, stitched: Any, schedule: tuple[Any, Any, Any],
           settings: SliceSettings, cleaned: tuple[Any, Any]) -> Any:
    """:func:`vecslice.slice_mesh`'s model, from its simplified rings onwards."""
    from vecslice.parts import apply_slicing_tolerance, make_parts
    from vecslice.pipeline import _cleaned
    from vecslice.storage import SlicedModel

    slice_z, print_z, thickness = schedule
    loops = _cleaned(raw, settings, *cleaned)
    loops = apply_slicing_tolerance(loops, settings.slicing_tolerance)
    parts = make_parts(
        loops, union_overlapping_volumes=settings.union_overlapping_volumes)
    open_chains = raw.open.rings_per_layer() if raw.open is not None else None
    return SlicedModel.from_parts(parts, slice_z=slice_z, print_z=print_z,
                                  thickness=thickness, open=loops.open,
                                  open_chains=open_chains, stitched_gaps=stitched)


def _variant(raw: Any, stitched: Any, schedule: tuple[Any, Any, Any],
             settings: SliceSettings,
             raw_area_um2: Any = None) -> tuple[Any, Any]:
    """:func:`vecslice.slice_mesh`'s stages after the raw contours, and the errors.

    Returns ``(model, errors)``; ``model`` is what ``slice_mesh`` returns for
    these settings (tests check it). ``raw_area_um2``: the raw layers' areas
    (the same for every combination of a schedule), when the caller has them.
    The errors are measured on another thread while this one makes the parts.
    """
    from vecslice.pipeline import _clean_closed

    cleaned = _clean_closed(raw, settings)
    with ThreadPoolExecutor(1, thread_name_prefix="vecslice-metrics") as pool:
        errors = pool.submit(_error_cache(raw, raw_area_um2).errors, *cleaned)
        model = _model(raw, stitched, schedule, settings, cleaned)
        return model, errors.result()


def _timed(fn: Any, *args: Any) -> tuple[Any, float]:
    t = time.perf_counter()
    return fn(*args), time.perf_counter() - t


class _Stopped(Exception):
    """The sweep was interrupted: a task stops between combinations."""


_STOPS: dict[str, threading.Event] = {}
"""Local sweeps running in this process, by token: set on Ctrl-C (_run_local).

A task looks its sweep up (a worker of a distributed cluster finds nothing: the
client releases its futures instead)."""


def _rows(prep: _Prepared, mesh_index: int, name: str,
          combos: list[tuple[int, SliceSettings]], speed: float,
          controller_ms: float, token: str = "") -> list[dict[str, Any]]:
    """All rows of one (mesh, layer schedule) task.

    Once the sweep ``token`` names is stopped (Ctrl-C), no further combination
    is started and the rows made so far are returned (nobody reads them).

    The combinations' stages run as a pipeline on two threads besides this one:
    while a combination's parts are made here (manifold3d, mostly one core), its
    errors are measured and the next combination is simplified, so that the
    cores stay busy; each kernel then runs on one thread. The errors of a ring
    that simplified as in an earlier combination are reused
    (:class:`vecslice.errorcache.ErrorCache`).
    """
    from vecslice._validate import check_layer_count
    from vecslice.layers import layer_heights
    from vecslice.pipeline import _clean_closed, _kept_loops
    from vecslice.slicing import _contours
    from vecslice.stitch import stitch

    stop = _STOPS.get(token)

    def stopped() -> bool:
        return stop is not None and stop.is_set()

    if prep.error:
        return [_row(mesh_index, name, i, s, None, prep.error) for i, s in combos]
    t = time.perf_counter()
    mesh = prep.mesh
    first = combos[0][1]
    cura = getattr(first, "compat", "vecslice") != "vecslice"
    raw = stitched = None
    try:
        schedule = layer_heights(mesh, first)
        limit = getattr(first, "max_layers", None)
        if limit is not None:
            check_layer_count(len(schedule[0]), limit, "layers in the schedule",
                              "SliceSettings(max_layers={n})")
        if not cura:
            raw = _contours(mesh, schedule[0], False)
            raw, stitched = stitch(raw)
    except Exception as exc:
        return [_row(mesh_index, name, i, s, None, _describe(exc)) for i, s in combos]

    def share() -> _Shared:  # measures the mesh volume (a pass over the faces)
        from vecslice.staircase import _solid

        return _Shared(mesh, raw, stitched, schedule, _solid(mesh),
                       prep.seconds + time.perf_counter() - t)

    if cura:  # CuraEngine's own stages: no raw contours to share
        shared = share()
        out = []
        for i, s in combos:
            if stopped():
                break
            out.append(_measured(mesh_index, name, i, s, _cura_model(shared, s),
                                 None, shared, speed=speed,
                                 controller_ms=controller_ms))
        return out
    # which loops the perimeter filter keeps, by minimum circumference
    keep_of: dict[int, np.ndarray] = {}
    keep_lock = threading.Lock()
    # a ring that comes out of simplification as in an earlier combination
    # takes that combination's errors (the same pair: the same numbers)
    cache = _error_cache(raw)

    def simplified(s: SliceSettings) -> tuple[Any, float]:
        if stopped():
            raise _Stopped
        t = time.perf_counter()
        c = s.minimum_polygon_circumference
        with keep_lock:
            if c not in keep_of:
                keep_of[c] = _kept_loops(raw, c)
        return _clean_closed(raw, s, keep_of[c]), time.perf_counter() - t

    rows: list[dict[str, Any]] = []
    last = None  # the previous combination, its row made once this one's parts are
    with ThreadPoolExecutor(2, thread_name_prefix="vecslice-sweep",
                            initializer=_helper_thread) as pool:
        ahead: dict[int, Any] = {
            j: pool.submit(simplified, combos[j][1]) for j in range(min(2, len(combos)))
        }
        # the mesh volume (0.1-0.25 s for a million faces) is measured here,
        # while the first two combinations are simplified
        shared = share()
        for n, (i, s) in enumerate(combos):
            if stopped():  # waits only for what the helpers are running now
                pool.shutdown(wait=False, cancel_futures=True)
                return rows
            for j in (n, n + 1):  # this combination (if not yet), and the next
                if j < len(combos) and j not in ahead:
                    ahead[j] = pool.submit(simplified, combos[j][1])
            errors = None
            try:
                rings, simplify_seconds = ahead.pop(n).result()
                errors = pool.submit(_timed, cache.errors, *rings, 1)
                model, seconds = _timed(_model, raw, stitched, schedule, s, rings)
                made: Any = (model, seconds + simplify_seconds)
            except Exception as exc:
                made = exc
            if last is not None:
                rows.append(_measured(mesh_index, name, *last, shared, speed=speed,
                                      controller_ms=controller_ms))
            last = (i, s, made, errors)
        if last is not None:
            rows.append(_measured(mesh_index, name, *last, shared, speed=speed,
                                  controller_ms=controller_ms))
    return rows


HELPER_NICE = 5  # how much lower the pipeline's helper threads run (Linux)


def _helper_thread() -> None:
    """Start a helper thread of the pipeline in :func:`_rows`.

    The task's own thread makes the parts, the pipeline's critical path: each
    union waits only for its combination's simplification, which the helpers
    do ahead, besides measuring the errors. Three busy threads share the cores,
    so the helpers' kernels run on their thread alone (numba's thread count is
    per thread: no chunk helpers on top) and, on Linux, at a nice value
    :data:`HELPER_NICE` higher (there it is per thread; elsewhere a thread id
    is not a process id, and nothing changes), so the scheduler lets the
    unions run first and the helpers fill the rest. On five Benchies and the
    12 combinations of ``benchmarks/sweep_ratio.py`` the sweep took 8% and 11%
    less wall time than with plain helpers (two comparisons, medians of 10
    interleaved runs each). The threads end with the task.
    """
    import numba

    numba.set_num_threads(1)
    if sys.platform.startswith("linux"):
        tid = threading.get_native_id()
        try:
            os.setpriority(os.PRIO_PROCESS, tid,
                           min(19, os.getpriority(os.PRIO_PROCESS, tid) + HELPER_NICE))
        except OSError:  # not allowed here: run at the same priority
            pass


def _cura_model(shared: _Shared, s: SliceSettings) -> Any:
    """compat="cura": CuraEngine's own stages (no raw-contour correspondence)."""
    from vecslice.pipeline import slice_mesh

    try:
        return _timed(slice_mesh, shared.mesh, s)
    except Exception as exc:
        return exc


@dataclass
class _Shared:
    """What every combination of one (mesh, layer schedule) task shares."""

    mesh: Any
    raw: Any  # stitched raw contours (None in compat="cura")
    stitched: Any
    schedule: tuple[Any, Any, Any]
    solid: Any  # staircase._Solid: what the staircase is measured against
    prep_seconds: float


def _measured(mesh_index: int, name: str, i: int, s: SliceSettings, model: Any,
              errors: Any, shared: _Shared, *, speed: float,
              controller_ms: float) -> dict[str, Any]:
    """One combination's row.

    ``model``: ``(SlicedModel, seconds)`` or the exception that stopped it;
    ``errors``: the future of ``(ContourErrors, seconds)``, or None (compat
    "cura"). ``seconds`` sums the combination's own stages (simplify, parts,
    errors, moves), wherever they ran.
    """
    from vecslice.metrics import move_stats, volume_error

    if isinstance(model, Exception):
        return _row(mesh_index, name, i, s, None, _describe(model))
    model, seconds = model
    t = time.perf_counter()
    raw = shared.raw
    try:
        err = None
        if errors is not None:
            err, err_seconds = errors.result()
            seconds += err_seconds
        moves = move_stats(model, speed_mm_s=speed, controller_ms=controller_ms,
                           percentiles=(1, 5, 50))
        vol = volume_error(model, shared.mesh, _solid_of_mesh=shared.solid,
                           _section_area_um2=err.raw_area_um2 if err else None)
    except Exception as exc:
        return _row(mesh_index, name, i, s, None, _describe(exc))
    nan = math.nan
    m = {
        "layers": model.n_layers,
        "raw_vertices": int(raw.coords.shape[0]) if err else nan,
        "vertices": int(model.coords.shape[0]),
        "parts": model.n_parts,
        "max_deviation_um": err.max_deviation_um if err else nan,
        "area_error_um2": err.area_error_um2 if err else nan,
        "relative_area_error": err.relative_area_error if err else nan,
        "volume_error_mm3": vol.volume_error_mm3,
        "short_move_fraction": moves.short_move_fraction,
        "moves_per_s": moves.moves_per_s,
        "raw_rings": raw.n_rings if err else nan,
        "rings": model.n_rings,
        "dropped_rings": int(err.dropped.sum()) if err else nan,
        "rings_beyond_max_deviation": (err.rings_beyond(s.max_deviation)
                                       if err else nan),
        "raw_to_simplified_um": _nanmax(err.raw_to_simplified_um) if err else nan,
        "simplified_to_raw_um": _nanmax(err.simplified_to_raw_um) if err else nan,
        "xor_sweep_rings": int((~err.linear).sum()) if err else nan,
        "relative_volume_error": vol.relative_volume_error,
        "staircase_error_mm3": vol.staircase_error_mm3,
        "relative_staircase_error": vol.relative_staircase_error,
        "mesh_volume_mm3": vol.mesh_volume_mm3,
        "stack_height_um": vol.stack_height_um,
        "height_um": vol.height_um,
        "open_chains": int(model.open_chains.sum()),
        "moves": moves.moves,
        "shortest_move_um": moves.shortest_um,
        "move_p1_um": moves.length_percentiles_um[0],
        "move_p5_um": moves.length_percentiles_um[1],
        "move_p50_um": moves.length_percentiles_um[2],
        "move_p50_ms": moves.duration_percentiles_ms[2],
        "prep_seconds": shared.prep_seconds,
    }
    m["seconds"] = seconds + time.perf_counter() - t
    return _row(mesh_index, name, i, s, m, "")


def _nanmax(a: Any) -> float:
    kept = a[~np.isnan(a)]
    return float(kept.max()) if kept.size else math.nan


def _row(mesh_index: int, name: str, i: int, s: SliceSettings,
         metrics: dict[str, Any] | None, error: str) -> dict[str, Any]:
    row: dict[str, Any] = {"_mesh": mesh_index, "_combo": i, "mesh": name}
    row.update({k: getattr(s, k) for k in SliceSettings.option_names()})
    for c in METRIC_COLUMNS:
        row[c] = math.nan if metrics is None else metrics[c]
    row["error"] = error
    return row


# --- the engine ---------------------------------------------------------------


@keyboard_interrupts
def sweep(
    meshes: Any,
    grid: Any,
    *,
    speed_mm_s: float = 60,
    controller_ms: float = 1.0,
    client: Any = None,
    progress: bool = False,
    scale: float | Mapping[str, float] = 1.0,
) -> Any:
    """Slice many meshes at a grid of settings and measure every result.

    Parameters
    ----------
    meshes : path, Mesh, list of them, or dict name -> path or Mesh
        The models. Paths are loaded on the workers (:func:`vecslice.load_mesh`;
        for combinations with ``compat="cura"``, ``load_mesh(path,
        compat="cura")``, CuraEngine's reading); a Mesh is used as it is (load it
        with ``compat="cura"`` yourself for CuraEngine's reading). A list names
        each mesh by its file name (``mesh<i>`` for Mesh objects).
    grid : dict or list of dict
        ``{setting: [values, ...]}`` sweeps the full product of the values (a
        list, tuple, range, numpy array or pandas Series; a bare value counts as
        a list of one); a list of dicts gives the combinations explicitly. Keys
        are :class:`vecslice.SliceSettings` fields (µm); unset fields keep their
        defaults.
    speed_mm_s : float, default 60
        Contour speed for the move metrics, mm/s.
    controller_ms : float, default 1.0
        The controller's time per move, ms (moves shorter than this are short).
    client : distributed.Client, optional
        Run the tasks on this Dask cluster; default: Dask's threaded scheduler on
        this machine (the kernels release the GIL).
    progress : bool, default False
        Show progress: a tqdm bar over the tasks, or dask's progress display
        with a client.
    scale : float or dict name -> float, default 1.0
        File units to millimetres for meshes given as paths (25.4 for inches).
        A scale other than 1 for a Mesh object is refused: scale it when loading.

    Returns
    -------
    pandas.DataFrame
        One row per (mesh, combination), in the order given: ``mesh``, every
        SliceSettings field, then :data:`METRIC_COLUMNS` and ``error`` (empty, or
        why the mesh could not be loaded or sliced; its metrics are then NaN).
        ``max_deviation_um`` is the model's largest measured deviation of a
        simplified ring from its raw ring (exact); ``area_error_um2`` the summed
        ring XOR area and ``relative_area_error`` that over the net raw area;
        ``volume_error_mm3`` the volume error of the model's layers, and
        ``staircase_error_mm3`` that of the Z staircase alone, whatever the XY
        settings (:func:`vecslice.metrics.volume_error`);
        ``short_move_fraction`` and ``moves_per_s`` come from
        :func:`vecslice.metrics.move_stats`; ``seconds`` sums the times of the
        combination's own stages (simplification, union, metrics; they overlap
        with other combinations' stages, so the column adds up to more than the
        sweep's wall time; ``prep_seconds``: its task's load, topology and raw
        contours). With a client the table is the same apart from times.
        With ``compat="cura"`` the model comes from CuraEngine's own stages
        (:func:`vecslice.slice_mesh`) and the contour-error columns are NaN.
        Metrics that have nothing to measure are NaN in rows without an error
        too: a model with no layers or no rings left (all below
        ``minimum_polygon_circumference``; often a wrong ``scale``) has no
        deviation, no relative errors and no moves. Whole-number columns
        (:data:`METRIC_COLUMNS` counts such as ``layers`` and ``vertices``) are
        int64, or float64 when some row of the table has no value for them (an
        error row, a ``compat="cura"`` row).

    Raises
    ------
    SettingsError
        An unknown setting, a bad value, an empty grid, or a bad speed or
        controller time — before any work starts. A grid value of the wrong type
        (``"500"`` for a length) raises a SettingsError that is also a TypeError.
    InputValueError, InputTypeError
        A bad ``meshes``, ``scale``, ``progress`` or ``client``, or a speed or
        controller time that is not a number (also before any work).
    ImportError
        If pandas or dask is missing (``pip install 'vecslice[sweep]'``).

    Notes
    -----
    Each (mesh, layer schedule) task loads the mesh and cuts its raw contours
    once; its combinations run as a pipeline on the task's thread (the parts)
    and two helper threads (simplifying ahead, measuring errors) that the task
    starts and ends. The helpers' kernels use one thread each and, on Linux,
    run at a nice value :data:`HELPER_NICE` higher than the task's thread, so
    that the parts run first. A ring that simplifies as in an earlier
    combination of the task takes that combination's errors (the same numbers).

    Examples
    --------
    >>> import trimesh, vecslice as vs
    >>> box = vs.load_mesh(trimesh.creation.box((10, 10, 2)))
    >>> t = vs.sweep({"box": box}, {"max_resolution": [200, 500]})
    >>> t[["mesh", "max_resolution", "layers", "vertices", "max_deviation_um"]]
      mesh  max_resolution  layers  vertices  max_deviation_um
    0  box             200      18        72               0.0
    1  box             500      18        72               0.0
    """
    from vecslice.moves import _check_number

    pd, dask = _require()
    items = _sources(meshes)
    combos = _combinations(grid)
    speed = _check_number(speed_mm_s, "speed_mm_s", "mm/s", zero=False)
    ctrl = _check_number(controller_ms, "controller_ms", "ms", zero=True)
    scales = _scales(scale, items)
    progress = bool(check_bool(progress, "progress"))
    groups = _schedule_groups(combos)
    token = uuid.uuid4().hex if client is None else ""  # see _STOPS
    tasks = []
    for mi, (name, source) in enumerate(items):
        # a path is read once per way of reading it; a Mesh is prepared once
        is_path = isinstance(source, (str, os.PathLike))
        preps: dict[str, Any] = {}
        for group in groups:
            compat = getattr(group[0][1], "compat", "vecslice") if is_path else ""
            if compat not in preps:
                preps[compat] = dask.delayed(_prepare, pure=False)(
                    source, scales[name], compat or "vecslice")
            tasks.append((mi, name, group, dask.delayed(_rows, pure=False)(
                preps[compat], mi, name, group, speed, ctrl, token)))
    if client is None:
        results = _run_local(dask, [t[3] for t in tasks], progress, token)
    else:
        results = _run_client(client, tasks, progress)
    rows = [r for rs in results for r in rs]
    table = pd.DataFrame(rows).sort_values(["_mesh", "_combo"], kind="stable")
    table = table.drop(columns=["_mesh", "_combo"]).reset_index(drop=True)
    for c in _INT_COLUMNS:  # whole numbers stay integers unless a row failed
        if not table[c].isna().any():
            table[c] = table[c].astype(np.int64)
    return table


def _run_local(dask: Any, delayed: list[Any], progress: bool,
               token: str) -> list[Any]:
    """The tasks on this machine; on Ctrl-C, the running ones stop too.

    dask starts no further task once the interrupt reaches this thread, and
    the tasks already running stop between combinations (``_STOPS``).
    """
    _STOPS[token] = threading.Event()
    try:
        return _compute_local(dask, delayed, progress)
    except BaseException:
        _STOPS[token].set()
        raise
    finally:
        _STOPS.pop(token, None)  # a stopped task holds its Event


def _compute_local(dask: Any, delayed: list[Any], progress: bool) -> list[Any]:
    # Dask's threads on every numba threading layer: the kernels are plain nogil
    # kernels (no parfors, which numba's workqueue layer cannot run from two
    # threads at once)
    scheduler = "threads"
    if not progress:
        return list(dask.compute(*delayed, scheduler=scheduler))
    from dask.callbacks import Callback
    from tqdm import tqdm

    keys = {d.key for d in delayed}
    bar = tqdm(total=len(delayed), desc="sweep", unit="task")

    class _Bar(Callback):  # type: ignore[misc]
        def _posttask(self, key: Any, *args: Any) -> None:
            if key in keys:
                bar.update(1)

    try:
        with _Bar():
            return list(dask.compute(*delayed, scheduler=scheduler))
    finally:
        bar.close()


def _run_client(client: Any, tasks: list[Any], progress: bool) -> list[Any]:
    try:
        from distributed import Client
        from distributed import progress as show
    except ImportError:
        _require()
        raise
    if not isinstance(client, Client):
        raise InputTypeError(
            "`client` must be a distributed.Client or None; got "
            f"{type(client).__name__}"
        )
    futures = client.compute([t[3] for t in tasks], retries=2)
    if progress:
        show(futures)
    results = []
    for (mi, name, group, _), fut in zip(tasks, futures, strict=True):
        try:
            results.append(fut.result())
        except Exception as exc:  # e.g. KilledWorker: that task's rows say why
            results.append([_row(mi, name, i, s, None, _describe(exc))
                            for i, s in group])
    return results

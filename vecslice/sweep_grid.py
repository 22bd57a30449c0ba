"""The inputs of ``vs.sweep``, checked before any work: meshes, grid, scales.

Also how combinations group into tasks: those that differ only in the XY
settings share a layer schedule and its raw contours.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from difflib import get_close_matches
from pathlib import Path
from typing import Any

import numpy as np

from vecslice.errors import (
    InputTypeError,
    InputValueError,
    SettingsError,
    VecsliceError,
)
from vecslice.settings import SliceSettings

__all__ = ["XY_SETTINGS"]

XY_SETTINGS = (
    "max_resolution", "max_deviation", "max_area_deviation",
    "minimum_polygon_circumference", "union_overlapping_volumes",
)
"""Settings that leave the layer schedule and the raw contours unchanged."""
_ADAPTIVE_ONLY = ("adaptive_variation", "adaptive_variation_step",
                  "adaptive_threshold")  # read only with adaptive_layers=True


def _sources(meshes: Any) -> list[tuple[str, Any]]:
    from vecslice.mesh import Mesh

    def name_of(i: int, m: Any) -> str:
        return Path(m).name if isinstance(m, (str, os.PathLike)) else f"mesh{i}"

    if isinstance(meshes, bytes):
        raise InputTypeError(
            f"`meshes` must be a path (str or os.PathLike), a vecslice.Mesh, a list "
            f"of them or a dict name -> either; got bytes {meshes!r} (decode it)"
        )
    if isinstance(meshes, (str, os.PathLike, Mesh)):
        meshes = [meshes]
    if isinstance(meshes, Mapping):
        items = [(k, v) for k, v in meshes.items()]
        for k, _ in items:
            if not isinstance(k, str):
                raise InputTypeError(
                    f"`meshes` keys must be names (str); got {type(k).__name__} {k!r}"
                )
    elif isinstance(meshes, Sequence):
        items = [(name_of(i, m), m) for i, m in enumerate(meshes)]
    else:
        raise InputTypeError(
            "`meshes` must be a path, a vecslice.Mesh, a list of them or a dict "
            f"name -> either; got {type(meshes).__name__}"
        )
    if not items:
        raise InputValueError("`meshes` must hold at least one mesh; got none")
    seen: set[str] = set()
    for name, m in items:
        if not isinstance(m, (str, os.PathLike, Mesh)):
            raise InputTypeError(
                f"`meshes` entry {name!r} must be a path or a vecslice.Mesh; "
                f"got {type(m).__name__}"
            )
        if name in seen:
            raise InputValueError(
                f"`meshes` must have unique names; got {name!r} twice "
                "(pass a dict name -> mesh)"
            )
        seen.add(name)
    return items


class GridTypeError(SettingsError, InputTypeError):
    """A grid value of the wrong type: a SettingsError, and a TypeError."""


def _combinations(grid: Any) -> list[SliceSettings]:
    names = SliceSettings.option_names()
    if isinstance(grid, Mapping):
        if not grid:
            raise SettingsError("`grid` must name at least one setting; got {}")
        axes = []
        for key, values in grid.items():
            _check_name(key, names)
            values = _values(key, values)
            if not values:
                raise SettingsError(f"`grid[{key!r}]` must list at least one value; "
                                    "got an empty list")
            axes.append((key, values))
        combos: list[dict[str, Any]] = [{}]
        for key, values in axes:
            combos = [{**c, key: v} for c in combos for v in values]
    elif isinstance(grid, Sequence) and not isinstance(grid, (str, bytes)):
        if not grid:
            raise SettingsError("`grid` must hold at least one combination; got []")
        combos = []
        for i, c in enumerate(grid):
            if not isinstance(c, Mapping):
                raise SettingsError(
                    f"`grid[{i}]` must be a dict of settings; got {type(c).__name__}"
                )
            for key in c:
                _check_name(key, names)
            combos.append(dict(c))
    else:
        raise SettingsError(
            "`grid` must be a dict setting -> list of values or a list of dicts; "
            f"got {type(grid).__name__}"
        )
    out = []
    for c in combos:
        try:
            out.append(SliceSettings(**{k: _plain(v) for k, v in c.items()}))
        except VecsliceError as exc:
            cls = GridTypeError if isinstance(exc, TypeError) else SettingsError
            raise cls(f"`grid` combination {c!r} is invalid: {exc}") from None
    return out


def _values(key: str, values: Any) -> list[Any]:
    """The values of one grid axis: a list, array, range, Series... or one value."""
    if isinstance(values, np.ndarray) and values.ndim == 0:
        return [values.item()]
    if isinstance(values, (set, frozenset)):
        raise SettingsError(
            f"`grid[{key!r}]` must be a list of values (a set has no order, so the "
            f"rows would not either); got {values!r}"
        )
    if isinstance(values, (str, bytes, Mapping)) or not isinstance(values, Iterable):
        return [values]
    return list(values)


def _check_name(key: object, names: tuple[str, ...]) -> None:
    if not isinstance(key, str) or key not in names:
        close = get_close_matches(str(key), names, n=1)
        hint = f"; did you mean `{close[0]}`?" if close else ""
        raise SettingsError(
            f"`grid` must name SliceSettings fields ({', '.join(names)}); "
            f"got unknown setting {key!r}{hint}"
        )


def _plain(v: Any) -> Any:
    """Numpy scalars from a grid as Python scalars."""
    return v.item() if isinstance(v, np.generic) else v


def _scales(scale: Any, items: list[tuple[str, Any]]) -> dict[str, float]:
    """The scale of every mesh; only meshes given as paths are scaled."""
    from vecslice.mesh import _check_scale

    paths = {n for n, m in items if isinstance(m, (str, os.PathLike))}
    if isinstance(scale, Mapping):
        unknown = sorted(set(scale) - {n for n, _ in items})
        if unknown:
            raise InputValueError(
                f"`scale` must name meshes of the sweep; got unknown {unknown[0]!r}"
            )
        out = {n: _check_scale(scale.get(n, 1.0)) for n, _ in items}
        given = sorted(n for n in scale if n not in paths and out[n] != 1.0)
        if given:
            raise InputValueError(
                f"`scale` applies to meshes given as paths; {given[0]!r} is a "
                f"vecslice.Mesh (scale {scale[given[0]]!r}): load it with that "
                "scale instead"
            )
        return out
    s = _check_scale(scale)
    if s != 1.0 and not paths:
        raise InputValueError(
            f"`scale` applies to meshes given as paths; got {scale!r} and only "
            "vecslice.Mesh objects: load them with that scale instead"
        )
    return {n: s for n, _ in items}



def _schedule_groups(
    combos: list[SliceSettings],
) -> list[list[tuple[int, SliceSettings]]]:
    """Combinations grouped by everything but the XY settings (the schedule).

    Without adaptive layers the ``adaptive_*`` settings change nothing either:
    such combinations share their uniform schedule's raw contours.
    """
    groups: dict[tuple[Any, ...], list[tuple[int, SliceSettings]]] = {}
    for i, s in enumerate(combos):
        unused = () if s.adaptive_layers else _ADAPTIVE_ONLY
        key = tuple((k, getattr(s, k)) for k in SliceSettings.option_names()
                    if k not in XY_SETTINGS and k not in unused)
        groups.setdefault(key, []).append((i, s))
    return list(groups.values())



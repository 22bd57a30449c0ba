"""Slicing settings (CuraEngine's names and defaults, all lengths in int64 µm)."""

from __future__ import annotations

from dataclasses import dataclass, fields
from difflib import get_close_matches
from typing import Literal

from vecslice._validate import SettingsTypeError, check_bool, check_int, check_option
from vecslice.errors import SettingsError

__all__ = ["COMPAT_MODES", "MAX_LAYERS", "SLICING_TOLERANCES", "SliceSettings"]

SLICING_TOLERANCES = ("middle", "inclusive", "exclusive")
COMPAT_MODES = ("vecslice", "cura")
MAX_LAYERS = 100_000
"""Default layer limit (``SliceSettings.max_layers``): 10 m of 0.1 mm layers."""


@dataclass(frozen=True, slots=True)
class SliceSettings:
    """Settings of :func:`vecslice.slice_mesh`, validated on construction.

    Parameters
    ----------
    layer_height : int, default 100
        Layer thickness in µm (Cura ``layer_height``), ``> 0``.
    initial_layer_height : int, default 300
        First layer thickness in µm (Cura ``layer_height_0``), ``> 0``.
    slicing_tolerance : {'middle', 'inclusive', 'exclusive'}, default 'middle'
        Where each layer is cut: its middle; its bottom then unioned with the next
        layer; or its bottom then intersected with the next layer.
    max_resolution : int, default 500
        Edges shorter than this (µm) may be removed by simplification.
    max_deviation : int, default 25
        CuraEngine's per-removal threshold (µm): a vertex is removed only if it
        lies within this distance of the line through its kept neighbours (and a
        short edge is replaced by an intersection only within it). Removals
        accumulate, so the simplified contour can end up further than this from
        the raw one; :mod:`vecslice.metrics` measures how far.
    max_area_deviation : int, default 50000
        Largest extrusion-area change (µm²) for variable-width paths.
    minimum_polygon_circumference : int, default 1000
        Loops with a shorter perimeter (µm) are dropped before simplification.
    union_overlapping_volumes : bool, default True
        Union the loops of a layer with the NonZero rule (overlapping bodies merge);
        ``False`` uses EvenOdd.
    compat : {'vecslice', 'cura'}, default 'vecslice'
        ``'cura'`` builds the polygons as CuraEngine does, with all its rounding
        (``spec/CURA_COMPAT.md``): two crossings per face from the face's own
        vertex order with CuraEngine's biased ``interpolate``, its case table and
        on-plane rules, loops started at the lowest unused segment with the
        near-duplicate closing point kept into simplification, its chaining,
        stitching, circumference filter and open-polyline stitcher. Use it with a
        mesh loaded with ``load_mesh(path, compat="cura")`` to get the polygons
        CuraEngine hands to its union; the union itself stays manifold3d's. The
        default ``'vecslice'`` computes one crossing per mesh edge, rounded once,
        so loops are watertight by construction.
    max_layers : int, default 100000 (``vecslice.settings.MAX_LAYERS``)
        Largest number of layers a slice may have, ``>= 1``. More layers raise a
        :class:`SettingsError` before any work, naming the count: memory and time
        grow with the layer count (100,000 layers are 10 m at 0.1 mm). Raise it
        to slice taller objects or thinner layers.
    adaptive_layers : bool, default False
        Use CuraEngine's adaptive layer heights (Cura
        ``adaptive_layer_height_enabled``) instead of the uniform schedule; see
        :func:`vecslice.layer_heights`.
    adaptive_variation : int, default 100
        Adaptive layers are ``layer_height ± adaptive_variation`` µm thick (Cura
        ``adaptive_layer_height_variation``), ``>= 0``.
    adaptive_variation_step : int, default 10
        Spacing of the allowed adaptive heights in µm (Cura
        ``adaptive_layer_height_variation_step``), ``> 0``.
    adaptive_threshold : int, default 200
        Largest allowed stair-step width ``height / tan(slope)`` in µm (Cura
        ``adaptive_layer_height_threshold``, "Topography Size"); ``<= 0`` makes
        every layer on a non-flat surface the thinnest allowed.

    Raises
    ------
    SettingsError
        A height is not positive, a threshold is negative, the tolerance is unknown,
        ``max_layers`` is not positive, the adaptive step is not positive or the
        adaptive variation leaves no allowed height.
    """

    layer_height: int = 100
    initial_layer_height: int = 300
    slicing_tolerance: Literal["middle", "inclusive", "exclusive"] = "middle"
    max_resolution: int = 500
    max_deviation: int = 25
    max_area_deviation: int = 50000
    minimum_polygon_circumference: int = 1000
    union_overlapping_volumes: bool = True
    compat: Literal["vecslice", "cura"] = "vecslice"
    max_layers: int = MAX_LAYERS
    adaptive_layers: bool = False
    adaptive_variation: int = 100
    adaptive_variation_step: int = 10
    adaptive_threshold: int = 200

    def __init__(
        self,
        *,
        layer_height: int = 100,
        initial_layer_height: int = 300,
        slicing_tolerance: Literal["middle", "inclusive", "exclusive"] = "middle",
        max_resolution: int = 500,
        max_deviation: int = 25,
        max_area_deviation: int = 50000,
        minimum_polygon_circumference: int = 1000,
        union_overlapping_volumes: bool = True,
        compat: Literal["vecslice", "cura"] = "vecslice",
        max_layers: int = MAX_LAYERS,
        adaptive_layers: bool = False,
        adaptive_variation: int = 100,
        adaptive_variation_step: int = 10,
        adaptive_threshold: int = 200,
        **unknown: object,
    ) -> None:
        if unknown:
            name = sorted(unknown)[0]
            close = get_close_matches(name, self.option_names(), n=1)
            hint = f"; did you mean `{close[0]}`?" if close else ""
            raise SettingsTypeError(
                f"unknown setting `{name}` (got {unknown[name]!r}); settings are "
                f"{', '.join(self.option_names())}{hint}"
            )
        values = dict(locals())
        for name in self.option_names():
            object.__setattr__(self, name, values[name])
        self._check()

    def _check(self) -> None:
        limit = 2**30
        for name, minimum in (("layer_height", 1), ("initial_layer_height", 1)):
            v = check_int(getattr(self, name), name, minimum=minimum, maximum=limit)
            object.__setattr__(self, name, v)
        for name in (
            "max_resolution", "max_deviation", "minimum_polygon_circumference"
        ):
            v = check_int(getattr(self, name), name, minimum=0, maximum=limit)
            object.__setattr__(self, name, v)
        v = check_int(self.max_area_deviation, "max_area_deviation", minimum=0,
                      maximum=2**62)
        object.__setattr__(self, "max_area_deviation", v)
        check_option(self.slicing_tolerance, SLICING_TOLERANCES, "slicing_tolerance")
        check_option(self.compat, COMPAT_MODES, "compat")
        v = check_bool(self.union_overlapping_volumes, "union_overlapping_volumes",
                       setting=True)
        object.__setattr__(self, "union_overlapping_volumes", v)
        n = check_int(self.max_layers, "max_layers", minimum=1,
                      what="an integer number of layers")
        object.__setattr__(self, "max_layers", n)
        self._check_adaptive(limit)

    def _check_adaptive(self, limit: int) -> None:
        on = check_bool(self.adaptive_layers, "adaptive_layers", setting=True)
        object.__setattr__(self, "adaptive_layers", on)
        # ADAPTIVE.md section 1: a step <= 0 never ends CuraEngine's list of allowed
        # heights; a negative variation leaves it empty (undefined behaviour there)
        step = check_int(self.adaptive_variation_step, "adaptive_variation_step",
                         minimum=1, maximum=limit)
        v = check_int(self.adaptive_variation, "adaptive_variation", maximum=limit)
        if v < 0:
            raise SettingsError(
                "`adaptive_variation` must be >= 0 (from layer_height + variation "
                f"down to layer_height - variation no height is allowed); got {v}"
            )
        t = check_int(self.adaptive_threshold, "adaptive_threshold",
                      minimum=-limit, maximum=limit)
        for name, value in (("adaptive_variation_step", step),
                            ("adaptive_variation", v), ("adaptive_threshold", t)):
            object.__setattr__(self, name, value)

    def replace(self, **changes: object) -> SliceSettings:
        """A copy with some settings changed (validated like the constructor)."""
        values: dict[str, object] = {n: getattr(self, n) for n in self.option_names()}
        values.update(changes)
        return SliceSettings(**values)  # type: ignore[arg-type]

    @classmethod
    def option_names(cls) -> tuple[str, ...]:
        """Names of all settings, in declaration order."""
        return tuple(f.name for f in fields(cls))

"""Printer moves along the contours of a sliced model (see :mod:`vecslice.metrics`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vecslice.errors import InputTypeError, SettingsError
from vecslice.interrupt import keyboard_interrupts
from vecslice.paths import LayerPaths, Paths
from vecslice.storage import SlicedModel
from vecslice.units import power_of_ten

__all__ = ["MoveStats", "move_stats"]


def _check_number(value: object, name: str, unit: str, *, zero: bool) -> float:
    """A finite real number, > 0 (or >= 0 with ``zero``), as a float."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise InputTypeError(
            f"`{name}` must be a number of {unit}; got {type(value).__name__} "
            f"{value!r}"
        )
    want = "finite and >= 0" if zero else "finite and > 0"
    try:
        v = float(value)
    except OverflowError:  # a Python int beyond float range (10**400)
        raise SettingsError(f"`{name}` must be {want} ({unit}); got "
                            f"{power_of_ten(value)}") from None
    if not np.isfinite(v) or v < 0 or (v == 0 and not zero):
        raise SettingsError(f"`{name}` must be {want} ({unit}); got {v!r}")
    return v


@dataclass(frozen=True, slots=True)
class MoveStats:
    """The contour moves of a sliced model, one per vertex (edge of a ring).

    Without moves (a model with no rings) the lengths, durations,
    ``short_move_fraction`` and ``moves_per_s`` are NaN.

    Attributes
    ----------
    moves : int
        Number of moves (edges, closing edges included).
    total_length_um : float
        Summed move length, µm.
    shortest_um : float
        Shortest move, µm (NaN without moves).
    percentiles : tuple of float
        The percentiles reported below (of all moves).
    length_percentiles_um : tuple of float
        Move length at each percentile, µm.
    duration_percentiles_ms : tuple of float
        Move duration at the contour speed, ms.
    short_move_fraction : float
        Share of moves lasting less than the controller's time per move.
    moves_per_s : float
        Moves the controller must plan per second while printing contours:
        ``moves / (total_length / speed)``.
    speed_mm_s, controller_ms : float
        The speed and controller time used.
    """

    moves: int
    total_length_um: float
    shortest_um: float
    percentiles: tuple[float, ...]
    length_percentiles_um: tuple[float, ...]
    duration_percentiles_ms: tuple[float, ...]
    short_move_fraction: float
    moves_per_s: float
    speed_mm_s: float
    controller_ms: float

    @property
    def print_time_s(self) -> float:
        """Time to trace every contour once at the contour speed, s."""
        return self.total_length_um / (self.speed_mm_s * 1000.0)


def _edge_d2(coords: NDArray[np.int64], offsets: NDArray[np.int64]) -> NDArray[Any]:
    """Squared length (exact int64) of every edge of every closed ring."""
    n = coords.shape[0]
    nxt = np.arange(1, n + 1, dtype=np.int64)
    lens = np.diff(offsets)
    ends = offsets[1:][lens > 0]
    nxt[ends - 1] = offsets[:-1][lens > 0]
    d = coords[nxt] - coords
    return d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]


@keyboard_interrupts
def move_stats(
    source: SlicedModel | LayerPaths | Paths,
    *,
    speed_mm_s: float = 60,
    controller_ms: float = 1.0,
    percentiles: tuple[float, ...] = (1, 5, 50, 95, 99),
) -> MoveStats:
    """Printer moves along every ring of ``source``, at one contour speed.

    Parameters
    ----------
    source : SlicedModel, LayerPaths or Paths
        Closed rings; every edge is one move.
    speed_mm_s : float, default 60
        Contour speed, mm/s, ``> 0``.
    controller_ms : float, default 1.0
        The controller's time per move, ms, ``>= 0``: a planner that needs that
        long per command starves on shorter moves.
    percentiles : tuple of float, default (1, 5, 50, 95, 99)
        Percentiles (0..100) of length and duration to report.

    Returns
    -------
    MoveStats

    Notes
    -----
    A move is short when its duration ``length / speed`` is below
    ``controller_ms``, i.e. its length is below ``speed_mm_s * controller_ms``
    µm; the test compares exact int64 squared lengths.

    Examples
    --------
    A 1 mm square at 60 mm/s: four 1000 µm moves of 16.7 ms, 60 per second.

    >>> sq = Paths([[0, 0], [1000, 0], [1000, 1000], [0, 1000]], [0, 4])
    >>> st = move_stats(sq, speed_mm_s=60, controller_ms=1.0)
    >>> st.moves, st.shortest_um, st.moves_per_s, st.short_move_fraction
    (4, 1000.0, 60.0, 0.0)
    """
    if isinstance(source, SlicedModel):
        coords, offsets = source.coords, source.ring_offsets
    elif isinstance(source, (LayerPaths, Paths)):
        coords, offsets = source.coords, source.ring_offsets
    else:
        raise InputTypeError(
            "`source` must be a vecslice.SlicedModel, LayerPaths or Paths; "
            f"got {type(source).__name__}"
        )
    speed = _check_number(speed_mm_s, "speed_mm_s", "mm/s", zero=False)
    ctrl = _check_number(controller_ms, "controller_ms", "ms", zero=True)
    if isinstance(percentiles, (str, bytes)) or not isinstance(
        percentiles, (Sequence, np.ndarray)
    ):
        raise InputTypeError(
            "`percentiles` must be a sequence of numbers (percent), e.g. (50,); "
            f"got {type(percentiles).__name__} {percentiles!r}"
        )
    q = tuple(_check_number(p, "percentiles", "percent", zero=True)
              for p in np.asarray(percentiles, dtype=object).reshape(-1))
    if any(p > 100 for p in q):
        raise SettingsError(f"`percentiles` must be in [0, 100]; got {percentiles!r}")
    d2 = _edge_d2(coords, offsets)
    n = int(d2.shape[0])
    if n == 0:
        nan = float("nan")
        return MoveStats(0, 0.0, nan, q, (nan,) * len(q), (nan,) * len(q), nan,
                         nan, speed, ctrl)
    length = np.sqrt(d2.astype(np.float64))
    total = float(length.sum())
    limit = speed * ctrl  # µm: mm/s * ms
    lp = np.percentile(length, q) if q else np.empty(0)
    return MoveStats(
        moves=n,
        total_length_um=total,
        shortest_um=float(length.min()),
        percentiles=q,
        length_percentiles_um=tuple(float(x) for x in lp),
        duration_percentiles_ms=tuple(float(x) / speed for x in lp),
        short_move_fraction=float((d2.astype(np.float64) < limit * limit).mean()),
        moves_per_s=n * speed * 1000.0 / total if total else float("inf"),
        speed_mm_s=speed,
        controller_ms=ctrl,
    )

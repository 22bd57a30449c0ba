"""Layers of parts (CuraEngine's LayerParts): the container and its part views.

:class:`PartsLayout` holds the access shared by every container with the layout
layers -> parts -> rings -> coords (:class:`LayerParts` and
:class:`vecslice.SlicedModel`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice.errors import LayoutError
from vecslice.paths import exact_area2
from vecslice.ragged import RaggedContainer, check_index, nested_offsets

__all__ = ["LayerParts", "PartsLayout", "check_part_rings"]

Part = tuple[NDArray[np.int64], list[NDArray[np.int64]]]


def check_part_rings(
    coords: NDArray[np.int64],
    ring_offsets: NDArray[np.int64],
    part_offsets: NDArray[np.int64],
    layer_offsets: NDArray[np.int64],
) -> None:
    """Raise a LayoutError unless every part is an outline and its holes.

    Every part has >= 1 ring, every ring >= 3 vertices, every outline (first ring
    of a part) a positive area (CCW) and every hole a negative area (CW). The
    offsets are already valid. A ring whose twice-area does not fit int64 (it
    winds around more than once near the coordinate limit) is an InputValueError.
    """
    def where(r: int) -> str:
        q = int(np.searchsorted(part_offsets, r, side="right")) - 1
        k = int(np.searchsorted(layer_offsets, q, side="right")) - 1
        role = "the outline" if r == part_offsets[q] else "a hole"
        return f"ring {r} ({role} of part {q}, layer {k})"

    empty = np.flatnonzero(np.diff(part_offsets) == 0)
    if empty.size:
        raise LayoutError(
            f"`part_offsets` must give every part >= 1 ring (its outline); "
            f"part {int(empty[0])} is empty"
        )
    lens = np.diff(ring_offsets)
    small = np.flatnonzero(lens < 3)
    if small.size:
        r = int(small[0])
        raise LayoutError(
            f"every ring must have >= 3 vertices; {where(r)} has {int(lens[r])}"
        )
    a2 = exact_area2(coords, ring_offsets, where)  # never wrapped: signs are true
    is_outline = np.zeros(a2.shape[0], dtype=bool)
    is_outline[part_offsets[:-1]] = True
    bad = np.flatnonzero(np.where(is_outline, a2 <= 0, a2 >= 0))
    if bad.size:
        r = int(bad[0])
        want = ("counter-clockwise (area > 0)" if is_outline[r]
                else "clockwise (area < 0)")
        raise LayoutError(
            f"{where(r)} must be {want}; got twice the signed area {int(a2[r])} µm²"
        )


class PartsLayout(RaggedContainer):
    """Views and per-layer sums of a layers -> parts -> rings -> coords layout.

    In plain Python, ring ``r`` of part ``j`` of layer ``k`` is::

        q = layer_offsets[k] + j                  # global part index
        i = part_offsets[q] + r                   # global ring index (r = 0: outline)
        coords[ring_offsets[i]:ring_offsets[i + 1]]
    """

    __slots__ = ()
    coords: NDArray[np.int64]
    ring_offsets: NDArray[np.int64]
    part_offsets: NDArray[np.int64]
    layer_offsets: NDArray[np.int64]

    @property
    def n_layers(self) -> int:
        """Number of layers ``L``."""
        return int(self.layer_offsets.shape[0] - 1)

    @property
    def n_parts(self) -> int:
        """Number of parts ``P`` over all layers."""
        return int(self.part_offsets.shape[0] - 1)

    @property
    def n_rings(self) -> int:
        """Number of rings ``R`` (outlines and holes) over all layers."""
        return int(self.ring_offsets.shape[0] - 1)

    def _part_views(self, q: int) -> Part:
        """Global part ``q`` as ``(outline, [holes])`` views."""
        ro, c = self.ring_offsets, self.coords
        r0, r1 = int(self.part_offsets[q]), int(self.part_offsets[q + 1])
        return c[ro[r0] : ro[r0 + 1]], [c[ro[r] : ro[r + 1]] for r in range(r0 + 1, r1)]

    def _layer_parts(self, i: object, name: str) -> list[Part]:
        k = check_index(i, self.n_layers, name, "layer index")
        q0, q1 = int(self.layer_offsets[k]), int(self.layer_offsets[k + 1])
        return [self._part_views(q) for q in range(q0, q1)]

    def _part(self, i: object, j: object, names: tuple[str, str]) -> Part:
        k = check_index(i, self.n_layers, names[0], "layer index")
        q0, q1 = int(self.layer_offsets[k]), int(self.layer_offsets[k + 1])
        q = check_index(j, q1 - q0, names[1], f"part index of layer {k}")
        return self._part_views(q0 + q)

    def ring_layer(self) -> NDArray[np.int64]:
        """Layer index of each ring, shape (R,)."""
        part_layer = np.repeat(np.arange(self.n_layers, dtype=np.int64),
                               np.diff(self.layer_offsets))
        return np.repeat(part_layer, np.diff(self.part_offsets))

    def layer_areas(self) -> NDArray[np.float64]:
        """Area of each layer in µm², holes subtracted, shape (L,), float64."""
        a2 = exact_area2(self.coords, self.ring_offsets)
        out = np.bincount(self.ring_layer(), weights=a2, minlength=self.n_layers)
        return out / 2.0

    def to_shapely(self, i: int) -> Any:
        """Layer ``i`` as a shapely MultiPolygon in millimetres (needs shapely).

        Clipper's rings may touch at vertices, which shapely's ``is_valid``
        refuses: see :func:`vecslice.interop.to_shapely`.
        """
        from vecslice.interop import to_shapely

        return to_shapely(self, check_index(i, self.n_layers, "i", "layer index"))


@dataclass(frozen=True, slots=True, eq=False)
class LayerParts(PartsLayout):
    """Layers split into parts (CuraEngine's LayerParts), with nested offsets.

    Attributes
    ----------
    coords : ndarray of shape (N, 2), int64
        All vertices in µm.
    ring_offsets : ndarray of shape (R + 1,), int64
        Ring starts in ``coords``.
    part_offsets : ndarray of shape (P + 1,), int64
        Part starts in the rings. The first ring of a part is its outline (CCW,
        ``ring_area2 > 0``); the others are its holes (CW, ``ring_area2 < 0``).
    layer_offsets : ndarray of shape (L + 1,), int64
        Layer starts in the parts.

    Raises
    ------
    LayoutError
        If an offsets array is invalid, a part has no ring, a ring fewer than 3
        vertices, an outline is not CCW or a hole not CW.

    Examples
    --------
    >>> sq = [[0, 0], [10, 0], [10, 10], [0, 10]]
    >>> p = LayerParts(sq, [0, 4], [0, 1], [0, 0, 1])
    >>> p.n_layers, p.n_parts, p.part(1, 0)[0].tolist()
    (2, 1, [[0, 0], [10, 0], [10, 10], [0, 10]])

    In plain Python, ring ``r`` of part ``j`` of layer ``k`` is::

        q = layer_offsets[k] + j
        r_abs = part_offsets[q] + r
        coords[ring_offsets[r_abs]:ring_offsets[r_abs + 1]]
    """

    coords: NDArray[np.int64]
    ring_offsets: NDArray[np.int64]
    part_offsets: NDArray[np.int64]
    layer_offsets: NDArray[np.int64]

    def __init__(
        self,
        coords: ArrayLike,
        ring_offsets: ArrayLike,
        part_offsets: ArrayLike,
        layer_offsets: ArrayLike,
    ) -> None:
        # private copies, validated after copying (see ragged.nested_offsets)
        arrays = nested_offsets(coords, [
            ("ring_offsets", ring_offsets), ("part_offsets", part_offsets),
            ("layer_offsets", layer_offsets),
        ])
        check_part_rings(*arrays)
        names = ("coords", "ring_offsets", "part_offsets", "layer_offsets")
        self._set_fields(dict(zip(names, arrays, strict=True)))

    def layer(self, k: int) -> list[Part]:
        """Parts of layer ``k`` as ``[(outline (n, 2), [holes]), ...]`` views."""
        return self._layer_parts(k, "k")

    def part(self, k: int, j: int) -> Part:
        """Part ``j`` of layer ``k`` as ``(outline, [holes])`` read-only views."""
        return self._part(k, j, ("k", "j"))

    def __repr__(self) -> str:
        return (
            f"LayerParts({self.n_layers} layers, {self.n_parts} parts, "
            f"{self.n_rings} rings, {self.coords.shape[0]} vertices)"
        )

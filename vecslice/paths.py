"""Ragged containers of rings: :class:`Paths` and :class:`LayerPaths`."""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice._kernels.rings import AREA2_BEYOND_INT64, ring_area2
from vecslice._validate import as_int_array, check_coord_range, check_int
from vecslice.errors import InputTypeError, InputValueError, LayoutError
from vecslice.ragged import (
    RaggedContainer,
    check_index,
    nested_offsets,
    offsets_from_lengths,
)
from vecslice.units import COORD_LIMIT

__all__ = ["LayerPaths", "Paths", "exact_area2"]


def exact_area2(
    coords: NDArray[np.int64], ring_offsets: NDArray[np.int64],
    where: Callable[[int], str] | None = None,
) -> NDArray[np.int64]:
    """Twice the signed area of each ring in µm², exact, or an InputValueError.

    A ring's twice-area fits int64 unless the ring winds around more than once
    near the coordinate limit; such a ring is refused (the message names it with
    ``where(r)``, default ``"ring r"``, and gives the exact value) instead of
    wrapping around, which could flip its orientation.
    """
    a2 = ring_area2(coords, ring_offsets)
    beyond = np.flatnonzero(a2 == AREA2_BEYOND_INT64)
    if beyond.size:
        r = int(beyond[0])
        d = coords[ring_offsets[r] : ring_offsets[r + 1]] - coords[ring_offsets[r]]
        t = d[1:-1, 0] * d[2:, 1] - d[1:-1, 1] * d[2:, 0]  # each fits int64
        exact = int((t >> 32).sum()) * 2**32 + int((t & 0xFFFFFFFF).sum())
        raise InputValueError(
            f"twice the signed area of {where(r) if where else f'ring {r}'} must "
            f"fit int64 (|value| < 2**63); got {exact} µm² (a ring that winds "
            "around more than once near the coordinate limit)"
        )
    return a2


@dataclass(frozen=True, slots=True, eq=False)
class Paths(RaggedContainer):
    """Rings or polylines in one flat buffer.

    Ring ``i`` is ``coords[ring_offsets[i]:ring_offsets[i + 1]]``; closed rings do not
    repeat their first vertex.

    Attributes
    ----------
    coords : ndarray of shape (N, 2), int64
        All vertices in µm.
    ring_offsets : ndarray of shape (R + 1,), int64
        Start of each ring in ``coords``, then ``N``.

    Examples
    --------
    >>> p = Paths([[0, 0], [10, 0], [10, 10], [0, 10]], [0, 4])
    >>> len(p), p.ring(0).shape, p.area2().tolist()
    (1, (4, 2), [200])
    """

    coords: NDArray[np.int64]
    ring_offsets: NDArray[np.int64]

    def __init__(self, coords: ArrayLike, ring_offsets: ArrayLike) -> None:
        # private copies, validated after copying (see ragged.nested_offsets)
        c, o = nested_offsets(coords, [("ring_offsets", ring_offsets)])
        self._set_fields({"coords": c, "ring_offsets": o})

    @classmethod
    def from_rings(cls, rings: Iterable[ArrayLike]) -> Paths:
        """Build from a sequence of rings, each an (n, 2) array of integer µm.

        Parameters
        ----------
        rings : iterable of array_like of shape (n, 2), int
            The rings in order; an empty ring may be ``[]``.

        Returns
        -------
        Paths

        Raises
        ------
        InputTypeError
            If ``rings`` is not an iterable of arrays, or a ring is not integer.
        InputValueError
            If a ring does not have shape (n, 2) or a value reaches ``2**30`` µm;
            the message names the ring (``rings[i]``).

        Examples
        --------
        >>> Paths.from_rings([[[0, 0], [4, 0], [0, 4]], []]).ring_lengths().tolist()
        [3, 0]
        """
        if isinstance(rings, (str, bytes, dict)) or not isinstance(rings, Iterable):
            raise InputTypeError(
                "`rings` must be a sequence of (n, 2) integer arrays; got "
                f"{type(rings).__name__}"
            )
        arrs = []
        for i, ring in enumerate(rings):
            if isinstance(ring, (list, tuple)) and len(ring) == 0:
                ring = np.empty((0, 2), np.int64)
            arrs.append(as_int_array(ring, f"rings[{i}]", ndim=2, width=2))
        offsets = offsets_from_lengths(np.array([len(r) for r in arrs], np.int64))
        # a fresh copy of the rings, range-checked after copying (not the rings
        # given, which their owner could change in between)
        coords = (
            np.concatenate(arrs) if arrs else np.empty((0, 2), dtype=np.int64)
        )
        lim = COORD_LIMIT
        if coords.size and not -lim < coords.min() <= coords.max() < lim:
            for i, (a, b) in enumerate(itertools.pairwise(offsets.tolist())):
                check_coord_range(coords[a:b], f"rings[{i}]")  # names the ring
        return cls._trusted(coords, offsets)

    def __len__(self) -> int:
        return int(self.ring_offsets.shape[0] - 1)

    @property
    def n_rings(self) -> int:
        """Number of rings ``R``."""
        return len(self)

    def ring(self, i: int) -> NDArray[np.int64]:
        """Vertices of ring ``i`` as a read-only (n, 2) view.

        Negative ``i`` counts from the end (``-1`` is the last ring).

        Raises
        ------
        InputTypeError
            If ``i`` is not an integer.
        InputIndexError
            If ``i`` is not in ``[-R, R)`` (also an ``IndexError``).
        """
        i = check_index(i, len(self), "i", "ring index")
        return self.coords[self.ring_offsets[i] : self.ring_offsets[i + 1]]

    def rings(self) -> list[NDArray[np.int64]]:
        """All rings as a list of (n, 2) views."""
        ro = self.ring_offsets.tolist()
        return [self.coords[a:b] for a, b in itertools.pairwise(ro)]

    def ring_lengths(self) -> NDArray[np.int64]:
        """Vertex count of each ring, shape (R,)."""
        return np.diff(self.ring_offsets)

    def area2(self) -> NDArray[np.int64]:
        """Twice the signed area of each ring in µm² (exact; CCW > 0).

        Raises InputValueError for a ring whose value does not fit int64 (one
        that winds around more than once near the coordinate limit).
        """
        return exact_area2(self.coords, self.ring_offsets)

    def __repr__(self) -> str:
        return f"Paths({len(self)} rings, {self.coords.shape[0]} vertices)"


@dataclass(frozen=True, slots=True, eq=False)
class LayerPaths(RaggedContainer):
    """Rings grouped by layer.

    Layer ``k`` holds rings ``layer_offsets[k]:layer_offsets[k + 1]``; ring ``i`` is
    ``coords[ring_offsets[i]:ring_offsets[i + 1]]``.

    Attributes
    ----------
    coords : ndarray of shape (N, 2), int64
        All vertices in µm.
    ring_offsets : ndarray of shape (R + 1,), int64
        Ring starts in ``coords``.
    layer_offsets : ndarray of shape (L + 1,), int64
        Layer starts in the rings.
    open : LayerPaths or None
        Chains that did not close (open polylines), with the same layers; ``None``
        on a LayerPaths that itself holds open chains.

    Examples
    --------
    >>> lp = LayerPaths([[0, 0], [10, 0], [0, 10]], [0, 3], [0, 0, 1])
    >>> lp.n_layers, [len(x) for x in lp.layer(0)], [len(x) for x in lp.layer(1)]
    (2, [], [3])
    """

    coords: NDArray[np.int64]
    ring_offsets: NDArray[np.int64]
    layer_offsets: NDArray[np.int64]
    open: LayerPaths | None

    def __init__(
        self,
        coords: ArrayLike,
        ring_offsets: ArrayLike,
        layer_offsets: ArrayLike,
        open: LayerPaths | None = None,
    ) -> None:
        c, r, lo = nested_offsets(  # private copies, validated after copying
            coords, [("ring_offsets", ring_offsets), ("layer_offsets", layer_offsets)]
        )
        if open is not None and not isinstance(open, LayerPaths):
            raise InputTypeError(
                f"`open` must be a vecslice.LayerPaths or None; got "
                f"{type(open).__name__}"
            )
        if open is not None and open.n_layers != lo.shape[0] - 1:
            raise LayoutError(
                f"`open` must have {lo.shape[0] - 1} layers; got {open.n_layers}"
            )
        self._set_fields(
            {"coords": c, "ring_offsets": r, "layer_offsets": lo, "open": open})

    @classmethod
    def empty(cls, n_layers: int) -> LayerPaths:
        """A LayerPaths with ``n_layers`` (an int >= 0) empty layers."""
        n_layers = check_int(n_layers, "n_layers", minimum=0, setting=False,
                             what="an integer number of layers")
        return cls(
            np.empty((0, 2), np.int64), np.zeros(1, np.int64),
            np.zeros(n_layers + 1, np.int64),
        )

    @property
    def n_layers(self) -> int:
        """Number of layers ``L``."""
        return int(self.layer_offsets.shape[0] - 1)

    @property
    def n_rings(self) -> int:
        """Number of rings ``R`` over all layers."""
        return int(self.ring_offsets.shape[0] - 1)

    def __len__(self) -> int:
        return self.n_layers

    def layer(self, k: int) -> list[NDArray[np.int64]]:
        """Rings of layer ``k`` as a list of read-only (n, 2) views.

        Negative ``k`` counts from the end (``-1`` is the last layer).

        Raises
        ------
        InputTypeError
            If ``k`` is not an integer.
        InputIndexError
            If ``k`` is not in ``[-L, L)`` (also an ``IndexError``).
        """
        k = check_index(k, self.n_layers, "k", "layer index")
        r0, r1 = self.layer_offsets[k], self.layer_offsets[k + 1]
        ro = self.ring_offsets
        return [self.coords[ro[i] : ro[i + 1]] for i in range(r0, r1)]

    def paths(self) -> Paths:
        """All rings of all layers as one :class:`Paths` (layers flattened)."""
        return Paths._trusted(self.coords, self.ring_offsets)

    def rings_per_layer(self) -> NDArray[np.int64]:
        """Number of rings in each layer, shape (L,)."""
        return np.diff(self.layer_offsets)

    def ring_layer(self) -> NDArray[np.int64]:
        """Layer index of each ring, shape (R,)."""
        layers = np.arange(self.n_layers, dtype=np.int64)
        return np.repeat(layers, self.rings_per_layer())

    def area2(self) -> NDArray[np.int64]:
        """Twice the signed area of each ring in µm² (exact; CCW > 0).

        Raises InputValueError for a ring whose value does not fit int64 (one
        that winds around more than once near the coordinate limit).
        """
        return exact_area2(
            self.coords, self.ring_offsets,
            lambda r: f"ring {r} (layer "
            f"{int(np.searchsorted(self.layer_offsets, r, side='right')) - 1})")

    def layer_area2(self) -> NDArray[np.int64]:
        """Twice the signed area summed over the rings of each layer, shape (L,).

        Exact. Raises InputValueError if a layer's sum does not fit int64 (each
        ring's does: |coordinates| < 2**30; rings of a layer as large as that,
        overlapping, can sum beyond it) instead of wrapping around.
        """
        area2 = self.area2()
        layer = self.ring_layer()
        out = np.zeros(self.n_layers, dtype=np.int64)
        np.add.at(out, layer, area2)
        # the float64 sums are within 2**11 per ring of the exact ones: a layer
        # below 2**62 in float cannot have wrapped; the others are summed exactly
        approx = np.bincount(layer, weights=area2.astype(np.float64),
                             minlength=self.n_layers)
        for k in np.flatnonzero(np.abs(approx) >= 2.0**62).tolist():
            exact = sum(int(a) for a in area2[layer == k])
            if not -(2**63) <= exact < 2**63:
                raise InputValueError(
                    f"twice the area of layer {k} must fit int64 (|value| < 2**63); "
                    f"got {exact} µm² (overlapping rings near the coordinate limit)"
                )
        return out

    def __repr__(self) -> str:
        n_open = self.open.n_rings if self.open is not None else 0
        return (
            f"LayerPaths({self.n_layers} layers, {self.n_rings} rings, "
            f"{self.coords.shape[0]} vertices, {n_open} open chains)"
        )

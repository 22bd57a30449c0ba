"""``SlicedModel``: the sliced layers (CuraEngine's SliceDataStorage), saved as .npz.

Layout (GeoArrow/shapely MultiPolygon nesting): ``layer_offsets`` (L + 1) -> parts,
``part_offsets`` (P + 1) -> rings, ``ring_offsets`` (R + 1) -> ``coords`` (N, 2).
Open polylines of broken meshes are kept beside them with their own offsets.
"""

from __future__ import annotations

import os
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice._kernels.rings import ring_area2
from vecslice._validate import as_coords, as_int_array, as_offsets
from vecslice.errors import InputValueError, LayoutError, StorageFileError
from vecslice.paths import LayerPaths

__all__ = ["FORMAT", "FORMAT_VERSION", "SlicedModel", "load_sliced"]

FORMAT = "vecslice.SlicedModel"
FORMAT_VERSION = 1

_PER_LAYER = ("slice_z", "print_z", "thickness", "open_chains", "stitched_gaps")
_FIELDS = (
    "slice_z", "print_z", "thickness", "layer_offsets", "part_offsets",
    "ring_offsets", "coords", "open_coords", "open_ring_offsets",
    "open_layer_offsets", "open_chains", "stitched_gaps",
)


def _freeze_copy(new: NDArray[np.int64], old: object) -> NDArray[np.int64]:
    """``new`` made read-only; copied if it is the caller's own writeable array.

    Read-only arrays that own their data (such as a LayerParts' arrays) are shared.
    """
    shared = new is old and (new.flags.writeable or not new.flags.owndata)
    out = new.copy() if shared else new
    out.flags.writeable = False
    return out


@dataclass(frozen=True, slots=True, eq=False)
class SlicedModel:
    """Layers of parts of rings, in flat int64 arrays with nested offsets.

    Parameters
    ----------
    slice_z, print_z, thickness : array_like of shape (L,), int
        Height of each cut in the mesh's frame, top of each printed layer above
        the bed, and layer thickness, in µm.
    layer_offsets : array_like of shape (L + 1,), int
        Layer ``k`` holds parts ``layer_offsets[k]:layer_offsets[k + 1]``.
    part_offsets : array_like of shape (P + 1,), int
        Part ``q`` holds rings ``part_offsets[q]:part_offsets[q + 1]``; the first
        is its outline (CCW, positive area), the others its holes (CW).
    ring_offsets : array_like of shape (R + 1,), int
        Ring ``r`` is ``coords[ring_offsets[r]:ring_offsets[r + 1]]`` (not closed).
    coords : array_like of shape (N, 2), int
        All vertices in µm.
    open_coords, open_ring_offsets, open_layer_offsets : array_like, optional
        Open polylines (from broken meshes): the same two-level layout as
        :class:`vecslice.LayerPaths`. Default: none.
    open_chains, stitched_gaps : array_like of shape (L,), int, optional
        Per layer: chains left open, and gaps closed by stitching. Default zeros.

    Raises
    ------
    LayoutError
        If an offsets array is invalid, a part has no ring, or the per-layer
        arrays disagree on ``L``.

    Examples
    --------
    >>> sq = [[0, 0], [10, 0], [10, 10], [0, 10]]
    >>> m = SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4], sq)
    >>> m.n_layers, m.n_parts, m.layer_areas().tolist()
    (1, 1, [100.0])
    >>> outline, holes = m.layer(0)[0]
    >>> outline[2].tolist(), holes
    ([10, 10], [])

    In plain Python, ring ``r`` of part ``j`` of layer ``k`` is::

        q = layer_offsets[k] + j                  # global part index
        i = part_offsets[q] + r                   # global ring index (r = 0: outline)
        coords[ring_offsets[i]:ring_offsets[i + 1]]
    """

    slice_z: NDArray[np.int64]
    print_z: NDArray[np.int64]
    thickness: NDArray[np.int64]
    layer_offsets: NDArray[np.int64]
    part_offsets: NDArray[np.int64]
    ring_offsets: NDArray[np.int64]
    coords: NDArray[np.int64]
    open_coords: NDArray[np.int64]
    open_ring_offsets: NDArray[np.int64]
    open_layer_offsets: NDArray[np.int64]
    open_chains: NDArray[np.int64]
    stitched_gaps: NDArray[np.int64]

    def __init__(
        self,
        slice_z: ArrayLike,
        print_z: ArrayLike,
        thickness: ArrayLike,
        layer_offsets: ArrayLike,
        part_offsets: ArrayLike,
        ring_offsets: ArrayLike,
        coords: ArrayLike,
        *,
        open_coords: ArrayLike | None = None,
        open_ring_offsets: ArrayLike | None = None,
        open_layer_offsets: ArrayLike | None = None,
        open_chains: ArrayLike | None = None,
        stitched_gaps: ArrayLike | None = None,
    ) -> None:
        z = as_int_array(slice_z, "slice_z", ndim=1)
        n = z.shape[0]
        zeros = np.zeros(n, dtype=np.int64)
        if open_coords is None and open_ring_offsets is None:
            open_coords, open_ring_offsets = np.empty((0, 2), np.int64), [0]
            open_layer_offsets = np.zeros(n + 1, dtype=np.int64)
        given = {
            "slice_z": slice_z, "print_z": print_z, "thickness": thickness,
            "layer_offsets": layer_offsets, "part_offsets": part_offsets,
            "ring_offsets": ring_offsets, "coords": coords,
            "open_coords": open_coords, "open_ring_offsets": open_ring_offsets,
            "open_layer_offsets": open_layer_offsets,
            "open_chains": zeros if open_chains is None else open_chains,
            "stitched_gaps": zeros if stitched_gaps is None else stitched_gaps,
        }
        v = {"slice_z": z}
        for name in _PER_LAYER[1:]:
            v[name] = as_int_array(given[name], name, ndim=1)
            if v[name].shape[0] != n:
                raise LayoutError(
                    f"`{name}` must have length {n} (one per layer, as `slice_z`); "
                    f"got {v[name].shape[0]}"
                )
        for prefix in ("", "open_"):
            c = as_coords(given[prefix + "coords"], prefix + "coords")
            r = as_offsets(given[prefix + "ring_offsets"], c.shape[0],
                           prefix + "ring_offsets")
            below = r.shape[0] - 1
            if not prefix:
                p = as_offsets(part_offsets, below, "part_offsets")
                empty = np.flatnonzero(np.diff(p) == 0)
                if empty.size:
                    raise LayoutError(
                        f"`part_offsets` must give every part >= 1 ring (its "
                        f"outline); part {int(empty[0])} is empty"
                    )
                v["part_offsets"], below = p, p.shape[0] - 1
            lo = as_offsets(given[prefix + "layer_offsets"], below,
                            prefix + "layer_offsets")
            if lo.shape[0] != n + 1:
                raise LayoutError(
                    f"`{prefix}layer_offsets` must have length {n + 1} (layers + 1, "
                    f"as `slice_z`); got {lo.shape[0]}"
                )
            v[prefix + "coords"], v[prefix + "ring_offsets"] = c, r
            v[prefix + "layer_offsets"] = lo
        for name in _FIELDS:
            object.__setattr__(self, name, _freeze_copy(v[name], given[name]))

    @classmethod
    def from_parts(
        cls,
        parts: Any,
        *,
        slice_z: ArrayLike,
        print_z: ArrayLike,
        thickness: ArrayLike,
        open: LayerPaths | None = None,
        open_chains: ArrayLike | None = None,
        stitched_gaps: ArrayLike | None = None,
    ) -> SlicedModel:
        """Build from :func:`vecslice.make_parts` output and the layer schedule.

        Parameters
        ----------
        parts : LayerParts
            Layers of parts (anything with ``coords``, ``ring_offsets``,
            ``part_offsets`` and ``layer_offsets``).
        slice_z, print_z, thickness : array_like of shape (L,), int
            The layer schedule in µm (see :func:`vecslice.layer_heights`).
        open : LayerPaths, optional
            Open polylines per layer. ``open_chains`` defaults to their count.
        open_chains, stitched_gaps : array_like of shape (L,), int, optional
            Broken-mesh report per layer; default: the open count and zeros.

        Returns
        -------
        SlicedModel
        """
        kw: dict[str, Any] = {"open_chains": open_chains,
                              "stitched_gaps": stitched_gaps}
        if open is not None:
            kw.update(open_coords=open.coords, open_ring_offsets=open.ring_offsets,
                      open_layer_offsets=open.layer_offsets)
            if open_chains is None:
                kw["open_chains"] = open.rings_per_layer()
        return cls(slice_z, print_z, thickness, parts.layer_offsets,
                   parts.part_offsets, parts.ring_offsets, parts.coords, **kw)

    @property
    def n_layers(self) -> int:
        """Number of layers ``L``."""
        return int(self.slice_z.shape[0])

    @property
    def n_parts(self) -> int:
        """Number of parts ``P`` over all layers."""
        return int(self.part_offsets.shape[0] - 1)

    @property
    def n_rings(self) -> int:
        """Number of rings ``R`` (outlines and holes) over all layers."""
        return int(self.ring_offsets.shape[0] - 1)

    @property
    def open(self) -> LayerPaths:
        """The open polylines as a :class:`vecslice.LayerPaths` (views, no copy)."""
        return LayerPaths._trusted(self.open_coords, self.open_ring_offsets,
                                   self.open_layer_offsets)

    def _layer_index(self, i: int, name: str = "i") -> int:
        n = self.n_layers
        if not isinstance(i, (int, np.integer)) or not -n <= i < n:
            raise InputValueError(f"`{name}` must be a layer index in [-{n}, {n}); "
                                  f"got {i!r}")
        return int(i) % n

    def _part_rings(self, q: int) -> tuple[NDArray[np.int64], list[NDArray[np.int64]]]:
        ro, c = self.ring_offsets, self.coords
        r0, r1 = int(self.part_offsets[q]), int(self.part_offsets[q + 1])
        return c[ro[r0] : ro[r0 + 1]], [c[ro[r] : ro[r + 1]] for r in range(r0 + 1, r1)]

    def layer(self, i: int) -> list[tuple[NDArray[np.int64], list[NDArray[np.int64]]]]:
        """Parts of layer ``i`` as ``[(outline (n, 2), [holes]), ...]`` views."""
        i = self._layer_index(i)
        q0, q1 = int(self.layer_offsets[i]), int(self.layer_offsets[i + 1])
        return [self._part_rings(q) for q in range(q0, q1)]

    def part(self, i: int, j: int) -> tuple[NDArray[np.int64], list[NDArray[np.int64]]]:
        """Part ``j`` of layer ``i`` as ``(outline (n, 2), [holes])`` views."""
        i = self._layer_index(i)
        q0, q1 = int(self.layer_offsets[i]), int(self.layer_offsets[i + 1])
        if not isinstance(j, (int, np.integer)) or not -(q1 - q0) <= j < q1 - q0:
            raise InputValueError(f"`j` must be a part index of layer {i} in "
                                  f"[{-(q1 - q0)}, {q1 - q0}); got {j!r}")
        return self._part_rings(q0 + int(j) % (q1 - q0))

    def ring_layer(self) -> NDArray[np.int64]:
        """Layer index of each ring, shape (R,)."""
        part_layer = np.repeat(np.arange(self.n_layers, dtype=np.int64),
                               np.diff(self.layer_offsets))
        return np.repeat(part_layer, np.diff(self.part_offsets))

    def layer_areas(self) -> NDArray[np.float64]:
        """Area of each layer in µm², holes subtracted, shape (L,), float64."""
        a2 = ring_area2(self.coords, self.ring_offsets)
        out = np.bincount(self.ring_layer(), weights=a2, minlength=self.n_layers)
        return out / 2.0

    def bounds(self) -> NDArray[np.int64] | None:
        """``[[xmin, ymin], [xmax, ymax]]`` in µm of all rings and open polylines.

        ``None`` for a model without any vertex.
        """
        c = np.concatenate([self.coords, self.open_coords])
        if c.shape[0] == 0:
            return None
        return np.stack([c.min(axis=0), c.max(axis=0)])

    @property
    def nbytes(self) -> int:
        """Bytes held by all arrays (coords, every offsets, per-layer values)."""
        return int(sum(getattr(self, name).nbytes for name in _FIELDS))

    def to_shapely(self, i: int) -> Any:
        """Layer ``i`` as a shapely MultiPolygon in millimetres (needs shapely)."""
        from vecslice.parts import to_shapely

        return to_shapely(self, self._layer_index(i))

    def to_svg(self, i: int, **options: Any) -> str:
        """Layer ``i`` as SVG text, µm user units, mm size (see :mod:`vecslice.svg`)."""
        from vecslice.svg import layer_svg

        return layer_svg(self, i, **options)

    def save(self, path: str | os.PathLike[str], *, compress: bool = False) -> None:
        """Write the model to ``path`` as an .npz archive (bit-exact).

        The file is written to a temporary file beside ``path`` and renamed into
        place, so a failed save leaves no partial file. ``path`` is used as given
        (no ``.npz`` is appended). ``compress=True`` uses zip deflate.

        Raises
        ------
        StorageFileError
            If the file cannot be written (e.g. its directory does not exist).
        """
        target = Path(os.fspath(path))
        arrays = {name: getattr(self, name) for name in _FIELDS}
        writer = np.savez_compressed if compress else np.savez
        tmp = None
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp",
                                       dir=target.parent)
            with os.fdopen(fd, "wb") as fh:
                writer(fh, format=np.array(FORMAT), version=np.array(FORMAT_VERSION),
                       **arrays)
            os.replace(tmp, target)
            tmp = None
        except OSError as exc:
            raise StorageFileError(
                f"cannot save a vecslice model to {os.fspath(path)!r}: "
                f"{exc.strerror or exc}"
            ) from exc
        finally:
            if tmp is not None and os.path.exists(tmp):
                os.unlink(tmp)

    def __repr__(self) -> str:
        return (
            f"SlicedModel({self.n_layers} layers, {self.n_parts} parts, "
            f"{self.n_rings} rings, {self.coords.shape[0]} vertices, "
            f"{self.open_ring_offsets.shape[0] - 1} open polylines, "
            f"{self.nbytes / 1e6:.1f} MB)"
        )


def load_sliced(path: str | os.PathLike[str]) -> SlicedModel:
    """Read a model written by :meth:`SlicedModel.save` (bit-exact).

    Parameters
    ----------
    path : str or os.PathLike
        The .npz file.

    Returns
    -------
    SlicedModel

    Raises
    ------
    StorageFileError
        If ``path`` is missing, a directory, not an .npz archive, not a vecslice
        model, of a newer format version, or holds arrays of the wrong dtype or
        layout. The message names the path.

    Examples
    --------
    >>> import os, tempfile
    >>> m = SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 3],
    ...                 [[0, 0], [10, 0], [0, 10]])
    >>> with tempfile.TemporaryDirectory() as d:
    ...     m.save(os.path.join(d, "m.npz"))
    ...     load_sliced(os.path.join(d, "m.npz")).layer_areas().tolist()
    [50.0]
    """
    p = os.fspath(path)
    if not os.path.exists(p):
        raise StorageFileError(f"{p!r} does not exist")
    if os.path.isdir(p):
        raise StorageFileError(f"{p!r} is a directory, not a saved vecslice model")
    try:
        data = np.load(p, allow_pickle=False)
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise StorageFileError(
            f"{p!r} is not an .npz file written by SlicedModel.save() ({exc})"
        ) from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise StorageFileError(
            f"{p!r} is a single .npy array, not an .npz written by SlicedModel.save()"
        )
    with data:
        arrays = _read_arrays(p, data)
    for a in arrays.values():  # fresh arrays: the model can own them without a copy
        a.flags.writeable = False
    try:
        return SlicedModel(*(arrays[k] for k in _FIELDS[:7]),
                           **{k: arrays[k] for k in _FIELDS[7:]})
    except (InputValueError, TypeError) as exc:
        raise StorageFileError(f"{p!r} holds an invalid vecslice model: {exc}") from exc


def _read_arrays(p: str, data: Any) -> dict[str, NDArray[Any]]:
    """Check the format marker and version, then read every field as int64."""
    try:
        marker = str(data["format"][()]) if "format" in data.files else None
        if marker != FORMAT:
            raise StorageFileError(
                f"{p!r} is not a saved vecslice model (format marker {marker!r}; "
                f"expected {FORMAT!r})"
            )
        version = int(data["version"][()]) if "version" in data.files else -1
        if not 1 <= version <= FORMAT_VERSION:
            raise StorageFileError(
                f"{p!r} has vecslice format version {version}; this vecslice reads "
                f"versions 1 to {FORMAT_VERSION}"
            )
        missing = [k for k in _FIELDS if k not in data.files]
        if missing:
            raise StorageFileError(f"{p!r} misses the array {missing[0]!r}")
        out = {k: data[k] for k in _FIELDS}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        if isinstance(exc, StorageFileError):
            raise
        raise StorageFileError(f"{p!r} is a damaged .npz archive ({exc})") from None
    for k, a in out.items():
        if a.dtype != np.int64:
            raise StorageFileError(
                f"{p!r}: array {k!r} must have dtype int64; got {a.dtype}"
            )
    return out

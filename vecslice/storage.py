"""``SlicedModel``: the sliced layers (CuraEngine's SliceDataStorage), saved as .npz.

Layout (GeoArrow/shapely MultiPolygon nesting): ``layer_offsets`` (L + 1) -> parts,
``part_offsets`` (P + 1) -> rings, ``ring_offsets`` (R + 1) -> ``coords`` (N, 2).
Open polylines of broken meshes are kept beside them with their own offsets.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice._validate import check_bool, check_int, check_offsets
from vecslice.errors import (
    InputTypeError,
    InputValueError,
    LayoutError,
    StorageFileError,
)
from vecslice.interrupt import keyboard_interrupts
from vecslice.layerparts import Part, PartsLayout, check_part_rings
from vecslice.npz import (
    MAX_BYTES,
    Member,
    check_path,
    open_archive,
    read_array,
    read_members,
    write_atomic,
)
from vecslice.paths import LayerPaths
from vecslice.ragged import freeze, nested_offsets, private_int_array
from vecslice.units import COORD_LIMIT

__all__ = ["FORMAT", "FORMAT_VERSION", "SlicedModel", "load_sliced"]

FORMAT = "vecslice.SlicedModel"
FORMAT_VERSION = 1

_MAX_COUNT = 2**31  # per layer: sums over 2**32 layers still fit int64
_PER_LAYER = ("slice_z", "print_z", "thickness", "open_chains", "stitched_gaps")
_FIELDS = (
    "slice_z", "print_z", "thickness", "layer_offsets", "part_offsets",
    "ring_offsets", "coords", "open_coords", "open_ring_offsets",
    "open_layer_offsets", "open_chains", "stitched_gaps",
)


def _layer_offsets(
    given: dict[str, Any], prefix: str, below: NDArray[np.int64], n: int
) -> NDArray[np.int64]:
    """``given[prefix + 'layer_offsets']`` copied, then checked: ``n + 1`` long."""
    name = prefix + "layer_offsets"
    lo = private_int_array(given[name], name, ndim=1)
    check_offsets(lo, below.shape[0] - 1, name)
    if lo.shape[0] != n + 1:
        raise LayoutError(
            f"`{name}` must have length {n + 1} (layers + 1, as `slice_z`); "
            f"got {lo.shape[0]}"
        )
    return lo


def _check_schedule(
    slice_z: NDArray[np.int64], print_z: NDArray[np.int64],
    thickness: NDArray[np.int64],
) -> None:
    """The layer schedule's values: within the coordinate limit, layers stacked.

    Every schedule vecslice makes (SLICING.md §1, ADAPTIVE.md §5) has
    ``print_z[n] = print_z[n - 1] + thickness[n]`` with ``thickness > 0``: the
    tops strictly increase, no two layers share a height.
    """
    for name, a in (("slice_z", slice_z), ("print_z", print_z)):
        bad = np.flatnonzero((a >= COORD_LIMIT) | (a <= -COORD_LIMIT))
        if bad.size:
            i = int(bad[0])
            raise InputValueError(
                f"`{name}` must satisfy |value| < 2**30 µm (about 1 km); got "
                f"{int(a[i])} at layer {i}"
            )
    bad = np.flatnonzero((thickness <= 0) | (thickness >= COORD_LIMIT))
    if bad.size:
        i = int(bad[0])
        raise InputValueError(
            f"`thickness` must be > 0 and < 2**30 µm; got {int(thickness[i])} at "
            f"layer {i}"
        )
    bad = np.flatnonzero(np.diff(print_z) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise InputValueError(
            f"`print_z` must increase from layer to layer (each layer above the "
            f"one before); got {int(print_z[i])} at layer {i} after "
            f"{int(print_z[i - 1])} at layer {i - 1}"
        )


def _check_counts(
    open_chains: NDArray[np.int64], stitched_gaps: NDArray[np.int64]
) -> None:
    """The broken-mesh counts: per layer, 0 <= count < 2**31 (their sums fit int64)."""
    for name, a in (("open_chains", open_chains), ("stitched_gaps", stitched_gaps)):
        bad = np.flatnonzero((a < 0) | (a >= _MAX_COUNT))
        if bad.size:
            i = int(bad[0])
            raise InputValueError(
                f"`{name}` must be a count per layer, >= 0 and < 2**31; got "
                f"{int(a[i])} at layer {i}"
            )


@dataclass(frozen=True, slots=True, eq=False)
class SlicedModel(PartsLayout):
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
        If an offsets array is invalid, the per-layer arrays disagree on ``L``, a
        part has no ring, a ring fewer than 3 vertices, an outline is not CCW
        (positive area) or a hole not CW.
    InputValueError
        If a ``slice_z`` or ``print_z`` value reaches 2**30 µm in magnitude, a
        ``thickness`` is not in 1 .. 2**30 - 1 µm, ``print_z`` does not
        strictly increase (layers are stacked: no two share a height), an
        ``open_chains`` or ``stitched_gaps`` count is negative or reaches 2**31,
        or a ring's twice-area does not fit int64 (a ring that winds around more
        than once near the coordinate limit). The message names the field or
        ring, the layer and the value.

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
        # each array is coerced, copied (ragged.private_int_array) and then
        # checked: the checks see what is stored, not the caller's memory
        z = private_int_array(slice_z, "slice_z", ndim=1)
        n = z.shape[0]
        zeros = freeze(np.zeros(n, dtype=np.int64))  # defaults: ours, not copied
        if open_coords is None and open_ring_offsets is None:
            open_coords, open_ring_offsets = freeze(np.empty((0, 2), np.int64)), [0]
            open_layer_offsets = freeze(np.zeros(n + 1, dtype=np.int64))
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
            v[name] = private_int_array(given[name], name, ndim=1)
            if v[name].shape[0] != n:
                raise LayoutError(
                    f"`{name}` must have length {n} (one per layer, as `slice_z`); "
                    f"got {v[name].shape[0]}"
                )
        _check_schedule(v["slice_z"], v["print_z"], v["thickness"])
        _check_counts(v["open_chains"], v["stitched_gaps"])
        v["coords"], v["ring_offsets"], v["part_offsets"] = nested_offsets(
            coords, [("ring_offsets", ring_offsets), ("part_offsets", part_offsets)]
        )
        v["layer_offsets"] = _layer_offsets(given, "", v["part_offsets"], n)
        check_part_rings(v["coords"], v["ring_offsets"], v["part_offsets"],
                         v["layer_offsets"])
        v["open_coords"], v["open_ring_offsets"] = nested_offsets(
            given["open_coords"], [("open_ring_offsets", open_ring_offsets)],
            "open_coords")
        v["open_layer_offsets"] = _layer_offsets(given, "open_",
                                                 v["open_ring_offsets"], n)
        self._set_fields({name: v[name] for name in _FIELDS})

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
    def open(self) -> LayerPaths:
        """The open polylines as a :class:`vecslice.LayerPaths` (views, no copy)."""
        return LayerPaths._trusted(self.open_coords, self.open_ring_offsets,
                                   self.open_layer_offsets)

    def layer(self, i: int) -> list[Part]:
        """Parts of layer ``i`` as ``[(outline (n, 2), [holes]), ...]`` views."""
        return self._layer_parts(i, "i")

    def part(self, i: int, j: int) -> Part:
        """Part ``j`` of layer ``i`` as ``(outline (n, 2), [holes])`` views."""
        return self._part(i, j, ("i", "j"))

    def bounds(self) -> NDArray[np.int64] | None:
        """``[[xmin, ymin], [xmax, ymax]]`` in µm of all rings and open polylines.

        ``None`` for a model without any vertex.
        """
        c = np.concatenate([self.coords, self.open_coords])
        if c.shape[0] == 0:
            return None
        return np.stack([c.min(axis=0), c.max(axis=0)])

    def to_svg(self, i: int, **options: Any) -> str:
        """Layer ``i`` as SVG text, µm user units, mm size (see :mod:`vecslice.svg`)."""
        from vecslice.svg import layer_svg

        return layer_svg(self, i, **options)

    def save(self, path: str | os.PathLike[str], *, compress: bool = False) -> None:
        """Write the model to ``path`` as an .npz archive (bit-exact).

        The file is written to a hidden temporary file beside ``path`` and renamed
        into place, so a failed or interrupted save (error, Ctrl-C, SIGTERM) leaves
        no partial file. ``path`` is used as given (no ``.npz`` is appended); a
        symbolic link is written through (the file it points to is replaced). A
        new file gets the permissions ``0o666 & ~umask``; an overwritten file keeps
        its mode. Only a regular file is ever replaced: a FIFO, a device (such as
        ``/dev/null``) or a socket is refused, and so is a read-only file (no write
        permission for the caller, or none at all, so that even root does not
        replace it), as the shell's ``>`` would refuse it: make it writable or
        remove it first.

        Parameters
        ----------
        path : str or os.PathLike
            The file to write.
        compress : bool, default False
            Use zip deflate (smaller, slower).

        Raises
        ------
        InputTypeError
            If ``path`` is not a path or ``compress`` not a bool.
        InputValueError
            If ``path`` is empty.
        StorageFileError
            If the file cannot be written (e.g. its directory does not exist, it is
            a directory, a symbolic link loop, not a regular file or read-only).
        """
        compress = check_bool(compress, "compress")
        p = check_path(path)
        arrays = {name: getattr(self, name) for name in _FIELDS}

        def write(fh: Any) -> None:
            writer = np.savez_compressed if compress else np.savez
            writer(fh, format=np.array(FORMAT), version=np.array(FORMAT_VERSION),
                   **arrays)

        write_atomic(p, write)

    def __repr__(self) -> str:
        return (
            f"SlicedModel({self.n_layers} layers, {self.n_parts} parts, "
            f"{self.n_rings} rings, {self.coords.shape[0]} vertices, "
            f"{self.open_ring_offsets.shape[0] - 1} open polylines, "
            f"{self.nbytes / 1e6:.1f} MB)"
        )


def check_model(model: object, name: str = "model") -> None:
    """Refuse anything but a :class:`SlicedModel` (InputTypeError naming ``name``).

    A path gets a hint: a saved model is read with :func:`load_sliced`.
    """
    if not isinstance(model, SlicedModel):
        hint = (" (read a saved model with vs.load_sliced(path))"
                if isinstance(model, (str, os.PathLike)) else "")
        raise InputTypeError(f"`{name}` must be a vecslice.SlicedModel; got "
                             f"{type(model).__name__}{hint}")


@keyboard_interrupts
def load_sliced(
    path: str | os.PathLike[str], *, max_bytes: int = MAX_BYTES
) -> SlicedModel:
    """Read a model written by :meth:`SlicedModel.save` (bit-exact).

    Hostile files are refused before any array is inflated: the ``.npy`` header
    of every member is read first and its dtype, its shape against the others
    and the member's size are checked, as well as the compression ratio and the
    total size (``max_bytes``). The model is then validated like a constructed
    one, including ring sizes and orientations.

    Parameters
    ----------
    path : str or os.PathLike
        The .npz file.
    max_bytes : int, default 2**32 (``vecslice.npz.MAX_BYTES``, 4 GiB)
        Largest total size of the arrays; raise it for larger models.

    Returns
    -------
    SlicedModel

    Raises
    ------
    InputTypeError, InputValueError
        If ``path`` is not a path or empty, or ``max_bytes`` not an int >= 0.
    StorageFileError
        If ``path`` is missing, unreadable (permission denied), a directory, not
        a regular file (a FIFO or a device, refused at once, never read), not an
        .npz archive, not a vecslice model, of a newer format version, too large,
        damaged, or holds arrays of the wrong dtype, shape or layout (such as a
        clockwise outline, a ring of fewer than 3 vertices, a thickness <= 0,
        ``print_z`` not increasing or a negative ``open_chains`` count). The
        message names the path.

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
    p = check_path(path)
    max_bytes = check_int(max_bytes, "max_bytes", minimum=0, setting=False,
                          what="an integer number of bytes")
    with open_archive(p) as zf:
        members = read_members(p, zf, ("format", "version", *_FIELDS),
                               max_bytes=max_bytes)
        _check_marker(p, zf, members)
        _check_shapes(p, members)
        arrays = {k: freeze(read_array(p, zf, members[k])) for k in _FIELDS}
    try:  # fresh frozen arrays: the model holds them without a copy
        return SlicedModel(*(arrays[k] for k in _FIELDS[:7]),
                           **{k: arrays[k] for k in _FIELDS[7:]})
    except (InputValueError, InputTypeError) as exc:
        raise StorageFileError(f"{p!r} holds an invalid vecslice model: {exc}") from exc


def _check_marker(p: str, zf: Any, members: dict[str, Member]) -> None:
    """The format marker and version, read only if they are small scalars."""
    fmt = members.get("format")
    marker = None
    if fmt is not None and fmt.shape == () and fmt.dtype.kind == "U" and (
        fmt.nbytes <= 4 * 64
    ):
        marker = str(read_array(p, zf, fmt)[()])
    elif fmt is not None:
        marker = f"<array of dtype {fmt.dtype} and shape {fmt.shape}>"
    if marker != FORMAT:
        raise StorageFileError(
            f"{p!r} is not a saved vecslice model (format marker {marker!r}; "
            f"expected {FORMAT!r})"
        )
    ver = members.get("version")
    if ver is None:
        version: object = "missing"
    elif ver.shape != () or ver.dtype.kind not in "iu":
        raise StorageFileError(
            f"{p!r}: `version` must be one integer; got an array of dtype "
            f"{ver.dtype} and shape {ver.shape}"
        )
    else:
        version = int(read_array(p, zf, ver)[()])
    if not isinstance(version, int) or not 1 <= version <= FORMAT_VERSION:
        raise StorageFileError(
            f"{p!r} has vecslice format version {version}; this vecslice reads "
            f"versions 1 to {FORMAT_VERSION}"
        )
    missing = [k for k in _FIELDS if k not in members]
    if missing:
        raise StorageFileError(f"{p!r} misses the array {missing[0]!r}")


def _check_shapes(p: str, members: dict[str, Member]) -> None:
    """Dtypes and shapes from the headers, against each other, before reading."""
    for k in _FIELDS:
        m = members[k]
        if m.dtype != np.int64:
            raise StorageFileError(
                f"{p!r}: array {k!r} must have dtype int64; got {m.dtype}"
            )
        want = (2,) if k.endswith("coords") else (1,)
        if len(m.shape) != want[0] or (k.endswith("coords") and m.shape[1] != 2):
            expect = "(N, 2)" if k.endswith("coords") else "(N,)"
            raise StorageFileError(
                f"{p!r} holds an invalid vecslice model: `{k}` must have shape "
                f"{expect}; got shape {m.shape}"
            )
    n = members["slice_z"].shape[0]
    length = {k: members[k].shape[0] for k in _FIELDS}
    for k in _FIELDS:
        want_len = n + 1 if k.endswith("layer_offsets") else n
        if (k in _PER_LAYER or k.endswith("layer_offsets")) and length[k] != want_len:
            raise StorageFileError(
                f"{p!r} holds an invalid vecslice model: `{k}` must have length "
                f"{want_len} (as `slice_z`); got {length[k]}"
            )
    checks = (
        ("part_offsets", "ring_offsets", 1, "every part has >= 1 ring"),
        ("ring_offsets", "coords", 3, "every ring has >= 3 vertices"),
    )
    for upper, lower, k, why in checks:
        n_upper = length[upper] - 1
        n_lower = length[lower] - (0 if lower == "coords" else 1)
        if n_upper < 0 or k * n_upper > n_lower:
            raise StorageFileError(
                f"{p!r} holds an invalid vecslice model: `{upper}` has "
                f"{length[upper]} entries, too many for {n_lower} "
                f"{'vertices' if lower == 'coords' else 'rings'} ({why})"
            )

"""The layer viewer: one self-contained HTML file to browse a sliced model's layers.

The page needs no server and no network: the layers are embedded in it, and a
small script draws them on a canvas. The data are exact int64 µm values written
compactly: every offsets array as counts, the coordinates as differences from the
previous vertex (interleaved x, y), each number as a zigzag LEB128 varint (most
differences take one or two bytes), all zlib-compressed and base64-encoded. The
browser inflates them with its built-in ``DecompressionStream``.
"""

from __future__ import annotations

import base64
import html
import json
import os
import re
import zlib
from importlib import resources
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["varint_encode", "viewer_html", "write_viewer"]

_LIMIT = 2**52  # varints are decoded into JavaScript doubles: stay exact
_PLACEHOLDER = re.compile(r"\{\{(TITLE|META|DATA)\}\}")  # in viewer.html
# JSON escapes of the characters that may change how HTML reads a <script> element
_JSON_IN_HTML = str.maketrans({"<": "\\u003c", ">": "\\u003e", "&": "\\u0026"})


def varint_encode(values: NDArray[np.int64]) -> bytes:
    """Zigzag LEB128 varints of int64 values (|v| < 2**52), vectorised.

    Parameters
    ----------
    values : ndarray of int64
        Any shape; encoded in C order.

    Returns
    -------
    bytes
        Seven bits per byte, low bits first, high bit set on every byte but a
        value's last; a value ``v`` is first mapped to ``2v`` (``v >= 0``) or
        ``-2v - 1`` (``v < 0``).

    Raises
    ------
    InputValueError
        If a magnitude reaches 2**52.

    Examples
    --------
    >>> varint_encode(np.array([0, -1, 1, 63, -64, 64, 300])).hex()
    '0001027e7f8001d804'
    """
    from vecslice.errors import InputValueError

    v = np.ascontiguousarray(values, dtype=np.int64).ravel()
    if v.size and int(np.abs(v).max()) >= _LIMIT:
        raise InputValueError(f"`values` must be below 2**52 in magnitude; got "
                              f"{int(v[np.argmax(np.abs(v))])}")
    u = ((v << 1) ^ (v >> 63)).astype(np.uint64)
    size = np.ones(u.shape, dtype=np.int64)
    for k in range(1, 8):
        size += u >= np.uint64(1 << (7 * k))
    end = np.cumsum(size)
    start = end - size
    out = np.empty(int(end[-1]) if v.size else 0, dtype=np.uint8)
    for k in range(8):
        m = size > k
        if not m.any():
            break
        byte = (u[m] >> np.uint64(7 * k)) & np.uint64(0x7F)
        more = (size[m] - 1 > k).astype(np.uint64) << np.uint64(7)
        out[start[m] + k] = (byte | more).astype(np.uint8)
    return out.tobytes()


def _deltas(coords: NDArray[np.int64]) -> NDArray[np.int64]:
    """Interleaved (dx, dy) from the previous vertex (the first from (0, 0))."""
    return np.diff(coords, axis=0, prepend=np.zeros((1, 2), np.int64)).ravel()


def _sections(model: Any) -> list[tuple[str, NDArray[np.int64]]]:
    return [
        ("slice_z", model.slice_z),
        ("print_z", model.print_z),
        ("parts", np.diff(model.layer_offsets)),
        ("rings", np.diff(model.part_offsets)),
        ("vertices", np.diff(model.ring_offsets)),
        ("coords", _deltas(model.coords)),
        ("open_chains", np.diff(model.open_layer_offsets)),
        ("open_vertices", np.diff(model.open_ring_offsets)),
        ("open_coords", _deltas(model.open_coords)),
    ]


def viewer_html(model: Any, *, title: str = "vecslice") -> str:
    """The layer viewer of ``model`` as one self-contained HTML document.

    The page shows one layer at a time: parts filled, holes open, open chains of
    broken meshes in orange; a slider and the keyboard (arrows, PgUp/PgDn,
    Home/End) step through the layers; the wheel zooms and dragging pans; a readout
    gives the layer's z, parts, holes, vertices and area. ``#layer=N`` in the
    address selects layer N; without it the page opens at the middle layer.

    Parameters
    ----------
    model : SlicedModel
        The sliced model.
    title : str, default 'vecslice'
        Shown in the page's header and window title (HTML-escaped).

    Returns
    -------
    str
        The HTML text (UTF-8). It needs a browser with ``DecompressionStream``
        (Chrome 80, Firefox 113, Safari 16.4 or newer) and nothing else.

    Raises
    ------
    InputTypeError
        If ``model`` is not a :class:`vecslice.SlicedModel` or ``title`` not a str.

    Examples
    --------
    >>> from vecslice import SlicedModel
    >>> sq = SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4],
    ...                  [[0, 0], [10, 0], [10, 10], [0, 10]])
    >>> page = viewer_html(sq, title="square")
    >>> page.startswith("<!doctype html>"), "<title>square" in page
    (True, True)
    """
    from vecslice.errors import InputTypeError
    from vecslice.storage import check_model

    check_model(model)
    if not isinstance(title, str):
        raise InputTypeError(f"`title` must be a str; got {type(title).__name__}")
    sections = _sections(model)
    blob = b"".join(varint_encode(a) for _, a in sections)
    box = model.bounds()
    meta = {
        "title": title,
        "n_layers": model.n_layers,
        "n_parts": model.n_parts,
        "n_vertices": int(model.coords.shape[0]),
        "bounds": [0, 0, 0, 0] if box is None else box.ravel().tolist(),
        "areas_mm2": [round(a, 6) for a in (model.layer_areas() / 1e6).tolist()],
        "sections": [[name, int(a.size)] for name, a in sections],
    }
    data = base64.b64encode(zlib.compress(blob, 9)).decode("ascii")
    template = resources.files("vecslice").joinpath("viewer.html").read_text("utf-8")
    # no "<", ">" or "&" inside the JSON's <script> element: "</script" would end
    # it, and "<!--<script" would keep the page's own "</script>" from ending it
    # (HTML's "script data double escaped" state); the escapes are valid JSON
    meta_text = json.dumps(meta, separators=(",", ":")).translate(_JSON_IN_HTML)
    values = {"TITLE": html.escape(title), "META": meta_text, "DATA": data}
    # one pass over the template: a title holding "{{META}}" stays text
    return _PLACEHOLDER.sub(lambda m: values[m.group(1)], template)


def write_viewer(
    model: Any, path: str | os.PathLike[str], *, title: str = "vecslice"
) -> None:
    """Write :func:`viewer_html` of ``model`` to ``path`` (UTF-8), all or nothing.

    The page goes to a temporary file beside ``path`` that is renamed into place,
    so an error or Ctrl-C leaves no partial file.

    Parameters
    ----------
    model : SlicedModel
        The sliced model.
    path : str or os.PathLike
        The .html file to write (replaced if it exists; a FIFO, a device or a
        read-only file is refused, see :func:`vecslice.npz.write_atomic`).
    title : str, default 'vecslice'
        The page's title.

    Raises
    ------
    StorageFileError
        If the file cannot be written, is not a regular file or is read-only.
    """
    from vecslice.npz import check_path, write_atomic

    data = viewer_html(model, title=title).encode("utf-8")
    write_atomic(check_path(path), lambda fh: fh.write(data),
                 what="a layer viewer page")

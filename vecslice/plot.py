"""Drawings of a sliced model with matplotlib (the optional ``plot`` extra).

``pip install "vecslice[plot]"`` installs matplotlib. Axes are in millimetres.
Nothing here touches pyplot's global state unless you pass it pyplot axes: without
``ax`` every function makes its own :class:`matplotlib.figure.Figure` (no GUI
backend is needed, so this works on servers and in tests).

* :func:`layer` — one layer: parts filled, holes open, open chains in orange;
  optionally the raw (unsimplified) contour drawn over it.
* :func:`stack` — several layers, each shifted by an offset, bottom first.
* :func:`stats` — area and vertex count of every layer against z.
* :func:`save_layer` — :func:`layer` written to a PNG (or any matplotlib format).

For an SVG without matplotlib use :meth:`vecslice.SlicedModel.to_svg`.
"""

from __future__ import annotations

import os
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from vecslice.storage import check_model
from vecslice.svg import SVG_STYLE, layer_index

__all__ = ["layer", "layer_vertex_counts", "save_layer", "stack", "stats"]

_RAW_COLOUR = "#d6336c"


def _matplotlib() -> Any:
    """Import matplotlib, or say which extra installs it."""
    try:
        import matplotlib
        from matplotlib.figure import Figure  # noqa: F401  (fails early if broken)
    except ImportError as exc:
        from vecslice.errors import MissingDependencyError

        raise MissingDependencyError(
            "vecslice.plot needs matplotlib, which is not installed: "
            "pip install 'vecslice[plot]'"
        ) from exc
    return matplotlib


def _new_axes(ax: Any, figsize: tuple[float, float] = (6.4, 4.8)) -> Any:
    if ax is not None:
        return ax
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained").add_subplot()


def _rings_path(coords: NDArray[np.int64], ring_offsets: NDArray[np.int64],
                shift: tuple[float, float] = (0.0, 0.0)) -> Any:
    """One compound matplotlib Path (mm) of closed rings; ``None`` if empty."""
    from matplotlib.path import Path

    lens = np.diff(ring_offsets)
    lens = lens[lens > 0]
    if lens.size == 0:
        return None
    start = int(ring_offsets[0])
    pts = coords[start : start + int(lens.sum())] / 1000.0 + np.asarray(shift)
    # one extra (closing) vertex per ring
    ends = np.cumsum(lens + 1)
    verts = np.empty((int(ends[-1]), 2))
    codes = np.full(int(ends[-1]), Path.LINETO, dtype=Path.code_type)
    first = ends - lens - 1
    keep = np.ones(verts.shape[0], dtype=bool)
    keep[ends - 1] = False
    verts[keep] = pts
    verts[ends - 1] = verts[first]
    codes[first] = Path.MOVETO
    codes[ends - 1] = Path.CLOSEPOLY
    return Path(verts, codes)


def _layer_rings(model: Any, k: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``coords`` and the ring offsets (into them) of the rings of layer ``k``."""
    p0, p1 = model.layer_offsets[k], model.layer_offsets[k + 1]
    r0, r1 = model.part_offsets[p0], model.part_offsets[p1]
    return model.coords, model.ring_offsets[r0 : r1 + 1]


def _draw_layer(ax: Any, model: Any, k: int, shift: tuple[float, float],
                fill: str, alpha: float) -> None:
    from matplotlib.collections import LineCollection
    from matplotlib.patches import PathPatch

    path = _rings_path(*_layer_rings(model, k), shift)
    if path is not None:
        ax.add_patch(PathPatch(path, facecolor=fill, edgecolor=SVG_STYLE["stroke"],
                               linewidth=0.6, alpha=alpha))
    chains = [c / 1000.0 + np.asarray(shift) for c in model.open.layer(k) if len(c)]
    if chains:
        ax.add_collection(LineCollection(chains, colors=SVG_STYLE["open"],
                                         linewidths=1.5, label="open chains"))


def _figsize(model: Any) -> tuple[float, float]:
    """6.4 inches wide, as tall as the model's aspect needs (3 to 9 inches)."""
    box = model.bounds()
    if box is None:
        return (6.4, 4.8)
    w, h = (box[1] - box[0] + 2000).tolist()
    return (6.4, float(np.clip(5.4 * h / w + 1.0, 3.0, 9.0)))


def _frame(ax: Any, model: Any, pad_mm: float = 1.0) -> None:
    box = model.bounds()
    if box is not None:
        (x0, y0), (x1, y1) = box / 1000.0
        ax.set_xlim(x0 - pad_mm, x1 + pad_mm)
        ax.set_ylim(y0 - pad_mm, y1 + pad_mm)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")


def layer(model: Any, i: int, *, ax: Any = None, raw: Any = None,
          fill: str = SVG_STYLE["fill"]) -> Any:
    """Draw layer ``i``: parts filled, holes open, open chains in orange.

    Parameters
    ----------
    model : SlicedModel
        The sliced model.
    i : int
        Layer index (negative counts from the top).
    ax : matplotlib Axes, optional
        Where to draw; default a new Figure's axes.
    raw : LayerPaths, optional
        Raw loops at the same layers (``vs.slice_contours(mesh, model.slice_z)``),
        drawn as thin lines over the filled, simplified layer.
    fill : str, default '#7fb2e5'
        Fill colour of the parts.

    Returns
    -------
    matplotlib Axes
        In mm, equal aspect, framed on the whole model's bounding box.

    Raises
    ------
    MissingDependencyError
        If matplotlib is not installed.
    InputTypeError
        If ``model`` is not a SlicedModel.
    InputValueError
        If ``i`` is not a layer index, or ``raw`` has another number of layers.

    Examples
    --------
    >>> from vecslice import SlicedModel
    >>> sq = SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4],
    ...                  [[0, 0], [10000, 0], [10000, 10000], [0, 10000]])
    >>> ax = layer(sq, 0)
    >>> ax.get_xlabel(), len(ax.patches)
    ('x (mm)', 1)
    """
    _matplotlib()
    check_model(model)
    k = layer_index(model, i)
    ax = _new_axes(ax, _figsize(model))
    _draw_layer(ax, model, k, (0.0, 0.0), fill, 1.0)
    if raw is not None:
        from matplotlib.patches import PathPatch

        from vecslice.errors import InputValueError

        if getattr(raw, "n_layers", None) != model.n_layers:
            raise InputValueError(
                f"`raw` must have the model's {model.n_layers} layers (slice it at "
                f"model.slice_z); got {getattr(raw, 'n_layers', type(raw).__name__)}"
            )
        r0, r1 = raw.layer_offsets[k], raw.layer_offsets[k + 1]
        path = _rings_path(raw.coords, raw.ring_offsets[r0 : r1 + 1])
        if path is not None:
            ax.add_patch(PathPatch(path, fill=False, edgecolor=_RAW_COLOUR,
                                   linewidth=0.6, linestyle="--", label="raw"))
    _frame(ax, model)
    ax.set_title(f"layer {k}, z {model.print_z[k] / 1000:g} mm")
    return ax


def stack(model: Any, layers: Any = None, *, offset: tuple[float, float] | None = None,
          ax: Any = None) -> Any:
    """Draw several layers, each shifted by ``offset`` from the one below.

    Parameters
    ----------
    model : SlicedModel
        The sliced model.
    layers : sequence of int, optional
        Layer indices, drawn in the given order (later ones on top). Default: up to
        eight layers evenly spaced from bottom to top.
    offset : (float, float), optional
        Shift in mm from one drawn layer to the next; default a quarter of the
        model's width and height, so the layers read as an oblique stack.
    ax : matplotlib Axes, optional
        Where to draw; default a new Figure's axes.

    Returns
    -------
    matplotlib Axes

    Raises
    ------
    MissingDependencyError
        If matplotlib is not installed.
    InputTypeError
        If ``model`` is not a SlicedModel.
    InputValueError
        If an index is not a layer index.
    """
    _matplotlib()
    check_model(model)
    n = model.n_layers
    if layers is None:
        layers = np.unique(np.linspace(0, n - 1, min(n, 8)).round().astype(int))
    ks = [layer_index(model, int(i) if isinstance(i, np.integer) else i,
                      f"layers[{j}]") for j, i in enumerate(layers)]
    box = model.bounds()
    size = (box[1] - box[0]) / 1000.0 if box is not None else np.zeros(2)
    if offset is None:
        offset = (0.25 * float(size[0]), 0.25 * float(size[1]))
    dx, dy = (float(v) for v in offset)
    ax = _new_axes(ax)
    for j, k in enumerate(ks):
        shift = (j * dx, j * dy)
        _draw_layer(ax, model, k, shift, SVG_STYLE["fill"], 0.9)
        if box is not None:
            ax.annotate(f"{model.print_z[k] / 1000:g} mm",
                        (box[1, 0] / 1000.0 + shift[0], box[0, 1] / 1000.0 + shift[1]),
                        fontsize=7, color="#555")
    if box is not None and ks:
        (x0, y0), (x1, y1) = box / 1000.0
        span = (len(ks) - 1) * np.array([dx, dy])
        ax.set_xlim(x0 + min(0, span[0]) - 1, x1 + max(0, span[0]) + 1)
        ax.set_ylim(y0 + min(0, span[1]) - 1, y1 + max(0, span[1]) + 1)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm), shifted per layer")
    ax.set_ylabel("y (mm), shifted per layer")
    return ax


def layer_vertex_counts(model: Any) -> NDArray[np.int64]:
    """Stored vertices of each layer (outlines and holes), shape (L,).

    Examples
    --------
    >>> from vecslice import SlicedModel
    >>> sq = SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4],
    ...                  [[0, 0], [10, 0], [10, 10], [0, 10]])
    >>> layer_vertex_counts(sq).tolist()
    [4]
    """
    per_ring = np.diff(model.ring_offsets)
    return np.bincount(model.ring_layer(), weights=per_ring,
                       minlength=model.n_layers).astype(np.int64)


def stats(model: Any, *, axes: Any = None) -> Any:
    """Area (mm²) and vertex count of every layer against z (mm).

    Parameters
    ----------
    model : SlicedModel
        The sliced model.
    axes : pair of matplotlib Axes, optional
        Where to draw area and vertices; default two new stacked axes.

    Returns
    -------
    tuple of two matplotlib Axes
        ``(area_axes, vertex_axes)``, sharing the z axis (print height, mm).

    Raises
    ------
    MissingDependencyError
        If matplotlib is not installed.
    InputTypeError
        If ``model`` is not a SlicedModel.
    """
    _matplotlib()
    check_model(model)
    if axes is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(6.4, 5.2), layout="constrained")
        top = fig.add_subplot(2, 1, 1)
        axes = (top, fig.add_subplot(2, 1, 2, sharex=top))
    ax_area, ax_vert = axes
    z = model.print_z / 1000.0
    ax_area.plot(z, model.layer_areas() / 1e6, color=SVG_STYLE["stroke"])
    ax_area.set_ylabel("area (mm²)")
    ax_vert.plot(z, layer_vertex_counts(model), color=SVG_STYLE["open"])
    ax_vert.set_ylabel("vertices")
    ax_vert.set_xlabel("z (mm)")
    return ax_area, ax_vert


def save_layer(model: Any, i: int, path: str | os.PathLike[str] | IO[bytes], *,
               raw: Any = None, dpi: int = 150, format: str | None = None) -> None:
    """Draw layer ``i`` with :func:`layer` and save the figure (format by suffix).

    Parameters
    ----------
    model : SlicedModel
        The sliced model.
    i : int
        Layer index.
    path : str, os.PathLike or binary file
        Output file, e.g. ``layer.png`` (with a file object, give ``format``).
    raw : LayerPaths, optional
        Raw loops drawn over the layer (see :func:`layer`).
    dpi : int, default 150
        Resolution of raster formats.
    format : str, optional
        ``'png'``, ``'svg'``, ``'pdf'``...; default from the suffix of ``path``.

    Raises
    ------
    MissingDependencyError
        If matplotlib is not installed.
    StorageFileError
        If the file ``path`` cannot be written; the message names it. (Writing
        to a file object raises what the object raises.)
    """
    from vecslice.errors import StorageFileError

    ax = layer(model, i, raw=raw)
    if hasattr(path, "write"):
        # a file object: its owner knows what file it is (the command line's
        # write_atomic names the output), so its OSError is passed on as is
        ax.figure.savefig(path, dpi=dpi, facecolor="white", format=format)
        return
    target = os.fspath(path)  # type: ignore[arg-type]
    try:
        ax.figure.savefig(target, dpi=dpi, facecolor="white", format=format)
    except OSError as exc:
        raise StorageFileError(f"cannot write {target!r}: "
                               f"{exc.strerror or exc}") from exc

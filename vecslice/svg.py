"""One layer of a sliced model as SVG text (no matplotlib, exact coordinates).

The SVG's user unit is the micron: path coordinates are the model's int64 µm values
written as integers (y negated, since SVG's y axis points down), and the document's
``width`` / ``height`` are given in millimetres, so the picture prints at 1:1.
"""

from __future__ import annotations

from typing import Any
from xml.sax.saxutils import escape

import numpy as np
from numpy.typing import NDArray

__all__ = ["SVG_STYLE", "layer_index", "layer_svg"]

SVG_STYLE = {
    "fill": "#7fb2e5",
    "stroke": "#1d4f7c",
    "open": "#e8590c",
    "background": "#ffffff",
}
"""Default colours: part fill, part outline, open chains (warning), background."""


def layer_index(model: Any, i: object, name: str = "i") -> int:
    """``i`` as a layer index of ``model`` in ``[0, L)`` (negative counts from the top).

    Raises
    ------
    InputTypeError
        If ``i`` is not an integer.
    InputIndexError
        If it is outside ``[-L, L)`` (also an ``IndexError``).
    """
    from vecslice.errors import InputIndexError
    from vecslice.ragged import check_index

    if model.n_layers == 0 and isinstance(i, (int, np.integer)) \
            and not isinstance(i, (bool, np.bool_)):
        raise InputIndexError(f"`{name}` must be a layer index, but the model has "
                              f"no layers; got {int(i)}")
    return check_index(i, model.n_layers, name, "layer index")


def _ring_d(ring: NDArray[np.int64]) -> str:
    """``M x y L x y ... Z`` for one ring, y negated, integer µm."""
    xy = np.column_stack([ring[:, 0], -ring[:, 1]]).ravel().tolist()
    pts = " ".join(map(str, xy[2:]))
    return f"M{xy[0]} {xy[1]}L{pts}Z" if pts else f"M{xy[0]} {xy[1]}Z"


def _chain_d(chain: NDArray[np.int64]) -> str:
    xy = np.column_stack([chain[:, 0], -chain[:, 1]]).ravel().tolist()
    return f"M{xy[0]} {xy[1]}L" + " ".join(map(str, xy[2:] or xy[:2]))


def layer_svg(
    model: Any,
    i: int,
    *,
    margin: int = 1000,
    style: dict[str, str] | None = None,
) -> str:
    """Layer ``i`` of a :class:`vecslice.SlicedModel` as a standalone SVG document.

    Parts are filled (holes left open with the even-odd rule), outlines stroked,
    and open chains of broken meshes drawn in a warning colour. The frame is the
    bounding box of the whole model (every layer), so pictures of different layers
    of one model line up.

    Parameters
    ----------
    model : SlicedModel
        The sliced model.
    i : int
        Layer index (negative counts from the top).
    margin : int, default 1000
        Blank border around the model's bounding box, in µm.
    style : dict, optional
        Colours overriding :data:`SVG_STYLE` (keys ``fill``, ``stroke``, ``open``,
        ``background``; ``background=""`` for a transparent picture).

    Returns
    -------
    str
        The SVG document; user units are µm, ``width``/``height`` in mm.

    Raises
    ------
    InputTypeError, InputIndexError
        If ``i`` is not a layer index of the model.
    SettingsError
        If ``margin`` is negative.

    Examples
    --------
    >>> from vecslice import SlicedModel
    >>> sq = SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4],
    ...                  [[0, 0], [10, 0], [10, 10], [0, 10]])
    >>> svg = layer_svg(sq, 0, margin=0)
    >>> 'viewBox="0 -10 10 10"' in svg, "M0 0L10 0 10 -10 0 -10Z" in svg
    (True, True)
    """
    from vecslice._validate import check_int
    from vecslice.storage import check_model

    check_model(model)
    k = layer_index(model, i)
    pad = check_int(margin, "margin", minimum=0)
    colours = {**SVG_STYLE, **(style or {})}
    box = model.bounds()
    if box is None:
        box = np.zeros((2, 2), dtype=np.int64)
    x0, y0 = int(box[0, 0]) - pad, int(box[0, 1]) - pad
    w, h = int(box[1, 0]) - x0 + pad, int(box[1, 1]) - y0 + pad
    w, h = max(w, 1), max(h, 1)
    z = int(model.print_z[k])
    out = [
        '<svg xmlns="http://www.w3.org/2000/svg" version="1.1" '
        f'width="{w / 1000:g}mm" height="{h / 1000:g}mm" '
        f'viewBox="{x0} {-(y0 + h)} {w} {h}">',
        f"<title>{escape(f'layer {k} of {model.n_layers}, z {z / 1000:g} mm')}"
        "</title>",
    ]
    if colours["background"]:
        out.append(f'<rect x="{x0}" y="{-(y0 + h)}" width="{w}" height="{h}" '
                   f'fill="{escape(colours["background"])}"/>')
    out.append(f'<g fill="{escape(colours["fill"])}" fill-rule="evenodd" '
               f'stroke="{escape(colours["stroke"])}" stroke-width="1" '
               'vector-effect="non-scaling-stroke">')
    for outline, holes in model.layer(k):
        d = "".join(_ring_d(r) for r in (outline, *holes))
        out.append(f'<path d="{d}" vector-effect="non-scaling-stroke"/>')
    out.append("</g>")
    chains = model.open.layer(k)
    if chains:
        out.append(f'<g fill="none" stroke="{escape(colours["open"])}" '
                   'stroke-width="2">')
        out += [f'<path d="{_chain_d(c)}" vector-effect="non-scaling-stroke"/>'
                for c in chains if len(c)]
        out.append("</g>")
    out.append("</svg>\n")
    return "\n".join(out)

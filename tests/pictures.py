"""Reading test pictures: PNG pixels, colour masks, regions enclosed by a shape."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from scipy import ndimage


def rgb(png: bytes | Path) -> np.ndarray:
    """(H, W, 3) float RGB in [0, 1] of a PNG file or PNG bytes."""
    from matplotlib.image import imread

    src = io.BytesIO(png) if isinstance(png, bytes) else str(png)
    img = imread(src, format="png")
    return np.asarray(img[..., :3], dtype=np.float64)


def near(img: np.ndarray, colour: str, tol: float = 0.12) -> np.ndarray:
    """Pixels within ``tol`` (per channel) of ``colour`` ('#rrggbb')."""
    want = np.array([int(colour[i : i + 2], 16) / 255 for i in (1, 3, 5)])
    return (np.abs(img - want) <= tol).all(axis=-1)


def shape_and_holes(img: np.ndarray, fill: str, stroke: str,
                    background: str = "#ffffff", min_pixels: int = 3):
    """The largest shape drawn in ``fill``/``stroke``, and the holes in it.

    Returns ``(shape_mask, hole_sizes)``: the pixels of the largest connected
    region of fill or stroke colour, and the size in background pixels of each
    region of background colour that this shape encloses (at least
    ``min_pixels`` pixels; anti-aliasing specks are ignored).
    """
    drawn = near(img, fill) | near(img, stroke, 0.2)
    labels, n = ndimage.label(drawn)
    if n == 0:
        return drawn, []
    sizes = ndimage.sum_labels(drawn, labels, index=np.arange(1, n + 1))
    shape = labels == 1 + int(np.argmax(sizes))
    inside = ndimage.binary_fill_holes(shape) & ~shape & near(img, background)
    holes, m = ndimage.label(inside)
    hole_sizes = ndimage.sum_labels(inside, holes, index=np.arange(1, m + 1))
    return shape, [int(s) for s in hole_sizes if s >= min_pixels]


def bbox(mask: np.ndarray) -> tuple[int, int, int, int]:
    """(row0, col0, row1, col1) of the true pixels (inclusive)."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    return int(rows[0]), int(cols[0]), int(rows[-1]), int(cols[-1])

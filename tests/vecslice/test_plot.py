import errno
import io
import os
import sys

import numpy as np
import pytest

import vecslice as vs
from pictures import rgb, shape_and_holes
from vecslice import plot
from vecslice.svg import SVG_STYLE

pytest.importorskip("matplotlib")
from matplotlib.collections import LineCollection
from matplotlib.path import Path


@pytest.fixture(scope="module")
def demo():
    return vs.slice_mesh(vs.demo_mesh())


@pytest.fixture(scope="module")
def broken():
    """Two layers: a square, then only an open chain."""
    return vs.SlicedModel(
        [100, 200], [200, 300], [200, 100], [0, 1, 1], [0, 1], [0, 4],
        [[0, 0], [10000, 0], [10000, 10000], [0, 10000]],
        open_coords=[[0, 20000], [5000, 25000], [9000, 20000]],
        open_ring_offsets=[0, 3], open_layer_offsets=[0, 0, 1])


def subpaths(path):
    """Rings (mm) of a compound matplotlib Path, closing vertex dropped."""
    starts = np.flatnonzero(path.codes == Path.MOVETO)
    ends = np.flatnonzero(path.codes == Path.CLOSEPOLY)
    assert len(starts) == len(ends)
    return [path.vertices[s:e] for s, e in zip(starts, ends)]


def test_layer_fills_parts_with_their_holes_in_mm(demo):
    ax = plot.layer(demo, 10)
    (patch,) = ax.patches
    got = subpaths(patch.get_path())
    outline, holes = demo.layer(10)[0]
    assert len(got) == 2
    for a, b in zip(got, [outline, *holes]):
        assert np.array_equal(a, b / 1000.0)
    assert ax.get_xlabel() == "x (mm)" and ax.get_ylabel() == "y (mm)"
    assert ax.get_aspect() == 1.0
    assert ax.get_xlim() == (-16.0, 16.0) and ax.get_title() == "layer 10, z 1.3 mm"


def test_raw_contour_over_the_simplified_one(demo):
    raw = vs.slice_contours(vs.demo_mesh(), demo.slice_z)
    ax = plot.layer(demo, 10, raw=raw)
    filled, dashed = ax.patches
    assert dashed.get_fill() is False and dashed.get_linestyle() == "--"
    rings = subpaths(dashed.get_path())
    assert len(rings) == len(raw.layer(10))
    assert np.array_equal(rings[0], raw.layer(10)[0] / 1000.0)
    with pytest.raises(vs.InputValueError, match="`raw` must have the model's 148"):
        plot.layer(demo, 10, raw=vs.slice_contours(vs.demo_mesh(), demo.slice_z[:3]))


def test_open_chains_are_drawn_in_the_warning_colour(broken):
    ax = plot.layer(broken, 1)
    assert len(ax.patches) == 0
    (lines,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert np.array_equal(lines.get_segments()[0], [[0, 20], [5, 25], [9, 20]])
    assert tuple(lines.get_colors()[0][:3]) == pytest.approx(
        [int(SVG_STYLE["open"][i:i + 2], 16) / 255 for i in (1, 3, 5)])


def test_stack_shifts_each_layer_by_the_offset(demo):
    ax = plot.stack(demo, [0, 60, 120], offset=(5, 2))
    assert len(ax.patches) == 3
    for j, (patch, k) in enumerate(zip(ax.patches, [0, 60, 120])):
        first = subpaths(patch.get_path())[0]
        assert np.array_equal(first, demo.layer(k)[0][0] / 1000.0 + [5 * j, 2 * j])
    default = plot.stack(demo)
    assert len(default.patches) == 8  # eight layers, bottom to top
    with pytest.raises(vs.InputValueError,
                       match=r"^`layers\[1\]` must be a layer index in "
                             r"\[-148, 148\); got 500$"):
        plot.stack(demo, [0, 500])


def test_a_bad_layer_is_named_by_its_argument(demo):
    # audit s35: layer(model, i) named the index `layer`, as layer_svg did
    with pytest.raises(vs.InputValueError,
                       match=r"^`i` must be a layer index in \[-148, 148\); "
                             r"got 500$"):
        plot.layer(demo, 500)


def test_stats_against_z(demo):
    area_ax, vert_ax = plot.stats(demo)
    (area,), (verts,) = area_ax.get_lines(), vert_ax.get_lines()
    assert np.array_equal(area.get_xdata(), demo.print_z / 1000.0)
    assert np.allclose(area.get_ydata(), demo.layer_areas() / 1e6)
    counts = plot.layer_vertex_counts(demo)
    assert np.array_equal(verts.get_ydata(), counts)
    assert counts.sum() == demo.coords.shape[0]
    assert area_ax.get_ylabel() == "area (mm²)" and vert_ax.get_xlabel() == "z (mm)"


def test_save_layer_png_shows_the_hole(demo, tmp_path):
    plot.save_layer(demo, 10, tmp_path / "l.png")
    shape, holes = shape_and_holes(rgb(tmp_path / "l.png"), SVG_STYLE["fill"],
                                   SVG_STYLE["stroke"])
    assert len(holes) == 1
    plot.save_layer(demo, -1, tmp_path / "top.png")  # the boss: a disc
    assert shape_and_holes(rgb(tmp_path / "top.png"), SVG_STYLE["fill"],
                           SVG_STYLE["stroke"])[1] == []


def test_save_layer_error_names_the_file(demo, tmp_path):
    with pytest.raises(vs.StorageFileError, match=r"cannot write .*nowhere"):
        plot.save_layer(demo, 0, tmp_path / "nowhere" / "x.png")


class _FullDisk(io.BytesIO):
    def write(self, data):
        raise OSError(errno.EFBIG, os.strerror(errno.EFBIG))


def test_save_layer_to_a_file_object_passes_its_error_on(demo):
    """Audit s24 D6: the message named ``<_io.BufferedWriter name=3>`` (the
    command line's temporary file) instead of the picture; the writer of the
    file object words it (see test_cli_args)."""
    with pytest.raises(OSError, match="File too large") as info:
        plot.save_layer(demo, 0, _FullDisk(), format="png")
    assert not isinstance(info.value, vs.StorageFileError)
    assert "BytesIO" not in str(info.value) and "name=" not in str(info.value)


def test_draws_into_given_axes(demo):
    from matplotlib.figure import Figure

    ax = Figure().add_subplot()
    assert plot.layer(demo, 0, ax=ax) is ax


def test_missing_matplotlib_names_the_extra(demo, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(vs.MissingDependencyError, match=r"vecslice\[plot\]") as e:
        plot.layer(demo, 0)
    assert isinstance(e.value, ModuleNotFoundError)
    for fn in (plot.stack, plot.stats):
        with pytest.raises(ImportError, match="pip install 'vecslice"):
            fn(demo)


@pytest.mark.parametrize("draw", [lambda m: plot.layer(m, 0), lambda m: plot.stack(m),
                                  plot.stats, lambda m: plot.save_layer(m, 0, "x.png")])
@pytest.mark.parametrize(("model", "hint"), [("m.npz", r" \(read a saved model with "
                                                       r"vs.load_sliced\(path\)\)$"),
                                             (None, "$"), ([1, 2], "$")])
def test_a_model_of_another_type_is_refused_by_name(draw, model, hint):
    """Audit s25 docs D3: AttributeError ('str' object has no attribute 'n_layers')."""
    with pytest.raises(vs.InputTypeError,
                       match=rf"^`model` must be a vecslice.SlicedModel; got "
                             rf"{type(model).__name__}{hint}"):
        draw(model)

import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import vecslice as vs
from vecslice.svg import SVG_STYLE, layer_index, layer_svg

NS = {"svg": "http://www.w3.org/2000/svg"}


def rings_of(d):
    """Integer rings (y negated back) from a path's ``d``."""
    out = []
    for sub in re.findall(r"M[^MZ]*Z?", d):
        nums = [int(v) for v in re.findall(r"-?\d+", sub)]
        xy = np.array(nums, dtype=np.int64).reshape(-1, 2)
        out.append(np.column_stack([xy[:, 0], -xy[:, 1]]))
    return out


@pytest.fixture(scope="module")
def demo():
    return vs.slice_mesh(vs.demo_mesh())


def test_to_svg_is_layer_svg(demo):
    assert demo.to_svg(3) == layer_svg(demo, 3)
    assert demo.to_svg(-1) == layer_svg(demo, demo.n_layers - 1)


def test_coordinates_are_exact_and_holes_kept(demo):
    k = 10  # the plate with its hole
    root = ET.fromstring(demo.to_svg(k))
    paths = root.findall("svg:g/svg:path", NS)
    parts = demo.layer(k)
    assert len(paths) == len(parts) == 1
    got = rings_of(paths[0].get("d"))
    outline, holes = parts[0]
    assert len(got) == 2
    for a, b in zip(got, [outline, *holes]):
        assert np.array_equal(a, b)
    g = root.find("svg:g", NS)
    assert g.get("fill-rule") == "evenodd" and g.get("fill") == SVG_STYLE["fill"]


def test_frame_is_the_model_bounds_in_mm(demo):
    root = ET.fromstring(demo.to_svg(0, margin=500))
    # bounds x -15..15 mm, y -10..10 mm, plus 0.5 mm each side; y is negated
    assert root.get("viewBox") == "-15500 -10500 31000 21000"
    assert root.get("width") == "31mm" and root.get("height") == "21mm"
    assert "layer 0 of 148, z 0.3 mm" in root.find("svg:title", NS).text


def test_open_chains_in_the_warning_colour():
    model = vs.SlicedModel(
        [100, 200], [200, 300], [200, 100], [0, 1, 1], [0, 1], [0, 4],
        [[0, 0], [10, 0], [10, 10], [0, 10]],
        open_coords=[[0, 20], [5, 25], [9, 20]], open_ring_offsets=[0, 3],
        open_layer_offsets=[0, 0, 1])
    root = ET.fromstring(model.to_svg(1))
    groups = root.findall("svg:g", NS)
    assert len(groups[0].findall("svg:path", NS)) == 0  # no parts on layer 1
    chain = groups[1]
    assert chain.get("stroke") == SVG_STYLE["open"] and chain.get("fill") == "none"
    assert chain.find("svg:path", NS).get("d") == "M0 -20L5 -25 9 -20"
    assert len(ET.fromstring(model.to_svg(0)).findall("svg:g", NS)) == 1


def test_style_and_transparent_background(demo):
    text = demo.to_svg(0, style={"fill": "#000000", "background": ""})
    root = ET.fromstring(text)
    assert root.find("svg:rect", NS) is None
    assert root.find("svg:g", NS).get("fill") == "#000000"
    assert ET.fromstring(demo.to_svg(0)).find("svg:rect", NS).get("fill") == "#ffffff"


def test_empty_model():
    empty = vs.SlicedModel([], [], [], [0], [0], [0], np.empty((0, 2), np.int64))
    with pytest.raises(vs.InputValueError, match=r"`i` must be a layer index, "
                       r"but the model has no layers; got 0"):
        empty.to_svg(0)


@pytest.mark.parametrize(("i", "err", "match"), [
    (148, vs.InputValueError,
     r"`i` must be a layer index in \[-148, 148\); got 148"),
    (-149, vs.InputValueError, r"got -149"),
    (1.0, vs.InputTypeError, r"`i` must be an integer layer index; got float 1.0"),
    (True, vs.InputTypeError, r"got bool True"),
    ("3", vs.InputTypeError, r"got str '3'"),
])
def test_bad_layer(demo, i, err, match):
    with pytest.raises(err, match=match):
        demo.to_svg(i)


def test_bad_margin(demo):
    with pytest.raises(vs.SettingsError, match="`margin` must be >= 0; got -1"):
        demo.to_svg(0, margin=-1)


def test_layer_index_accepts_numpy_integers(demo):
    assert layer_index(demo, np.int32(-1)) == 147
    assert layer_index(demo, np.int64(2)) == 2


def test_a_model_of_another_type_is_refused_by_name(tmp_path):
    """Audit s25 docs D3: AttributeError ('str' object has no attribute 'n_layers')."""
    with pytest.raises(vs.InputTypeError,
                       match=r"`model` must be a vecslice.SlicedModel; got PosixPath "
                             r"\(read a saved model with vs.load_sliced\(path\)\)"):
        layer_svg(tmp_path / "m.npz", 0)

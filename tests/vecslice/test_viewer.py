"""The layer viewer: its data round-trip exactly, and it works in a real browser."""

import base64
import html
import json
import os
import re
import shutil
import zlib

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import vecslice as vs
from conftest import MESHES
from pictures import bbox, near, rgb, shape_and_holes
from vecslice.svg import SVG_STYLE
from vecslice.viewer import varint_encode, viewer_html, write_viewer

# --- the embedded data --------------------------------------------------------


def varint_decode(data, count=None):
    """Slow reference decoder (what the page's script does)."""
    out, u, shift = [], 0, 0
    for b in data:
        u |= (b & 0x7F) << shift
        shift += 7
        if not b & 0x80:
            out.append(-(u + 1) // 2 if u & 1 else u // 2)
            u, shift = 0, 0
    assert shift == 0
    return out


def embedded(page):
    """(meta, {section: int64 array}) read back from a viewer page."""
    meta = json.loads(re.search(r'id="vecslice-meta" type="application/json">'
                                r"(.*?)</script>", page, re.S).group(1))
    b64 = re.search(r'id="vecslice-data" type="application/octet-stream">'
                    r"(.*?)</script>", page, re.S).group(1)
    values = np.array(varint_decode(zlib.decompress(base64.b64decode(b64))),
                      dtype=np.int64)
    sizes = [n for _, n in meta["sections"]]
    parts = np.split(values, np.cumsum(sizes)[:-1]) if sizes else []
    return meta, dict(zip([s for s, _ in meta["sections"]], parts))


def offsets(counts):
    return np.concatenate([[0], np.cumsum(counts)])


@given(st.lists(st.integers(-(2**52) + 1, 2**52 - 1), max_size=50))
def test_varints_round_trip(values):
    assert varint_decode(varint_encode(np.array(values, dtype=np.int64))) == values


def test_varint_sizes_and_limit():
    assert len(varint_encode(np.array([63, -64]))) == 2
    assert len(varint_encode(np.array([64, 8191, -8192]))) == 6
    assert varint_encode(np.array([], dtype=np.int64)) == b""
    with pytest.raises(vs.InputValueError, match=r"below 2\*\*52 .* got -4503599"):
        varint_encode(np.array([1, -(2**52)]))


def _check_round_trip(model):
    meta, s = embedded(viewer_html(model))
    assert meta["n_layers"] == model.n_layers and meta["n_parts"] == model.n_parts
    assert np.array_equal(s["slice_z"], model.slice_z)
    assert np.array_equal(s["print_z"], model.print_z)
    assert np.array_equal(offsets(s["parts"]), model.layer_offsets)
    assert np.array_equal(offsets(s["rings"]), model.part_offsets)
    assert np.array_equal(offsets(s["vertices"]), model.ring_offsets)
    xy = np.cumsum(s["coords"].reshape(-1, 2), axis=0)
    assert np.array_equal(xy, model.coords)
    assert np.array_equal(offsets(s["open_chains"]), model.open_layer_offsets)
    assert np.array_equal(offsets(s["open_vertices"]), model.open_ring_offsets)
    oxy = np.cumsum(s["open_coords"].reshape(-1, 2), axis=0)
    assert np.array_equal(oxy, model.open_coords)
    assert np.allclose(meta["areas_mm2"], model.layer_areas() / 1e6, atol=1e-6)
    box = model.bounds()
    assert meta["bounds"] == ([0, 0, 0, 0] if box is None else box.ravel().tolist())


def test_data_round_trip_exactly():
    _check_round_trip(vs.slice_mesh(vs.demo_mesh()))
    _check_round_trip(vs.SlicedModel(
        [100, 200], [200, 300], [200, 100], [0, 1, 1], [0, 1], [0, 4],
        [[-(2**30) + 1, 0], [2**30 - 1, 0], [2**30 - 1, 5], [0, 5]],
        open_coords=[[0, 20], [5, 25], [9, 20]], open_ring_offsets=[0, 3],
        open_layer_offsets=[0, 0, 1]))
    _check_round_trip(vs.SlicedModel([], [], [], [0], [0], [0],
                                     np.empty((0, 2), np.int64)))


def test_page_is_self_contained_and_escapes_the_title():
    page = viewer_html(vs.slice_mesh(vs.demo_mesh()), title="</script><b>x&y")
    assert "<title>&lt;/script&gt;&lt;b&gt;x&amp;y - vecslice" in page
    meta, _ = embedded(page)
    assert meta["title"] == "</script><b>x&y"
    assert page.count("</script>") == 3  # meta, data, the viewer's script
    assert not re.search(r"""(src|href)\s*=\s*["']?(https?:)?//""", page)
    assert "fetch(" not in page and "XMLHttpRequest" not in page


@pytest.mark.parametrize("title", [
    "{{META}}<img src=x onerror=alert(1)>.npz", "{{DATA}}", "{{TITLE}}{{META}}",
])  # fmt: skip
def test_placeholders_in_the_title_stay_text(title):
    """Audit s23 D13: a title holding ``{{META}}`` got the meta JSON (with the raw,
    unescaped title) pasted into the page's <title>."""
    model = vs.SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4],
                           [[0, 0], [10, 0], [10, 10], [0, 10]])
    page = viewer_html(model, title=title)
    head = re.search(r"<title>(.*?)</title>", page, re.S).group(1)
    assert head == f"{html.escape(title)} - vecslice layer viewer"
    assert page.count("</script>") == 3
    # raw markup only as JSON text inside the meta <script>, never in the HTML
    outside = re.sub(r'(id="vecslice-meta" type="application/json">).*?</script>',
                     "", page, flags=re.S)
    assert "<img" not in outside and "{{" not in outside.replace(head, "")
    meta, data = embedded(page)
    assert meta["title"] == title and data["coords"].size == 8


@pytest.mark.parametrize("title", [
    "<!--<script>.npz", "<!--<script", "a<!--<SCRIPT x>b-->c.stl", "<script>&amp;",
    "x]]><!--.npz",
])  # fmt: skip
def test_no_markup_in_the_embedded_json(title):
    """Audit s24 D3: a title holding ``<!--<script`` put the HTML tokenizer in its
    "script data double escaped" state: the meta <script> swallowed the rest of
    the page, whose data and program were gone (yet it still had 3 ``</script>``)."""
    model = vs.SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4],
                           [[0, 0], [10, 0], [10, 10], [0, 10]])
    page = viewer_html(model, title=title)
    assert page.lower().count("<script") == 3 and page.count("</script>") == 3
    text = re.search(r'id="vecslice-meta" type="application/json">(.*?)</script>',
                     page, re.S).group(1)
    assert not set("<>&") & set(text)  # nothing for the tokenizer to act on
    meta = json.loads(text)  # what the page's JSON.parse reads
    assert meta["title"] == title and meta["n_layers"] == 1
    _, data = embedded(page)
    assert data["coords"].size == 8


def test_bad_arguments(tmp_path):
    model = vs.slice_mesh(vs.demo_mesh())
    with pytest.raises(vs.InputTypeError, match=r"`model` must be a vecslice\.Sliced"):
        viewer_html(vs.demo_mesh())
    with pytest.raises(vs.InputTypeError, match="`title` must be a str; got int"):
        viewer_html(model, title=3)
    with pytest.raises(vs.StorageFileError, match=r"cannot save .* to .*v\.html"):
        write_viewer(model, tmp_path / "missing" / "v.html")
    write_viewer(model, tmp_path / "v.html", title="demo")
    assert (tmp_path / "v.html").read_text(encoding="utf-8") == viewer_html(
        model, title="demo")


# --- in a real browser: headless Chromium through chromedriver ----------------

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
         "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync"]


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not (chromium and driver):
        why = ("the browser test needs Debian's chromium and chromium-driver "
               "(apt-get install -y chromium chromium-driver)")
        if os.environ.get("CI"):
            pytest.fail(why)  # .ci/run installs them: never skipped in CI
        pytest.skip(why)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    profile = tmp_path_factory.mktemp("chromium-profile")
    for flag in [*FLAGS, f"--user-data-dir={profile}", "--window-size=1000,800",
                 "--force-device-scale-factor=1"]:
        options.add_argument(flag)
    d = webdriver.Chrome(options=options, service=Service(driver))
    d.set_page_load_timeout(120)
    yield d
    d.quit()


def _open(d, path, fragment=""):
    from selenium.webdriver.support.ui import WebDriverWait

    d.get("about:blank")  # a fresh document even if only the fragment differs
    d.get(path.resolve().as_uri() + fragment)
    WebDriverWait(d, 120).until(
        lambda d: d.execute_script("return document.body.dataset.ready"
                                   " || document.body.dataset.error"))
    assert d.execute_script("return document.body.dataset.error") is None
    return d


def _canvas(d):
    from selenium.webdriver.common.by import By

    return rgb(d.find_element(By.ID, "canvas").screenshot_as_png)


def _state(d, layer=None):
    """(layer, readout) once drawn; waits until ``layer`` is drawn if given."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    js = "return document.body.dataset.layer + '/' + document.body.dataset.draws"
    if layer is not None:
        WebDriverWait(d, 30).until(lambda d: d.execute_script(js).startswith(
            f"{layer}/"))
    return (int(d.execute_script("return document.body.dataset.layer")),
            d.find_element(By.ID, "readout").text)


def _moved(d, old):
    """Wait until the drawn layer is no longer ``old``; return (layer, readout)."""
    from selenium.webdriver.support.ui import WebDriverWait

    WebDriverWait(d, 30).until(lambda d: int(d.execute_script(
        "return document.body.dataset.layer")) != old)
    return _state(d)


def _plate_holes(d):
    shape, holes = shape_and_holes(_canvas(d), SVG_STYLE["fill"], SVG_STYLE["stroke"])
    return shape, holes


@pytest.fixture(scope="module")
def plate_page(tmp_path_factory):
    path = MESHES / "plate_holes.STL"
    if not path.exists():
        pytest.skip(f"{path} not found")
    model = vs.slice_mesh(vs.load_mesh(path))
    page = tmp_path_factory.mktemp("viewer") / "plate.html"
    write_viewer(model, page, title="plate_holes.STL")
    return page, model


def test_browser_shows_the_plate_with_five_holes_and_the_slider_moves(
        browser, plate_page):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    page, model = plate_page
    d = _open(browser, page)
    layer, text = _state(d)
    assert layer == model.n_layers // 2  # opens at the middle layer
    assert f"layer {layer} of {model.n_layers}" in text
    assert "1 part · 5 holes" in text
    assert f"z {model.print_z[layer] / 1000:.3f} mm" in text
    plate, holes = _plate_holes(d)
    assert len(holes) == 5
    r0, c0, r1, c1 = bbox(plate)
    assert (c1 - c0) / (r1 - r0) == pytest.approx(203.2 / 304.8, rel=0.03)
    before = d.get_screenshot_as_png()

    # drag the slider's thumb to the right, as a user does
    slider = d.find_element(By.ID, "slider")
    ActionChains(d).click_and_hold(slider).move_by_offset(slider.size["width"] // 4, 0)\
        .release().perform()
    moved, moved_text = _moved(d, layer)
    assert moved > layer + 5
    assert f"z {model.print_z[moved] / 1000:.3f} mm" in moved_text
    assert d.get_screenshot_as_png() != before
    assert len(_plate_holes(d)[1]) == 5

    # keyboard stepping
    body = d.find_element(By.TAG_NAME, "body")
    body.send_keys("\ue014")  # arrow right
    _state(d, moved + 1)
    body.send_keys("\ue010")  # End
    _state(d, model.n_layers - 1)
    body.send_keys("\ue011")  # Home
    _state(d, 0)
    assert d.current_url.endswith("#layer=0")


def test_browser_picture_follows_the_layer_and_zooms(browser, tmp_path):
    """The demo model: a plate with a hole up to 5 mm, a round boss above."""
    model = vs.slice_mesh(vs.demo_mesh())
    page = tmp_path / "demo.html"
    write_viewer(model, page)
    d = _open(browser, page, "#layer=10")
    _state(d, 10)
    plate, holes = _plate_holes(d)
    assert len(holes) == 1
    r0, c0, r1, c1 = bbox(plate)
    assert (c1 - c0) / (r1 - r0) == pytest.approx(30 / 20, rel=0.03)

    from selenium.webdriver.common.by import By

    slider = d.find_element(By.ID, "slider")
    slider.send_keys("\ue010")  # End on the slider itself
    _state(d, model.n_layers - 1)
    boss, holes = _plate_holes(d)
    assert holes == []
    b0, bc0, b1, bc1 = bbox(boss)
    # the boss is an 8 mm disc: 8/30 of the plate's width, round
    assert (bc1 - bc0) / (c1 - c0) == pytest.approx(8 / 30, rel=0.06)
    assert (bc1 - bc0) / (b1 - b0) == pytest.approx(1, rel=0.05)

    draws = d.execute_script("return document.body.dataset.draws")
    d.find_element(By.TAG_NAME, "body").send_keys("+")
    from selenium.webdriver.support.ui import WebDriverWait

    WebDriverWait(d, 30).until(lambda d: d.execute_script(
        "return document.body.dataset.draws") != draws)
    z0, zc0, z1, zc1 = bbox(_plate_holes(d)[0])
    assert (zc1 - zc0) / (bc1 - bc0) == pytest.approx(1.25, rel=0.05)


def test_browser_draws_open_chains_in_the_warning_colour(browser, tmp_path):
    model = vs.SlicedModel(
        [100, 200], [200, 300], [200, 100], [0, 1, 1], [0, 1], [0, 4],
        [[0, 0], [10000, 0], [10000, 10000], [0, 10000]],
        open_coords=[[0, 12000], [5000, 18000], [9000, 12000]],
        open_ring_offsets=[0, 3], open_layer_offsets=[0, 0, 1])
    page = tmp_path / "open.html"
    write_viewer(model, page)
    d = _open(browser, page, "#layer=1")
    layer, text = _state(d, 1)
    assert layer == 1 and "1 open chain" in text
    img = _canvas(d)
    assert near(img, SVG_STYLE["open"], 0.1).sum() > 100
    assert not near(img, SVG_STYLE["fill"], 0.05).any()  # no part on layer 1
    d = _open(browser, page, "#layer=0")
    assert not near(_canvas(d), SVG_STYLE["open"], 0.1).any()


def test_browser_renders_the_svg_export(browser, plate_page, tmp_path):
    page, model = plate_page
    svg = tmp_path / "layer.svg"
    svg.write_text(model.to_svg(model.n_layers // 2))
    frame = tmp_path / "frame.html"  # the SVG is 1:1 in mm: fit it in the window
    frame.write_text('<body style="margin:0"><img src="layer.svg" '
                     'style="height:95vh"></body>')
    browser.get(frame.resolve().as_uri())
    img = rgb(browser.get_screenshot_as_png())
    plate, holes = shape_and_holes(img, SVG_STYLE["fill"], SVG_STYLE["stroke"])
    assert len(holes) == 5

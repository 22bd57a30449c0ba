"""The ``vecslice`` command, run as a subprocess the way a user runs it."""

import os
import stat
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import vecslice as vs
from conftest import MESHES
from pictures import bbox, rgb, shape_and_holes
from vecslice.cli import SLICE_OPTIONS
from vecslice.svg import SVG_STYLE

PLATE = MESHES / "plate_holes.STL"


def run_cli(*args, cwd, timeout=300, env=None, module="vecslice"):
    """``python -m vecslice ARGS`` in ``cwd``; stderr is a pipe (not a terminal)."""
    proc = subprocess.run(
        [sys.executable, "-m", module, *map(str, args)], cwd=cwd,
        capture_output=True, text=True, timeout=timeout, check=False,
        env={**os.environ, **(env or {})},
    )
    assert "Traceback" not in proc.stderr, proc.stderr
    return proc


def mesh(name):
    path = MESHES / name
    if not path.exists():
        pytest.skip(f"{path} not found")
    return path


def lines(text):
    return {ln.split(None, 1)[0]: ln for ln in text.splitlines() if ln.strip()}


# --- success ------------------------------------------------------------------


def test_demo_without_arguments(tmp_path):
    p = run_cli(cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    out = lines(p.stdout)
    assert "built-in demo model" in p.stdout
    assert out["model"].endswith("30.000 x 20.000 x 15.000 mm, watertight")
    assert out["layers"] == "layers    148, z 0.300 to 15.000 mm"
    assert out["parts"] == "parts     148 (48 holes)"
    # raw and stored vertices, open chains, seconds per stage
    assert " raw -> 5,226 stored (" in out["vertices"]
    assert out["open"] == "open      0 chains left open, 0 gaps stitched"
    for stage in ("load", "contours", "stitch", "simplify", "parts", "total"):
        assert f"{stage} " in out["seconds"]
    # stderr is a pipe: no progress bar frames (D5)
    assert "\r" not in p.stderr and "it/s" not in p.stderr and "%|" not in p.stderr
    assert list(tmp_path.iterdir()) == []  # nothing saved without -o


def test_slice_a_real_mesh_with_mm_options(tmp_path):
    path = mesh("featuretype.STL")
    p = run_cli("slice", path, "--scale", "25.4", "--layer-height", "0.0625",
                "--initial-layer-height", "0.3", "--max-deviation", "0.02",
                "-o", "feature.npz", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    model = vs.load_sliced(tmp_path / "feature.npz")
    # 0.0625 mm = 62.5 µm rounds half away from zero to 63 µm (to_microns), once
    assert model.thickness[0] == 300 and (model.thickness[1:] == 63).all()
    assert (np.diff(model.slice_z)[1:] == 63).all()
    assert model.n_layers == len(model.slice_z) > 500
    assert f"layers    {model.n_layers:,}," in p.stdout
    assert "saved     feature.npz (" in p.stdout


def test_model_alone_is_short_for_slice(tmp_path):
    path = mesh("plate_holes.STL")
    a = run_cli(path, "--layer-height", "0.5", "-o", "a.npz", cwd=tmp_path)
    b = run_cli("slice", path, "--layer-height", "0.5", "-o", "b.npz", cwd=tmp_path)
    assert a.returncode == b.returncode == 0
    ma, mb = vs.load_sliced(tmp_path / "a.npz"), vs.load_sliced(tmp_path / "b.npz")
    assert np.array_equal(ma.coords, mb.coords) and ma.n_layers == mb.n_layers == 26


def test_compat_cura_reads_and_slices_as_cura_does(tmp_path):
    # the 1000-gon cylinder: CuraEngine's reading and polygons differ from the
    # default's, and both the loading and the slicing options must be passed on
    path = mesh("cura/cylinder1000.stl")
    p = run_cli(path, "--compat", "cura", "-o", "cyl.npz", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    want = vs.slice_mesh(vs.load_mesh(path, compat="cura"),
                         vs.SliceSettings(compat="cura"))
    got = vs.load_sliced(tmp_path / "cyl.npz")
    assert np.array_equal(got.coords, want.coords)
    assert np.array_equal(got.ring_offsets, want.ring_offsets)
    half = vs.slice_mesh(vs.load_mesh(path), vs.SliceSettings(compat="cura"))
    assert got.coords.shape != half.coords.shape  # the reading matters here
    # the STL's corners are melded within 30 µm: said so, not "same position"
    merged = vs.load_mesh(path, compat="cura").load_info.vertices_merged
    assert merged > 0
    assert f"cleaned   {merged:,} vertices melded (within 30 µm" in p.stdout
    assert "same position" not in p.stdout


def test_adaptive_layers_in_mm(tmp_path):
    path = mesh("Voron_Design_Cube_v7.stl")
    p = run_cli(path, "--adaptive-layers", "--layer-height", "0.2",
                "--adaptive-variation", "0.1", "--adaptive-variation-step", "0.05",
                "--adaptive-threshold", "0.25", "-o", "cube.npz", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    settings = vs.SliceSettings(layer_height=200, adaptive_layers=True,
                                adaptive_variation=100, adaptive_variation_step=50,
                                adaptive_threshold=250)
    want = vs.slice_mesh(vs.load_mesh(path), settings)
    got = vs.load_sliced(tmp_path / "cube.npz")
    assert np.array_equal(got.thickness, want.thickness)
    assert np.array_equal(got.coords, want.coords)
    assert len(set(got.thickness[1:].tolist())) > 1  # adaptive: several heights


def test_max_layers(tmp_path):
    p = run_cli(mesh("plate_holes.STL"), "--max-layers", "50", cwd=tmp_path)
    _only_error_line(p, "more layers than --max-layers 50 allows")
    assert "raise the limit: --max-layers 125 or more" in p.stderr


def test_repair_is_reported_and_metres_get_a_hint(tmp_path):
    path = mesh("hourglass.stl")
    p = run_cli("slice", path, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "repaired  1,622 faces flipped" in p.stdout
    assert "layers    0\n" in p.stdout
    assert "the result has 0 layers" in p.stderr and "--scale 1000" in p.stderr
    assert "the model is only 0.034 x 0.034 x 0.070 mm" in p.stderr


def test_no_repair_and_scale(tmp_path):
    path = mesh("hourglass.stl")
    p = run_cli("slice", path, "--scale", "1000", "--no-repair", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "repaired" not in p.stdout and "--scale" not in p.stderr
    assert "34.000 x 34.000 x 70.000 mm" in p.stdout
    assert "inconsistent" in lines(p.stdout)["model"]  # windings as read
    fixed = run_cli("slice", path, "--scale", "1000", cwd=tmp_path)
    assert "watertight" in lines(fixed.stdout)["model"]


def test_info_on_a_mesh(tmp_path):
    p = run_cli("info", mesh("plate_holes.STL"), cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    for want in ("faces               1,252", "bodies (shells)     1",
                 "size mm             203.200 x 304.800 x 12.700",
                 "boundary edges      0", "non-manifold edges  0",
                 "volume mm3          "):
        assert want in p.stdout
    assert p.stderr == ""


def test_info_on_a_saved_model(tmp_path):
    model = vs.slice_mesh(vs.demo_mesh())
    model.save(tmp_path / "demo.npz")
    p = run_cli("info", "demo.npz", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    out = lines(p.stdout)
    assert out["layers"] == "layers    148"
    assert out["z"] == ("z         0.300 to 15.000 mm (printed), cut at 0.150 to "
                        "14.950 mm")
    assert out["thickness"] == "thickness first layer 0.3 mm, then 0.1 mm"
    assert out["parts"] == "parts     148 (48 holes)"
    assert out["vertices"] == f"vertices  {model.coords.shape[0]:,}"
    assert out["bounds"] == "bounds    x -15.000 to 15.000 mm, y -10.000 to 10.000 mm"


def test_preview_png_shows_the_plate_and_its_five_holes(tmp_path):
    path = mesh("plate_holes.STL")
    p = run_cli("preview", path, "--z", "6.35", "-o", "plate.png", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "-> plate.png" in p.stdout
    img = rgb(tmp_path / "plate.png")
    plate, holes = shape_and_holes(img, SVG_STYLE["fill"], SVG_STYLE["stroke"])
    assert len(holes) == 5
    r0, c0, r1, c1 = bbox(plate)
    # the plate is 203.2 x 304.8 mm, drawn with equal axes
    assert (c1 - c0) / (r1 - r0) == pytest.approx(203.2 / 304.8, rel=0.03)
    assert plate.sum() > 0.2 * plate.size  # it fills much of the picture


def test_preview_svg_from_a_saved_model(tmp_path):
    path = mesh("plate_holes.STL")
    model = vs.slice_mesh(vs.load_mesh(path))
    model.save(tmp_path / "plate.npz")
    p = run_cli("preview", "plate.npz", "--layer", "-1", "-o", "top.svg",
                cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    text = (tmp_path / "top.svg").read_text()
    assert text == model.to_svg(model.n_layers - 1)
    root = ET.fromstring(text)
    paths = root.findall(".//{http://www.w3.org/2000/svg}path")
    assert len(paths) == 1 and paths[0].get("d").count("M") == 6  # outline + 5


def test_view_writes_a_self_contained_page(tmp_path):
    path = mesh("plate_holes.STL")
    p = run_cli("view", path, "--layer-height", "0.4", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    page = tmp_path / "plate_holes.html"  # default: the model's name, here
    assert f"wrote     {page.name} (" in p.stdout and "32 layers" in p.stdout
    text = page.read_text()
    assert text.startswith("<!doctype html>") and '"n_layers":32' in text
    assert "http://" not in text.replace("http://www.w3.org", "")
    assert "https://" not in text and "<script src" not in text


def test_console_script_help_describes_every_option_with_its_default():
    exe = Path(sys.executable).with_name("vecslice")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "vecslice"]
    top = subprocess.run([*cmd, "--help"], capture_output=True, text=True,
                         check=False, timeout=120)
    assert top.returncode == 0
    for name in ("slice", "info", "preview", "view", "examples:"):
        assert name in top.stdout
    sub = subprocess.run([*cmd, "slice", "--help"], capture_output=True, text=True,
                         check=False, timeout=120)
    assert sub.returncode == 0
    text = " ".join(sub.stdout.split())
    assert "Cura's" in text and "in mm" in text
    text = text[text.index("positional arguments:"):]  # past the usage line
    for opt in SLICE_OPTIONS:
        at = text.index(opt.flag + " ")
        nxt = text.find(" --", at + len(opt.flag) + 1)
        assert "default" in text[at:nxt if nxt > 0 else None], opt.flag
    for flag, default in (("--layer-height", "default 0.1)"),
                          ("--initial-layer-height", "default 0.3)"),
                          ("--max-resolution", "default 0.5)"),
                          ("--max-deviation", "default 0.025)"),
                          ("--minimum-polygon-circumference", "default 1)"),
                          ("--slicing-tolerance", "default middle)"),
                          ("--scale", "(default 1)"), ("--no-repair", "default:"),
                          ("--no-progress", "default: a bar on stderr")):
        assert flag in text and default in text[text.index(flag + " "):][:400], flag


# --- errors: exit 1 with one line, exit 2 for usage ---------------------------


def _only_error_line(p, fragment):
    assert p.returncode == 1, (p.stdout, p.stderr)
    err = p.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("vecslice: error: "), p.stderr
    assert fragment in err[0], err[0]


@pytest.mark.parametrize(("args", "fragment"), [
    (["missing.stl"], "not found: 'missing.stl'"),
    (["info", "missing.stl"], "not found: 'missing.stl'"),
    (["slice", "missing.stl", "--layer-height", "0.2"], "missing.stl"),
    (["--layer-height", "0"], "bad value for --layer-height: 0 mm (0 µm)"),
    (["--layer-height", "-0.1"], "bad value for --layer-height: -0.1 mm"),
    (["--layer-height", "nan"], "--layer-height must be a finite length in mm"),
    (["--max-deviation", "1e12"], "--max-deviation 1e+12 mm is out of range"),
    (["--max-layers", "0"], "bad value for --max-layers: 0: `max_layers`"),
    (["--adaptive-layers", "--adaptive-variation-step", "0"],
     "bad value for --adaptive-variation-step"),
    (["--scale", "2"], "--scale only applies to a model file"),
    (["preview", "missing.npz", "--layer", "0", "-o", "x.svg"], "does not exist"),
    (["view", "missing.npz"], "does not exist"),
    (["info", "."], "is a directory"),
])
def test_input_errors(tmp_path, args, fragment):
    p = run_cli(*args, cwd=tmp_path)
    _only_error_line(p, fragment)
    assert list(tmp_path.iterdir()) == []


def test_bad_scale_for_a_file(tmp_path):
    p = run_cli(mesh("plate_holes.STL"), "--scale", "-1", cwd=tmp_path)
    _only_error_line(p, "--scale must be a positive finite number (file units to "
                     "mm); got -1")


def test_garbage_mesh_file(tmp_path):
    (tmp_path / "bad.stl").write_bytes(b"solid nonsense\nthis is not an stl\n")
    p = run_cli("bad.stl", "-o", "bad.npz", cwd=tmp_path)
    _only_error_line(p, "bad.stl")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["bad.stl"]


def test_not_a_saved_model(tmp_path):
    (tmp_path / "x.npz").write_bytes(b"PK\x03\x04 not really a zip")
    for args in (["info", "x.npz"],
                 ["preview", "x.npz", "--layer", "0", "-o", "a.svg"]):
        _only_error_line(run_cli(*args, cwd=tmp_path), "'x.npz'")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["x.npz"]


@pytest.mark.parametrize("target", ["missing/out.npz", "adir", "file.txt/out.npz"])
def test_output_is_checked_before_slicing(tmp_path, target):
    (tmp_path / "adir").mkdir()
    (tmp_path / "file.txt").write_text("x")
    p = run_cli(mesh("plate_holes.STL"), "-o", target, cwd=tmp_path)
    _only_error_line(p, f"-o '{target}'")
    assert p.stdout == ""  # not even loaded
    assert sorted(f.name for f in tmp_path.iterdir()) == ["adir", "file.txt"]
    assert list((tmp_path / "adir").iterdir()) == []


def _box_and_model(tmp_path):
    """``x.stl`` (a 10 mm cube) and ``m.npz`` (the demo model) in ``tmp_path``."""
    import trimesh

    trimesh.creation.box((10, 10, 10)).export(tmp_path / "x.stl")
    vs.slice_mesh(vs.demo_mesh()).save(tmp_path / "m.npz")
    return {n: (tmp_path / n).read_bytes() for n in ("x.stl", "m.npz")}


@pytest.mark.parametrize(("args", "out", "source"), [
    (["x.stl", "-o", "x.stl"], "x.stl", "x.stl"),
    (["slice", "./x.stl", "-o", "x.stl"], "x.stl", "x.stl"),  # pathlib drops ./
    (["slice", "x.stl", "-o", "../{here}/x.stl"], "../{here}/x.stl", "x.stl"),
    (["x.stl", "-o", "hard.npz"], "hard.npz", "x.stl"),
    (["x.stl", "-o", "soft.npz"], "soft.npz", "x.stl"),
    (["view", "m.npz", "-o", "m.npz"], "m.npz", "m.npz"),
    (["view", "x.stl", "-o", "x.stl"], "x.stl", "x.stl"),
    (["view", "m.npz", "-o", "page.html"], "page.html", "m.npz"),
    (["preview", "m.npz", "--layer", "0", "-o", "pic.svg"], "pic.svg", "m.npz"),
    (["preview", "x.stl", "--layer", "0", "-o", "pic.png"], "pic.png", "x.stl"),
])  # fmt: skip
def test_output_never_overwrites_the_input(tmp_path, args, out, source):
    """Audit s23 D3: ``-o`` naming the input (or a link to it) destroyed it."""
    before = _box_and_model(tmp_path)
    os.link(tmp_path / "x.stl", tmp_path / "hard.npz")
    (tmp_path / "soft.npz").symlink_to("x.stl")
    target = "m.npz" if "m.npz" in args else "x.stl"
    for name in ("page.html", "pic.svg", "pic.png"):
        (tmp_path / name).symlink_to(target)
    args = [a.replace("{here}", tmp_path.name) for a in args]
    out = out.replace("{here}", tmp_path.name)
    p = run_cli(*args, cwd=tmp_path)
    _only_error_line(p, f"-o '{out}' is the input file '{source}': vecslice never "
                     "overwrites its input")
    assert p.stdout == ""  # refused before any work
    assert {n: (tmp_path / n).read_bytes() for n in before} == before
    assert len(os.listdir(tmp_path)) == 7  # no temporary file


def test_view_output_must_be_a_web_page(tmp_path):
    """Audit s23 D3: ``view -o`` had no suffix check (``preview -o`` has one)."""
    _box_and_model(tmp_path)
    (tmp_path / "old.npz").write_bytes(b"another model")
    p = run_cli("view", "m.npz", "-o", "old.npz", cwd=tmp_path)
    _only_error_line(p, "-o must name a .html or .htm file; got 'old.npz'")
    assert (tmp_path / "old.npz").read_bytes() == b"another model"
    p = run_cli("view", "m.npz", "-o", "page.HTM", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "page.HTM").read_text().startswith("<!doctype html>")


@pytest.mark.parametrize("command", ["slice", "view", "preview"])
def test_output_onto_a_fifo_or_read_only_file_is_refused(tmp_path, command):
    """Audit s23 D4, D13: ``-o`` replaced a FIFO (or a device) by a regular file,
    and silently replaced a read-only file."""
    _box_and_model(tmp_path)
    suffix = {"slice": ".npz", "view": ".html", "preview": ".svg"}[command]
    fifo, ro = tmp_path / f"fifo{suffix}", tmp_path / f"ro{suffix}"
    os.mkfifo(fifo)
    ro.write_bytes(b"keep")
    ro.chmod(0o444)
    extra = ["--layer", "0"] if command == "preview" else []
    for out, fragment in ((fifo, "it is a FIFO (named pipe), not a regular file"),
                          (ro, "it is read-only (mode 0444)")):
        p = run_cli(command, "x.stl", *extra, "-o", out.name, cwd=tmp_path,
                    timeout=60)
        _only_error_line(p, f"-o '{out.name}': {fragment}")
        assert p.stdout == ""  # before any work
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and ro.read_bytes() == b"keep"
    assert len(os.listdir(tmp_path)) == 4


def test_info_on_a_fifo_or_device_does_not_hang(tmp_path):
    """Audit s23 D5: ``vecslice info fifo.npz`` blocked forever."""
    os.mkfifo(tmp_path / "fifo.npz")
    (tmp_path / "zero.npz").symlink_to("/dev/zero")
    for name, kind in (("fifo.npz", "a FIFO (named pipe)"),
                       ("zero.npz", "a character device")):
        p = run_cli("info", name, cwd=tmp_path, timeout=60)
        _only_error_line(p, f"'{name}' is {kind}, not a regular file")


def test_preview_errors(tmp_path):
    vs.slice_mesh(vs.demo_mesh()).save(tmp_path / "d.npz")
    cases = [
        (["--layer", "148", "-o", "a.svg"],
         "--layer must be a layer index from 0 to 147"),
        (["--layer", "-149", "-o", "a.svg"], "got -149"),
        (["--z", "15.5", "-o", "a.svg"], "--z must be a height from 0 to 15 mm"),
        (["--z", "-1", "-o", "a.svg"], "got -1"),
        (["--layer", "0", "-o", "a.jpg"], "-o must name a .png or .svg file"),
        (["--layer", "0", "-o", "a.svg", "--layer-height", "0.2"],
         "--layer-height applies to a mesh file"),
    ]
    for args, fragment in cases:
        _only_error_line(run_cli("preview", "d.npz", *args, cwd=tmp_path), fragment)
    assert sorted(f.name for f in tmp_path.iterdir()) == ["d.npz"]


def test_png_preview_without_matplotlib_names_the_extra(tmp_path):
    vs.slice_mesh(vs.demo_mesh()).save(tmp_path / "d.npz")
    code = ("import sys; sys.modules['matplotlib'] = None; "
            "from vecslice.cli import main; "
            "sys.exit(main(['preview', 'd.npz', '--layer', '3', '-o', 'a.png']))")
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, text=True,
                       capture_output=True, check=False, timeout=120)
    _only_error_line(p, "pip install 'vecslice[plot]'")
    assert not (tmp_path / "a.png").exists()
    # the SVG needs no matplotlib
    code = code.replace("a.png", "a.svg")
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, text=True,
                       capture_output=True, check=False, timeout=120)
    assert p.returncode == 0 and (tmp_path / "a.svg").exists()


@pytest.mark.parametrize(("args", "fragment"), [
    (["--layer-height", "abc"], "invalid float value: 'abc'"),
    (["--slicing-tolerance", "sideways"], "invalid choice: 'sideways'"),
    (["--max-layers", "1.5"], "invalid int value: '1.5'"),
    (["--frobnicate"], "unrecognized arguments: --frobnicate"),
    (["preview", "x.npz", "-o", "a.png"],
     "one of the arguments --layer --z is required"),
    (["preview", "x.npz", "--layer", "1", "--z", "1", "-o", "a.png"],
     "not allowed with"),
    (["preview", "x.npz", "--layer", "1"], "the following arguments are required: -o"),
    (["info"], "the following arguments are required: FILE"),
])
def test_usage_errors_exit_2(tmp_path, args, fragment):
    p = run_cli(*args, cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    assert "usage: vecslice" in p.stderr and fragment in p.stderr


def test_python_m_vecslice_cli_also_works(tmp_path):
    p = run_cli("--version", cwd=tmp_path, module="vecslice.cli")
    assert p.returncode == 0 and p.stdout.strip() == f"vecslice {vs.__version__}"


def _stderr_on_a_terminal(args, cwd):
    """Run with stderr on a pseudo-terminal; return what it showed."""
    import fcntl
    import pty
    import struct
    import termios

    leader, follower = pty.openpty()
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "vecslice", *args], cwd=cwd,
                            stdout=subprocess.PIPE, stderr=follower)
    os.close(follower)
    chunks = []
    while True:
        try:
            data = os.read(leader, 4096)
        except OSError:  # the terminal closed
            break
        if not data:
            break
        chunks.append(data)
    proc.communicate(timeout=300)
    os.close(leader)
    assert proc.returncode == 0
    return b"".join(chunks).decode(errors="replace")


def test_progress_bar_only_on_a_terminal(tmp_path):
    shown = _stderr_on_a_terminal([], tmp_path)
    assert "stage" in shown and "7/7" in shown  # tqdm's bar over the 7 stages
    assert "stage" not in _stderr_on_a_terminal(["--no-progress"], tmp_path)

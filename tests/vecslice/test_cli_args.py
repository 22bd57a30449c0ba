"""How the ``vecslice`` command reads its arguments (audit s24), run in-process.

``main([...])`` returns the exit status; what it prints is read with ``capsys``.
"""

import errno
import os
import subprocess
import sys

import pytest

import vecslice as vs
from vecslice.cli import main


@pytest.fixture
def cube(tmp_path, monkeypatch):
    """``cube.stl`` (a 10 mm cube) in ``tmp_path``, the current directory."""
    import trimesh

    monkeypatch.chdir(tmp_path)
    trimesh.creation.box((10, 10, 10)).export(tmp_path / "cube.stl")
    return tmp_path / "cube.stl"


def run(capsys, *args):
    """``(exit status, stdout, stderr)`` of ``vecslice ARGS``."""
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert "Traceback" not in err, err
    return code, out, err


def error_line(capsys, *args, code=1, before_work=True):
    """The one line ``vecslice: error: ...`` of a failed run (by default refused
    before any work: nothing on stdout)."""
    got, out, err = run(capsys, *args)
    assert got == code, (out, err)
    lines = err.strip().splitlines()
    assert lines[-1].startswith("vecslice") and ": error: " in lines[-1], err
    if code == 1:
        assert len(lines) == 1 and (out == "" or not before_work), (out, err)
    return lines[-1]


# --- D1: no abbreviated options -----------------------------------------------


@pytest.mark.parametrize(("args", "typed"), [
    (["slice", "cube.stl", "--layer", "10"], "--layer"),
    (["cube.stl", "--layer", "10"], "--layer"),
    (["view", "cube.stl", "--layer", "10", "-o", "c.html"], "--layer"),
    (["cube.stl", "--initial", "1"], "--initial"),
    (["cube.stl", "--no-r"], "--no-r"),
    (["cube.stl", "--even"], "--even"),
    (["info", "cube.stl", "--sc", "2"], "--sc"),
    (["preview", "cube.stl", "--layer", "0", "--z-", "1", "-o", "c.svg"], "--z-"),
    (["--vers"], "--vers"),
])  # fmt: skip
def test_an_abbreviated_option_is_an_error_naming_it(capsys, cube, args, typed):
    """Audit s24 D1: ``view MODEL --layer 10`` sliced with 10 mm layers."""
    line = error_line(capsys, *args, code=2)
    assert "unrecognized arguments: " in line and typed in line.split(": ")[-1]
    assert sorted(p.name for p in cube.parent.iterdir()) == ["cube.stl"]


# --- D2: what `slice -o` may name; D7: empty arguments ------------------------


def test_slice_output_must_be_an_npz_file(capsys, cube):
    """Audit s24 D2: ``slice -o other.stl`` replaced a mesh by a zip archive."""
    other = cube.parent / "other.stl"
    other.write_bytes(b"solid the user's mesh\nendsolid\n")
    for name in ("other.stl", "model", "page.html"):
        line = error_line(capsys, "cube.stl", "-o", name)
        assert line == f"vecslice: error: -o must name a .npz file; got '{name}'"
    assert other.read_bytes() == b"solid the user's mesh\nendsolid\n"
    assert sorted(p.name for p in cube.parent.iterdir()) == ["cube.stl", "other.stl"]
    code, out, _ = run(capsys, "cube.stl", "-o", "CUBE.NPZ")  # any case
    assert code == 0 and "saved     CUBE.NPZ (" in out


@pytest.mark.parametrize("target", ["results/", "results.npz/", "results.npz/.",
                                    "sub/..", "."])
def test_output_naming_a_directory_is_refused(capsys, cube, target):
    """Audit s24 D2: ``-o results/`` wrote a file named ``results``."""
    (cube.parent / "sub").mkdir()
    for args in (["cube.stl"], ["view", "cube.stl"],
                 ["preview", "cube.stl", "--layer", "0"]):
        line = error_line(capsys, *args, "-o", target)
        assert line == (f"vecslice: error: -o '{target}' names a directory, not a "
                        "file; give a file name")
    assert sorted(p.name for p in cube.parent.iterdir()) == ["cube.stl", "sub"]


def test_output_that_is_a_directory_is_said_to_be_one(capsys, cube):
    (cube.parent / "sub").mkdir()
    for args in (["cube.stl"], ["view", "cube.stl"],
                 ["preview", "cube.stl", "--layer", "0"]):
        line = error_line(capsys, *args, "-o", "sub")
        assert line == "vecslice: error: -o 'sub' is a directory; give a file name"


@pytest.mark.parametrize(("args", "flag"), [
    (["view", ""], "FILE"),
    (["info", ""], "FILE"),
    (["preview", "", "--layer", "0", "-o", "a.svg"], "FILE"),
    (["slice", ""], "MODEL"),
    ([""], "MODEL"),
    (["cube.stl", "-o", ""], "-o"),
    (["view", "cube.stl", "-o", ""], "-o"),
])  # fmt: skip
def test_an_empty_argument_is_said_to_be_empty(capsys, cube, args, flag):
    """Audit s24 D7: ``view ''`` complained about ``-o '.html'``, ``info ''``
    about the directory ``'.'``."""
    line = error_line(capsys, *args)
    assert line == f"vecslice: error: {flag} is an empty string; give a file name"
    assert sorted(p.name for p in cube.parent.iterdir()) == ["cube.stl"]


# --- D4: file names that are not UTF-8 ----------------------------------------


def _vecslice(*args, cwd, encoding):
    """``python -m vecslice ARGS`` with stdout and stderr in ``encoding`` (strict)."""
    env = {**os.environ, "PYTHONIOENCODING": encoding}
    proc = subprocess.run([sys.executable, "-m", "vecslice", *args], cwd=cwd,
                          capture_output=True, check=False, timeout=300, env=env)
    err = proc.stderr.decode("ascii")  # escaped, whatever the name
    assert "Traceback" not in err, err
    return proc.returncode, proc.stdout.decode("ascii"), err


@pytest.mark.parametrize(("raw", "encoding"), [
    (b"caf\xe9", "utf-8"),  # Latin-1 bytes: surrogates in Python
    ("café".encode(), "ascii"),  # valid UTF-8, on an ASCII terminal
])
def test_a_file_name_that_the_terminal_cannot_show(tmp_path, raw, encoding):
    """Audit s24 D4: ``view`` always, and ``info``/``slice`` under a strict stdout
    (``PYTHONIOENCODING=utf-8``, any UTF-8 locale but C), ended in a traceback, after
    the slice (which was lost)."""
    import trimesh

    stl = os.fsdecode(raw + b".stl")
    trimesh.creation.box((10, 10, 10)).export(tmp_path / stl)
    shown = r"caf\xe9"  # the bytes' escape, in both cases
    code, out, err = _vecslice("info", stl, cwd=tmp_path, encoding=encoding)
    assert code == 0, err
    assert f"file                {shown}.stl\n" in out
    assert f"source              {shown}.stl\n" in out
    code, out, err = _vecslice(stl, "-o", os.fsdecode(raw + b".npz"), cwd=tmp_path,
                               encoding=encoding)
    assert code == 0, err
    assert f"model     {shown}.stl: 12 faces" in out
    assert f"saved     {shown}.npz (" in out
    code, out, err = _vecslice("view", stl, cwd=tmp_path, encoding=encoding)
    assert code == 0, err
    assert f"wrote     {shown}.html (" in out
    page = (tmp_path / os.fsdecode(raw + b".html")).read_text(encoding="utf-8")
    title = raw.decode("utf-8", "backslashreplace")  # café, or caf\xe9 escaped
    assert f"<title>{title}.stl - vecslice layer viewer</title>" in page
    code, out, err = _vecslice("preview", os.fsdecode(raw + b".npz"), "--layer",
                               "-1", "-o", os.fsdecode(raw + b".svg"), cwd=tmp_path,
                               encoding=encoding)
    assert code == 0, err
    assert out.endswith(f"-> {shown}.svg\n")
    # errors too: one line, the same form of the name
    code, out, err = _vecslice("view", stl, "-o", stl, cwd=tmp_path,
                               encoding=encoding)
    assert code == 1 and err == (f"vecslice: error: -o '{shown}.stl' is the input "
                                 f"file '{shown}.stl': vecslice never overwrites "
                                 "its input; choose another output name\n")


# --- D5: options that would do nothing ----------------------------------------


@pytest.mark.parametrize(("args", "line"), [
    (["cube.stl", "--adaptive-variation", "0.05"],
     "--adaptive-variation only applies with --adaptive-layers; got 0.05 without it"),
    (["cube.stl", "--adaptive-variation-step", "0.05", "--adaptive-threshold", "5"],
     "--adaptive-variation-step only applies with --adaptive-layers; got 0.05 "
     "without it"),
    (["view", "cube.stl", "--adaptive-threshold", "-0.5"],
     "--adaptive-threshold only applies with --adaptive-layers; got -0.5 without it"),
    (["preview", "cube.stl", "--layer", "0", "-o", "a.svg", "--adaptive-threshold",
      "5"], "--adaptive-threshold only applies with --adaptive-layers"),
    (["--no-repair"], "--no-repair only applies to a model file; got it without one"),
    (["slice", "--no-repair", "-o", "demo.npz"], "--no-repair only applies to a "
     "model file"),
])  # fmt: skip
def test_options_that_would_do_nothing_are_refused(capsys, cube, args, line):
    """Audit s24 D5: the adaptive options without ``--adaptive-layers``, and
    ``--no-repair`` on the demo model, were accepted and ignored."""
    assert error_line(capsys, *args).startswith(f"vecslice: error: {line}")
    assert sorted(p.name for p in cube.parent.iterdir()) == ["cube.stl"]


def test_adaptive_options_apply_with_adaptive_layers(capsys, cube):
    code, out, err = run(capsys, "cube.stl", "--adaptive-layers",
                         "--adaptive-variation", "0.05", "--adaptive-threshold",
                         "0.1", "-o", "a.npz")
    assert code == 0, err
    want = vs.slice_mesh(vs.load_mesh(cube), vs.SliceSettings(
        adaptive_layers=True, adaptive_variation=50, adaptive_threshold=100))
    assert (vs.load_sliced(cube.parent / "a.npz").thickness == want.thickness).all()


# --- D6: a failed write names the output and what it is -----------------------


class _FullDisk:
    """A file whose writes fail as on a full disk (delegates everything else)."""

    def __init__(self, fh):
        self._fh = fh

    def write(self, data):
        raise OSError(errno.EFBIG, os.strerror(errno.EFBIG))

    def __getattr__(self, name):
        return getattr(self._fh, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._fh.close()


@pytest.mark.parametrize(("out", "what"), [
    ("layer.png", "a PNG picture"), ("layer.svg", "an SVG picture"),
    ("page.html", "a layer viewer page"), ("m.npz", "a vecslice model"),
])  # fmt: skip
def test_a_failed_write_names_the_output(capsys, cube, monkeypatch, out, what):
    """Audit s24 D6: ``preview -o layer.png`` said ``cannot write
    <_io.BufferedWriter name=3>``, and SVG or page writes "a vecslice model"."""
    if out.endswith(".png"):
        pytest.importorskip("matplotlib")
    fdopen = os.fdopen
    monkeypatch.setattr(os, "fdopen", lambda *a, **k: _FullDisk(fdopen(*a, **k)))
    command = {"png": ["preview", "--layer", "0"], "svg": ["preview", "--layer", "0"],
               "html": ["view"], "npz": ["slice"]}[out.rsplit(".", 1)[1]]
    line = error_line(capsys, command[0], "cube.stl", *command[1:], "-o", out,
                      before_work=False)
    assert line == f"vecslice: error: cannot save {what} to '{out}': File too large"
    assert os.listdir() == ["cube.stl"]  # no temporary file left


# --- D7: messages in command-line terms ---------------------------------------


def test_max_layers_message_names_the_option(capsys, cube):
    """Audit s24 D7: the hint was ``SliceSettings(max_layers=298)``."""
    line = error_line(capsys, "cube.stl", "--max-layers", "50", before_work=False)
    assert line == ("vecslice: error: the slice has more layers than --max-layers 50 "
                    "allows (up to 98). Memory and time grow with the layers; if "
                    "this is intended, raise the limit: --max-layers 98 or more")
    code, out, err = run(capsys, "cube.stl", "--max-layers", "98")
    assert code == 0 and "layers    98," in out, err
    # adaptive layers stop at the limit: the hint is enough for any schedule
    line = error_line(capsys, "cube.stl", "--adaptive-layers", "--max-layers", "20",
                      before_work=False)
    assert "more layers than --max-layers 20 allows (up to " in line
    assert "SliceSettings" not in line and "`max_layers`" not in line
    need = line.rsplit("--max-layers ", 1)[1].split()[0]
    code, out, err = run(capsys, "cube.stl", "--adaptive-layers", "--max-layers",
                         need)
    assert code == 0, err


def test_compat_cura_on_another_file_type(capsys, cube):
    """Audit s24 D7: the message said ``compat='vecslice'``, "or pass a trimesh
    object"."""
    import trimesh

    trimesh.creation.box((10, 10, 10)).export(cube.parent / "cube.obj")
    line = error_line(capsys, "cube.obj", "--compat", "cura")
    assert line == ("vecslice: error: --compat cura reads STL files only (CuraEngine's "
                    "own reader); got 'cube.obj': slice it with --compat vecslice "
                    "(the default)")
    code, out, err = run(capsys, "cube.obj", "--compat", "vecslice")
    assert code == 0, err


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "-inf", "-2e-3"])
def test_scale_message_names_the_option(capsys, cube, value):
    """Audit s24 D7: the message named `` `scale` ``, not ``--scale``."""
    for command in (["slice"], ["info"], ["view"]):
        line = error_line(capsys, *command, "cube.stl", "--scale", value)
        assert line == ("vecslice: error: --scale must be a positive finite number "
                        f"(file units to mm); got {float(value):g}")
    assert os.listdir() == ["cube.stl"]


def test_out_of_range_length_says_the_value_once(capsys, cube):
    """Audit s24 D7: "--layer-height 2e+06 mm is out of range: `--layer-height`
    must be below ... got 2000000.0 mm at flat index 0"."""
    line = error_line(capsys, "cube.stl", "--layer-height", "2e6")
    assert line == ("vecslice: error: --layer-height 2e+06 mm is out of range: it "
                    "must be below 1.07374e+06 mm in magnitude (2**30 µm)")


@pytest.mark.parametrize(("value", "um"), [
    ("-5e-1", -500), ("-1E-1", -100), ("-.25", -250), ("-5.", -5000), ("-1e+0", -1000),
])
def test_negative_values_in_any_float_form(capsys, cube, value, um):
    """Audit s24 D7: ``--adaptive-threshold -5e-1`` was "expected one argument"
    (argparse took the value for an option); ``-0.5`` worked."""
    for args in (["cube.stl"], ["slice", "cube.stl"]):
        code, out, err = run(capsys, *args, "--adaptive-layers",
                             "--adaptive-threshold", value, "-o", "t.npz")
        assert code == 0, err
        want = vs.slice_mesh(vs.load_mesh(cube), vs.SliceSettings(
            adaptive_layers=True, adaptive_threshold=um))
        assert (vs.load_sliced("t.npz").thickness == want.thickness).all()


@pytest.mark.parametrize(("args", "line"), [
    (["--layer-height", "-inf"], "--layer-height must be a finite length in mm; "
     "got -inf"),
    (["--layer-height", "-1e-1"], "bad value for --layer-height: -0.1 mm (-100 µm)"),
    (["--max-deviation", "-1E+9"], "--max-deviation -1e+09 mm is out of range"),
    (["--scale", "-1e3"], "--scale must be a positive finite number"),
    (["--scale", "-INF"], "--scale must be a positive finite number"),
])  # fmt: skip
def test_negative_values_reach_the_value_checks(capsys, cube, args, line):
    assert error_line(capsys, "cube.stl", *args).startswith(
        f"vecslice: error: {line}")
    assert error_line(capsys, "preview", "cube.stl", "--z", "-1e-3", "-o",
                      "a.svg", before_work=False).startswith(
        "vecslice: error: --z must be a height from 0 to")


# --- D8: -o through a dangling symbolic link ----------------------------------


@pytest.mark.parametrize("command", [["slice"], ["view"], ["preview", "--layer", "0"]])
def test_dangling_link_into_a_missing_directory_is_refused_first(capsys, cube,
                                                                 command):
    """Audit s24 D8: the whole slice ran before the save failed."""
    out = {"slice": "out.npz", "view": "out.html", "preview": "out.svg"}[command[0]]
    os.symlink("/nonexistent/dir/" + out, out)
    line = error_line(capsys, command[0], "cube.stl", *command[1:], "-o", out)
    assert line == (f"vecslice: error: -o '{out}': it is a symbolic link to "
                    f"'/nonexistent/dir/{out}', whose directory '/nonexistent/dir' "
                    "does not exist")
    assert sorted(os.listdir()) == ["cube.stl", out]


# --- D9: lengths converted from the decimal typed ------------------------------


def _settings(*args):
    from vecslice.cli import build_parser, settings_from_args

    return settings_from_args(build_parser().parse_args(["slice", *args]))


@pytest.mark.parametrize(("flag", "setting"), [
    ("--layer-height", "layer_height"), ("--max-deviation", "max_deviation"),
    ("--initial-layer-height", "initial_layer_height"),
])  # fmt: skip
@pytest.mark.parametrize(("text", "um"), [
    ("0.5005", 501), ("0.5015", 502), ("0.0255", 26), ("0.1005", 101), ("0.1", 100),
    ("0.0625", 63), ("0.2", 200), ("1e-1", 100), ("0.5004999999", 500),
    ("0.50049999999999999999999999999999", 500), ("2.5e-3", 3),
    ("1_000.0005", 1_000_001),
])  # fmt: skip
def test_lengths_round_half_away_from_zero_exactly(flag, setting, text, um):
    """Audit s24 D9: ``0.5005`` gave 500 µm (the float just below 0.5005 was
    rounded), ``0.0255`` 26."""
    assert getattr(_settings(flag, text), setting) == um


@pytest.mark.parametrize(("text", "um"), [
    ("-0.5005", -501), ("-0.0255", -26), ("-0.0005", -1), ("-0.0004999", 0),
    ("-0", 0), ("0.0005", 1), ("-1e-1", -100), ("-1.2345", -1235),
])  # fmt: skip
def test_negative_lengths_round_half_away_from_zero(text, um):
    got = _settings("--adaptive-layers", "--adaptive-threshold", text)
    assert got.adaptive_threshold == um


def _mm2int(text):
    """CuraEngine's MM2INT(atof(text)), written out from spec/CURA_COMPAT.md."""
    x = float(text)
    return int(x * 1000 + (0.5 if x > 0 else -0.5 if x < 0 else 0.0))


@pytest.mark.parametrize(("text", "um"), [
    # (the doubles of 0.5005 and 0.5015 lie just below them: the typed decimal
    # rounds to 501 and 502 µm, CuraEngine's float64 MM2INT to 500 and 501)
    ("0.5005", 500), ("0.5015", 501), ("0.0255", 26), ("0.1005", 101), ("0.1", 100),
    ("0.0625", 63), ("-0.5005", -500), ("-0.0255", -26), ("0", 0), ("1e-1", 100),
])  # fmt: skip
def test_compat_cura_reads_lengths_as_curaengine(text, um):
    """Audit s26 adaptive D5: with --compat cura, a typed length is the µm value
    CuraEngine's MM2INT gives it, so the same millimetres give Cura's schedule."""
    assert _mm2int(text) == um
    got = _settings("--compat", "cura", "--adaptive-layers", "--adaptive-threshold",
                    text)
    assert got.adaptive_threshold == um and got.compat == "cura"
    if not text.startswith("-") and text != "0":
        assert _settings("--compat", "cura", "--layer-height", text).layer_height == um


def test_first_layer_of_a_half_micron_length(capsys, cube):
    code, out, err = run(capsys, "cube.stl", "--initial-layer-height", "0.5005",
                         "--layer-height", "0.0255", "-o", "c.npz")
    assert code == 0, err
    model = vs.load_sliced("c.npz")
    assert model.thickness[0] == 501 and set(model.thickness[1:].tolist()) == {26}
    assert "z 0.501 to " in out


@pytest.mark.parametrize(("text", "line"), [
    ("nan", "--layer-height must be a finite length in mm; got nan"),
    ("-NaN", "--layer-height must be a finite length in mm; got nan"),
    ("inf", "--layer-height must be a finite length in mm; got inf"),
    ("1e400", "--layer-height 1e+400 mm is out of range: it must be below "
     "1.07374e+06 mm in magnitude (2**30 µm)"),
    ("1073741.8235", "--layer-height 1.07374e+06 mm is out of range"),
    ("-1073741.8235", "--layer-height -1.07374e+06 mm is out of range"),
    ("1e-400", "bad value for --layer-height: 1e-400 mm (0 µm)"),
    ("0.0004999", "bad value for --layer-height: 0.0004999 mm (0 µm)"),
])  # fmt: skip
def test_bad_lengths_keep_their_messages(capsys, cube, text, line):
    assert error_line(capsys, "cube.stl", "--layer-height", text).startswith(
        f"vecslice: error: {line}")


def test_largest_length_in_range():
    # 2**30 - 1 µm = 1073741.823 mm; .8235 would round to 2**30
    assert _settings("--max-resolution", "1073741.8234").max_resolution == 2**30 - 1


@pytest.mark.parametrize("text", ["abc", "0x10", "", "1,5", "snan"])
def test_what_float_does_not_read_is_a_usage_error(capsys, cube, text):
    line = error_line(capsys, "cube.stl", "--layer-height", text, code=2)
    assert line.endswith(f"argument --layer-height: invalid float value: {text!r}")


def test_z_is_compared_in_microns(capsys, cube):
    """``--z`` is a length too: the top of a layer, typed as printed, is found."""
    code, _, err = run(capsys, "cube.stl", "--layer-height", "0.3", "-o", "c.npz")
    assert code == 0, err
    model = vs.load_sliced("c.npz")
    top = model.print_z[-1] / 1000  # 9.9 mm: 9.899999999999999 as a float
    for z, k in (("0", 0), ("-0", 0), ("0.3", 0), ("0.3005", 1), ("0.6", 1),
                 (f"{top:g}", model.n_layers - 1)):
        code, out, err = run(capsys, "preview", "c.npz", "--z", z, "-o", "a.svg")
        assert code == 0 and out.startswith(f"layer {k} of "), (z, out, err)
    for z in ("-0.0001", f"{top + 0.001:g}", "nan", "-inf", "1e400"):
        line = error_line(capsys, "preview", "c.npz", "--z", z, "-o", "a.svg")
        assert line.startswith(f"vecslice: error: --z must be a height from 0 to "
                               f"{top:g} mm (the top of the last layer); got ")


# --- audit s26: a slice too large for memory is one line, not a traceback -----


def test_out_of_memory_is_one_line(capsys, cube, monkeypatch):
    import numpy as np

    import vecslice.pipeline

    def huge(*args, **kwargs):
        # what the contour stage meets with a billion-point slice: numpy's own
        # MemoryError for an allocation far beyond the machine
        return np.empty((2**45, 2), dtype=np.int64)

    monkeypatch.setattr(vecslice.pipeline, "slice_mesh", huge)
    line = error_line(capsys, "cube.stl", "-o", "c.npz", before_work=False)
    assert "not enough memory" in line and "TiB" in line and "--layer-height" in line
    assert not (cube.parent / "c.npz").exists()

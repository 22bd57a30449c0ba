"""How the ``vecslice`` command reads its arguments (audit s24), run in-process.

``main([...])`` returns the exit status; what it prints is read with ``capsys``.
"""

import pytest

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


def error_line(capsys, *args, code=1):
    """The one line ``vecslice: error: ...`` of a refused run (nothing on stdout)."""
    got, out, err = run(capsys, *args)
    assert got == code, (out, err)
    lines = err.strip().splitlines()
    assert lines[-1].startswith("vecslice") and ": error: " in lines[-1], err
    if code == 1:
        assert len(lines) == 1 and out == "", (out, err)
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

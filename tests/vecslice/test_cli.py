import subprocess
import sys

import numpy as np
import pytest

import vecslice as vs
from conftest import MESHES
from vecslice.cli import main


def test_demo_model_without_arguments(capsys):
    assert main(["--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "built-in demo model" in out and "SlicedModel(" in out and "time:" in out


def test_slice_a_file_and_save(tmp_path, capsys):
    path = MESHES / "featuretype.STL"
    if not path.exists():
        pytest.skip(f"{path} not found")
    out = tmp_path / "feature.npz"
    assert main([str(path), "--scale", "25.4", "--layer-height", "200",
                 "-o", str(out), "--no-progress"]) == 0
    model = vs.load_sliced(out)
    # first layer 300 µm (sliced at 150), then 200 µm layers sliced at their middle
    assert model.n_layers == 174 and (np.diff(model.slice_z)[1:] == 200).all()
    assert "saved" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["missing.stl"], "missing.stl"),
        (["--layer-height", "0"], "`layer_height` must be >= 1; got 0"),
        (["--scale", "-1"], "`scale` only applies to a model file"),
    ],
)
def test_errors_exit_2_with_a_message_and_leave_no_output(tmp_path, capsys, args,
                                                          fragment):
    out = tmp_path / "out.npz"
    assert main([*args, "-o", str(out), "--no-progress"]) == 2
    assert fragment in capsys.readouterr().err
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_garbage_file_leaves_nothing_behind(tmp_path, capsys):
    bad = tmp_path / "bad.stl"
    bad.write_bytes(b"solid nonsense\nthis is not an stl\n")
    out = tmp_path / "bad.npz"
    assert main([str(bad), "-o", str(out), "--no-progress"]) == 2
    assert "bad.stl" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.stl"]


def test_console_script_entry_point():
    proc = subprocess.run([sys.executable, "-m", "vecslice.cli", "--help"],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0 and "--layer-height" in proc.stdout


def test_bad_scale_for_a_file(tmp_path, capsys):
    path = MESHES / "featuretype.STL"
    if not path.exists():
        pytest.skip(f"{path} not found")
    out = tmp_path / "x.npz"
    assert main([str(path), "--scale", "-1", "-o", str(out), "--no-progress"]) == 2
    assert "`scale`" in capsys.readouterr().err and not out.exists()

import io
import os
from dataclasses import dataclass
from pathlib import Path

import numba
import pytest

import vecslice as vs
from vecslice._cli_support import (
    COMPILE_MESSAGE,
    CliInputError,
    CompileNotice,
    check_output,
    load_info_lines,
    mm_to_microns,
    mm_value,
    say,
    shown,
    size_hint,
)
from vecslice._kernels import _jit
from vecslice.meshcheck import LoadInfo


def test_compile_notice_says_it_once_for_a_real_compile():
    err = io.StringIO()
    with CompileNotice(err) as notice:
        assert notice._ready in _jit.compile_listeners
        numba.njit(lambda x: x + 1)(1)  # an uncached function: a real compile
        numba.njit(lambda x: x + 2)(1)
    assert err.getvalue().count(COMPILE_MESSAGE) == 1
    assert "compiled kernels in" in err.getvalue()
    assert notice._ready not in _jit.compile_listeners
    seen = notice.compiled
    numba.njit(lambda x: x + 3)(1)  # numba's listener is gone too
    assert notice.compiled == seen


def test_compile_notice_is_silent_without_compiling():
    err = io.StringIO()
    with CompileNotice(err):
        vs.slice_mesh(vs.demo_mesh())  # kernels already compiled in this process
    assert err.getvalue() == ""


def test_compile_seconds_count_the_outermost_kernels_only():
    notice = CompileNotice(io.StringIO())
    for event, name, s in [("start", "a", 0), ("start", "b", 0), ("end", "b", 1.0),
                           ("end", "a", 3.0), ("start", "c", 0), ("end", "c", 0.5)]:
        notice._ready(event, name, s)
    assert notice.seconds == 3.5


def test_load_info_lines_report_every_nonzero_count():
    assert load_info_lines(None) == []
    assert load_info_lines(LoadInfo("x.stl", 10, 30)) == []
    info = LoadInfo("x.stl", 2146, 6438, vertices_merged=5363, faces_flipped=1622,
                    faces_duplicate=2)
    assert load_info_lines(info) == [
        "cleaned   5,363 vertices merged (same position)",
        "repaired  2 duplicate faces removed, 1,622 faces flipped",
    ]

    assert load_info_lines(LoadInfo("x.stl", 1, 3, vertices_merged=1, faces_flipped=1,
                                    faces_degenerate=2)) == [
        "cleaned   1 vertex merged (same position), 2 degenerate faces dropped",
        "repaired  1 face flipped",
    ]
    shells = LoadInfo("x.stl", 1, 3, shells_reversed=2, cavities_kept=1)
    assert load_info_lines(shells) == ["repaired  2 shells reversed, 1 cavity kept"]
    # compat="cura" melds vertices within 30 µm: not "same position"
    assert load_info_lines(info, melded=True)[0] == (
        "cleaned   5,363 vertices melded (within 30 µm, as CuraEngine)")

    @dataclass(frozen=True)
    class Newer(LoadInfo):  # a later repair step adds counts: reported by name
        holes_filled: int = 0

    newer = Newer("x.stl", 1, 3, holes_filled=3, cavities_kept=2)
    assert load_info_lines(newer) == ["repaired  2 cavities kept, 3 holes filled"]


def test_size_hints():
    assert size_hint([20.0, 30.0, 10.0], False) is None
    assert size_hint([0.034, 0.034, 0.07], False) == (
        "the model is only 0.034 x 0.034 x 0.070 mm; if the file is in metres, "
        "add --scale 1000")
    assert "--scale" not in size_hint([0.034, 0.034, 0.07], True)
    assert "--scale 0.001" in size_hint([20000.0, 3.0, 1.0], False)


def test_check_output(tmp_path):
    assert check_output(None) is None
    assert check_output(tmp_path / "a.npz") == tmp_path / "a.npz"
    assert check_output(Path("relative.npz")) == Path("relative.npz")
    (tmp_path / "f").write_text("x")
    for bad, match in [(tmp_path, "is a directory"),
                       (tmp_path / "no" / "a.npz", "does not exist"),
                       (tmp_path / "f" / "a.npz", "is not a directory")]:
        with pytest.raises(CliInputError, match=match):
            check_output(bad)
    with pytest.raises(vs.InputValueError, match=r"-o must name a .png or .svg"):
        check_output(tmp_path / "a.jpg", (".png", ".svg"))


def test_check_output_refuses_the_input_and_special_files(tmp_path):
    """Audit s23 D3, D4: ``-o`` could name the input, a FIFO or a device."""
    import os

    src = tmp_path / "x.stl"
    src.write_text("solid")
    (tmp_path / "soft.npz").symlink_to(src)
    os.link(src, tmp_path / "hard.npz")
    for out in (src, tmp_path / "soft.npz", tmp_path / "hard.npz",
                tmp_path / "." / "x.stl"):
        with pytest.raises(CliInputError,
                           match=f"-o '{out}' is the input file '{src}'"):
            check_output(out, inputs=(None, src))
    assert check_output(tmp_path / "new.npz", inputs=(src,)) == tmp_path / "new.npz"
    assert check_output(src) == src  # no inputs given: a writable regular file
    os.mkfifo(tmp_path / "fifo.npz")
    with pytest.raises(vs.StorageFileError,
                       match=r"-o '.*fifo\.npz': it is a FIFO \(named pipe\)"):
        check_output(tmp_path / "fifo.npz")
    with pytest.raises(OSError, match="it is a character device"):
        check_output(Path("/dev/null"))  # refused, never written
    src.chmod(0o444)
    with pytest.raises(vs.StorageFileError, match=r"it is read-only \(mode 0444\)"):
        check_output(src)


def test_paths_are_shown_the_same_way_and_printing_never_raises():
    """Audit s24 D4: a name that is not UTF-8, printed to a strict stream."""
    assert shown(os.fsdecode(b"caf\xe9.stl")) == "caf\\xe9.stl"
    assert shown(Path("dir") / "café.stl") == "dir/café.stl"
    stream = io.TextIOWrapper(io.BytesIO(), encoding="ascii", errors="strict")
    say("café 30 µm", stream)
    say(os.fsdecode(b"caf\xe9"), stream, flush=True)
    assert stream.buffer.getvalue() == b"caf\\xe9 30 \\xb5m\ncaf\\udce9\n"


def test_every_half_micron_rounds_away_from_zero():
    """Audit s24 D9: 92 of these 10,000 inputs rounded down (through a float)."""
    for n in range(10_000):
        text = f"{n // 1000}.{n % 1000:03d}5"  # n + 0.5 µm
        assert mm_to_microns(mm_value(text), "--x") == n + 1, text
        assert mm_to_microns(mm_value("-" + text), "--x") == -(n + 1), text

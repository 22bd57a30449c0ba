"""load_mesh(..., compat="cura"): CuraEngine's STL reading (vecslice/cura_stl.py)."""

import os
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given
from hypothesis import strategies as st

import reference_cura as ref
import vecslice as vs
from vecslice.cura_stl import _to_float32, meld, mm2int

E2E = {
    "voron": "Voron_Design_Cube_v7.stl",
    "plate_holes": "plate_holes.STL",
    "cube": "cura/cube.stl",
    "cylinder1000": "cura/cylinder1000.stl",
}


@pytest.mark.parametrize("name", list(E2E))
def test_mesh_equals_curaengines(meshes_dir, testdata_dir, name):
    data = np.load(testdata_dir / "cura_e2e" / f"{name}.npz")
    mesh = vs.load_mesh(meshes_dir / E2E[name], compat="cura")
    assert np.array_equal(mesh.vertices, data["mesh_vertices"])
    assert np.array_equal(mesh.faces, data["mesh_faces"])
    info = data["info"]  # faces read, faces kept, vertices after melding
    assert (mesh.load_info.faces_in, mesh.n_faces, mesh.n_vertices) == tuple(
        int(x) for x in info[2:5])


def _ascii(triangles, header="solid t", newline="\n", indent="  "):
    lines = [header]
    for tri in triangles:
        lines += [f"{indent}facet normal 0 0 1", f"{indent}  outer loop"]
        lines += [f"{indent}    vertex {x} {y} {z}" for x, y, z in tri]
        lines += [f"{indent}  endloop", f"{indent}endfacet"]
    lines.append("endsolid t")
    return newline.join(lines) + newline


def _binary(triangles, header=b"binary", count=None):
    out = bytearray(header.ljust(80, b" ")[:80])
    out += struct.pack("<I", len(triangles) if count is None else count)
    for tri in triangles:
        out += struct.pack("<3f", 0, 0, 1)
        out += struct.pack("<9f", *[c for p in tri for c in p])
        out += b"\0\0"
    return bytes(out)


def _write(tmp_path: Path, data, name="m.stl") -> Path:
    p = tmp_path / name
    p.write_bytes(data.encode() if isinstance(data, str) else data)
    return p


TRI = [[(0, 0, 0), (10, 0, 0), (0, 10, 0)], [(0, 0, 0), (0, 10, 0), (0, 0, 10)]]


@pytest.mark.parametrize("newline", ["\n", "\r\n", "\r"])
@pytest.mark.parametrize("lead", ["", "  \n\t", "\n\n"])
def test_ascii_line_endings_and_leading_whitespace(tmp_path, newline, lead):
    mesh = vs.load_mesh(_write(tmp_path, lead + _ascii(TRI, newline=newline)),
                        compat="cura")
    assert mesh.vertices.tolist() == [[0, 0, 0], [10000, 0, 0], [0, 10000, 0],
                                      [0, 0, 10000]]
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3]]


def test_ascii_header_any_case_and_sscanf_rules(tmp_path):
    # "SOLID" in any case; "vertex" needs no space before the number; text after
    # the third number is ignored; hex floats parse; other lines are skipped
    text = ("  SoLiD x\nvertex1 2 3 trailing\n\tvertex 0x1p2 -0.5e1 +.25\n"
            "facet vertex 9 9 9\n vertex 7 8 9\nendsolid\n")
    mesh = vs.load_mesh(_write(tmp_path, text), compat="cura")
    assert mesh.vertices.tolist() == [[1000, 2000, 3000], [4000, -5000, 250],
                                      [7000, 8000, 9000]]


def test_values_are_float32(tmp_path):
    # 0.0005 mm is 0.5 µm in double (MM2INT -> 1), but float32(0.0005) is
    # 0.000500000024, so 1 either way; 1.0000005 mm: float32 is 1.00000048,
    # MM2INT(1.00000048) = 1000; 0.0014995 mm: float32 0.00149949995 -> 1 µm
    values = (0.0005, 1.0000005, 0.0014995)
    text = _ascii([[values, (5, 0, 0), (0, 0, 5)]])
    mesh = vs.load_mesh(_write(tmp_path, text), compat="cura")
    assert mesh.vertices[0].tolist() == [1, 1000, 1] == [
        ref.mm2int(float(np.float32(v))) for v in values]
    # a value whose float32 rounds across a half micron: 2.0005 mm is 2000.5 µm
    # in decimal; float32(2.0005) = 2.00049996 -> 2000 (double would give 2001)
    mesh = vs.load_mesh(_write(tmp_path, _ascii([[(2.0005, 0, 0), (5, 0, 0),
                                                  (0, 0, 5)]])), compat="cura")
    assert mesh.vertices[0, 0] == 2000 and ref.mm2int(2.0005) == 2001


def test_binary_with_solid_header_is_read_as_binary(tmp_path):
    data = _binary(TRI, header=b"solid but binary")
    mesh = vs.load_mesh(_write(tmp_path, data), compat="cura")
    assert mesh.n_faces == 2 and mesh.vertices.max() == 10000


def test_binary_count_from_file_size(tmp_path):
    data = _binary(TRI, count=7) + b"xyz"  # wrong count, 3 stray bytes
    with pytest.warns(vs.VecsliceWarning, match="announces 7 triangles"):
        mesh = vs.load_mesh(_write(tmp_path, data), compat="cura")
    assert mesh.n_faces == 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vs.load_mesh(_write(tmp_path, _binary(TRI)), compat="cura")


def test_melding_across_a_hash_cell_boundary(tmp_path):
    # two triangles sharing an edge whose copies differ by 1 µm: 0.014 and
    # 0.015 mm lie in different 30 µm cells (not melded); 0.016 and 0.044 lie in
    # one cell, 28 µm apart (melded into the first)
    a = [(0.014, 0, 0), (5, 0, 0), (0.016, 5, 0)]
    b = [(0.015, 0, 0), (0.044, 5, 0), (-5, 3, 0)]
    mesh = vs.load_mesh(_write(tmp_path, _ascii([a, b])), compat="cura")
    assert mesh.vertices.tolist() == [[14, 0, 0], [5000, 0, 0], [16, 5000, 0],
                                      [15, 0, 0], [-5000, 3000, 0]]
    assert mesh.faces.tolist() == [[0, 1, 2], [3, 2, 4]]


def test_degenerate_faces_dropped_vertices_kept(tmp_path):
    # the second triangle collapses (two corners 10 µm apart meld); its third
    # vertex stays in the mesh, as CuraEngine keeps it (and its bounding box)
    tri = [TRI[0], [(0, 0, 0), (0.01, 0, 0), (3, 3, 3)]]
    mesh = vs.load_mesh(_write(tmp_path, _ascii(tri)), compat="cura")
    assert mesh.n_faces == 1 and mesh.n_vertices == 4
    assert mesh.zrange == (0, 3000)
    assert mesh.load_info.faces_degenerate == 1


def test_no_repair(tmp_path):
    # a flipped and a duplicate face stay as they are
    tri = [TRI[0], TRI[0][::-1], TRI[0]]
    mesh = vs.load_mesh(_write(tmp_path, _ascii(tri)), compat="cura")
    assert mesh.faces.tolist() == [[0, 1, 2], [2, 1, 0], [0, 1, 2]]


def test_scale_and_trimesh_input(tmp_path):
    mesh = vs.load_mesh(_write(tmp_path, _ascii(TRI)), compat="cura", scale=25.4)
    assert mesh.vertices.max() == 254000
    box = trimesh.creation.box((10, 20, 30))
    m = vs.load_mesh(box, compat="cura")
    # vertices in the order the corners first appear, face by face
    corners = np.rint(box.vertices[box.faces.reshape(-1)] * 1000).astype(np.int64)
    _, first = np.unique(corners, axis=0, return_index=True)
    assert m.n_faces == 12
    assert m.vertices.tolist() == corners[np.sort(first)].tolist()
    scene = trimesh.Scene([box])
    assert vs.load_mesh(scene, compat="cura").faces.tolist() == m.faces.tolist()


def test_ascii_stl_equals_binary_stl(meshes_dir, tmp_path):
    # plate_holes is binary; written as ASCII with 9 significant digits the
    # float32 values come back exactly
    tm = trimesh.load(meshes_dir / "plate_holes.STL", process=False)
    tris = np.asarray(tm.vertices, dtype=np.float32)[tm.faces].astype(np.float64)
    text = _ascii([[tuple(f"{c:.9g}" for c in p) for p in t] for t in tris])
    a = vs.load_mesh(_write(tmp_path, text), compat="cura")
    b = vs.load_mesh(meshes_dir / "plate_holes.STL", compat="cura")
    assert np.array_equal(a.vertices, b.vertices)
    assert np.array_equal(a.faces, b.faces)


@given(st.lists(st.floats(-1e4, 1e4, allow_nan=False, width=32), min_size=1,
                max_size=30))
def test_float32_parsing_and_mm2int_match_reference(values):
    tokens = [f"{v!r}".encode() for v in values] + [f"{v:.7e}".encode()
                                                    for v in values]
    got = _to_float32(tokens)
    want = np.array([np.float32(float(t)) for t in tokens], dtype=np.float32)
    assert np.array_equal(got, want)
    assert mm2int(got.astype(np.float64)).tolist() == [
        ref.mm2int(float(v)) for v in got]


def test_float32_parsing_rounds_once():
    # 1 + 2**-24 is halfway between two float32 values; the decimal below is a
    # hair above it: float32 rounds up, double-then-float32 would round to even
    s = b"1.0000000596046448936"  # 1 + 2**-24 + 4e-20
    assert _to_float32([s])[0] == np.nextafter(np.float32(1), np.float32(2))
    assert _to_float32([b"1.000000059604644775390625"])[0] == np.float32(1)


@given(st.lists(st.tuples(*[st.integers(-200, 200)] * 3), min_size=3, max_size=45))
def test_meld_wrapper_matches_reference(corners):
    corners = corners[: len(corners) - len(corners) % 3]
    vertices, corner_vertex = meld(np.array(corners, dtype=np.int64))
    want_v, _ = ref.meld(corners)
    assert [tuple(v) for v in vertices.tolist()] == want_v


@pytest.mark.parametrize(
    ("label", "make", "err", "match"),
    [
        ("missing", None, vs.MeshFileError, "not found"),
        ("short", b"sol", vs.MeshFileError, "fewer than 5 bytes"),
        ("short binary", b"xxxxxxxxxx", vs.MeshFileError, "84-byte header"),
        ("ascii no faces", "solid x\nendsolid x\n", vs.MeshFileError,
         "84-byte header"),
        ("nan", _ascii([[("nan", 0, 0), (1, 0, 0), (0, 1, 0)]]), vs.InputValueError,
         "must be finite"),
        ("huge", _ascii([[(2e6, 0, 0), (1, 0, 0), (0, 1, 0)]]), vs.InputValueError,
         "2\\*\\*30"),
        ("collapsed", _ascii([[(0, 0, 0), (0.001, 0, 0), (0, 0.001, 0)]]),
         vs.MeshFileError, "non-degenerate"),
        ("zero faces", _binary([]), vs.MeshFileError, "no triangles"),
    ],
)
def test_bad_files(tmp_path, label, make, err, match):
    path = tmp_path / "x.stl"
    if make is not None:
        _write(tmp_path, make, "x.stl")
    with pytest.raises(err, match=match):
        vs.load_mesh(path, compat="cura")


def test_bad_arguments(tmp_path, meshes_dir):
    with pytest.raises(vs.MeshFileError, match="STL files only"):
        vs.load_mesh(meshes_dir / "3DBenchy.3mf", compat="cura")
    with pytest.raises(vs.SettingsError, match="`compat` must be one of"):
        vs.load_mesh(meshes_dir / "cura" / "cube.stl", compat="CuraEngine")
    with pytest.raises(vs.InputTypeError, match="path_or_trimesh"):
        vs.load_mesh(3, compat="cura")
    with pytest.raises(vs.MeshFileError, match="directory"):
        vs.load_mesh(tmp_path, compat="cura")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes")
def test_pipe_and_device_are_refused_without_reading(tmp_path):
    # audit s23 D5: compat='cura' read a FIFO forever and /dev/zero to MemoryError
    fifo = tmp_path / "fifo.stl"
    os.mkfifo(fifo)
    zero = tmp_path / "zero.stl"
    zero.symlink_to("/dev/zero")
    for p in (fifo, zero):
        with pytest.raises(vs.MeshFileError, match=rf"'.*{p.name}' is not a regular "
                           r"file \(a device or pipe\?\)") as info:
            vs.load_mesh(p, compat="cura")
        assert isinstance(info.value, OSError)


def test_symlink_loop_and_broken_link_are_named(tmp_path):
    # audit s23 D13: compat='cura' called a symbolic link loop "not found"
    a, b = tmp_path / "a.stl", tmp_path / "b.stl"
    a.symlink_to(b)
    b.symlink_to(a)
    with pytest.raises(vs.MeshFileError, match=r"'.*a\.stl' is a symbolic link loop"):
        vs.load_mesh(a, compat="cura")
    c = tmp_path / "c.stl"
    c.symlink_to(tmp_path / "gone.stl")
    with pytest.raises(vs.MeshFileError, match=r"'.*c\.stl' is a broken symbolic "
                       r"link: its target '.*gone\.stl' does not exist"):
        vs.load_mesh(c, compat="cura")


@pytest.mark.parametrize("bad", [99, 4, -2, -1])
def test_trimesh_face_indices_are_checked(bad):
    # audit s23 D7: -2 wrapped to vertex 2, 99 raised a raw numpy IndexError
    v = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, bad]])
    tm = trimesh.Trimesh(v, f, process=False)
    for compat in ("vecslice", "cura"):
        with pytest.raises(vs.InputValueError, match=rf"`faces` must index vertices "
                           rf"in \[0, 4\); got {bad} at face 3") as info:
            vs.load_mesh(tm, compat=compat)
        assert isinstance(info.value, ValueError)


def test_trimesh_scene_face_indices_are_checked():
    # an index past one geometry's vertices would pick another geometry's vertex
    v = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
    good = trimesh.Trimesh(v, [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
                           process=False)
    bad = trimesh.Trimesh(v, [[0, 2, 1], [0, 1, 5]], process=False)
    scene = trimesh.Scene({"bad": bad, "good": good})
    for compat in ("vecslice", "cura"):
        with pytest.raises(vs.InputValueError, match=r"`faces` of scene geometry "
                           r"'bad' must index its vertices in \[0, 4\); got 5 at "
                           r"face 1"):
            vs.load_mesh(scene, compat=compat)


@pytest.mark.parametrize("make", [_ascii, _binary], ids=["ascii", "binary"])
def test_triangle_limit_applies_as_for_the_default_reader(tmp_path, monkeypatch,
                                                          make):
    # audit s24 D12: compat='cura' never applied MAX_TRIANGLES
    tris = [[(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 0, 0), (0, 1, 0), (0, 0, 1)],
            [(0, 0, 0), (0, 0, 1), (1, 0, 0)]]
    path = _write(tmp_path, make(tris))
    monkeypatch.setattr("vecslice.meshfile.MAX_TRIANGLES", 3)
    assert vs.load_mesh(path, compat="cura").n_faces == 3
    monkeypatch.setattr("vecslice.meshfile.MAX_TRIANGLES", 2)
    for compat in ("vecslice", "cura"):
        with pytest.raises(vs.MeshFileError, match=r"m\.stl' announces 3 triangles; "
                           r"vecslice reads at most 2 triangles \(vecslice\.meshfile"
                           r"\.MAX_TRIANGLES\)"):
            vs.load_mesh(path, compat=compat)


@pytest.mark.parametrize("compat", ["vecslice", "cura"])
def test_trimesh_faces_are_checked_on_the_copy_that_is_used(write_when_copied,
                                                            compat):
    """Audit s26 state D2: a trimesh's faces were checked in its own memory and
    used from there (compat='vecslice': by the merge kernels); a write by another
    thread in between went unchecked. Here the write lands just before the copy."""
    v = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
    tm = trimesh.Trimesh(v, [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
                         process=False)
    writes = write_when_copied(tm.faces, (3, 1), 10**12)
    with pytest.raises(vs.InputValueError, match=r"`faces` must index vertices in "
                       r"\[0, 4\); got 1000000000000 at face 3"):
        vs.load_mesh(tm, compat=compat)
    assert writes == [(3, 1)]


# ---------------------------------------------------------------------------
# messages name the file (audit D3/D14)
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(("newline", "line"), [("\n", 12), ("\r\n", 12), ("\r", 12)])
def test_bad_value_names_the_file_corner_and_line(tmp_path, newline, line):
    text = _ascii([TRI[0], [(0, 0, 0), (1, 0, "inf"), (0, 1, 0)]], newline=newline)
    path = _write(tmp_path, text, "bad value.stl")
    with pytest.raises(vs.InputValueError, match=rf"`vertices` must be finite; got "
                       rf"inf at corner 4 \(triangle 1, line {line}\) of "
                       rf"'.*bad value\.stl'") as info:
        vs.load_mesh(path, compat="cura")
    assert isinstance(info.value, ValueError)
    huge = _write(tmp_path, _ascii([[(0, 0, 0), (1, 0, 0), (0, 1, 2000)]]), "h.stl")
    with pytest.raises(vs.InputValueError, match=r"got 2000000\.0 mm at corner 2 "
                       r"\(triangle 0, line 6\) of '.*h\.stl'"):
        vs.load_mesh(huge, compat="cura", scale=1000)


def test_bad_binary_value_names_the_file():
    tri = [TRI[0], [(0, 0, 0), (float("nan"), 0, 0), (0, 1, 0)]]
    with pytest.raises(vs.InputValueError, match=r"`vertices` must be finite; got "
                       r"nan at corner 4 \(triangle 1\) of '.*m\.stl'"):
        vs.load_mesh(_write_tmp(_binary(tri)), compat="cura")


def test_trimesh_bad_value_names_the_source():
    tm = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, np.inf, 0]], [[0, 1, 2]],
                         process=False)
    with pytest.raises(vs.InputValueError, match=r"got inf at corner 2 \(triangle "
                       r"0\) of trimesh\.Trimesh"):
        vs.load_mesh(tm, compat="cura")


def _write_tmp(data, name="m.stl"):
    import tempfile

    return _write(Path(tempfile.mkdtemp()), data, name)


NO_VERTEX = "no line starts with 'vertex'"


@pytest.mark.parametrize(
    ("text", "ascii_reason", "binary_reason"),
    [
        ("solid x\nendsolid x\n", NO_VERTEX,
         "a binary STL needs an 84-byte header; the file has 19 bytes"),
        ("solid x\n" + "facet normal 0 0 1\n" * 6 + "endsolid x\n", NO_VERTEX,
         "it has no 50-byte triangle record after the 84-byte header \\(the file "
         "has 133 bytes\\)"),
        ("solid x\n" + "this is not a vertex line at all\n" * 20, NO_VERTEX,
         "`vertices` must be below .* at corner 0 \\(triangle 0 of 11\\)"),
        ("solid x\n  vertex 1,5 2 3\n", "line 2 \\('vertex 1,5 2 3'\\) is not "
         "'vertex' and three numbers as CuraEngine reads them \\(sscanf \" vertex %f "
         "%f %f\"\\)", "a binary STL needs an 84-byte header"),
        ("solid x\n  vertex 1 2 3\n\tvertex 1 2 3e+x\n  vertex 1 2\n", "it has 2 "
         "vertex lines, fewer than a triangle's 3; line 4 \\('vertex 1 2'\\) is not .*",
         "a binary STL needs an 84-byte header"),
        ("solid x\n  vertex 1 2 3\n  vertex 1 2 3\nendsolid\n", "it has 2 vertex "
         "lines, fewer than a triangle's 3", "a binary STL needs an 84-byte header"),
        ("SOLID X\r\n" + "  VERTEX 1 2 3\r\n" * 3 + "x" * 100, "its vertex lines are "
         "not in lower case \\(line 2: 'VERTEX 1 2 3'\\); CuraEngine reads only "
         "'vertex' \\(compat='vecslice' any case\\)", "`vertices` must be below"),
    ],
    ids=["short", "no records", "garbage", "unreadable numbers", "one unreadable",
         "two vertices", "upper case"],
)
def test_ascii_without_triangles_says_why(tmp_path, text, ascii_reason,
                                          binary_reason):
    # a file beginning with 'solid' whose ASCII gives no triangle is read as
    # binary (CuraEngine's fallback); when that fails too, both reasons are given,
    # as a MeshFileError (the header's count is not warned about)
    path = _write(tmp_path, text, "t.stl")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(vs.MeshFileError, match=rf"'.*t\.stl' holds no triangles\. "
                           rf"As ASCII \(it begins with 'solid'\): {ascii_reason}\. "
                           rf"As binary \(CuraEngine's fallback\): {binary_reason}"
                           ) as info:
            vs.load_mesh(path, compat="cura")
    assert isinstance(info.value, OSError)


def test_binary_with_solid_header_and_wrong_count_still_warns(tmp_path):
    data = _binary(TRI, header=b"solid exported as binary", count=5)
    with pytest.warns(vs.VecsliceWarning, match="announces 5 triangles"):
        mesh = vs.load_mesh(_write(tmp_path, data), compat="cura")
    assert mesh.n_faces == 2

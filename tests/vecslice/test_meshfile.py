"""Reading STL, OBJ, PLY and OFF files (vecslice.meshfile): every failure is a
MeshFileError naming the file, announced counts are checked, nothing is printed.
Every file is generated here."""

import logging
import os
import random
import struct
import sys
import tracemalloc
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import vecslice as vs
from vecslice import meshfile

TRI_STL = (b"solid %s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
           b"vertex 0 1 0\nendloop\nendfacet\nendsolid %s\n")


def write(tmp_path, name, data):
    p = tmp_path / name
    p.write_bytes(data.encode() if isinstance(data, str) else data)
    return p


def refused(path, match, **kw):
    with pytest.raises(vs.MeshFileError, match=match) as info:
        vs.load_mesh(path, **kw)
    assert isinstance(info.value, OSError) and isinstance(info.value, vs.VecsliceError)
    return info.value


@pytest.fixture
def no_charset_normalizer(monkeypatch):
    """As on an install without charset_normalizer (issue 8 A1)."""
    monkeypatch.setitem(sys.modules, "charset_normalizer", None)


# ---------------------------------------------------------------------------
# A1: every failure while reading becomes a MeshFileError naming the file
# ---------------------------------------------------------------------------


def test_ascii_stl_with_latin1_name_loads(tmp_path, no_charset_normalizer):
    p = write(tmp_path, "caf.stl", TRI_STL % (b"caf\xe9 cr\xe8me", b"caf\xe9"))
    m = vs.load_mesh(p)
    assert m.vertices.tolist() == [[0, 0, 0], [1000, 0, 0], [0, 1000, 0]]


@pytest.mark.parametrize("ext", ["stl", "obj", "ply", "off", "3mf"])
def test_garbage_never_leaks_raw_exceptions(tmp_path, no_charset_normalizer, ext):
    rng = random.Random(ext)
    heads = {"stl": b"solid x\n", "obj": b"v 0 0 0\n", "ply": b"ply\n",
             "off": b"OFF\n", "3mf": b"PK\x03\x04"}
    for trial in range(30):
        body = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 400)))
        data = heads[ext] + body if trial % 2 else body
        p = write(tmp_path, f"g.{ext}", data)
        with pytest.raises(vs.MeshFileError, match=r"g\." + ext):
            vs.load_mesh(p)


@pytest.mark.parametrize("exc", [ModuleNotFoundError("No module named 'x'"),
                                 UnboundLocalError("cannot access local variable"),
                                 RuntimeError("boom"), RecursionError("deep")])
def test_any_parser_failure_becomes_mesh_file_error(tmp_path, monkeypatch, exc):
    def fail(*a, **k):
        raise exc

    monkeypatch.setattr(meshfile, "read_ply_ascii", fail)
    p = write(tmp_path, "a.ply", PLY % ("vertex_indices", "3 0 1 2"))
    err = refused(p, r"cannot read '.*a\.ply' as PLY: " + type(exc).__name__)
    assert err.__cause__ is exc


def test_memory_error_becomes_a_clear_mesh_file_error(tmp_path, monkeypatch):
    def fail(*a, **k):
        raise MemoryError

    monkeypatch.setattr(meshfile, "read_off", fail)
    p = write(tmp_path, "a.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    refused(p, r"cannot read '.*a\.off' as OFF: ran out of memory")


def test_keyboard_interrupt_is_not_swallowed(tmp_path, monkeypatch):
    def stop(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(meshfile, "read_ply_ascii", stop)
    p = write(tmp_path, "a.ply", PLY % ("vertex_indices", "3 0 1 2"))
    with pytest.raises(KeyboardInterrupt):
        vs.load_mesh(p)


# ---------------------------------------------------------------------------
# A2: counts a file announces are checked before memory is spent
# ---------------------------------------------------------------------------


def _peak_mib(fn):
    tracemalloc.start()
    try:
        fn()
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return peak / 2**20


def binary_stl(n_triangles, claimed=None):
    head = b"\0" * 80 + struct.pack("<I", n_triangles if claimed is None else claimed)
    rec = np.zeros(n_triangles, dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                       ("a", "<u2")])
    rec["v"] = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    rec["v"][:, :, 2] = np.arange(n_triangles)[:, None]
    return head + rec.tobytes()


def test_binary_stl_claiming_4e9_triangles(tmp_path):
    p = write(tmp_path, "claim.stl", binary_stl(2, claimed=4_000_000_000))
    refused(p, r"claim\.stl' is truncated or corrupt: its binary STL header "
            r"announces 4,000,000,000 triangles, which take 200,000,000,084 bytes "
            r"\(84 \+ 50 each\), but the file has 184 bytes$")
    assert _peak_mib(lambda: _swallow(vs.load_mesh, p)) < 4


def _swallow(fn, *a):
    try:
        fn(*a)
    except vs.MeshFileError:
        pass


def test_triangle_limit(tmp_path, monkeypatch):
    monkeypatch.setattr("vecslice.meshfile.MAX_TRIANGLES", 10)
    assert vs.load_mesh(write(tmp_path, "ok.stl", binary_stl(10))).n_faces == 10
    refused(write(tmp_path, "big.stl", binary_stl(11)),
            r"big\.stl' announces 11 triangles; vecslice reads at most 10 triangles "
            r"\(vecslice\.meshfile\.MAX_TRIANGLES\)")
    obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\n" + "f 1 2 3\n" * 11
    refused(write(tmp_path, "big.obj", obj), r"announces 11 faces")
    refused(write(tmp_path, "big.off",
                  "OFF\n3 11 0\n0 0 0\n1 0 0\n0 1 0\n" + "3 0 1 2\n" * 11),
            r"big\.off' announces 11 faces")


PLY = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
       "property float y\nproperty float z\nelement face 1\n"
       "property list uchar int %s\nend_header\n0 0 0\n1 0 0\n0 1 0\n%s\n")


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test_ply_header_claiming_huge_counts(tmp_path, fmt):
    head = (f"ply\nformat {fmt} 1.0\nelement vertex %d\nproperty float x\n"
            "property float y\nproperty float z\nelement face 1\n"
            "property list uchar int vertex_indices\nend_header\n")
    p = write(tmp_path, "huge.ply", (head % 50_000_000).encode() + b"\0" * 64)
    per, face = (12, 1) if fmt.startswith("binary") else (6, 2)
    refused(p, r"huge\.ply' is truncated or corrupt: its PLY header announces "
            r"50,000,000 'vertex' and 1 'face' elements \(at least "
            + f"{50_000_000 * per + face:,}" + r" bytes\), but 64 bytes follow the "
            r"header")
    assert _peak_mib(lambda: _swallow(vs.load_mesh, p)) < 4
    p = write(tmp_path, "huger.ply", (head % 4_000_000_000).encode() + b"\0" * 64)
    refused(p, r"huger\.ply' announces 4,000,000,000 vertices; vecslice reads at "
            r"most 300,000,000 vertices \(3 x vecslice\.meshfile\.MAX_TRIANGLES\)")


def test_off_header_claiming_huge_counts(tmp_path):
    p = write(tmp_path, "huge.off", "OFF\n# made by hand\n3000000000 1 0\n0 0 0\n")
    refused(p, r"huge\.off' is truncated or corrupt: its OFF header announces "
            r"3,000,000,000 vertices and 1 faces")


# ---------------------------------------------------------------------------
# STL
# ---------------------------------------------------------------------------


def test_binary_stl_starting_with_solid(tmp_path):
    data = binary_stl(3)
    p = write(tmp_path, "s.stl", b"solid trap" + data[10:])
    m = vs.load_mesh(p, repair=False)
    assert m.n_faces == 3 and m.zrange == (0, 2000)


def test_odd_paths_and_tiny_files(tmp_path):
    refused(str(tmp_path / "a\0b.stl"), r"cannot open .*embedded null")

    class BytesPath:
        def __fspath__(self):
            return b"x.stl"

    with pytest.raises(vs.InputTypeError, match=r"`path_or_trimesh` must be a file "
                       r"path \(str\)"):
        vs.load_mesh(BytesPath())
    # 34 bytes = 84 + 50 * -1: no header to read, not a binary STL
    refused(write(tmp_path, "t.stl", b"\x01" * 34), r"t\.stl' holds no triangles "
            r"\(binary STL needs an 84-byte header; the file has 34 bytes\)")


def test_ascii_stl_multi_solid_and_upper_case(tmp_path):
    one = TRI_STL % (b"a", b"a")
    two = (TRI_STL % (b"b", b"b")).upper().replace(b"VERTEX 0 0 0", b"VERTEX 0 0 5")
    m = vs.load_mesh(write(tmp_path, "two.stl", one + two), repair=False)
    assert m.n_faces == 2 and m.zrange == (0, 5000)


@pytest.mark.parametrize(("label", "data", "match"), [
    ("quad facet", (TRI_STL % (b"q", b"q")).replace(
        b"endloop", b"vertex 1 1 0\nendloop"),
     r"ASCII STL facets must have 3 vertices each; got 4 vertices in 1 facets"),
    ("bad number", (TRI_STL % (b"n", b"n")).replace(b"vertex 1 0 0", b"vertex 1 0 x"),
     r"vertex 2 has 'x' where a number should be"),
    ("truncated", (TRI_STL % (b"t", b"t"))[:-12], r"truncated\?"),
])
def test_broken_ascii_stl(tmp_path, label, data, match):
    refused(write(tmp_path, "b.stl", data), r"b\.stl.*" + match)


# ---------------------------------------------------------------------------
# OBJ (B8 and D7: indices 1-based as in the file)
# ---------------------------------------------------------------------------

V3 = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"


def test_obj_face_index_zero_is_refused(tmp_path):
    p = write(tmp_path, "zero.obj", V3 + "v 0 0 1\nf 1 2 3\nf 0 1 2\n")
    refused(p, r"zero\.obj' is corrupt: face 2 \(line 6\) refers to vertex 0; OBJ "
            r"vertex indices start at 1")


@pytest.mark.parametrize(("label", "text", "match"), [
    ("beyond", V3 + "f 1 2 4\n", r"face 1 \(line 4\) refers to vertex 4; the file "
     r"has 3 vertices"),
    ("negative beyond", V3 + "f -1 -2 -4\n", r"face 1 \(line 4\) refers to vertex "
     r"-4; only 3 vertices are defined before it"),
    ("negative before definition", "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n",
     r"face 1 \(line 3\) refers to vertex -3; only 2 vertices"),
    ("two corners", V3 + "# c\nf 1 2\n", r"face 1 \(line 5\) has 2 vertices; a face "
     r"needs at least 3"),
    ("not a number", V3 + "f 1 2 3\nf 1 b 3\n", r"face 2 \(line 5\) has vertex index "
     r"'b'"),
    ("short vertex", "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", r"line 2 defines a vertex "
     r"without three coordinates"),
    ("bad coordinate", "v 0 0 0\nv 1 0 q\nv 0 1 0\nf 1 2 3\n",
     r"vertex 2 has 'q' where a number should be"),
])
def test_broken_obj(tmp_path, label, text, match):
    refused(write(tmp_path, "b.obj", text), r"b\.obj.*" + match)


def test_obj_negative_indices_count_back_from_the_face(tmp_path):
    # trimesh resolved them from the end of the file: both faces the second one
    text = V3 + "f -3 -2 -1\nv 0 0 5\nv 1 0 5\nv 0 1 5\nf -3 -2 -1\n"
    m = vs.load_mesh(write(tmp_path, "rel.obj", text), repair=False)
    assert m.vertices[m.faces].tolist() == [
        [[0, 0, 0], [1000, 0, 0], [0, 1000, 0]],
        [[0, 0, 5000], [1000, 0, 5000], [0, 1000, 5000]]]


def test_obj_polygons_slashes_comments_and_continuations(tmp_path):
    text = ("# a pentagon and a quad\nmtllib none.mtl\no thing\n"
            "v 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nv -2 2 0 0.5 0.5 0.5\n"
            "vt 0 0\nvn 0 0 1\nusemtl x\ns off\n"
            "f 1/1/1 2/1/1 3//1 4/1 \\\n 5  # five corners\n"
            "g quad\nf 1 2 3 4\nl 1 2\n")
    m = vs.load_mesh(write(tmp_path, "p.obj", text), repair=False)
    assert m.n_faces == 3 + 2
    assert m.faces[:3].tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]
    assert vs.check_mesh(m).zero_area_faces == 0


@pytest.mark.parametrize(("text", "match"), [
    # a continuation inside a face: the face is named by the line it starts on
    (V3 + "v 0 0 \\\n1\nf 1 2 \\\n 3\nf 1 2 9\n",
     r"face 2 \(line 8\) refers to vertex 9"),
    (V3 + "f 1 2 \\\n 3 \\\n 1\nf 1 2 \\\n q\n",
     r"face 2 \(line 7\) has vertex index 'q'"),
    (V3 + "f 1 \\\r\n 2 3\r\nf 1\r\n",
     r"face 2 \(line 6\) has 1 vertices"),
    (V3 + "f 1 2 \\\n 3\nv 0 \\\n 1\nf 1 2 3\n",
     r"line 6 defines a vertex without three coordinates"),
    (V3 + "f 1 2 \\\n 3\nf 1 2 \\\n 0\n",
     r"face 2 \(line 6\) refers to vertex 0"),
    (V3 + "f 1 2 \\\n 3\nf /1 2 3\n", r"face 2 \(line 6\) has corner '/1'"),
])
def test_obj_lines_after_continuations_are_numbered_as_in_the_file(tmp_path, text,
                                                                     match):
    """A ``\\`` continuation joins two lines of the file, which still count as
    two: messages named a line one too low per continuation before it."""
    refused(write(tmp_path, "c.obj", text), r"c\.obj' is corrupt: " + match)


def test_obj_matches_trimesh_on_the_shared_meshes(meshes_dir):
    import trimesh

    for name in ("stanford-bunny.obj", "openscad-nonmanifold-crash.obj"):
        tm = trimesh.load(meshes_dir / name, process=False)
        ours = vs.load_mesh(meshes_dir / name, repair=False)
        theirs = vs.load_mesh(tm, repair=False)
        # the same triangles in the same order (trimesh drops unused vertices,
        # so vertex numbers differ)
        assert np.array_equal(ours.vertices[ours.faces], theirs.vertices[theirs.faces])
        assert ours.load_info.vertices_in == {"stanford-bunny.obj": 35947}.get(
            name, 717)


# ---------------------------------------------------------------------------
# PLY (C1) and OFF
# ---------------------------------------------------------------------------


def test_ply_face_property_with_another_name_loads(tmp_path):
    # trimesh raised UnboundLocalError for a face list not named vertex_indices
    m = vs.load_mesh(write(tmp_path, "odd.ply", PLY % ("vidx", "3 0 1 2")))
    assert m.n_faces == 1 and m.bounds.tolist() == [[0, 0, 0], [1000, 1000, 0]]
    two = (PLY % ("a", "3 0 1 2 0")).replace(
        "end_header", "property list uchar int b\nend_header")
    refused(write(tmp_path, "two.ply", two),
            r"two\.ply': the PLY face element must have one list property of vertex "
            r"indices; got list properties \['a', 'b'\]")


def test_ply_binary_and_quads(tmp_path):
    head = (b"ply\nformat binary_little_endian 1.0\nelement vertex 4\n"
            b"property float x\nproperty float y\nproperty float z\nelement face 1\n"
            b"property list uchar int vertex_indices\nend_header\n")
    v = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]], "<f4").tobytes()
    f = bytes([4]) + np.array([0, 1, 2, 3], "<i4").tobytes()
    m = vs.load_mesh(write(tmp_path, "q.ply", head + v + f), repair=False)
    assert m.n_faces == 2 and vs.check_mesh(m).zero_area_faces == 0


def test_off_loads(tmp_path):
    m = vs.load_mesh(write(tmp_path, "a.off", "OFF\n4 1 0\n0 0 0\n2 0 0\n2 2 0\n"
                           "0 2 0\n4 0 1 2 3\n"), repair=False)
    assert m.n_faces == 2


TET_PLY = ("ply\nformat ascii 1.0\nelement vertex {nv}\nproperty float x\n"
           "property float y\nproperty float z\nelement face {nf}\n"
           "property list {ct} {it} vertex_indices\nend_header\n")
TET_V = "0 0 0\n10 0 0\n0 10 0\n0 0 10\n"
TET_F = "3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n"


def tet_ply(nv=4, nf=4, body=TET_V + TET_F, ct="uchar", it="int"):
    return TET_PLY.format(nv=nv, nf=nf, ct=ct, it=it) + body


def test_ascii_ply_and_off_counts_match_the_body(tmp_path):
    # audit s23 D6: truncated or lying ASCII PLY and OFF loaded as partial meshes
    assert vs.load_mesh(write(tmp_path, "ok.ply", tet_ply()), repair=False).n_faces == 4
    assert vs.load_mesh(write(tmp_path, "crlf.ply", tet_ply().replace(
        "\n", "\r\n") + "\n \n"), repair=False).n_faces == 4
    refused(write(tmp_path, "lie.ply", tet_ply(nv=5)),
            r"lie\.ply' is truncated or corrupt: its PLY header announces 5 'vertex' "
            r"and 4 'face' elements \(9 lines\), but 8 lines of numbers follow it")
    refused(write(tmp_path, "cut.ply", tet_ply()[:-9]),
            r"cut\.ply' is truncated or corrupt: .* but 7 lines of numbers follow it")
    refused(write(tmp_path, "cutrow.ply", tet_ply()[:-3] + "\n"),
            r"cutrow\.ply' is truncated or corrupt: PLY 'face' 3 \(line 17\) has 3 "
            r"values; its header's properties need 4")
    refused(write(tmp_path, "long.ply", tet_ply(body=TET_V + TET_F + "3 0 1 2\n")),
            r"long\.ply' is truncated or corrupt: .*9 lines of numbers follow it")
    refused(write(tmp_path, "word.ply", tet_ply(body=TET_V.replace("10", "ten", 1)
                                                + TET_F)),
            r"word\.ply' is corrupt: 'ten' where a number should be")
    off = "OFF\n4 4 0\n" + TET_V + TET_F
    commented = "# by hand\n# two lines\n" + off.replace("\n3 0 2", " # c\n3 0 2")
    for label, text in [("ok", off), ("commented", commented)]:
        m = vs.load_mesh(write(tmp_path, f"{label}.off", text), repair=False)
        assert m.n_faces == 4 and m.is_watertight, label
    refused(write(tmp_path, "cut.off", "# c\n" + off[:-8]),
            r"cut\.off' is truncated or corrupt: its OFF header announces 4 vertices "
            r"and 4 faces \(8 lines\), but 7 lines of numbers follow it")
    refused(write(tmp_path, "huge.off", "# comment first\nOFF\n4 1000000000000 0\n"
                  + TET_V + TET_F), r"huge\.off' announces 1,000,000,000,000 faces")
    refused(write(tmp_path, "short.off", off.replace("3 1 2 3", "3 1 2")),
            r"short\.off' is corrupt: OFF face 2 has 3 numbers and announces 3 "
            r"corners")
    refused(write(tmp_path, "nooff.off", "4 4 0\n" + TET_V + TET_F),
            r"nooff\.off' is not an OFF file")


def test_ply_faces_need_integer_indices_and_three_corners(tmp_path):
    # audit s23 D12: 1.7 was read as vertex 1; a 2-vertex face was dropped
    refused(write(tmp_path, "f.ply", tet_ply(it="float")),
            r"f\.ply' is corrupt: PLY face list property 'vertex_indices' must have "
            r"integer types \(vertex indices\); got 'uchar' counts and 'float' values")
    refused(write(tmp_path, "two.ply", tet_ply(body=TET_V + TET_F.replace(
        "3 1 2 3", "2 1 2"))),
            r"two\.ply' is corrupt: PLY 'face' 2 \(line 16\) has a list of 2 values; "
            r"a face needs at least 3 vertices")


# ---------------------------------------------------------------------------
# D6: nothing printed for files that load
# ---------------------------------------------------------------------------


def test_loading_prints_and_warns_nothing(tmp_path, capfd):
    stl = (TRI_STL % (b"x", b"x")).replace(b"normal 0 0 1", b"normal 0 0 x")
    ply = (PLY % ("vertex_indices", "3 0 1 2")).replace(
        "format ascii 1.0\n", "format ascii 1.0\ncomment TextureFile none.png\n"
    ).replace("property float z\n", "property float z\nproperty float texture_u\n"
              "property float texture_v\nproperty float red\n").replace(
        "0 0 0\n1 0 0\n0 1 0\n", "0 0 0 0 0 nan\n1 0 0 1 0 1e300\n0 1 0 0 1 -1\n")
    logger = logging.getLogger("trimesh")
    filters = list(logger.filters)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name, data in (("n.stl", stl), ("t.ply", ply)):
            assert vs.load_mesh(write(tmp_path, name, data)).n_faces == 1
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    assert logger.filters == filters  # nothing left behind


# ---------------------------------------------------------------------------
# D7: messages about the path, coordinates and scale
# ---------------------------------------------------------------------------


def test_symlink_loop_and_broken_link(tmp_path):
    a, b = tmp_path / "a.stl", tmp_path / "b.stl"
    a.symlink_to(b)
    b.symlink_to(a)
    refused(a, r"'.*a\.stl' is a symbolic link loop")
    c = tmp_path / "c.stl"
    c.symlink_to(tmp_path / "gone.stl")
    refused(c, r"'.*c\.stl' is a broken symbolic link: its target '.*gone\.stl' does "
            r"not exist")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes")
def test_pipe_is_refused_without_reading(tmp_path):
    p = tmp_path / "pipe.stl"
    os.mkfifo(p)
    refused(p, r"'.*pipe\.stl' is not a regular file")


def test_coordinate_errors_name_the_vertex_with_plain_numbers(tmp_path):
    p = write(tmp_path, "far.obj", V3 + "v 2e6 0.5 0\nf 1 2 4\n")
    with pytest.raises(vs.InputValueError) as info:
        vs.load_mesh(p)
    msg = str(info.value)
    assert "np.float64" not in msg and "flat index" not in msg
    assert "got (2e+06, 0.5, 0) mm at vertex 3 of '" in msg
    with pytest.raises(vs.InputValueError, match=r"got \(1, 0, 0\) x scale 2e\+06 mm "
                       r"at vertex 1"):
        vs.load_mesh(write(tmp_path, "v.obj", V3 + "f 1 2 3\n"), scale=2e6)
    with pytest.raises(vs.InputValueError, match=r"`vertices` must be finite; got "
                       r"\[0\.0, 1\.0, nan\] at vertex 2"):
        vs.load_mesh(write(tmp_path, "n.obj", "v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n"))


def test_scale_that_collapses_every_face_is_named(tmp_path):
    p = write(tmp_path, "tiny.obj", V3 + "f 1 2 3\n")
    refused(p, r"tiny\.obj': .* all 1 faces have two corners at the same position at "
            r"scale 0\.0001 \(file units to mm\): is the scale right\?", scale=1e-4)


def test_ascii_stl_and_obj_numbers_with_underscores_are_refused(tmp_path):
    # audit s23 D12: Python's float() read '1_0' as 10
    refused(write(tmp_path, "u.stl", TRI_STL.replace(b"vertex 1 0 0", b"vertex 1_0 0 0")
                  % (b"x", b"x")), r"u\.stl' is corrupt: vertex 2 has '1_0' where a "
            r"number should be")
    refused(write(tmp_path, "u.obj", "v 0 0 0\nv 1_0 0 0\nv 0 1 0\nf 1 2 3\n"),
            r"u\.obj' is corrupt: vertex 2 has '1_0' where a number should be")


@pytest.mark.parametrize("sep", ["\v", "\f"])
def test_obj_face_with_other_whitespace_separates_indices(tmp_path, sep):
    # audit s23 D13: "cannot read ... as OBJ: StopIteration: "
    m = vs.load_mesh(write(tmp_path, "w.obj", f"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                           f"f 1 2{sep}4 3\n"), repair=False)
    assert m.n_faces == 2


@pytest.mark.parametrize(("ext", "text"), [
    ("stl", TRI_STL.decode() % ("x", "x")),
    ("obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ("ply", "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n"),
    ("off", "OFF\n0 0 0\n"),
])
@pytest.mark.parametrize("codec", ["utf-16", "utf-16-le"])
def test_utf16_text_is_named(tmp_path, ext, text, codec):
    # audit s23 D13: a UTF-16 STL reported a binary header's count
    refused(write(tmp_path, f"t.{ext}", text.encode(codec)),
            r"t\." + ext + r"' .*\(it looks like UTF-16 text; save it as ASCII or "
            r"UTF-8\)")


@pytest.mark.parametrize("sep", ["\v", "\f"])
def test_obj_slash_token_ends_at_any_whitespace(tmp_path, sep):
    # audit s24 D4: '2/1\v3/1' lost corner 3 (the /vt suffix ran to the next space)
    m = vs.load_mesh(write(tmp_path, "w.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                           f"vt 0 0\nf 1/1 2/1{sep}3/1 4/1\n"), repair=False)
    assert m.n_faces == 2
    assert sorted(m.vertices[m.faces].reshape(-1, 3)[:, :2].tolist()) == sorted(
        [[0, 0], [1000, 0], [1000, 1000], [0, 0], [1000, 1000], [0, 1000]])


@pytest.mark.parametrize(("index", "why"), [
    ("-99999999999999999999999", "only 3 vertices are defined before it"),
    ("18446744073709551619", "the file has 3 vertices"),
    ("9223372036854775807", "the file has 3 vertices"),
])
def test_obj_index_beyond_int64_is_quoted_as_written(tmp_path, index, why):
    # audit s24 D10: reported as 9223372036854775807 (numpy saturates)
    refused(write(tmp_path, "s.obj", f"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 {index}\n"),
            rf"s\.obj' is corrupt: face 1 \(line 4\) refers to vertex {index}; {why}")


def _stl_facets(sizes):
    """An ASCII STL of a tetrahedron's 12 corners in facets of ``sizes`` vertices."""
    corners = [(0, 0, 0), (10, 0, 0), (0, 10, 0), (0, 0, 10)]
    flat = [corners[i] for t in [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
            for i in t]
    lines, at = ["solid s"], 0
    for n in sizes:
        lines += ["facet normal 0 0 0", "outer loop"]
        lines += [f"vertex {x} {y} {z}" for x, y, z in flat[at:at + n]]
        lines += ["endloop", "endfacet"]
        at += n
    return "\n".join([*lines, "endsolid s", ""])


@pytest.mark.parametrize(("sizes", "match"), [
    ((4, 2, 3, 3), r"facet 1 \(line 3\) has 4"),
    ((3, 2, 4, 3), r"facet 2 \(line 10\) has 2"),
    ((3, 3, 3, 0), r"got 9 vertices in 4 facets"),
])
def test_ascii_stl_facets_have_three_vertices_each(tmp_path, sizes, match):
    # audit s24 D7: only the total was compared; 4 + 2 regrouped the vertices
    refused(write(tmp_path, "r.stl", _stl_facets(sizes)), r"r\.stl' is corrupt: "
            r"ASCII STL facets must have 3 vertices each; " + match)
    m = vs.load_mesh(write(tmp_path, "g.stl", _stl_facets((3, 3, 3, 3))))
    assert m.n_faces == 4 and m.is_watertight


def test_ascii_stl_vertex_before_the_first_facet(tmp_path):
    data = (TRI_STL % (b"v", b"v")).replace(b"vertex 0 1 0\n", b"")
    data = data.replace(b"facet normal", b"vertex 5 5 5\nfacet normal", 1)
    refused(write(tmp_path, "v.stl", data), r"v\.stl' is corrupt: ASCII STL facets "
            r"must have 3 vertices each; 1 vertices come before the first facet "
            r"\(line 4\)")


@pytest.mark.filterwarnings("ignore:deprecated:DeprecationWarning")
def test_loading_leaves_other_threads_warnings_alone(meshes_dir):
    """Audit s26 state: reading a file swapped the process-wide warning filters
    (warnings.catch_warnings, with DeprecationWarning as an error while parsing
    OBJ numbers), so a DeprecationWarning in another thread raised meanwhile,
    and concurrent loads could leave the swapped filters behind."""
    import threading

    obj = meshes_dir / "openscad-nonmanifold-crash.obj"
    vs.load_mesh(obj)  # warm
    before = list(warnings.filters)
    raised, emitted = [], []
    stop = threading.Event()

    def other():
        while not stop.is_set():
            try:
                warnings.warn_explicit("deprecated", DeprecationWarning, "lib.py", 1,
                                       module="lib", registry={})
                emitted.append(1)
            except DeprecationWarning:
                raised.append(1)

    t = threading.Thread(target=other)
    t.start()
    try:
        with ThreadPoolExecutor(3) as ex:
            n = list(ex.map(lambda _: vs.load_mesh(obj).n_faces, range(12)))
    finally:
        stop.set()
        t.join()
    assert len(set(n)) == 1 and emitted
    assert raised == []
    assert warnings.filters == before


def test_obj_number_check_needs_no_warning_filter(tmp_path):
    # a number followed by text in the last vertex token is still refused, also
    # where DeprecationWarning is an error for the whole process
    p = write(tmp_path, "t.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0x\nf 1 2 3\n")
    for mode in ("default", "error"):
        with warnings.catch_warnings():
            warnings.simplefilter(mode, DeprecationWarning)
            with pytest.raises(vs.MeshFileError, match="0x"):
                vs.load_mesh(p)


# ---------------------------------------------------------------------------
# audit D08, D09, D10, D15: OBJ limits, tokens, line ends, bytes in messages
# ---------------------------------------------------------------------------


def test_obj_triangle_limit_is_checked_before_the_fans_are_built(tmp_path,
                                                                 monkeypatch):
    # one face line of 13 corners: 11 triangles, within the face-line limit
    from vecslice import plyoff

    monkeypatch.setattr("vecslice.meshfile.MAX_TRIANGLES", 10)
    built = []
    for module in (meshfile, plyoff):
        real = module.fan_triangles
        monkeypatch.setattr(module, "fan_triangles",
                            lambda c, k, real=real: built.append(len(c)) or real(c, k))
    ring = " ".join(str(i) for i in range(1, 14))
    text = "".join(f"v {i} {i * i % 7} 0\n" for i in range(13)) + f"f {ring}\n"
    refused(write(tmp_path, "fan.obj", text), r"fan\.obj' announces 11 triangles; "
            r"vecslice reads at most 10 triangles")
    assert built == []
    ok = "".join(f"v {i} {i * i % 7} 0\n" for i in range(12)) + f"f {ring[:-3]}\n"
    assert vs.load_mesh(write(tmp_path, "ok.obj", ok), repair=False).n_faces == 10


@pytest.mark.parametrize(("face", "token"), [
    ("f /1 /2 /3", "/1"),
    ("f 1 2 3 /4", "/4"),
    ("f 1 2 / 3", "/"),
    ("f 1 2 3 //1", "//1"),
])
def test_obj_corner_starting_with_a_slash_is_refused(tmp_path, face, token):
    # audit D09: such corners were dropped ('f 1 2 3 /4' loaded as a triangle)
    refused(write(tmp_path, "s.obj", V3 + "v 1 1 0\n" + face + "\n"),
            r"s\.obj' is corrupt: face 1 \(line 5\) has corner '" + token
            + r"'; a corner starts with its vertex index \(v, v/vt, v//vn or "
            r"v/vt/vn\)")


@pytest.mark.parametrize("eol", ["\n", "\r\n", "\r", "mixed"])
def test_obj_line_ends_cr_crlf_and_lf_alike(tmp_path, eol):
    # audit D10: with old Mac line ends (CR only) faces were lost
    lines = ["# square", "v 0 0 0", "v 1 0 0", "v 0 1 0", "v 1 1 0", "f 1 2 3",
             "f 2 4 3", "f 1 2 \\", "4"]
    ends = ["\r", "\n", "\r\n"] * 3 if eol == "mixed" else [eol] * 9
    text = "".join(a + b for a, b in zip(lines, ends, strict=True))
    m = vs.load_mesh(write(tmp_path, "e.obj", text), repair=False)
    assert m.faces.tolist() == [[0, 1, 2], [1, 3, 2], [0, 1, 3]]
    bad = text.replace("f 2 4 3", "f 2 5 3")
    refused(write(tmp_path, "b.obj", bad), r"b\.obj' is corrupt: face 2 \(line 7\) "
            r"refers to vertex 5; the file has 4 vertices")


@pytest.mark.parametrize(("text", "match"), [
    (b"v 0 0 0\nv 1 0 0\nv 0 1 \xe9\nf 1 2 3\n",
     r"vertex 3 has b'\\xe9' where a number should be"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 é\nf 1 2 3\n".encode(),
     r"vertex 3 has 'é' where a number should be"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\xff\n",
     r"face 1 \(line 4\) has vertex index b'3\\xff'; expected an integer"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 \xe2\x84\x96\n",
     r"face 1 \(line 4\) has vertex index '№'; expected an integer"),
])
def test_obj_token_bytes_are_shown_as_they_are(tmp_path, text, match):
    # audit D15: bytes that are not UTF-8 were shown as Latin-1 ('é' for \xe9)
    refused(write(tmp_path, "t.obj", text), r"t\.obj' is corrupt: " + match)


@pytest.mark.parametrize(("n", "claimed", "extra"), [(3, 4, b""), (3, 2, b""),
                                                      (3, 3, b"\0")])
def test_binary_stl_count_that_does_not_match_the_size_is_named(tmp_path, n, claimed,
                                                                extra):
    # audit D17: reported as "holds no triangles"
    data = binary_stl(n, claimed=claimed) + extra
    err = refused(write(tmp_path, "m.stl", data), r"m\.stl' is truncated or corrupt: "
                  rf"its binary STL header announces {claimed} triangles, which take "
                  rf"{84 + 50 * claimed} bytes \(84 \+ 50 each\), but the file has "
                  rf"{len(data)} bytes$")
    assert "holds no triangles" not in str(err)


BOM = b"\xef\xbb\xbf"  # UTF-8 byte order mark, as Windows tools write text


def test_obj_with_a_utf8_byte_order_mark_keeps_its_first_vertex(tmp_path):
    # audit s35 loaders: the BOM hid the first 'v' line, so every index pointed
    # one vertex further and a file with a spare vertex loaded another mesh
    text = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 7 7 7\nf 1 2 3\nf 1 2 4\n"
    plain = vs.load_mesh(write(tmp_path, "a.obj", text), repair=False)
    marked = vs.load_mesh(write(tmp_path, "b.obj", BOM + text), repair=False)
    assert marked.vertices.tolist() == plain.vertices.tolist()
    assert marked.faces.tolist() == plain.faces.tolist()
    assert marked.load_info.vertices_in == 5


@pytest.mark.parametrize(("name", "text"), [
    ("t.stl", TRI_STL % (b"x", b"x")),
    ("t.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
              b"property float y\nproperty float z\nelement face 1\n"
              b"property list uchar int vertex_indices\nend_header\n"
              b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
    ("t.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
])
def test_text_files_with_a_utf8_byte_order_mark_load(tmp_path, name, text):
    # audit s35 loaders: refused, an ASCII STL as a binary one announcing
    # 170,926,129 triangles (the BOM was taken for header bytes)
    m = vs.load_mesh(write(tmp_path, name, BOM + text), repair=False)
    assert m.vertices.tolist() == [[0, 0, 0], [1000, 0, 0], [0, 1000, 0]]
    assert m.faces.tolist() == [[0, 1, 2]]


def test_ascii_stl_with_old_mac_line_ends_loads(tmp_path):
    # audit s35 loaders: with CR-only line ends the name line ran to the end of
    # the file, and it was refused as "without a complete 'solid ... endsolid'
    # block: truncated?" (compat='cura' read it, as OBJ files read)
    text = (TRI_STL % (b"x", b"x")).replace(b"\n", b"\r")
    m = vs.load_mesh(write(tmp_path, "mac.stl", text), repair=False)
    assert m.vertices.tolist() == [[0, 0, 0], [1000, 0, 0], [0, 1000, 0]]
    bad = text.replace(b"vertex 0 1 0", b"vertex 0 1 q")
    refused(write(tmp_path, "bad.stl", bad), r"bad\.stl' is corrupt: vertex 3 has "
            r"'q' where a number should be")
    quad = text.replace(b"endloop", b"vertex 1 1 0\rendloop")
    refused(write(tmp_path, "quad.stl", quad), r"facets must have 3 vertices each; "
            r"got 4 vertices in 1 facets")


@pytest.mark.parametrize("end", [b"\n", b"\r\n"])
@pytest.mark.parametrize(("solid", "cut"), [
    (b"solid b\n", b""), (b"solid\n", b""), (b"solid b\n", b"facet normal 0 0 1\n"),
    (b"solid b\n", b"facet normal 0 0 1\nouter loop\nvert")])
def test_ascii_stl_cut_in_a_later_solid_before_its_first_vertex(tmp_path, solid, cut,
                                                                  end):
    # audit s35 loaders: the cut solid was dropped and the file loaded with the
    # first solid only (its endsolid stood after the last vertex); a nameless
    # solid and Windows line ends are found alike
    text = (TRI_STL % (b"a", b"a") + solid + cut).replace(b"\n", end)
    refused(write(tmp_path, "cut.stl", text), r"cut\.stl' is truncated or corrupt: "
            r"its ASCII STL solid on line 10 has no 'endsolid'")
    whole = TRI_STL % (b"a", b"a") + (TRI_STL % (b"b", b"b")).replace(b"0 1 0",
                                                                     b"0 0 1")
    assert vs.load_mesh(write(tmp_path, "two.stl", whole)).n_faces == 2

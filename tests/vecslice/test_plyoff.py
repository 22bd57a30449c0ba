"""PLY and OFF read by vecslice.plyoff. Binary PLY: every element walked through
its list counts, faces of mixed corner counts loaded as fans, lying counts refused
(audit s24 D1). ASCII PLY and OFF: the numbers the row checks parsed are the mesh,
as trimesh read them from clean files. Every file is generated here."""

import struct

import numpy as np
import pytest

import vecslice as vs
from vecslice.meshfile import read_mesh_file

CODES = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i",
         "uint": "I", "float": "f", "double": "d"}
CUBE_V = [(x, y, z) for z in (0, 10) for y in (0, 10) for x in (0, 10)]
# bottom and top as quads (outward), the sides as two triangles each
CUBE_F = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5], [0, 5, 4], [1, 3, 7], [1, 7, 5],
          [3, 2, 6], [3, 6, 7], [2, 0, 4], [2, 4, 6]]
XYZ = [("x", "float"), ("y", "float"), ("z", "float")]


def ply(elements, order="<"):
    """A PLY file. ``elements``: (name, properties, records); a property is
    (name, type) or (name, (count type, value type)); a record holds a value per
    property, a list for a list property, or (count, list) to write a count that
    is not the list's length."""
    fmt = {"<": "binary_little_endian", ">": "binary_big_endian", "a": "ascii"}[order]
    head = [f"ply\nformat {fmt} 1.0\n"]
    body = []
    for name, props, records in elements:
        head.append(f"element {name} {len(records)}\n")
        for pname, ptype in props:
            head.append(f"property list {ptype[0]} {ptype[1]} {pname}\n"
                        if isinstance(ptype, tuple) else f"property {ptype} {pname}\n")
        for rec in records:
            row = []
            for (_, ptype), value in zip(props, rec, strict=True):
                if isinstance(ptype, tuple):
                    n, items = (value if isinstance(value, tuple)
                                else (len(value), value))
                    row.append(_pack(order, ptype[0], [n])
                               + (b" " if order == "a" else b"")
                               + _pack(order, ptype[1], items))
                else:
                    row.append(_pack(order, ptype, [value]))
            body.append(b" ".join(row) + b"\n" if order == "a" else b"".join(row))
    return ("".join(head) + "end_header\n").encode() + b"".join(body)


def _pack(order, ptype, values):
    if order == "a":
        return " ".join(str(v) for v in values).encode()
    return struct.pack(order + CODES[ptype] * len(values), *values)


def mesh_ply(v, f, order="<", counts="uchar", index="int"):
    return ply([("vertex", XYZ, v), ("face", [("vertex_indices", (counts, index))],
                                     [[face] for face in f])], order)


def write(tmp_path, name, data):
    p = tmp_path / name
    p.write_bytes(data)
    return p


def refused(path, match):
    with pytest.raises(vs.MeshFileError, match=match):
        vs.load_mesh(path)


def triangles(v, f):
    """The triangles of (v, f): corner positions from the least, sorted."""
    v = np.asarray(v, np.float64)
    out = []
    for t in np.asarray(f):
        corners = [tuple(p) for p in v[t].tolist()]
        k = corners.index(min(corners))  # rotated, not reflected: winding kept
        out.append(tuple(corners[k:] + corners[:k]))
    return sorted(out)


def fans(v, faces):
    return triangles(v, [(p[0], p[j], p[j + 1]) for p in faces
                         for j in range(1, len(p) - 1)])


@pytest.mark.parametrize("order", ["<", ">"])
def test_faces_of_mixed_corner_counts_load_as_fans(tmp_path, order):
    # Blender's PLY exporter writes binary faces of 3 and 4 corners, mixed: they
    # were refused ("PLY is unexpected length!")
    for counts, index in [("uchar", "int"), ("ushort", "uint"), ("char", "short")]:
        p = write(tmp_path, "c.ply", mesh_ply(CUBE_V, CUBE_F, order, counts, index))
        v, f = read_mesh_file(p)
        assert triangles(v, f) == fans(CUBE_V, CUBE_F)
        m = vs.load_mesh(p)
        assert m.n_faces == 12 and m.is_watertight
    twin = write(tmp_path, "a.ply", mesh_ply(CUBE_V, CUBE_F, "a"))
    assert triangles(*read_mesh_file(twin)) == fans(CUBE_V, CUBE_F)


def test_polygons_as_long_as_uniform_records_load_their_own_triangles(tmp_path):
    # a quad, a triangle and a pentagon: 12 corners, the size of three quads;
    # trimesh read them with a 4-corner stride and loaded other triangles
    faces = [[0, 1, 2, 3], [1, 3, 4], [0, 4, 5, 6, 7]]
    for first in (faces, faces[::-1]):  # a pentagon first: fewer bytes than 3 of it
        v, f = read_mesh_file(write(tmp_path, "p.ply", mesh_ply(CUBE_V, first)))
        assert triangles(v, f) == fans(CUBE_V, first)


# byte offsets of the faces below: 4 vertices of 12 bytes, then 13 per triangle
@pytest.mark.parametrize(("make", "match", "at"), [
    # the counts say 0, 2 and 1 corners, each followed by 3 indices: loaded as
    # 4 triangles before
    (lambda: mesh_ply(CUBE_V[:4], [[0, 1, 2], (0, [0, 2, 3]), (2, [1, 3, 2]),
                                   (1, [0, 3, 1])]),
     r"is corrupt: PLY 'face' 1 \(byte {}\) has a list of 0 values; a face needs "
     r"at least 3 vertices$", 48 + 13),
    (lambda: mesh_ply(CUBE_V[:4], [[0, 1], [1, 2]]),
     r"PLY 'face' 0 \(byte {}\) has a list of 2 values; a face needs at least 3",
     48),
    (lambda: mesh_ply(CUBE_V[:4], [[0, 1, 2], (-1, [])], counts="char"),
     r"PLY 'face' 1 \(byte {}\) has a list of -1 values", 48 + 13),
    (lambda: mesh_ply(CUBE_V[:4], [(2**32 - 1, [0, 1, 2])], counts="uint"),
     r"is truncated or corrupt: PLY 'face' 0 \(byte {}\) runs past the end of the "
     r"file \(\d+ bytes\)", 48),
    (lambda: mesh_ply(CUBE_V[:4], [[0, 1, 2], [0, 2, 3, 1]])[:-1],
     r"is truncated or corrupt: PLY 'face' 1 \(byte {}\) runs past the end", 61),
    (lambda: mesh_ply(CUBE_V[:4], [[0, 1, 2], [0, 2, 3, 1]]) + b"\n",
     r"is corrupt: 1 bytes follow the elements its PLY header announces", 0),
    (lambda: ply([("vertex", [*XYZ, ("n", ("char", "float"))],
                   [(0, 0, 0, [1.0]), (1, 0, 0, (-3, []))]),
                  ("face", [("vertex_indices", ("uchar", "int"))], [])]),
     r"PLY 'vertex' 1 \(byte {}\) has a list of -3 values$", 12 + 1 + 4),
    (lambda: mesh_ply(CUBE_V, CUBE_F).replace(b"binary_little_endian",
                                              b"binary_middle_endian"),
     r"unknown PLY format 'binary_middle_endian'", 0),
    (lambda: mesh_ply(CUBE_V, CUBE_F).replace(b"float z", b"float4 z"),
     r"PLY header line 'property float4 z' has an unknown property type", 0),
    (lambda: mesh_ply(CUBE_V, CUBE_F).replace(b"float z", b"float w"),
     r"the PLY vertex element has no z property", 0),
    (lambda: mesh_ply(CUBE_V, CUBE_F).replace(b"list uchar", b"list float"),
     r"PLY face list property 'vertex_indices' must have integer types", 0),
    (lambda: mesh_ply(CUBE_V, CUBE_F, index="double"),
     r"PLY face list property 'vertex_indices' must have integer types", 0),
])
def test_lying_or_damaged_binary_ply_is_refused(tmp_path, make, match, at):
    data = make()
    body = data.index(b"end_header\n") + len(b"end_header\n")
    refused(write(tmp_path, "bad.ply", data),
            r"bad\.ply' .*" + match.replace("{}", f"{body + at:,}"))


@pytest.mark.parametrize("order", ["<", ">"])
def test_other_properties_and_elements_are_walked(tmp_path, order):
    """Elements before and after the faces, properties around the corner list,
    lists of varying lengths everywhere: only x, y, z and the corners count."""
    rng = np.random.default_rng(7)
    material = ("material", [("ambient", "uchar"), ("name", ("uchar", "char"))],
                [(1, [65, 66]), (2, []), (3, [67])])
    vertex = ("vertex", [("w", "double"), *XYZ, ("red", "uchar"),
                         ("tags", ("ushort", "short"))],
              [(0.5, *p, 200, list(rng.integers(-9, 9, k)))
               for p, k in zip(CUBE_V, rng.integers(0, 4, len(CUBE_V)), strict=True)])
    face = ("face", [("flags", "uchar"), ("vertex_index", ("uchar", "uint")),
                     ("texcoord", ("uchar", "float"))],
            [(1, p, list(rng.random(2 * len(p)))) for p in CUBE_F])
    edge = ("edge", [("vertex1", "int"), ("vertex2", "int")], [(0, 1), (1, 2)])
    p = write(tmp_path, "o.ply", ply([material, vertex, face, edge], order))
    v, f = read_mesh_file(p)
    assert v.tolist() == [list(map(float, q)) for q in CUBE_V]
    assert triangles(v, f) == fans(CUBE_V, CUBE_F)
    # a single list under another name is the corners, as in ASCII files
    face = ("face", [("vidx", ("uchar", "int"))], [[q] for q in CUBE_F])
    p = write(tmp_path, "n.ply", ply([("vertex", XYZ, CUBE_V), face], order))
    assert triangles(*read_mesh_file(p)) == fans(CUBE_V, CUBE_F)
    face = ("face", [("a", ("uchar", "int")), ("b", ("uchar", "int"))],
            [(q, q) for q in CUBE_F])
    refused(write(tmp_path, "two.ply", ply([("vertex", XYZ, CUBE_V), face], order)),
            r"two\.ply': the PLY face element must have one list property of "
            r"vertex indices; got list properties \['a', 'b'\]")


@pytest.mark.parametrize("order", ["<", ">"])
def test_binary_bunny_loads_as_its_ascii_file(meshes_dir, tmp_path, order):
    v, f = read_mesh_file(meshes_dir / "bun_zipper_res2.ply")  # ASCII
    v32 = v.astype(np.float32)
    props = [*XYZ, ("confidence", "float"), ("intensity", "float")]
    records = [(*p, 0.5, 0.25) for p in v32.tolist()]
    rng = np.random.default_rng(3)
    for extra in (False, True):  # triangles alike; or beside lists of any length
        fprops = [("vertex_indices", ("uchar", "int"))]
        frecs = [[t] for t in f.tolist()]
        if extra:
            fprops.append(("texcoord", ("uchar", "float")))
            frecs = [[t, [0.0] * int(k)] for t, k in zip(
                f.tolist(), rng.integers(0, 7, len(f)), strict=True)]
        p = write(tmp_path, "b.ply", ply([("vertex", props, records),
                                          ("face", fprops, frecs)], order))
        vb, fb = read_mesh_file(p)
        assert np.array_equal(vb, v32.astype(np.float64)) and np.array_equal(fb, f)


@pytest.mark.parametrize("order", ["a", "<"])
def test_face_texture_coordinates_are_not_vertex_indices(tmp_path, order):
    # MeshLab writes a float 'texcoord' list beside the corners: it was refused
    # as if it held vertex indices
    tris = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    face = ("face", [("vertex_indices", ("uchar", "int")),
                     ("texcoord", ("uchar", "float"))],
            [(t, [0.0, 0.5, 1.0, 0.5, 0.25, 0.75]) for t in tris])
    p = write(tmp_path, "t.ply", ply([("vertex", XYZ, [*CUBE_V[:3], (0, 0, 10)]),
                                      face], order))
    m = vs.load_mesh(p)
    assert m.n_faces == 4 and m.is_watertight


# ---------------------------------------------------------------------------
# ASCII PLY and OFF, read here since session 25 (trimesh read them before)
# ---------------------------------------------------------------------------


def trimesh_read(path):
    import trimesh

    tm = trimesh.load(path, process=False)
    return np.asarray(tm.vertices, np.float64), np.asarray(tm.faces, np.int64)


def off_text(v, f, extra=""):
    rows = [f"{x!r} {y!r} {z!r}{extra}" for x, y, z in v]
    rows += [" ".join(map(str, [len(p), *p])) + extra for p in f]
    return f"OFF\n{len(v)} {len(f)} 0\n" + "\n".join(rows) + "\n"


def test_ascii_ply_and_off_load_as_trimesh_loads_clean_files(meshes_dir, tmp_path):
    """Real and generated clean files: the arrays trimesh gives, value for value
    (float properties rounded to float32 as trimesh does)."""
    bunny = meshes_dir / "bun_zipper_res2.ply"
    for path in [bunny]:
        v, f = read_mesh_file(path)
        tv, tf = trimesh_read(path)
        assert np.array_equal(v, tv) and np.array_equal(f, tf)
    rng = np.random.default_rng(25)
    for trial in range(6):
        v = rng.uniform(-100, 100, (40, 3)).round(trial)  # 0 to 5 decimals
        f = rng.integers(0, 40, (60, 3))
        for name, data in [("r.ply", mesh_ply(v.tolist(), f.tolist(), "a")),
                           ("r.off", off_text(v.tolist(), f.tolist()).encode())]:
            path = write(tmp_path, name, data)
            got, want = read_mesh_file(path), trimesh_read(path)
            assert np.array_equal(got[0], want[0]), name
            assert np.array_equal(got[1], want[1]), name
    p = write(tmp_path, "f.ply", mesh_ply([(0.1, 0.2, 0.3), (1, 0, 0), (0, 1, 0)],
                                          [[0, 1, 2]], "a"))
    assert read_mesh_file(p)[0][0].tolist() == np.float32([0.1, 0.2, 0.3]).tolist()


@pytest.mark.parametrize("blank", [b"\x0c", b"\x0b", b"\n"])
def test_ascii_rows_are_lines_whatever_blanks_they_hold(tmp_path, blank):
    """A form feed or vertical tab inside a row split it for trimesh ("holds no
    triangles", or other triangles); a blank line between rows raised trimesh's
    IndexError or UnboundLocalError."""
    v = [*CUBE_V[:3], (0, 0, 10)]
    tris = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    clean = mesh_ply(v, tris, "a")
    head, body = clean.split(b"end_header\n")
    rows = body.split(b"\n")
    rows[5] = rows[5].replace(b" ", b" " + blank if blank != b"\n" else b" ", 1)
    if blank == b"\n":
        rows.insert(5, b"")  # a blank line among the faces
        rows.insert(2, b"  \t")
    path = write(tmp_path, "b.ply", head + b"end_header\n" + b"\n".join(rows))
    assert triangles(*read_mesh_file(path)) == triangles(v, tris)
    off = off_text(v, tris).encode().replace(b"3 0 1 3", b"3 0" + blank.replace(
        b"\n", b" ") + b"1 3").replace(b"\n3 0 2 1", b"\n\n3 0 2 1")
    path = write(tmp_path, "b.off", off)
    assert triangles(*read_mesh_file(path)) == triangles(v, tris)


def test_an_element_without_properties_holds_nothing(tmp_path):
    """Its records are empty lines; trimesh raised UnboundLocalError."""
    v = [*CUBE_V[:3], (0, 0, 10)]
    tris = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    for order in ("a", "<"):
        data = ply([("vertex", XYZ, v), ("note", [], [(), ()]),
                    ("face", [("vertex_indices", ("uchar", "int"))],
                     [[t] for t in tris]), ("end", [], [()] * 5)], order)
        assert b"element note 2\n" in data and b"element end 5\n" in data
        path = write(tmp_path, "e.ply", data)
        assert triangles(*read_mesh_file(path)) == triangles(v, tris)


def test_a_vertex_index_that_is_not_an_integer_is_refused(tmp_path):
    """trimesh truncated 1.5 to 1: another triangle, silently."""
    v = [*CUBE_V[:3], (0, 0, 10)]
    tris = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    data = mesh_ply(v, tris, "a").replace(b"3 0 1 3\n", b"3 0 1.5 3\n")
    refused(write(tmp_path, "i.ply", data),
            r"i\.ply' is corrupt: PLY face 1 has vertex index 1\.5; indices are "
            "integers")
    off = off_text(v, tris).encode().replace(b"3 0 3 2\n", b"3 0 3 2e-1\n")
    refused(write(tmp_path, "i.off", off),
            r"i\.off' is corrupt: OFF face 2 has vertex index 0\.2; indices are "
            "integers")


# ---------------------------------------------------------------------------
# hostile and corrupt ASCII files (audit s25 ply)
# ---------------------------------------------------------------------------

TET = [*CUBE_V[:3], (0, 0, 10)]
TET_F = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]


def ascii_ply(vertex_props, vertex_rows, face_rows, head_extra=""):
    head = (f"ply\nformat ascii 1.0\n{head_extra}element vertex {len(vertex_rows)}\n"
            + "".join(f"property {t} {n}\n" for n, t in vertex_props)
            + f"element face {len(face_rows)}\n"
            "property list uchar int vertex_indices\nend_header\n")
    return (head + "".join(r + "\n" for r in vertex_rows)
            + "".join(r + "\n" for r in face_rows)).encode()


@pytest.mark.parametrize(("ptype", "value", "shown"), [
    ("int", "1.5", "1.5"), ("uchar", "300", "300"), ("int", "3e9", "3000000000"),
    ("uint", "-1", "-1")])
def test_an_integer_property_must_hold_its_value(tmp_path, ptype, value, shown):
    """D1: 1.5 in an int loaded as 1, 300 in a uchar as 44, -1 in a uint as
    4294967295 (cast without a check)."""
    rows = ["0 0 0", f"{value} 0 0", "0 10 0", "0 0 10"]
    data = ascii_ply([("x", ptype), ("y", "int"), ("z", "int")], rows,
                     [" ".join(map(str, [3, *t])) for t in TET_F])
    refused(write(tmp_path, "i.ply", data),
            rf"i\.ply' is corrupt: PLY 'vertex' 1 \(line 11\) has x = {shown}, which "
            rf"its type {ptype} cannot hold")
    rows[1] = "10 0 0"
    path = write(tmp_path, "ok.ply", ascii_ply(
        [("x", ptype), ("y", "int"), ("z", "int")], rows,
        [" ".join(map(str, [3, *t])) for t in TET_F]))
    assert triangles(*read_mesh_file(path)) == triangles(TET, TET_F)


def test_a_bad_token_in_a_large_body_is_found_in_a_few_parses(tmp_path, monkeypatch):
    """D2: the bad token was looked for by parsing every token alone (12 MB: 15 s);
    the message had no line."""
    from vecslice import meshfile

    n = 20_000
    rows = ["0.5 0.25 0.125"] * n
    rows[-1] = "0.5 0.25 -1.#IND"
    data = ascii_ply(XYZ, rows, ["3 0 1 2"])
    calls = []
    real = meshfile._numbers
    monkeypatch.setattr(meshfile, "_numbers",
                        lambda *a: calls.append(1) or real(*a))
    refused(write(tmp_path, "b.ply", data),
            rf"b\.ply' is corrupt: '-1\.#IND' where a number should be \(line "
            rf"{n + 9}\)")
    assert len(calls) < 40  # log2 of the 60,004 tokens, and the first parse
    off = (b"OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 x\n0 0 1\n3 0 1 2\n")
    refused(write(tmp_path, "b.off", off),
            r"b\.off' is corrupt: 'x' where a number should be \(line 5\)")


def test_a_list_count_beyond_int64_is_refused_by_name(tmp_path):
    """D3: a count of 2**63 or 1e19 wrapped to a negative row position: IndexError."""
    for count in ("9223372036854775808", "1e19", "inf"):
        data = (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                b"property float y\nproperty float z\nelement face 1\n"
                b"property list uchar int vertex_indices\n"
                b"property list uchar float texcoord\nend_header\n"
                b"0 0 0\n1 0 0\n0 1 0\n" + count.encode() + b" 0 1 2 0\n")
        refused(write(tmp_path, "w.ply", data),
                r"w\.ply' is truncated or corrupt: PLY 'face' 0 \(line 14\) has 5 "
                r"values; its header's properties need")


@pytest.mark.parametrize(("name", "data", "match"), [
    ("t.ply", ascii_ply([("x", "float4"), ("y", "float"), ("z", "float")], [], []),
     r"PLY header line 'property float4 x' has an unknown property type"),
    ("d.ply", b"ply\nformat ascii 1.0\nelement face " + b"9" * 5000 + b"\nend_header\n",
     r"PLY header line 'element face 9999.*'\.\.\.: the count must be a whole "
     r"number below 10\*\*18"),
    ("s.ply", "ply\nformat ascii 1.0\nelement face ²\nend_header\n".encode(),
     r"PLY header line 'element face ²': the count must be a whole number"),
    ("d.off", b"OFF\n" + b"9" * 5000 + b" 1 0\n0 0 0\n",
     r"is not an OFF file: no 'OFF' line followed by the vertex and face counts"),
])
def test_header_input_never_leaks_a_python_error(tmp_path, name, data, match):
    """D4: KeyError 'float4' (ASCII), int()'s 4300-digit limit, isdigit('²')."""
    refused(write(tmp_path, name, data), match)


@pytest.mark.parametrize(("face", "match"), [
    ("3.0000001 0 1 3", r"has a list of 3\.0000001 values; a list's length is a "
                        r"whole number >= 0"),
    ("3 0 1.0000001 3", r"PLY face 1 has vertex index 1\.0000001; indices are "
                        r"integers"),
    ("3 0 2 inf", r"PLY face 1 has vertex index inf; beyond any vertex"),
    ("3 0 2 99999999999999999999999", r"PLY face 1 has vertex index 1e\+23; beyond "
                                      r"any vertex"),
])
def test_messages_show_the_numbers_the_file_holds(tmp_path, face, match):
    """D5: 3.0000001 was shown as 3, inf and 1e23 as vertex -9223372036854775808."""
    rows = [" ".join(map(str, p)) for p in TET]
    data = ascii_ply(XYZ, rows, ["3 0 2 1", face, "3 0 3 2", "3 1 2 3"])
    refused(write(tmp_path, "m.ply", data), match)


def test_header_lines_end_at_line_feeds_only(tmp_path):
    """D6: a comment holding Å (UTF-8: \\x85 in Latin-1), \\f or \\v shifted every
    line number; a comment ending with 'end_header' ended the header; 30,000
    elements gave a 439 KB message."""
    for comment in ("comment Ångström", "comment a\fb\vc", "comment end_header"):
        rows = [" ".join(map(str, p)) for p in TET]
        data = ascii_ply(XYZ, rows, ["3 0 2 1", "2 0 1", "3 0 3 2", "3 1 2 3"],
                         head_extra=comment + "\n")
        refused(write(tmp_path, "h.ply", data),
                r"PLY 'face' 1 \(line 16\) has a list of 2 values; a face needs at "
                r"least 3 vertices")
        data = data.replace(b"2 0 1\n", b"3 0 1 3\n")
        assert triangles(*read_mesh_file(write(tmp_path, "h.ply", data))) == \
            triangles(TET, TET_F)
    many = b"".join(b"element e%d 1\nproperty float a\n" % k for k in range(30_000))
    data = b"ply\nformat ascii 1.0\n" + many + b"end_header\n" + b"1\n" * 29_999
    with pytest.raises(vs.MeshFileError, match=r"announces 1 'e0' and 1 'e1' and 1 "
                       r"'e2' and 1 'e3' and 29,996 more elements") as info:
        vs.load_mesh(write(tmp_path, "many.ply", data))
    assert len(str(info.value)) < 400


def test_a_nul_byte_in_the_body_is_named_where_it_is(tmp_path):
    """numpy's parser stops at a NUL as at the end: the halving search named a
    later, good token."""
    rows = [" ".join(map(str, p)) for p in TET]
    rows[2] = "0 10\x000 0"
    data = ascii_ply(XYZ, rows, [" ".join(map(str, [3, *t])) for t in TET_F])
    refused(write(tmp_path, "z.ply", data),
            r"z\.ply' is corrupt: '10\\x000' where a number should be \(line 12\)")


# ---------------------------------------------------------------------------
# audit D16: header lines that say nothing PLY knows were skipped
# ---------------------------------------------------------------------------

GOOD = ascii_ply(XYZ, [" ".join(map(str, p)) for p in TET],
                 [" ".join(map(str, [3, *t])) for t in TET_F]).decode()


@pytest.mark.parametrize(("old", "new", "line", "why"), [
    ("element vertex 4\n", "element vertex 4\npropety float w\n", 4,
     r"expected 'format', 'element', 'property', 'comment' or 'obj_info'"),
    ("element vertex 4\n", "element vertex\nelement vertex 4\n", 3,
     r"expected 'element NAME COUNT'"),
    ("element vertex 4\n", "element vertex 4 x\n", 3,
     r"expected 'element NAME COUNT'"),
    ("property float x\n", "property float x y\n", 4,
     r"expected 'property TYPE NAME' or 'property list COUNT_TYPE VALUE_TYPE NAME'"),
    ("property list uchar int vertex_indices\n", "property list uchar int\n", 8,
     r"expected 'property TYPE NAME' or 'property list COUNT_TYPE VALUE_TYPE NAME'"),
    ("format ascii 1.0\n", "format ascii 1.0\nproperty float q\n", 3,
     r"a property before any element"),
    ("format ascii 1.0\n", "format ascii\n", 2,
     r"expected 'format ascii\|binary_little_endian\|binary_big_endian VERSION'"),
    ("format ascii 1.0\n", "format ascii 1.0\nformat ascii 1.0\n", 3,
     r"a second 'format' line"),
    ("ply\n", "ply 1\n", 1, r"the first line is 'ply'"),
    ("end_header\n", "end_header\n", 0, ""),  # a clean file, for reference
])
def test_a_malformed_header_line_is_refused_by_number(tmp_path, old, new, line, why):
    data = GOOD.replace(old, new, 1).encode()
    p = write(tmp_path, "h.ply", data)
    if not line:
        assert triangles(*read_mesh_file(p)) == triangles(TET, TET_F)
        return
    text = data.decode().split("\n")[line - 1]
    refused(p, r"h\.ply' is corrupt: PLY header line '" + text.replace("|", r"\|")
            + r"' \(line " + str(line) + r"\): " + why)


@pytest.mark.parametrize(("old", "new", "match"), [
    ("format ascii 1.0\n", "", r"the PLY header has no 'format' line"),
    ("format ascii 1.0\n", "format text 1.0\n", r"unknown PLY format 'text'; "
     r"expected ascii, binary_little_endian or binary_big_endian"),
])
def test_a_header_without_a_known_format_is_refused(tmp_path, old, new, match):
    # both were read as ASCII
    refused(write(tmp_path, "f.ply", GOOD.replace(old, new, 1).encode()),
            r"f\.ply' is corrupt: " + match)


def test_comments_obj_info_and_blank_header_lines_are_allowed(tmp_path):
    data = GOOD.replace("element vertex", "comment made by hand\nobj_info x 1\n\n"
                        "  \ncomment\nelement vertex", 1).replace(
        "end_header", "obj_info\nend_header", 1)
    p = write(tmp_path, "c.ply", data.encode())
    assert triangles(*read_mesh_file(p)) == triangles(TET, TET_F)


def test_body_token_bytes_are_shown_as_they_are(tmp_path):
    # audit D15, as for OBJ: bytes that are not UTF-8 were shown as Latin-1
    rows = [" ".join(map(str, p)) for p in TET]
    for token, shown in ((b"\xe9", r"b'\\xe9'"), ("é".encode(), "'é'")):
        data = ascii_ply(XYZ, rows, [" ".join(map(str, [3, *t])) for t in TET_F])
        data = data.replace(b"\n0 10 0\n", b"\n0 10 " + token + b"\n")
        refused(write(tmp_path, "u.ply", data),
                r"u\.ply' is corrupt: " + shown + r" where a number should be "
                r"\(line 12\)")
        off = b"OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 " + token + b"\n0 0 1\n3 0 1 2\n"
        refused(write(tmp_path, "u.off", off),
                r"u\.off' is corrupt: " + shown + r" where a number should be "
                r"\(line 5\)")

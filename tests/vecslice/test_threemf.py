"""3MF reading (vecslice.threemf): every placement, units, limits, hostile
packages. Every package is generated here."""

import bz2
import io
import re
import struct
import subprocess
import sys
import tracemalloc
import warnings
import zipfile
import zlib

import numpy as np
import pytest

import vecslice as vs

CORE = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
PROD = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
RELS = (
    '<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns='
    '"http://schemas.openxmlformats.org/package/2006/relationships"><Relationship '
    'Target="/3D/3dmodel.model" Id="rel0" Type='
    '"http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>'
)
# a tetrahedron with its right-angle corner at the origin, 10 mm legs, outward
TET_V = [(0, 0, 0), (10, 0, 0), (0, 10, 0), (0, 0, 10)]
TET_F = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]


def mesh_object(oid, v=TET_V, f=TET_F):
    verts = "".join(f'<vertex x="{x}" y="{y}" z="{z}"/>' for x, y, z in v)
    tris = "".join(f'<triangle v1="{a}" v2="{b}" v3="{c}"/>' for a, b, c in f)
    return (f'<object id="{oid}" type="model"><mesh><vertices>{verts}</vertices>'
            f"<triangles>{tris}</triangles></mesh></object>")


def move(dx=0, dy=0, dz=0, m=(1, 0, 0, 0, 1, 0, 0, 0, 1)):
    return " ".join(str(x) for x in (*m, dx, dy, dz))


def components_object(oid, parts):
    """parts: (objectid, transform or None, extra attributes)."""
    comps = "".join(
        f'<component objectid="{o}"'
        + (f' transform="{t}"' if t else "") + f"{extra}/>"
        for o, t, extra in parts)
    return f'<object id="{oid}" type="model"><components>{comps}</components></object>'


def model(resources, items, unit=None, head=""):
    u = f' unit="{unit}"' if unit is not None else ""
    build = "".join(
        f'<item objectid="{o}"' + (f' transform="{t}"' if t else "") + "/>"
        for o, t in items)
    return (f'<?xml version="1.0" encoding="UTF-8"?>{head}<model{u} xmlns="{CORE}" '
            f'xmlns:p="{PROD}"><resources>{resources}</resources>'
            f"<build>{build}</build></model>")


def write_3mf(path, model_xml, *, rels=RELS, extra=(), method=zipfile.ZIP_DEFLATED):
    with zipfile.ZipFile(path, "w", method) as z:
        z.writestr("[Content_Types].xml", "<Types/>")
        if rels is not None:
            z.writestr("_rels/.rels", rels)
        if model_xml is not None:
            z.writestr("3D/3dmodel.model", model_xml)
        for name, data in extra:
            z.writestr(name, data)
    return path


def load(tmp_path, model_xml, name="m.3mf", **kw):
    return vs.load_mesh(write_3mf(tmp_path / name, model_xml, **kw), repair=False)


def refused(tmp_path, model_xml, match, **kw):
    with pytest.raises(vs.MeshFileError, match=match) as info:
        load(tmp_path, model_xml, **kw)
    assert isinstance(info.value, OSError)
    return info.value


# ---------------------------------------------------------------------------
# placements
# ---------------------------------------------------------------------------


def test_nested_reused_components_give_every_placement(tmp_path):
    # issue 8 B3: 5 x 5 x 5 placements of one tetrahedron through three levels
    # of reused components (trimesh's flattening kept 63 of 125)
    res = (mesh_object(1)
           + components_object(2, [(1, move(dx=20 * i), "") for i in range(5)])
           + components_object(3, [(2, move(dy=20 * j), "") for j in range(5)])
           + components_object(4, [(3, move(dz=20 * k), "") for k in range(5)]))
    m = load(tmp_path, model(res, [(4, None)]))
    assert m.n_bodies == 125 and m.n_faces == 500 and m.is_watertight
    corners = {tuple(c) for c in m.vertices[m.faces[::4, 0]].tolist()}
    lows = {tuple(m.vertices[m.faces[4 * b : 4 * b + 4]].reshape(-1, 3).min(axis=0))
            for b in range(125)}
    assert lows == {(20000 * i, 20000 * j, 20000 * k)
                    for i in range(5) for j in range(5) for k in range(5)}
    assert len(corners) == 125
    assert m.volume == pytest.approx(125 * 10_000**3 / 6)


def test_transforms_compose_component_first_then_item(tmp_path):
    # 3MF points are row vectors: p' = p @ M (3x3 rows, then the translation).
    # Component: 90 degrees about z (x -> y) and up 5 mm; item: scale 2, +100 x.
    rot = move(dz=5, m=(0, 1, 0, -1, 0, 0, 0, 0, 1))
    item = move(dx=100, m=(2, 0, 0, 0, 2, 0, 0, 0, 2))
    m = load(tmp_path, model(mesh_object(1) + components_object(2, [(1, rot, "")]),
                             [(2, item)]))
    # (10, 0, 0) -> (0, 10, 5) -> (0, 20, 10) + (100, 0, 0)
    assert [100000, 20000, 10000] in m.vertices.tolist()
    assert m.bounds.tolist() == [[80000, 0, 10000], [100000, 20000, 30000]]
    assert m.volume == pytest.approx(8 * 10_000**3 / 6)  # scale 2: 8 x, outward


def test_mirrored_placement_keeps_outward_winding(tmp_path):
    mirror = move(dx=50, m=(-1, 0, 0, 0, 1, 0, 0, 0, 1))
    m = load(tmp_path, model(mesh_object(1), [(1, None), (1, mirror)]))
    assert m.n_bodies == 2 and m.is_watertight
    assert m.volume == pytest.approx(2 * 10_000**3 / 6)  # both outward, no repair
    assert m.bounds.tolist() == [[0, 0, 0], [50000, 10000, 10000]]


def test_components_in_another_model_part(tmp_path):
    # production extension: a component's p:path names another model part
    other = model(mesh_object(7), [])
    res = components_object(1, [(7, move(dx=30), ' p:path="/3D/other.model"'),
                                (7, None, ' p:path="/3D/other.model"')])
    m = load(tmp_path, model(res, [(1, None)]),
             extra=[("3D/other.model", other)])
    assert m.n_bodies == 2 and m.bounds.tolist() == [[0, 0, 0], [40000, 10000, 10000]]


def test_shared_3mf_files_keep_their_counts(meshes_dir):
    p = vs.load_mesh(meshes_dir / "pyramids.3mf", repair=False)
    assert (p.load_info.faces_in, p.n_bodies, p.n_vertices) == (3276, 12, 1662)
    b = vs.load_mesh(meshes_dir / "3DBenchy.3mf", repair=False)
    assert (b.load_info.faces_in, b.load_info.vertices_in, b.n_faces) == (
        225154, 112569, 225146)


# ---------------------------------------------------------------------------
# units
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(("unit", "um"), [
    (None, 10_000), ("millimeter", 10_000), ("micron", 10), ("centimeter", 100_000),
    ("inch", 254_000), ("foot", 3_048_000), ("meter", 10_000_000)])
def test_unit_is_applied(tmp_path, unit, um):
    # issue 8 B2: inch, micron, centimetre files loaded as millimetres
    m = load(tmp_path, model(mesh_object(1), [(1, move(dx=1))], unit=unit))
    assert m.bounds.tolist() == [[um // 10, 0, 0], [um + um // 10, um, um]]


def test_unit_and_scale_multiply(tmp_path):
    path = write_3mf(tmp_path / "i.3mf", model(mesh_object(1), [(1, None)], "inch"))
    assert vs.load_mesh(path, scale=0.5).bounds[1].tolist() == [127000] * 3


@pytest.mark.parametrize("unit", ["furlong", "mm", "Millimeter", ""])
def test_unknown_unit_is_refused(tmp_path, unit):
    refused(tmp_path, model(mesh_object(1), [(1, None)], unit=unit),
            r"'.*m\.3mf': 3MF unit must be one of micron, millimeter, centimeter, "
            r"inch, foot, meter; got '" + unit + "'")


# ---------------------------------------------------------------------------
# zip bombs and size limits (issue 8 A2)
# ---------------------------------------------------------------------------


def _peak_mib(fn):
    tracemalloc.start()
    try:
        fn()
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return peak / 2**20


def test_zip_bomb_model_is_refused_before_inflating(tmp_path):
    # a valid model followed by 64 MiB of spaces: deflates about 1000 times
    xml = model(mesh_object(1), [(1, None)]) + " " * (64 << 20)
    path = write_3mf(tmp_path / "bomb.3mf", xml)
    assert path.stat().st_size < 1 << 20
    with pytest.raises(vs.MeshFileError, match=r"3MF part '/3D/3dmodel\.model' "
                       r"would inflate 1,0\d\d times .* a zip bomb\?"):
        vs.load_mesh(path)
    assert _peak_mib(lambda: _refuse(path)) < 8


def _refuse(path, match=None):
    with pytest.raises(vs.MeshFileError, match=match):
        vs.load_mesh(path)


def test_model_bytes_limit(tmp_path, monkeypatch):
    monkeypatch.setattr("vecslice.threemf.MAX_MODEL_BYTES", 2000)
    big = model(mesh_object(1, v=TET_V * 20), [(1, None)])  # > 2000 bytes
    assert len(big) > 2000
    refused(tmp_path, big, r"3MF part '/3D/3dmodel\.model' inflates to [\d,]+ bytes, "
            r"more than the [\d,]+ bytes left of vecslice's limit on model XML "
            r"\(2,000 bytes, vecslice\.threemf\.MAX_MODEL_BYTES\)")
    load(tmp_path, model(mesh_object(1), [(1, None)]))  # a small one still loads


def test_relationships_part_limit_is_named_as_its_own(tmp_path):
    # it was named as what is left of MAX_MODEL_BYTES (1 GiB)
    rels = RELS.replace("<Relationship ", " " * (2 << 20) + "<Relationship ", 1)
    refused(tmp_path, model(mesh_object(1), [(1, None)]),
            r"3MF part '_rels/\.rels' inflates to 2,097,\d{3} bytes, more than the "
            r"1,048,576 bytes vecslice reads of it$", rels=rels)


def test_only_model_parts_are_inflated(tmp_path):
    # a 64 MiB thumbnail and texture (1000 x compressed) are never read
    bomb = b"\0" * (64 << 20)
    path = write_3mf(tmp_path / "t.3mf", model(mesh_object(1), [(1, None)]),
                     extra=[("Metadata/thumbnail.png", bomb),
                            ("3D/Textures/t.png", bomb)])
    assert _peak_mib(lambda: vs.load_mesh(path)) < 8
    assert vs.load_mesh(path).n_faces == 4


def test_zip_entry_lying_about_its_size(tmp_path):
    xml = model(mesh_object(1), [(1, None)]).encode()
    path = write_3mf(tmp_path / "lie.3mf", xml, method=zipfile.ZIP_STORED)
    data = bytearray(path.read_bytes())
    # claim 100 bytes in the central directory entry of the model
    cd = data.rfind(b"PK\x01\x02", 0, data.rfind(b"3D/3dmodel.model"))
    struct.pack_into("<I", data, cd + 24, 100)
    path.write_bytes(bytes(data))
    with pytest.raises(vs.MeshFileError, match=r"cannot read .* as 3MF"):
        vs.load_mesh(path)


def test_absurd_expansion_is_refused_before_placing(tmp_path):
    # 10 levels of 10 components: 10**10 tetrahedra
    res = mesh_object(1) + "".join(
        components_object(k + 1, [(k, None, "")] * 10) for k in range(1, 11))
    err = refused(tmp_path, model(res, [(11, None)]),
                  r"the 3MF build expands to 40,000,000,000 triangles; vecslice "
                  r"reads at most 30,000,000 "
                  r"\(vecslice\.threemf\.MAX_BUILD_TRIANGLES\)")
    assert err.__cause__ is None


def test_absurd_placement_count_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr("vecslice.threemf.MAX_INSTANCES", 1000)
    res = mesh_object(1) + "".join(
        components_object(k + 1, [(k, None, "")] * 10) for k in range(1, 4))
    refused(tmp_path, model(res, [(4, None)]),
            r"expands to 1,111 object placements; vecslice reads at most 1,000")


def _many_vertices(n, seed=0):
    """A vertex list of n varied coordinates (compresses about 5 times)."""
    xyz = np.random.default_rng(seed).integers(0, 1000, (n, 3))
    return [tuple(r) for r in xyz.tolist()]


def test_vertex_count_is_refused_while_streaming(tmp_path, monkeypatch):
    # audit s23 D1: a small 3MF must not build per-vertex objects before a cap
    monkeypatch.setattr("vecslice.threemf.MAX_BUILD_VERTICES", 1000)
    path = write_3mf(tmp_path / "v.3mf", model(
        mesh_object(1, v=_many_vertices(200_000), f=[(0, 1, 2)]), [(1, None)]))
    with pytest.raises(vs.MeshFileError, match=r"v\.3mf': the 3MF objects hold more "
                       r"than 1,000 vertices \(object 1 reaches 65,536 in all\); "
                       r"vecslice reads at most 1,000 "
                       r"\(vecslice\.threemf\.MAX_BUILD_VERTICES\)"):
        vs.load_mesh(path)
    assert _peak_mib(lambda: _refuse(path)) < 12  # one chunk, not 200,000 strings


def test_vertex_count_is_refused_before_its_numbers_are_parsed(tmp_path, monkeypatch):
    # the count was checked once the chunk was parsed and kept
    import vecslice._threemf_model as threemf_model

    monkeypatch.setattr("vecslice.threemf.MAX_BUILD_VERTICES", 1000)
    parsed = []
    numbers = threemf_model._numbers
    monkeypatch.setattr(threemf_model, "_numbers", lambda text, dtype, n: (
        parsed.append(n), numbers(text, dtype, n))[1])
    refused(tmp_path, model(mesh_object(1, v=_many_vertices(5000), f=[(0, 1, 2)]),
                            [(1, None)]),
            r"the 3MF objects hold more than 1,000 vertices \(object 1 reaches 5,000 "
            r"in all\)")
    assert parsed == []


def test_a_read_is_held_to_the_limits_as_it_began(tmp_path, monkeypatch):
    # some limits were read as the read began, others at each check (and
    # MAX_BUILD_TRIANGLES both ways): a change while reading split them
    import vecslice.threemf as threemf

    begin = threemf._model_part

    def begun(pkg):  # the read has begun: every limit drops to 1
        for name in threemf.__all__:
            if name.startswith("MAX_"):
                monkeypatch.setattr(threemf, name, 1)
        monkeypatch.setattr("vecslice.meshfile.MAX_TRIANGLES", 1)
        return begin(pkg)

    res = mesh_object(1) + components_object(
        2, [(1, move(dx=20 * i), "") for i in range(3)])
    path = write_3mf(tmp_path / "m.3mf", model(res, [(2, None), (1, None)]))
    monkeypatch.setattr(threemf, "_model_part", begun)
    v, f = threemf.read_3mf(path, 0)
    assert f.shape == (16, 3) and v.shape == (16, 3)


@pytest.mark.parametrize(("v", "f", "match"), [
    (TET_V, TET_F, r"the 3MF build expands to 12 triangles; vecslice reads at most "
     r"10 \(vecslice\.meshfile\.MAX_TRIANGLES\)$"),
    (_many_vertices(11), [(0, 1, 2)], r"the 3MF build expands to 33 vertices; "
     r"vecslice reads at most 30 \(3 x vecslice\.meshfile\.MAX_TRIANGLES\)$"),
])
def test_the_limit_of_every_mesh_file_is_checked_before_placing(tmp_path,
                                                                 monkeypatch, v, f,
                                                                 match):
    # it was checked once the 3MF reader had made the arrays (by read_mesh_file)
    import vecslice.threemf as threemf

    monkeypatch.setattr("vecslice.meshfile.MAX_TRIANGLES", 10)
    res = mesh_object(1, v=v, f=f) + components_object(
        2, [(1, move(dx=20 * i), "") for i in range(3)])
    path = write_3mf(tmp_path / "m.3mf", model(res, [(2, None)]))
    with pytest.raises(vs.MeshFileError, match=match):
        threemf.read_3mf(path, 0)


def test_triangle_count_is_refused_while_streaming(tmp_path, monkeypatch):
    monkeypatch.setattr("vecslice.threemf.MAX_BUILD_TRIANGLES", 15)
    refused(tmp_path, model(mesh_object(1, f=TET_F * 3) + mesh_object(2, f=TET_F * 2),
                            [(1, None)]),
            r"the 3MF objects hold more than 15 triangles \(object 2 reaches 20 in "
            r"all\); vecslice reads at most 15 "
            r"\(vecslice\.threemf\.MAX_BUILD_TRIANGLES\)")


def test_expanded_vertex_count_is_refused_before_placing(tmp_path, monkeypatch):
    # audit s23 D2: one triangle over 1000 vertices, placed 10,000 times
    monkeypatch.setattr("vecslice.threemf.MAX_BUILD_VERTICES", 1_000_000)
    res = mesh_object(1, v=_many_vertices(1000), f=[(0, 1, 2)]) + "".join(
        components_object(k + 1, [(k, None, "")] * 10) for k in range(1, 5))
    refused(tmp_path, model(res, [(5, None)]),
            r"the 3MF build expands to 10,000,000 vertices; vecslice reads at most "
            r"1,000,000 \(vecslice\.threemf\.MAX_BUILD_VERTICES\)")
    load(tmp_path, model(res, [(4, None)]), name="ok.3mf")  # 1,000,000 loads


def test_default_expansion_cap_refuses_a_hundred_million_triangles(tmp_path):
    # audit s23 D2: 11 kB placing a 1000-triangle strip 100,000 times was read
    strip = mesh_object(1, v=[(i, i % 2, 0) for i in range(1002)],
                        f=[(i, i + 1, i + 2) for i in range(1000)])
    res = strip + "".join(
        components_object(k + 1, [(k, None, "")] * 10) for k in range(1, 6))
    path = write_3mf(tmp_path / "c.3mf", model(res, [(6, None)]))
    assert path.stat().st_size < 20_000
    with pytest.raises(vs.MeshFileError, match=r"expands to 100,000,000 triangles; "
                       r"vecslice reads at most 30,000,000"):
        vs.load_mesh(path)
    assert _peak_mib(lambda: _refuse(path)) < 8


def test_vertices_are_streamed_not_built_as_a_tree(tmp_path):
    # audit s23 D1: 20 MB of <vertex> XML took about 37 bytes of memory per byte
    # (libxml2's tree, which tracemalloc does not see): measure the process
    path = write_3mf(tmp_path / "big.3mf", model(
        mesh_object(1, v=_many_vertices(700_000), f=[(0, 1, 2)]), [(1, None)]))
    code = (
        "import resource, sys\n"
        "from pathlib import Path\n"
        "from vecslice.threemf import read_3mf\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        "v, f = read_3mf(Path(sys.argv[1]), 0)\n"
        "assert v.shape == (700_000, 3), v.shape\n"
        "print((resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) >> 10)\n")
    out = subprocess.run([sys.executable, "-c", code, str(path)], check=True,
                         capture_output=True, text=True).stdout
    assert int(out) < 150  # MiB; the coordinates alone are 16 MiB


def test_component_cycle_is_refused(tmp_path):
    res = (mesh_object(1) + components_object(2, [(1, None, ""), (3, None, "")])
           + components_object(3, [(4, None, "")])
           + components_object(4, [(2, None, "")]))
    refused(tmp_path, model(res, [(2, None)]),
            r"3MF components form a cycle: objects 2 -> 3 -> 4 -> 2")


# ---------------------------------------------------------------------------
# XML safety and damaged models
# ---------------------------------------------------------------------------

XXE = '<!DOCTYPE model [<!ENTITY xxe SYSTEM "file:///etc/hostname">]>'
LAUGHS = ("<!DOCTYPE model [<!ENTITY a \"aaaaaaaaaa\">"
          + "".join(f'<!ENTITY {c} "' + f"&{p};" * 10 + '">'
                    for p, c in zip("abcdefgh", "bcdefghi"))
          + "]>")


@pytest.mark.parametrize(("label", "head", "x"), [
    ("xxe", XXE, "&xxe;"),
    ("billion laughs", LAUGHS, "&i;"),
    ("after a comment", "<!-- hi --><?pi x?>\n" + XXE, "&xxe;"),
])
def test_document_type_declarations_are_refused(tmp_path, label, head, x):
    obj = mesh_object(1).replace('x="10"', f'x="{x}"', 1)
    refused(tmp_path, model(obj, [(1, None)], head=head),
            r"has a document type declaration \(DTD\), which 3MF does not allow")


def test_utf16_model_with_dtd_is_refused(tmp_path):
    xml = model(mesh_object(1), [(1, None)], head=XXE).replace(
        'encoding="UTF-8"', 'encoding="UTF-16"').encode("utf-16")
    refused(tmp_path, xml, r"document type declaration")


BAD_MODELS = [
    ("no build items", model(mesh_object(1), []), r"the 3MF build places no objects"),
    ("undefined object", model(mesh_object(1), [(2, None)]),
     r"build item 1 refers to object 2, which is not defined"),
    ("bad transform", model(mesh_object(1), [(1, "1 0 0 1")]),
     r"build item 1 has transform '1 0 0 1'; expected 12 finite numbers"),
    ("nan transform", model(mesh_object(1), [(1, move(dx="nan"))]),
     r"expected 12 finite numbers"),
    ("index out of range", model(mesh_object(1, f=[(0, 1, 4)]), [(1, None)]),
     r"object 1: triangle 0 refers to vertices \[0, 1, 4\], but the object has 4 "
     r"vertices"),
    ("bad coordinate", model(mesh_object(1).replace('x="10"', 'x="1O"', 1),
                             [(1, None)]),
     r"object 1: vertex 1 has coordinates '1O 0 0'; expected x, y and z numbers"),
    ("missing coordinate", model(mesh_object(1).replace(' y="10"', "", 1),
                                 [(1, None)]),
     r"vertex 2 has coordinates '0 None 0'"),
    ("fractional index", model(mesh_object(1).replace('v3="1"', 'v3="1.5"', 1),
                               [(1, None)]),
     r"triangle 0 has vertices '0 2 1\.5'"),
    ("duplicate id", model(mesh_object(1) + mesh_object(1), [(1, None)]),
     r"object 1 is defined twice"),
    # audit s35: a second list or mesh of an object was skipped without a word
    ("second triangles", model(mesh_object(1).replace(
        "</triangles>", '</triangles><triangles><triangle v1="0" v2="1" v3="3"/>'
        "</triangles>"), [(1, None)]),
     r"object 1: its <mesh> has a second <triangles>; a 3MF mesh has one"),
    ("second vertices", model(mesh_object(1).replace(
        "<triangles>", '<vertices><vertex x="0" y="0" z="9"/></vertices><triangles>'),
        [(1, None)]),
     r"object 1: its <mesh> has a second <vertices>; a 3MF mesh has one"),
    ("second mesh", model(mesh_object(1).replace(
        "</mesh>", "</mesh><mesh><vertices/><triangles/></mesh>"), [(1, None)]),
     r"object 1 has a second <mesh>; a 3MF object has one"),
    ("object id", model(mesh_object("x"), [(1, None)]),
     r"an object in '/3D/3dmodel\.model' has id 'x'; expected a number"),
    ("unknown required extension",
     model(mesh_object(1), [(1, None)]).replace(
         "<model ", '<model xmlns:b="http://example.com/beams" '
         'requiredextensions="b" '),
     r"3MF requires the extension 'http://example\.com/beams', which vecslice does "
     r"not read"),
    ("not a model", '<?xml version="1.0"?><foo><object id="1"/></foo>',
     r"3MF part '/3D/3dmodel\.model' is not a 3D model \(its root element is <foo>"),
    ("missing part", model(components_object(
        1, [(7, None, ' p:path="/3D/none.model"')]), [(1, None)]),
     r"component 0 of object 1 refers to part '/3D/none\.model' \(p:path\), which "
     r"the package does not contain"),
]


@pytest.mark.parametrize(("label", "xml", "match"), BAD_MODELS,
                         ids=[c[0] for c in BAD_MODELS])
def test_damaged_models_are_refused_clearly(tmp_path, label, xml, match):
    refused(tmp_path, xml, match)


def test_required_production_extension_is_read(tmp_path):
    xml = model(mesh_object(1), [(1, None)]).replace(
        "<model ", '<model requiredextensions="p" ')
    assert load(tmp_path, xml).n_faces == 4


def test_package_without_rels_uses_the_conventional_model_part(tmp_path):
    assert load(tmp_path, model(mesh_object(1), [(1, None)]), rels=None).n_faces == 4
    with pytest.raises(vs.MeshFileError, match=r"3MF holds no 3D model: no part is "
                       r"named in _rels/\.rels as the 3D model, and there is no "
                       r"3D/3dmodel\.model"):
        load(tmp_path, None, rels=None, name="empty.3mf")


def test_garbage_and_truncated_packages(tmp_path):
    good = write_3mf(tmp_path / "g.3mf", model(mesh_object(1), [(1, None)]))
    data = good.read_bytes()
    rng = np.random.default_rng(5)
    for trial in range(40):
        d = bytearray(data[: rng.integers(1, len(data))] if trial % 2 else data)
        if trial % 2 == 0:
            for i in rng.integers(0, len(d), 8):
                d[i] = int(rng.integers(0, 256))
        p = tmp_path / "bad.3mf"
        p.write_bytes(bytes(d))
        try:
            vs.load_mesh(p)
        except vs.VecsliceError:
            pass
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("_rels/.rels", "<Relationships")  # cut XML in the rels
    (tmp_path / "r.3mf").write_bytes(buf.getvalue())
    with pytest.raises(vs.MeshFileError, match=r"as 3MF: XMLSyntaxError in part "
                       r"'_rels/\.rels'"):
        vs.load_mesh(tmp_path / "r.3mf")


SPLIT_ATTRIBUTES = [
    # audit s24 D3: the attributes were parsed as one stream of numbers
    ("two numbers in y, z empty", ('<vertex x="0" y="0" z="10"/>',
                                   '<vertex x="0" y="0 10" z=""/>'),
     r"object 1: vertex 3 has coordinates '0 0 10 '; expected x, y and z numbers"),
    ("shift between vertices", ('<vertex x="10" y="0" z="0"/>'
                                '<vertex x="0" y="10" z="0"/>',
                                '<vertex x="10 0" y="0" z="0"/>'
                                '<vertex x="10" y="0" z=""/>'),
     r"object 1: vertex 1 has coordinates '10 0 0 0'"),
    ("tab inside, x empty", ('<vertex x="0" y="0" z="10"/>',
                             '<vertex x="" y="0&#9;0" z="10"/>'),
     r"object 1: vertex 3 has coordinates ' 0\\t0 10'"),
    ("two indices in v2", ('v1="0" v2="2" v3="1"', 'v1="0" v2="2 1" v3=""'),
     r"object 1: triangle 0 has vertices '0 2 1 '; expected v1, v2 and v3 indices"),
]


@pytest.mark.parametrize(("label", "edit", "match"), SPLIT_ATTRIBUTES,
                         ids=[c[0] for c in SPLIT_ATTRIBUTES])
def test_each_attribute_holds_one_number(tmp_path, label, edit, match):
    xml = model(mesh_object(1), [(1, None)])
    assert edit[0] in xml
    refused(tmp_path, xml.replace(*edit, 1), match)


@pytest.mark.parametrize("second", ["3D/3dmodel.model", "3d/3DMODEL.model",
                                    "/3D/3dmodel.model", "3D/3d%6Dodel.model"])
def test_duplicate_part_names_are_refused(tmp_path, second):
    # audit s24 D5: the last of two equivalent parts was loaded, silently
    big = model(mesh_object(1, v=[(5 * x, 5 * y, 5 * z) for x, y, z in TET_V]),
                [(1, None)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # zipfile: "Duplicate name"
        path = write_3mf(tmp_path / "d.3mf", model(mesh_object(1), [(1, None)]),
                         extra=[(second, big)])
    as_ = "" if second == "3D/3dmodel.model" else f" (as '{second}')"
    with pytest.raises(vs.MeshFileError, match=r"d\.3mf' is not a valid 3MF package: "
                       r"it holds the part '3D/3dmodel\.model' twice"
                       + re.escape(as_) + "; part names must differ"):
        vs.load_mesh(path)


def test_triangle_index_beyond_int64_is_quoted_as_written(tmp_path):
    # audit s24 D10: reported as 9223372036854775807
    for index in ("-99999999999999999999", "18446744073709551619"):
        xml = model(mesh_object(1), [(1, None)]).replace('v3="3"', f'v3="{index}"', 1)
        refused(tmp_path, xml, r"object 1: triangle 1 refers to vertices \[0, 1, "
                + index + r"\], but the object has 4 vertices")


# ---------------------------------------------------------------------------
# audit s25: limits counted while reading, strict numbers and ids
# ---------------------------------------------------------------------------


class _CountingKey(tuple):
    """A (part, object id) key that counts its == comparisons."""

    calls = 0

    def __eq__(self, other):
        _CountingKey.calls += 1
        return tuple.__eq__(self, other)

    __hash__ = tuple.__hash__


def test_component_cycle_check_does_not_scan_the_chain(tmp_path, monkeypatch):
    # audit s25 D03: `key in active` on a list compared each component with
    # every object above it: depth**2 / 2 comparisons (500,000 here)
    import vecslice.threemf as threemf

    depth = 1000
    res = mesh_object(1) + "".join(
        components_object(k + 1, [(k, None, "")]) for k in range(1, depth))
    path = write_3mf(tmp_path / "chain.3mf", model(res, [(depth, None)]))
    ref = threemf._ref
    monkeypatch.setattr(threemf, "_ref",
                        lambda *a, **kw: _CountingKey(ref(*a, **kw)))
    _CountingKey.calls = 0
    v, f = threemf.read_3mf(path, 0)
    assert f.shape == (4, 3)
    assert _CountingKey.calls < 10 * depth


def _item_attrs(xml, attrs):
    return xml.replace('<item objectid="1"/>', f"<item {attrs}/>", 1)


BAD_IDS = [
    # audit s25 D12: these raised a raw ValueError or KeyError
    ("superscript id", model(mesh_object("\u00b2"), [(1, None)]),
     r"an object in '/3D/3dmodel\.model' has id '\u00b2'; expected a number"),
    ("arabic-indic id", model(mesh_object("\u0661"), [(1, None)]),
     r"has id '\u0661'; expected a number"),
    ("5000-digit id", model(mesh_object("1" * 5000), [(1, None)]),
     r"has id '1111111111\S*\.\.\. \(5,000 characters\); expected a number from 1 "
     r"to 2147483647"),
    ("id beyond 3MF's range", model(mesh_object(2**31), [(1, None)]),
     r"has id '2147483648'; expected a number from 1 to 2147483647"),
    # ST_ResourceID is a positive integer: 0 was read as an object
    ("zero id", model(mesh_object(0), [(0, None)]),
     r"an object in '/3D/3dmodel\.model' has id '0'; expected a number from 1 to "
     r"2147483647$"),
    ("zeros id", model(mesh_object(1) + mesh_object("000"), [(1, None)]),
     r"has id '000'; expected a number from 1 to 2147483647$"),
    ("negative id", model(mesh_object(-1), [(1, None)]),
     r"has id '-1'; expected a number from 1 to 2147483647$"),
    ("zero objectid", model(mesh_object(1), [(1, None), (0, None)]),
     r"build item 2 has objectid '0'; expected an object number from 1 to "
     r"2147483647$"),
    ("zero component objectid", model(mesh_object(1) + components_object(
        2, [(1, None, ""), ("00", None, "")]), [(2, None)]),
     r"component 1 of object 2 has objectid '00'; expected an object number from 1 "
     r"to 2147483647$"),
    ("missing id", model(mesh_object(1).replace(' id="1"', ""), [(1, None)]),
     r"an object in '/3D/3dmodel\.model' has no id"),
    ("superscript objectid", model(mesh_object(1), [("\u00b2", None)]),
     r"build item 1 has objectid '\u00b2'; expected an object number"),
    ("missing objectid", _item_attrs(model(mesh_object(1), [(1, None)]), ""),
     r"build item 1 has no objectid"),
    ("component objectid", model(mesh_object(1) + components_object(
        2, [("1" * 5000, None, "")]), [(2, None)]),
     r"component 0 of object 2 has objectid '1111\S*\.\.\. \(5,000 characters\); "
     r"expected an object number"),
    ("duplicate id, leading zero", model(mesh_object(1) + mesh_object("01"),
                                         [(1, None)]),
     r"object 01 is defined twice"),
]


@pytest.mark.parametrize(("label", "xml", "match"), BAD_IDS,
                         ids=[c[0] for c in BAD_IDS])
def test_bad_object_ids_are_refused_clearly(tmp_path, label, xml, match):
    err = refused(tmp_path, xml, match)
    assert "ValueError" not in str(err) and "KeyError" not in str(err)


def test_reference_to_an_escaped_part_name(tmp_path):
    # audit s25 D12: a part whose name holds '%25' was unescaped twice (KeyError)
    other = model(mesh_object(7), [])
    res = components_object(1, [(7, None, ' p:path="/3D/a%2541.model"')])
    m = load(tmp_path, model(res, [(1, None)]),
             extra=[("3D/a%2541.model", other)])
    assert m.n_faces == 4
    res = components_object(1, [(8, None, ' p:path="/3D/a%2541.model"')])
    refused(tmp_path, model(res, [(1, None)]), r"component 0 of object 1 refers to "
            r"object 8 of part '/3D/a%2541\.model', which is not defined",
            extra=[("3D/a%2541.model", other)])


OTHER = ("3D/other.model", model(mesh_object(7), []))
WRITTEN_REFS = [
    # the part as p:path writes it, not as a lookup key ('3d/no such.model')
    ("missing part", model(components_object(
        1, [(7, None, ' p:path="/3D/No%20Such.model"')]), [(1, None)]), [],
     r"component 0 of object 1 refers to part '/3D/No%20Such\.model' \(p:path\), "
     r"which the package does not contain$"),
    ("missing part of an item", model(mesh_object(1), [(1, None)]).replace(
        '<item objectid="1"/>', '<item objectid="1" p:path="/3D/Gone.model"/>'), [],
     r"build item 1 refers to part '/3D/Gone\.model' \(p:path\), which the "
     r"package does not contain$"),
    # the object id as written, not as the number it is
    ("leading zeros", model(mesh_object(1), [("002", None)]), [],
     r"build item 1 refers to object 002, which is not defined$"),
    ("another spelling of a part", model(components_object(
        1, [("08", None, ' p:path="/3d/OTHER.model"')]), [(1, None)]), [OTHER],
     r"component 0 of object 1 refers to object 08 of part '/3d/OTHER\.model', "
     r"which is not defined$"),
    ("the second component", model(mesh_object(1) + components_object(
        2, [(1, None, ""), (8, None, ' p:path="/3D/other.model"')]),
        [(2, None)]), [OTHER],
     r"component 1 of object 2 refers to object 8 of part '/3D/other\.model', "
     r"which is not defined$"),
    # a component in another part: that part is named where the reference is
    ("from another part", model(components_object(
        1, [(5, None, ' p:path="/3D/more.model"')]), [(1, None)]),
     [("3D/more.model", model(components_object(5, [(9, None, "")]), []))],
     r"component 0 of object 5 of '3D/more\.model' refers to object 9, which is "
     r"not defined$"),
    ("from another part to the root", model(components_object(
        1, [(5, None, ' p:path="/3D/more.model"')]), [(1, None)]),
     [("3D/more.model", model(components_object(5, [(
         9, None, ' p:path="/3D/3dmodel.model"')]), []))],
     r"component 0 of object 5 of '3D/more\.model' refers to object 9 of part "
     r"'/3D/3dmodel\.model', which is not defined$"),
]


@pytest.mark.parametrize(("label", "xml", "extra", "match"), WRITTEN_REFS,
                         ids=[c[0] for c in WRITTEN_REFS])
def test_missing_references_are_named_as_written(tmp_path, label, xml, extra, match):
    refused(tmp_path, xml, r"m\.3mf': " + match, extra=extra)


def test_references_spelt_unusually_cost_little(tmp_path):
    # their spelling is kept for messages (one tuple per spelling); the usual
    # one ('1', or p:path '/' and the part's name) is not kept at all
    n = 20_000
    empty = '<object id="1" type="model"><mesh><vertices/><triangles/></mesh></object>'
    path = write_3mf(tmp_path / "zeros.3mf", model(empty, [("01", None)] * n),
                     method=zipfile.ZIP_STORED)
    _refuse(path, match="holds no triangles")  # imports outside the measure
    assert _peak_mib(lambda: _refuse(path)) * 2**20 / n < 300  # bytes an item


@pytest.mark.parametrize("bad", [
    # audit s25 D11: float() took '1_0' as 10 (and these as numbers too)
    "1_0", "\u0661", "\uff11", "infinity", "nan", "+inf", "1e", ".", "+", "1d5", "1,5",
    "0x10", "--1", "1.5.2", "e3", "1e+", "1\u00a00"])
def test_transform_numbers_follow_the_3mf_grammar(tmp_path, bad):
    text = move(dx=bad)
    err = refused(tmp_path, model(mesh_object(1), [(1, text)]),
                  r"'.*m\.3mf': build item 1 has transform ")
    assert f"expected 12 finite numbers, but number 10 is {bad!r}, which is not a " \
           "3MF number" in str(err)


def test_transform_numbers_beyond_float64_are_refused(tmp_path):
    refused(tmp_path, model(mesh_object(1), [(1, move(dz="-1e999"))]),
            r"build item 1 has transform '.*'; expected 12 finite numbers, but "
            r"number 12 is '-1e999', beyond the range of float64")


def test_component_transform_is_read_strictly(tmp_path):
    res = mesh_object(1) + components_object(2, [(1, move(dy="2_0"), "")])
    refused(tmp_path, model(res, [(2, None)]),
            r"component 0 of object 2 has transform .*number 11 is '2_0'")


@pytest.mark.parametrize(("number", "dx_um"), [
    ("+1", 1000), ("-.5", -500), ("1E+1", 10_000), ("2.", 2000), ("007", 7000),
    ("5e-1", 500)])
def test_transform_numbers_the_grammar_allows(tmp_path, number, dx_um):
    m = load(tmp_path, model(mesh_object(1), [(1, move(dx=number))]))
    assert m.bounds[0].tolist() == [dx_um, 0, 0]


def test_transform_whitespace_is_xml_whitespace(tmp_path):
    # tabs and line ends separate numbers (as XML collapses them), no other space
    text = "1\t0 0&#10;0 1 0&#13;0 0 1  3 0 0 "
    m = load(tmp_path, model(mesh_object(1), [(1, text)]))
    assert m.bounds[0].tolist() == [3000, 0, 0]


@pytest.mark.parametrize(("text", "got"), [("", 0), (" \t", 0), ("1 " * 13, 13)])
def test_transform_number_count(tmp_path, text, got):
    refused(tmp_path, model(mesh_object(1), [(1, None)]).replace(
        '<item objectid="1"/>', f'<item objectid="1" transform="{text}"/>'),
        rf"build item 1 has transform .*; expected 12 finite numbers, got {got}$")


@pytest.mark.parametrize("bad", ["nan", "-inf", "1e999", "NaN"])
def test_non_finite_vertex_is_named_as_read(tmp_path, bad):
    # audit s25 D13: reported after the transform and unit, at its index among
    # all placements: "got [nan, nan, nan] at vertex 6"
    v = [*TET_V[:3], (0, bad, 10)]
    res = mesh_object(1) + mesh_object(2, v=v)
    with pytest.raises(vs.InputValueError) as info:
        load(tmp_path, model(res, [(1, None), (2, move(dx=5))], unit="inch"))
    assert isinstance(info.value, ValueError)
    assert str(info.value) == (
        f"`vertices` must be finite; got '0 {bad} 10' (x, y, z as written) at "
        f"vertex 3 of object 2 in '{tmp_path / 'm.3mf'}'")


def test_non_finite_vertex_in_another_part(tmp_path):
    other = model(mesh_object(7, v=[*TET_V[:3], ("nan", 0, 10)]), [])
    res = components_object(1, [(7, None, ' p:path="/3D/other.model"')])
    with pytest.raises(vs.InputValueError, match=r"got 'nan 0 10' \(x, y, z as "
                       r"written\) at vertex 3 of object 7 of '3D/other\.model' in"):
        load(tmp_path, model(res, [(1, None)]), extra=[("3D/other.model", other)])


def _items(n, transform=True):
    """n build items of object 1, each moved differently (or not moved)."""
    return [(1, move(dx=i % 997, dy=i // 997) if transform else None)
            for i in range(n)]


def test_build_items_are_counted_while_reading(tmp_path, monkeypatch):
    # audit s25 D01: every <item> was kept, with its own 4x4 matrix, and only
    # counted once the build was read (a 358 kB file took 1.35 GB)
    monkeypatch.setattr("vecslice.threemf.MAX_INSTANCES", 1000)
    path = write_3mf(tmp_path / "items.3mf", model(mesh_object(1), _items(200_000)),
                     method=zipfile.ZIP_STORED)
    with pytest.raises(vs.MeshFileError, match=r"items\.3mf': the 3MF holds more "
                       r"than 1,000 build items and components \(build item 1,001 "
                       r"is one more\); vecslice reads at most 1,000 "
                       r"\(vecslice\.threemf\.MAX_INSTANCES\)"):
        vs.load_mesh(path)
    assert _peak_mib(lambda: _refuse(path)) < 8  # 200,000 matrices: 50 MiB


def test_components_are_counted_while_reading(tmp_path, monkeypatch):
    monkeypatch.setattr("vecslice.threemf.MAX_INSTANCES", 1000)
    parts = [(1, t, "") for _, t in _items(100_000)]
    res = mesh_object(1) + components_object(2, parts[:500]) + components_object(
        3, parts[500:])
    path = write_3mf(tmp_path / "comps.3mf", model(res, [(2, None)]),
                     method=zipfile.ZIP_STORED)
    with pytest.raises(vs.MeshFileError, match=r"comps\.3mf': the 3MF holds more "
                       r"than 1,000 build items and components \(component 500 of "
                       r"object 3 is one more\)"):
        vs.load_mesh(path)
    assert _peak_mib(lambda: _refuse(path)) < 8


def test_placements_without_transform_share_one_matrix(tmp_path):
    # audit s25 D01: np.eye(4) per item and component (240 bytes each) and a
    # key tuple per reference: 440 bytes an item. The object holds no
    # triangles, so what is measured is reading and walking the build.
    n = 20_000
    empty = '<object id="1" type="model"><mesh><vertices/><triangles/></mesh></object>'
    res = empty + components_object(2, [(1, None, "")])
    path = write_3mf(tmp_path / "same.3mf", model(res, [(2, None)] * n),
                     method=zipfile.ZIP_STORED)
    _refuse(path, match="holds no triangles")  # imports outside the measure
    assert _peak_mib(lambda: _refuse(path)) * 2**20 / n < 250  # bytes an item


def test_objects_are_counted_while_reading(tmp_path, monkeypatch):
    # audit s25 D02: no cap on <object> elements, about 1 kB each (2.6 MB of
    # file took 1 GB)
    monkeypatch.setattr("vecslice.threemf.MAX_OBJECTS", 1000)
    res = mesh_object(1) + "".join(components_object(i, [(1, None, "")])
                                   for i in range(2, 100_000))
    path = write_3mf(tmp_path / "objs.3mf", model(res, [(1, None)]),
                     method=zipfile.ZIP_STORED)
    with pytest.raises(vs.MeshFileError, match=r"objs\.3mf': the 3MF holds more "
                       r"than 1,000 objects \(object 1001 is one more\); vecslice "
                       r"reads at most 1,000 \(vecslice\.threemf\.MAX_OBJECTS\)"):
        vs.load_mesh(path)
    assert _peak_mib(lambda: _refuse(path)) < 8  # 100,000 objects: 75 MiB
    other = model(mesh_object(7), [])  # the objects of every part count
    res = mesh_object(1) + "".join(components_object(i, []) for i in range(2, 1000))
    res += components_object(1000, [(7, None, ' p:path="/3D/other.model"')])
    refused(tmp_path, model(res, [(1000, None)]), r"holds more than 1,000 objects "
            r"\(object 7 of '3D/other\.model' is one more\)",
            extra=[("3D/other.model", other)])


def test_objects_without_triangles_are_small(tmp_path):
    # audit s25 D02: each kept two empty arrays, a list and a __dict__ (770 bytes)
    n = 20_000
    res = mesh_object(1) + "".join(components_object(i, [])
                                   for i in range(2, n + 2))
    path = write_3mf(tmp_path / "objs.3mf", model(res, [(1, None)]),
                     method=zipfile.ZIP_STORED)
    vs.load_mesh(path)  # imports outside the measure
    assert _peak_mib(lambda: vs.load_mesh(path)) * 2**20 / n < 300  # bytes


def _strip(n):
    """An object of n triangles in a strip (n + 2 vertices)."""
    return mesh_object(1, v=[(i, i % 2, 0) for i in range(n + 2)],
                       f=[(i, i + 1, i + 2) for i in range(n)])


def test_expansion_beyond_the_held_triangles_is_capped(tmp_path, monkeypatch):
    # audit s25 D05: placements multiply a few triangles within MAX_BUILD_TRIANGLES
    monkeypatch.setattr("vecslice.threemf.MAX_EXPANDED_TRIANGLES", 1000)

    def placed(n):
        return mesh_object(1) + components_object(
            2, [(1, move(dx=20 * i), "") for i in range(n)])

    refused(tmp_path, model(placed(251), [(2, None)]),
            r"the 3MF build expands to 1,004 triangles from the 4 its objects "
            r"hold; vecslice expands a 3MF to at most 1,000 triangles, or as many "
            r"as its objects hold \(vecslice\.threemf\.MAX_EXPANDED_TRIANGLES\)$")
    assert load(tmp_path, model(placed(250), [(2, None)]),
                name="ok.3mf").n_faces == 1000  # at the limit
    # a file that holds the triangles it places is limited as any file
    held = _strip(1200)
    assert load(tmp_path, model(held, [(1, None)])).n_faces == 1200
    refused(tmp_path, model(held, [(1, None), (1, move(dz=5))]),
            r"expands to 2,400 triangles from the 1,200 its objects hold")


def test_expanded_vertices_are_capped_at_three_per_triangle(tmp_path, monkeypatch):
    monkeypatch.setattr("vecslice.threemf.MAX_EXPANDED_TRIANGLES", 1000)
    one = mesh_object(1, v=_many_vertices(300), f=[(0, 1, 2)])  # 300 a triangle
    refused(tmp_path, model(one, [(1, move(dx=i)) for i in range(11)]),
            r"the 3MF build expands to 3,300 vertices from the 300 its objects "
            r"hold; vecslice expands a 3MF to at most 3,000 vertices \(3 x "
            r"vecslice\.threemf\.MAX_EXPANDED_TRIANGLES\), or as many as its "
            r"objects hold$")
    assert load(tmp_path, model(one, [(1, move(dx=i)) for i in range(10)]),
                name="ok.3mf").n_faces == 10


def test_default_expansion_cap_refuses_the_audit_file(tmp_path):
    # audit s25 D05: 1.8 kB placing 147 triangles 100,000 times (14.7M, below
    # MAX_BUILD_TRIANGLES) was expanded, then repaired at about 1-3 kB a
    # triangle (24 GB). Refused from the counts: nothing is placed.
    res = _strip(147) + "".join(
        components_object(k + 1, [(k, move(dz=k * i), "") for i in range(10)])
        for k in range(1, 4)) + components_object(
        5, [(4, move(dy=i), "") for i in range(100)])
    path = write_3mf(tmp_path / "amp.3mf", model(res, [(5, None)]))
    assert path.stat().st_size < 4000
    with pytest.raises(vs.MeshFileError, match=r"amp\.3mf': the 3MF build expands "
                       r"to 14,700,000 triangles from the 147 its objects hold; "
                       r"vecslice expands a 3MF to at most 2,000,000 triangles"):
        vs.load_mesh(path)
    assert _peak_mib(lambda: _refuse(path)) < 8


def test_expansion_counts_stay_small_numbers(tmp_path):
    # audit s25 D05: a chain of 3,000 objects of 10 components each expands to
    # 10**3000 placements; the counts per object were exact Python integers
    # (about 1.2 kB each by the end of the chain, 5 MB in all)
    depth = 3000
    res = mesh_object(1) + "".join(
        components_object(k + 1, [(k, None, "")] * 10) for k in range(1, depth))
    path = write_3mf(tmp_path / "deep.3mf", model(res, [(depth, None)]))
    with pytest.raises(vs.MeshFileError, match=r"deep\.3mf': the 3MF build expands "
                       r"to more than 4,611,686,018,427,387,904 triangles; vecslice "
                       r"reads at most 30,000,000"):
        vs.load_mesh(path)
    assert _peak_mib(lambda: _refuse(path)) < 4


def raw_zip(path, model_data, *, method=zipfile.ZIP_DEFLATED, size=None,
            crc=None, declared=None):
    """A 3MF package written byte by byte, its model part's entry as given.

    ``model_data`` is the model part's data as stored (deflated or not);
    ``size``, ``crc`` and ``declared`` (compressed size) default to the truth
    for stored data and must be given for deflated data.
    """
    members = [("[Content_Types].xml", 0, b"<Types/>"), ("_rels/.rels", 0,
                                                        RELS.encode())]
    out, central = bytearray(), bytearray()
    for name, how, data in [*members, ("3D/3dmodel.model", method, model_data)]:
        model_part = name == "3D/3dmodel.model"
        usize = size if model_part and size is not None else len(data)
        csize = declared if model_part and declared is not None else len(data)
        check = crc if model_part and crc is not None else zlib.crc32(data)
        n = name.encode()
        offset = len(out)
        out += struct.pack("<4s5H3L2H", b"PK\x03\x04", 20, 0, how, 0, 0, check,
                           csize, usize, len(n), 0) + n + data
        central += struct.pack("<4s6H3L5H2L", b"PK\x01\x02", 20, 20, 0, how, 0, 0,
                               check, csize, usize, len(n), 0, 0, 0, 0, 0,
                               offset) + n
    out += central + struct.pack("<4s4H2LH", b"PK\x05\x06", 0, 0, 3, 3,
                                 len(central), len(out), 0)
    path.write_bytes(bytes(out))
    return path


def deflated(data):
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    return c.compress(data) + c.flush()


def test_raw_zip_helper_writes_a_loadable_package(tmp_path):
    xml = model(mesh_object(1), [(1, None)]).encode()
    for method, data in ((zipfile.ZIP_STORED, xml), (zipfile.ZIP_DEFLATED,
                                                     deflated(xml))):
        path = raw_zip(tmp_path / "ok.3mf", data, method=method, size=len(xml),
                       crc=zlib.crc32(xml))
        assert vs.load_mesh(path).n_faces == 4


def test_declared_compressed_size_is_not_trusted(tmp_path):
    # audit s25 D07: the ratio was checked on the sizes the entry declares; one
    # declaring its compressed size as large as the data inflated freely
    xml = (model(mesh_object(1), [(1, None)]) + " " * (16 << 20)).encode()
    data = deflated(xml)
    assert len(xml) > 1000 * len(data)
    path = raw_zip(tmp_path / "lie.3mf", data, size=len(xml), crc=zlib.crc32(xml),
                   declared=len(xml))
    with pytest.raises(vs.MeshFileError, match=r"lie\.3mf': 3MF part "
                       r"'/3D/3dmodel\.model' inflates more than 200 times: "
                       r"[\d,]+ bytes from the first [\d,]+ compressed bytes \(its "
                       r"zip entry declares 16,777,\d{3} to 16,777,\d{3} bytes\): a "
                       r"zip bomb\? \(vecslice\.threemf\.MAX_COMPRESSION_RATIO\)"):
        vs.load_mesh(path)
    assert _peak_mib(lambda: _refuse(path)) < 8


DAMAGED_DATA = [
    # audit s25 D07: cut deflate data ended in "EOFError: " (no message)
    ("cut deflate data", lambda x: dict(model_data=deflated(x)[:-40], size=len(x),
                                        crc=zlib.crc32(x)),
     r"part '/3D/3dmodel\.model' is truncated: its data ends after [\d,]+ of the "
     r"[\d,]+ bytes its zip entry declares"),
    ("stored data short of its size", lambda x: dict(
        model_data=x[:100], method=zipfile.ZIP_STORED, size=len(x),
        crc=zlib.crc32(x)),
     r"part '/3D/3dmodel\.model' is truncated: its data ends after 100 of the "
     r"[\d,]+ bytes"),
    ("compressed size beyond the file", lambda x: dict(
        model_data=deflated(x)[:60], declared=10**6, size=len(x),
        crc=zlib.crc32(x)),
     r"part '/3D/3dmodel\.model' is (truncated|corrupt after [\d,]+ bytes)"),
    ("corrupt deflate data", lambda x: dict(
        model_data=b"\xff" * 8 + deflated(x)[8:], size=len(x), crc=zlib.crc32(x)),
     r"part '/3D/3dmodel\.model' is corrupt after 0 bytes: Error -3 while "
     r"decompressing data"),
    ("wrong CRC", lambda x: dict(model_data=deflated(x), size=len(x),
                                 crc=zlib.crc32(x) ^ 1),
     r"part '/3D/3dmodel\.model' is corrupt: its CRC-32 is [0-9a-f]{8}, its zip "
     r"entry says [0-9a-f]{8}"),
    ("longer than declared", lambda x: dict(model_data=deflated(x), size=len(x) - 1,
                                            crc=zlib.crc32(x)),
     r"part '/3D/3dmodel\.model' is longer than its zip entry says \([\d,]+ bytes\)"),
    ("bzip2", lambda x: dict(model_data=bz2.compress(x), method=zipfile.ZIP_BZIP2,
                             size=len(x), crc=zlib.crc32(x)),
     r"part '/3D/3dmodel\.model' is compressed with zip method 12; Open Packaging "
     r"Conventions packages \(3MF\) are stored or deflated"),
]


@pytest.mark.parametrize(("label", "edit", "match"), DAMAGED_DATA,
                         ids=[c[0] for c in DAMAGED_DATA])
def test_damaged_zip_data_is_named(tmp_path, label, edit, match):
    xml = model(mesh_object(1), [(1, None)]).encode()
    path = raw_zip(tmp_path / "d.3mf", **edit(xml))
    with pytest.raises(vs.MeshFileError, match=r"^cannot read '.*d\.3mf' as 3MF: "
                       + match) as info:
        vs.load_mesh(path)
    assert info.value.__cause__ is None

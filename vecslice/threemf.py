"""Reading 3MF files: the model parts of the package, every build placement.

A 3MF file is a zip package (OPC) whose ``_rels/.rels`` names the root 3D model
part, an XML document with ``<resources>`` (objects holding a ``<mesh>`` or
``<components>`` that place other objects) and a ``<build>`` of items placing
objects on the plate (3MF core specification 1.3; ``p:path`` of the production
extension reaches objects in other model parts).

Only model parts are inflated (never thumbnails or textures), each after its
declared size and compression ratio passed :data:`MAX_MODEL_BYTES` and
:data:`MAX_COMPRESSION_RATIO`. XML is parsed without network access, without
entity resolution and with libxml2's size guards; a document type declaration
is refused. Every build item and every component is walked, so an object reused
in nested components appears once per placement, with the transforms composed;
component cycles and expansions beyond :data:`~vecslice.meshfile.MAX_TRIANGLES`
triangles or :data:`MAX_INSTANCES` placements are refused. The model's ``unit``
is applied: vertices come out in millimetres.
"""

from __future__ import annotations

import io
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import unquote

import numpy as np
from numpy.typing import NDArray

from vecslice.errors import MeshFileError
from vecslice.meshfile import MAX_TRIANGLES, _numbers

if TYPE_CHECKING:
    from lxml import etree

__all__ = ["MAX_COMPRESSION_RATIO", "MAX_INSTANCES", "MAX_MODEL_BYTES", "UNITS",
           "read_3mf"]

MAX_MODEL_BYTES = 1 << 30
"""Most bytes (1 GiB) the model parts of one 3MF may inflate to, all together."""

MAX_COMPRESSION_RATIO = 200
"""Largest inflated/compressed size ratio of a model part above 1 MiB.

Model XML compresses about 5 to 20 times; a zip bomb a thousand times or more.
"""

MAX_INSTANCES = 1_000_000
"""Most object placements the build may expand to (components in components)."""

UNITS = {
    "micron": 0.001,
    "millimeter": 1.0,
    "centimeter": 10.0,
    "inch": 25.4,
    "foot": 304.8,
    "meter": 1000.0,
}
"""The ``unit`` values of the 3MF core specification, in millimetres."""

_MODEL_REL = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"
_PRODUCTION = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
# extensions whose required use still leaves the geometry to <mesh>/<components>
_READABLE = {
    "http://schemas.microsoft.com/3dmanufacturing/core/2015/02",
    _PRODUCTION,
    "http://schemas.microsoft.com/3dmanufacturing/material/2015/02",
}
_RATIO_FROM = 1 << 20

Key = tuple[str, int]  # (model part, object id)


@dataclass
class _Object:
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    # (model part, object id, 4x4 row-vector transform) of each component
    components: list[tuple[Key, NDArray[np.float64]]] = field(default_factory=list)


@dataclass
class _Package:
    path: Path
    zf: zipfile.ZipFile
    members: dict[str, zipfile.ZipInfo]
    budget: int
    unit: str = "millimeter"
    root: str = ""
    last_root: Any = None
    objects: dict[Key, _Object] = field(default_factory=dict)
    parsed: set[str] = field(default_factory=set)
    items: list[tuple[Key, NDArray[np.float64]]] = field(default_factory=list)

    def fail(self, what: str) -> MeshFileError:
        return MeshFileError(f"'{self.path}': {what}")

    def read(self, name: str, *, limit: int) -> bytes:
        """Inflate member ``name`` after checking its declared sizes."""
        info = self.members[_norm(name)]
        if info.flag_bits & 0x1:
            raise self.fail(f"3MF part '{name}' is encrypted")
        if info.file_size > min(limit, self.budget):
            raise self.fail(
                f"3MF part '{name}' inflates to {info.file_size:,} bytes, more than "
                f"the {min(limit, self.budget):,} bytes left of vecslice's limit on "
                f"model XML ({MAX_MODEL_BYTES:,} bytes, "
                "vecslice.threemf.MAX_MODEL_BYTES)")
        ratio = info.file_size / max(info.compress_size, 1)
        if info.file_size > _RATIO_FROM and ratio > MAX_COMPRESSION_RATIO:
            raise self.fail(
                f"3MF part '{name}' would inflate {ratio:,.0f} times "
                f"({info.compress_size:,} to {info.file_size:,} bytes): a zip bomb? "
                f"(at most {MAX_COMPRESSION_RATIO} times, "
                "vecslice.threemf.MAX_COMPRESSION_RATIO)")
        with self.zf.open(info) as fh:
            data = fh.read(info.file_size + 1)  # zipfile stops at the declared size
        if len(data) > info.file_size:
            raise self.fail(f"3MF part '{name}' is longer than its zip entry says")
        self.budget -= len(data)
        return data

    def xml(self, name: str, *, limit: int, tags: tuple[str, ...]) -> Any:
        """Safe iterparse over member ``name``: each element of ``tags`` at its end.

        Afterwards ``self.last_root`` is the document's root element (or None).
        """
        from lxml import etree

        data = self.read(name, limit=limit)
        if _has_doctype(data):
            raise self.fail(f"3MF part '{name}' has a document type declaration "
                            "(DTD), which 3MF does not allow")
        events = etree.iterparse(
            io.BytesIO(data), events=("end",), tag=tags,
            resolve_entities=False, no_network=True, huge_tree=False,
            load_dtd=False, dtd_validation=False, attribute_defaults=False)
        try:
            for _, el in events:
                yield el
        except etree.XMLSyntaxError as exc:
            raise MeshFileError(f"cannot read '{self.path}' as 3MF: XMLSyntaxError "
                                f"in part '{name}': {exc}") from exc
        self.last_root = events.root
        if events.root is not None and events.root.getroottree().docinfo.doctype:
            raise self.fail(f"3MF part '{name}' has a document type declaration "
                            "(DTD), which 3MF does not allow")


def _has_doctype(data: bytes) -> bool:
    """Whether a document type declaration precedes the root element."""
    i = 3 if data.startswith(b"\xef\xbb\xbf") else 0
    while True:
        while i < len(data) and data[i : i + 1].isspace():
            i += 1
        for start, end in ((b"<?", b"?>"), (b"<!--", b"-->")):
            if data.startswith(start, i):
                j = data.find(end, i + len(start))
                i = len(data) if j < 0 else j + len(end)
                break
        else:
            return data.startswith(b"<!DOCTYPE", i)


def _norm(name: str) -> str:
    """A part name as a lookup key: no leading '/', %-escapes decoded, lower case."""
    return unquote(name).lstrip("/").lower()


def _model_part(pkg: _Package) -> str:
    """The root model part named in ``_rels/.rels`` (or the conventional one)."""
    if _norm("_rels/.rels") in pkg.members:
        for el in pkg.xml("_rels/.rels", limit=1 << 20, tags=("{*}Relationship",)):
            if el.get("Type", "").strip() == _MODEL_REL:
                target = el.get("Target", "")
                if _norm(target) not in pkg.members:
                    raise pkg.fail(f"3MF holds no 3D model: _rels/.rels names "
                                   f"'{target}', which the package does not contain")
                return target
    if _norm("3D/3dmodel.model") in pkg.members:
        return "3D/3dmodel.model"
    raise pkg.fail("3MF holds no 3D model: no part is named in _rels/.rels as "
                   "the 3D model, and there is no 3D/3dmodel.model")


def _transform(pkg: _Package, text: str | None, where: str) -> NDArray[np.float64]:
    """A 3MF transform (12 numbers, row-major 3x4 rows + translation) as 4x4.

    Points are row vectors: ``[x y z 1] @ T``.
    """
    t = np.eye(4)
    if text is None:
        return t
    try:
        m = np.array(text.split(), dtype=np.float64)
    except ValueError:
        m = np.empty(0)
    if m.shape != (12,) or not np.isfinite(m).all():
        raise pkg.fail(f"{where} has transform {text!r}; expected 12 finite numbers")
    t[:, :3] = m.reshape(4, 3)
    return t


def _mesh(pkg: _Package, mesh: etree._Element, where: str) -> _Object:
    # iterate each list's own children: mesh.iter() would walk both lists twice
    vs, ts = mesh.find("{*}vertices"), mesh.find("{*}triangles")
    verts = [] if vs is None else [
        f"{e.get('x')} {e.get('y')} {e.get('z')}" for e in vs.iter("{*}vertex")]
    tris = [] if ts is None else [
        f"{e.get('v1')} {e.get('v2')} {e.get('v3')}" for e in ts.iter("{*}triangle")]
    v = _numbers(" ".join(verts), np.float64, 3 * len(verts))
    f = _numbers(" ".join(tris), np.int64, 3 * len(tris))
    if v is None:
        k = next(i for i, s in enumerate(verts) if _numbers(s, np.float64, 3) is None)
        raise pkg.fail(f"{where}: vertex {k} has coordinates {verts[k]!r}; expected "
                       "x, y and z numbers")
    if f is None:
        k = next(i for i, s in enumerate(tris) if _numbers(s, np.int64, 3) is None)
        raise pkg.fail(f"{where}: triangle {k} has vertices {tris[k]!r}; expected "
                       "v1, v2 and v3 indices")
    v, f = v.reshape(-1, 3), f.reshape(-1, 3)
    bad = np.flatnonzero(((f < 0) | (f >= v.shape[0])).any(axis=1))
    if bad.size:
        k = int(bad[0])
        raise pkg.fail(f"{where}: triangle {k} refers to vertices {f[k].tolist()}, "
                       f"but the object has {v.shape[0]} vertices")
    return _Object(v, f)


def _ref(pkg: _Package, el: etree._Element, part: str, where: str) -> Key:
    """(part, object id) an item or component refers to."""
    oid = el.get("objectid", "")
    if not oid.isdigit():
        raise pkg.fail(f"{where} has objectid {oid!r}; expected an object number")
    target = el.get(f"{{{_PRODUCTION}}}path")
    return (_norm(target) if target else part, int(oid))


def _parse_part(pkg: _Package, name: str, *, root: bool) -> None:
    """Read the objects (and, for the root part, the build) of model part ``name``."""
    part = _norm(name)
    pkg.parsed.add(part)
    seen_root = False
    for el in pkg.xml(name, limit=MAX_MODEL_BYTES, tags=("{*}object", "{*}build")):
        if not seen_root:
            seen_root = True
            _model_attributes(pkg, el.getroottree().getroot(), name, root=root)
        if el.tag.endswith("}object"):
            _object(pkg, el, part, name)
        elif root:
            for item in el.iter("{*}item"):
                where = f"build item {len(pkg.items) + 1}"
                pkg.items.append((_ref(pkg, item, part, where),
                                  _transform(pkg, item.get("transform"), where)))
        # drop the objects read before this one (memory stays near one object);
        # the last one goes with the document, which frees faster than clear()
        while el.getprevious() is not None:
            del el.getparent()[0]
    if not seen_root and pkg.last_root is not None:
        _model_attributes(pkg, pkg.last_root, name, root=root)


def _model_attributes(pkg: _Package, el: etree._Element, name: str, *,
                      root: bool) -> None:
    if el.tag.rsplit("}", 1)[-1] != "model":
        raise pkg.fail(f"3MF part '{name}' is not a 3D model (its root element is "
                       f"<{el.tag.rsplit('}', 1)[-1]}>, not <model>)")
    unit = el.get("unit", "millimeter")
    if unit not in UNITS:
        raise pkg.fail(f"3MF unit must be one of {', '.join(UNITS)}; got {unit!r}")
    if root:
        pkg.unit = unit
    elif unit != pkg.unit:
        raise pkg.fail(f"3MF part '{name}' is in {unit}s, the root model in "
                       f"{pkg.unit}s; vecslice reads parts in one unit only")
    for prefix in el.get("requiredextensions", "").split():
        ns = el.nsmap.get(prefix)
        if ns not in _READABLE:
            raise pkg.fail(f"3MF requires the extension {ns or prefix!r}, which "
                           "vecslice does not read")


def _object(pkg: _Package, el: etree._Element, part: str, name: str) -> None:
    oid = el.get("id", "")
    if not oid.isdigit():
        raise pkg.fail(f"an object in '{name}' has id {oid!r}; expected a number")
    key = (part, int(oid))
    where = f"object {oid}" + ("" if part == pkg.root else f" of '{name}'")
    if key in pkg.objects:
        raise pkg.fail(f"{where} is defined twice")
    mesh = el.find("{*}mesh")
    obj = _mesh(pkg, mesh, where) if mesh is not None else _Object(
        np.empty((0, 3)), np.empty((0, 3), dtype=np.int64))
    for k, c in enumerate(el.iterfind("{*}components/{*}component")):
        cw = f"component {k} of {where}"
        obj.components.append((_ref(pkg, c, part, cw),
                               _transform(pkg, c.get("transform"), cw)))
    pkg.objects[key] = obj


def _expand(pkg: _Package) -> list[tuple[Key, list[NDArray[np.float64]]]]:
    """Every (object with a mesh, its world transforms), components walked.

    Checks references, cycles and the expanded counts before any placement is
    made.
    """
    def children(key: Key) -> list[tuple[Key, NDArray[np.float64]]]:
        return pkg.objects[key].components

    def check(key: Key, where: str) -> None:
        if key[0] not in pkg.parsed:
            if key[0] not in pkg.members:
                raise pkg.fail(f"{where} refers to part '{key[0]}', which the "
                               "package does not contain")
            _parse_part(pkg, key[0], root=False)
        if key not in pkg.objects:
            raise pkg.fail(f"{where} refers to object {key[1]}, which is not defined")

    tri: dict[Key, int] = {}
    inst: dict[Key, int] = {}
    active: list[Key] = []
    for n, (key, _) in enumerate(pkg.items):
        check(key, f"build item {n + 1}")
        if key in tri:
            continue
        stack = [(key, iter(children(key)))]
        active = [key]
        while stack:
            node, it = stack[-1]
            child = next(it, None)
            if child is None:
                stack.pop()
                active.pop()
                o = pkg.objects[node]
                tri[node] = o.faces.shape[0] + sum(tri[c] for c, _ in children(node))
                inst[node] = 1 + sum(inst[c] for c, _ in children(node))
                continue
            ck = child[0]
            check(ck, f"a component of object {node[1]}")
            if ck in active:
                loop = " -> ".join(str(k[1]) for k in active[active.index(ck):])
                raise pkg.fail(f"3MF components form a cycle: objects {loop} -> "
                               f"{ck[1]}")
            if ck not in tri:
                stack.append((ck, iter(children(ck))))
                active.append(ck)
    n_tri = sum(tri[k] for k, _ in pkg.items)
    n_inst = sum(inst[k] for k, _ in pkg.items)
    if n_tri > MAX_TRIANGLES:
        raise pkg.fail(f"the 3MF build expands to {n_tri:,} triangles; vecslice "
                       f"reads at most {MAX_TRIANGLES:,} "
                       "(vecslice.meshfile.MAX_TRIANGLES)")
    if n_inst > MAX_INSTANCES:
        raise pkg.fail(f"the 3MF build expands to {n_inst:,} object placements; "
                       f"vecslice reads at most {MAX_INSTANCES:,} "
                       "(vecslice.threemf.MAX_INSTANCES)")
    placed: dict[Key, list[NDArray[np.float64]]] = {}
    todo = [(k, t) for k, t in reversed(pkg.items)]
    while todo:  # depth first, in file order
        key, world = todo.pop()
        if pkg.objects[key].faces.shape[0]:
            placed.setdefault(key, []).append(world)
        todo.extend((c, t @ world) for c, t in reversed(children(key)))
    return list(placed.items())


def read_3mf(path: Path, size: int) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Vertices (mm) and faces of every placement in the build of 3MF ``path``.

    Raises :class:`~vecslice.errors.MeshFileError` for a damaged package, a
    missing model, an unknown unit, an unsupported required extension, a bad
    reference or transform, a component cycle, or a part or expansion beyond the
    limits of this module.
    """
    try:
        zf = zipfile.ZipFile(path)
    except zipfile.BadZipFile as exc:
        raise MeshFileError(f"cannot read '{path}' as 3MF: BadZipFile: {exc}"
                            ) from exc
    with zf:
        members = {_norm(i.filename): i for i in zf.infolist()}
        pkg = _Package(path, zf, members, budget=MAX_MODEL_BYTES)
        root = _model_part(pkg)
        pkg.root = _norm(root)
        _parse_part(pkg, root, root=True)
        if not pkg.items:
            raise pkg.fail("the 3MF build places no objects (no <build> <item>)")
        placed = _expand(pkg)
    verts: list[NDArray[np.float64]] = []
    faces: list[NDArray[np.int64]] = []
    base = 0
    for key, worlds in placed:
        o = pkg.objects[key]
        w = np.stack(worlds)  # (K, 4, 4)
        v = np.einsum("vi,kij->kvj", o.vertices, w[:, :3, :3]) + w[:, None, 3, :3]
        mirror = np.linalg.det(w[:, :3, :3]) < 0  # a mirror turns the winding over
        f = np.where(mirror[:, None, None], o.faces[None, :, ::-1], o.faces[None])
        f = f + (base + o.vertices.shape[0] * np.arange(len(worlds)))[:, None, None]
        verts.append(v.reshape(-1, 3))
        faces.append(f.reshape(-1, 3))
        base += v.shape[0] * v.shape[1]
    if not faces:
        return np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    v = np.concatenate(verts) * UNITS[pkg.unit]
    return v, np.concatenate(faces)

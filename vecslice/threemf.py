"""Reading 3MF files: the model parts of the package, every build placement.

A 3MF file is a zip package (OPC) whose ``_rels/.rels`` names the root 3D model
part, an XML document with ``<resources>`` (objects holding a ``<mesh>`` or
``<components>`` that place other objects) and a ``<build>`` of items placing
objects on the plate (3MF core specification 1.3; ``p:path`` of the production
extension reaches objects in other model parts).

Only model parts are inflated (never thumbnails or textures), each after its
declared size and compression ratio passed :data:`MAX_MODEL_BYTES` and
:data:`MAX_COMPRESSION_RATIO`, and read from the file by
:mod:`vecslice._zipread`, which holds it to both as it inflates (to the
compressed bytes actually consumed, whatever the zip entry declares) and names
truncated or corrupt data. XML is parsed as it inflates, without network
access, without entity resolution and with libxml2's size guards; a document type
declaration is refused. No XML tree is built: ``<vertex>`` and ``<triangle>``
elements are parsed to numbers in chunks, and their counts are checked against
:data:`MAX_BUILD_VERTICES` and :data:`MAX_BUILD_TRIANGLES` as they grow, so memory
stays near 24 bytes per vertex and per triangle; ``<object>`` elements are
counted against :data:`MAX_OBJECTS`, ``<item>`` and ``<component>`` elements
against :data:`MAX_INSTANCES` as they are read, and those without a transform
share one identity matrix. Every build item and every component is walked, so
an object reused in nested components appears once per placement, with the
transforms composed; component cycles and expansions beyond
:data:`MAX_BUILD_TRIANGLES` triangles, :data:`MAX_BUILD_VERTICES` vertices,
:data:`MAX_INSTANCES` placements, or more than :data:`MAX_EXPANDED_TRIANGLES`
triangles from fewer held, are refused from the counts of the component graph
before any placement is made. The model's ``unit`` is applied: vertices come out
in millimetres.
"""

from __future__ import annotations

import math
import re
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO
from urllib.parse import unquote

import numpy as np
from numpy.typing import NDArray

from vecslice._zipread import InflationError, MemberDataError, inflate
from vecslice.errors import InputValueError, MeshFileError
from vecslice.meshfile import _numbers

if TYPE_CHECKING:
    pass

__all__ = ["MAX_BUILD_TRIANGLES", "MAX_BUILD_VERTICES", "MAX_COMPRESSION_RATIO",
           "MAX_EXPANDED_TRIANGLES", "MAX_INSTANCES", "MAX_MODEL_BYTES",
           "MAX_OBJECTS", "UNITS", "read_3mf"]

MAX_MODEL_BYTES = 1 << 30
"""Most bytes (1 GiB) the model parts of one 3MF may inflate to, all together."""

MAX_COMPRESSION_RATIO = 200
"""Largest inflated/compressed size ratio of a model part above 1 MiB.

Model XML compresses about 5 to 20 times; a zip bomb a thousand times or more.
Checked on the sizes the zip entry declares before inflating, then on the bytes
actually inflated and consumed, as they are (an entry may lie about its sizes).
"""

MAX_INSTANCES = 1_000_000
"""Most object placements the build may expand to (components in components).

Also the most ``<item>`` and ``<component>`` elements a 3MF may hold, all parts
together: each places an object at least once, and each is kept (with its
object, about 130 bytes, 370 with a transform) until the build is expanded,
so they are counted as they are read and the one past the limit is refused.
"""

MAX_OBJECTS = 100_000
"""Most ``<object>`` elements a 3MF may hold, all model parts together.

Each costs about 200 bytes before its mesh (a million objects cost 770 MB before
this was slimmed and capped), whether it is placed or not, so they are counted
as they are read and the one past the limit is refused. A plate of parts uses
one object or a few per part.
"""

MAX_BUILD_TRIANGLES = 30_000_000
"""Most triangles a 3MF may hold, in its objects and after expanding components.

Components let a file of a few kB place an object millions of times, so this
caps the result (720 MB of faces), not the file: a 3MF holding or placing more
is refused before its arrays are made (placements that multiply the triangles
held are also capped by :data:`MAX_EXPANDED_TRIANGLES`). 3DBenchy has 225,154
triangles; a plate of a hundred detailed parts stays below it.
"""

MAX_EXPANDED_TRIANGLES = 2_000_000
"""Most triangles placements may multiply a 3MF's objects to, unless they hold more.

A file's own triangles cost file bytes, as in every other format (a binary STL
50 bytes each; :data:`MAX_BUILD_TRIANGLES` caps them). Placements cost almost
nothing: 2 kB of nested components placed 147 triangles 100,000 times, within
:data:`MAX_BUILD_TRIANGLES`, and loading and repairing a mesh takes about 0.2 to
1 kB a triangle (measured; up to 3.3 kB in an audit), so 14.7 million
triangles took up to 24 GB. A build is therefore refused when it expands to
more than ``max(MAX_EXPANDED_TRIANGLES, triangles its objects hold)``
triangles, or more than three vertices a triangle of that (the vertex limit of
:mod:`vecslice.meshfile` is also three times its triangle limit). The counts
come from the component graph, before any placement is made. Two million
triangles place a 3DBenchy eight times; a file that writes each copy out is
limited by :data:`MAX_BUILD_TRIANGLES` only.
"""

MAX_BUILD_VERTICES = 30_000_000
"""Most vertices a 3MF may hold, in its objects and after expanding components.

720 MB of float64 coordinates; see :data:`MAX_BUILD_TRIANGLES`.
"""

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


_IDENTITY = np.eye(4)
_IDENTITY.flags.writeable = False  # the transform of every placement without one
_NO_VERTICES = np.empty((0, 3))
_NO_VERTICES.flags.writeable = False  # the arrays of every object without triangles
_NO_FACES = np.empty((0, 3), dtype=np.int64)
_NO_FACES.flags.writeable = False
_MANY = 2**62  # expanded counts saturate here: beyond every limit, a small int
_SATURATED = np.iinfo(np.int64).max  # numpy's parse of any integer beyond int64
_FEED = 1 << 20  # bytes of XML handed to the parser at a time
_CHUNK = 1 << 16  # vertices or triangles parsed to numbers at a time


@dataclass(slots=True)
class _Object:
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    # (model part, object id, 4x4 row-vector transform) of each component
    components: Sequence[tuple[Key, NDArray[np.float64]]] = ()


@dataclass
class _Package:
    path: Path
    fh: BinaryIO  # the package file: members are inflated from it directly
    members: dict[str, zipfile.ZipInfo]
    budget: int
    unit: str = "millimeter"
    root: str = ""
    objects: dict[Key, _Object] = field(default_factory=dict)
    parsed: set[str] = field(default_factory=set)
    items: list[tuple[Key, NDArray[np.float64]]] = field(default_factory=list)
    refs: int = 0  # <item> and <component> elements read so far
    n_objects: int = 0  # <object> elements read so far
    # one key tuple per referenced object, shared by its references
    keys: dict[Key, Key] = field(default_factory=dict)
    # vertices and triangles of every object read so far (placed or not)
    counts: dict[str, int] = field(
        default_factory=lambda: {"vertex": 0, "triangle": 0})

    def fail(self, what: str) -> MeshFileError:
        return MeshFileError(f"'{self.path}': {what}")

    def placement(self, attrib: dict[str, str], part: str,
                  where: str) -> tuple[Key, NDArray[np.float64]]:
        """The (object, transform) of an ``<item>`` or ``<component>``, counted.

        Each one places an object at least once, so more than
        :data:`MAX_INSTANCES` of them are refused as they are read, before they
        cost memory (each is kept until the build is expanded).
        """
        self.refs += 1
        if self.refs > MAX_INSTANCES:
            raise self.fail(
                f"the 3MF holds more than {MAX_INSTANCES:,} build items and "
                f"components ({where} is one more); vecslice reads at most "
                f"{MAX_INSTANCES:,} (vecslice.threemf.MAX_INSTANCES)")
        return (_ref(self, attrib, part, where),
                _transform(self, attrib.get("transform"), where))

    def member(self, key: str, name: str, *, limit: int) -> zipfile.ZipInfo:
        """Member ``key`` (called ``name``) after checking its declared sizes."""
        info = self.members[key]
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
        return info

    def parse(self, name: str, *, limit: int, target: Any,
              key: str | None = None) -> None:
        """Feed member ``name`` to the lxml parser target ``target`` as it inflates.

        ``key`` is the member's key in :attr:`members` (by default ``name``
        normalised; a name that is a key already must not be unescaped twice).

        No tree is built: memory stays near what the target keeps. No network
        access, no entity resolution, libxml2's size guards; a document type
        declaration is refused.
        """
        from lxml import etree

        info = self.member(_norm(name) if key is None else key, name, limit=limit)
        parser = etree.XMLParser(
            target=target, resolve_entities=False, no_network=True, huge_tree=False,
            load_dtd=False, dtd_validation=False, attribute_defaults=False)
        first = True
        try:
            # at most the declared size, at most MAX_COMPRESSION_RATIO times the
            # compressed bytes actually consumed: whatever the entry declares
            for chunk in inflate(self.fh, info, max_ratio=MAX_COMPRESSION_RATIO,
                                 ratio_from=_RATIO_FROM, chunk=_FEED):
                if first and _has_doctype(chunk):
                    self.dtd(name)
                first = False
                self.budget -= len(chunk)
                parser.feed(chunk)
            parser.close()
        except etree.XMLSyntaxError as exc:
            raise MeshFileError(f"cannot read '{self.path}' as 3MF: XMLSyntaxError "
                                f"in part '{name}': {exc}") from exc
        except MemberDataError as exc:
            raise MeshFileError(f"cannot read '{self.path}' as 3MF: part '{name}' "
                                f"{exc}") from None
        except InflationError as exc:
            raise self.fail(
                f"3MF part '{name}' inflates more than {MAX_COMPRESSION_RATIO} "
                f"times: {exc.inflated:,} bytes from the first {exc.consumed:,} "
                f"compressed bytes (its zip entry declares {info.compress_size:,} "
                f"to {info.file_size:,} bytes): a zip bomb? "
                "(vecslice.threemf.MAX_COMPRESSION_RATIO)") from None

    def dtd(self, name: str) -> None:
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


class _Target:
    """Base of the lxml parser targets: refuses a document type declaration."""

    def __init__(self, pkg: _Package, name: str) -> None:
        self.pkg, self.name = pkg, name

    def doctype(self, *args: Any) -> None:
        self.pkg.dtd(self.name)

    def close(self) -> None:
        pass


class _Rels(_Target):
    """lxml parser target: the targets of 3D model relationships, in file order."""

    def __init__(self, pkg: _Package, name: str) -> None:
        super().__init__(pkg, name)
        self.targets: list[str] = []

    def start(self, tag: str, attrib: dict[str, str]) -> None:
        if (tag.rpartition("}")[2] == "Relationship"
                and attrib.get("Type", "").strip() == _MODEL_REL):
            self.targets.append(attrib.get("Target", ""))


def _model_part(pkg: _Package) -> str:
    """The root model part named in ``_rels/.rels`` (or the conventional one)."""
    if _norm("_rels/.rels") in pkg.members:
        rels = _Rels(pkg, "_rels/.rels")
        pkg.parse("_rels/.rels", limit=1 << 20, target=rels)
        for target in rels.targets[:1]:
            if _norm(target) not in pkg.members:
                raise pkg.fail(f"3MF holds no 3D model: _rels/.rels names "
                               f"'{target}', which the package does not contain")
            return target
    if _norm("3D/3dmodel.model") in pkg.members:
        return "3D/3dmodel.model"
    raise pkg.fail("3MF holds no 3D model: no part is named in _rels/.rels as "
                   "the 3D model, and there is no 3D/3dmodel.model")


# ST_Number of the 3MF schemas: optional sign, digits, optional fraction and
# exponent (the later schemas also take '1.'); no '1_0', 'nan', 'inf' or other
# scripts' digits, which float() takes
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_XML_SPACE = re.compile(r"[ \t\r\n]+")  # what XML collapses, no other space


def _transform(pkg: _Package, text: str | None, where: str) -> NDArray[np.float64]:
    """A 3MF transform (12 numbers, row-major 3x4 rows + translation) as 4x4.

    Points are row vectors: ``[x y z 1] @ T``. Numbers follow the 3MF grammar
    (:data:`_NUMBER`), separated by XML whitespace.
    """
    if text is None:
        return _IDENTITY
    t = np.eye(4)
    body = text.strip(" \t\r\n")
    tokens = _XML_SPACE.split(body) if body else []
    why = f", got {len(tokens)}" if len(tokens) != 12 else ""
    for i, tok in enumerate(tokens if not why else ()):
        if not _NUMBER.fullmatch(tok):
            why = (f", but number {i + 1} is {_shown(tok)}, which is not a 3MF "
                   "number (an optional sign, digits, an optional fraction and "
                   "exponent: 12, -0.5, 1.5e-3)")
        elif not math.isfinite(float(tok)):
            why = f", but number {i + 1} is {tok!r}, beyond the range of float64"
        if why:
            break
    if why:
        raise pkg.fail(f"{where} has transform {_shown(text, 400)}; expected 12 "
                       f"finite numbers{why}")
    t[:, :3] = np.array([float(x) for x in tokens]).reshape(4, 3)
    return t


_ID_MAX = 2**31 - 1
"""Largest 3MF resource id (ST_ResourceID: below 2**31)."""


def _shown(text: str, limit: int = 40) -> str:
    """``repr(text)`` for a message, cut after ``limit`` characters."""
    if len(text) <= limit:
        return repr(text)
    return f"{text[:limit]!r}... ({len(text):,} characters)"


def _object_id(text: str) -> int | None:
    """The object id ``text`` (ASCII digits, at most :data:`_ID_MAX`), or None.

    ``str.isdigit`` and ``int`` also take the digits of other scripts (Arabic-Indic
    one, U+0661), ``isdigit`` also superscripts, which ``int`` refuses, and
    ``int`` refuses more than 4300 digits: all raised a bare ValueError.
    """
    if not (text.isascii() and text.isdigit()) or len(text.lstrip("0")) > 10:
        return None
    n = int(text)
    return n if n <= _ID_MAX else None


def _ref(pkg: _Package, attrib: dict[str, str], part: str, where: str) -> Key:
    """(part, object id) an item or component refers to."""
    oid = attrib.get("objectid")
    if oid is None:
        raise pkg.fail(f"{where} has no objectid")
    n = _object_id(oid)
    if n is None:
        raise pkg.fail(f"{where} has objectid {_shown(oid)}; expected an object "
                       f"number from 0 to {_ID_MAX}")
    target = attrib.get(f"{{{_PRODUCTION}}}path")
    key = (_norm(target) if target else part, n)
    return pkg.keys.setdefault(key, key)  # one tuple per object, not per reference


# each list of a <mesh>: (its element, attributes, number type, wording, limit name)
_LISTS = {
    "vertices": ("vertex", ("x", "y", "z"), np.float64, "coordinates",
                 "x, y and z numbers", "MAX_BUILD_VERTICES"),
    "triangles": ("triangle", ("v1", "v2", "v3"), np.int64, "vertices",
                  "v1, v2 and v3 indices", "MAX_BUILD_TRIANGLES"),
}


class _Reading:
    """An ``<object>`` being read; its mesh lists stream into number chunks."""

    def __init__(self, key: Key, where: str) -> None:
        self.key, self.where = key, where
        self.mesh = 0  # 0 before its first <mesh>, 1 inside it, 2 after it
        self.mesh_depth = 0
        self.chunks: dict[str, list[NDArray[Any]]] = {"vertices": [],
                                                      "triangles": []}
        self.n = {"vertices": 0, "triangles": 0}
        self.seen: set[str] = set()  # the lists read (only a mesh's first of each)
        self.components: list[tuple[Key, NDArray[np.float64]]] = []


class _ModelReader(_Target):
    """lxml parser target: the objects (and, in the root part, the build) of a part.

    ``<vertex>`` and ``<triangle>`` attributes are kept as text for at most
    :data:`_CHUNK` elements, then parsed to numbers; the counts are checked
    against :data:`MAX_BUILD_VERTICES` and :data:`MAX_BUILD_TRIANGLES` as they
    grow, so a hostile part is refused before its numbers cost memory.
    """

    def __init__(self, pkg: _Package, name: str, *, key: str, root: bool) -> None:
        super().__init__(pkg, name)
        self.part, self.root = key, root
        self.stack: list[str] = []  # local names of the open elements
        self.objects: list[_Reading] = []  # open objects, innermost last
        self.list: str | None = None  # the mesh list being streamed
        self.list_depth = 0
        self.element = ""  # its element: vertex or triangle
        self.names: tuple[str, ...] = ()
        self.buf: list[str] = []
        self.build = 0  # open <build> elements

    def start(self, tag: str, attrib: dict[str, str],
              nsmap: dict[str, str] | None = None) -> None:
        local = tag[tag.rfind("}") + 1:]
        if local == self.element:  # the hot path: a vertex or a triangle
            a, b, c = self.names
            get = attrib.get
            self.buf.append(f"{get(a)} {get(b)} {get(c)}")
            if len(self.buf) >= _CHUNK:
                self.flush()
            return
        stack = self.stack
        parent = stack[-1] if stack else ""
        stack.append(local)
        if len(stack) == 1:
            _model_attributes(self.pkg, local, attrib, nsmap or {}, self.name,
                              root=self.root)
        elif local == "object":
            self.open_object(attrib)
        elif local == "build":
            self.build += 1
        elif local == "item" and self.build and self.root:
            pkg = self.pkg
            where = f"build item {len(pkg.items) + 1:,}"
            pkg.items.append(pkg.placement(attrib, self.part, where))
        if not self.objects or local in ("object", "build", "item"):
            return
        grand = stack[-3] if len(stack) >= 3 else ""
        obj = self.objects[-1]
        if local == "mesh" and parent == "object" and obj.mesh == 0:
            obj.mesh, obj.mesh_depth = 1, len(stack)
        elif (local in _LISTS and parent == "mesh" and grand == "object"
              and obj.mesh == 1 and len(stack) == obj.mesh_depth + 1
              and self.list is None and local not in obj.seen):
            obj.seen.add(local)
            self.list, self.list_depth = local, len(stack)
            self.element, self.names = _LISTS[local][:2]
        elif local == "component" and parent == "components" and grand == "object":
            pkg = self.pkg
            cw = f"component {len(obj.components):,} of {obj.where}"
            obj.components.append(pkg.placement(attrib, self.part, cw))

    def end(self, tag: str) -> None:
        local = tag[tag.rfind("}") + 1:]
        if local == self.element:
            return
        depth = len(self.stack)
        self.stack.pop()
        if self.list is not None and depth == self.list_depth:
            self.flush()
            self.list, self.element, self.names = None, "", ()
        elif local == "object" and self.objects:
            self.close_object(self.objects.pop())
        elif local == "mesh" and self.objects:
            obj = self.objects[-1]
            if obj.mesh == 1 and depth == obj.mesh_depth:
                obj.mesh = 2
        elif local == "build":
            self.build -= 1

    def open_object(self, attrib: dict[str, str]) -> None:
        pkg = self.pkg
        oid = attrib.get("id")
        if oid is None:
            raise pkg.fail(f"an object in '{self.name}' has no id")
        n = _object_id(oid)
        if n is None:
            raise pkg.fail(f"an object in '{self.name}' has id {_shown(oid)}; "
                           f"expected a number from 0 to {_ID_MAX}")
        where = f"object {oid}" + ("" if self.part == pkg.root else
                                   f" of '{self.name}'")
        pkg.n_objects += 1
        if pkg.n_objects > MAX_OBJECTS:
            raise pkg.fail(
                f"the 3MF holds more than {MAX_OBJECTS:,} objects ({where} is one "
                f"more); vecslice reads at most {MAX_OBJECTS:,} "
                "(vecslice.threemf.MAX_OBJECTS)")
        key = (self.part, n)
        if key in pkg.objects or any(o.key == key for o in self.objects):
            raise pkg.fail(f"{where} is defined twice")
        self.objects.append(_Reading(key, where))

    def flush(self) -> None:
        """Parse the buffered elements of the open list to numbers."""
        buf, kind = self.buf, self.list
        if not buf or kind is None:
            return
        obj, pkg = self.objects[-1], self.pkg
        element, _, dtype, what, expected, limit_name = _LISTS[kind]
        text = " ".join(buf)
        # one number per attribute: no space but the 3n - 1 joining ones, no
        # empty attribute, no other whitespace ('y="0 10" z=""' shifted values)
        a = None
        if (text.count(" ") == 3 * len(buf) - 1 and "  " not in text
                and text[0] != " " and text[-1] != " " and text.isprintable()):
            a = _numbers(text, dtype, 3 * len(buf))
        if a is None:
            k = next(i for i, s in enumerate(buf) if not _one_each(s)
                     or _numbers(s, dtype, 3) is None)
            raise pkg.fail(f"{obj.where}: {element} {obj.n[kind] + k} has {what} "
                           f"{buf[k]!r}; expected {expected}")
        if kind == "triangles" and (a == _SATURATED).any():  # beyond int64: quote
            k = int(np.flatnonzero(a == _SATURATED)[0]) // 3  # the file's text
            raise pkg.fail(f"{obj.where}: triangle {obj.n[kind] + k} refers to "
                           f"vertices [{', '.join(buf[k].split(' '))}], but the "
                           f"object has {obj.n['vertices']} vertices")
        if kind == "vertices" and not np.isfinite(a).all():  # named as read
            k = int(np.flatnonzero(~np.isfinite(a))[0]) // 3
            raise InputValueError(
                f"`vertices` must be finite; got {buf[k]!r} (x, y, z as written) at "
                f"vertex {obj.n[kind] + k} of {obj.where} in '{pkg.path}'")
        obj.chunks[kind].append(a)
        obj.n[kind] += len(buf)
        pkg.counts[element] += len(buf)
        buf.clear()
        limit = globals()[limit_name]
        if pkg.counts[element] > limit:
            raise pkg.fail(
                f"the 3MF objects hold more than {limit:,} {kind} ({obj.where} "
                f"reaches {pkg.counts[element]:,} in all); vecslice reads at most "
                f"{limit:,} (vecslice.threemf.{limit_name})")

    def close_object(self, obj: _Reading) -> None:
        pkg = self.pkg
        components = obj.components or ()
        if not obj.chunks["triangles"]:  # nothing to place: no arrays kept
            pkg.objects[obj.key] = _Object(_NO_VERTICES, _NO_FACES, components)
            return
        v, f = (np.concatenate(obj.chunks[k]) if obj.chunks[k] else np.empty(0)
                for k in _LISTS)
        v, f = v.reshape(-1, 3), f.astype(np.int64, copy=False).reshape(-1, 3)
        bad = np.flatnonzero(((f < 0) | (f >= v.shape[0])).any(axis=1))
        if bad.size:
            k = int(bad[0])
            raise pkg.fail(f"{obj.where}: triangle {k} refers to vertices "
                           f"{f[k].tolist()}, but the object has {v.shape[0]} "
                           "vertices")
        pkg.objects[obj.key] = _Object(v, f, components)


def _one_each(entry: str) -> bool:
    """Whether ``'x y z'`` (three attributes joined) has one token per attribute."""
    parts = entry.split(" ")
    return len(parts) == 3 and "" not in parts and entry.isprintable()


def _parse_part(pkg: _Package, key: str, name: str, *, root: bool) -> None:
    """Read the objects (and, for the root part, the build) of model part ``key``.

    ``name`` is how messages call it.
    """
    pkg.parsed.add(key)
    pkg.parse(name, key=key, limit=MAX_MODEL_BYTES,
              target=_ModelReader(pkg, name, key=key, root=root))


def _model_attributes(pkg: _Package, local: str, attrib: dict[str, str],
                      nsmap: dict[str, str], name: str, *, root: bool) -> None:
    if local != "model":
        raise pkg.fail(f"3MF part '{name}' is not a 3D model (its root element is "
                       f"<{local}>, not <model>)")
    unit = attrib.get("unit", "millimeter")
    if unit not in UNITS:
        raise pkg.fail(f"3MF unit must be one of {', '.join(UNITS)}; got {unit!r}")
    if root:
        pkg.unit = unit
    elif unit != pkg.unit:
        raise pkg.fail(f"3MF part '{name}' is in {unit}s, the root model in "
                       f"{pkg.unit}s; vecslice reads parts in one unit only")
    for prefix in attrib.get("requiredextensions", "").split():
        ns = nsmap.get(prefix)
        if ns not in _READABLE:
            raise pkg.fail(f"3MF requires the extension {ns or prefix!r}, which "
                           "vecslice does not read")


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
            _parse_part(pkg, key[0], pkg.members[key[0]].filename, root=False)
        if key not in pkg.objects:
            part = ("" if key[0] == pkg.root else
                    f" of part '{pkg.members[key[0]].filename}'")
            raise pkg.fail(f"{where} refers to object {key[1]}{part}, which is not "
                           "defined")

    tri: dict[Key, int] = {}
    vert: dict[Key, int] = {}
    inst: dict[Key, int] = {}
    for n, (key, _) in enumerate(pkg.items):
        check(key, f"build item {n + 1:,}")
        if key in tri:
            continue
        # the objects on the path from the item: in order (the stack) and as a
        # set, so a cycle check costs one lookup, not a walk along the path
        stack = [(key, iter(children(key)))]
        active = {key}
        while stack:
            node, it = stack[-1]
            child = next(it, None)
            if child is None:
                stack.pop()
                active.discard(node)
                o = pkg.objects[node]
                # saturated: exact integers grew a digit a level (kilobytes
                # each at the end of a chain of a thousand objects)
                kids = children(node)
                tri[node] = min(_MANY, o.faces.shape[0]
                                + sum(tri[c] for c, _ in kids))
                vert[node] = min(_MANY, (o.vertices.shape[0] if o.faces.shape[0]
                                         else 0) + sum(vert[c] for c, _ in kids))
                inst[node] = min(_MANY, 1 + sum(inst[c] for c, _ in kids))
                continue
            ck = child[0]
            check(ck, f"a component of object {node[1]}")
            if ck in active:
                path = [k for k, _ in stack]
                loop = " -> ".join(str(k[1]) for k in path[path.index(ck):])
                raise pkg.fail(f"3MF components form a cycle: objects {loop} -> "
                               f"{ck[1]}")
            if ck not in tri:
                stack.append((ck, iter(children(ck))))
                active.add(ck)
    n_tri = min(_MANY, sum(tri[k] for k, _ in pkg.items))
    n_vert = min(_MANY, sum(vert[k] for k, _ in pkg.items))
    n_inst = min(_MANY, sum(inst[k] for k, _ in pkg.items))
    if n_tri > MAX_BUILD_TRIANGLES:
        raise pkg.fail(f"the 3MF build expands to {_many(n_tri)} triangles; "
                       f"vecslice reads at most {MAX_BUILD_TRIANGLES:,} "
                       "(vecslice.threemf.MAX_BUILD_TRIANGLES)")
    if n_vert > MAX_BUILD_VERTICES:
        raise pkg.fail(f"the 3MF build expands to {_many(n_vert)} vertices; "
                       f"vecslice reads at most {MAX_BUILD_VERTICES:,} "
                       "(vecslice.threemf.MAX_BUILD_VERTICES)")
    if n_inst > MAX_INSTANCES:
        raise pkg.fail(f"the 3MF build expands to {_many(n_inst)} object "
                       f"placements; vecslice reads at most {MAX_INSTANCES:,} "
                       "(vecslice.threemf.MAX_INSTANCES)")
    held = pkg.counts["triangle"]
    if n_tri > max(MAX_EXPANDED_TRIANGLES, held):
        raise pkg.fail(f"the 3MF build expands to {n_tri:,} triangles from the "
                       f"{held:,} its objects hold; vecslice expands a 3MF to at "
                       f"most {MAX_EXPANDED_TRIANGLES:,} triangles, or as many as "
                       "its objects hold (vecslice.threemf.MAX_EXPANDED_TRIANGLES)")
    held = pkg.counts["vertex"]
    if n_vert > max(3 * MAX_EXPANDED_TRIANGLES, held):
        raise pkg.fail(f"the 3MF build expands to {n_vert:,} vertices from the "
                       f"{held:,} its objects hold; vecslice expands a 3MF to at "
                       f"most {3 * MAX_EXPANDED_TRIANGLES:,} vertices (3 x "
                       "vecslice.threemf.MAX_EXPANDED_TRIANGLES), or as many as "
                       "its objects hold")
    placed: dict[Key, list[NDArray[np.float64]]] = {}
    for item in pkg.items:  # depth first, in file order
        todo = [item]
        while todo:
            key, world = todo.pop()
            if pkg.objects[key].faces.shape[0]:
                placed.setdefault(key, []).append(world)
            todo.extend((c, _compose(t, world)) for c, t in reversed(children(key)))
    return list(placed.items())


def _many(n: int) -> str:
    """A count for a message: saturated ones (:data:`_MANY`) as 'more than'."""
    return f"{n:,}" if n < _MANY else f"more than {_MANY:,}"


def _compose(t: NDArray[np.float64], world: NDArray[np.float64]
             ) -> NDArray[np.float64]:
    """``t @ world``, without a new matrix when either is :data:`_IDENTITY`."""
    if t is _IDENTITY:
        return world
    return t if world is _IDENTITY else t @ world


def read_3mf(path: Path, size: int) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Vertices (mm) and faces of every placement in the build of 3MF ``path``.

    Raises :class:`~vecslice.errors.MeshFileError` for a damaged package, a
    missing model, an unknown unit, an unsupported required extension, a bad
    reference or transform, a component cycle, or a part or expansion beyond the
    limits of this module; :class:`~vecslice.errors.InputValueError` for a
    vertex that is not finite (named as written, with its object and index).
    """
    with open(path, "rb") as fh:
        try:
            zf = zipfile.ZipFile(fh)
        except zipfile.BadZipFile as exc:
            raise MeshFileError(f"cannot read '{path}' as 3MF: BadZipFile: {exc}"
                                ) from exc
        return _read_package(path, fh, zf)


def _read_package(path: Path, fh: BinaryIO, zf: zipfile.ZipFile
                  ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """:func:`read_3mf` of the opened package ``zf`` of the file ``fh``."""
    with zf:
        members: dict[str, zipfile.ZipInfo] = {}
        for info in zf.infolist():
            key = _norm(info.filename)
            if key in members:  # OPC: names compare case-insensitively
                first = members[key].filename
                raise MeshFileError(
                    f"'{path}' is not a valid 3MF package: it holds the part "
                    f"'{first}' twice"
                    + (f" (as '{info.filename}')" if info.filename != first else "")
                    + "; part names must differ in more than case, so which one a "
                    "reader takes would be arbitrary")
            members[key] = info
        pkg = _Package(path, fh, members, budget=MAX_MODEL_BYTES)
        root = _model_part(pkg)
        pkg.root = _norm(root)
        _parse_part(pkg, pkg.root, root, root=True)
        if not pkg.items:
            raise pkg.fail("the 3MF build places no objects (no <build> <item>)")
        placed = _expand(pkg)
    # written in place: memory is the result's, with no per-placement copies
    n_v = sum(pkg.objects[k].vertices.shape[0] * len(w) for k, w in placed)
    n_f = sum(pkg.objects[k].faces.shape[0] * len(w) for k, w in placed)
    v_out = np.empty((n_v, 3))
    f_out = np.empty((n_f, 3), dtype=np.int64)
    base = at = 0
    for key, worlds in placed:
        o = pkg.objects[key]
        w = np.stack(worlds)  # (K, 4, 4)
        nv, nf = o.vertices.shape[0], o.faces.shape[0]
        v = v_out[base : base + len(worlds) * nv].reshape(len(worlds), nv, 3)
        np.einsum("vi,kij->kvj", o.vertices, w[:, :3, :3], out=v)
        v += w[:, None, 3, :3]
        f = f_out[at : at + len(worlds) * nf].reshape(len(worlds), nf, 3)
        f[:] = o.faces
        mirror = np.linalg.det(w[:, :3, :3]) < 0  # a mirror turns the winding over
        f[mirror] = o.faces[:, ::-1]
        f += (base + nv * np.arange(len(worlds)))[:, None, None]
        base += len(worlds) * nv
        at += len(worlds) * nf
    if UNITS[pkg.unit] != 1.0:
        v_out *= UNITS[pkg.unit]
    return v_out, f_out

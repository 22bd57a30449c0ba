"""The lxml parser targets that read a 3MF model part, and what they make.

:class:`_ModelReader` streams a model part's ``<object>`` elements (their
``<mesh>`` lists parsed to numbers in chunks, their ``<components>``) and, in
the root part, its ``<build>`` items into the :class:`vecslice.threemf._Package`
being read, counting each against the limits of :mod:`vecslice.threemf` as it
is read. Transforms, object ids and references are parsed strictly here.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any
from urllib.parse import unquote

import numpy as np
from numpy.typing import NDArray

from vecslice.errors import InputValueError
from vecslice.meshfile import _numbers

if TYPE_CHECKING:
    from vecslice.threemf import _Package

Key = tuple[str, int]  # (model part, object id)
# a reference: (the key of the object whose component it is, or None for a
# build item; the index of the component or item)
At = tuple[Key | None, int]
_PRODUCTION = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"

_IDENTITY = np.eye(4)
_IDENTITY.flags.writeable = False  # the transform of every placement without one
_NO_VERTICES = np.empty((0, 3))
_NO_VERTICES.flags.writeable = False  # the arrays of every object without triangles
_NO_FACES = np.empty((0, 3), dtype=np.int64)
_NO_FACES.flags.writeable = False
_SATURATED = np.iinfo(np.int64).max  # numpy's parse of any integer beyond int64
_CHUNK = 1 << 16  # vertices or triangles parsed to numbers at a time


def _norm(name: str) -> str:
    """A part name as a lookup key: no leading '/', %-escapes decoded, lower case."""
    return unquote(name).lstrip("/").lower()


@dataclass(slots=True)
class _Object:
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    # (model part, object id, 4x4 row-vector transform) of each component
    components: Sequence[tuple[Key, NDArray[np.float64]]] = ()


class _Target:
    """Base of the lxml parser targets: refuses a document type declaration."""

    def __init__(self, pkg: _Package, name: str) -> None:
        self.pkg, self.name = pkg, name

    def doctype(self, *args: Any) -> None:
        self.pkg.dtd(self.name)

    def close(self) -> None:
        pass


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
"""Largest 3MF resource id (ST_ResourceID: a positive integer below 2**31)."""


def _shown(text: str, limit: int = 40) -> str:
    """``repr(text)`` for a message, cut after ``limit`` characters."""
    if len(text) <= limit:
        return repr(text)
    return f"{text[:limit]!r}... ({len(text):,} characters)"


def _object_id(text: str) -> int | None:
    """The object id ``text`` (ASCII digits, 1 to :data:`_ID_MAX`), or None.

    0 is none (3MF resource ids are positive), nor is a signed number.
    ``str.isdigit`` and ``int`` also take the digits of other scripts
    (Arabic-Indic one, U+0661), ``isdigit`` also superscripts, which ``int``
    refuses, and ``int`` refuses more than 4300 digits: all raised a bare
    ValueError.
    """
    if not (text.isascii() and text.isdigit()) or len(text.lstrip("0")) > 10:
        return None
    n = int(text)
    return n if 0 < n <= _ID_MAX else None


def _id_of(pkg: _Package, attrib: dict[str, str], name: str, who: str,
           expected: str) -> tuple[str, int]:
    """(as written, number) of the object id in attribute ``name`` of ``who``.

    A missing or malformed id is a MeshFileError naming ``who`` and the value.
    """
    text = attrib.get(name)
    if text is None:
        raise pkg.fail(f"{who} has no {name}")
    n = _object_id(text)
    if n is None:
        raise pkg.fail(f"{who} has {name} {_shown(text)}; expected {expected} from 1 "
                       f"to {_ID_MAX}")
    return text, n


def _ref(pkg: _Package, attrib: dict[str, str], part: str, where: str,
         at: At) -> Key:
    """(part, object id) an item or component of model part ``part`` refers to.

    ``at`` names the reference for :func:`_written`. The few references whose
    spelling their key does not give back (an id with leading zeros; a
    ``p:path`` that is not ``'/'`` and the part's name in the package, that
    names the referring part itself, or a part the package lacks) are kept as
    written in ``pkg.spelled``: a message names them as the file does.
    """
    oid, n = _id_of(pkg, attrib, "objectid", where, "an object number")
    target = attrib.get(f"{{{_PRODUCTION}}}path")
    key = (_norm(target) if target else part, n)
    info = pkg.members.get(key[0]) if target else None
    if oid != str(n) or (target and (key[0] == part or info is None
                                     or target != "/" + info.filename)):
        spelled = (oid, target)  # one tuple per spelling, not per reference
        pkg.spelled[at] = pkg.spellings.setdefault(spelled, spelled)
    return pkg.keys.setdefault(key, key)  # one tuple per object, not per reference


def _written(pkg: _Package, key: Key, at: At) -> tuple[str, str | None]:
    """The objectid and ``p:path`` (None: none) of reference ``at`` as written.

    ``at`` is (the key of the object whose component it is, or None for a
    build item; the component's or item's index); ``key`` what it refers to.
    """
    spelled = pkg.spelled.get(at)
    if spelled is not None:
        return spelled
    part = pkg.root if at[0] is None else at[0][0]  # where the reference is
    return str(key[1]), (None if key[0] == part else
                         "/" + pkg.members[key[0]].filename)


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
        self.seen: set[str] = set()  # the lists read (a mesh has one of each)
        self.components: list[tuple[Key, NDArray[np.float64]]] = []


class _ModelReader(_Target):
    """lxml parser target: the objects (and, in the root part, the build) of a part.

    ``<vertex>`` and ``<triangle>`` attributes are kept as text for at most
    :data:`_CHUNK` elements, then parsed to numbers; the counts are checked
    against :data:`vecslice.threemf.MAX_BUILD_VERTICES` and
    :data:`~vecslice.threemf.MAX_BUILD_TRIANGLES` as they grow, and objects
    against :data:`~vecslice.threemf.MAX_OBJECTS` (the values in ``pkg.limits``),
    so a hostile part is refused before its numbers cost memory.
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
            self.pkg.model_attributes(local, attrib, nsmap or {}, self.name,
                                      root=self.root)
        elif local == "object":
            self.open_object(attrib)
        elif local == "build":
            self.build += 1
        elif local == "item" and self.build and self.root:
            pkg = self.pkg
            where = f"build item {len(pkg.items) + 1:,}"
            pkg.items.append(pkg.placement(attrib, self.part, where,
                                           (None, len(pkg.items))))
        if not self.objects or local in ("object", "build", "item"):
            return
        grand = stack[-3] if len(stack) >= 3 else ""
        obj = self.objects[-1]
        if local == "mesh" and parent == "object":
            if obj.mesh:  # its triangles would be left out without a word
                raise self.pkg.fail(f"{obj.where} has a second <mesh>; a 3MF "
                                    "object has one")
            obj.mesh, obj.mesh_depth = 1, len(stack)
        elif (local in _LISTS and parent == "mesh" and grand == "object"
              and obj.mesh == 1 and len(stack) == obj.mesh_depth + 1
              and self.list is None):
            if local in obj.seen:
                raise self.pkg.fail(f"{obj.where}: its <mesh> has a second "
                                    f"<{local}>; a 3MF mesh has one")
            obj.seen.add(local)
            self.list, self.list_depth = local, len(stack)
            self.element, self.names = _LISTS[local][:2]
        elif local == "component" and parent == "components" and grand == "object":
            pkg = self.pkg
            cw = f"component {len(obj.components):,} of {obj.where}"
            obj.components.append(pkg.placement(attrib, self.part, cw,
                                                (obj.key, len(obj.components))))

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
        oid, n = _id_of(pkg, attrib, "id", f"an object in '{self.name}'", "a number")
        where = f"object {oid}" + ("" if self.part == pkg.root else
                                   f" of '{self.name}'")
        pkg.n_objects += 1
        limit = pkg.limits["MAX_OBJECTS"]
        if pkg.n_objects > limit:
            raise pkg.fail(
                f"the 3MF holds more than {limit:,} objects ({where} is one more); "
                f"vecslice reads at most {limit:,} (vecslice.threemf.MAX_OBJECTS)")
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
        limit, reach = pkg.limits[limit_name], pkg.counts[element] + len(buf)
        if reach > limit:  # before the chunk is joined, parsed and kept
            raise pkg.fail(
                f"the 3MF objects hold more than {limit:,} {kind} ({obj.where} "
                f"reaches {reach:,} in all); vecslice reads at most {limit:,} "
                f"(vecslice.threemf.{limit_name})")
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
        pkg.counts[element] = reach
        buf.clear()

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

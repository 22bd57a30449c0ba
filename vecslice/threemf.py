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
before any placement is made, as are builds beyond the limits of every mesh
file (:data:`vecslice.meshfile.MAX_TRIANGLES`). The limits are read once, as a
read begins, so every check of one read uses the same values. The model's
``unit`` is applied: vertices come out in millimetres. The parser targets that
read model parts are in :mod:`vecslice._threemf_model`.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from numpy.typing import NDArray

from vecslice import meshfile
from vecslice._threemf_model import (
    _IDENTITY,
    _PRODUCTION,
    At,
    Key,
    _ModelReader,
    _norm,
    _Object,
    _ref,
    _shown,
    _Target,
    _transform,
    _written,
)
from vecslice._zipread import InflationError, MemberDataError, inflate
from vecslice.errors import MeshFileError

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
object, about 130 bytes, 370 with a transform, about 120 more if its objectid or
``p:path`` is spelt otherwise than usual, kept for messages) until the build is
expanded, so they are counted as they are read and the one past the limit is
refused.
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
# extensions whose required use still leaves the geometry to <mesh>/<components>
_READABLE = {
    "http://schemas.microsoft.com/3dmanufacturing/core/2015/02",
    _PRODUCTION,
    "http://schemas.microsoft.com/3dmanufacturing/material/2015/02",
}
_RATIO_FROM = 1 << 20
_RELS_BYTES = 1 << 20  # most bytes _rels/.rels may inflate to (within the budget)
_MANY = 2**62  # expanded counts saturate here: beyond every limit, a small int
_FEED = 1 << 20  # bytes of XML handed to the parser at a time


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
    # (objectid, p:path) as written of the references their key does not
    # spell back (see _ref)
    spelled: dict[At, tuple[str, str | None]] = field(default_factory=dict)
    spellings: dict[tuple[str, str | None], tuple[str, str | None]] = field(
        default_factory=dict)
    # the limits the read is held to (see _limits), by the names of the constants
    limits: dict[str, int] = field(default_factory=dict)
    # vertices and triangles of every object read so far (placed or not)
    counts: dict[str, int] = field(
        default_factory=lambda: {"vertex": 0, "triangle": 0})

    def fail(self, what: str) -> MeshFileError:
        return MeshFileError(f"'{self.path}': {what}")

    def placement(self, attrib: dict[str, str], part: str, where: str,
                  at: At) -> tuple[Key, NDArray[np.float64]]:
        """The (object, transform) of an ``<item>`` or ``<component>``, counted.

        ``part`` is the model part it is in, ``at`` which one it is (see
        :func:`vecslice._threemf_model._written`).

        Each one places an object at least once, so more than
        :data:`MAX_INSTANCES` of them are refused as they are read, before they
        cost memory (each is kept until the build is expanded).
        """
        self.refs += 1
        limit = self.limits["MAX_INSTANCES"]
        if self.refs > limit:
            raise self.fail(
                f"the 3MF holds more than {limit:,} build items and components "
                f"({where} is one more); vecslice reads at most {limit:,} "
                "(vecslice.threemf.MAX_INSTANCES)")
        return (_ref(self, attrib, part, where, at),
                _transform(self, attrib.get("transform"), where))

    def member(self, key: str, name: str, *, limit: int) -> zipfile.ZipInfo:
        """Member ``key`` (called ``name``) after checking its declared sizes.

        It may inflate to ``limit`` bytes, and to what is left of the budget.
        """
        info = self.members[key]
        if info.flag_bits & 0x1:
            raise self.fail(f"3MF part '{name}' is encrypted")
        if info.file_size > min(limit, self.budget):
            total = self.limits["MAX_MODEL_BYTES"]
            raise self.fail(
                f"3MF part '{name}' inflates to {info.file_size:,} bytes, more than "
                + (f"the {limit:,} bytes vecslice reads of it" if limit < self.budget
                   else f"the {self.budget:,} bytes left of vecslice's limit on "
                   f"model XML ({total:,} bytes, vecslice.threemf.MAX_MODEL_BYTES)"))
        ratio = info.file_size / max(info.compress_size, 1)
        most = self.limits["MAX_COMPRESSION_RATIO"]
        if info.file_size > _RATIO_FROM and ratio > most:
            raise self.fail(
                f"3MF part '{name}' would inflate {ratio:,.0f} times "
                f"({info.compress_size:,} to {info.file_size:,} bytes): a zip bomb? "
                f"(at most {most} times, vecslice.threemf.MAX_COMPRESSION_RATIO)")
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
        most = self.limits["MAX_COMPRESSION_RATIO"]
        try:
            # at most the declared size, at most MAX_COMPRESSION_RATIO times the
            # compressed bytes actually consumed: whatever the entry declares
            for chunk in inflate(self.fh, info, max_ratio=most,
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
                f"3MF part '{name}' inflates more than {most} times: "
                f"{exc.inflated:,} bytes from the first {exc.consumed:,} compressed "
                f"bytes (its zip entry declares {info.compress_size:,} "
                f"to {info.file_size:,} bytes): a zip bomb? "
                "(vecslice.threemf.MAX_COMPRESSION_RATIO)") from None

    def dtd(self, name: str) -> None:
        raise self.fail(f"3MF part '{name}' has a document type declaration "
                        "(DTD), which 3MF does not allow")

    def model_attributes(self, local: str, attrib: dict[str, str],
                         nsmap: dict[str, str], name: str, *, root: bool) -> None:
        """Check the root element of model part ``name``; the root part's unit."""
        if local != "model":
            raise self.fail(f"3MF part '{name}' is not a 3D model (its root element is "
                            f"<{local}>, not <model>)")
        unit = attrib.get("unit", "millimeter")
        if unit not in UNITS:
            raise self.fail(
                f"3MF unit must be one of {', '.join(UNITS)}; got {unit!r}")
        if root:
            self.unit = unit
        elif unit != self.unit:
            raise self.fail(f"3MF part '{name}' is in {unit}s, the root model in "
                            f"{self.unit}s; vecslice reads parts in one unit only")
        for prefix in attrib.get("requiredextensions", "").split():
            ns = nsmap.get(prefix)
            if ns not in _READABLE:
                raise self.fail(f"3MF requires the extension {ns or prefix!r}, which "
                                "vecslice does not read")


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
        pkg.parse("_rels/.rels", limit=_RELS_BYTES, target=rels)
        for target in rels.targets[:1]:
            if _norm(target) not in pkg.members:
                raise pkg.fail(f"3MF holds no 3D model: _rels/.rels names "
                               f"'{target}', which the package does not contain")
            return target
    if _norm("3D/3dmodel.model") in pkg.members:
        return "3D/3dmodel.model"
    raise pkg.fail("3MF holds no 3D model: no part is named in _rels/.rels as "
                   "the 3D model, and there is no 3D/3dmodel.model")


def _parse_part(pkg: _Package, key: str, name: str, *, root: bool) -> None:
    """Read the objects (and, for the root part, the build) of model part ``key``.

    ``name`` is how messages call it.
    """
    pkg.parsed.add(key)
    pkg.parse(name, key=key, limit=pkg.limits["MAX_MODEL_BYTES"],
              target=_ModelReader(pkg, name, key=key, root=root))


def _expand(pkg: _Package) -> list[tuple[Key, list[NDArray[np.float64]]]]:
    """Every (object with a mesh, its world transforms), components walked.

    Checks references, cycles and the expanded counts before any placement is
    made.
    """
    def children(key: Key) -> list[tuple[Key, NDArray[np.float64]]]:
        return pkg.objects[key].components

    def check(key: Key, at: At) -> None:
        """Read the part ``key`` is in, if need be; refuse a missing ``key``.

        ``at``: the reference to it, named in a message as the file writes it.
        """
        if key in pkg.objects:
            return
        holder, k = at
        where = f"build item {k + 1:,}" if holder is None else (
            f"component {k:,} of object {holder[1]}" + (
                "" if holder[0] == pkg.root else
                f" of '{pkg.members[holder[0]].filename}'"))
        oid, target = _written(pkg, key, at)
        if key[0] not in pkg.parsed:
            if key[0] not in pkg.members:
                raise pkg.fail(f"{where} refers to part {_shown(target or '', 200)} "
                               "(p:path), which the package does not contain")
            _parse_part(pkg, key[0], pkg.members[key[0]].filename, root=False)
        if key not in pkg.objects:
            of = f" of part {_shown(target, 200)}" if target else ""
            raise pkg.fail(f"{where} refers to object {oid}{of}, which is not "
                           "defined")

    tri: dict[Key, int] = {}
    vert: dict[Key, int] = {}
    inst: dict[Key, int] = {}
    for n, (key, _) in enumerate(pkg.items):
        check(key, (None, n))
        if key in tri:
            continue
        # the objects on the path from the item: in order (the stack) and as a
        # set, so a cycle check costs one lookup, not a walk along the path
        stack = [(key, enumerate(children(key)))]
        active = {key}
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
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
            i, (ck, _) = nxt
            check(ck, (node, i))
            if ck in active:
                path = [k for k, _ in stack]
                loop = " -> ".join(str(k[1]) for k in path[path.index(ck):])
                raise pkg.fail(f"3MF components form a cycle: objects {loop} -> "
                               f"{ck[1]}")
            if ck not in tri:
                stack.append((ck, enumerate(children(ck))))
                active.add(ck)
    n_tri = min(_MANY, sum(tri[k] for k, _ in pkg.items))
    n_vert = min(_MANY, sum(vert[k] for k, _ in pkg.items))
    n_inst = min(_MANY, sum(inst[k] for k, _ in pkg.items))
    lim = pkg.limits
    for n, what, most, source in (
            (n_tri, "triangles", lim["MAX_BUILD_TRIANGLES"],
             "vecslice.threemf.MAX_BUILD_TRIANGLES"),
            (n_vert, "vertices", lim["MAX_BUILD_VERTICES"],
             "vecslice.threemf.MAX_BUILD_VERTICES"),
            (n_inst, "object placements", lim["MAX_INSTANCES"],
             "vecslice.threemf.MAX_INSTANCES"),
            # the limits of every mesh file (read_mesh_file checks them once the
            # arrays are made); this module's are lower, unless they were raised
            (n_tri, "triangles", lim["MAX_TRIANGLES"],
             "vecslice.meshfile.MAX_TRIANGLES"),
            (n_vert, "vertices", 3 * lim["MAX_TRIANGLES"],
             "3 x vecslice.meshfile.MAX_TRIANGLES")):
        if n > most:
            raise pkg.fail(f"the 3MF build expands to {_many(n)} {what}; vecslice "
                           f"reads at most {most:,} ({source})")
    most, held = lim["MAX_EXPANDED_TRIANGLES"], pkg.counts["triangle"]
    if n_tri > max(most, held):
        raise pkg.fail(f"the 3MF build expands to {n_tri:,} triangles from the "
                       f"{held:,} its objects hold; vecslice expands a 3MF to at "
                       f"most {most:,} triangles, or as many as "
                       "its objects hold (vecslice.threemf.MAX_EXPANDED_TRIANGLES)")
    held = pkg.counts["vertex"]
    if n_vert > max(3 * most, held):
        raise pkg.fail(f"the 3MF build expands to {n_vert:,} vertices from the "
                       f"{held:,} its objects hold; vecslice expands a 3MF to at "
                       f"most {3 * most:,} vertices (3 x "
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


def _limits() -> dict[str, int]:
    """The limits a read is held to, by the names of their constants.

    This module's and :data:`vecslice.meshfile.MAX_TRIANGLES`, read here only,
    as the read begins: every check of one read uses the same values.
    """
    return {"MAX_MODEL_BYTES": MAX_MODEL_BYTES,
            "MAX_COMPRESSION_RATIO": MAX_COMPRESSION_RATIO,
            "MAX_INSTANCES": MAX_INSTANCES, "MAX_OBJECTS": MAX_OBJECTS,
            "MAX_BUILD_TRIANGLES": MAX_BUILD_TRIANGLES,
            "MAX_BUILD_VERTICES": MAX_BUILD_VERTICES,
            "MAX_EXPANDED_TRIANGLES": MAX_EXPANDED_TRIANGLES,
            "MAX_TRIANGLES": meshfile.MAX_TRIANGLES}


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
        limits = _limits()
        pkg = _Package(path, fh, members, budget=limits["MAX_MODEL_BYTES"],
                       limits=limits)
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

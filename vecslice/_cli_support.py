"""Plumbing of the ``vecslice`` command: messages, output checks, safe writes.

Kept apart from :mod:`vecslice.cli` (the options and the commands) so that both stay
short. Nothing here imports numba, trimesh or matplotlib.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
import threading
from dataclasses import fields
from decimal import ROUND_HALF_UP, Decimal, InvalidOperation
from pathlib import Path
from typing import Any, TextIO

from vecslice.errors import InputValueError

__all__ = [
    "COMPILE_MESSAGE",
    "CliInputError",
    "CliParser",
    "CompileNotice",
    "check_output",
    "cli_path",
    "flush_and_exit",
    "human_bytes",
    "load_info_lines",
    "mm_to_microns",
    "mm_value",
    "note",
    "say",
    "shown",
    "shown_mm",
    "size_hint",
]

COMPILE_MESSAGE = "vecslice: compiling kernels, first run only"


class CliInputError(InputValueError):
    """A command-line value that vecslice rejects (exit status 1)."""


# what argparse takes for a negative number (a value), not an option: its own
# -5 and -.5, and also -5e-1, -1E+3, -5., -inf and -nan (any case), which float()
# reads
_NEGATIVE_NUMBER = re.compile(
    r"^-(\d+\.?\d*|\.\d+)(e[-+]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)


class CliParser(argparse.ArgumentParser):
    """An ArgumentParser that reads ``-5e-1`` and ``-inf`` as values.

    Its sub-parsers are CliParsers too (``add_subparsers`` makes sub-parsers of
    the parser's own class).
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # argparse's own matcher (Python 3.11) knows only forms like -5 and -.5
        self._negative_number_matcher = _NEGATIVE_NUMBER


def mm_value(text: str) -> Decimal:
    """A length in mm as typed, as the exact decimal it names (an argparse type).

    What ``float()`` reads is accepted (``1e-3``, ``inf``, ``nan``, ``1_000``),
    nothing else; ``0.5005`` stays 0.5005, not the binary float just below it.
    """
    try:
        number = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid float value: {text!r}") from None
    try:
        return Decimal(text.strip())
    except InvalidOperation:  # a form float() reads and Decimal does not
        return Decimal(number)


def shown_mm(value: Decimal) -> str:
    """A length in mm for messages, as ``{:g}`` shows a float (``2e+06``)."""
    f = float(value)
    if value.is_finite() and value and (f == 0 or not math.isfinite(f)):
        return f"{value:g}"  # beyond the range of floats (1e400, 1e-400)
    return f"{f:g}"


def mm_to_microns(value: Decimal, flag: str, *, cura: bool = False) -> int:
    """``value`` mm in µm, rounding half away from zero, exactly.

    With ``cura``, as CuraEngine reads a length setting instead
    (``spec/CURA_COMPAT.md``): ``MM2INT(atof(text))``, the nearest double of the
    decimal times 1000 plus half its sign, in float64, truncated. It differs
    where the double lies below a half micron: ``0.5005`` is 500 µm there.

    Raises
    ------
    CliInputError
        If ``value`` is not finite, or its magnitude reaches ``COORD_LIMIT`` µm.
    """
    from vecslice.units import COORD_LIMIT

    if not value.is_finite():
        raise CliInputError(f"{flag} must be a finite length in mm; got "
                            f"{shown_mm(value)}")
    out_of_range = CliInputError(
        f"{flag} {shown_mm(value)} mm is out of range: it must be below "
        f"{COORD_LIMIT / 1000:g} mm in magnitude (2**30 µm)")
    if abs(value) >= COORD_LIMIT:  # (in mm): far out, and quantize stays exact
        raise out_of_range
    if cura:
        x = float(value)  # the double strtod gives for the typed decimal
        um = int(x * 1000.0 + math.copysign(0.5, x) * (x != 0.0))
    else:  # one rounding, of the decimal itself: half away from zero for both signs
        um = int(value.quantize(Decimal("0.001"), rounding=ROUND_HALF_UP).scaleb(3))
    if abs(um) >= COORD_LIMIT:
        raise out_of_range
    return um


def shown(path: str | os.PathLike[str]) -> str:
    r"""How the command line shows ``path``: its bytes as UTF-8, others escaped.

    A file name is bytes; one that is not valid UTF-8 (``caf\xe9.stl`` in
    Latin-1) reaches Python with surrogates, which no strict encoder accepts.
    Every path printed, or put into a page, goes through here: the same
    ``caf\xe9.stl`` everywhere, never a UnicodeEncodeError.
    """
    return os.fsencode(path).decode("utf-8", "backslashreplace")


def say(text: str, stream: TextIO | None = None, *, flush: bool = False) -> None:
    """Print ``text`` and a newline on ``stream`` (default: stdout).

    Characters the stream's encoding lacks (``µ`` on an ASCII stream, a
    surrogate under ``PYTHONIOENCODING=utf-8``) are written as backslash escapes
    instead of raising UnicodeEncodeError, which would end the run with a
    traceback after its work was done.
    """
    stream = stream or sys.stdout
    try:
        stream.write(text + "\n")
    except UnicodeEncodeError:  # raised before anything is written
        encoding = getattr(stream, "encoding", None) or "ascii"
        safe = text.encode(encoding, "backslashreplace").decode(encoding, "replace")
        stream.write(safe + "\n")
    if flush:
        stream.flush()


def note(message: str) -> None:
    """One line on stderr, prefixed ``vecslice: ``."""
    say(f"vecslice: {message}", sys.stderr, flush=True)


class CompileNotice:
    """Say once on stderr that kernels are being compiled (a cold numba cache).

    Numba reports every real compilation (``numba:compile``; a kernel loaded from
    the on-disk cache does not emit it), so the line appears on a first run only.
    The lazy kernels' ``compile_listeners`` measure the time spent making kernels
    ready, for the closing line.
    """

    def __init__(self, stream: Any = None) -> None:
        self.stream = stream
        self.compiled = 0
        self.seconds = 0.0
        self._lock = threading.Lock()
        self._depth = threading.local()
        self._listener: Any = None

    def _announce(self) -> None:
        with self._lock:
            self.compiled += 1
            first = self.compiled == 1
        if first:
            print(COMPILE_MESSAGE + " (later runs load them from the cache)",
                  file=self.stream or sys.stderr, flush=True)

    def _ready(self, event: str, name: str, seconds: float) -> None:
        # kernels called by a kernel are made ready inside their caller's
        # compilation: count the outermost ones only, per thread
        depth = getattr(self._depth, "n", 0)
        if event == "start":
            self._depth.n = depth + 1
            return
        self._depth.n = depth - 1
        if depth == 1:
            with self._lock:
                self.seconds += seconds

    def __enter__(self) -> CompileNotice:
        from numba.core import event

        from vecslice._kernels import _jit

        notice = self

        class _Listener(event.Listener):
            def on_start(self, ev: Any) -> None:
                notice._announce()

            def on_end(self, ev: Any) -> None:
                pass

        self._listener = _Listener()
        event.register("numba:compile", self._listener)
        _jit.compile_listeners.append(self._ready)
        return self

    def __exit__(self, *exc: object) -> None:
        from numba.core import event

        from vecslice._kernels import _jit

        event.unregister("numba:compile", self._listener)
        if self._ready in _jit.compile_listeners:
            _jit.compile_listeners.remove(self._ready)
        if self.compiled and exc[0] is None:
            print(f"vecslice: compiled kernels in {self.seconds:.1f} s; they are "
                  "cached for the next run", file=self.stream or sys.stderr,
                  flush=True)


def cli_path(text: str, flag: str, *, output: bool = False) -> Path:
    """The path a command-line argument names, refusing what a Path would change.

    ``Path("")`` is ``.`` and ``Path("out/")`` is ``out``: an empty argument, and an
    output that ends with a path separator (or in ``.`` or ``..``), name no file.

    Raises
    ------
    CliInputError
        If ``text`` is empty, or ``output`` and ``text`` names a directory.
    """
    if not text:
        raise CliInputError(f"{flag} is an empty string; give a file name")
    seps = tuple(s for s in (os.sep, os.altsep) if s)
    if output and (text.endswith(seps) or os.path.basename(text) in (".", "..")):
        raise CliInputError(f"{flag} '{shown(text)}' names a directory, not a "
                            "file; give a file name")
    return Path(text)


def check_output(path: Path | None, suffixes: tuple[str, ...] = (),
                 flag: str = "-o",
                 inputs: tuple[Path | None, ...] = ()) -> Path | None:
    """Check, before any work, that ``path`` can be written.

    An existing ``path`` is replaced only if it is a regular, writable file that
    is none of the ``inputs`` (compared as files: ``./x.stl``, a symbolic or a
    hard link to an input count as the input).

    Raises
    ------
    CliInputError
        If ``path`` is one of ``inputs``, a directory, its directory does not
        exist or cannot be written, or its suffix is not one of ``suffixes``
        (when given).
    vecslice.errors.StorageFileError
        If ``path`` exists and is not a regular file (a FIFO, a device such as
        ``/dev/null``, a socket) or is read-only.
    """
    if path is None:
        return None
    name = shown(path)
    for source in inputs:
        if source is not None and _same_file(path, source):
            raise CliInputError(f"{flag} '{name}' is the input file "
                                f"'{shown(source)}': vecslice never overwrites its "
                                "input; choose another output name")
    if path.is_dir():
        raise CliInputError(f"{flag} '{name}' is a directory; give a file name")
    if suffixes and path.suffix.lower() not in suffixes:
        raise CliInputError(f"{flag} must name a {' or '.join(suffixes)} file; "
                            f"got '{name}'")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.exists():
        raise CliInputError(f"{flag} '{name}': the directory '{shown(parent)}' "
                            "does not exist")
    if not parent.is_dir():
        raise CliInputError(f"{flag} '{name}': '{shown(parent)}' is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise CliInputError(f"{flag} '{name}': the directory '{shown(parent)}' "
                            "is not writable")
    from vecslice.npz import check_target

    check_target(str(path), where=f"{flag} '{name}'")
    return path


def _same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` are the same existing file (links followed)."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):  # one is missing (or unreadable): not the same
        return False


_LOADING = ("source", "faces_in", "vertices_in")
# label of each count: (one, several)
_CLEANUP = {
    "vertices_merged": ("vertex merged (same position)",
                        "vertices merged (same position)"),
    "vertices_unused": ("unused vertex dropped", "unused vertices dropped"),
    "faces_degenerate": ("degenerate face dropped", "degenerate faces dropped"),
}
# CuraEngine's loading melds vertices within 30 µm, not only equal ones
_MELDED = ("vertex melded (within 30 µm, as CuraEngine)",
           "vertices melded (within 30 µm, as CuraEngine)")
_REPAIR = {
    "faces_duplicate": ("duplicate face removed", "duplicate faces removed"),
    "faces_flipped": ("face flipped", "faces flipped"),
    "shells_reversed": ("shell reversed", "shells reversed"),
    "cavities_kept": ("cavity kept", "cavities kept"),
}


def load_info_lines(info: Any, *, melded: bool = False) -> list[str]:
    """``cleaned: ...`` and ``repaired: ...`` lines for the non-zero counts.

    Every integer field of :class:`vecslice.meshcheck.LoadInfo` is reported: the
    known ones with a label (singular for a count of one), any other (a newer
    repair step) by its name. ``melded``: the mesh was read with
    ``compat="cura"``, whose merged vertices are those within 30 µm.
    """
    if info is None:
        return []
    cleaned, repaired = [], []
    for f in fields(info):
        value = getattr(info, f.name)
        if f.name in _LOADING or isinstance(value, bool) or not isinstance(value, int):
            continue
        if value:
            forms = (_MELDED if melded and f.name == "vertices_merged"
                     else _CLEANUP.get(f.name) or _REPAIR.get(f.name))
            label = forms[value != 1] if forms else f.name.replace("_", " ")
            (cleaned if f.name in _CLEANUP else repaired).append(f"{value:,} {label}")
    lines = []
    if cleaned:
        lines.append("cleaned   " + ", ".join(cleaned))
    if repaired:
        lines.append("repaired  " + ", ".join(repaired))
    return lines


def size_hint(size_mm: Any, scale_given: bool) -> str | None:
    """A suggestion when a model's size suggests a file in other units."""
    largest = float(max(size_mm))
    dims = " x ".join(f"{v:.3f}" for v in size_mm)
    if largest < 2.0:
        hint = "" if scale_given else "; if the file is in metres, add --scale 1000"
        return f"the model is only {dims} mm{hint}"
    if largest > 2000.0:
        hint = "" if scale_given else "; if the file is in µm, add --scale 0.001"
        return f"the model is {dims} mm, larger than any printer{hint}"
    return None


def human_bytes(n: int) -> str:
    """``123 B``, ``4.5 kB``, ``6.7 MB``."""
    if n < 1000:
        return f"{n} B"
    if n < 1_000_000:
        return f"{n / 1e3:.1f} kB"
    return f"{n / 1e6:.1f} MB"


def flush_and_exit(code: int) -> None:
    """Flush the standard streams and end the process at once.

    Used after Ctrl-C: a kernel still running in the worker thread cannot be
    stopped, and a normal interpreter shutdown would wait for it.
    """
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(code)

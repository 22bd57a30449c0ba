"""``.npz`` archives read and written safely.

Reading: the ``.npy`` header of every member is read first (a few hundred bytes
inflated), so dtypes, shapes, sizes and the compression ratio are checked before any
array is inflated: a small hostile file cannot make vecslice allocate gigabytes.

Both refuse what is not a regular file (a FIFO, a device, a socket) at once:
reading one could block forever or never end, and replacing one (``/dev/null``
as root) would damage the system.

Writing: to a temporary file beside the target, renamed into place, removed on any
failure, on Ctrl-C and on SIGTERM; symbolic links are written through, new files
respect the umask and overwritten files keep their mode. A read-only file is never
replaced (as the shell's ``>`` and ``cp`` refuse it).
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import secrets
import signal
import stat
import struct
import threading
import tokenize
import zipfile
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from vecslice.errors import InputTypeError, InputValueError, StorageFileError

__all__ = [
    "MAX_BYTES",
    "MAX_RATIO",
    "Member",
    "check_path",
    "check_target",
    "file_kind",
    "open_archive",
    "read_array",
    "read_members",
    "write_atomic",
]

MAX_BYTES = 2**32
"""Default limit on the total size of the arrays of one archive (4 GiB)."""
MAX_RATIO = 200
"""Largest compression ratio accepted for the arrays of an archive, all together,
once they inflate to more than 1 MiB.

One member may legitimately deflate near deflate's ceiling of about 1000:1 (the
coordinates of a prism repeat the same ring on every layer, a per-layer count that
is all zero), but not the whole model: its offsets and heights grow from layer to
layer and compress about 3-10:1, so saved models stay below about 100:1 (tall
prisms of rings of 3 to 2,000 vertices: 16-95:1). A zip bomb inflates about 1000:1.
"""
_RATIO_FLOOR = 2**20
_CHUNK = 2**24
# what zipfile, zlib and numpy's header parser raise on damaged or odd files
_READ_ERRORS = (OSError, ValueError, TypeError, EOFError, SyntaxError, RuntimeError,
                NotImplementedError, struct.error, tokenize.TokenError, zlib.error,
                zipfile.BadZipFile)


@dataclass(frozen=True, slots=True)
class Member:
    """One ``.npy`` member of an archive, described by its header."""

    name: str
    """The array's name (the member's file name without ``.npy``)."""
    dtype: np.dtype[Any]
    shape: tuple[int, ...]
    nbytes: int
    """Bytes of array data the header promises."""
    info: zipfile.ZipInfo


def check_path(path: object, name: str = "path") -> str:
    """``path`` as a non-empty ``str``, or an InputTypeError / InputValueError."""
    if not isinstance(path, (str, os.PathLike)):
        raise InputTypeError(
            f"`{name}` must be a file path (str or os.PathLike); got "
            f"{type(path).__name__} {path!r}"
        )
    p = os.fspath(path)
    if not isinstance(p, str):  # bytes paths
        p = os.fsdecode(p)
    if not p:
        raise InputValueError(f"`{name}` must be a non-empty file path; got ''")
    if "\0" in p:
        raise InputValueError(f"`{name}` must not contain NUL characters; got {p!r}")
    return p


def file_kind(mode: int) -> str:
    """What a file of mode ``mode`` (``st_mode``) is: ``"a FIFO (named pipe)"``..."""
    for test, kind in ((stat.S_ISDIR, "a directory"),
                       (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return kind
    return "a regular file" if stat.S_ISREG(mode) else "not a regular file"


def _check_regular(p: str, mode: int) -> None:
    if stat.S_ISDIR(mode):
        raise StorageFileError(f"{p!r} is a directory, not a saved vecslice model")
    if not stat.S_ISREG(mode):
        raise StorageFileError(
            f"{p!r} is {file_kind(mode)}, not a regular file; a saved vecslice "
            "model is a regular .npz file"
        )


class _OwnedZipFile(zipfile.ZipFile):
    """A ZipFile reading an already opened file, which it closes with itself."""

    def __init__(self, fh: IO[bytes]) -> None:
        self._owned = fh
        super().__init__(fh)

    def close(self) -> None:
        try:
            super().close()
        finally:
            self._owned.close()


def open_archive(p: str) -> zipfile.ZipFile:
    """Open ``p`` as a zip archive, with clear errors for what is not one.

    The file is opened without blocking and checked through its descriptor, so a
    FIFO or a device (``/dev/zero``) is refused at once, whatever ``p`` links to.
    """
    fh = None
    try:
        try:
            _check_regular(p, os.stat(p).st_mode)
            # no blocking open: a FIFO swapped in after the stat must not hang
            fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        except FileNotFoundError:
            raise StorageFileError(f"{p!r} does not exist") from None
        except PermissionError:
            raise StorageFileError(f"cannot read {p!r}: permission denied") from None
        fh = os.fdopen(fd, "rb")
        _check_regular(p, os.fstat(fd).st_mode)
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        magic = fh.read(6)
        if magic.startswith(b"\x93NUMPY"):
            raise StorageFileError(
                f"{p!r} is a single .npy array, not an .npz written by "
                "SlicedModel.save()"
            )
        fh.seek(0)
        zf, fh = _OwnedZipFile(fh), None
        return zf
    except _READ_ERRORS as exc:
        if isinstance(exc, StorageFileError):
            raise
        raise StorageFileError(
            f"{p!r} is not an .npz file written by SlicedModel.save() ({exc})"
        ) from None
    finally:
        if fh is not None:
            fh.close()


def read_members(
    p: str, zf: zipfile.ZipFile, names: tuple[str, ...], *, max_bytes: int
) -> dict[str, Member]:
    """Headers of the members ``names`` (those present), checked, nothing inflated.

    Refuses duplicated or encrypted members, compression other than deflate,
    pickled (object) arrays, Fortran order, a header whose shape disagrees with
    the member's size, a total above ``max_bytes`` and a compression ratio of the
    members read, all together, above :data:`MAX_RATIO` (above 1 MiB).
    """
    seen: set[str] = set()
    for info in zf.infolist():
        if info.filename in seen:
            raise StorageFileError(f"{p!r} holds the member {info.filename!r} twice")
        seen.add(info.filename)
    out: dict[str, Member] = {}
    total = 0
    for name in names:
        if name + ".npy" not in seen:
            continue
        member = _read_header(p, zf, zf.getinfo(name + ".npy"), name)
        total += member.nbytes
        if total > max_bytes:
            raise StorageFileError(
                f"{p!r} holds more than `max_bytes` = {max_bytes} bytes of arrays "
                f"(at {name!r}: {total}); pass load_sliced(..., max_bytes=...) to "
                "read larger models"
            )
        out[name] = member
    _check_ratio(p, [m.info for m in out.values()])
    return out


def _check_ratio(p: str, infos: list[zipfile.ZipInfo]) -> None:
    """Refuse members that inflate more than :data:`MAX_RATIO` times, all together."""
    inflated = sum(i.file_size for i in infos)
    if inflated > _RATIO_FLOOR and inflated > MAX_RATIO * sum(
            max(i.compress_size, 1) for i in infos):
        worst = max(infos, key=lambda i: i.file_size / max(i.compress_size, 1))
        raise StorageFileError(
            f"{p!r}: its arrays would inflate {sum(i.compress_size for i in infos)} "
            f"bytes to {inflated} (ratio above {MAX_RATIO}:1; member "
            f"{worst.filename!r} would inflate {worst.compress_size} bytes to "
            f"{worst.file_size}): not a saved model, maybe a zip bomb"
        )


def _read_header(
    p: str, zf: zipfile.ZipFile, info: zipfile.ZipInfo, name: str
) -> Member:
    where = f"{p!r}: member {info.filename!r}"
    if info.flag_bits & 0x1:
        raise StorageFileError(f"{where} is encrypted")
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise StorageFileError(
            f"{where} uses compression method {info.compress_type}; vecslice "
            "reads stored or deflated members"
        )
    try:
        with zf.open(info) as fp:
            version = np.lib.format.read_magic(fp)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(fp)
            elif version in ((2, 0), (3, 0)):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(fp)
            else:  # pragma: no cover - read_magic accepts only these
                raise ValueError(f"unknown .npy version {version}")
            offset = fp.tell()
    except _READ_ERRORS as exc:
        raise StorageFileError(
            f"{where} is not a readable .npy array ({exc})"
        ) from None
    if dtype.hasobject:
        raise StorageFileError(
            f"{where} holds Python objects; vecslice never unpickles"
        )
    if fortran and len(shape) > 1:
        raise StorageFileError(f"{where} is in Fortran order; vecslice writes C order")
    nbytes = math.prod(shape) * dtype.itemsize
    if offset + nbytes != info.file_size:
        raise StorageFileError(
            f"{where} is damaged: its header promises {nbytes} bytes of data "
            f"(shape {shape}, dtype {dtype}) but the member holds "
            f"{info.file_size - offset}"
        )
    return Member(name, dtype, tuple(shape), nbytes, info)


def read_array(p: str, zf: zipfile.ZipFile, member: Member) -> NDArray[Any]:
    """Inflate ``member`` into a fresh array (checked size, zip CRC verified)."""
    out = np.empty(member.shape, dtype=member.dtype)
    view = memoryview(out.reshape(-1).view(np.uint8))
    try:
        with zf.open(member.info) as fp:
            fp.read(member.info.file_size - member.nbytes)  # the header, read before
            done = 0
            while done < member.nbytes:
                n = fp.readinto(view[done : done + _CHUNK])
                if not n:
                    raise EOFError(f"{member.nbytes - done} bytes missing")
                done += n
            if fp.read(1):  # also makes zipfile check the CRC
                raise ValueError("more data than its header says")
    except _READ_ERRORS as exc:
        raise StorageFileError(
            f"{p!r} is a damaged .npz archive (member {member.info.filename!r}: "
            f"{exc})"
        ) from None
    return out


def _resolve(p: str, where: str) -> str:
    """The file a write to ``p`` should replace: symbolic links are followed."""
    if not os.path.islink(p):
        return p
    try:
        os.stat(p)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise StorageFileError(f"{where}: it is a symbolic link loop") from None
    return os.path.realpath(p)


def check_target(path: str, where: str | None = None) -> str:
    """The file a write to ``path`` would replace, checked before writing anything.

    Symbolic links are followed (see :func:`write_atomic`). A missing file is fine
    (it is created); an existing one must be a regular file that is not read-only.

    Parameters
    ----------
    path : str
        The file to write.
    where : str, optional
        How messages name the file (e.g. ``"-o 'out.npz'"``); default
        ``"cannot write '<path>'"``.

    Returns
    -------
    str
        The path to replace: ``path`` itself, or the file its links lead to.

    Raises
    ------
    StorageFileError
        If ``path`` is a symbolic link loop, a directory, not a regular file (a
        FIFO, a device, a socket) or a read-only file: no write permission for
        the caller, or none at all (so even root does not replace it); or if it
        is missing and so is the directory it would be created in (also the
        directory a dangling symbolic link points into). The message names
        ``path`` and what it is.
    """
    where = where or f"cannot write {path!r}"
    target = _resolve(path, where)
    try:
        st = os.stat(target)
    except FileNotFoundError:  # created by the write: its directory must exist
        folder = os.path.dirname(target) or "."
        if not os.path.isdir(folder):
            link = (f"it is a symbolic link to {target!r}, whose" if target != path
                    else "the")
            raise StorageFileError(f"{where}: {link} directory {folder!r} does not "
                                   "exist") from None
        return target
    except OSError as exc:
        raise StorageFileError(f"{where}: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        what = file_kind(st.st_mode)
        raise StorageFileError(
            f"{where}: it is {what}, not a regular file"
            + ("; give a file name" if stat.S_ISDIR(st.st_mode)
               else "; vecslice replaces only regular files")
        )
    if not st.st_mode & 0o222 or not os.access(target, os.W_OK):
        why = "read-only" if not st.st_mode & 0o222 else "not writable by you"
        raise StorageFileError(
            f"{where}: it is {why} (mode {stat.S_IMODE(st.st_mode):04o}); make it "
            "writable or remove it to replace it"
        )
    return target


def _create_temp(target: str) -> tuple[int, str]:
    """A new hidden file beside ``target``: the umask applies, as for any new file."""
    head, tail = os.path.split(target)
    for _ in range(100):
        tmp = os.path.join(head, f".{tail}.{secrets.token_hex(4)}.tmp")
        try:
            return os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), tmp
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "no free temporary file name", target)


class _Terminated(BaseException):
    """SIGTERM arrived while a file was being written (internal)."""


@contextlib.contextmanager
def _sigterm_raises() -> Iterator[None]:
    """While active, SIGTERM raises :class:`_Terminated` instead of killing.

    Only where SIGTERM would kill the process at once (the default action) and
    only in the main thread (the only one Python signal handlers run in); the
    previous handler is restored on exit. Ignored or handled SIGTERM is left alone.
    """
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL):
        yield
        return
    fired = []

    def handler(signum: int, frame: Any) -> None:
        if not fired:  # once: a second SIGTERM must not interrupt the clean-up
            fired.append(signum)
            raise _Terminated

    signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def write_atomic(path: str, write: Callable[[IO[bytes]], None], *,
                 what: str = "a vecslice model") -> None:
    """Write ``path`` through ``write(file)``: all of it or nothing.

    The data goes to a hidden temporary file beside the target (beside the file
    a symbolic link points to), which is renamed over the target once complete.
    On any error, Ctrl-C or SIGTERM the temporary file is removed (SIGTERM then
    terminates the process as it would have). A new file gets the permissions
    ``0o666 & ~umask``; an overwritten file keeps its mode. What is not a regular
    file (a FIFO, a device such as ``/dev/null``, a socket) and a read-only file
    are refused, never replaced (see :func:`check_target`).

    Parameters
    ----------
    path : str
        The file to write.
    write : callable
        Writes the data to the binary file object it is given. An OSError it
        raises (disk full, file too large) becomes the StorageFileError below.
    what : str, default 'a vecslice model'
        What is written, for messages: ``cannot save <what> to '<path>': ...``.

    Raises
    ------
    StorageFileError
        If the file cannot be written, or ``path`` is not a regular file or is
        read-only; the message names ``path`` and ``what``.
    """
    where = f"cannot save {what} to {path!r}"
    tmp = None
    try:
        with _sigterm_raises():
            try:
                target = check_target(path, where)
                try:
                    mode: int | None = os.stat(target).st_mode & 0o777
                except FileNotFoundError:
                    mode = None
                fd, tmp = _create_temp(target)
                with os.fdopen(fd, "wb") as fh:
                    if mode is not None:
                        os.fchmod(fh.fileno(), mode)
                    write(fh)
                os.replace(tmp, target)
                tmp = None
            finally:
                if tmp is not None:
                    with contextlib.suppress(FileNotFoundError):
                        os.unlink(tmp)
    except _Terminated:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)  # even if restoring was cut
        signal.raise_signal(signal.SIGTERM)  # the default action: terminate
        raise StorageFileError(  # pragma: no cover - only if SIGTERM returns
            f"saving {path!r} was interrupted by SIGTERM; nothing was written"
        ) from None
    except OSError as exc:
        if isinstance(exc, StorageFileError):
            raise
        raise StorageFileError(f"{where}: {exc.strerror or exc}") from exc

"""Inflating one zip member from the archive's own file, checked as it inflates.

:mod:`zipfile` reads an entry by the sizes its header declares: a ratio check on
those sizes trusts the entry (one declaring its compressed size as large as its
inflated size passes any ratio), and data cut short ends in a bare ``EOFError``.
:func:`inflate` reads the member's bytes from the file itself, counts the
compressed bytes zlib actually consumes, and refuses, as it goes, output beyond
a ratio to them, beyond the declared size, or short of it, corrupt deflate data
and a CRC mismatch. Only stored and deflated members are read, the two methods
the Open Packaging Conventions (and so 3MF) allow.
"""

from __future__ import annotations

import struct
import zipfile
import zlib
from collections.abc import Iterator
from typing import BinaryIO

__all__ = ["InflationError", "MemberDataError", "inflate"]

_LOCAL = struct.Struct("<4s5H3L2H")  # local file header, before name and extra
_INPUT = 1 << 16  # compressed bytes read at a time


class MemberDataError(Exception):
    """A member's data is missing, truncated, corrupt or fails its checks.

    The message completes "part 'name' ...".
    """


class InflationError(Exception):
    """A member inflated more than the allowed ratio to the bytes it consumed."""

    def __init__(self, inflated: int, consumed: int) -> None:
        super().__init__(f"{inflated} bytes from {consumed} compressed bytes")
        self.inflated, self.consumed = inflated, consumed


def inflate(fh: BinaryIO, info: zipfile.ZipInfo, *, max_ratio: float,
            ratio_from: int, chunk: int) -> Iterator[bytes]:
    """The bytes of member ``info`` of the zip file ``fh``, ``chunk`` at a time.

    Every piece but the last is exactly ``chunk`` bytes. Raises
    :class:`InflationError` as soon as more than ``ratio_from`` bytes came out
    and they are more than ``max_ratio`` times the compressed bytes consumed,
    and :class:`MemberDataError` for a member without a local header, a method
    other than stored or deflated, data that inflates beyond the declared size
    or ends short of it, corrupt deflate data or a CRC mismatch. Memory stays
    near ``2 * chunk`` (zipfile's ``read(chunk)`` takes as much), whatever the
    entry declares.
    """
    fh.seek(info.header_offset)
    head = fh.read(_LOCAL.size)
    if len(head) < _LOCAL.size or head[:4] != b"PK\x03\x04":
        raise MemberDataError(f"has no local zip header at offset "
                              f"{info.header_offset:,}: the file is truncated or "
                              "corrupt")
    if info.compress_type == zipfile.ZIP_DEFLATED:
        dec = zlib.decompressobj(-zlib.MAX_WBITS)
    elif info.compress_type == zipfile.ZIP_STORED:
        dec = None
    else:
        raise MemberDataError(f"is compressed with zip method {info.compress_type}; "
                              "Open Packaging Conventions packages (3MF) are "
                              "stored or deflated")
    *_, n_name, n_extra = _LOCAL.unpack(head)
    fh.seek(info.header_offset + _LOCAL.size + n_name + n_extra)
    left = info.compress_size  # compressed bytes the entry declares, not read yet
    size = info.file_size
    consumed = out = crc = 0
    tail = b""  # compressed bytes read, not consumed yet
    pieces: list[bytes] = []  # inflated, not handed out yet: less than chunk
    filled = 0
    while True:
        if dec is None:
            piece = fh.read(min(chunk - filled, left))
            if not piece:
                break
            left -= len(piece)
            consumed += len(piece)
        else:
            if not tail:
                if dec.eof:
                    break
                if left:
                    tail = fh.read(min(_INPUT, left))
                    if not tail:  # the file ends inside the entry's data
                        break
                    left -= len(tail)
                # else every compressed byte is in, but output that max_length
                # held back (the rest of a match) may still be in zlib: asked with
                # no input, it gives that, or nothing (and the loop ends below)
            before = len(tail)
            try:
                piece = dec.decompress(tail, chunk - filled)
            except zlib.error as exc:
                raise MemberDataError(f"is corrupt after {out:,} bytes: {exc}"
                                      ) from None
            tail = dec.unconsumed_tail  # empty once the stream ended
            consumed += before - len(tail)
            if not piece:
                if len(tail) == before:  # no progress (zlib always makes some)
                    break
                continue
        out += len(piece)
        if out > size:
            raise MemberDataError(f"is longer than its zip entry says ({size:,} "
                                  "bytes)")
        if out > ratio_from and out > max_ratio * consumed:
            raise InflationError(out, consumed)
        crc = zlib.crc32(piece, crc)
        pieces.append(piece)
        filled += len(piece)
        if filled == chunk:  # one copy at most (none for a single piece)
            data = b"".join(pieces)
            pieces.clear()
            filled = 0
            yield data
    if out < size:
        raise MemberDataError(f"is truncated: its data ends after {out:,} of the "
                              f"{size:,} bytes its zip entry declares")
    if crc != info.CRC:
        raise MemberDataError(f"is corrupt: its CRC-32 is {crc:08x}, its zip entry "
                              f"says {info.CRC:08x}")
    if pieces:
        yield b"".join(pieces)

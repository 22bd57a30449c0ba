"""vecslice._zipread: one zip member inflated from the file, checked as it goes."""

import io
import zipfile

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from vecslice._zipread import InflationError, MemberDataError, inflate


def _archive(data, method):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", method) as z:
        z.writestr("first", b"x" * 100)
        z.writestr("m", data)
        z.writestr("last", b"y" * 100)
    buf.seek(0)
    return buf, zipfile.ZipFile(buf).getinfo("m")


def _read(data, method, chunk, **kw):
    fh, info = _archive(data, method)
    kw = {"max_ratio": 10**6, "ratio_from": 0, **kw}
    return list(inflate(fh, info, chunk=chunk, **kw))


@given(st.binary(max_size=5000), st.sampled_from([zipfile.ZIP_STORED,
                                                  zipfile.ZIP_DEFLATED]),
       st.integers(1, 700))
# a match whose copy outlasts the input: with all 5 compressed bytes consumed,
# zlib still holds 3 bytes of output that a 1-byte max_length left behind
@example(b"\x90" * 5, zipfile.ZIP_DEFLATED, 1)
def test_pieces_rebuild_the_member_in_chunks(data, method, chunk):
    pieces = _read(data, method, chunk)
    assert b"".join(pieces) == data
    assert all(len(p) == chunk for p in pieces[:-1])
    assert all(pieces)


def test_compressible_data_in_exact_chunks():
    data = b"<a/>" * 100_000 + np.random.default_rng(3).bytes(50_000)
    pieces = _read(data, zipfile.ZIP_DEFLATED, 1 << 16)
    assert [len(p) for p in pieces] == [1 << 16] * 6 + [len(data) - 6 * (1 << 16)]
    assert b"".join(pieces) == data


def test_ratio_is_checked_on_consumed_bytes():
    data = b" " * (4 << 20)
    fh, info = _archive(data, zipfile.ZIP_DEFLATED)
    it = inflate(fh, info, max_ratio=200, ratio_from=1 << 20, chunk=1 << 16)
    with pytest.raises(InflationError) as exc:
        for _ in it:
            pass
    assert exc.value.inflated > 1 << 20
    assert exc.value.inflated > 200 * exc.value.consumed
    assert exc.value.inflated <= (1 << 20) + (1 << 16)  # stopped at once
    # below ratio_from nothing is refused; stored data is never above 1
    assert len(b"".join(_read(data[: 1 << 20], zipfile.ZIP_DEFLATED, 1 << 16,
                              max_ratio=200, ratio_from=1 << 20))) == 1 << 20
    assert len(b"".join(_read(data, zipfile.ZIP_STORED, 1 << 16, max_ratio=1,
                              ratio_from=0))) == 4 << 20


def test_missing_local_header():
    fh, info = _archive(b"abc", zipfile.ZIP_STORED)
    info.header_offset += 1
    with pytest.raises(MemberDataError, match=r"^has no local zip header at offset "
                       r"[\d,]+: the file is truncated or corrupt$"):
        list(inflate(fh, info, max_ratio=200, ratio_from=0, chunk=10))

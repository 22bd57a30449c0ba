"""Tests of vecslice.errors: the hierarchy and printable messages."""

from __future__ import annotations

import os
import pickle
import warnings

import pytest

import vecslice as vs
from vecslice.errors import (
    InputValueError,
    MeshFileError,
    StorageFileError,
    VecsliceError,
    VecsliceWarning,
    printable,
)

LATIN1 = os.fsdecode(b"caf\xe9")  # 'caf\udce9': a file name that is not UTF-8


@pytest.mark.parametrize(("text", "shown"), [
    ("plain µm text", "plain µm text"),
    (LATIN1, r"caf\xe9"),
    ("a \ud800 b", r"a \ud800 b"),  # a surrogate no file name's byte gives
    ("", ""),
])
def test_printable(text, shown):
    assert printable(text) == shown
    assert printable(shown) == shown  # escaping twice changes nothing
    shown.encode("utf-8")  # strict: never raises


@pytest.mark.parametrize("cls", [MeshFileError, StorageFileError, InputValueError])
def test_a_message_quoting_a_file_name_that_is_not_utf8_can_be_printed(cls):
    """Session 24's open item: library messages held the name's surrogates, and
    printing them under a strict encoding raised UnicodeEncodeError."""
    err = cls(f"cannot open '{LATIN1}.stl'")
    assert str(err) == r"cannot open 'caf\xe9.stl'"
    str(err).encode("utf-8")
    assert isinstance(err, VecsliceError)
    assert pickle.loads(pickle.dumps(err)).args == err.args


def test_non_text_arguments_are_kept():
    err = InputValueError("x", 3)
    assert err.args == ("x", 3)


def test_loading_a_missing_file_with_a_latin1_name(tmp_path):
    with pytest.raises(MeshFileError) as info:
        vs.load_mesh(tmp_path / f"{LATIN1}.stl")
    assert r"caf\xe9.stl" in str(info.value)
    str(info.value).encode("utf-8")


def test_loading_a_corrupt_file_with_a_latin1_name(tmp_path):
    path = tmp_path / f"{LATIN1}.ply"
    path.write_bytes(b"not a ply")
    with pytest.raises(MeshFileError, match=r"caf\\xe9\.ply.* is not a PLY file"):
        vs.load_mesh(path)


def test_a_warning_quoting_a_latin1_name_can_be_printed():
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        warnings.warn(f"'{LATIN1}': odd", VecsliceWarning, stacklevel=1)
    assert str(seen[0].message) == r"'caf\xe9': odd"

"""C's %f as glibc's sscanf reads it (vecslice/_cfloat.py), checked against libc."""

import ctypes
import ctypes.util
import math
import platform
import struct
from decimal import Decimal
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from vecslice._cfloat import scan_float, strtof
from vecslice.cura_stl import _parse_ascii

if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
    pytest.skip("the expectations come from glibc (CuraEngine on x86-64 Linux)",
                allow_module_level=True)

LIBC = ctypes.CDLL(ctypes.util.find_library("c"))
LIBC.strtof.restype = ctypes.c_float
LIBC.strtof.argtypes = [ctypes.c_char_p, ctypes.POINTER(ctypes.c_char_p)]
LIBC.sscanf.restype = ctypes.c_int


def c_strtof(text: bytes) -> float:
    return LIBC.strtof(text, None)


def c_scan(text: bytes):
    """glibc's ``sscanf(text, "%f%n")``: (value, consumed) or None."""
    f, n = ctypes.c_float(), ctypes.c_int(-1)
    if LIBC.sscanf(text, b"%f%n", ctypes.byref(f), ctypes.byref(n)) != 1:
        return None
    return f.value, n.value


def c_vertex(line: bytes):
    """glibc's ``sscanf(line, " vertex %f %f %f") == 3``: the values or None."""
    f = (ctypes.c_float * 3)()
    if LIBC.sscanf(line, b" vertex %f %f %f", ctypes.byref(f, 0), ctypes.byref(f, 4),
                   ctypes.byref(f, 8)) != 3:
        return None
    return list(f)


def bits(x: float) -> int:
    """A float32 value's bits, every NaN the same (their sign does not matter)."""
    return -1 if math.isnan(x) else struct.unpack("<I", struct.pack("<f", x))[0]


def same(a, b) -> bool:
    if a is None or b is None:
        return a is b
    return bits(a[0]) == bits(b[0]) and a[1:] == b[1:]


# ------------------------------------------------------------------ one %f
@pytest.mark.parametrize("text", [
    b"1", b"1e", b"1.5e", b"1e+", b"1e-x", b"1e5e", b"1-2", b"123", b".", b"+",
    b"-.5", b".e5", b"1.e5", b"1..", b"1,5", b"1ee", b"1e+-1", b"0e", b"00x1",
    b"0x", b"0X", b"0xg", b"0x-1", b"-0xp", b"0xp1", b"0x.", b"0x..", b"-0x.",
    b"0x.p1", b"0X.P", b"0x.8p1", b"0x.e", b"0x1p", b"0x1.p", b"0x1p+", b"0x1pa",
    b"0x1p1.5", b"0x1e+5", b"0x1.2.3", b"0xAp0x", b"+0x1",
    b"0x1.fffffffffffffffffp0", b"0x1p99999", b"-0x1p-99999", b"1e99999",
    b"1e-99999", b"inf", b"-INF", b"infx", b"infi", b"infin", b"infinit",
    b"infinity", b"iNfInItYx", b"nan", b"-nan", b"nan(12)", b"na", b"nanx",
    b" \t\v\f1", b"", b"  ", b"-", b"e5",
])
def test_one_number_as_glibc_reads_it(text):
    assert same(scan_float(text), c_scan(text))


NUMBERISH = st.text(alphabet="0123456789.eEpPxXaAbBfF+-nNiItTyY( ", max_size=14)


@given(NUMBERISH)
@example("0x1p+")
@example("1.5e 2")
def test_any_text_is_read_as_glibc_reads_it(text):
    raw = text.encode()
    assert same(scan_float(raw), c_scan(raw))


@st.composite
def numbers(draw):
    """Well-formed and nearly well-formed numbers, decimal and hexadecimal."""
    sign = draw(st.sampled_from(["", "-", "+"]))
    digits = "0123456789abcdef" if draw(st.booleans()) else "0123456789"
    whole = draw(st.text(digits, max_size=30))
    frac = draw(st.text(digits, max_size=30))
    point = "." if frac or draw(st.booleans()) else ""
    mark = "p" if digits[-1] == "f" else "e"
    exp = draw(st.sampled_from(["", mark, mark + "-", mark + "+"]))
    if exp:
        exp += str(draw(st.integers(0, 60 if mark == "e" else 200)))
    head = "0x" if digits[-1] == "f" else ""
    return (sign + head + whole + point + frac + exp).encode()


@given(numbers())
def test_numbers_are_read_as_glibc_reads_them(text):
    assert same(scan_float(text), c_scan(text))


# ----------------------------------------------------------- exact rounding
def _decimal(q: Fraction) -> str:
    """The exact decimal expansion of a dyadic rational."""
    n, d = q.numerator, q.denominator
    k = d.bit_length() - 1  # d = 2**k
    return f"{Decimal(n * 5**k).scaleb(-k):f}"


FLOAT32 = st.floats(width=32, min_value=0, allow_infinity=False, allow_nan=False)


@st.composite
def near_midpoints(draw):
    """Decimal and hex texts at, just above and just below a float32 midpoint."""
    f = draw(FLOAT32)
    with np.errstate(over="ignore"):
        g = float(np.nextafter(np.float32(f), np.float32(np.inf)))
    hi = Fraction(g) if math.isfinite(g) else Fraction(2**128)
    mid = (Fraction(f) + hi) / 2
    how = draw(st.sampled_from(["exact", "above", "below", "hex above",
                                "hex below", "digits"]))
    sign = draw(st.sampled_from(["", "-"]))
    if how == "exact":
        return sign + _decimal(mid)
    if how in ("above", "below"):
        tiny = Fraction(1, 10 ** draw(st.integers(1, 80))) * mid
        tiny = Fraction(Decimal(tiny.numerator) / Decimal(tiny.denominator))
        q = mid + tiny if how == "above" else mid - tiny
        return sign + f"{Decimal(q.numerator) / Decimal(q.denominator):.60e}"
    if how.startswith("hex"):
        text = float(mid).hex()  # a float32 midpoint is a double
        pad = "0" * draw(st.integers(0, 20))
        if how == "hex above":
            mant, _, exp = text.partition("p")
            return f"{sign}{mant}{pad}1p{exp}"
        below = float(mid) - float(mid) * 2.0**-52
        return sign + below.hex()
    n = draw(st.integers(1, 25))  # the midpoint cut to n significant digits
    return sign + f"{Decimal(mid.numerator) / Decimal(mid.denominator):.{n}e}"


@given(near_midpoints())
@example("1.0000000596046448936")  # 1 + 2**-24 + 4e-20: up, not to even
@example("1.000000059604644775390625")  # 1 + 2**-24 exactly: to even
@example("7.00649232162408535461864791644958065640130970938257885878534141944895541"
         "342930300743319094181060791015625e-46")  # 2**-150, between 0 and 2**-149
@example("3.40282356779733661637539395458142568448e38")  # FLT_MAX + half a step
@example("3.4028235677973366e38")  # a hair below it: FLT_MAX
def test_rounding_to_float32_is_exact(text):
    raw = text.encode()
    assert bits(float(strtof([raw])[0])) == bits(c_strtof(raw))


@given(st.lists(st.floats(width=32, allow_nan=False, allow_infinity=False),
                min_size=1, max_size=20))
def test_nine_digits_give_the_float32_back(values):
    # the common case, read in bulk: every float32 written with 9 digits
    got = strtof([f"{v:.8e}".encode() for v in values])
    assert got.tolist() == np.array(values, dtype=np.float32).tolist()


def test_long_tokens_are_exact():
    # more digits than Python converts to int (4300), near a midpoint
    mid = _decimal(Fraction(1) + Fraction(1, 2**24))
    for text in (mid + "0" * 5000 + "1", mid[:-1] + "4" + "9" * 5000,
                 "0x1.000001" + "0" * 5000 + "1p0", "0x1.000001p" + "0" * 5000):
        raw = text.encode()
        assert bits(float(strtof([raw])[0])) == bits(c_strtof(raw))


# ---------------------------------------------------------- whole vertex lines
def _vertices(line: bytes):
    v = _parse_ascii(Path("x.stl"), b"solid x\n" + line + b"\n")
    return None if v.shape[0] == 0 else v[0].tolist()


@pytest.mark.parametrize("line", [
    b"vertex 1 2 3", b"  vertex 1-2 3", b"vertex 123 4", b"vertex 1 2 3e+x",
    b"vertex1 2 3", b"vertex 1.5e 2 3", b"Vertex 1 2 3", b"vertex 1 2 3 4",
    b"vertex 1 2 0x", b"vertex 1e5.3 2", b"vertex 0x1p 0x. -0x.8p1",
    b"vertex 1 2 infin", b"vertex nan(1) 2 3", b"vertex 1 2 3\x00", b"vertex 1\x00 2 3",
    b"\vvertex\t1\f2 3", b"vertex +-1 2 3", b"vertex 1.2.3",
])
def test_vertex_lines_as_glibc_reads_them(line):
    got, want = _vertices(line), c_vertex(line)
    assert (got is None) == (want is None)
    if got is not None:
        assert [bits(x) for x in got] == [bits(x) for x in want]


@given(st.lists(NUMBERISH | numbers().map(bytes.decode), min_size=1, max_size=4),
       st.lists(st.sampled_from(["", " ", "\t", "  "]), min_size=5, max_size=5))
def test_any_vertex_line_is_read_as_glibc_reads_it(tokens, gaps):
    line = (gaps[0] + "vertex" + "".join(g + t for g, t in zip(gaps[1:], tokens,
                                                               strict=False)))
    raw = line.encode()
    got, want = _vertices(raw), c_vertex(raw)
    assert (got is None) == (want is None)
    if got is not None:
        assert [bits(x) for x in got] == [bits(x) for x in want]

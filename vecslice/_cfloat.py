r"""C's ``%f`` as glibc's ``sscanf`` reads it, to float32 (for ``compat="cura"``).

CuraEngine reads an ASCII STL line with ``sscanf(line, " vertex %f %f %f")``.
What one ``%f`` takes, measured with glibc 2.36 (x86-64 Linux, the "C" locale)
and checked against it by ``tests/vecslice/test_cfloat.py``:

* whitespace is skipped, then an optional sign;
* ``nan`` (any case; a following ``(...)`` is left unread), or ``inf`` or
  ``infinity`` (any case; ``inf`` followed by an incomplete ``inity`` fails);
* ``0x`` or ``0X``: hexadecimal digits with at most one point, and after at
  least one digit, ``p`` with an optional sign and decimal digits; ``0x`` with
  neither a digit nor a point after it fails (``0x.`` reads as 0);
* otherwise decimal digits with at most one point (at least one digit), then
  ``e`` with an optional sign and digits;
* each part is taken greedily: an exponent marker (and its sign) is consumed
  even when no digit follows it, and the number is then what ``strtof`` reads
  of the consumed text, its longest valid prefix: ``1e`` and ``1.5e+`` read as 1
  and 1.5 and are consumed whole, so ``vertex 1.5e 2 3`` is a vertex, while
  ``vertex 123 4`` is not (``123`` is one number, and no third follows). A sign
  starts a new number: ``1-2`` is two numbers, 1 and -2.

The value is the float32 nearest to the exact value of that text, ties to even
(``strtof``), overflowing to infinity. The nearest double is found first (it is
correctly rounded); rounding it to float32 can differ from one rounding only
when the double lies exactly halfway between two float32 values, and those are
decided from the exact value of the text (:class:`fractions.Fraction`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from decimal import Decimal
from fractions import Fraction

import numpy as np
from numpy.typing import NDArray

__all__ = ["SCANF_FLOAT", "scan_float", "strtof"]

_HEX = rb"[0-9a-fA-F]"
SCANF_FLOAT = (
    rb"[+-]?(?:"
    rb"[nN][aA][nN]"
    rb"|[iI][nN][fF](?:[iI][nN][iI][tT][yY]|(?![iI]))"
    rb"|0[xX](?:" + _HEX + rb"+\.?" + _HEX + rb"*(?:[pP][+-]?[0-9]*)?"
    rb"|\.(?:" + _HEX + rb"+(?:[pP][+-]?[0-9]*)?)?)"
    rb"|(?!0[xX])(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]*)?"
    rb")"
)
"""What one ``%f`` consumes, after the whitespace (a regular expression).

Its first match is the greedy one (nothing follows a part that could make it
give characters back), so as an atomic group, ``(?=(?P<n>...))(?P=n)``, it never
splits a number the way a backtracking match could (``123`` into ``12`` and
``3``).
"""

_ONE = re.compile(rb"[ \t\n\v\f\r]*(?=(?P<n>" + SCANF_FLOAT + rb"))(?P=n)")
# an exponent marker without digits (in hexadecimal, e is a digit)
_DANGLING = re.compile(rb"[eE][+-]?\Z")
_DANGLING_HEX = re.compile(rb"[pP][+-]?\Z")
_HEX_DIGIT = re.compile(_HEX)


def scan_float(text: bytes) -> tuple[float, int] | None:
    """One ``%f`` at the start of ``text``: ``(value, bytes consumed)`` or None.

    The value is a float32 value (as a Python float); None is a matching failure.

    Examples
    --------
    >>> scan_float(b" 1.5e+x"), scan_float(b"0x.p1"), scan_float(b"infin")
    ((1.5, 6), (0.0, 3), None)
    """
    m = _ONE.match(text)
    if m is None:
        return None
    return float(strtof([m.group("n")])[0]), m.end()


def _readable(token: bytes) -> bytes:
    """The longest prefix of a consumed token that ``strtof`` reads."""
    body = token.lstrip(b"+-")
    if body[:2] not in (b"0x", b"0X"):
        return _DANGLING.sub(b"", token)
    if not _HEX_DIGIT.search(body, 2):
        return token[: len(token) - len(body)] + b"0"  # "0x." reads as "0"
    return _DANGLING_HEX.sub(b"", token)


def _double(token: bytes) -> float:
    """The double nearest to a readable token (hex, inf and nan too)."""
    body = token.lstrip(b"+-")
    if body[:2] not in (b"0x", b"0X"):
        return float(token)
    try:
        return float.fromhex(token.decode("ascii"))
    except OverflowError:
        return float("-inf") if token.startswith(b"-") else float("inf")


def _exact(token: bytes) -> Fraction:
    """The exact value of a readable, finite token."""
    body = token.lstrip(b"+-").lower()
    sign = -1 if token.startswith(b"-") else 1
    if not body.startswith(b"0x"):
        # through Decimal: Fraction(str) refuses more than 4300 digits
        return sign * Fraction(Decimal(body.decode("ascii")))
    mantissa, _, exponent = body[2:].partition(b"p")
    whole, _, frac = mantissa.partition(b".")
    m = int(whole + frac, 16)  # base 16: no limit on the digits
    digits = exponent.lstrip(b"+-").lstrip(b"0") or b"0"
    e = (-1 if exponent.startswith(b"-") else 1) * int(digits) - 4 * len(frac)
    return sign * (Fraction(m << e) if e >= 0 else Fraction(m, 1 << -e))


def strtof(tokens: Sequence[bytes]) -> NDArray[np.float32]:
    """``strtof`` of each token that :data:`SCANF_FLOAT` consumed, as float32.

    Examples
    --------
    A decimal a hair above the midpoint 1 + 2**-24 between two float32 values:
    rounded once it goes up; through the double (which is that midpoint) it
    would go to even.

    >>> strtof([b"1.0000000596046448936", b"1e", b"-0x1.8p1", b"1e39"]).tolist()
    [1.0000001192092896, 1.0, -3.0, inf]
    """
    if not tokens:
        return np.empty(0, dtype=np.float32)
    try:
        d = np.fromiter(map(float, tokens), dtype=np.float64, count=len(tokens))
    except ValueError:  # hex, a dangling exponent: rare
        tokens = [_readable(t) for t in tokens]
        d = np.fromiter(map(_double, tokens), dtype=np.float64, count=len(tokens))
    with np.errstate(over="ignore"):
        f = d.astype(np.float32)
    a = np.abs(d)
    fine = np.isfinite(a) & (a > 0) & (a < 2.0**128)
    _, e = np.frexp(np.where(fine, a, 1.0))
    # in units of half a float32 step (2**-150 below 2**-126): a midpoint between
    # two float32 values is an odd integer
    t = np.ldexp(np.where(fine, a, 0.0), 25 - np.maximum(e, -125))
    for i in np.flatnonzero(fine & (t == np.floor(t)) & (np.fmod(t, 2.0) == 1.0)):
        exact = _exact(_readable(tokens[i]))
        mid = Fraction(float(d[i]))
        if exact != mid and (f[i] > d[i]) != (exact > mid):
            up = np.float32(np.inf) if exact > mid else np.float32(-np.inf)
            f[i] = np.nextafter(f[i], up)
    return f

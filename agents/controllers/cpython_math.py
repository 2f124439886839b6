"""CPython's own float functions, compiled, bit for bit: the control laws were written (and
their reference results recorded) in Python, and their compiled form must give the same bits.

Most of ``math`` calls the C library, as numba does: ``sin``, ``cos``, ``atan2`` and ``sqrt``
agree as they are. These do not:

- ``math.dist`` and ``math.hypot`` run CPython's own ``vector_norm`` (lossless scaling,
  Veltkamp-Dekker splitting, compensated summation and a corrected square root), which
  differs from the C library's ``hypot`` in the last bit for about one pair in 200;
  :func:`distance` is CPython 3.11's algorithm for two coordinates (3.12 computes the same
  norm with ``fma``, also almost always correctly rounded);
- ``min`` and ``max`` return their first argument on a tie (``max(-0.0, 0.0)`` is ``-0.0``);
  :func:`first_min` and :func:`first_max` do too;
- ``math.remainder`` is exact (the IEEE remainder is always representable), so any exact
  method agrees: :func:`ieee_remainder` follows CPython's.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: 2**27 + 1, Veltkamp-Dekker's splitter for doubles: hi holds the top 26 bits of x.
_SPLITTER = 134217729.0


@njit(cache=True, inline="always")
def _accumulate(csum: float, frac: float, x: float) -> tuple[float, float]:
    """Add ``x`` to the running sum ``csum`` (|csum| >= |x|), keeping what rounding lost in
    ``frac`` (Neumaier's compensated summation)."""
    total = csum + x
    return total, frac + ((csum - total) + x)


@njit(cache=True)
def distance(x: float, y: float) -> float:
    """``math.hypot(x, y)`` (and ``math.dist(p, q)`` of the differences) as CPython 3.11
    computes it, bit for bit, NaN and infinities included."""
    x, y = abs(x), abs(y)
    largest = 0.0
    if x > largest:
        largest = x
    if y > largest:
        largest = y
    if math.isinf(largest):
        return largest
    if math.isnan(x) or math.isnan(y):
        return math.nan
    if largest == 0.0:
        return largest
    _, exponent = math.frexp(largest)
    csum, frac1, frac2, frac3 = 1.0, 0.0, 0.0, 0.0
    if exponent < -1023:
        # Scaling by 2**-exponent would overflow: divide by the largest instead.
        for value in (x, y):
            scaled = value / largest
            csum, frac1 = _accumulate(csum, frac1, scaled * scaled)
        return largest * math.sqrt(csum - 1.0 + frac1)
    scale = math.ldexp(1.0, -exponent)
    for value in (x, y):
        scaled = value * scale  # lossless: a power of two
        t = scaled * _SPLITTER
        hi = t - (t - scaled)
        lo = scaled - hi
        csum, frac1 = _accumulate(csum, frac1, hi * hi)
        csum, frac2 = _accumulate(csum, frac2, 2.0 * hi * lo)
        frac3 += lo * lo
    root = math.sqrt(csum - 1.0 + (frac1 + frac2 + frac3))
    t = root * _SPLITTER
    hi = t - (t - root)
    lo = root - hi
    csum, frac1 = _accumulate(csum, frac1, -hi * hi)
    csum, frac2 = _accumulate(csum, frac2, -2.0 * hi * lo)
    csum, frac3 = _accumulate(csum, frac3, -lo * lo)
    correction = csum - 1.0 + (frac1 + frac2 + frac3)
    return (root + correction / (2.0 * root)) / scale


@njit(cache=True, inline="always")
def first_max(a: float, b: float) -> float:
    """Python's ``max(a, b)``: ``b`` only when it is greater."""
    return b if b > a else a


@njit(cache=True, inline="always")
def first_min(a: float, b: float) -> float:
    """Python's ``min(a, b)``: ``b`` only when it is smaller."""
    return b if b < a else a


@njit(cache=True)
def ieee_remainder(x: float, y: float) -> float:
    """``math.remainder(x, y)`` for finite x and finite non-zero y: x minus the multiple of y
    nearest to it (the even one on a tie), exact."""
    absolute_x, absolute_y = abs(x), abs(y)
    modulo = np.fmod(absolute_x, absolute_y)
    complement = absolute_y - modulo
    if modulo < complement:
        result = modulo
    elif modulo > complement:
        result = -complement
    else:  # halfway between two multiples: take the even one
        result = modulo - 2.0 * np.fmod(0.5 * (absolute_x - modulo), absolute_y)
    return math.copysign(1.0, x) * result

"""CPython's float functions, compiled: the same bits as the interpreter's."""

import math
import sys
from fractions import Fraction

import numpy as np
import pytest
from numba import njit

from agents.controllers.cpython_math import distance, first_max, first_min, ieee_remainder


@njit
def _distances(x, y, out):
    for index in range(x.shape[0]):
        out[index] = distance(x[index], y[index])


@njit
def _remainders(x, y, out):
    for index in range(x.shape[0]):
        out[index] = ieee_remainder(x[index], y[index])


def random_pairs(count=200_000):
    rng = np.random.default_rng(7)
    pairs = []
    for scale in (1e-300, 1e-8, 1.0, 37.0, 1e300):
        x = rng.normal(size=count) * scale
        y = rng.normal(size=count) * scale * rng.uniform(0.0, 2.0, count)
        x[:100], y[100:200] = 0.0, 0.0
        pairs.append((x, y))
    return pairs


@pytest.mark.skipif(
    sys.version_info[:2] != (3, 11),
    reason="distance() is CPython 3.11's math.hypot; other versions compute it otherwise",
)
def test_distance_is_cpythons_hypot_bit_for_bit():
    for x, y in random_pairs():
        out = np.empty_like(x)
        _distances(x, y, out)
        expected = np.array([math.hypot(a, b) for a, b in zip(x.tolist(), y.tolist(), strict=True)])
        np.testing.assert_array_equal(out.view(np.int64), expected.view(np.int64))


def test_distance_is_correctly_rounded_almost_always():
    # Against the exact square root of the exact sum of squares, rounded once.
    x, y = random_pairs(2000)[2]
    out = np.empty_like(x)
    _distances(x, y, out)
    exact_ulps = []
    for a, b, got in zip(x.tolist(), y.tolist(), out.tolist(), strict=True):
        square = Fraction(a) ** 2 + Fraction(b) ** 2
        below, above = math.nextafter(got, 0.0), math.nextafter(got, math.inf)
        # got is correctly rounded when the square lies between the squared midpoints.
        low = (Fraction(below) + Fraction(got)) / 2
        high = (Fraction(got) + Fraction(above)) / 2
        exact_ulps.append(low**2 <= square <= high**2)
    assert np.mean(exact_ulps) > 0.999


def test_distance_special_values():
    for a, b, expected in [
        (math.inf, math.nan, math.inf),
        (math.nan, -math.inf, math.inf),
        (0.0, -0.0, 0.0),
        (3.0, -4.0, 5.0),
        (5e-324, 5e-324, 5e-324 * math.sqrt(2)),
    ]:
        assert distance(a, b) == expected
    assert math.isnan(distance(math.nan, 1.0))


def test_the_remainder_is_math_remainder_bit_for_bit():
    rng = np.random.default_rng(3)
    x = rng.normal(size=100_000) * 20.0
    y = rng.choice([2.0 * math.pi, 1.0, 0.5, 3.0, 1e-3], size=100_000)
    x[:200] = y[:200] * (np.arange(200) - 99.5)  # halfway cases: the even multiple wins
    out = np.empty_like(x)
    _remainders(x, y, out)
    expected = np.array([math.remainder(a, b) for a, b in zip(x.tolist(), y.tolist(), strict=True)])
    np.testing.assert_array_equal(out.view(np.int64), expected.view(np.int64))


def test_min_and_max_keep_the_first_of_equal_arguments_as_python_does():
    for a, b in [(-0.0, 0.0), (0.0, -0.0), (1.0, 2.0), (2.0, 1.0)]:
        assert math.copysign(1.0, first_max(a, b)) == math.copysign(1.0, max(a, b))
        assert math.copysign(1.0, first_min(a, b)) == math.copysign(1.0, min(a, b))
        assert (first_max(a, b), first_min(a, b)) == (max(a, b), min(a, b))

"""mobile_envs._kernels.exact_math: the C library's bits, elementwise, whatever the CPU.

numpy's float64 transcendental ufuncs take SIMD paths on AVX-512 CPUs with other last bits;
the helpers loop over ``math.*`` in compiled code instead. Here each helper is compared bit
for bit with the scalar function it stands for: Python's ``math`` for sin, cos, expm1 and
atan2 (which call the C library for finite arguments) and the C library's own ``hypot``
through ctypes (Python's ``math.hypot`` has its own algorithm since 3.8). Non-finite
arguments give what the C function gives: nan where ``math.sin`` and ``math.cos`` raise.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math

import numba
import numpy as np
import pytest

from mobile_envs._kernels import exact_math
from mobile_envs.tracks.figure_eight import figure_eight_path
from mobile_envs.world.paths import arc_straight_path, random_path, random_paths

_LIBM = ctypes.CDLL(ctypes.util.find_library("m"))
_LIBM.hypot.restype = ctypes.c_double
_LIBM.hypot.argtypes = [ctypes.c_double, ctypes.c_double]

#: Values where implementations tend to part: zeros, multiples of pi, huge arguments
#: (argument reduction), subnormals, the largest finite numbers.
EDGES = np.array(
    [
        0.0,
        -0.0,
        math.pi,
        -math.pi,
        math.pi / 2,
        -math.pi / 2,
        2 * math.pi,
        1e-310,
        -1e-310,
        5e-324,
        1e-8,
        1e22,
        -1e22,
        1e300,
        1.7976931348623157e308,
        -1.7976931348623157e308,
        355.0,
        103079215104.0,
    ]
)
NON_FINITE = np.array([math.inf, -math.inf, math.nan])


def _bits(values) -> np.ndarray:
    return np.asarray(values, dtype=np.float64).view(np.int64)


def _samples() -> np.ndarray:
    rng = np.random.default_rng(20240611)
    n = 20_000
    return np.concatenate(
        [
            EDGES,
            rng.uniform(-4 * math.pi, 4 * math.pi, n),
            rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-310, 308, n),
            rng.integers(-(10**6), 10**6, n) * (math.pi / 4),
        ]
    )


def _c_or_nan(function, *args: float) -> float:
    """``math.function(*args)``, or nan where Python raises for a non-finite argument (the C
    function returns nan there)."""
    try:
        return function(*args)
    except ValueError:
        return math.nan


def test_numba_uses_no_vector_math_library():
    # With SVML (Intel's icc_rt installed) numba would vectorize math.sin & co. with other
    # last bits, here and in every kernel of the package.
    assert not numba.config.USING_SVML


@pytest.mark.parametrize(
    ("helper", "scalar"),
    [(exact_math.sin, math.sin), (exact_math.cos, math.cos), (exact_math.expm1, math.expm1)],
)
def test_unary_helpers_are_the_scalar_functions_bit_for_bit(helper, scalar):
    x = _samples()
    if scalar is math.expm1:
        x = x[np.abs(x) < 700.0]  # math.expm1 raises OverflowError above ~709.78
    expected = [scalar(value) for value in x.tolist()]
    assert np.array_equal(_bits(helper(x)), _bits(expected))


@pytest.mark.parametrize(
    ("helper", "scalar"),
    [(exact_math.sin, math.sin), (exact_math.cos, math.cos), (exact_math.expm1, math.expm1)],
)
def test_unary_helpers_on_non_finite_values_give_what_c_gives(helper, scalar):
    got = helper(NON_FINITE)
    expected = [_c_or_nan(scalar, value) for value in NON_FINITE.tolist()]
    np.testing.assert_array_equal(got, expected)  # nan equals nan here
    assert math.isnan(exact_math.sin(math.inf))  # no exception, no warning
    assert math.isnan(exact_math.cos(-math.inf))
    assert exact_math.expm1(math.inf) == math.inf
    assert exact_math.expm1(-math.inf) == -1.0


def _pairs() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    n = 20_000
    y = np.concatenate([rng.normal(size=n) * 10.0 ** rng.uniform(-300, 300, n), EDGES])
    x = np.concatenate([rng.normal(size=n) * 10.0 ** rng.uniform(-300, 300, n), EDGES[::-1]])
    y[:50], x[50:100] = 0.0, -0.0  # axes, signed zeros
    edges = np.array([0.0, -0.0, 1.0, -1.0, math.inf, -math.inf, math.nan])
    grid_y, grid_x = np.meshgrid(edges, edges)
    return np.concatenate([y, grid_y.ravel()]), np.concatenate([x, grid_x.ravel()])


def test_arctan2_is_math_atan2_bit_for_bit():
    y, x = _pairs()
    expected = [math.atan2(a, b) for a, b in zip(y.tolist(), x.tolist(), strict=True)]
    assert np.array_equal(_bits(exact_math.arctan2(y, x)), _bits(expected))


def test_hypot_is_the_c_librarys_hypot_bit_for_bit():
    y, x = _pairs()
    expected = [_LIBM.hypot(a, b) for a, b in zip(x.tolist(), y.tolist(), strict=True)]
    assert np.array_equal(_bits(exact_math.hypot(x, y)), _bits(expected))


def test_shapes_broadcasting_and_scalars_follow_numpy():
    grid = np.linspace(-3.0, 3.0, 24).reshape(2, 3, 4)
    strided = grid[:, 1, ::2]  # not contiguous
    for helper, ufunc in [(exact_math.sin, np.sin), (exact_math.cos, np.cos)]:
        for values in (grid, strided, np.empty((0, 3))):
            assert helper(values).shape == ufunc(values).shape
            assert helper(values).dtype == np.float64
        assert isinstance(helper(0.5), np.float64)
        assert isinstance(helper(np.array(0.5)), np.float64)
    column = np.arange(3.0)[:, np.newaxis]
    assert exact_math.arctan2(column, np.arange(1.0, 5.0)).shape == (3, 4)
    assert exact_math.hypot(1.0, np.arange(4.0)).shape == (4,)
    assert exact_math.arctan2(1.0, 1.0) == math.atan2(1.0, 1.0)
    before = grid.copy()
    exact_math.sin(grid)
    assert np.array_equal(grid, before)  # inputs untouched


def _assert_headings_are_atan2_of_deltas(path) -> None:
    delta = np.diff(path.points, axis=0)
    expected = [math.atan2(dy, dx) for dx, dy in delta.tolist()]
    assert np.array_equal(_bits(path.segment_headings), _bits(expected))


def test_path_headings_are_math_atan2_of_their_deltas_bit_for_bit():
    paths = [
        arc_straight_path(),
        figure_eight_path(),
        *(random_path(np.random.default_rng(seed)) for seed in range(5)),
        *random_paths([np.random.default_rng(seed) for seed in range(100, 110)]),
    ]
    for path in paths:
        _assert_headings_are_atan2_of_deltas(path)

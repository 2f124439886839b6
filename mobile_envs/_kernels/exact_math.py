"""Elementwise transcendental functions of float64 arrays with the same bits on every CPU.

numpy's float64 ``sin``, ``cos``, ``arctan2``, ``expm1`` (and others) dispatch at run time to
SIMD implementations where the CPU has them (AVX-512: numpy's own or SVML-derived loops),
whose results differ in the last bit from the C library's scalar functions for some inputs.
Anything built from them (path headings, the figure eight's points, sensor geometry, the
plant's lag factor) would then depend on the machine, and "same seed, same bits" would hold
only on one kind of CPU. Without AVX-512, numpy's results equal the C library's.

The functions here loop over the elements in numba-compiled code calling ``math.*``, which
numba compiles to calls of the C library's scalar functions (no fast-math; no SVML, which
numba uses only when Intel's ``icc_rt`` is installed: ``numba.config.USING_SVML`` is then
true and the tests of this module fail). The bits are therefore those of the C library's
scalar functions (glibc's libm on Linux), the same on every x86-64 machine with the same C
library, and equal to Python's ``math.*`` for finite arguments.

Inputs are converted to float64 (every call site passes float64); outputs have the
(broadcast) shape of the inputs, and a 0-d result is returned as a numpy float64 scalar, as
numpy's ufuncs do. Non-finite arguments give what the C function gives, without raising and
without a warning: ``sin(inf)`` and ``cos(inf)`` are nan (where ``math.sin`` raises), nan
gives nan, ``arctan2`` and ``hypot`` follow C99 (``hypot(inf, nan)`` is inf).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

__all__ = ["arctan2", "cos", "expm1", "hypot", "sin"]


@njit(cache=True)
def _sin(x: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    for i in range(len(x)):
        out[i] = math.sin(x[i])


@njit(cache=True)
def _cos(x: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    for i in range(len(x)):
        out[i] = math.cos(x[i])


@njit(cache=True)
def _expm1(x: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    for i in range(len(x)):
        out[i] = math.expm1(x[i])


@njit(cache=True)
def _arctan2(y: NDArray[np.float64], x: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    for i in range(len(y)):
        out[i] = math.atan2(y[i], x[i])


@njit(cache=True)
def _hypot(x: NDArray[np.float64], y: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    for i in range(len(x)):
        out[i] = math.hypot(x[i], y[i])


def _result(out: NDArray[np.float64]) -> Any:
    return out[()] if out.ndim == 0 else out


def _unary(kernel: Any, x: ArrayLike) -> Any:
    values = np.asarray(x, dtype=np.float64, order="C")  # not ascontiguousarray: keeps 0-d
    out = np.empty(values.shape)
    kernel(values.reshape(-1), out.reshape(-1))
    return _result(out)


def _binary(kernel: Any, a: ArrayLike, b: ArrayLike) -> Any:
    first, second = np.broadcast_arrays(np.asarray(a, np.float64), np.asarray(b, np.float64))
    first, second = np.asarray(first, order="C"), np.asarray(second, order="C")
    out = np.empty(first.shape)
    kernel(first.reshape(-1), second.reshape(-1), out.reshape(-1))
    return _result(out)


def sin(x: ArrayLike) -> Any:
    """``np.sin`` with the C library's bits: ``math.sin`` of each element."""
    return _unary(_sin, x)


def cos(x: ArrayLike) -> Any:
    """``np.cos`` with the C library's bits: ``math.cos`` of each element."""
    return _unary(_cos, x)


def expm1(x: ArrayLike) -> Any:
    """``np.expm1`` with the C library's bits: ``math.expm1`` of each element."""
    return _unary(_expm1, x)


def arctan2(y: ArrayLike, x: ArrayLike) -> Any:
    """``np.arctan2`` with the C library's bits: ``math.atan2`` of each (broadcast) pair."""
    return _binary(_arctan2, y, x)


def hypot(x: ArrayLike, y: ArrayLike) -> Any:
    """``np.hypot`` with the C library's bits: ``math.hypot`` of each (broadcast) pair."""
    return _binary(_hypot, x, y)

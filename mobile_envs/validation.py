"""Checks of user-given settings, written once for the whole package.

Each takes the setting's name and its value and returns the value in the type the code uses,
or raises ``ValueError`` naming the setting and what is wrong with it. A bool is never a
number here (``True`` is an ``int`` to Python, never a speed to a robot), and no value gets
through that would make a later computation overflow to inf or NaN.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, TypeGuard

import numpy as np
from numpy.typing import NDArray

#: Python and numpy reals; bools are refused where a number is meant.
REAL_TYPES = (int, float, np.integer, np.floating)
#: Step counters are int64: no count beyond this can be counted to.
MAX_COUNT = int(np.iinfo(np.int64).max)


def is_list(value: Any) -> TypeGuard[Sequence[Any] | NDArray[Any]]:
    """Whether ``value`` is a list, a tuple or a 1-d array; a string, a number or an array of
    another dimension (a 0-d one included) is not."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        return False
    return not isinstance(value, np.ndarray) or value.ndim == 1


def as_real(name: str, value: Any) -> float:
    """``value`` as a finite float: Python or numpy reals, never a bool (or numpy bool).

    :raises ValueError: naming ``name`` for any other type, NaN or inf
    """
    if isinstance(value, bool) or not isinstance(value, REAL_TYPES):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    try:
        number = float(value)
    except OverflowError:  # a Python int beyond float64
        number = math.inf
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return number


def as_positive(
    name: str, value: Any, maximum: float = math.inf, unit: str = "", why: str = ""
) -> float:
    """``value`` as a float in (0, maximum]; see :func:`as_real`.

    :param unit: printed after ``maximum`` in the message (``" m"``)
    :param why: the reason for ``maximum``, printed in parentheses after it
    """
    number = as_real(name, value)
    if number <= 0.0:
        raise ValueError(f"{name} must be a positive number, got {value!r}")
    _check_maximum(name, value, number, maximum, unit, why)
    return number


def as_non_negative(
    name: str, value: Any, maximum: float = math.inf, unit: str = "", why: str = ""
) -> float:
    """``value`` as a float in [0, maximum]; see :func:`as_positive`."""
    number = as_real(name, value)
    if number < 0.0:
        raise ValueError(f"{name} must be a number >= 0, got {value!r}")
    _check_maximum(name, value, number, maximum, unit, why)
    return number + 0.0  # -0.0 as 0.0: numpy refuses a uniform range from 0.0 to -0.0


def _check_maximum(
    name: str, value: Any, number: float, maximum: float, unit: str, why: str
) -> None:
    if number > maximum:
        reason = f" ({why})" if why else ""
        raise ValueError(f"{name} must be at most {maximum:g}{unit}{reason}, got {value!r}")


def as_count(name: str, value: Any, maximum: int = MAX_COUNT, minimum: int = 1) -> int:
    """``value`` as an int in [minimum, maximum]: Python or numpy integers, or floats with an
    integer value (``25.0``); never a bool.

    :raises ValueError: naming ``name`` otherwise
    """
    kind = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
    if isinstance(value, bool) or not isinstance(value, REAL_TYPES):
        raise ValueError(f"{name} must be {kind}, got {value!r}")
    if isinstance(value, (float, np.floating)) and not (
        math.isfinite(value) and float(value).is_integer()
    ):
        raise ValueError(f"{name} must be {kind}, got {value!r}")
    count = int(value)
    if count < minimum:
        raise ValueError(f"{name} must be {kind}, got {value!r}")
    if count > maximum:
        raise ValueError(f"{name} must be at most {maximum}, got {value!r}")
    return count


def as_flag(name: str, value: Any) -> bool:
    """``value`` as a bool, if it is one (a numpy bool too; never a number).

    :raises ValueError: naming ``name`` otherwise
    """
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def as_optional_count(name: str, value: Any, maximum: int = MAX_COUNT) -> int | None:
    """None as it is (a count that is not kept: an ideal encoder), else :func:`as_count`."""
    return None if value is None else as_count(name, value, maximum)


def as_limit(name: str, value: Any) -> float:
    """``value`` as a limit on a magnitude: a positive float, ``math.inf`` for none; see
    :func:`as_real` (which this follows, inf aside).

    :raises ValueError: naming ``name`` for another type, NaN, zero or a negative number
    """
    if isinstance(value, bool) or not isinstance(value, REAL_TYPES):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    try:
        number = float(value)
    except OverflowError:  # a Python int beyond float64: no limit a robot could reach, or < 0
        number = math.inf if value > 0 else -math.inf
    if math.isnan(number) or number <= 0.0:
        raise ValueError(f"{name} must be a positive number (inf for no limit), got {value!r}")
    return number


def as_in_open_interval(name: str, value: Any, low: float, high: float, span: str) -> float:
    """``value`` as a float strictly between ``low`` and ``high``; see :func:`as_real`.

    :param span: how the message writes the interval (``"(0, pi/2)"``)
    """
    number = as_real(name, value)
    if not low < number < high:
        raise ValueError(f"{name} must lie in {span}, got {value!r}")
    return number


def as_finite_array(name: str, value: Any) -> NDArray[np.float64]:
    """``value`` as a new float64 array of finite numbers.

    :raises ValueError: naming ``name`` for anything but real numbers (text and complex
        numbers are not cast away, ragged lists, ints beyond float64) and for NaN or inf
    """
    try:
        given = np.asarray(value)
        if given.dtype.kind not in "biufO":
            raise TypeError(f"dtype {given.dtype}")
        array = given.astype(np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be an array of numbers, got {value!r}") from None
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite, got {value!r}")
    return array


def as_rows(name: str, value: Any, width: int) -> tuple[NDArray[np.float64], bool]:
    """``value``, one row of ``width`` numbers or N of them, as a new C-contiguous (N, width)
    float64 array of finite numbers, and whether it held N rows (was 2-d).

    :raises ValueError: naming ``name`` as :func:`as_finite_array`, or for another shape
    """
    array = as_finite_array(name, value)
    if array.ndim == 1 and array.shape[0] == width:
        return array[np.newaxis].copy(), False
    if array.ndim == 2 and array.shape[1] == width:
        return np.array(array, order="C"), True
    raise ValueError(f"{name} must have shape ({width},) or (N, {width}), got {array.shape}")


def as_point(name: str, value: Any) -> NDArray[np.float64]:
    """``value`` as an (x, y) pair of finite numbers, a new float64 array of shape (2,).

    :raises ValueError: naming ``name`` as :func:`as_finite_array`, or for another shape
    """
    point = np.array(as_finite_array(name, value))
    if point.shape != (2,):
        raise ValueError(f"{name} must be an (x, y) pair, got shape {point.shape}")
    return point


def as_choice(name: str, value: Any, choices: Sequence[str]) -> str:
    """``value`` if it is one of the names ``choices`` (a str: an array or a list is none).

    :raises ValueError: naming ``name`` and the choices otherwise
    """
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"{name} must be one of {tuple(choices)}, got {value!r}")
    return value

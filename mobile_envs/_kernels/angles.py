"""Angle wrapping: one formula for numpy and for compiled code.

The kinematic models wrap headings and the path geometry wraps turn angles with the same
formula, so that neither module needs the other: :func:`wrap_angle` for arrays and
:func:`wrap_scalar_angle` inside numba kernels give the same bits.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray


def wrap_angle(angle: ArrayLike) -> NDArray[np.float64]:
    """Wrap angles to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=np.float64), 2.0 * np.pi)


@njit(cache=True)
def wrap_scalar_angle(angle: float) -> float:
    """:func:`wrap_angle` of one angle, for compiled code: the same formula, the same bits."""
    return math.pi - (math.pi - angle) % (2.0 * math.pi)

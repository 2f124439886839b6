"""Wheel and steering encoders: what a robot's own sensors count of its motion.

A model with encoders reads one step of its motion in its module's compiled
``encoder_increments`` (seed 000, eq. 16, for the differential drive; a traction and a
steering encoder for the car-like robots, as seed 003's robot has), from the settings laid
out as :class:`EncoderSetting` says. Odometry (:mod:`mobile_envs.sensing.odometry`) turns the
increments into a pose estimate. Incremental encoders count whole counts: a step's fraction
of a count is kept (the *residual*) and counted in a later step, so no distance is lost to
rounding.
"""

from __future__ import annotations

import enum
import math

from numba import njit


class EncoderSetting(enum.IntEnum):
    """The columns of the float64 array of encoder settings a model's
    ``encoder_increments`` reads."""

    #: Relative error e of the wheel radii the odometry assumes: the differential drive's
    #: right wheel r (1 + e/2), its left r (1 - e/2); a car-like traction wheel r (1 + e).
    RADIUS_ERROR = 0
    #: Relative error of the track width (wheelbase) the odometry assumes.
    WHEELBASE_ERROR = 1
    #: Traction encoder counts per wheel revolution; 0: ideal encoders.
    COUNTS = 2
    #: Steering encoder counts per revolution; 0: an ideal encoder.
    STEERING_COUNTS = 3
    #: A car-like robot's traction wheel radius (m); 0 when not needed.
    TRACTION_RADIUS = 4


@njit(cache=True)
def count_encoder(rotation: float, residual: float, counts_per_revolution: float):
    """What an incremental encoder reports for a turn of ``rotation`` radians.

    The encoder reports whole counts of 2 pi / counts_per_revolution; the fraction of a
    count it has turned past its last count, ``residual`` in [0, one count), carries over
    to the next step, so the counted total never drifts from the true one by a count or more.

    :param counts_per_revolution: counts in one turn; 0 for an ideal encoder
    :return: (measured rotation, new residual)
    """
    if counts_per_revolution == 0.0:
        return rotation, 0.0
    count = 2.0 * math.pi / counts_per_revolution
    total = residual + rotation
    counts = float(math.floor(total / count))
    left = total - counts * count
    # Rounding can leave the remainder a hair outside [0, count): move it back in.
    if left < 0.0:
        counts -= 1.0
        left += count
    elif left >= count:
        counts += 1.0
        left -= count
    return counts * count, left


@njit(cache=True)
def read_steering(gamma: float, counts_per_revolution: float) -> float:
    """An absolute steering encoder's reading of gamma, to the nearest count."""
    if counts_per_revolution == 0.0:
        return gamma
    count = 2.0 * math.pi / counts_per_revolution
    return round(gamma / count) * count


@njit(cache=True, inline="always")
def traction_distance(encoders, distance: float, residuals) -> float:
    """The distance a car-like robot's traction encoder reports for a true ``distance``, at
    the wheel radius the odometry assumes; ``residuals[0]`` carries the fraction of a count."""
    counts = encoders[EncoderSetting.COUNTS]
    if counts != 0.0:
        radius = encoders[EncoderSetting.TRACTION_RADIUS]
        turned, residuals[0] = count_encoder(distance / radius, residuals[0], counts)
        distance = turned * radius
    return distance * (1.0 + encoders[EncoderSetting.RADIUS_ERROR])

"""The differential drive: two driven wheels on one axle (Bermúdez 2003; the course)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from mobile_envs._kernels import exact_math
from mobile_envs.robots.encoders import EncoderSetting, count_encoder
from mobile_envs.robots.families import WheelDriven
from mobile_envs.robots.model import Array, _as_batch, _as_batch_pair
from mobile_envs.robots.motion import rim_speeds_into_limit
from mobile_envs.robots.rigid_body import advance, rates, twist
from mobile_envs.validation import as_positive

__all__ = ["DifferentialDrive", "advance", "body_twist", "encoder_increments", "rates", "twist"]

# The columns of DifferentialDrive.kernel_parameters: r, L, and a true robot's errors of its
# right and left wheel radii (fractions of r; 0 for the nominal robot).
WHEEL_RADIUS, TRACK_WIDTH, RIGHT_RADIUS_ERROR, LEFT_RADIUS_ERROR = 0, 1, 2, 3


@njit(cache=True, inline="always")
def body_twist(parameters, inputs):
    """v = r (omega_R + omega_L) / 2 and omega = r (omega_R - omega_L) / L (eqs. 6-8); a true
    robot's wheels roll as r (1 + e_R) and r (1 - e_L) would."""
    wheel_radius, track_width = parameters[WHEEL_RADIUS], parameters[TRACK_WIDTH]
    right = inputs[0] * (1.0 + parameters[RIGHT_RADIUS_ERROR])
    left = inputs[1] * (1.0 + parameters[LEFT_RADIUS_ERROR])
    v = 0.5 * wheel_radius * (right + left)
    return v, 0.0, wheel_radius * (right - left) / track_width


@njit(cache=True, inline="always")
def encoder_increments(parameters, encoders, state_before, state_after, inputs, dt, residuals):
    """U(k) = (dD, dtheta) from the wheel encoders (eq. 16): each wheel turns omega dt; its
    counted turn times the radius the odometry assumes (right r (1 + e/2), left r (1 - e/2))
    gives dD_R and dD_L, and eq. 16 with the assumed track width L (1 + e_L) gives dD and
    dtheta. ``residuals`` (2,) carries each wheel's fraction of a count."""
    radius_error = encoders[EncoderSetting.RADIUS_ERROR]
    length_scale = 1.0 + encoders[EncoderSetting.WHEELBASE_ERROR]
    counts = encoders[EncoderSetting.COUNTS]
    wheel_radius, track_width = parameters[WHEEL_RADIUS], parameters[TRACK_WIDTH]
    right, residuals[0] = count_encoder(inputs[0] * dt, residuals[0], counts)
    left, residuals[1] = count_encoder(inputs[1] * dt, residuals[1], counts)
    delta_right = wheel_radius * (1.0 + 0.5 * radius_error) * right
    delta_left = wheel_radius * (1.0 - 0.5 * radius_error) * left
    return 0.5 * (delta_right + delta_left), (delta_right - delta_left) / (
        track_width * length_scale
    )


class DifferentialDrive(WheelDriven):
    """Two driven wheels on one axle (Bermúdez 2003, eqs. 4, 6-8, 11; the course).

    v = r (omega_R + omega_L) / 2, omega = r (omega_R - omega_L) / L, with the reference
    point midway between the wheels.

    :param wheel_radius: r in metres (course: 0.05)
    :param track_width: L, the distance between the wheels, in metres (course: 1.0)
    :param max_wheel_speed: limit on each wheel's |angular speed| (rad/s), unbounded by default
    """

    name = "diff_drive"
    env_id = "DiffDrive"
    #: The course's robot: top speed 1 m/s, top yaw rate 2 rad/s.
    env_defaults = {"wheel_radius": 0.05, "track_width": 1.0, "max_wheel_speed": 20.0}
    state_names = ("x", "y", "theta")
    input_names = ("omega_R", "omega_L")
    parameter_names = ("wheel_radius", "track_width", "max_wheel_speed")
    parameter_errors = ("wheel_radius_right", "wheel_radius_left", "track_width")
    has_encoders = True

    def __init__(
        self,
        wheel_radius: float = 0.05,
        track_width: float = 1.0,
        max_wheel_speed: float = math.inf,
    ):
        self.wheel_radius = as_positive("wheel_radius", wheel_radius)
        self.track_width = as_positive("track_width", track_width)
        self._limit_wheels(max_wheel_speed)
        self.kernel_parameters = np.array([self.wheel_radius, self.track_width, 0.0, 0.0])

    @property
    def top_yaw_rate(self) -> float:
        return 2.0 * self.wheel_radius * self.max_wheel_speed / self.track_width

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        half_track = 0.5 * self.track_width
        rim = np.stack([v + omega * half_track, v - omega * half_track], axis=1)
        # Both wheels scaled by one factor, so the turning radius survives saturation.
        return rim_speeds_into_limit(rim, self.wheel_radius, self.max_wheel_speed)

    def _apply_error(self, rows: Array, name: str, error: Array) -> None:
        if name == "track_width":
            rows[:, TRACK_WIDTH] *= 1.0 + error
        else:
            rows[:, RIGHT_RADIUS_ERROR if name == "wheel_radius_right" else LEFT_RADIUS_ERROR] = (
                error
            )

    def turning_radius(self, u: ArrayLike) -> Array:
        """R = L (v_R + v_L) / (2 (v_R - v_L)), signed (positive turning left), inf if straight.

        :param u: wheel speeds (omega_R, omega_L), shape (2,) or (N, 2)
        """
        inputs, batched = _as_batch(u, 2, "u")
        inputs = self.saturate(inputs)
        total, difference = inputs[:, 0] + inputs[:, 1], inputs[:, 0] - inputs[:, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            radius = self.track_width * total / (2.0 * difference)
        radius = np.where(difference == 0.0, math.inf, radius)
        return radius if batched else radius[0]

    def instantaneous_center(self, state: ArrayLike, u: ArrayLike) -> Array:
        """Instantaneous centre of rotation (Bermúdez 2003, eq. 2): (x - R sin th, y + R cos th).

        For a robot driving straight there is no centre; its row is (inf, inf).

        :return: shape (2,) or (N, 2)
        """
        states, inputs, batched = _as_batch_pair(state, u, 3, 2)
        radius = np.atleast_1d(self.turning_radius(inputs))
        straight = np.isinf(radius)
        finite_radius = np.where(straight, 0.0, radius)
        center = np.stack(
            [
                states[:, 0] - finite_radius * exact_math.sin(states[:, 2]),
                states[:, 1] + finite_radius * exact_math.cos(states[:, 2]),
            ],
            axis=1,
        )
        center[straight] = math.inf
        return center if batched else center[0]

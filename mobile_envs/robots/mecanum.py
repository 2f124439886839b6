"""The mecanum-wheeled omnidirectional robot: four wheels with rollers at 45 degrees.

Wheels front-left, front-right, rear-left, rear-right, in the X configuration (each wheel's
rollers point at the robot's centre when seen from above); r the wheel radius, l_x the half
wheelbase, l_y the half track. The body twist follows from the four wheel speeds:

    v_x   = r / 4 (w_fl + w_fr + w_rl + w_rr)
    v_y   = r / 4 (-w_fl + w_fr + w_rl - w_rr)
    omega = r / (4 (l_x + l_y)) (-w_fl + w_fr - w_rl + w_rr)

so it moves in any direction while turning, as the constant-velocity robot does, through
real wheels with real limits.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from mobile_envs.robots.families import WheelDriven
from mobile_envs.robots.model import Array
from mobile_envs.robots.motion import rim_speeds_into_limit
from mobile_envs.robots.rigid_body import advance, rates, twist
from mobile_envs.validation import as_positive

__all__ = ["Mecanum", "advance", "body_twist", "rates", "twist"]

# The columns of Mecanum.kernel_parameters: r, l_x, l_y, then a true robot's error of each
# wheel's radius (FL, FR, RL, RR; fractions of r, 0 for the nominal robot).
WHEEL_RADIUS, HALF_WHEELBASE, HALF_TRACK, RADIUS_ERRORS = 0, 1, 2, 3


@njit(cache=True, inline="always")
def body_twist(parameters, inputs):
    """(v_x, v_y, omega) from the wheel speeds (w_fl, w_fr, w_rl, w_rr)."""
    quarter_radius = 0.25 * parameters[WHEEL_RADIUS]
    front_left = inputs[0] * (1.0 + parameters[RADIUS_ERRORS])
    front_right = inputs[1] * (1.0 + parameters[RADIUS_ERRORS + 1])
    rear_left = inputs[2] * (1.0 + parameters[RADIUS_ERRORS + 2])
    rear_right = inputs[3] * (1.0 + parameters[RADIUS_ERRORS + 3])
    v_x = quarter_radius * (front_left + front_right + rear_left + rear_right)
    v_y = quarter_radius * (-front_left + front_right + rear_left - rear_right)
    lever = parameters[HALF_WHEELBASE] + parameters[HALF_TRACK]
    omega = quarter_radius * (-front_left + front_right - rear_left + rear_right) / lever
    return v_x, v_y, omega


class Mecanum(WheelDriven):
    """Omnidirectional robot on four mecanum wheels (X configuration, rollers at 45 degrees).

    Inputs: the four wheels' angular speeds (front-left, front-right, rear-left,
    rear-right), each within ``max_wheel_speed``. The reference point is the robot's centre.
    A wanted twist (v, omega) maps to wheel speeds with no sideways velocity, all four scaled
    by one factor when one would exceed its limit (the direction of motion is kept).

    :param wheel_radius: r in metres
    :param half_wheelbase: l_x, from the centre to the front (and rear) axle, in metres
    :param half_track: l_y, from the centre to the left (and right) wheels, in metres
    :param max_wheel_speed: limit on each wheel's |angular speed| (rad/s), unbounded by default
    """

    name = "mecanum"
    env_id = "Mecanum"
    #: r = 5 cm, l_x = l_y = 20 cm, 20 rad/s a wheel: top speed 1 m/s, top yaw rate 2.5 rad/s.
    env_defaults = {
        "wheel_radius": 0.05,
        "half_wheelbase": 0.2,
        "half_track": 0.2,
        "max_wheel_speed": 20.0,
    }
    state_names = ("x", "y", "theta")
    input_names = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
    parameter_names = ("wheel_radius", "half_wheelbase", "half_track", "max_wheel_speed")
    parameter_errors = (
        "wheel_radius_fl",
        "wheel_radius_fr",
        "wheel_radius_rl",
        "wheel_radius_rr",
        "half_wheelbase",
        "half_track",
    )

    def __init__(
        self,
        wheel_radius: float = 0.05,
        half_wheelbase: float = 0.2,
        half_track: float = 0.2,
        max_wheel_speed: float = math.inf,
    ):
        self.wheel_radius = as_positive("wheel_radius", wheel_radius)
        self.half_wheelbase = as_positive("half_wheelbase", half_wheelbase)
        self.half_track = as_positive("half_track", half_track)
        self._limit_wheels(max_wheel_speed)
        self.kernel_parameters = np.array(
            [self.wheel_radius, self.half_wheelbase, self.half_track, 0.0, 0.0, 0.0, 0.0]
        )

    @property
    def top_yaw_rate(self) -> float:
        return self.wheel_radius * self.max_wheel_speed / (self.half_wheelbase + self.half_track)

    def wheel_speeds(self, v_x: Array, v_y: Array, omega: Array) -> Array:
        """The inverse kinematics: the wheel speeds (N, 4) that give the body twist
        (v_x, v_y, omega), unsaturated."""
        return self._rim_speeds(v_x, v_y, omega) / self.wheel_radius

    def _rim_speeds(self, v_x: Array, v_y: Array, omega: Array) -> Array:
        lever = (self.half_wheelbase + self.half_track) * omega
        return np.stack(
            [v_x - v_y - lever, v_x + v_y + lever, v_x + v_y - lever, v_x - v_y + lever], axis=1
        )

    def _apply_error(self, rows: Array, name: str, error: Array) -> None:
        if name == "half_wheelbase":
            rows[:, HALF_WHEELBASE] *= 1.0 + error
        elif name == "half_track":
            rows[:, HALF_TRACK] *= 1.0 + error
        else:
            wheel = ("wheel_radius_fl", "wheel_radius_fr", "wheel_radius_rl", "wheel_radius_rr")
            rows[:, RADIUS_ERRORS + wheel.index(name)] = error

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        rim = self._rim_speeds(v, np.zeros_like(v), omega)
        # All four wheels scaled by one factor, so the direction of motion survives saturation.
        return rim_speeds_into_limit(rim, self.wheel_radius, self.max_wheel_speed)

"""The bicycle: a car-like robot with its reference point on the rear axle (the course,
after Corke)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from mobile_envs.robots.encoders import EncoderSetting, read_steering, traction_distance
from mobile_envs.robots.families import CarLike
from mobile_envs.robots.model import Array
from mobile_envs.robots.motion import apply_steering_error, steering_for
from mobile_envs.robots.rigid_body import advance, rates, twist

__all__ = ["Bicycle", "advance", "body_twist", "encoder_increments", "rates", "twist"]

# The columns of Bicycle.kernel_parameters: L, and a true robot's steering offset (rad).
WHEELBASE, STEERING_OFFSET = 0, 1


@njit(cache=True, inline="always")
def body_twist(parameters, inputs):
    """v along the heading and th' = v tan(gamma) / L: the inputs are (v, gamma); a true
    robot's misaligned steering adds its offset to the angle the actuator sets."""
    v, gamma = inputs[0], inputs[1]
    if parameters[STEERING_OFFSET] != 0.0:
        gamma = gamma + parameters[STEERING_OFFSET]
    return v, 0.0, v * math.tan(gamma) / parameters[WHEELBASE]


@njit(cache=True, inline="always")
def encoder_increments(parameters, encoders, state_before, state_after, inputs, dt, residuals):
    """U(k) = (dD, dtheta): the traction encoder counts the reference point's distance v dt
    (turns of a wheel of radius r, assumed r (1 + e)); dtheta = dD tan(gamma) / L (1 + e_L),
    gamma read by the steering encoder."""
    travelled = traction_distance(encoders, inputs[0] * dt, residuals)
    wheelbase = parameters[WHEELBASE] * (1.0 + encoders[EncoderSetting.WHEELBASE_ERROR])
    gamma = read_steering(inputs[1], encoders[EncoderSetting.STEERING_COUNTS])
    return travelled, travelled * math.tan(gamma) / wheelbase


class Bicycle(CarLike):
    """Car-like robot with the reference point on the rear axle (the course, after Corke).

    x' = v cos th, y' = v sin th, th' = v tan(gamma) / L. A wanted yaw rate omega maps to
    gamma = atan(L omega / v), saturated at ``max_steering``.

    :param wheelbase: L in metres (course: 1.0)
    :param max_steering: limit on |gamma| in (0, pi/2) radians (course tries pi/3, pi/4, pi/6)
    :param max_speed: limit on |v| (m/s), unbounded by default
    """

    name = "bicycle"
    env_id = "Bicycle"
    env_defaults = {"wheelbase": 1.0, "max_steering": math.pi / 4, "max_speed": 1.0}
    state_names = ("x", "y", "theta")
    input_names = ("v", "gamma")
    parameter_names = ("wheelbase", "max_steering", "max_speed")

    def __init__(
        self,
        wheelbase: float = 1.0,
        max_steering: float = math.pi / 4,
        max_speed: float = math.inf,
    ):
        self._set_steering(wheelbase, max_steering, max_speed)
        self.input_high = np.array([self.max_speed, self.max_steering])
        self.input_low = -self.input_high
        self.kernel_parameters = np.array([self.wheelbase, 0.0, 0.0, 0.0])

    @property
    def top_yaw_rate(self) -> float:
        return self.max_speed * math.tan(self.max_steering) / self.wheelbase

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        return np.stack([v, steering_for(self.wheelbase, v, omega)], axis=1)

    def _apply_error(self, rows: Array, name: str, error: Array) -> None:
        apply_steering_error(rows, name, error, WHEELBASE, STEERING_OFFSET)

"""The constant-velocity (holonomic) robot of the course: it holds a body-frame velocity."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from mobile_envs.robots.model import FROM_INPUT, Array, KinematicModel, ObservedState
from mobile_envs.robots.rigid_body import advance, rates, twist
from mobile_envs.validation import as_limit

__all__ = ["ConstantVelocity", "advance", "body_twist", "rates", "twist"]


# The column of ConstantVelocity.kernel_parameters: the true robot's velocity scale error.
VELOCITY_SCALE_ERROR = 0


@njit(cache=True, inline="always")
def body_twist(parameters, inputs):
    """The body twist (v_x, v_y, omega) is the input itself (scaled by a true robot's error)."""
    scale = 1.0 + parameters[VELOCITY_SCALE_ERROR]
    return inputs[0] * scale, inputs[1] * scale, inputs[2] * scale


class ConstantVelocity(KinematicModel):
    """Holonomic robot holding a body-frame velocity over each step (the course).

    Pose composition p (+) (u dt): x += (v_x cos th - v_y sin th) dt,
    y += (v_x sin th + v_y cos th) dt, th += omega dt. The course's helper writes
    ``- v_y dt cos th`` in y, a sign error; this model uses ``+``.

    :param max_speed: limit on |v_x| and on |v_y| (m/s), unbounded by default
    :param max_angular_speed: limit on |omega| (rad/s), unbounded by default
    """

    name = "constant_velocity"
    env_id = "ConstantVelocity"
    env_defaults = {"max_speed": 1.0, "max_angular_speed": 2.0}
    state_names = ("x", "y", "theta")
    input_names = ("v_x", "v_y", "omega")
    parameter_names = ("max_speed", "max_angular_speed")
    #: A true robot realizes its commanded velocity times (1 + velocity_scale).
    parameter_errors = ("velocity_scale",)

    def __init__(self, max_speed: float = math.inf, max_angular_speed: float = math.inf):
        self.max_speed = as_limit("max_speed", max_speed)
        self.max_angular_speed = as_limit("max_angular_speed", max_angular_speed)
        self.input_high = np.array([self.max_speed, self.max_speed, self.max_angular_speed])
        self.input_low = -self.input_high
        #: The inputs are the twist; a true robot's velocity scale error, 0 for the nominal.
        self.kernel_parameters = np.zeros(4)

    @property
    def top_speed(self) -> float:
        return self.max_speed

    @property
    def top_yaw_rate(self) -> float:
        return self.max_angular_speed

    @property
    def min_turning_radius(self) -> float:
        return 0.0

    @property
    def observed_state(self) -> tuple[ObservedState, ...]:
        return (ObservedState("lateral_velocity", FROM_INPUT, 1, 1.0 / self.top_speed),)

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        return np.stack([v, np.zeros_like(v), omega], axis=1)

    def _apply_error(self, rows: Array, name: str, error: Array) -> None:
        rows[:, VELOCITY_SCALE_ERROR] = error

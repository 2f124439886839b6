"""The tricycle AGV of Font-Llagunes & Batlle (2006): a steered drive wheel C ahead of the rear
axle, its angle part of the state."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from mobile_envs._kernels import exact_math
from mobile_envs._kernels.angles import wrap_scalar_angle
from mobile_envs.robots.encoders import EncoderSetting, read_steering, traction_distance
from mobile_envs.robots.families import CarLike
from mobile_envs.robots.model import (
    FROM_STATE,
    Array,
    ObservedState,
    _as_batch,
)
from mobile_envs.robots.motion import (
    EULER,
    EXACT,
    RK4,
    apply_steering_error,
    arc_displacement,
    clip,
    rk4_increment,
    steering_for,
)
from mobile_envs.validation import as_count, as_limit

__all__ = ["MAX_SUBSTEPS", "Tricycle", "advance", "encoder_increments", "rates", "twist"]

#: The exact tricycle step's error falls as 1 / substeps**2: at 2**26 sub-arcs it is 2**-52
#: of one arc's, float64's resolution, so more could not be more accurate (only slower).
MAX_SUBSTEPS = 2**26
# The columns of Tricycle.kernel_parameters: L, the steering limit, the exact step's arcs,
# and a true robot's steering offset (rad; 0 for the nominal robot).
WHEELBASE, MAX_STEERING, SUBSTEPS, STEERING_OFFSET = 0, 1, 2, 3


@njit(cache=True, inline="always")
def _wheel_angle(parameters, gamma):
    """The drive wheel's true angle: the actuator's gamma plus a misaligned steering's offset."""
    offset = parameters[STEERING_OFFSET]
    return gamma + offset if offset != 0.0 else gamma


@njit(cache=True, inline="always")
def _rates(parameters, heading, gamma, v, gamma_rate):
    """Time derivative of (x, y, psi, gamma); the limit stops the wheel."""
    wheelbase, max_steering = parameters[WHEELBASE], parameters[MAX_STEERING]
    wheel = _wheel_angle(parameters, gamma)
    speed_of_o = v * math.cos(wheel)
    pushing_past_limit = abs(gamma) >= max_steering and gamma * gamma_rate > 0.0
    return (
        speed_of_o * math.cos(heading),
        speed_of_o * math.sin(heading),
        v * math.sin(wheel) / wheelbase,
        0.0 if pushing_past_limit else gamma_rate,
    )


@njit(cache=True, inline="always")
def _rk4(parameters, x, y, heading, gamma, inputs, dt):
    """Classical Runge-Kutta step of (x, y, psi, gamma) on :func:`_rates`."""
    v, gamma_rate = inputs[0], inputs[1]
    k1 = _rates(parameters, heading, gamma, v, gamma_rate)
    half = 0.5 * dt
    k2 = _rates(parameters, heading + half * k1[2], gamma + half * k1[3], v, gamma_rate)
    k3 = _rates(parameters, heading + half * k2[2], gamma + half * k2[3], v, gamma_rate)
    k4 = _rates(parameters, heading + dt * k3[2], gamma + dt * k3[3], v, gamma_rate)
    return (
        x + rk4_increment(dt, k1[0], k2[0], k3[0], k4[0]),
        y + rk4_increment(dt, k1[1], k2[1], k3[1], k4[1]),
        heading + rk4_increment(dt, k1[2], k2[2], k3[2], k4[2]),
        gamma + rk4_increment(dt, k1[3], k2[3], k3[3], k4[3]),
    )


@njit(cache=True, inline="always")
def _arcs(parameters, x, y, psi, gamma, v, gamma_rate, dt, integrator_code):
    """One euler, midpoint or exact step, as arcs of constant gamma.

    gamma moves linearly in time, clipped at its limit. The exact step is ``substeps`` arcs,
    each with gamma at its own midpoint; euler and midpoint take one arc with gamma at the
    step's start and middle.
    """
    wheelbase, max_steering = parameters[WHEELBASE], parameters[MAX_STEERING]
    substeps = int(parameters[SUBSTEPS]) if integrator_code == EXACT else 1
    sample_at = 0.0 if integrator_code == EULER else 0.5
    h = dt / substeps
    for index in range(substeps):
        arc_gamma = _wheel_angle(
            parameters, clip(gamma + gamma_rate * ((index + sample_at) * h), max_steering)
        )
        omega = v * math.sin(arc_gamma) / wheelbase
        dx, dy = arc_displacement(psi, v * math.cos(arc_gamma), 0.0, omega, h, integrator_code)
        x += dx
        y += dy
        psi += omega * h
    return x, y, psi, clip(gamma + gamma_rate * dt, max_steering)


@njit(cache=True, inline="always")
def advance(parameters, state, inputs, dt, integrator_code, out):
    """Advance one robot by ``dt`` seconds into ``out`` (which may be ``state``)."""
    x, y, heading, gamma = state[0], state[1], state[2], state[3]
    if integrator_code == RK4:
        x, y, heading, gamma = _rk4(parameters, x, y, heading, gamma, inputs, dt)
        gamma = clip(gamma, parameters[MAX_STEERING])
    else:
        x, y, heading, gamma = _arcs(
            parameters, x, y, heading, gamma, inputs[0], inputs[1], dt, integrator_code
        )
    out[0] = x
    out[1] = y
    out[2] = wrap_scalar_angle(heading)
    out[3] = gamma


@njit(cache=True, inline="always")
def twist(parameters, state, inputs):
    """O's speed v cos(gamma) and the yaw rate v sin(gamma) / L."""
    v, gamma = inputs[0], _wheel_angle(parameters, state[3])
    return v * math.cos(gamma), v * math.sin(gamma) / parameters[WHEELBASE]


@njit(cache=True, inline="always")
def rates(parameters, state, inputs, out):
    """The time derivative of one robot's (x, y, psi, gamma) into ``out``."""
    out[0], out[1], out[2], out[3] = _rates(parameters, state[2], state[3], inputs[0], inputs[1])


@njit(cache=True)
def _mean_sin_cos(gamma_start: float, gamma_end: float) -> tuple[float, float]:
    """Mean of sin and of cos of gamma moving linearly from ``gamma_start`` to ``gamma_end``.

    (cos a - cos b) / (b - a) = sin((a + b)/2) sinc((b - a)/2), and the same for cos: the
    product form has no 0/0 when the wheel holds still.
    """
    middle, half_sweep = 0.5 * (gamma_start + gamma_end), 0.5 * (gamma_end - gamma_start)
    shrink = 1.0 if half_sweep == 0.0 else math.sin(half_sweep) / half_sweep
    return math.sin(middle) * shrink, math.cos(middle) * shrink


@njit(cache=True, inline="always")
def encoder_increments(parameters, encoders, state_before, state_after, inputs, dt, residuals):
    """U(k) = (dD, dtheta): the traction encoder counts the drive wheel C's distance v dt; the
    steering encoder reads gamma at the step's start and end. With gamma moving linearly
    between them, O travels dD_C mean(cos gamma) and the body turns dD_C mean(sin gamma) / L."""
    travelled = traction_distance(encoders, inputs[0] * dt, residuals)
    wheelbase = parameters[WHEELBASE] * (1.0 + encoders[EncoderSetting.WHEELBASE_ERROR])
    steering_counts = encoders[EncoderSetting.STEERING_COUNTS]
    mean_sin, mean_cos = _mean_sin_cos(
        read_steering(state_before[3], steering_counts),
        read_steering(state_after[3], steering_counts),
    )
    return travelled * mean_cos, travelled * mean_sin / wheelbase


class Tricycle(CarLike):
    """Tricycle AGV of Font-Llagunes & Batlle (2006): a steered drive wheel C ahead of the rear
    axle.

    State (x, y, psi, gamma): position of O, the midpoint of the rear (fork) wheels, the
    heading psi and the drive wheel's angle gamma. Inputs (v, gamma_rate): the speed of C
    and the steering rate. psi' = v sin(gamma) / L (Font-Llagunes & Batlle 2006, eq. 8), O moves at
    v cos(gamma) along psi, gamma' = gamma_rate with |gamma| held within ``max_steering``.

    The ``"exact"`` integrator: gamma moves linearly in time (clipped at its limit), so the
    pose has no closed form while the wheel turns. The step is split into ``substeps``
    equal parts, each an exact arc (Bermúdez 2003, eq. 25) with gamma at its own midpoint: exact
    whenever the wheel angle holds still, second order in the sub-step otherwise.

    :param wheelbase: L, from O to C, in metres
    :param max_steering: limit on |gamma| in (0, pi/2) radians; default 85 degrees (O then
        circles 8.7 cm from the centre)
    :param max_speed: limit on |v| (m/s), unbounded by default
    :param max_steering_rate: limit on |gamma_rate| (rad/s), unbounded by default
    :param substeps: arcs per step of the ``"exact"`` integrator
    """

    name = "tricycle"
    env_id = "Tricycle"
    env_defaults = {
        "wheelbase": 1.0,
        "max_steering": math.radians(85.0),
        "max_speed": 1.0,
        "max_steering_rate": 2.0,
    }
    state_names = ("x", "y", "psi", "gamma")
    input_names = ("v", "gamma_rate")
    parameter_names = ("wheelbase", "max_steering", "max_speed", "max_steering_rate", "substeps")

    def __init__(
        self,
        wheelbase: float = 1.0,
        max_steering: float = math.radians(85.0),
        max_speed: float = math.inf,
        max_steering_rate: float = math.inf,
        substeps: int = 4,
    ):
        self._set_steering(wheelbase, max_steering, max_speed)
        self.max_steering_rate = as_limit("max_steering_rate", max_steering_rate)
        self.substeps = as_count("substeps", substeps, MAX_SUBSTEPS)
        self.input_high = np.array([self.max_speed, self.max_steering_rate])
        self.input_low = -self.input_high
        self.kernel_parameters = np.array(
            [self.wheelbase, self.max_steering, float(self.substeps), 0.0]
        )

    @property
    def top_yaw_rate(self) -> float:
        return self.max_speed * math.sin(self.max_steering) / self.wheelbase

    @property
    def observed_state(self) -> tuple[ObservedState, ...]:
        return (ObservedState("wheel_angle", FROM_STATE, 3, 1.0 / self.max_steering),)

    def _check_state(self, states: Array) -> None:
        if (np.abs(states[:, 3]) > self.max_steering + 1e-12).any():
            raise ValueError(
                f"the wheel angle gamma (state[3]) must lie within +-max_steering "
                f"= +-{self.max_steering}, got {states[:, 3]}"
            )

    def derivative(self, state: ArrayLike, u: ArrayLike) -> Array:
        self._check_state(_as_batch(state, 4, "state")[0])
        return super().derivative(state, u)

    def step(self, state: ArrayLike, u: ArrayLike, dt: float, integrator: str = "exact") -> Array:
        self._check_state(_as_batch(state, 4, "state")[0])
        return super().step(state, u, dt, integrator)

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        # C moves at (v, omega L) in the body frame when O moves at v and the body turns at
        # omega; steer the wheel along that velocity within one step.
        wanted_gamma = np.clip(
            steering_for(self.wheelbase, v, omega), -self.max_steering, self.max_steering
        )
        wheel_speed = np.where(v < 0.0, -1.0, 1.0) * exact_math.hypot(v, omega * self.wheelbase)
        return np.stack([wheel_speed, (wanted_gamma - states[:, 3]) / dt], axis=1)

    def _apply_error(self, rows: Array, name: str, error: Array) -> None:
        apply_steering_error(rows, name, error, WHEELBASE, STEERING_OFFSET)

"""Kinematic models of wheeled robots, batched over N robots.

Four models, after the course slides (seed 002), the differential-drive paper (seed 000)
and the tricycle AGV paper (seed 003):

========================  ====================  ==========================================
model                     state                 native input ``u``
========================  ====================  ==========================================
:class:`ConstantVelocity`  (x, y, theta)         body-frame velocity (v_x, v_y, omega)
:class:`DifferentialDrive` (x, y, theta)         wheel angular speeds (omega_R, omega_L)
:class:`Bicycle`           (x, y, theta)         rear-axle speed and steering (v, gamma)
:class:`Tricycle`          (x, y, psi, gamma)    drive-wheel speed and steering rate
========================  ====================  ==========================================

Every method takes a single robot (``state`` of shape ``(k,)``) or a batch (``(N, k)``); one
copy of the physics serves the single environment (N = 1) and the vector environment.
Inputs are held constant over a step and saturated to the model's limits. Headings are
wrapped to (-pi, pi].

Integrators (``step(..., integrator=...)``):

- ``"euler"``: the course's update, pose composition with the heading at the step's start.
- ``"midpoint"``: seed 000 eq. 26, the displacement taken along the mid-step heading.
- ``"exact"``: seed 000 eq. 25, the closed-form arc: the displacement along the mid-step
  heading shortened by ``sinc(omega dt / 2)``, which tends smoothly to 1 as omega -> 0.
- ``"rk4"``: classical Runge-Kutta on :meth:`KinematicModel.derivative`.

Any (v, omega) controller drives any model through :meth:`KinematicModel.inputs_for`, as
MATLAB's ``VehicleSpeedHeadingRate`` mode does.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "INTEGRATORS",
    "MODELS",
    "Bicycle",
    "ConstantVelocity",
    "DifferentialDrive",
    "KinematicModel",
    "Tricycle",
    "make_model",
    "wrap_angle",
]

INTEGRATORS = ("euler", "midpoint", "exact", "rk4")

Array = NDArray[np.float64]


def wrap_angle(angle: ArrayLike) -> Array:
    """Wrap angles to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=np.float64), 2.0 * np.pi)


def _check_positive(name: str, value: float, allow_inf: bool = False) -> float:
    value = float(value)
    if math.isnan(value) or value <= 0.0 or (math.isinf(value) and not allow_inf):
        kind = "a positive number" if allow_inf else "a positive finite number"
        raise ValueError(f"{name} must be {kind}, got {value}")
    return value


def _check_steering_limit(name: str, value: float) -> float:
    value = float(value)
    if not 0.0 < value < math.pi / 2:
        raise ValueError(f"{name} must lie in (0, pi/2), got {value}")
    return value


def _as_batch(values: ArrayLike, width: int, name: str) -> tuple[Array, bool]:
    """Return ``values`` as a finite (N, width) float64 array and whether it was batched."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim == 1 and array.shape[0] == width:
        array, batched = array[np.newaxis, :], False
    elif array.ndim == 2 and array.shape[1] == width:
        batched = True
    else:
        raise ValueError(
            f"{name} must have shape ({width},) or (N, {width}), got shape {array.shape}"
        )
    if not np.isfinite(array).all():
        raise ValueError(f"{name} contains NaN or inf: {values!r}")
    return array, batched


def _as_batch_pair(
    state: ArrayLike, u: ArrayLike, state_width: int, input_width: int
) -> tuple[Array, Array, bool]:
    """Validate a state and an input batch; a single one of either broadcasts to N."""
    states, states_batched = _as_batch(state, state_width, "state")
    inputs, inputs_batched = _as_batch(u, input_width, "u")
    if states_batched and inputs_batched and len(states) != len(inputs):
        raise ValueError(
            f"state and u hold different numbers of robots: {len(states)} and {len(inputs)}"
        )
    count = max(len(states), len(inputs))
    states = np.broadcast_to(states, (count, state_width))
    inputs = np.broadcast_to(inputs, (count, input_width))
    return states, inputs, states_batched or inputs_batched


def _check_dt(dt: float) -> float:
    return _check_positive("dt", dt)


def _check_integrator(integrator: str) -> None:
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")


def _arc_displacement(
    heading: Array, v_x: Array, v_y: Array, omega: Array, dt: float, integrator: str
) -> tuple[Array, Array]:
    """World-frame displacement over ``dt`` of a body moving at a constant body twist.

    The body velocity (v_x, v_y) rotates with the heading; integrating exactly gives the
    displacement along the mid-step heading times sinc(omega dt / 2) (seed 000 eq. 25).
    """
    if integrator == "euler":
        direction, shrink = heading, 1.0
    else:
        half_turn = 0.5 * omega * dt
        direction = heading + half_turn
        # np.sinc(t) = sin(pi t) / (pi t): smooth through omega = 0, no division by zero.
        shrink = np.sinc(half_turn / np.pi) if integrator == "exact" else 1.0
    cos_d, sin_d = np.cos(direction), np.sin(direction)
    dx = (v_x * cos_d - v_y * sin_d) * dt * shrink
    dy = (v_x * sin_d + v_y * cos_d) * dt * shrink
    return dx, dy


class KinematicModel:
    """Base of the four models: validation, saturation, integrators and the twist bridge.

    Subclasses define :attr:`state_names`, :attr:`input_names`, the input limits and
    :meth:`_derivative`, :meth:`_advance`, :meth:`batch_twist` and :meth:`_inputs_for` on
    validated (N, k) arrays.
    """

    name: ClassVar[str]
    state_names: ClassVar[tuple[str, ...]]
    input_names: ClassVar[tuple[str, ...]]
    #: The constructor's parameters, stored as attributes of the same names.
    parameter_names: ClassVar[tuple[str, ...]]

    input_low: Array
    input_high: Array

    @property
    def state_dim(self) -> int:
        """Number of state variables k."""
        return len(self.state_names)

    @property
    def input_dim(self) -> int:
        """Number of native inputs m."""
        return len(self.input_names)

    def saturate(self, u: ArrayLike) -> Array:
        """Clip inputs to the model's limits."""
        return np.clip(u, self.input_low, self.input_high)

    def derivative(self, state: ArrayLike, u: ArrayLike) -> Array:
        """Time derivative of the state under (saturated) inputs ``u``.

        :param state: shape (k,) or (N, k)
        :param u: shape (m,) or (N, m)
        :return: same shape as the (broadcast) state
        """
        states, inputs, batched = _as_batch_pair(state, u, self.state_dim, self.input_dim)
        result = self._derivative(states, self.saturate(inputs))
        return result if batched else result[0]

    def step(self, state: ArrayLike, u: ArrayLike, dt: float, integrator: str = "exact") -> Array:
        """Advance the state by ``dt`` seconds with inputs held (and saturated) over the step.

        :param state: shape (k,) or (N, k)
        :param u: shape (m,) or (N, m)
        :param dt: step length in seconds, positive
        :param integrator: one of ``"euler"``, ``"midpoint"``, ``"exact"``, ``"rk4"``
        :return: the new state, heading wrapped to (-pi, pi]
        """
        states, inputs, batched = _as_batch_pair(state, u, self.state_dim, self.input_dim)
        _check_integrator(integrator)
        result = self.advance(states, self.saturate(inputs), _check_dt(dt), integrator)
        return result if batched else result[0]

    def advance(self, states: Array, inputs: Array, dt: float, integrator: str) -> Array:
        """:meth:`step` without validation or saturation, for callers on a hot path.

        :param states: (N, k) finite float64
        :param inputs: (N, m) finite float64 within the input limits
        """
        if integrator == "rk4":
            result = self._rk4(states, inputs, dt)
        else:
            result = self._advance(states, inputs, dt, integrator)
        result[:, 2] = wrap_angle(result[:, 2])
        return result

    def twist(self, state: ArrayLike, u: ArrayLike) -> tuple[Array, Array]:
        """Forward speed v (m/s) and yaw rate omega (rad/s) of the reference point.

        :return: ``(v, omega)``, scalars (0-d arrays) for a single robot, (N,) for a batch
        """
        states, inputs, batched = _as_batch_pair(state, u, self.state_dim, self.input_dim)
        v, omega = self.batch_twist(states, self.saturate(inputs))
        return (v, omega) if batched else (v[0], omega[0])

    def inputs_for(
        self, state: ArrayLike, v: ArrayLike, omega: ArrayLike, dt: float = 0.1
    ) -> Array:
        """The saturated native inputs that best produce the twist (v, omega).

        :param state: shape (k,) or (N, k)
        :param v: wanted forward speed of the reference point, scalar or (N,)
        :param omega: wanted yaw rate, scalar or (N,)
        :param dt: the step over which the inputs will be held (only the tricycle, whose
            input is a steering rate, needs it)
        :return: inputs of shape (m,) or (N, m)
        """
        states, batched = _as_batch(state, self.state_dim, "state")
        wanted = np.broadcast_arrays(np.asarray(v, np.float64), np.asarray(omega, np.float64))
        if wanted[0].ndim > 1 or (wanted[0].ndim == 1 and len(wanted[0]) != len(states)):
            raise ValueError(
                f"v and omega must be scalars or have shape ({len(states)},), "
                f"got {np.shape(v)} and {np.shape(omega)}"
            )
        if not (np.isfinite(wanted[0]).all() and np.isfinite(wanted[1]).all()):
            raise ValueError(f"v and omega must be finite, got {v!r} and {omega!r}")
        speeds = np.broadcast_to(wanted[0], (len(states),))
        rates = np.broadcast_to(wanted[1], (len(states),))
        inputs = self.saturate(self._inputs_for(states, speeds, rates, _check_dt(dt)))
        return inputs if batched or wanted[0].ndim == 1 else inputs[0]

    def _rk4(self, states: Array, inputs: Array, dt: float) -> Array:
        k1 = self._derivative(states, inputs)
        k2 = self._derivative(states + 0.5 * dt * k1, inputs)
        k3 = self._derivative(states + 0.5 * dt * k2, inputs)
        k4 = self._derivative(states + dt * k3, inputs)
        return states + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    def _derivative(self, states: Array, inputs: Array) -> Array:
        raise NotImplementedError

    def _advance(self, states: Array, inputs: Array, dt: float, integrator: str) -> Array:
        raise NotImplementedError

    def batch_twist(self, states: Array, inputs: Array) -> tuple[Array, Array]:
        """:meth:`twist` on validated, saturated (N, k) states and (N, m) inputs."""
        raise NotImplementedError

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        raise NotImplementedError

    def __repr__(self) -> str:
        params = ", ".join(f"{key}={value!r}" for key, value in self.parameters().items())
        return f"{type(self).__name__}({params})"

    def parameters(self) -> dict[str, float]:
        """The constructor arguments that rebuild this model."""
        return {name: getattr(self, name) for name in self.parameter_names}


class _RigidBodyModel(KinematicModel):
    """A model whose inputs fix a constant body twist (v_x, v_y, omega) over the step."""

    state_names = ("x", "y", "theta")

    def _body_twist(self, inputs: Array) -> tuple[Array, Array, Array]:
        raise NotImplementedError

    def _derivative(self, states: Array, inputs: Array) -> Array:
        v_x, v_y, omega = self._body_twist(inputs)
        cos_t, sin_t = np.cos(states[:, 2]), np.sin(states[:, 2])
        return np.stack([v_x * cos_t - v_y * sin_t, v_x * sin_t + v_y * cos_t, omega], axis=1)

    def _advance(self, states: Array, inputs: Array, dt: float, integrator: str) -> Array:
        v_x, v_y, omega = self._body_twist(inputs)
        dx, dy = _arc_displacement(states[:, 2], v_x, v_y, omega, dt, integrator)
        result = np.empty_like(states)
        result[:, 0] = states[:, 0] + dx
        result[:, 1] = states[:, 1] + dy
        result[:, 2] = states[:, 2] + omega * dt
        return result

    def batch_twist(self, states: Array, inputs: Array) -> tuple[Array, Array]:
        v_x, _, omega = self._body_twist(inputs)
        return v_x, omega


class ConstantVelocity(_RigidBodyModel):
    """Holonomic robot holding a body-frame velocity over each step (seed 002).

    Pose composition p (+) (u dt): x += (v_x cos th - v_y sin th) dt,
    y += (v_x sin th + v_y cos th) dt, th += omega dt. The course's helper writes
    ``- v_y dt cos th`` in y, a sign error; this model uses ``+``.

    :param max_speed: limit on |v_x| and on |v_y| (m/s), unbounded by default
    :param max_angular_speed: limit on |omega| (rad/s), unbounded by default
    """

    name = "constant_velocity"
    input_names = ("v_x", "v_y", "omega")
    parameter_names = ("max_speed", "max_angular_speed")

    def __init__(self, max_speed: float = math.inf, max_angular_speed: float = math.inf):
        self.max_speed = _check_positive("max_speed", max_speed, allow_inf=True)
        self.max_angular_speed = _check_positive(
            "max_angular_speed", max_angular_speed, allow_inf=True
        )
        self.input_high = np.array([self.max_speed, self.max_speed, self.max_angular_speed])
        self.input_low = -self.input_high

    def _body_twist(self, inputs: Array) -> tuple[Array, Array, Array]:
        return inputs[:, 0], inputs[:, 1], inputs[:, 2]

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        return np.stack([v, np.zeros_like(v), omega], axis=1)


class DifferentialDrive(_RigidBodyModel):
    """Two driven wheels on one axle (seed 000 eqs. 4, 6-8, 11; seed 002).

    v = r (omega_R + omega_L) / 2, omega = r (omega_R - omega_L) / L, with the reference
    point midway between the wheels.

    :param wheel_radius: r in metres (course: 0.05)
    :param track_width: L, the distance between the wheels, in metres (course: 1.0)
    :param max_wheel_speed: limit on each wheel's |angular speed| (rad/s), unbounded by default
    """

    name = "diff_drive"
    input_names = ("omega_R", "omega_L")
    parameter_names = ("wheel_radius", "track_width", "max_wheel_speed")

    def __init__(
        self,
        wheel_radius: float = 0.05,
        track_width: float = 1.0,
        max_wheel_speed: float = math.inf,
    ):
        self.wheel_radius = _check_positive("wheel_radius", wheel_radius)
        self.track_width = _check_positive("track_width", track_width)
        self.max_wheel_speed = _check_positive("max_wheel_speed", max_wheel_speed, True)
        self.input_high = np.full(2, self.max_wheel_speed)
        self.input_low = -self.input_high

    def _body_twist(self, inputs: Array) -> tuple[Array, Array, Array]:
        right, left = inputs[:, 0], inputs[:, 1]
        v = 0.5 * self.wheel_radius * (right + left)
        omega = self.wheel_radius * (right - left) / self.track_width
        return v, np.zeros_like(v), omega

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        half_track = 0.5 * self.track_width
        wheels = np.stack([v + omega * half_track, v - omega * half_track], axis=1)
        wheels /= self.wheel_radius
        # Scale both wheels by one factor, so the turning radius survives saturation.
        peak = np.abs(wheels).max(axis=1, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(peak > self.max_wheel_speed, self.max_wheel_speed / peak, 1.0)
        return wheels * scale

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
        """Instantaneous centre of rotation (seed 000 eq. 2): (x - R sin th, y + R cos th).

        For a robot driving straight there is no centre; its row is (inf, inf).

        :return: shape (2,) or (N, 2)
        """
        states, inputs, batched = _as_batch_pair(state, u, 3, 2)
        radius = np.atleast_1d(self.turning_radius(inputs))
        straight = np.isinf(radius)
        finite_radius = np.where(straight, 0.0, radius)
        center = np.stack(
            [
                states[:, 0] - finite_radius * np.sin(states[:, 2]),
                states[:, 1] + finite_radius * np.cos(states[:, 2]),
            ],
            axis=1,
        )
        center[straight] = math.inf
        return center if batched else center[0]


def _steering_for(wheelbase: float, v: Array, omega: Array) -> Array:
    """Steering angle gamma with tan(gamma) = L omega / v; +-pi/2 asked for when v = 0."""
    forward = np.where(v < 0.0, -1.0, 1.0)
    return np.arctan2(wheelbase * omega * forward, np.abs(v))


class Bicycle(_RigidBodyModel):
    """Car-like robot with the reference point on the rear axle (seed 002, after Corke).

    x' = v cos th, y' = v sin th, th' = v tan(gamma) / L. A wanted yaw rate omega maps to
    gamma = atan(L omega / v), saturated at ``max_steering``.

    :param wheelbase: L in metres (course: 1.0)
    :param max_steering: limit on |gamma| in (0, pi/2) radians (course tries pi/3, pi/4, pi/6)
    :param max_speed: limit on |v| (m/s), unbounded by default
    """

    name = "bicycle"
    input_names = ("v", "gamma")
    parameter_names = ("wheelbase", "max_steering", "max_speed")

    def __init__(
        self,
        wheelbase: float = 1.0,
        max_steering: float = math.pi / 4,
        max_speed: float = math.inf,
    ):
        self.wheelbase = _check_positive("wheelbase", wheelbase)
        self.max_steering = _check_steering_limit("max_steering", max_steering)
        self.max_speed = _check_positive("max_speed", max_speed, allow_inf=True)
        self.input_high = np.array([self.max_speed, self.max_steering])
        self.input_low = -self.input_high

    def _body_twist(self, inputs: Array) -> tuple[Array, Array, Array]:
        v = inputs[:, 0]
        return v, np.zeros_like(v), v * np.tan(inputs[:, 1]) / self.wheelbase

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        return np.stack([v, _steering_for(self.wheelbase, v, omega)], axis=1)


class Tricycle(KinematicModel):
    """Tricycle AGV of seed 003: a steered drive wheel C ahead of the rear axle.

    State (x, y, psi, gamma): position of O, the midpoint of the rear (fork) wheels, the
    heading psi and the drive wheel's angle gamma. Inputs (v, gamma_rate): the speed of C
    and the steering rate. psi' = v sin(gamma) / L (seed 003 eq. 8), O moves at
    v cos(gamma) along psi, gamma' = gamma_rate with |gamma| held within ``max_steering``.

    The ``"exact"`` integrator: gamma moves linearly in time (clipped at its limit), so the
    pose has no closed form while the wheel turns. The step is split into ``substeps``
    equal parts, each an exact arc (seed 000 eq. 25) with gamma at its own midpoint: exact
    whenever the wheel angle holds still, second order in the sub-step otherwise.

    :param wheelbase: L, from O to C, in metres
    :param max_steering: limit on |gamma| in (0, pi/2) radians; default 85 degrees
    :param max_speed: limit on |v| (m/s), unbounded by default
    :param max_steering_rate: limit on |gamma_rate| (rad/s), unbounded by default
    :param substeps: arcs per step of the ``"exact"`` integrator
    """

    name = "tricycle"
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
        self.wheelbase = _check_positive("wheelbase", wheelbase)
        self.max_steering = _check_steering_limit("max_steering", max_steering)
        self.max_speed = _check_positive("max_speed", max_speed, allow_inf=True)
        self.max_steering_rate = _check_positive("max_steering_rate", max_steering_rate, True)
        if int(substeps) != substeps or substeps < 1:
            raise ValueError(f"substeps must be a positive integer, got {substeps}")
        self.substeps = int(substeps)
        self.input_high = np.array([self.max_speed, self.max_steering_rate])
        self.input_low = -self.input_high

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

    def _steering_after(self, gamma: Array, gamma_rate: Array, elapsed: float) -> Array:
        return np.clip(gamma + gamma_rate * elapsed, -self.max_steering, self.max_steering)

    def _derivative(self, states: Array, inputs: Array) -> Array:
        v, gamma_rate = inputs[:, 0], inputs[:, 1]
        psi, gamma = states[:, 2], states[:, 3]
        speed_of_o = v * np.cos(gamma)
        pushing_past_limit = (np.abs(gamma) >= self.max_steering) & (gamma * gamma_rate > 0.0)
        return np.stack(
            [
                speed_of_o * np.cos(psi),
                speed_of_o * np.sin(psi),
                v * np.sin(gamma) / self.wheelbase,
                np.where(pushing_past_limit, 0.0, gamma_rate),
            ],
            axis=1,
        )

    def _rk4(self, states: Array, inputs: Array, dt: float) -> Array:
        result = super()._rk4(states, inputs, dt)
        result[:, 3] = np.clip(result[:, 3], -self.max_steering, self.max_steering)
        return result

    def _advance(self, states: Array, inputs: Array, dt: float, integrator: str) -> Array:
        v, gamma_rate = inputs[:, 0], inputs[:, 1]
        gamma0 = states[:, 3]
        if integrator == "euler":
            substeps, sample_at = 1, 0.0
        elif integrator == "midpoint":
            substeps, sample_at = 1, 0.5
        else:
            substeps, sample_at = self.substeps, 0.5
        h = dt / substeps
        x, y, psi = states[:, 0].copy(), states[:, 1].copy(), states[:, 2].copy()
        for index in range(substeps):
            gamma = self._steering_after(gamma0, gamma_rate, (index + sample_at) * h)
            omega = v * np.sin(gamma) / self.wheelbase
            dx, dy = _arc_displacement(psi, v * np.cos(gamma), 0.0, omega, h, integrator)
            x += dx
            y += dy
            psi += omega * h
        return np.stack([x, y, psi, self._steering_after(gamma0, gamma_rate, dt)], axis=1)

    def batch_twist(self, states: Array, inputs: Array) -> tuple[Array, Array]:
        v, gamma = inputs[:, 0], states[:, 3]
        return v * np.cos(gamma), v * np.sin(gamma) / self.wheelbase

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        # C moves at (v, omega L) in the body frame when O moves at v and the body turns at
        # omega; steer the wheel along that velocity within one step.
        wanted_gamma = np.clip(
            _steering_for(self.wheelbase, v, omega), -self.max_steering, self.max_steering
        )
        wheel_speed = np.where(v < 0.0, -1.0, 1.0) * np.hypot(v, omega * self.wheelbase)
        return np.stack([wheel_speed, (wanted_gamma - states[:, 3]) / dt], axis=1)


MODELS: dict[str, type[KinematicModel]] = {
    model.name: model for model in (ConstantVelocity, DifferentialDrive, Bicycle, Tricycle)
}


def make_model(name: str, **parameters: float) -> KinematicModel:
    """Build a model by name: ``constant_velocity``, ``diff_drive``, ``bicycle``, ``tricycle``."""
    if name not in MODELS:
        raise ValueError(f"unknown model {name!r}; known models: {sorted(MODELS)}")
    return MODELS[name](**parameters)

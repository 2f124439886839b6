"""Kinematic models of wheeled robots, batched over N robots.

Four models, after the course on mobile-robot kinematics (after Corke), Bermúdez (2003) on
the differential drive and its odometry, and Font-Llagunes & Batlle (2006) on a tricycle AGV:

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
- ``"midpoint"``: Bermúdez 2003, eq. 26, the displacement taken along the mid-step heading.
- ``"exact"``: Bermúdez 2003, eq. 25, the closed-form arc: the displacement along the mid-step
  heading shortened by ``sinc(omega dt / 2)``, which tends smoothly to 1 as omega -> 0.
- ``"rk4"``: classical Runge-Kutta on :meth:`KinematicModel.derivative`.

Any (v, omega) controller drives any model through :meth:`KinematicModel.inputs_for`, as
MATLAB's ``VehicleSpeedHeadingRate`` mode does.

The physics lives in per-robot kernels compiled by numba: :func:`advance_robot` and
:func:`robot_twist` take a model's :attr:`~KinematicModel.kernel_code` and
:attr:`~KinematicModel.kernel_parameters`, so other compiled code can step a robot without
a Python call. The batched methods loop over robots with the same kernels, so a batch gives
the same bits as its robots stepped one at a time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from mobile_envs._kernels.angles import wrap_scalar_angle

__all__ = [
    "BICYCLE",
    "CONSTANT_VELOCITY",
    "DIFF_DRIVE",
    "INTEGRATORS",
    "KERNEL_CODES",
    "MODELS",
    "TRICYCLE",
    "Bicycle",
    "ConstantVelocity",
    "DifferentialDrive",
    "KinematicModel",
    "ObservedState",
    "Tricycle",
    "advance_robot",
    "make_model",
    "robot_twist",
]

#: Integrator names; a kernel's integrator code is the name's index here.
INTEGRATORS = ("euler", "midpoint", "exact", "rk4")
_EULER, _MIDPOINT, _EXACT, _RK4 = range(len(INTEGRATORS))

# Model codes of the kernels and the layout of each model's ``kernel_parameters``, a
# C-contiguous float64 array of length 4 (input limits are not in it: kernels take inputs
# already saturated):
#   CONSTANT_VELOCITY  unused, zeros
#   DIFF_DRIVE         [wheel_radius, track_width, 0, 0]
#   BICYCLE            [wheelbase, 0, 0, 0]
#   TRICYCLE           [wheelbase, max_steering, substeps, 0]
CONSTANT_VELOCITY = 0
DIFF_DRIVE = 1
BICYCLE = 2
TRICYCLE = 3
#: Every code the kernels dispatch on; a model class with another code is refused when it is
#: defined, and the kernels raise on one, so no model can fall through to another's physics.
KERNEL_CODES = (CONSTANT_VELOCITY, DIFF_DRIVE, BICYCLE, TRICYCLE)

Array = NDArray[np.float64]


#: Python and numpy reals; a bool is refused where a number is meant.
_REAL_TYPES = (int, float, np.integer, np.floating)
#: The exact tricycle step's error falls as 1 / substeps**2: at 2**26 sub-arcs it is 2**-52
#: of one arc's, float64's resolution, so more could not be more accurate (only slower).
MAX_SUBSTEPS = 2**26


def _check_real(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, _REAL_TYPES):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    try:
        return float(value)
    except OverflowError:  # a Python int beyond float64
        raise ValueError(f"{name} must be a finite number, got {value!r}") from None


def _check_positive(name: str, value: float, allow_inf: bool = False) -> float:
    value = _check_real(name, value)
    if math.isnan(value) or value <= 0.0 or (math.isinf(value) and not allow_inf):
        kind = "a positive number" if allow_inf else "a positive finite number"
        raise ValueError(f"{name} must be {kind}, got {value}")
    return value


def _check_steering_limit(name: str, value: float) -> float:
    value = _check_real(name, value)
    if not 0.0 < value < math.pi / 2:
        raise ValueError(f"{name} must lie in (0, pi/2), got {value}")
    return value


def _check_substeps(substeps: int) -> int:
    value = _check_real("substeps", substeps)
    if not (value.is_integer() and 1 <= value <= MAX_SUBSTEPS):
        raise ValueError(f"substeps must be an integer in [1, {MAX_SUBSTEPS}], got {substeps!r}")
    return int(value)


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
    # Fresh C-contiguous writable copies: one compiled specialization serves every call.
    states = np.broadcast_to(states, (count, state_width)).copy()
    inputs = np.broadcast_to(inputs, (count, input_width)).copy()
    return states, inputs, states_batched or inputs_batched


def _check_dt(dt: float) -> float:
    return _check_positive("dt", dt)


def _check_integrator(integrator: str) -> None:
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")


# ---------------------------------------------------------------- compiled kernels
# No fastmath and no parallel: the same inputs give the same bits, batched or not.
# Kernels that take arrays are inlined into their callers by numba, which can then drop
# the reference counting of the arrays around each call: 1024 robots' twists take 2 us
# instead of 55 us.


@njit(cache=True)
def _clip(value: float, limit: float) -> float:
    """``value`` clipped to [-limit, limit], as ``np.clip`` does."""
    return min(max(value, -limit), limit)


@njit(cache=True)
def _sinc(half_turn: float) -> float:
    """sin(h) / h, and 1 at h = 0: an arc's chord over its length (Bermúdez 2003, eq. 25)."""
    if half_turn == 0.0:
        return 1.0
    return math.sin(half_turn) / half_turn


@njit(cache=True)
def _arc_displacement(heading, v_x, v_y, omega, dt, integrator_code):
    """World-frame displacement over ``dt`` of a body moving at a constant body twist.

    The body velocity (v_x, v_y) rotates with the heading; integrating exactly gives the
    displacement along the mid-step heading times sinc(omega dt / 2) (Bermúdez 2003, eq. 25).
    Euler takes the heading at the step's start, midpoint the mid-step heading unshortened.
    """
    direction, shrink = heading, 1.0
    if integrator_code != _EULER:
        half_turn = 0.5 * omega * dt
        direction = heading + half_turn
        if integrator_code == _EXACT:
            shrink = _sinc(half_turn)
    cos_d, sin_d = math.cos(direction), math.sin(direction)
    dx = (v_x * cos_d - v_y * sin_d) * dt * shrink
    dy = (v_x * sin_d + v_y * cos_d) * dt * shrink
    return dx, dy


@njit(cache=True, inline="always")
def _body_twist(model_code, parameters, inputs):
    """Body-frame velocity (v_x, v_y, omega) held by a rigid-body model's inputs."""
    if model_code == CONSTANT_VELOCITY:
        return inputs[0], inputs[1], inputs[2]
    if model_code == DIFF_DRIVE:
        wheel_radius, track_width = parameters[0], parameters[1]
        right, left = inputs[0], inputs[1]
        v = 0.5 * wheel_radius * (right + left)
        return v, 0.0, wheel_radius * (right - left) / track_width
    if model_code == BICYCLE:
        v, gamma = inputs[0], inputs[1]
        return v, 0.0, v * math.tan(gamma) / parameters[0]
    raise ValueError("unknown model kernel code")


@njit(cache=True, inline="always")
def _tricycle_rates(parameters, heading, gamma, v, gamma_rate):
    """Time derivative of the tricycle's (x, y, psi, gamma); the limit stops the wheel."""
    wheelbase, max_steering = parameters[0], parameters[1]
    speed_of_o = v * math.cos(gamma)
    pushing_past_limit = abs(gamma) >= max_steering and gamma * gamma_rate > 0.0
    return (
        speed_of_o * math.cos(heading),
        speed_of_o * math.sin(heading),
        v * math.sin(gamma) / wheelbase,
        0.0 if pushing_past_limit else gamma_rate,
    )


@njit(cache=True, inline="always")
def _rates(model_code, parameters, heading, gamma, inputs):
    """Time derivative of (x, y, heading, gamma); gamma is 0 for the rigid-body models.

    The position does not enter: the rates depend on the heading and gamma alone.
    """
    if model_code == TRICYCLE:
        return _tricycle_rates(parameters, heading, gamma, inputs[0], inputs[1])
    v_x, v_y, omega = _body_twist(model_code, parameters, inputs)
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    return v_x * cos_h - v_y * sin_h, v_x * sin_h + v_y * cos_h, omega, 0.0


@njit(cache=True)
def _rk4_increment(dt, k1, k2, k3, k4):
    return dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


@njit(cache=True, inline="always")
def _rk4(model_code, parameters, x, y, heading, gamma, inputs, dt):
    """Classical Runge-Kutta step of (x, y, heading, gamma) on :func:`_rates`."""
    k1 = _rates(model_code, parameters, heading, gamma, inputs)
    half = 0.5 * dt
    k2 = _rates(model_code, parameters, heading + half * k1[2], gamma + half * k1[3], inputs)
    k3 = _rates(model_code, parameters, heading + half * k2[2], gamma + half * k2[3], inputs)
    k4 = _rates(model_code, parameters, heading + dt * k3[2], gamma + dt * k3[3], inputs)
    return (
        x + _rk4_increment(dt, k1[0], k2[0], k3[0], k4[0]),
        y + _rk4_increment(dt, k1[1], k2[1], k3[1], k4[1]),
        heading + _rk4_increment(dt, k1[2], k2[2], k3[2], k4[2]),
        gamma + _rk4_increment(dt, k1[3], k2[3], k3[3], k4[3]),
    )


@njit(cache=True, inline="always")
def _rigid_body_arc(model_code, parameters, x, y, heading, inputs, dt, integrator_code):
    """One euler, midpoint or exact step of a model whose inputs fix its body twist."""
    v_x, v_y, omega = _body_twist(model_code, parameters, inputs)
    dx, dy = _arc_displacement(heading, v_x, v_y, omega, dt, integrator_code)
    return x + dx, y + dy, heading + omega * dt


@njit(cache=True, inline="always")
def _tricycle_arcs(parameters, x, y, psi, gamma, v, gamma_rate, dt, integrator_code):
    """One euler, midpoint or exact step of the tricycle, as arcs of constant gamma.

    gamma moves linearly in time, clipped at its limit. The exact step is ``substeps`` arcs,
    each with gamma at its own midpoint; euler and midpoint take one arc with gamma at the
    step's start and middle.
    """
    wheelbase, max_steering = parameters[0], parameters[1]
    substeps = int(parameters[2]) if integrator_code == _EXACT else 1
    sample_at = 0.0 if integrator_code == _EULER else 0.5
    h = dt / substeps
    for index in range(substeps):
        arc_gamma = _clip(gamma + gamma_rate * ((index + sample_at) * h), max_steering)
        omega = v * math.sin(arc_gamma) / wheelbase
        dx, dy = _arc_displacement(psi, v * math.cos(arc_gamma), 0.0, omega, h, integrator_code)
        x += dx
        y += dy
        psi += omega * h
    return x, y, psi, _clip(gamma + gamma_rate * dt, max_steering)


@njit(cache=True, inline="always")
def advance_robot(
    model_code: int,
    parameters: Array,
    state: Array,
    inputs: Array,
    dt: float,
    integrator_code: int,
    out: Array,
) -> None:
    """Advance one robot by ``dt`` seconds; the compiled core of :meth:`KinematicModel.step`.

    :param model_code: the model's :attr:`~KinematicModel.kernel_code`
    :param parameters: the model's :attr:`~KinematicModel.kernel_parameters`
    :param state: shape (k,), float64
    :param inputs: shape (m,), float64, already saturated
    :param dt: step length in seconds, positive
    :param integrator_code: ``INTEGRATORS.index(integrator)``
    :param out: shape (k,), receives the new state, heading wrapped to (-pi, pi]; it may be
        ``state`` itself
    """
    x, y, heading = state[0], state[1], state[2]
    gamma = state[3] if model_code == TRICYCLE else 0.0
    if integrator_code == _RK4:
        x, y, heading, gamma = _rk4(model_code, parameters, x, y, heading, gamma, inputs, dt)
        if model_code == TRICYCLE:
            gamma = _clip(gamma, parameters[1])
    elif model_code == TRICYCLE:
        x, y, heading, gamma = _tricycle_arcs(
            parameters, x, y, heading, gamma, inputs[0], inputs[1], dt, integrator_code
        )
    else:
        x, y, heading = _rigid_body_arc(
            model_code, parameters, x, y, heading, inputs, dt, integrator_code
        )
    out[0] = x
    out[1] = y
    out[2] = wrap_scalar_angle(heading)
    if model_code == TRICYCLE:
        out[3] = gamma


@njit(cache=True, inline="always")
def robot_twist(
    model_code: int, parameters: Array, state: Array, inputs: Array
) -> tuple[float, float]:
    """Forward speed v (m/s) and yaw rate omega (rad/s) of one robot's reference point.

    :param model_code: the model's :attr:`~KinematicModel.kernel_code`
    :param parameters: the model's :attr:`~KinematicModel.kernel_parameters`
    :param state: shape (k,), float64
    :param inputs: shape (m,), float64, already saturated
    """
    if model_code == TRICYCLE:
        v, gamma = inputs[0], state[3]
        return v * math.cos(gamma), v * math.sin(gamma) / parameters[0]
    v_x, _, omega = _body_twist(model_code, parameters, inputs)
    return v_x, omega


@njit(cache=True, inline="always")
def _robot_derivative(model_code, parameters, state, inputs, out):
    """Time derivative of one robot's state into ``out`` (k,)."""
    gamma = state[3] if model_code == TRICYCLE else 0.0
    rates = _rates(model_code, parameters, state[2], gamma, inputs)
    for index in range(out.shape[0]):
        out[index] = rates[index]


@njit(cache=True)
def _advance_rows(model_code, parameters, states, inputs, dt, integrator_code):
    """:func:`advance_robot` on each row of (N, k) states, into a new array."""
    out = np.empty(states.shape)
    for row in range(states.shape[0]):
        advance_robot(
            model_code, parameters, states[row], inputs[row], dt, integrator_code, out[row]
        )
    return out


@njit(cache=True)
def _twist_rows(model_code, parameters, states, inputs):
    """:func:`robot_twist` on each row: (v, omega), each of shape (N,)."""
    count = states.shape[0]
    v, omega = np.empty(count), np.empty(count)
    for row in range(count):
        v[row], omega[row] = robot_twist(model_code, parameters, states[row], inputs[row])
    return v, omega


@njit(cache=True)
def _derivative_rows(model_code, parameters, states, inputs):
    """:func:`_robot_derivative` on each row of (N, k) states, into a new array."""
    out = np.empty(states.shape)
    for row in range(states.shape[0]):
        _robot_derivative(model_code, parameters, states[row], inputs[row], out[row])
    return out


# ---------------------------------------------------------------- models

#: Where an :class:`ObservedState` is read: a column of the robot's state or of its inputs.
FROM_STATE, FROM_INPUT = range(2)


@dataclass(frozen=True)
class ObservedState:
    """A model quantity beyond the twist that the environment's observation carries.

    :param name: the observation element's name
    :param source: :data:`FROM_STATE` or :data:`FROM_INPUT`
    :param column: its column in the state or the (saturated) inputs
    :param scale: the factor that brings it to [-1, 1] (one over its largest magnitude)
    """

    name: str
    source: int
    column: int
    scale: float


MODELS: dict[str, type[KinematicModel]] = {}


class KinematicModel:
    """Base of the models: validation, saturation, integrators and the twist bridge.

    A model owns every fact the rest of the project needs about it, so the environment,
    its observation and the agents never ask which model they have. Subclasses define:

    - :attr:`name` (what :func:`make_model` and the envs' ``model=`` take), :attr:`env_id`
      (the id prefix, ``"DiffDrive"`` in ``mobile_envs/DiffDrive-Segments-v0``) and
      :attr:`env_defaults` (the finite limits the environments build it with);
    - :attr:`state_names`, :attr:`input_names`, :attr:`parameter_names` and the input limits;
    - :attr:`top_speed`, :attr:`top_yaw_rate`, :attr:`min_turning_radius` and
      :attr:`observed_state`;
    - :attr:`kernel_code` (one of :data:`KERNEL_CODES`; anything else is refused when the
      class is defined) and :attr:`kernel_parameters`, which the compiled kernels
      (:func:`advance_robot`, :func:`robot_twist`) read, and :meth:`_inputs_for`.

    Defining a subclass with a ``name`` registers it in :data:`MODELS`, and
    ``import mobile_envs`` registers its env ids.
    """

    name: ClassVar[str]
    env_id: ClassVar[str]
    env_defaults: ClassVar[dict[str, float]]
    state_names: ClassVar[tuple[str, ...]]
    input_names: ClassVar[tuple[str, ...]]
    #: The constructor's parameters, stored as attributes of the same names.
    parameter_names: ClassVar[tuple[str, ...]]
    #: The model's code in the kernels, one of :data:`KERNEL_CODES`.
    kernel_code: ClassVar[int]
    #: The model's parameters for the kernels, float64 of length 4, laid out as the comment
    #: on the model codes (CONSTANT_VELOCITY, ...) says.
    kernel_parameters: Array

    input_low: Array
    input_high: Array

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "kernel_code" in vars(cls) and cls.kernel_code not in KERNEL_CODES:
            raise TypeError(
                f"{cls.__name__}.kernel_code = {cls.kernel_code!r} is not a code the kernels "
                f"dispatch on {KERNEL_CODES}; add its branches to the kernels first"
            )
        if "name" in vars(cls):
            MODELS[cls.name] = cls

    @property
    def top_speed(self) -> float:
        """The largest forward speed |v| (m/s) of the reference point within the limits."""
        raise NotImplementedError

    @property
    def top_yaw_rate(self) -> float:
        """The largest |omega| (rad/s) the model reaches within its limits."""
        raise NotImplementedError

    @property
    def min_turning_radius(self) -> float:
        """The smallest turning radius (m) of the reference point: 0 for models that turn
        on the spot."""
        raise NotImplementedError

    @property
    def observed_state(self) -> tuple[ObservedState, ...]:
        """What the observation shows of the model beyond its twist (none by default)."""
        return ()

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
        result = _derivative_rows(
            self.kernel_code, self.kernel_parameters, states, self.saturate(inputs)
        )
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
        :return: the new states, a new (N, k) array
        """
        return _advance_rows(
            self.kernel_code,
            self.kernel_parameters,
            states,
            inputs,
            float(dt),
            INTEGRATORS.index(integrator),
        )

    def twist(self, state: ArrayLike, u: ArrayLike) -> tuple[Array, Array]:
        """Forward speed v (m/s) and yaw rate omega (rad/s) of the reference point.

        :return: ``(v, omega)``, scalars (0-d arrays) for a single robot, (N,) for a batch
        """
        states, inputs, batched = _as_batch_pair(state, u, self.state_dim, self.input_dim)
        v, omega = self.batch_twist(states, self.saturate(inputs))
        return (v, omega) if batched else (v[0], omega[0])

    def batch_twist(self, states: Array, inputs: Array) -> tuple[Array, Array]:
        """:meth:`twist` on validated, saturated (N, k) states and (N, m) inputs."""
        return _twist_rows(self.kernel_code, self.kernel_parameters, states, inputs)

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

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        raise NotImplementedError

    def __repr__(self) -> str:
        params = ", ".join(f"{key}={value!r}" for key, value in self.parameters().items())
        return f"{type(self).__name__}({params})"

    def parameters(self) -> dict[str, float]:
        """The constructor arguments that rebuild this model."""
        return {name: getattr(self, name) for name in self.parameter_names}


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
    kernel_code = CONSTANT_VELOCITY

    def __init__(self, max_speed: float = math.inf, max_angular_speed: float = math.inf):
        self.max_speed = _check_positive("max_speed", max_speed, allow_inf=True)
        self.max_angular_speed = _check_positive(
            "max_angular_speed", max_angular_speed, allow_inf=True
        )
        self.input_high = np.array([self.max_speed, self.max_speed, self.max_angular_speed])
        self.input_low = -self.input_high
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


class DifferentialDrive(KinematicModel):
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
    kernel_code = DIFF_DRIVE

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
        self.kernel_parameters = np.array([self.wheel_radius, self.track_width, 0.0, 0.0])

    @property
    def top_speed(self) -> float:
        return self.wheel_radius * self.max_wheel_speed

    @property
    def top_yaw_rate(self) -> float:
        return 2.0 * self.wheel_radius * self.max_wheel_speed / self.track_width

    @property
    def min_turning_radius(self) -> float:
        return 0.0

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


class Bicycle(KinematicModel):
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
    kernel_code = BICYCLE

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
        self.kernel_parameters = np.array([self.wheelbase, 0.0, 0.0, 0.0])

    @property
    def top_speed(self) -> float:
        return self.max_speed

    @property
    def top_yaw_rate(self) -> float:
        return self.max_speed * math.tan(self.max_steering) / self.wheelbase

    @property
    def min_turning_radius(self) -> float:
        return self.wheelbase / math.tan(self.max_steering)

    def _inputs_for(self, states: Array, v: Array, omega: Array, dt: float) -> Array:
        return np.stack([v, _steering_for(self.wheelbase, v, omega)], axis=1)


class Tricycle(KinematicModel):
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
    :param max_steering: limit on |gamma| in (0, pi/2) radians; default 85 degrees
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
    kernel_code = TRICYCLE

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
        self.substeps = _check_substeps(substeps)
        self.input_high = np.array([self.max_speed, self.max_steering_rate])
        self.input_low = -self.input_high
        self.kernel_parameters = np.array(
            [self.wheelbase, self.max_steering, float(self.substeps), 0.0]
        )

    @property
    def top_speed(self) -> float:
        """The top speed of C (O moves at v cos(gamma), never faster)."""
        return self.max_speed

    @property
    def top_yaw_rate(self) -> float:
        return self.max_speed * math.sin(self.max_steering) / self.wheelbase

    @property
    def min_turning_radius(self) -> float:
        """``L / tan(max_steering)``: O circles 8.7 cm from the centre at 85 degrees."""
        return self.wheelbase / math.tan(self.max_steering)

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
            _steering_for(self.wheelbase, v, omega), -self.max_steering, self.max_steering
        )
        wheel_speed = np.where(v < 0.0, -1.0, 1.0) * np.hypot(v, omega * self.wheelbase)
        return np.stack([wheel_speed, (wanted_gamma - states[:, 3]) / dt], axis=1)


def make_model(name: str, **parameters: float) -> KinematicModel:
    """Build a model by name (a key of :data:`MODELS`: ``constant_velocity``, ``diff_drive``,
    ``bicycle``, ``tricycle``)."""
    if name not in MODELS:
        raise ValueError(f"unknown model {name!r}; known models: {sorted(MODELS)}")
    return MODELS[name](**parameters)

"""What every kinematic model shares: validation, saturation, the integrators and the twist
bridge, and the catalogue of models by name.

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

The physics lives in the model's module, compiled by numba (:attr:`KinematicModel.compiled`
lists what it holds), so other compiled code steps a robot without a Python call: kernels
written once call it through :func:`mobile_envs._kernels.specialize.for_model`. The batched
methods here loop over robots with the same functions, so a batch gives the same bits as
its robots stepped one at a time.
"""

from __future__ import annotations

import sys
import types
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from mobile_envs._kernels.specialize import fallback, for_model, model, model_namespace, per_model
from mobile_envs.robots.motion import INTEGRATORS
from mobile_envs.validation import as_positive

Array = NDArray[np.float64]

#: What a model's module must hold for the compiled code, and what each does for one robot
#: (``parameters`` is the model's :attr:`~KinematicModel.kernel_parameters`; inputs arrive
#: saturated).
COMPILED_FUNCTIONS = {
    "advance": "(parameters, state, inputs, dt, integrator_code, out): the state after dt "
    "into out (which may be state), the heading wrapped",
    "twist": "(parameters, state, inputs) -> (v, omega) of the reference point",
    "rates": "(parameters, state, inputs, out): the state's time derivative into out",
}
#: What a model with wheel or steering encoders adds (:attr:`KinematicModel.has_encoders`).
ENCODER_FUNCTION = (
    "encoder_increments",
    "(parameters, encoders, state_before, state_after, inputs, dt, residuals) -> (dD, dtheta)",
)


@njit(cache=True)
def _no_encoders(parameters, encoders, state_before, state_after, inputs, dt, residuals):
    """A robot without encoders has nothing to count: no model falls through to another's."""
    if parameters.shape[0] >= 0:  # always; the return below only gives the call its type
        raise ValueError("this robot has no encoders for odometry to count")
    return 0.0, 0.0


# Compiled code that counts encoders (odometry) compiles for every model, whatever branch
# it takes at run time.
fallback(ENCODER_FUNCTION[0], _no_encoders)


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
    return as_positive("dt", dt)


def _check_integrator(integrator: str) -> None:
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")


# ---------------------------------------------------------------- batched rows
# Templates compiled per model (for_model): a loop over robots of the model's own functions.


@per_model()
def _advance_rows(parameters, states, inputs, dt, integrator_code):
    """``model.advance`` on each row of (N, k) states, into a new array."""
    out = np.empty(states.shape)
    for row in range(states.shape[0]):
        model.advance(parameters, states[row], inputs[row], dt, integrator_code, out[row])
    return out


@per_model()
def _twist_rows(parameters, states, inputs):
    """``model.twist`` on each row: (v, omega), each of shape (N,)."""
    count = states.shape[0]
    v, omega = np.empty(count), np.empty(count)
    for row in range(count):
        v[row], omega[row] = model.twist(parameters, states[row], inputs[row])
    return v, omega


@per_model()
def _derivative_rows(parameters, states, inputs):
    """``model.rates`` on each row of (N, k) states, into a new array."""
    out = np.empty(states.shape)
    for row in range(states.shape[0]):
        model.rates(parameters, states[row], inputs[row], out[row])
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


#: The models by name (:attr:`KinematicModel.name`); a subclass with a name registers itself.
MODELS: dict[str, type[KinematicModel]] = {}


class KinematicModel:
    """Base of the models: validation, saturation, integrators and the twist bridge.

    A model owns every fact the rest of the project needs about it, so the environment,
    its observation and the agents never ask which model they have. A model is one module
    (``mobile_envs/robots/diff_drive.py``): the class and its compiled functions. The class
    defines:

    - :attr:`name` (what :func:`make_model` and the envs' ``model=`` take), :attr:`env_id`
      (the id prefix, ``"DiffDrive"`` in ``mobile_envs/DiffDrive-Segments-v0``) and
      :attr:`env_defaults` (the finite limits the environments build it with);
    - :attr:`state_names`, :attr:`input_names`, :attr:`parameter_names` and the input limits;
    - :attr:`top_speed`, :attr:`top_yaw_rate`, :attr:`min_turning_radius` and
      :attr:`observed_state`;
    - :attr:`kernel_parameters` (its parameters as the compiled functions read them) and
      :meth:`_inputs_for`.

    Its module (:attr:`compiled`, by default the one the class is defined in) holds the
    compiled functions of :data:`COMPILED_FUNCTIONS` (a rigid-body model takes them from
    :mod:`mobile_envs.robots.rigid_body` and defines ``body_twist``), and
    ``encoder_increments`` when the robot has encoders (:attr:`has_encoders`). A class whose
    module lacks one is refused when it is defined.

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
    #: Whether the robot has encoders that wheel odometry can count
    #: (:mod:`mobile_envs.sensing.odometry`): its module then holds ``encoder_increments``.
    has_encoders: ClassVar[bool] = False
    #: Whether its traction encoder turns with a wheel whose radius the model does not know
    #: (the car-like robots): odometry that counts its turns must be told the radius.
    traction_radius_unknown: ClassVar[bool] = False
    #: The errors a true robot may have against this nominal model, by name (fractions of a
    #: parameter, ``steering_offset`` in radians): see :meth:`true_parameters`.
    parameter_errors: ClassVar[tuple[str, ...]] = ()
    #: The module of the model's compiled functions.
    compiled: ClassVar[types.ModuleType]
    #: The model's parameters for its compiled functions, a float64 array laid out as its
    #: module says.
    kernel_parameters: Array

    input_low: Array
    input_high: Array

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "compiled" not in vars(cls):
            cls.compiled = sys.modules[cls.__module__]
        if "name" in vars(cls):
            required = dict(COMPILED_FUNCTIONS)
            if cls.has_encoders:
                required[ENCODER_FUNCTION[0]] = ENCODER_FUNCTION[1]
            missing = [name for name in required if not hasattr(cls.compiled, name)]
            if missing:
                needs = "; ".join(f"{name}{required[name]}" for name in missing)
                raise TypeError(
                    f"{cls.__name__}'s module {cls.compiled.__name__} lacks the compiled "
                    f"functions {missing}: {needs}"
                )
            MODELS[cls.name] = cls

    @property
    def kernels(self) -> types.ModuleType:
        """The model's compiled functions (``kernels.advance``, ``kernels.twist``, ...), to call
        from Python or from compiled code on one robot with :attr:`kernel_parameters`."""
        return model_namespace(self.compiled)

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
        rows = for_model(_derivative_rows, self.compiled)
        result = rows(self.kernel_parameters, states, self.saturate(inputs))
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
        rows = for_model(_advance_rows, self.compiled)
        return rows(
            self.kernel_parameters, states, inputs, float(dt), INTEGRATORS.index(integrator)
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
        rows = for_model(_twist_rows, self.compiled)
        v, omega = rows(self.kernel_parameters, states, inputs)
        return v, omega

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

    def true_parameters(self, errors: Array) -> Array:
        """The :attr:`kernel_parameters` of true robots that differ from this nominal model by
        ``errors``: the compiled functions move a robot with them exactly as a model built
        with the true parameters would (a plant's ``parameter_errors``).

        :param errors: (n, len(parameter_errors)) in the order of :attr:`parameter_errors`:
            fractions e of a parameter (the true value is nominal x (1 + e)), or an offset in
            radians for ``steering_offset``; zeros give the nominal model's bits
        :return: (n, len(kernel_parameters)) float64, C-contiguous
        """
        rows = np.tile(self.kernel_parameters, (len(errors), 1))
        for column, name in enumerate(self.parameter_errors):
            self._apply_error(rows, name, np.asarray(errors, np.float64)[:, column])
        return rows

    def _apply_error(self, rows: Array, name: str, error: Array) -> None:
        """Write error ``name`` of each true robot into its row of kernel parameters."""
        raise NotImplementedError


def make_model(name: str, **parameters: float) -> KinematicModel:
    """Build a model by name (a key of :data:`MODELS`: ``constant_velocity``, ``diff_drive``,
    ``bicycle``, ``tricycle``, ``mecanum``)."""
    if name not in MODELS:
        raise ValueError(f"unknown model {name!r}; known models: {sorted(MODELS)}")
    return MODELS[name](**parameters)

"""The plant: what the true robot does with a command (delay, lag, wrong parameters, slip).

Controllers and the observation's scaling use the nominal model; with a plant the true robot
does not do exactly what it is told, for the reasons the seeds name (the course, after
Corke: imprecise parameters, a deflated wheel; Bermúdez 2003: wheel slip and uneven floors,
the non-systematic errors of eq. 17):

- **delay** (s, a whole number d of steps): the native inputs applied during step k are those
  commanded at step k - d; before any command has arrived the robot applies zero inputs.
- **time_constant** tau (s): a first-order lag on each native input, updated once a step and
  held over it: ``u_k = u_{k-1} + (1 - exp(-dt / tau)) (c_k - u_{k-1})``, ``u_0 = 0``, with
  ``c_k`` the (delayed) command; exact for a lag driven by a command held over the step.
- **parameter_errors**: the true robot is the nominal model with its parameters off by the
  fractions given (:attr:`~mobile_envs.robots.model.KinematicModel.parameter_errors` names
  them per model; ``steering_offset`` is in radians): it moves exactly as a model built
  with the true parameters would.
- **slip** (K_D, K_Dtheta, K_theta): each step the true pose gets zero-mean Gaussian noise
  of eq. 17's covariance, Q = diag(K_D |dD cos th|, K_D |dD sin th|, K_Dth |dD| + K_th |dth|),
  on the step's true distance dD and heading change dth and the heading th at its start;
  each coefficient at most :data:`MAX_SLIP`.
- **randomize**: per-episode draws at reset from each robot's own generator: ``delay`` and
  ``time_constant`` ranges (s; the delay a whole number of steps within its range), one size
  for every ``parameter_errors`` entry (each drawn uniform in +-size; ``steering_offset``
  may have its own, in radians; the draws replace fixed errors), and a range of scales on
  ``slip`` (on Crowley's coefficients when no ``slip`` is given; at most
  :data:`MAX_SLIP_SCALE`). A delay is at most :data:`MAX_DELAY`.

Presets: ``"ideal"`` (no plant) and ``"realistic"`` (:data:`PRESETS`). Everything runs in the
compiled step for all robots at once (:func:`actuate`, :func:`slip`), each robot drawing
from its own generator, so the vector env equals N single envs bit for bit.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from mobile_envs._kernels import exact_math
from mobile_envs._kernels.angles import wrap_scalar_angle
from mobile_envs.robots import KinematicModel
from mobile_envs.sensing.odometry import (
    DEFAULT_K_DISTANCE,
    DEFAULT_K_DISTANCE_HEADING,
    DEFAULT_K_HEADING,
    odometry_variances,
)
from mobile_envs.validation import as_non_negative, as_real, is_list

Array = NDArray[np.float64]
Indices = NDArray[np.int64]

#: Eq. 17's coefficients of Crowley & Chenavier, as seed 000 quotes them.
CROWLEY_SLIP = (DEFAULT_K_DISTANCE, DEFAULT_K_DISTANCE_HEADING, DEFAULT_K_HEADING)
#: The named plants; ``"ideal"`` is no plant at all (``plant=None``).
PRESETS: dict[str, dict[str, Any] | None] = {
    "ideal": None,
    "realistic": {
        "delay": 0.1,
        "time_constant": 0.1,
        "slip": CROWLEY_SLIP,
        "randomize": {"parameter_errors": 0.03, "steering_offset": 0.02},
    },
}
#: The presets with ids of their own: ``mobile_envs/<Model>-<PathSet>-Realistic-v0``.
PRESET_IDS = {"Realistic": "realistic"}
#: A delay must be a whole number of steps within this (s).
DELAY_TOLERANCE = 1e-9
#: The longest delay (s): each robot keeps its commands in flight, one row a step.
MAX_DELAY = 60.0
#: The largest slip coefficient (m^2/m or rad^2/m or rad^2/rad: a standard deviation of 1 m
#: per metre driven, a thousand times Crowley's K_D) and the largest scale a randomized slip
#: draws: beyond them the true robot leaves any path in one step, and its rewards overflow.
MAX_SLIP, MAX_SLIP_SCALE = 1.0, 100.0
#: Slip normals drawn per robot at once (three a step), refilled when used up.
SLIP_BLOCK_STEPS = 64
_KEYS = ("delay", "time_constant", "parameter_errors", "slip", "randomize")
_RANDOMIZED_KEYS = ("delay", "time_constant", "parameter_errors", "steering_offset", "slip")


class PlantFloat(enum.IntEnum):
    """Columns of the plant's per-robot floats."""

    #: 1 - exp(-dt / tau) of the lag; 1 without lag (the command is applied as it is).
    LAG = 0
    SLIP_DISTANCE = 1  # K_D (m^2/m)
    SLIP_DISTANCE_HEADING = 2  # K_Dtheta (rad^2/m)
    SLIP_HEADING = 3  # K_theta (rad^2/rad)


class PlantInt(enum.IntEnum):
    """Columns of the plant's per-robot ints."""

    DELAY_STEPS = 0
    #: Where the next command goes in the robot's ring of commands.
    COMMAND_CURSOR = 1
    #: The next unused row of the robot's block of slip normals.
    SLIP_CURSOR = 2


# ---------------------------------------------------------------- compiled steps


@njit(cache=True, inline="always")
def actuate(i, actions, action_map, plant_floats, plant_ints, commands, inputs):
    """Robot ``i``'s realized native inputs this step into ``inputs[i]``: its command (the
    action mapped by ``action_map``'s centre and half range) enters the ring of commands,
    the one from ``DELAY_STEPS`` steps ago leaves it (zero before any has arrived) and the
    lag moves the inputs toward it."""
    slots = commands.shape[1]
    cursor = plant_ints[i, PlantInt.COMMAND_CURSOR]
    for j in range(inputs.shape[1]):
        commands[i, cursor, j] = action_map[0, j] + actions[i, j] * action_map[1, j]
    delayed = cursor - plant_ints[i, PlantInt.DELAY_STEPS]
    if delayed < 0:
        delayed += slots
    plant_ints[i, PlantInt.COMMAND_CURSOR] = cursor + 1 if cursor + 1 < slots else 0
    lag_towards(plant_floats[i, PlantFloat.LAG], commands[i, delayed], inputs[i])


@njit(cache=True, inline="always")
def lag_towards(lag, command, realized):
    """The first-order lag, once a step: ``realized`` (the native inputs applied last step)
    moves toward ``command`` in place by the fraction ``lag`` = 1 - exp(-dt / tau); with
    ``lag`` 1 (no lag) it becomes the command, bit for bit."""
    if lag == 1.0:
        for j in range(realized.shape[0]):
            realized[j] = command[j]
    else:
        for j in range(realized.shape[0]):
            realized[j] += lag * (command[j] - realized[j])


@njit(cache=True, inline="always")
def slip(i, start_x, start_y, start_heading, state, plant_floats, plant_ints, normals):
    """Add eq. 17's noise to robot ``i``'s true pose after its step from (start_x, start_y,
    start_heading), with three standard normals from its block (none drawn without slip)."""
    k_distance = plant_floats[i, PlantFloat.SLIP_DISTANCE]
    k_distance_heading = plant_floats[i, PlantFloat.SLIP_DISTANCE_HEADING]
    k_heading = plant_floats[i, PlantFloat.SLIP_HEADING]
    if k_distance == 0.0 and k_distance_heading == 0.0 and k_heading == 0.0:
        return
    distance = math.hypot(state[i, 0] - start_x, state[i, 1] - start_y)
    turn = wrap_scalar_angle(state[i, 2] - start_heading)
    q11, q22, q33 = odometry_variances(
        distance, turn, start_heading, k_distance, k_distance_heading, k_heading
    )
    draw = normals[i, plant_ints[i, PlantInt.SLIP_CURSOR]]
    plant_ints[i, PlantInt.SLIP_CURSOR] += 1
    state[i, 0] += math.sqrt(q11) * draw[0]
    state[i, 1] += math.sqrt(q22) * draw[1]
    state[i, 2] = wrap_scalar_angle(state[i, 2] + math.sqrt(q33) * draw[2])


# ---------------------------------------------------------------- settings


def _range(name: str, value: Any, maximum: float = math.inf, unit: str = "") -> tuple[float, float]:
    if not is_list(value) or len(value) != 2:
        raise ValueError(f"{name} must be a (low, high) range, got {value!r}")
    low = as_non_negative(name, value[0], maximum, unit)
    high = as_non_negative(name, value[1], maximum, unit)
    if low > high:
        raise ValueError(f"{name} must have low <= high, got {value!r}")
    return low, high


def _slip(name: str, value: Any) -> tuple[float, float, float]:
    if not is_list(value) or len(value) != 3:
        raise ValueError(f"{name} must be (K_D, K_Dtheta, K_theta), got {value!r}")
    first, second, third = (as_non_negative(name, coefficient, MAX_SLIP) for coefficient in value)
    return first, second, third


def _steps(name: str, seconds: float, dt: float) -> int:
    steps = round(seconds / dt)
    if abs(steps * dt - seconds) > DELAY_TOLERANCE:
        raise ValueError(f"{name} must be a multiple of dt = {dt} s, got {seconds} s")
    return steps


@dataclass(frozen=True)
class PlantSettings:
    """A plant's settings, validated against the env's model and step.

    :param model: the nominal model, whose :attr:`parameter_errors` the errors must name
    :param dt: the env's step (s)
    :param delay: s, a multiple of ``dt`` within 1e-9 s, >= 0
    :param time_constant: s, >= 0; 0 is no lag
    :param parameter_errors: the true robot's errors by name (fractions > -1; rad for
        ``steering_offset``)
    :param slip: eq. 17's (K_D, K_Dtheta, K_theta) acting on the robot itself, each in [0, MAX_SLIP]
    :param randomize: per-episode draws (see the module's manual), or None
    """

    model: KinematicModel
    dt: float
    delay: float = 0.0
    time_constant: float = 0.0
    parameter_errors: Mapping[str, float] = field(default_factory=dict)
    slip: tuple[float, float, float] = (0.0, 0.0, 0.0)
    randomize: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        delay = as_non_negative("plant delay", self.delay, MAX_DELAY, " s")
        object.__setattr__(self, "delay", delay)
        _steps("plant delay", self.delay, self.dt)
        tau = as_non_negative("plant time_constant", self.time_constant)
        object.__setattr__(self, "time_constant", tau)
        object.__setattr__(self, "parameter_errors", self._errors(self.parameter_errors))
        object.__setattr__(self, "slip", _slip("plant slip", self.slip))
        object.__setattr__(self, "randomize", self._randomization(self.randomize))

    def _errors(self, errors: Any) -> dict[str, float]:
        if not isinstance(errors, Mapping):
            raise ValueError(f"plant parameter_errors must be a dict, got {errors!r}")
        known = self.model.parameter_errors
        checked = {}
        for name, value in errors.items():
            if name not in known:
                raise ValueError(
                    f"plant parameter_errors: {type(self.model).__name__} has no parameter "
                    f"{name!r}; its parameter errors: {list(known)}"
                )
            number = as_real(f"plant parameter_errors[{name!r}]", value)
            if name != "steering_offset" and number <= -1.0:
                raise ValueError(
                    f"plant parameter_errors[{name!r}] must be a fraction > -1, got {value!r}"
                )
            checked[name] = number
        return checked

    def _randomization(self, randomize: Any) -> dict[str, Any]:
        if randomize is None:
            return {}
        if not isinstance(randomize, Mapping):
            raise ValueError(f"plant randomize must be a dict, got {randomize!r}")
        unknown = sorted(set(randomize) - set(_RANDOMIZED_KEYS), key=str)
        if unknown:
            raise ValueError(
                f"plant randomize: unknown keys {unknown}; known: {list(_RANDOMIZED_KEYS)}"
            )
        checked: dict[str, Any] = {}
        if "delay" in randomize:
            low, high = _range("plant randomize delay", randomize["delay"], MAX_DELAY, " s")
            first, last = math.ceil(low / self.dt - 1e-9), math.floor(high / self.dt + 1e-9)
            if first > last:
                raise ValueError(
                    f"plant randomize delay {randomize['delay']!r} holds no whole number of "
                    f"steps of dt = {self.dt} s"
                )
            checked["delay"] = (first, last)
        if "time_constant" in randomize:
            checked["time_constant"] = _range(
                "plant randomize time_constant", randomize["time_constant"]
            )
        for key in ("parameter_errors", "steering_offset"):
            if key in randomize:
                size = as_non_negative(f"plant randomize {key}", randomize[key])
                if key == "parameter_errors" and size >= 1.0:
                    raise ValueError(f"plant randomize parameter_errors must be < 1, got {size}")
                checked[key] = size
        if "slip" in randomize:
            checked["slip"] = _range("plant randomize slip", randomize["slip"], MAX_SLIP_SCALE)
        return checked

    @property
    def delay_steps(self) -> int:
        """The fixed delay in steps."""
        return _steps("plant delay", self.delay, self.dt)

    @property
    def max_delay_steps(self) -> int:
        """The longest delay any episode can draw, in steps."""
        drawn = self.randomize.get("delay")
        return self.delay_steps if drawn is None else max(drawn[1], self.delay_steps)

    @property
    def slip_base(self) -> tuple[float, float, float]:
        """The coefficients a randomized slip scale multiplies: ``slip``, or Crowley's when
        only the scale is given."""
        if "slip" in self.randomize and not any(self.slip):
            return CROWLEY_SLIP
        return self.slip

    @property
    def slips(self) -> bool:
        """Whether any episode can slip."""
        return any(self.slip_base) and self.randomize.get("slip", (1.0, 1.0))[1] > 0.0

    def describe(self) -> dict[str, Any]:
        """The settings as a plain dict (what ``plant=`` would take to rebuild them)."""
        described: dict[str, Any] = {
            "delay": self.delay,
            "time_constant": self.time_constant,
            "parameter_errors": dict(self.parameter_errors),
            "slip": list(self.slip),
        }
        if self.randomize:
            randomize = dict(self.randomize)
            if "delay" in randomize:
                first, last = randomize["delay"]
                randomize["delay"] = (first * self.dt, last * self.dt)
            described["randomize"] = randomize
        return described


def plant_settings(plant: Any, model: KinematicModel, dt: float) -> PlantSettings | None:
    """The env's ``plant`` argument as settings: None or ``"ideal"`` for the ideal robot, a
    preset name, a dict of settings, or :class:`PlantSettings` (checked against the model).

    :raises ValueError: naming the unknown preset or key, or the setting that is wrong
    """
    if isinstance(plant, PlantSettings):
        plant = plant.describe()
    if isinstance(plant, str):
        if plant not in PRESETS:
            raise ValueError(f"unknown plant preset {plant!r}; known presets: {list(PRESETS)}")
        plant = PRESETS[plant]
    if plant is None:
        return None
    if not isinstance(plant, Mapping):
        raise ValueError(f"plant must be None, a preset name or a dict, got {plant!r}")
    unknown = sorted(set(plant) - set(_KEYS), key=str)
    if unknown:
        raise ValueError(f"plant: unknown keys {unknown}; known keys: {list(_KEYS)}")
    return PlantSettings(model, dt, **plant)


# ---------------------------------------------------------------- the robots' plant


class Plant:
    """The plant's per-robot arrays and their reset; the compiled step reads them as the
    tuple :attr:`kernel_arrays`.

    :param settings: the validated settings
    :param num_robots: N
    """

    def __init__(self, settings: PlantSettings, num_robots: int) -> None:
        self.settings = settings
        model = settings.model
        self.errors = np.zeros((num_robots, len(model.parameter_errors)))
        self.true_parameters = model.true_parameters(self.errors)
        self.floats = np.zeros((num_robots, len(PlantFloat)))
        self.ints = np.zeros((num_robots, len(PlantInt)), dtype=np.int64)
        self.commands = np.zeros((num_robots, settings.max_delay_steps + 1, model.input_dim))
        blocks = SLIP_BLOCK_STEPS if settings.slips else 0
        self.slip_normals = np.zeros((num_robots, blocks, 3))
        #: Each robot's drawn delay (s), time constant (s), slip coefficients and parameter
        #: errors, as its reset's info reports them.
        self.delay = np.zeros(num_robots)
        self.time_constant = np.zeros(num_robots)
        self.slip = np.zeros((num_robots, 3))
        self.kernel_arrays = (
            self.true_parameters,
            self.floats,
            self.ints,
            self.commands,
            self.slip_normals,
        )

    def reset(self, indices: Indices, rngs: Sequence[np.random.Generator]) -> None:
        """Start robots ``indices``' episodes: draw their plant from their own generators
        (in the order delay, time constant, parameter errors, slip scale, then the first
        block of slip normals), empty their commands."""
        settings, model = self.settings, self.settings.model
        count = len(indices)
        delay_steps = np.full(count, settings.delay_steps, dtype=np.int64)
        tau = np.full(count, settings.time_constant)
        errors = np.tile(
            [settings.parameter_errors.get(name, 0.0) for name in model.parameter_errors],
            (count, 1),
        )
        scale = np.ones(count)
        if settings.randomize:
            self._draw(indices, rngs, delay_steps, tau, errors, scale)
        self.delay[indices] = delay_steps * settings.dt
        self.time_constant[indices] = tau
        self.errors[indices] = errors
        self.slip[indices] = np.multiply.outer(scale, settings.slip_base)
        self.ints[indices, PlantInt.DELAY_STEPS] = delay_steps
        with np.errstate(divide="ignore", over="ignore"):  # tau near 0: no lag
            self.floats[indices, PlantFloat.LAG] = np.where(
                tau == 0.0, 1.0, -exact_math.expm1(-settings.dt / tau)
            )
        self.floats[indices, PlantFloat.SLIP_DISTANCE :] = self.slip[indices]
        self.true_parameters[indices] = model.true_parameters(errors)
        self.commands[indices] = 0.0
        self.ints[indices, PlantInt.COMMAND_CURSOR] = 0
        if self.slip_normals.shape[1]:
            for index in indices.tolist():
                self._refill(index, rngs[index])

    def _draw(
        self,
        indices: Indices,
        rngs: Sequence[np.random.Generator],
        delay_steps: NDArray[np.int64],
        tau: Array,
        errors: Array,
        scale: Array,
    ) -> None:
        """Draw each robot's randomized settings from its own generator, into row k of the
        arrays for robot ``indices[k]``."""
        randomize, model = self.settings.randomize, self.settings.model
        drawn_errors = "parameter_errors" in randomize or "steering_offset" in randomize
        fraction = randomize.get("parameter_errors", 0.0)
        offsets = [name == "steering_offset" for name in model.parameter_errors]
        sizes = np.where(offsets, randomize.get("steering_offset", fraction), fraction)
        for k, index in enumerate(indices.tolist()):
            rng = rngs[index]
            if "delay" in randomize:
                first, last = randomize["delay"]
                delay_steps[k] = rng.integers(first, last + 1)
            if "time_constant" in randomize:
                tau[k] = rng.uniform(*randomize["time_constant"])
            if drawn_errors:
                errors[k] = rng.uniform(-1.0, 1.0, len(sizes)) * sizes
            if "slip" in randomize:
                scale[k] = rng.uniform(*randomize["slip"])

    def refill_used(self, indices: Indices, rngs: Sequence[np.random.Generator]) -> None:
        """Draw a new block of slip normals for each robot of ``indices`` that used up its
        own (after a step)."""
        if not self.slip_normals.shape[1]:
            return
        used = indices[self.ints[indices, PlantInt.SLIP_CURSOR] == self.slip_normals.shape[1]]
        for index in used.tolist():
            self._refill(index, rngs[index])

    def _refill(self, index: int, rng: np.random.Generator) -> None:
        rng.standard_normal(out=self.slip_normals[index])
        self.ints[index, PlantInt.SLIP_CURSOR] = 0

"""The environments' settings, validated once for the single and the vector environment."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from mobile_envs.robots import INTEGRATORS, MODELS, KinematicModel, make_model
from mobile_envs.sensing.localization import Localization, make_localization
from mobile_envs.sensing.sensors import RangeSensor, Sensor, SensorSpec, make_sensors
from mobile_envs.sim.observation import ObservationLayout
from mobile_envs.sim.plant import plant_settings
from mobile_envs.tracks.catalogue import path_set
from mobile_envs.tracks.sets import FixedPathSet, PathSet, Track
from mobile_envs.validation import MAX_COUNT, REAL_TYPES, as_count, as_positive, as_real, is_list
from mobile_envs.world.paths import MAX_COORDINATE, Path

__all__ = [
    "MAX_STEPS",
    "NOMINAL_SPEED",
    "REACH",
    "REWARD_LIMIT",
    "STALL_PROGRESS",
    "TIME_LIMIT_FACTOR",
    "WORLD_EXTENT",
    "CoreConfig",
    "PathsArgument",
    "RewardWeights",
    "available_threads",
    "build_model",
    "build_path_set",
    "default_sensors",
    "make_core_config",
]

#: Progress (m) beyond the farthest point reached that counts as advancing; see stall_time.
STALL_PROGRESS = 0.01
#: Nominal speed that sets the time limit, and how many nominal traversals it allows.
NOMINAL_SPEED = 0.6
TIME_LIMIT_FACTOR = 3.0

# The bounds below follow from the world's size and the number types, not from taste: each
# keeps a computed quantity finite, and the error names the setting that would break it.
#: Step counters are int64: no step limit beyond this can be counted to.
MAX_STEPS = MAX_COUNT
#: The largest float64 below 2**63, the time limit a path's length saturates at (a float
#: equal to 2**63 would wrap to INT64_MIN when cast).
_MAX_STEPS_FLOAT = float(np.nextafter(2.0**63, 0.0))
#: Metres: paths and mazes lie within this of the origin on each axis, so no length setting
#: (radii, the off-track distance, the start noise, one step's travel) may exceed it.
WORLD_EXTENT = MAX_COORDINATE
#: Metres: a bound on every distance a step's reward sees. Path points lie within sqrt(2) E
#: of the origin (E = WORLD_EXTENT), a robot starts within 2 sqrt(2) E of it (start noise
#: <= E per axis), stays within max_cross_track <= E of its path until its episode ends and
#: moves at most E a step: |cross-track error| <= (3 sqrt(2) + 1) E < 5.3 E. One step's
#: progress spans at most two segments (<= 2 sqrt(2) E each) and the 1 m search window.
REACH = 6.0 * WORLD_EXTENT
#: Rewards and observations reach SB3 as float32: one step's reward must stay below this.
REWARD_LIMIT = float(np.finfo(np.float32).max)
#: Heading noise is drawn uniformly from [-h, h], whose width 2 h must be a finite float.
_MAX_HEADING_NOISE = float(np.finfo(np.float64).max) / 2.0

#: Why no length setting may exceed WORLD_EXTENT.
_WITHIN_THE_WORLD = f"paths and mazes lie within {WORLD_EXTENT:g} m of the origin"

PathsArgument = str | Path | Track | Sequence[Path | Track] | PathSet


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward terms; see :class:`mobile_envs.envs.path_following.PathFollowingEnv`.

    Each is a finite real number (numpy scalars too, stored as floats; never a bool).
    """

    progress: float = 1.0
    time: float = 0.01
    cross_track: float = 8.0
    cross_track_squared: float = 20.0
    heading: float = 0.2
    action_change: float = 0.02
    peak_cross_track: float = 0.0
    goal_bonus: float = 10.0
    failure_penalty: float = 10.0

    def __post_init__(self) -> None:
        for item in dataclasses.fields(self):
            number = as_real(f"RewardWeights.{item.name}", getattr(self, item.name))
            object.__setattr__(self, item.name, number)

    def step_bounds(self, dt: float) -> dict[str, float]:
        """The largest magnitude each weighted term of one step's reward can reach, by
        weight: distances are at most :data:`REACH`, the heading error pi, the mean squared
        change of actions in [-1, 1] 4, and the goal and failure flags 1."""
        return {
            "progress": abs(self.progress) * REACH,
            "time": abs(self.time),
            "cross_track": abs(self.cross_track) * REACH * dt,
            "cross_track_squared": abs(self.cross_track_squared) * REACH * REACH * dt,
            "heading": abs(self.heading) * math.pi * dt,
            "action_change": abs(self.action_change) * 4.0,
            "peak_cross_track": abs(self.peak_cross_track) * REACH,
            "goal_bonus": abs(self.goal_bonus),
            "failure_penalty": abs(self.failure_penalty),
        }


def default_sensors() -> tuple[Sensor, ...]:
    """The sensors every environment has unless told otherwise: the range ring."""
    return (RangeSensor(),)


def build_model(model: str | KinematicModel, parameters: dict | None = None) -> KinematicModel:
    """A model instance from a name (with the model's env defaults) or an instance."""
    if parameters is not None and not isinstance(parameters, Mapping):
        raise ValueError(f"model_params must be a dict or None, got {parameters!r}")
    if isinstance(model, KinematicModel):
        if parameters:
            raise ValueError("model_params can only be given with a model name, not an instance")
        built = model
    elif not isinstance(model, str) or model not in MODELS:
        raise ValueError(
            f"model must be a KinematicModel or one of {sorted(MODELS)}, got {model!r}"
        )
    else:
        known = MODELS[model].parameter_names
        unknown = sorted(set(parameters or {}) - set(known), key=repr)
        if unknown:
            raise ValueError(f"unknown model_params {unknown} for {model!r}; known: {known}")
        built = make_model(model, **{**MODELS[model].env_defaults, **(parameters or {})})
    if not np.isfinite(built.input_high).all():
        raise ValueError(
            f"the environment maps actions in [-1, 1] onto the model's input limits, which "
            f"must be finite; {built!r} has input limits {built.input_high}"
        )
    return built


def build_path_set(paths: PathsArgument) -> PathSet:
    """A path set from a registered name, a path, a track, or a list of them."""
    if isinstance(paths, PathSet):
        return paths
    if isinstance(paths, str):
        return path_set(paths)
    if isinstance(paths, (Path, Track)):
        paths = [paths]
    if not isinstance(paths, Sequence):
        # An unordered set would be drawn from in a different order in every process.
        raise ValueError(
            f"paths must be a path-set name, a Path, a Track, a PathSet or a list of Paths "
            f"and Tracks, got {paths!r}"
        )
    tracks = []
    for item in paths:
        if isinstance(item, Path):
            tracks.append(Track(item))
        elif isinstance(item, Track):
            tracks.append(item)
        else:
            raise ValueError(f"paths must hold Path or Track objects, got {type(item).__name__}")
    if not tracks:
        raise ValueError("paths is an empty list")
    return FixedPathSet("custom", tracks)


def _reciprocal(value: float) -> float:
    """1 / value, inf for 0 (a product that underflowed)."""
    return math.inf if value == 0.0 else 1.0 / value


def _start_noise(noise: Any) -> tuple[float, float]:
    """``start_noise`` as a (position m, heading rad) pair; one number stands for both."""
    if not isinstance(noise, REAL_TYPES) or isinstance(noise, bool):
        if not isinstance(noise, (Sequence, np.ndarray)) or isinstance(noise, str):
            raise ValueError(f"start_noise must be a number or a pair, got {noise!r}")
        if not is_list(noise) or len(noise) != 2:
            raise ValueError(f"start_noise must be a (position m, heading rad) pair, got {noise!r}")
    position, heading = (noise, noise) if isinstance(noise, REAL_TYPES) else noise
    pair = (as_real("start_noise", position), as_real("start_noise", heading))
    if min(pair) < 0.0:
        raise ValueError(f"start_noise must be non-negative, got {noise!r}")
    if pair[0] > WORLD_EXTENT:
        raise ValueError(
            f"start_noise's position part must be at most {WORLD_EXTENT:g} m (paths and mazes "
            f"lie within it of the origin), got {noise!r}"
        )
    if pair[1] > _MAX_HEADING_NOISE:
        raise ValueError(
            f"start_noise's heading part must be at most {_MAX_HEADING_NOISE:g} rad (headings "
            f"are drawn from [-h, h], whose width must be finite), got {noise!r}"
        )
    return pair


@dataclass
class CoreConfig:
    """Validated settings shared by the single and the vector environment."""

    model: KinematicModel
    path_set: PathSet
    dt: float = 0.1
    integrator: str = "exact"
    goal_radius: float = 0.1
    max_cross_track: float = 1.0
    step_limit: int | None = None
    start_noise: tuple[float, float] = (0.0, 0.0)
    robot_radius: float = 0.25
    stall_time: float | None = 10.0
    reward: RewardWeights = field(default_factory=RewardWeights)
    sensors: tuple[Sensor, ...] = field(default_factory=default_sensors)
    #: How robots come to believe their pose; None: they know it (``"exact"``).
    localization: Localization | None = None
    #: What the true robots do with their commands (:mod:`mobile_envs.sim.plant`): given as
    #: None, a preset name, a dict or :class:`~mobile_envs.sim.plant.PlantSettings`, held as
    #: the validated settings or None (the ideal robot).
    plant: Any = None
    #: Threads the step and observation kernels split the robots over, at most numba's
    #: ``NUMBA_NUM_THREADS`` (the core count unless that variable is set). It changes the
    #: speed only: every robot's result is the same, bit for bit. One by default: a parallel
    #: region waits for its slowest thread, and on cores that other processes keep busy
    #: two threads ran several times slower than one (on a quiet 2-core machine, 1024 robots
    #: ran 1.2-1.7x faster on two). Below about 512 robots one thread is faster anyway.
    num_threads: int = 1
    #: The observation's blocks, names, scales and offsets (derived).
    layout: ObservationLayout = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.dt = as_positive("dt", self.dt)
        for name in ("goal_radius", "max_cross_track", "robot_radius"):
            setattr(
                self,
                name,
                as_positive(name, getattr(self, name), WORLD_EXTENT, " m", _WITHIN_THE_WORLD),
            )
        if self.stall_time is not None:
            self.stall_time = as_positive("stall_time", self.stall_time)
        if not isinstance(self.integrator, str) or self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {self.integrator!r}")
        if self.step_limit is not None:
            self.step_limit = as_count("step_limit", self.step_limit)
        self.start_noise = _start_noise(self.start_noise)
        if not isinstance(self.reward, RewardWeights):
            raise ValueError(f"reward_weights must be a RewardWeights, got {self.reward!r}")
        self.sensors = make_sensors(self.sensors)
        if self.localization is not None and not isinstance(self.localization, Localization):
            raise ValueError(f"localization must be a Localization, got {self.localization!r}")
        self._check_step_scales()
        self._check_observation_scales()
        for sensor in self.sensors:
            sensor.bind(self.model)
        self.layout = ObservationLayout(self.model, self.sensors, self.max_cross_track)
        if not np.isfinite(self.layout.scales).all():
            raise ValueError(f"the observation scales must be finite, got {self.layout.scales}")
        self._check_reward_bound()
        self.num_threads = _thread_count(self.num_threads)
        self.plant = plant_settings(self.plant, self.model, self.dt)

    def _check_step_scales(self) -> None:
        """What one step of dt seconds does must be finite: its rate, the model's motion,
        the stall limit in steps and the episode's time at any step count."""
        dt, model = self.dt, self.model
        if not math.isfinite(1.0 / dt):
            raise ValueError(
                f"dt must be at least {1.0 / np.finfo(np.float64).max:g} s, so that the step "
                f"rate 1/dt is finite, got {dt!r}"
            )
        if not math.isfinite(dt * MAX_STEPS):
            raise ValueError(
                f"dt must be at most {np.finfo(np.float64).max / MAX_STEPS:g} s, so that an "
                f"episode's time (steps x dt, steps up to {MAX_STEPS}) is finite, got {dt!r}"
            )
        travel = model.top_speed * dt
        if not travel <= WORLD_EXTENT:
            raise ValueError(
                f"dt = {dt!r} s at the top speed {model.top_speed:g} m/s of {model!r} moves "
                f"the robot {travel:g} m in one step, beyond the world's {WORLD_EXTENT:g} m; "
                f"lower dt or the model's limits (model_params)"
            )
        turn = model.top_yaw_rate * dt
        with np.errstate(over="ignore"):
            held = model.input_high * dt
        if not (math.isfinite(turn) and np.isfinite(held).all()):
            raise ValueError(
                f"dt = {dt!r} s times the limits of {model!r} (top yaw rate "
                f"{model.top_yaw_rate:g} rad/s, inputs {model.input_high}) overflows: one "
                f"step's turn and inputs held over it must be finite"
            )
        if self.stall_time is not None and not math.isfinite(self.stall_time / dt):
            raise ValueError(
                f"stall_time / dt (the stall limit in steps) must be finite, got stall_time = "
                f"{self.stall_time!r} s with dt = {dt!r} s"
            )

    def _check_observation_scales(self) -> None:
        """Every observation element is a reading times a scale: each scale (one over the
        largest value it divides) must be finite and positive, or 0 x inf gives NaN."""
        model = self.model
        owners = [
            (f"max_cross_track = {self.max_cross_track!r}", _reciprocal(self.max_cross_track)),
            (f"the top speed {model.top_speed:g} m/s of {model!r}", _reciprocal(model.top_speed)),
            (
                f"the top yaw rate {model.top_yaw_rate:g} rad/s of {model!r}",
                _reciprocal(model.top_yaw_rate),
            ),
        ]
        owners += [
            (f"the observed {item.name} of {model!r}", item.scale) for item in model.observed_state
        ]
        for sensor in self.sensors:
            owners += [(f"sensor {sensor!r}", scale) for scale in np.asarray(sensor.scales, float)]
        for owner, scale in owners:
            if not (math.isfinite(scale) and scale > 0.0):
                raise ValueError(
                    f"{owner} makes the observation scale {scale:g}: the value it divides by "
                    f"must be positive, finite and at least {1.0 / np.finfo(np.float64).max:g}"
                )

    def _check_reward_bound(self) -> None:
        """One step's reward must stay within :data:`REWARD_LIMIT` in every state the world
        allows."""
        bounds = self.reward.step_bounds(self.dt)
        for name, bound in bounds.items():
            if not bound <= REWARD_LIMIT:
                raise ValueError(
                    f"reward_weights.{name} = {getattr(self.reward, name)!r} with dt = "
                    f"{self.dt!r} s lets one step's reward reach {bound:g}, beyond "
                    f"{REWARD_LIMIT:g} (float32, as SB3 takes rewards); lower the weight or dt"
                )
        if not sum(bounds.values()) <= REWARD_LIMIT:
            raise ValueError(
                f"reward_weights {self.reward} with dt = {self.dt!r} s let one step's reward "
                f"reach {sum(bounds.values()):g}, beyond {REWARD_LIMIT:g} (float32, as SB3 "
                f"takes rewards); lower the weights or dt"
            )

    @property
    def observation_names(self) -> tuple[str, ...]:
        """Every observation element's name, in order."""
        return self.layout.names

    def time_limit(self, path_length: NDArray[np.float64]) -> NDArray[np.int64]:
        """Steps allowed on paths of (k,) lengths ``path_length`` (m): ``step_limit``, or
        TIME_LIMIT_FACTOR traversals at NOMINAL_SPEED."""
        if self.step_limit is not None:
            return np.full(np.shape(path_length), self.step_limit, dtype=np.int64)
        per_step = NOMINAL_SPEED * self.dt
        return _traversal_limits(
            path_length, per_step, _MAX_STEPS_FLOAT * per_step / TIME_LIMIT_FACTOR
        )


@numba.njit(cache=True)
def _traversal_limits(
    path_length: NDArray[np.float64], per_step: float, length_cap: float
) -> NDArray[np.int64]:
    """ceil(TIME_LIMIT_FACTOR * length / per_step) steps for each length, in one compiled
    call (a restart's few lengths cost a microsecond a numpy operation otherwise). A limit
    past the int64 counter's range is no limit: it saturates rather than wraps, the length
    capped at ``length_cap`` first, where the limit saturates anyway, so nothing overflows."""
    limits = np.empty(path_length.shape[0], dtype=np.int64)
    for k in range(path_length.shape[0]):
        steps = TIME_LIMIT_FACTOR * min(path_length[k], length_cap) / per_step
        limits[k] = np.int64(min(np.ceil(steps), _MAX_STEPS_FLOAT))
    return limits


def available_threads() -> int:
    """The most threads numba runs a kernel on: ``NUMBA_NUM_THREADS``, the core count unless
    that environment variable is set."""
    return int(numba.config.NUMBA_NUM_THREADS)  # type: ignore[attr-defined]  # set at import


def _thread_count(requested: Any) -> int:
    """``num_threads`` validated: an integer from 1 to numba's ``NUMBA_NUM_THREADS``."""
    available = available_threads()
    try:
        return as_count("num_threads", requested, available)
    except ValueError:
        raise ValueError(
            f"num_threads must be an integer in [1, {available}] (numba's "
            f"NUMBA_NUM_THREADS, the core count unless set), got {requested!r}"
        ) from None


def _reward_weights(weights: RewardWeights | Mapping[str, float] | None) -> RewardWeights:
    """The reward weights: the defaults, a RewardWeights, or a mapping of some of its fields
    (as YAML files and sweeps store them) over the defaults."""
    if weights is None:
        return RewardWeights()
    if isinstance(weights, Mapping):
        known = {item.name for item in dataclasses.fields(RewardWeights)}
        unknown = sorted(set(weights) - known)
        if unknown:
            raise ValueError(f"unknown reward_weights {unknown}; known: {sorted(known)}")
        return RewardWeights(**weights)
    return weights


def make_core_config(
    model: str | KinematicModel,
    paths: PathsArgument,
    *,
    model_params: dict | None = None,
    reward_weights: RewardWeights | Mapping[str, float] | None = None,
    sensors: Sequence[SensorSpec] | None = None,
    localization: str | Localization | None = "exact",
    localization_params: dict[str, Any] | None = None,
    **settings: Any,
) -> CoreConfig:
    """The validated configuration shared by the single and the vector environment.

    :param sensors: the sensors, by default :func:`default_sensors`: objects, names of
        :data:`mobile_envs.sensing.sensors.SENSORS` or ``{"type": name, **settings}``
        mappings (:func:`mobile_envs.sensing.sensors.make_sensors`)
    :param localization: ``"exact"`` (the robot knows its pose), a name of
        :data:`mobile_envs.sensing.localization.LOCALIZATIONS` or a
        :class:`~mobile_envs.sensing.localization.Localization`
    :param localization_params: the named localization's settings
    :param settings: the remaining :class:`CoreConfig` fields (``dt``, ``integrator``,
        ``goal_radius``, ``max_cross_track``, ``step_limit``, ``start_noise``,
        ``robot_radius``, ``stall_time``, ``num_threads``, ``plant``)
    """
    known = {item.name for item in dataclasses.fields(CoreConfig) if item.init} - {
        "model",
        "path_set",
        "reward",
        "sensors",
        "localization",
    }
    unknown = sorted(set(settings) - known)
    if unknown:
        raise ValueError(f"unknown environment arguments {unknown}; known: {sorted(known)}")
    return CoreConfig(
        model=build_model(model, model_params),
        path_set=build_path_set(paths),
        reward=_reward_weights(reward_weights),
        sensors=default_sensors() if sensors is None else make_sensors(sensors),
        localization=make_localization(localization, localization_params),
        **settings,
    )

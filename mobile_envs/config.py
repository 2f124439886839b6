"""The environments' settings, validated once for the single and the vector environment."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mobile_envs.kinematics import INTEGRATORS, MODELS, KinematicModel, make_model
from mobile_envs.localization import Localization, make_localization
from mobile_envs.observation import ObservationLayout
from mobile_envs.paths import Path
from mobile_envs.sensors import RangeSensor, Sensor
from mobile_envs.tracks import FixedPathSet, PathSet, Track, path_set

#: Progress (m) beyond the farthest point reached that counts as advancing; see stall_time.
STALL_PROGRESS = 0.01
#: Nominal speed that sets the time limit, and how many nominal traversals it allows.
NOMINAL_SPEED = 0.6
TIME_LIMIT_FACTOR = 3.0

PathsArgument = str | Path | Track | Sequence[Path | Track] | PathSet


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward terms; see :class:`mobile_envs.env.PathFollowingEnv`."""

    progress: float = 1.0
    time: float = 0.01
    cross_track: float = 8.0
    cross_track_squared: float = 20.0
    heading: float = 0.2
    action_change: float = 0.02
    goal_bonus: float = 10.0
    failure_penalty: float = 10.0


def default_sensors() -> tuple[Sensor, ...]:
    """The sensors every environment has unless told otherwise: the range ring."""
    return (RangeSensor(),)


def build_model(model: str | KinematicModel, parameters: dict | None = None) -> KinematicModel:
    """A model instance from a name (with the model's env defaults) or an instance."""
    if isinstance(model, KinematicModel):
        if parameters:
            raise ValueError("model_params can only be given with a model name, not an instance")
        built = model
    else:
        defaults = MODELS[model].env_defaults if model in MODELS else {}
        built = make_model(model, **{**defaults, **(parameters or {})})
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
    #: The observation's blocks, names, scales and offsets (derived).
    layout: ObservationLayout = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("dt", "goal_radius", "max_cross_track", "robot_radius"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if self.stall_time is not None and not (
            isinstance(self.stall_time, (int, float))
            and math.isfinite(self.stall_time)
            and self.stall_time > 0
        ):
            raise ValueError(
                f"stall_time must be a positive number or None, got {self.stall_time!r}"
            )
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {self.integrator!r}")
        steps = self.step_limit
        if steps is not None and (int(steps) != steps or steps < 1):
            raise ValueError(f"step_limit must be a positive integer, got {steps!r}")
        noise = self.start_noise
        if isinstance(noise, (int, float)):
            noise = (float(noise), float(noise))
        if len(noise) != 2 or not all(math.isfinite(n) and n >= 0 for n in noise):
            raise ValueError(
                f"start_noise must be a non-negative (position m, heading rad) pair, got {noise!r}"
            )
        self.start_noise = (float(noise[0]), float(noise[1]))
        if not isinstance(self.reward, RewardWeights):
            raise ValueError(f"reward must be a RewardWeights, got {self.reward!r}")
        self.sensors = tuple(self.sensors)
        for sensor in self.sensors:
            if not isinstance(sensor, Sensor):
                raise ValueError(f"sensors must hold Sensor objects, got {sensor!r}")
        if self.localization is not None and not isinstance(self.localization, Localization):
            raise ValueError(f"localization must be a Localization, got {self.localization!r}")
        self.layout = ObservationLayout(self.model, self.sensors, self.max_cross_track)

    @property
    def observation_names(self) -> tuple[str, ...]:
        """Every observation element's name, in order."""
        return self.layout.names

    def time_limit(self, path_length: NDArray[np.float64]) -> NDArray[np.int64]:
        """Steps allowed on a path: ``step_limit``, or TIME_LIMIT_FACTOR traversals at
        NOMINAL_SPEED."""
        if self.step_limit is not None:
            return np.full(np.shape(path_length), self.step_limit, dtype=np.int64)
        steps = TIME_LIMIT_FACTOR * np.asarray(path_length) / (NOMINAL_SPEED * self.dt)
        return np.ceil(steps).astype(np.int64)


def make_core_config(
    model: str | KinematicModel,
    paths: PathsArgument,
    *,
    model_params: dict | None = None,
    reward_weights: RewardWeights | None = None,
    sensors: Sequence[Sensor] | None = None,
    localization: str | Localization | None = "exact",
    localization_params: dict[str, Any] | None = None,
    **settings: Any,
) -> CoreConfig:
    """The validated configuration shared by the single and the vector environment.

    :param sensors: the sensors, by default :func:`default_sensors`
    :param localization: ``"exact"`` (the robot knows its pose), a name of
        :data:`mobile_envs.localization.LOCALIZATIONS` or a
        :class:`~mobile_envs.localization.Localization`
    :param localization_params: the named localization's settings
    :param settings: the remaining :class:`CoreConfig` fields (``dt``, ``integrator``,
        ``goal_radius``, ``max_cross_track``, ``step_limit``, ``start_noise``,
        ``robot_radius``, ``stall_time``)
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
        reward=reward_weights or RewardWeights(),
        sensors=default_sensors() if sensors is None else tuple(sensors),
        localization=make_localization(localization, localization_params),
        **settings,
    )

"""What the single and the vector environment present alike, written once for both.

Spaces, action validation, reset options, and the info: the per-step keys and the episode
metrics are one table each (:data:`STEP_INFO_KEYS`, :data:`EPISODE_INFO_KEYS`), read for
robot 0 as Python numbers (:func:`robot_info`) or for all robots as arrays
(:func:`batch_step_info`, :func:`batch_episode_info`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from mobile_envs.sim.columns import FlagColumn, FloatColumn, IntColumn
from mobile_envs.sim.config import WORLD_EXTENT, CoreConfig, build_path_set
from mobile_envs.sim.core import PathFollowingCore
from mobile_envs.sim.step import (
    EPISODE_METRIC_ROWS,
    clipped_to_unit,
    episode_metric_arrays,
    step_info_arrays,
)
from mobile_envs.tracks.sets import Track

RESET_OPTIONS = ("path", "start_pose")

#: Step info read from ``floats`` columns, then from ``flags`` columns (plain ints: they
#: also index the Python lists of the single env's hot path).
_FLOAT_INFO = (
    ("cross_track_error", int(FloatColumn.CROSS_TRACK_ERROR)),
    ("heading_error", int(FloatColumn.HEADING_ERROR)),
)
_FLAG_INFO = (
    ("is_success", int(FlagColumn.SUCCESS)),
    ("collision", int(FlagColumn.COLLISION)),
    ("off_track", int(FlagColumn.OFF_TRACK)),
    ("stalled", int(FlagColumn.STALLED)),
)
_ARC_LENGTH, _PATH_LENGTH = int(FloatColumn.ARC_LENGTH), int(FloatColumn.PATH_LENGTH)
_SUM_LOCALIZATION_ERROR = int(FloatColumn.SUM_LOCALIZATION_ERROR)
_MAX_LOCALIZATION_ERROR = int(FloatColumn.MAX_LOCALIZATION_ERROR)
_LOCALIZATION_ERROR = int(FloatColumn.LOCALIZATION_ERROR)
_SUM_ABS_CTE, _SUM_SQ_CTE = int(FloatColumn.SUM_ABS_CTE), int(FloatColumn.SUM_SQ_CTE)
_MAX_ABS_CTE, _DISTANCE = int(FloatColumn.MAX_ABS_CTE), int(FloatColumn.DISTANCE)
_STEPS = int(IntColumn.STEPS)
_HEADING_LOCALIZATION_ERROR = int(FloatColumn.HEADING_LOCALIZATION_ERROR)
(_CROSS_TRACK_ERROR, _HEADING_ERROR), (_SUCCESS, _COLLISION, _OFF_TRACK, _STALLED) = (
    [column for _, column in _FLOAT_INFO],
    [column for _, column in _FLAG_INFO],
)
#: The step info's rows, as :func:`mobile_envs.sim.step.step_info_arrays` fills them.
_STEP_FLOAT_COLUMNS = np.array([column for _, column in _FLOAT_INFO], dtype=np.int64)
_STEP_FLAG_COLUMNS = np.array([column for _, column in _FLAG_INFO], dtype=np.int64)
_STEP_FLOAT_NAMES = (*(name for name, _ in _FLOAT_INFO), "progress")
_STEP_FLAG_NAMES = tuple(name for name, _ in _FLAG_INFO)
#: Info keys present for every robot at every step.
STEP_INFO_KEYS = (
    *(name for name, _ in _FLOAT_INFO),
    "progress",
    *(name for name, _ in _FLAG_INFO),
    "pose",
)
#: Info keys present every step when the robots localize (``localization`` is not "exact"):
#: the estimated (x, y, heading), the distance (m) from the estimated to the true position
#: and the heading's error (rad, estimate minus truth).
LOCALIZATION_INFO_KEYS = ("estimated_pose", "localization_error", "heading_localization_error")
#: Reset info keys when the true robot is not the nominal model (``plant`` is set): what it
#: drew for this episode, its delay (s), its time constant (s), its slip coefficients
#: (K_D, K_Dtheta, K_theta) and its parameter errors (in the order of the model's
#: ``parameter_errors``).
PLANT_INFO_KEYS = ("plant_delay", "plant_time_constant", "plant_slip", "plant_parameter_errors")
#: Episode metrics added when the robots localize: the mean and max localization error (m).
LOCALIZATION_EPISODE_KEYS = ("mean_localization_error", "max_localization_error")
#: Info keys present only at the step an episode ends.
EPISODE_INFO_KEYS = (
    "mean_abs_cte",
    "max_abs_cte",
    "rms_cte",
    "episode_time",
    "distance_travelled",
    "completed",
)


def episode_info_placeholders(localized: bool) -> dict[str, np.float64 | np.bool_]:
    """The episode metrics as they read before an episode's end, for a recorder that wants
    the same info keys every step (Minari's ``DataCollector``, :mod:`agents.harness.datasets`):
    NaN for each number, False for ``completed``, as numpy scalars.

    :param localized: whether the env localizes (it then adds
        :data:`LOCALIZATION_EPISODE_KEYS`)
    """
    keys = EPISODE_INFO_KEYS + (LOCALIZATION_EPISODE_KEYS if localized else ())
    return {key: np.bool_(False) if key == "completed" else np.float64(np.nan) for key in keys}


def observation_space_for(config: CoreConfig) -> spaces.Box:
    return spaces.Box(-1.0, 1.0, (config.layout.size,), dtype=np.float32)


def action_space_for(config: CoreConfig) -> spaces.Box:
    return spaces.Box(-1.0, 1.0, (config.model.input_dim,), dtype=np.float32)


#: The action dtypes the compiled clip takes directly (dtypes are compared by identity:
#: numpy's native builtin dtypes are singletons, and anything else takes the slow path).
_FLOAT32, _FLOAT64 = np.dtype(np.float32), np.dtype(np.float64)


def _as_float64(array: NDArray[Any], actions: Any) -> NDArray[np.float64]:
    """Real actions of another dtype as float64, checked for NaN and inf in their own dtype
    first (a longdouble beyond float64's range is clipped, not made infinite)."""
    if array.dtype == _FLOAT32 or array.dtype == _FLOAT64:  # equal but not the singleton
        return array
    if array.dtype.kind not in "fiu":
        raise ValueError(f"action must hold real numbers, got dtype {array.dtype}")
    if array.dtype.kind == "f":
        if not np.isfinite(array).all():
            raise ValueError(f"action must be finite, got {actions!r}")
        array = np.clip(array, -1.0, 1.0)
    return array.astype(np.float64)


def validate_actions(actions: Any, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """Actions of ``shape`` as an (N, m) float64 copy clipped to [-1, 1] (N = 1 for a single
    robot's (m,)); NaN, inf, a wrong shape or a dtype that is not real raise ValueError.

    Every real dtype is accepted; float32 and float64 go to the compiled clip as they are,
    others (float16, longdouble, integers, non-native byte order) are converted first.
    """
    try:
        array = np.asarray(actions)
    except (TypeError, ValueError) as error:  # ragged nesting, objects numpy cannot read
        raise ValueError(f"action must be an array of shape {shape}: {error}") from None
    if array.shape != shape:
        raise ValueError(f"action must have shape {shape}, got shape {array.shape}")
    dtype = array.dtype
    if dtype is not _FLOAT32 and dtype is not _FLOAT64:
        array = _as_float64(array, actions)
    clipped, finite = clipped_to_unit(array, 1 if len(shape) == 1 else shape[0], shape[-1])
    if not finite:
        raise ValueError(f"action must be finite, got {actions!r}")
    return clipped


def parse_reset_options(
    options: dict[str, Any] | None,
) -> tuple[Track | None, NDArray[np.float64] | None]:
    """The track and start pose that ``reset(options=...)`` asks for, validated.

    :param options: None or a dict with the keys of :data:`RESET_OPTIONS`: ``"path"`` (a
        path-set name, a Path, a Track, a PathSet or a list that holds exactly one track) and
        ``"start_pose"`` ((x, y, heading), x and y within ``WORLD_EXTENT`` m of the origin)
    """
    if options is None:
        return None, None
    if not isinstance(options, Mapping):
        raise ValueError(
            f"reset options must be a dict with keys from {RESET_OPTIONS} or None, got {options!r}"
        )
    unknown = set(options) - set(RESET_OPTIONS)
    if unknown:
        raise ValueError(
            f"unknown reset options {sorted(unknown, key=repr)}; known: {RESET_OPTIONS}"
        )
    track = None
    if options.get("path") is not None:
        requested = options["path"]
        try:
            tracks = build_path_set(requested).tracks
        except ValueError as error:
            raise ValueError(f"reset option path: {error}") from None
        if len(tracks) != 1:
            raise ValueError(
                f"reset option path={requested!r} holds {len(tracks) or 'randomly drawn'} "
                f"paths; give exactly one (a single path's name, a Path or a Track)"
            )
        track = tracks[0]
    start_pose = None
    if options.get("start_pose") is not None:
        start_pose = _start_pose(options["start_pose"])
    return track, start_pose


def _start_pose(requested: Any) -> NDArray[np.float64]:
    """The reset option ``start_pose`` as a float64 (x, y, heading)."""
    try:
        pose = np.asarray(requested, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        pose = None
    if pose is None or pose.shape != (3,) or not np.isfinite(pose).all():
        raise ValueError(f"start_pose must be a finite (x, y, heading), got {requested!r}")
    if np.abs(pose[:2]).max() > WORLD_EXTENT:
        raise ValueError(
            f"start_pose must put x and y within {WORLD_EXTENT:g} m of the origin (paths and "
            f"mazes lie within it), got {requested!r}"
        )
    return pose


def robot_info(core: PathFollowingCore, values: list[float], flags: list[bool]) -> dict[str, Any]:
    """Robot 0's step info, as Python numbers.

    :param values: ``core.floats[0].tolist()``
    :param flags: ``core.flags[0].tolist()`` (one conversion per packed array: reading
        elements one at a time costs microseconds, and a single env step costs a few)
    """
    # Written out, the fastest way to build it; a test holds it to STEP_INFO_KEYS and to
    # batch_step_info.
    return {
        "cross_track_error": values[_CROSS_TRACK_ERROR],
        "heading_error": values[_HEADING_ERROR],
        "progress": min(max(values[_ARC_LENGTH] / values[_PATH_LENGTH], 0.0), 1.0),
        "is_success": flags[_SUCCESS],
        "collision": flags[_COLLISION],
        "off_track": flags[_OFF_TRACK],
        "stalled": flags[_STALLED],
        "pose": core.state[0, :3].copy(),
    }


def robot_localization_info(core: PathFollowingCore, values: list[float]) -> dict[str, Any]:
    """Robot 0's :data:`LOCALIZATION_INFO_KEYS`, from ``values = core.floats[0].tolist()``."""
    return {
        "estimated_pose": core.estimate[0].copy(),
        "localization_error": values[_LOCALIZATION_ERROR],
        "heading_localization_error": values[_HEADING_LOCALIZATION_ERROR],
    }


def batch_localization_info(core: PathFollowingCore) -> dict[str, NDArray[np.float64]]:
    """Every robot's :data:`LOCALIZATION_INFO_KEYS`, as (N, 3) and (N,) arrays."""
    return {
        "estimated_pose": core.estimate.copy(),
        "localization_error": core.localization_error.copy(),
        "heading_localization_error": core.heading_localization_error.copy(),
    }


def robot_plant_info(core: PathFollowingCore) -> dict[str, Any]:
    """Robot 0's :data:`PLANT_INFO_KEYS` (floats and arrays); empty without a plant."""
    plant = core.plant
    if plant is None:
        return {}
    return {
        "plant_delay": float(plant.delay[0]),
        "plant_time_constant": float(plant.time_constant[0]),
        "plant_slip": plant.slip[0].copy(),
        "plant_parameter_errors": plant.errors[0].copy(),
    }


def batch_plant_info(core: PathFollowingCore, mask: NDArray[np.bool_]) -> dict[str, Any]:
    """The :data:`PLANT_INFO_KEYS` of the robots where ``mask`` is True (zeros elsewhere), as
    (N,) and (N, k) arrays with their ``_key`` masks; empty without a plant."""
    plant = core.plant
    if plant is None:
        return {}
    infos: dict[str, Any] = {}
    for name, values in (
        ("plant_delay", plant.delay),
        ("plant_time_constant", plant.time_constant),
        ("plant_slip", plant.slip),
        ("plant_parameter_errors", plant.errors),
    ):
        rows = mask.reshape(-1, *[1] * (values.ndim - 1))
        infos[name] = np.where(rows, values, 0.0)
        infos[f"_{name}"] = mask.copy()
    return infos


def robot_episode_info(core: PathFollowingCore) -> dict[str, float | bool]:
    """Robot 0's episode metrics, as Python numbers: :func:`episode_metrics` for one robot,
    in plain float arithmetic (the same IEEE operations, so the same bits; numpy on one
    robot costs tens of microseconds)."""
    values = core.floats[0].tolist()
    steps = int(core.ints[0, _STEPS])
    divisor = max(steps, 1)
    metrics: dict[str, float | bool] = {
        "mean_abs_cte": values[_SUM_ABS_CTE] / divisor,
        "max_abs_cte": values[_MAX_ABS_CTE],
        "rms_cte": math.sqrt(values[_SUM_SQ_CTE] / divisor),
        "episode_time": steps * core.config.dt,
        "distance_travelled": values[_DISTANCE],
        "completed": bool(core.flags[0, _SUCCESS]),
    }
    if core.localization is not None:
        metrics["mean_localization_error"] = values[_SUM_LOCALIZATION_ERROR] / divisor
        metrics["max_localization_error"] = values[_MAX_LOCALIZATION_ERROR]
    return metrics


def batch_step_info(core: PathFollowingCore) -> dict[str, Any]:
    """Every robot's step info as (N,) arrays ((N, 3) for ``pose``), each with its ``_key``
    mask, as Gymnasium's vector envs give it.

    The arrays are rows of a few blocks filled in one compiled pass (one allocation per
    block, not per key); the masks of one call are one array, True everywhere.
    """
    values, flag_values, poses = step_info_arrays(
        _STEP_FLOAT_COLUMNS, _STEP_FLAG_COLUMNS, core.floats, core.flags, core.state
    )
    everyone = np.ones(core.num_robots, dtype=bool)
    infos: dict[str, Any] = {}
    for row, name in enumerate(_STEP_FLOAT_NAMES):
        infos[name] = values[row]
        infos[f"_{name}"] = everyone
    for row, name in enumerate(_STEP_FLAG_NAMES):
        infos[name] = flag_values[row]
        infos[f"_{name}"] = everyone
    infos["pose"] = poses
    infos["_pose"] = everyone
    if core.localization is not None:
        for name, value in batch_localization_info(core).items():
            infos[name] = value
            infos[f"_{name}"] = everyone
    return infos


def episode_metrics(
    core: PathFollowingCore, ended: NDArray[np.bool_]
) -> dict[str, NDArray[np.generic]]:
    """The episode metrics of every robot whose episode ``ended`` (zeros elsewhere)."""
    localized = core.localization is not None
    values, completed = episode_metric_arrays(
        core.floats, core.ints, core.flags, ended, core.config.dt, localized
    )
    rows = dict(zip(EPISODE_METRIC_ROWS[: len(values)], values, strict=True))
    metrics: dict[str, NDArray[np.generic]] = {
        key: completed if key == "completed" else rows[key]
        for key in EPISODE_INFO_KEYS + (LOCALIZATION_EPISODE_KEYS if localized else ())
    }
    return metrics


def batch_episode_info(core: PathFollowingCore, ended: NDArray[np.bool_]) -> dict[str, Any]:
    """The episode metrics of the robots whose episode ``ended``, each with its ``_key``
    mask (empty when none ended); the masks of one call are one copy of ``ended``."""
    if not ended.any():
        return {}
    mask = ended.copy()
    infos: dict[str, Any] = {}
    for key, value in episode_metrics(core, ended).items():
        infos[key] = value
        infos[f"_{key}"] = mask
    return infos

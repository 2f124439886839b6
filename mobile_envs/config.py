"""``mobile_envs.config``, kept for the code and documents that import it.

The environments' settings; they live in :mod:`mobile_envs.sim.config`.
"""

from mobile_envs.sim.config import (
    MAX_STEPS,
    NOMINAL_SPEED,
    REACH,
    REWARD_LIMIT,
    STALL_PROGRESS,
    TIME_LIMIT_FACTOR,
    WORLD_EXTENT,
    CoreConfig,
    PathsArgument,
    RewardWeights,
    available_threads,
    build_model,
    build_path_set,
    default_sensors,
    make_core_config,
)

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

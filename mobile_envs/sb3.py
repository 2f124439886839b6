"""``mobile_envs.sb3``, kept for the code and documents that import it.

The Stable-Baselines3 adapter; it lives in :mod:`mobile_envs.envs.sb3`.
"""

from mobile_envs.envs.sb3 import (
    PER_ROBOT_ATTRIBUTES,
    PathFollowingSB3VecEnv,
)

__all__ = [
    "PER_ROBOT_ATTRIBUTES",
    "PathFollowingSB3VecEnv",
]

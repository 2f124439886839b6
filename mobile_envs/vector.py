"""``mobile_envs.vector``, kept for the code and documents that import it.

The vector environment; it lives in :mod:`mobile_envs.envs.vector`.
"""

from mobile_envs.envs.vector import (
    AUTORESET_MODES,
    PathFollowingVectorEnv,
    StepResult,
)

__all__ = [
    "AUTORESET_MODES",
    "PathFollowingVectorEnv",
    "StepResult",
]

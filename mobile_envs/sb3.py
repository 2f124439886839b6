"""``mobile_envs.sb3``, kept for the code and documents that import it.

The Stable-Baselines3 adapter; it lives in :mod:`mobile_envs.envs.sb3`.
"""

from mobile_envs.envs.sb3 import *  # noqa: F403
from mobile_envs.envs.sb3 import __all__ as __all__

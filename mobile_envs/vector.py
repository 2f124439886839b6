"""``mobile_envs.vector``, kept for the code and documents that import it.

The vector environment; it lives in :mod:`mobile_envs.envs.vector`.
"""

from mobile_envs.envs.vector import *  # noqa: F403
from mobile_envs.envs.vector import __all__ as __all__

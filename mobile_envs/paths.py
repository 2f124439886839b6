"""``mobile_envs.paths``, kept for the code and documents that import it.

Paths; they live in :mod:`mobile_envs.world.paths`.
"""

from mobile_envs.world.paths import *  # noqa: F403
from mobile_envs.world.paths import __all__ as __all__

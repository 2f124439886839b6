"""``mobile_envs.config``, kept for the code and documents that import it.

The environments' settings; they live in :mod:`mobile_envs.sim.config`.
"""

from mobile_envs.sim.config import *  # noqa: F403
from mobile_envs.sim.config import __all__ as __all__

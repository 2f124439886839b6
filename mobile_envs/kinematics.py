"""``mobile_envs.kinematics``, kept for the code and documents that import it.

The kinematic models; they live in :mod:`mobile_envs.robots`, one module each.
"""

from mobile_envs.robots import *  # noqa: F403
from mobile_envs.robots import __all__ as __all__

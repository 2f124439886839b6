"""``mobile_envs.odometry``, kept for the code and documents that import it.

Wheel odometry; it lives in :mod:`mobile_envs.sensing.odometry`.
"""

from mobile_envs.sensing.odometry import *  # noqa: F403
from mobile_envs.sensing.odometry import __all__ as __all__

"""``mobile_envs.env``, kept for the code and documents that import it.

The single environment; it lives in :mod:`mobile_envs.envs.path_following`.
"""

from mobile_envs.envs.path_following import *  # noqa: F403
from mobile_envs.envs.path_following import __all__ as __all__

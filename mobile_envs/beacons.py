"""``mobile_envs.beacons``, kept for the code and documents that import it.

Laser-beacon positioning; it lives in :mod:`mobile_envs.sensing.beacons`.
"""

from mobile_envs.sensing.beacons import *  # noqa: F403
from mobile_envs.sensing.beacons import __all__ as __all__

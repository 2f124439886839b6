"""Gymnasium environments in which a wheeled robot follows a path.

``import mobile_envs`` registers the environment ids, nothing else::

    import gymnasium as gym
    import mobile_envs

    env = gym.make("mobile_envs/DiffDrive-Segments-v0")

The ids come from the catalogues of models, path sets and localizations
(:mod:`mobile_envs.envs.registration`): ``mobile_envs/<Model>-<PathSet>-v0`` for
``<Model>`` in ``ConstantVelocity``, ``DiffDrive``, ``Bicycle``, ``Tricycle`` and
``<PathSet>`` in ``Lines``, ``Segments``, ``SharpSegments``, ``Maze``, ``FigureEight``,
``Random``;
``mobile_envs/Tricycle-ArcStraight-v0`` (the run of Font-Llagunes & Batlle 2006) and
``mobile_envs/PathFollowing-v0``, which takes
:class:`mobile_envs.envs.path_following.PathFollowingEnv`'s keyword arguments.
``gym.make_vec(id, num_envs=N)`` returns the batched
:class:`mobile_envs.envs.vector.PathFollowingVectorEnv`.

Robots that localize (:mod:`mobile_envs.sensing.modes`): ``mobile_envs/<Model>-<PathSet>-
{Odometry,Beacons,OdometryBeacons}-v0`` on the course's sets, the maze and the figure eight
(odometry for the models with wheel encoders) and
``mobile_envs/Tricycle-ArcStraight-Beacons-v0`` (Font-Llagunes & Batlle's run on their laser
positioning).

Models, path sets and localizations registered after the import get their ids from
:func:`register_envs`.
"""

from typing import Any

# Before any kernel module loads: numba would otherwise reuse kernels compiled from sources
# that have changed since (it checks only each kernel's own file, not what the kernel inlines).
from mobile_envs._kernels import kernel_cache  # noqa: F401
from mobile_envs.envs.registration import model_ids, register_envs

register_envs()

__all__ = ["register_envs"]


def __getattr__(name: str) -> Any:
    # ``mobile_envs.MODEL_IDS``, kept for the code that reads it: the models' id parts, each
    # with its model's name, as the catalogue holds them now.
    if name == "MODEL_IDS":
        return model_ids()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

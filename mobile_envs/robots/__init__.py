"""Kinematic models of wheeled robots, batched over N robots: one module per model.

After the course on mobile-robot kinematics (after Corke), Bermúdez (2003) on the
differential drive and its odometry, and Font-Llagunes & Batlle (2006) on a tricycle AGV.
Each model's module holds its class, its facts and its compiled physics
(:mod:`~mobile_envs.robots.diff_drive`, ...); :mod:`mobile_envs.robots.model` what they share:
the base class, the catalogue :data:`MODELS` and :func:`make_model`.

Importing this package imports every module in it, so a model added as a module of its own
registers itself by name (``make_model("mecanum")``, ``model="mecanum"`` in the envs) and
``import mobile_envs`` registers its env ids; nothing else needs an edit.
"""

import importlib
import pkgutil

from mobile_envs.robots.bicycle import Bicycle
from mobile_envs.robots.constant_velocity import ConstantVelocity
from mobile_envs.robots.diff_drive import DifferentialDrive
from mobile_envs.robots.model import (
    FROM_INPUT,
    FROM_STATE,
    MODELS,
    KinematicModel,
    ObservedState,
    make_model,
)
from mobile_envs.robots.motion import INTEGRATORS
from mobile_envs.robots.tricycle import Tricycle

for _module in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_module.name}")

__all__ = [
    "FROM_INPUT",
    "FROM_STATE",
    "INTEGRATORS",
    "MODELS",
    "Bicycle",
    "ConstantVelocity",
    "DifferentialDrive",
    "KinematicModel",
    "ObservedState",
    "Tricycle",
    "make_model",
]

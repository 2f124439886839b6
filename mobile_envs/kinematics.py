"""``mobile_envs.kinematics``, kept for the code and documents that import it.

The kinematic models; they live in :mod:`mobile_envs.robots`, one module each.
"""

from mobile_envs.robots import (
    FROM_INPUT,
    FROM_STATE,
    INTEGRATORS,
    MODELS,
    Bicycle,
    ConstantVelocity,
    DifferentialDrive,
    KinematicModel,
    ObservedState,
    Tricycle,
    make_model,
)

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

"""``mobile_envs.kinematics``, kept for the code and documents that import it.

The kinematic models; they live in :mod:`mobile_envs.robots`, one module each.
"""

from mobile_envs.robots import (
    BICYCLE,
    CONSTANT_VELOCITY,
    DIFF_DRIVE,
    INTEGRATORS,
    KERNEL_CODES,
    MODELS,
    TRICYCLE,
    Bicycle,
    ConstantVelocity,
    DifferentialDrive,
    KinematicModel,
    ObservedState,
    Tricycle,
    advance_robot,
    make_model,
    robot_twist,
)

__all__ = [
    "BICYCLE",
    "CONSTANT_VELOCITY",
    "DIFF_DRIVE",
    "INTEGRATORS",
    "KERNEL_CODES",
    "MODELS",
    "TRICYCLE",
    "Bicycle",
    "ConstantVelocity",
    "DifferentialDrive",
    "KinematicModel",
    "ObservedState",
    "Tricycle",
    "advance_robot",
    "make_model",
    "robot_twist",
]

"""The kinematic models of wheeled robots, batched over N robots."""

from mobile_envs.robots.model import (
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

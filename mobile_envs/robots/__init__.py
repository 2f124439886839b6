"""Kinematic models of wheeled robots, batched over N robots: one module per model.

Four models, after the course on mobile-robot kinematics (after Corke), Bermúdez (2003) on
the differential drive and its odometry, and Font-Llagunes & Batlle (2006) on a tricycle AGV:

=============================  ====================  ======================================
model (module)                 state                 native input ``u``
=============================  ====================  ======================================
:class:`ConstantVelocity`      (x, y, theta)         body-frame velocity (v_x, v_y, omega)
:class:`DifferentialDrive`     (x, y, theta)         wheel angular speeds (omega_R, omega_L)
:class:`Bicycle`               (x, y, theta)         rear-axle speed and steering (v, gamma)
:class:`Tricycle`              (x, y, psi, gamma)    drive-wheel speed and steering rate
=============================  ====================  ======================================

:mod:`mobile_envs.robots.model` holds what they share (the base class, the integrators, the
catalogue :data:`MODELS` and :func:`make_model`); importing this package registers the
models above by name.
"""

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

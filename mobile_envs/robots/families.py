"""What the models of one family share: the car-like robots' steering, the wheel-driven
robots' wheels.

A model of a family derives from the family's class here instead of
:class:`~mobile_envs.robots.model.KinematicModel` and sets its family's parameters with one
call in its constructor, so their validation and the facts that follow from them (the top
speed, the turning radius, the errors a true robot may have) are written once per family.
"""

from __future__ import annotations

import math

import numpy as np

from mobile_envs.robots.model import KinematicModel
from mobile_envs.validation import as_in_open_interval, as_limit, as_positive

__all__ = ["CarLike", "WheelDriven"]


class CarLike(KinematicModel):
    """A robot steered by a wheel at angle gamma within ``max_steering``, its wheelbase L
    from the reference point, driven at a speed v within ``max_speed`` (the bicycle, the
    tricycle). A traction encoder counts the turns of a wheel of a radius the model does not
    know, a steering encoder reads gamma; a true robot may have a wheelbase error and a
    misaligned steering.
    """

    parameter_errors = ("wheelbase", "steering_offset")
    has_encoders = True
    traction_radius_unknown = True

    #: L (m)
    wheelbase: float
    #: The limit on |gamma| (rad), in (0, pi/2).
    max_steering: float
    #: The limit on |v| (m/s).
    max_speed: float

    def _set_steering(self, wheelbase: float, max_steering: float, max_speed: float) -> None:
        """Validate and keep L, the steering limit and the speed limit, in that order."""
        self.wheelbase = as_positive("wheelbase", wheelbase)
        self.max_steering = as_in_open_interval(
            "max_steering", max_steering, 0.0, math.pi / 2, "(0, pi/2)"
        )
        self.max_speed = as_limit("max_speed", max_speed)

    @property
    def top_speed(self) -> float:
        """``max_speed``: the reference point is never faster than the wheel the speed limit
        holds (the tricycle's O moves at v cos(gamma))."""
        return self.max_speed

    @property
    def min_turning_radius(self) -> float:
        """``L / tan(max_steering)``."""
        return self.wheelbase / math.tan(self.max_steering)


class WheelDriven(KinematicModel):
    """A robot whose inputs are the angular speeds of its wheels, one per input, of one
    radius r and each within ``max_wheel_speed``, that turns on the spot (the differential
    drive, the mecanum robot)."""

    #: r (m)
    wheel_radius: float
    #: The limit on each wheel's |angular speed| (rad/s).
    max_wheel_speed: float

    def _limit_wheels(self, max_wheel_speed: float) -> None:
        """Validate and keep the wheels' speed limit, the limit of every input."""
        self.max_wheel_speed = as_limit("max_wheel_speed", max_wheel_speed)
        self.input_high = np.full(len(self.input_names), self.max_wheel_speed)
        self.input_low = -self.input_high

    @property
    def top_speed(self) -> float:
        """``r max_wheel_speed``: every wheel at its limit, rolling one way."""
        return self.wheel_radius * self.max_wheel_speed

    @property
    def min_turning_radius(self) -> float:
        """0: the wheels turn it on the spot."""
        return 0.0

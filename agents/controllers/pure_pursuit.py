"""Pure pursuit as the course's MATLAB controller does it, and Nav2's regulated pure pursuit.

:class:`PurePursuit` in mode ``"matlab"`` reproduces MATLAB's ``controllerPurePursuit`` step
for step: the projection of the robot searched forward from its current segment, a lookahead
point at arc length ``Ld`` beyond it, and ``omega = 2 sin(alpha) / Ld``.

:class:`RegulatedPurePursuit` follows Macenski et al. 2023, "Regulated Pure Pursuit for Robot
Path Tracking" (ROS 2 Nav2's ``RegulatedPurePursuitController``): a speed-scaled lookahead,
speed regulated on tight curvature and near the goal, and rotation in place towards the path
when the robot faces too far away from it; car-like robots, which cannot rotate in place,
back up instead, as in a three-point turn.

Both work without an environment::

    pure_pursuit = PurePursuit()
    pure_pursuit.reset(path)
    v, omega = pure_pursuit.twist(pose)  # once per control step

and bind to one with ``PurePursuit.for_env(env, **params)`` (see :mod:`agents.controllers.base`).
Each law is written once, for many robots: :class:`PurePursuitBatch` and
:class:`RegulatedPurePursuitBatch` command N robots in one compiled call
(:func:`pure_pursuit_twists`, :func:`regulated_twists`), and the single robot above is their
batch of one. The compiled laws give the bits of the pure-Python ones they replaced
(:mod:`agents.controllers.cpython_math`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from agents.controllers.base import TwistAgent
from agents.controllers.batch import ONE_ROBOT, Indices, TwistLawBatch
from agents.controllers.cpython_math import distance, first_max, first_min
from agents.controllers.projection import (
    ForwardProjection,
    Point,
    ProjectionStates,
    point_ahead,
    remaining_length,
    update_projection,
)
from mobile_envs.robots import KinematicModel
from mobile_envs.world.geometry import TIE_TOLERANCE

__all__ = ["MODES", "ForwardProjection", "Point", "PurePursuit", "RegulatedPurePursuit"]

MODES = ("matlab", "textbook")


def _checked_number(
    name: str,
    value: object,
    minimum: float = 0.0,
    *,
    strict: bool = True,
    maximum: float = math.inf,
) -> float:
    """``value`` as a float, if it is a finite real number (a numpy scalar too, never a bool)
    above ``minimum`` (at least ``minimum`` when not ``strict``) and at most ``maximum``.

    :raises ValueError: naming ``name`` otherwise.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    number = float(value)
    above = number > minimum if strict else number >= minimum
    if not (math.isfinite(number) and above and number <= maximum):
        wanted = f"{'>' if strict else '>='} {minimum:g}"
        if maximum < math.inf:
            wanted += f" and <= {maximum:g}"
        raise ValueError(f"{name} must be finite and {wanted}, got {value!r}")
    return number


class PurePursuit(TwistAgent):
    """Pure pursuit: steer along the circular arc through a lookahead point on the path.

    With alpha the bearing of the lookahead point from the robot's heading, the arc through it
    has curvature ``2 sin(alpha) / Ld`` (Coulter 1992).

    - ``mode="matlab"``: MATLAB's ``controllerPurePursuit``: ``omega = 2 sin(alpha) / Ld``
      (the curvature itself, whatever the speed), and ``omega = +-1 rad/s`` when the lookahead
      point lies exactly behind, so the robot turns round at a constant rate.
    - ``mode="textbook"``: ``omega = v 2 sin(alpha) / Ld``, the yaw rate that drives the arc
      at speed v. It has no rule for a point exactly behind, where sin(alpha) = 0: from the
      course's start heading on ``sharp_segments`` the robot drives straight away.

    Either way ``omega`` is saturated to ``+-max_angular_speed`` and ``v = speed``. The
    projection and the lookahead point are MATLAB's (:class:`ForwardProjection`).

    :param lookahead: lookahead distance Ld (m), along the path from the projection
    :param speed: constant forward speed v (m/s), MATLAB's DesiredLinearVelocity
    :param max_angular_speed: yaw rate limit (rad/s), MATLAB's MaxAngularVelocity
    :param mode: ``"matlab"`` or ``"textbook"``
    :raises ValueError: naming the parameter, unless the three numbers are finite and
        positive (numpy scalars too, not bools) and the mode is known
    """

    def __init__(
        self,
        lookahead: float = 0.3,
        speed: float = 0.6,
        max_angular_speed: float = 2.0,
        mode: str = "matlab",
    ):
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        self.lookahead = _checked_number("lookahead", lookahead)
        self.speed = _checked_number("speed", speed)
        self.max_angular_speed = _checked_number("max_angular_speed", max_angular_speed)
        self.mode = mode

    def batch(self, num_robots: int) -> PurePursuitBatch:
        return PurePursuitBatch(self, num_robots)

    def lookahead_point(self, pose: ArrayLike) -> Point:
        """Update the projection for ``pose`` and return the lookahead point."""
        robot = self.robot()
        assert isinstance(robot, PurePursuitBatch)
        x, y = np.asarray(pose, dtype=np.float64)[:2].tolist()
        return robot.lookahead_point(x, y)


@njit(cache=True)
def pure_pursuit_twists(
    paths, robots, poses, points, segments, started, lookahead, speed, max_angular_speed,
    textbook, tie_tolerance, v_out, omega_out,
):  # fmt: skip
    """:class:`PurePursuit`'s (v, omega) for robots ``robots`` at ``poses[robots]``, each on
    its row of the path table, moving their projections; into ``v_out`` and ``omega_out``."""
    for j in range(robots.shape[0]):
        robot = robots[j]
        x, y, heading = poses[robot, 0], poses[robot, 1], poses[robot, 2]
        update_projection(paths, points, segments, started, robot, x, y, lookahead, tie_tolerance)
        target_x, target_y = point_ahead(paths, points, segments, robot, lookahead)
        bearing = math.atan2(target_y - y, target_x - x) - heading
        alpha = math.atan2(math.sin(bearing), math.cos(bearing))  # wrapped to [-pi, pi]
        curvature = 2.0 * math.sin(alpha) / lookahead
        if textbook:
            omega = speed * curvature
        else:
            omega = curvature
            if abs(abs(alpha) - math.pi) < 1e-12:
                # MATLAB's sign(): 0 stays 0.
                omega = (1.0 if curvature > 0.0 else 0.0) - (1.0 if curvature < 0.0 else 0.0)
        v_out[j] = speed
        omega_out[j] = first_min(first_max(omega, -max_angular_speed), max_angular_speed)


class PurePursuitBatch(TwistLawBatch):
    """:class:`PurePursuit` for N robots: their projections, commanded in one compiled call.

    :param law: the parameters
    :param num_robots: N
    """

    def __init__(self, law: PurePursuit, num_robots: int):
        super().__init__(num_robots)
        self.law = law
        self.projections = ProjectionStates(num_robots)

    def restart(self, robots: Indices) -> None:
        self.projections.restart(robots)

    def twists(
        self,
        robots: Indices,
        states: NDArray[np.float64],
        dt: float = 0.1,
        turns_in_place: bool = True,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        law, projections = self.law, self.projections
        v, omega = np.empty(len(robots)), np.empty(len(robots))
        pure_pursuit_twists(
            self.paths.arrays(robots), robots, states, projections.points, projections.segments,
            projections.started, law.lookahead, law.speed, law.max_angular_speed,
            law.mode == "textbook", TIE_TOLERANCE, v, omega,
        )  # fmt: skip
        return v, omega

    def lookahead_point(self, x: float, y: float) -> Point:
        """Robot 0's lookahead point, its projection moved for a robot at (x, y)."""
        paths = self.paths.arrays(ONE_ROBOT)
        projections, lookahead = self.projections, self.law.lookahead
        update_projection(
            paths, projections.points, projections.segments, projections.started, 0, x, y,
            lookahead, TIE_TOLERANCE,
        )  # fmt: skip
        return point_ahead(paths, projections.points, projections.segments, 0, lookahead)


class RegulatedPurePursuit(TwistAgent):
    """Regulated pure pursuit (Macenski et al. 2023; Nav2's RegulatedPurePursuitController).

    Each step, with v_prev the previous command's forward speed:

    1. lookahead ``Ld = clamp(v_prev lookahead_time, min_lookahead, max_lookahead)`` and the
       lookahead point Ld along the path from the robot's projection, as
       :class:`PurePursuit` finds it (Nav2 takes the first point at straight-line distance
       Ld, which jumps from one branch to the other of a sharp corner);
    2. in the robot frame the point is (x, y): curvature ``kappa = 2 y / (x^2 + y^2)``,
       bearing ``beta = atan2(y, x)``;
    3. rotate to heading: a robot that turns on the spot (its reference point's turning
       radius is at most ``in_place_radius``: the differential drive, the holonomic robot
       and the tricycle with its wheel across) turns towards the point with ``v = 0`` when
       ``|beta| > rotate_min_angle``, at ``rotate_angular_speed``, changing omega by at most
       ``max_angular_accel dt`` per step;
    4. reverse to heading (not in Nav2, whose car-like robots reverse only where the path
       does): any other robot (the bicycle) backs up at ``reverse_speed`` with the wheel
       turned away from the point when ``|beta| > reverse_min_angle``, until
       ``|beta| < reverse_exit_angle``: the reversing leg of a three-point turn. It keeps the
       lookahead of its start, so the point does not jump with the speed;
    5. otherwise ``v = speed``, times ``R / min_radius`` when the arc's radius
       ``R = 1 / |kappa|`` is below ``min_radius``, at least ``min_regulated_speed``; within
       ``approach_distance`` of the path's end, times (distance to goal /
       ``approach_distance``) but at least ``min_approach_speed``; ``omega = v kappa``.

    omega is always saturated to ``+-max_angular_speed``.

    Nav2's defaults, for a 0.5 m/s robot: lookahead 1.5 s within [0.3, 0.9] m, minimum
    radius 0.9 m, regulated minimum speed 0.25 m/s, approach 0.6 m and 0.05 m/s, rotation
    above 0.785 rad at 1.8 rad/s and 3.2 rad/s^2. The defaults here are tuned for the
    envs' robots (top speed 1 m/s and 2 rad/s, the bicycle's 1 m turning radius, 1.5 m maze
    corridors): a shorter lookahead time at a higher speed, and a longer maximum lookahead so
    that the bicycle starts its turns early enough.

    :param speed: desired forward speed (m/s)
    :param lookahead_time: seconds of travel the lookahead spans (s)
    :param min_lookahead: smallest lookahead (m)
    :param max_lookahead: largest lookahead (m)
    :param min_radius: arc radius (m) below which the speed is scaled down
    :param min_regulated_speed: floor (m/s) of the curvature-regulated speed
    :param approach_distance: remaining path length (m) at which the slow-down starts
    :param min_approach_speed: floor (m/s) of the speed near the goal
    :param rotate_min_angle: bearing (rad) above which a robot rotates towards the point
    :param rotate_angular_speed: yaw rate (rad/s) of that rotation
    :param max_angular_accel: yaw acceleration limit (rad/s^2) of that rotation
    :param in_place_radius: largest turning radius (m) that counts as turning on the spot
    :param reverse_min_angle: bearing (rad) above which other robots reverse (69 degrees)
    :param reverse_exit_angle: bearing (rad) below which they drive forward again
    :param reverse_speed: speed (m/s) of the reversing leg
    :param max_angular_speed: yaw rate limit (rad/s)
    :raises ValueError: naming the parameter, unless every parameter is a finite number
        (numpy scalars too, not bools): speeds, times, rates and lookaheads positive, radii,
        distances and floors at least 0, angles in [0, pi],
        ``min_lookahead <= max_lookahead`` and ``reverse_exit_angle <= reverse_min_angle``
    """

    def __init__(
        self,
        speed: float = 0.9,
        lookahead_time: float = 1.2,
        min_lookahead: float = 0.3,
        max_lookahead: float = 1.0,
        min_radius: float = 0.9,
        min_regulated_speed: float = 0.25,
        approach_distance: float = 0.6,
        min_approach_speed: float = 0.05,
        rotate_min_angle: float = math.pi / 4,
        rotate_angular_speed: float = 1.8,
        max_angular_accel: float = 3.2,
        in_place_radius: float = 0.25,
        reverse_min_angle: float = 1.2,
        reverse_exit_angle: float = math.pi / 6,
        reverse_speed: float = 0.3,
        max_angular_speed: float = 2.0,
    ):
        self.speed = _checked_number("speed", speed)
        self.lookahead_time = _checked_number("lookahead_time", lookahead_time)
        self.min_lookahead = _checked_number("min_lookahead", min_lookahead)
        self.max_lookahead = _checked_number("max_lookahead", max_lookahead)
        if self.min_lookahead > self.max_lookahead:
            raise ValueError(
                f"need 0 < min_lookahead <= max_lookahead, got {min_lookahead}, {max_lookahead}"
            )
        self.min_radius = _checked_number("min_radius", min_radius, strict=False)
        self.min_regulated_speed = _checked_number(
            "min_regulated_speed", min_regulated_speed, strict=False
        )
        self.approach_distance = _checked_number(
            "approach_distance", approach_distance, strict=False
        )
        self.min_approach_speed = _checked_number(
            "min_approach_speed", min_approach_speed, strict=False
        )
        self.rotate_min_angle = _checked_number(
            "rotate_min_angle", rotate_min_angle, strict=False, maximum=math.pi
        )
        self.rotate_angular_speed = _checked_number("rotate_angular_speed", rotate_angular_speed)
        self.max_angular_accel = _checked_number("max_angular_accel", max_angular_accel)
        self.in_place_radius = _checked_number("in_place_radius", in_place_radius, strict=False)
        self.reverse_min_angle = _checked_number(
            "reverse_min_angle", reverse_min_angle, strict=False, maximum=math.pi
        )
        self.reverse_exit_angle = _checked_number(
            "reverse_exit_angle", reverse_exit_angle, strict=False, maximum=self.reverse_min_angle
        )
        self.reverse_speed = _checked_number("reverse_speed", reverse_speed)
        self.max_angular_speed = _checked_number("max_angular_speed", max_angular_speed)

    def batch(self, num_robots: int) -> RegulatedPurePursuitBatch:
        return RegulatedPurePursuitBatch(self, num_robots)

    def kernel_parameters(self) -> NDArray[np.float64]:
        """The parameters in the order :func:`regulated_twists` reads them
        (:data:`REGULATED_PARAMETERS`)."""
        return np.array([getattr(self, name) for name in REGULATED_PARAMETERS])


#: The parameters :func:`regulated_twists` reads, in its order.
REGULATED_PARAMETERS = (
    "speed",
    "lookahead_time",
    "min_lookahead",
    "max_lookahead",
    "min_radius",
    "min_regulated_speed",
    "approach_distance",
    "min_approach_speed",
    "rotate_min_angle",
    "rotate_angular_speed",
    "max_angular_accel",
    "reverse_min_angle",
    "reverse_exit_angle",
    "reverse_speed",
    "max_angular_speed",
)
(
    _SPEED,
    _LOOKAHEAD_TIME,
    _MIN_LOOKAHEAD,
    _MAX_LOOKAHEAD,
    _MIN_RADIUS,
    _MIN_REGULATED_SPEED,
    _APPROACH_DISTANCE,
    _MIN_APPROACH_SPEED,
    _ROTATE_MIN_ANGLE,
    _ROTATE_ANGULAR_SPEED,
    _MAX_ANGULAR_ACCEL,
    _REVERSE_MIN_ANGLE,
    _REVERSE_EXIT_ANGLE,
    _REVERSE_SPEED,
    _MAX_ANGULAR_SPEED,
) = range(len(REGULATED_PARAMETERS))


@njit(cache=True)
def regulated_twists(
    paths, robots, poses, points, segments, started, previous, lookaheads, reversing,
    parameters, dt, turns_in_place, tie_tolerance, v_out, omega_out,
):  # fmt: skip
    """:class:`RegulatedPurePursuit`'s (v, omega) for robots ``robots`` at ``poses[robots]``
    (steps 1-5 of its docstring), moving their projections and updating their previous
    twists, lookaheads and reversing flags; into ``v_out`` and ``omega_out``."""
    max_angular_speed = parameters[_MAX_ANGULAR_SPEED]
    for j in range(robots.shape[0]):
        robot = robots[j]
        x, y, heading = poses[robot, 0], poses[robot, 1], poses[robot, 2]
        previous_speed, previous_omega = previous[robot, 0], previous[robot, 1]
        if previous_speed >= 0.0:
            lookaheads[robot] = first_min(
                first_max(previous_speed * parameters[_LOOKAHEAD_TIME], parameters[_MIN_LOOKAHEAD]),
                parameters[_MAX_LOOKAHEAD],
            )
        lookahead = lookaheads[robot]
        update_projection(paths, points, segments, started, robot, x, y, lookahead, tie_tolerance)
        target_x, target_y = point_ahead(paths, points, segments, robot, lookahead)
        cos_h, sin_h = math.cos(heading), math.sin(heading)
        dx, dy = target_x - x, target_y - y
        forward, left = cos_h * dx + sin_h * dy, cos_h * dy - sin_h * dx
        distance_sq = forward * forward + left * left
        curvature = 2.0 * left / distance_sq if distance_sq > 0.0 else 0.0
        bearing = math.atan2(left, forward)

        exit_angle = (
            parameters[_REVERSE_EXIT_ANGLE] if reversing[robot] else parameters[_REVERSE_MIN_ANGLE]
        )
        reversing[robot] = not turns_in_place and abs(bearing) > exit_angle
        if turns_in_place and abs(bearing) > parameters[_ROTATE_MIN_ANGLE]:
            v = 0.0
            wanted = math.copysign(parameters[_ROTATE_ANGULAR_SPEED], bearing)
            max_change = parameters[_MAX_ANGULAR_ACCEL] * dt
            omega = first_min(
                first_max(wanted, previous_omega - max_change), previous_omega + max_change
            )
        elif reversing[robot]:
            # Backing up with the wheel turned away from the point turns the heading towards it.
            v = -parameters[_REVERSE_SPEED]
            omega = math.copysign(max_angular_speed, bearing)
        else:
            v = _regulated_speed(paths, points, segments, robot, parameters, curvature, x, y)
            omega = v * curvature
        omega = first_min(first_max(omega, -max_angular_speed), max_angular_speed)
        previous[robot, 0], previous[robot, 1] = v, omega
        v_out[j], omega_out[j] = v, omega


@njit(cache=True, inline="always")
def _regulated_speed(paths, points, segments, robot, parameters, curvature, x, y):
    """The desired speed, slowed on tight arcs and near the goal."""
    v = parameters[_SPEED]
    min_radius = parameters[_MIN_RADIUS]
    radius = math.inf if curvature == 0.0 else 1.0 / abs(curvature)
    if radius < min_radius:
        v *= radius / min_radius
    v = first_max(v, parameters[_MIN_REGULATED_SPEED])
    approach_distance = parameters[_APPROACH_DISTANCE]
    if remaining_length(paths, points, segments, robot) < approach_distance:
        scale = distance(paths.goals[robot, 0] - x, paths.goals[robot, 1] - y) / approach_distance
        v = first_min(v, first_max(v * scale, parameters[_MIN_APPROACH_SPEED]))
    return v


class RegulatedPurePursuitBatch(TwistLawBatch):
    """:class:`RegulatedPurePursuit` for N robots: their projections, previous twists,
    lookaheads and reversing flags, commanded in one compiled call.

    :param law: the parameters
    :param num_robots: N
    """

    def __init__(self, law: RegulatedPurePursuit, num_robots: int):
        super().__init__(num_robots)
        self.law = law
        self.parameters = law.kernel_parameters()
        self.projections = ProjectionStates(num_robots)
        #: (N, 2) each robot's previous command (v, omega).
        self.previous_twists = np.zeros((num_robots, 2))
        #: (N,) each robot's lookahead (m): kept while it reverses.
        self.lookaheads = np.full(num_robots, law.min_lookahead)
        #: (N,) whether each robot is on the reversing leg of a three-point turn.
        self.reversing = np.zeros(num_robots, dtype=bool)

    def restart(self, robots: Indices) -> None:
        self.projections.restart(robots)
        self.previous_twists[robots] = 0.0
        self.lookaheads[robots] = self.law.min_lookahead
        self.reversing[robots] = False

    def turns_in_place(self, model: KinematicModel) -> bool:
        return model.min_turning_radius <= self.law.in_place_radius

    def twists(
        self,
        robots: Indices,
        states: NDArray[np.float64],
        dt: float = 0.1,
        turns_in_place: bool = True,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        projections = self.projections
        v, omega = np.empty(len(robots)), np.empty(len(robots))
        regulated_twists(
            self.paths.arrays(robots), robots, states, projections.points, projections.segments,
            projections.started, self.previous_twists, self.lookaheads, self.reversing,
            self.parameters, float(dt), bool(turns_in_place), TIE_TOLERANCE, v, omega,
        )  # fmt: skip
        return v, omega

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
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agents.controllers.base import TwistAgent
from mobile_envs.robots import KinematicModel
from mobile_envs.validation import as_choice, as_non_negative, as_positive
from mobile_envs.world.geometry import TIE_TOLERANCE
from mobile_envs.world.paths import Path

Point = tuple[float, float]

MODES = ("matlab", "textbook")
#: Why an angle a bearing is compared with is at most pi.
_LARGEST_BEARING = "no bearing is wider"


def _wrap_to_pi(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


def _closest_point_on_segment(start: Point, end: Point, position: Point) -> tuple[Point, float]:
    """The point of segment [start, end] closest to ``position``, and its distance."""
    dx, dy = end[0] - start[0], end[1] - start[1]
    length_sq = dx * dx + dy * dy
    fraction = 0.0
    if length_sq > 0.0:
        fraction = ((position[0] - start[0]) * dx + (position[1] - start[1]) * dy) / length_sq
        fraction = min(max(fraction, 0.0), 1.0)
    point = (start[0] + fraction * dx, start[1] + fraction * dy)
    return point, math.dist(point, position)


class ForwardProjection:
    """The robot's projection on a path as MATLAB's ``controllerPurePursuit`` keeps it.

    State between calls: the projection point and its segment index. The first call starts
    from the first waypoint and searches every segment; later calls first slide the point
    forward along its own segment (it never moves back within it), then look at the following
    segments while the path walked so far stays within ``search_distance``, taking a segment
    only when it is closer by more than :data:`~mobile_envs.world.geometry.TIE_TOLERANCE`.
    MATLAB takes any strictly closer segment; the tolerance changes nothing on the course's
    paths but keeps a leg that doubles back over the one being driven, as close to the robot
    up to floating point, from taking the projection before the robot reaches the turn.

    :param path: the path to project on
    """

    def __init__(self, path: Path):
        self.waypoints: list[Point] = [(float(x), float(y)) for x, y in path.points]
        self.segment_lengths: list[float] = [float(length) for length in path.segment_lengths]
        self.point: Point | None = None
        self.segment = 0

    def update(self, position: Point, search_distance: float) -> Point:
        """Move the projection for a robot at ``position``; return the projection point."""
        waypoints = self.waypoints
        first_call = self.point is None
        if self.point is None:
            self.point, self.segment = waypoints[0], 0
        segment_end = waypoints[self.segment + 1]
        self.point, best = _closest_point_on_segment(self.point, segment_end, position)
        walked = math.dist(self.point, segment_end)
        for index in range(self.segment + 1, len(waypoints) - 1):
            if not first_call and walked > search_distance:
                break
            walked += self.segment_lengths[index]
            point, distance = _closest_point_on_segment(
                waypoints[index], waypoints[index + 1], position
            )
            if distance < best - TIE_TOLERANCE:
                best, self.point, self.segment = distance, point, index
        return self.point

    def point_ahead(self, distance: float) -> Point:
        """The path point ``distance`` of arc length past the projection; the last waypoint
        when the path ends sooner (MATLAB's lookahead point)."""
        waypoints = self.waypoints
        index = self.segment
        start, end = self._projected_point(), waypoints[index + 1]
        walked = math.dist(start, end)
        overshoot = walked - distance
        while overshoot < 0.0:
            if index + 2 >= len(waypoints):
                return waypoints[-1]
            index += 1
            start, end = waypoints[index], waypoints[index + 1]
            walked += self.segment_lengths[index]
            overshoot = walked - distance
        fraction = overshoot / math.dist(start, end)
        return (end[0] + fraction * (start[0] - end[0]), end[1] + fraction * (start[1] - end[1]))

    def remaining_length(self) -> float:
        """Arc length (m) from the projection to the path's end."""
        beyond = sum(self.segment_lengths[self.segment + 1 :])
        return math.dist(self._projected_point(), self.waypoints[self.segment + 1]) + beyond

    def _projected_point(self) -> Point:
        if self.point is None:
            raise RuntimeError("call update(position) before asking for points ahead")
        return self.point


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
        self.mode = as_choice("mode", mode, MODES)
        self.lookahead = as_positive("lookahead", lookahead)
        self.speed = as_positive("speed", speed)
        self.max_angular_speed = as_positive("max_angular_speed", max_angular_speed)
        self.projection: ForwardProjection | None = None

    def reset(self, path: Path) -> None:
        self.projection = ForwardProjection(path)

    def lookahead_point(self, pose: ArrayLike) -> Point:
        """Update the projection for ``pose`` and return the lookahead point."""
        if self.projection is None:
            raise RuntimeError("call reset(path) before asking for a command")
        x, y = np.asarray(pose, dtype=np.float64)[:2]
        self.projection.update((float(x), float(y)), search_distance=self.lookahead)
        return self.projection.point_ahead(self.lookahead)

    def twist(self, pose: ArrayLike) -> tuple[float, float]:
        x, y, heading = (float(value) for value in np.asarray(pose, dtype=np.float64)[:3])
        target_x, target_y = self.lookahead_point(pose)
        alpha = _wrap_to_pi(math.atan2(target_y - y, target_x - x) - heading)
        curvature = 2.0 * math.sin(alpha) / self.lookahead
        if self.mode == "textbook":
            omega = self.speed * curvature
        else:
            omega = curvature
            if abs(abs(alpha) - math.pi) < 1e-12:
                # MATLAB's sign(): 0 stays 0.
                omega = float(curvature > 0.0) - float(curvature < 0.0)
        omega = min(max(omega, -self.max_angular_speed), self.max_angular_speed)
        return self.speed, omega


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
        self.speed = as_positive("speed", speed)
        self.lookahead_time = as_positive("lookahead_time", lookahead_time)
        self.min_lookahead = as_positive("min_lookahead", min_lookahead)
        self.max_lookahead = as_positive("max_lookahead", max_lookahead)
        if self.min_lookahead > self.max_lookahead:
            raise ValueError(
                f"need 0 < min_lookahead <= max_lookahead, got {min_lookahead}, {max_lookahead}"
            )
        self.min_radius = as_non_negative("min_radius", min_radius)
        self.min_regulated_speed = as_non_negative("min_regulated_speed", min_regulated_speed)
        self.approach_distance = as_non_negative("approach_distance", approach_distance)
        self.min_approach_speed = as_non_negative("min_approach_speed", min_approach_speed)
        self.rotate_min_angle = as_non_negative(
            "rotate_min_angle", rotate_min_angle, math.pi, " rad", _LARGEST_BEARING
        )
        self.rotate_angular_speed = as_positive("rotate_angular_speed", rotate_angular_speed)
        self.max_angular_accel = as_positive("max_angular_accel", max_angular_accel)
        self.in_place_radius = as_non_negative("in_place_radius", in_place_radius)
        self.reverse_min_angle = as_non_negative(
            "reverse_min_angle", reverse_min_angle, math.pi, " rad", _LARGEST_BEARING
        )
        self.reverse_exit_angle = as_non_negative(
            "reverse_exit_angle",
            reverse_exit_angle,
            self.reverse_min_angle,
            " rad",
            "reverse_min_angle: the robot drives forward again below it",
        )
        self.reverse_speed = as_positive("reverse_speed", reverse_speed)
        self.max_angular_speed = as_positive("max_angular_speed", max_angular_speed)
        self.projection: ForwardProjection | None = None

    def reset(self, path: Path) -> None:
        self.projection = ForwardProjection(path)
        self.previous_twist = (0.0, 0.0)
        self.lookahead = self.min_lookahead
        self.reversing = False

    def inputs(self, state: NDArray[np.float64], model: KinematicModel, dt: float) -> ArrayLike:
        turns_in_place = model.min_turning_radius <= self.in_place_radius
        v, omega = self.twist(state[:3], dt=dt, turns_in_place=turns_in_place)
        return model.inputs_for(state, v, omega, dt)

    def twist(
        self, pose: ArrayLike, dt: float = 0.1, turns_in_place: bool = True
    ) -> tuple[float, float]:
        """The regulated command; see the class docstring.

        :param pose: (x, y, heading)
        :param dt: control period (s), for the angular acceleration limit
        :param turns_in_place: whether the robot rotates to heading on the spot (True) or
            reverses to heading (False)
        """
        projection = self.projection
        if projection is None:
            raise RuntimeError("call reset(path) before asking for a command")
        x, y, heading = (float(value) for value in np.asarray(pose, dtype=np.float64)[:3])
        previous_speed, previous_omega = self.previous_twist
        if previous_speed >= 0.0:
            self.lookahead = min(
                max(previous_speed * self.lookahead_time, self.min_lookahead), self.max_lookahead
            )
        projection.update((x, y), search_distance=self.lookahead)
        target = projection.point_ahead(self.lookahead)
        cos_h, sin_h = math.cos(heading), math.sin(heading)
        dx, dy = target[0] - x, target[1] - y
        forward, left = cos_h * dx + sin_h * dy, cos_h * dy - sin_h * dx
        distance_sq = forward * forward + left * left
        curvature = 2.0 * left / distance_sq if distance_sq > 0.0 else 0.0
        bearing = math.atan2(left, forward)

        exit_angle = self.reverse_exit_angle if self.reversing else self.reverse_min_angle
        self.reversing = not turns_in_place and abs(bearing) > exit_angle
        if turns_in_place and abs(bearing) > self.rotate_min_angle:
            v = 0.0
            wanted = math.copysign(self.rotate_angular_speed, bearing)
            max_change = self.max_angular_accel * dt
            omega = min(max(wanted, previous_omega - max_change), previous_omega + max_change)
        elif self.reversing:
            # Backing up with the wheel turned away from the point turns the heading towards it.
            v = -self.reverse_speed
            omega = math.copysign(self.max_angular_speed, bearing)
        else:
            v = self._regulated_speed(curvature, (x, y), projection)
            omega = v * curvature
        omega = min(max(omega, -self.max_angular_speed), self.max_angular_speed)
        self.previous_twist = (v, omega)
        return v, omega

    def _regulated_speed(
        self, curvature: float, position: Point, projection: ForwardProjection
    ) -> float:
        """The desired speed, slowed on tight arcs and near the goal."""
        v = self.speed
        radius = math.inf if curvature == 0.0 else 1.0 / abs(curvature)
        if radius < self.min_radius:
            v *= radius / self.min_radius
        v = max(v, self.min_regulated_speed)
        if projection.remaining_length() < self.approach_distance:
            goal = projection.waypoints[-1]
            scale = math.dist(goal, position) / self.approach_distance
            v = min(v, max(v * scale, self.min_approach_speed))
        return v

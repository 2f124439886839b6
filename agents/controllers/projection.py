"""The robot's projection on its path as MATLAB's ``controllerPurePursuit`` keeps it, compiled
for many robots: what pure pursuit and regulated pure pursuit steer by.

The functions read each robot's path from :class:`~agents.controllers.batch.PathArrays`
(robot r on row r) and its projection state (a point and its segment) from the arrays of
:class:`ProjectionStates`; :class:`ForwardProjection` is the same for one robot. Distances
are CPython's (:func:`agents.controllers.cpython_math.distance`), so the compiled projection
gives the bits of the pure-Python one it replaced.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from agents.controllers.batch import ONE_ROBOT, RobotPaths
from agents.controllers.cpython_math import distance, first_max, first_min
from mobile_envs.world.geometry import TIE_TOLERANCE
from mobile_envs.world.paths import Path

Point = tuple[float, float]


@njit(cache=True, inline="always")
def waypoint(paths, robot, index):
    """Waypoint ``index`` of robot ``robot``'s path: the start of its segment ``index``, or
    the goal past the last segment."""
    if index <= paths.spans[robot, 1]:
        column = paths.spans[robot, 0] + index
        return paths.starts_x[column], paths.starts_y[column]
    return paths.goals[robot, 0], paths.goals[robot, 1]


@njit(cache=True, inline="always")
def segment_length(paths, robot, index):
    """The length of segment ``index`` of robot ``robot``'s path."""
    return paths.segment_lengths[paths.spans[robot, 0] + index]


@njit(cache=True, inline="always")
def closest_point_on_segment(start_x, start_y, end_x, end_y, x, y):
    """The point of segment [start, end] closest to (x, y), and its distance."""
    dx, dy = end_x - start_x, end_y - start_y
    length_sq = dx * dx + dy * dy
    fraction = 0.0
    if length_sq > 0.0:
        fraction = ((x - start_x) * dx + (y - start_y) * dy) / length_sq
        fraction = first_min(first_max(fraction, 0.0), 1.0)
    point_x, point_y = start_x + fraction * dx, start_y + fraction * dy
    return point_x, point_y, distance(point_x - x, point_y - y)


@njit(cache=True)
def update_projection(paths, points, segments, started, robot, x, y, search, tie_tolerance):
    """Move robot ``robot``'s projection for a robot at (x, y) (see
    :meth:`ForwardProjection.update`, whose tolerance is ``tie_tolerance``); return the
    projection point."""
    first_call = not started[robot]
    if first_call:
        points[robot, 0], points[robot, 1] = waypoint(paths, robot, 0)
        segments[robot] = 0
        started[robot] = True
    segment = segments[robot]
    end_x, end_y = waypoint(paths, robot, segment + 1)
    point_x, point_y, best = closest_point_on_segment(
        points[robot, 0], points[robot, 1], end_x, end_y, x, y
    )
    walked = distance(point_x - end_x, point_y - end_y)
    for index in range(segment + 1, paths.spans[robot, 1] + 1):
        if not first_call and walked > search:
            break
        walked += segment_length(paths, robot, index)
        start_x, start_y = waypoint(paths, robot, index)
        end_x, end_y = waypoint(paths, robot, index + 1)
        candidate_x, candidate_y, gap = closest_point_on_segment(
            start_x, start_y, end_x, end_y, x, y
        )
        if gap < best - tie_tolerance:
            best, point_x, point_y, segment = gap, candidate_x, candidate_y, index
    points[robot, 0], points[robot, 1] = point_x, point_y
    segments[robot] = segment
    return point_x, point_y


@njit(cache=True)
def point_ahead(paths, points, segments, robot, ahead):
    """The path point ``ahead`` of arc length past robot ``robot``'s projection; the goal
    when the path ends sooner."""
    index = segments[robot]
    start_x, start_y = points[robot, 0], points[robot, 1]
    end_x, end_y = waypoint(paths, robot, index + 1)
    walked = distance(start_x - end_x, start_y - end_y)
    overshoot = walked - ahead
    while overshoot < 0.0:
        if index >= paths.spans[robot, 1]:
            return paths.goals[robot, 0], paths.goals[robot, 1]
        index += 1
        start_x, start_y = waypoint(paths, robot, index)
        end_x, end_y = waypoint(paths, robot, index + 1)
        walked += segment_length(paths, robot, index)
        overshoot = walked - ahead
    fraction = overshoot / distance(start_x - end_x, start_y - end_y)
    return end_x + fraction * (start_x - end_x), end_y + fraction * (start_y - end_y)


@njit(cache=True)
def remaining_length(paths, points, segments, robot):
    """Arc length (m) from robot ``robot``'s projection to its path's end: the rest of its
    segment, then the later segments added one by one (as Python 3.11's ``sum`` does)."""
    segment = segments[robot]
    end_x, end_y = waypoint(paths, robot, segment + 1)
    beyond = 0.0
    for index in range(segment + 1, paths.spans[robot, 1] + 1):
        beyond += segment_length(paths, robot, index)
    return distance(points[robot, 0] - end_x, points[robot, 1] - end_y) + beyond


class ProjectionStates:
    """The forward projections of N robots: each one's projection point and its segment.

    :param num_robots: N
    """

    def __init__(self, num_robots: int):
        #: (N, 2) each robot's projection point.
        self.points = np.zeros((num_robots, 2))
        #: (N,) the segment each projection point lies on.
        self.segments = np.zeros(num_robots, dtype=np.int64)
        #: (N,) False until a robot's first update, which searches its whole path.
        self.started = np.zeros(num_robots, dtype=bool)

    def restart(self, robots: NDArray[np.int64]) -> None:
        """Forget the projections of ``robots``: their next update starts afresh."""
        self.started[robots] = False
        self.segments[robots] = 0


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

    The projection of one robot; pure pursuit keeps those of many in
    :class:`ProjectionStates`, moved by the same compiled functions.

    :param path: the path to project on
    """

    def __init__(self, path: Path):
        self._paths = RobotPaths(1)
        self._paths.assign(ONE_ROBOT, [path])
        self._state = ProjectionStates(1)

    @property
    def point(self) -> Point | None:
        """The projection point, None before the first :meth:`update`."""
        if not self._state.started[0]:
            return None
        x, y = self._state.points[0].tolist()
        return x, y

    @property
    def segment(self) -> int:
        """The segment the projection point lies on."""
        return int(self._state.segments[0])

    def update(self, position: ArrayLike, search_distance: float) -> Point:
        """Move the projection for a robot at ``position`` (x, y); return the projection
        point."""
        x, y = np.asarray(position, dtype=np.float64)[:2].tolist()
        state = self._state
        return update_projection(
            self._paths.arrays(ONE_ROBOT), state.points, state.segments, state.started, 0, x, y,
            float(search_distance), TIE_TOLERANCE,
        )  # fmt: skip

    def point_ahead(self, distance: float) -> Point:
        """The path point ``distance`` of arc length past the projection; the last waypoint
        when the path ends sooner (MATLAB's lookahead point)."""
        self._check_started()
        state = self._state
        paths = self._paths.arrays(ONE_ROBOT)
        return point_ahead(paths, state.points, state.segments, 0, float(distance))

    def remaining_length(self) -> float:
        """Arc length (m) from the projection to the path's end."""
        self._check_started()
        paths = self._paths.arrays(ONE_ROBOT)
        return remaining_length(paths, self._state.points, self._state.segments, 0)

    def _check_started(self) -> None:
        if not self._state.started[0]:
            raise RuntimeError("call update(position) before asking for points ahead")

"""Laser-beacon positioning of seed 003 (Font & Batlle 2006, section 2).

A laser head turning at a constant rate on the robot (8 Hz, an encoder of 65535 counts a
revolution, 30 m reach) reads the bearing theta_i of each reflector R_i, relative to the
robot's longitudinal axis and counter-clockwise positive, at the instant its beam sweeps it.
Walls hide reflectors (:func:`visible_reflectors`).

**Triangulation with absolute angles** (:func:`triangulate`). From an odometric heading
psi_est the lines through R_i at the absolute angles psi_est + theta_i would meet at the
head's centre P if psi_est were right. With an error delta = psi_est - psi they form the
*error triangle* T_12 T_13 T_23, similar to the *triangle of centres* C_12 C_13 C_23 (C_ij:
centre of the circle through P, R_i and R_j, found from the angle R_i P R_j alone) with ratio
r = 2 sin |delta| (eq. 1). So |delta| = arcsin(sqrt(A_e / A_c) / 2) from the areas (eq. 4),
or from one pair of sides when P is aligned with two reflectors and a vertex is at infinity
(eq. 5); the sign of delta is that of the z of T_ij T_ik x C_ij C_ik (eq. 6). With psi known,
each pair of lines meets at P_ij, and P is their mean weighted by
W_ij = sin(alpha_ij) / max(L_ij, 2 rho_ij) (eq. 7): alpha_ij the angle between the lines,
L_ij = |R_i R_j|, rho_ij the distance from the midpoint of R_i R_j to P. (Geometrically the
error triangle is the centres' one times 1 - e^{2 i delta}, as complex numbers: a scale of
2 |sin delta| and a turn of 90 degrees - |delta|, clockwise when delta > 0.)

On the circle through the three reflectors every point sees them at the same relative
angles, so the heading is undetermined there and the fix ill-conditioned near it. The fix's
heading errs by at most g e to first order, g its heading gain (:func:`bearing_sensitivity`)
and e the bound on a bearing's error (the encoder's count plus the reading noise), while
psi_est errs by delta, which the fix measures. So the heading stays psi_est only where the fix
cannot tell psi_est from psi beyond its own error, g e >= |delta|, and g exceeds
``max_heading_gain`` (below it the fix is always taken: its error is at most
``max_heading_gain`` e). Kept, the heading errs by at most 2 g e; fixed, by at most g e. With
more reflectors in view the best-conditioned triple is
used: the one whose position is least sensitive to the bearings, as the first-order error
propagation of the measurement geometry predicts. (Averaging all triples would mix in the
ill-conditioned ones, whose heading errors are unbounded, and costs a triangulation each.)

**Dynamic positioning.** While the robot moves, the bearings of one sweep are read from
different poses. :func:`correct_bearings` brings them to one pose, as seed 003 does: from
each bearing's pose relative to the reference pose (from odometry, or a constant twist,
:func:`twist_relative_poses`) and the estimated reference pose, it adds to each bearing the
change the motion in between makes in it.

The per-robot work is in numba kernels (:func:`measure_bearings`, :func:`sweep_screw_bearings`,
:func:`correct_robot_bearings`, :func:`triangulate_robot`) that compiled code can call per
step; the numpy functions validate and batch them.
"""

from __future__ import annotations

import enum
import math
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from mobile_envs._kernels import exact_math
from mobile_envs._kernels.angles import wrap_scalar_angle
from mobile_envs.tracks.arc_straight import LAB_REFLECTORS
from mobile_envs.tracks.catalogue import PATH_SETS
from mobile_envs.tracks.catalogue import path_set as catalogued_path_set
from mobile_envs.tracks.course import OPEN_AREA_REFLECTORS
from mobile_envs.tracks.mazes import maze_reflectors
from mobile_envs.tracks.sets import PathSet
from mobile_envs.validation import (
    as_finite_array,
    as_limit,
    as_non_negative,
    as_optional_count,
    as_point,
    as_positive,
    as_real,
    as_rows,
)

__all__ = [
    "DEFAULT_BEARING_ERROR",
    "DEFAULT_MAX_HEADING_GAIN",
    "FIX",
    "HEADING_KEPT",
    "LAB_REFLECTORS",
    "NO_FIX",
    "OPEN_AREA_REFLECTORS",
    "Fix",
    "HeadSetting",
    "LaserHead",
    "bearing_error",
    "bearing_sensitivity",
    "correct_bearings",
    "correct_robot_bearings",
    "default_reflectors",
    "maze_reflectors",
    "measure_bearings",
    "screw_pose",
    "sight_is_clear",
    "sweep_screw_bearings",
    "triangulate",
    "triangulate_near",
    "triangulate_robot",
    "twist_relative_poses",
    "validate_reflectors",
    "visible_reflectors",
]

#: What :func:`triangulate_robot` found: position and heading; the position with the heading
#: kept at its estimate (near the critical circle); nothing (fewer than three usable
#: reflectors, or bearings that no pose gives).
FIX, HEADING_KEPT, NO_FIX = 0, 1, 2

#: Up to this many radians of heading error per radian of bearing error, the fix is always
#: taken; above it, only where it tells psi_est from psi beyond its own error. With 65535
#: counts a revolution the always-taken fixes err by at most 0.096 mrad x 50 = 4.8 mrad
#: (0.27 degrees) from the head's resolution.
DEFAULT_MAX_HEADING_GAIN = 50.0
#: The bound on a bearing's error :func:`triangulate` assumes by default: one count of the
#: default head's encoder (65535 counts a revolution, 0.096 mrad).
DEFAULT_BEARING_ERROR = 2.0 * math.pi / 65535
#: Standard deviations of the readings' noise that bound its error in the fallback test:
#: 99.7 % of normal errors lie within 3.
NOISE_BOUND = 3.0
# Bearings computed exactly still carry rounding, a few ulps of 2 pi: the fallback test takes
# at least this error, so exact bearings keep psi_est only where the gain is astronomical.
_ROUNDING = 8.0 * 2.0**-52 * math.pi

# A wall that meets the line of sight within this distance of the reflector does not hide
# it: a reflector on a post is seen past the walls that end at the post.
REFLECTOR_CLEARANCE = 1e-6  # m
# Pairs of lines closer to parallel than this |sin(alpha)| have no usable intersection.
_PARALLEL = 1e-9
# At most this many visible reflectors, the nearest, compete for the best triple: the cost of
# choosing grows as its cube.
MAX_CANDIDATES = 8
_PAIRS = ((0, 1), (0, 2), (1, 2))


class HeadSetting(enum.IntEnum):
    """The columns of :attr:`LaserHead.kernel_parameters`: the head's settings as compiled
    code reads them."""

    #: Revolutions per second (Hz).
    FREQUENCY = 0
    #: The encoder's counts in one revolution; 0 for exact bearings.
    COUNTS = 1
    #: The farthest reflector it reads (m); inf for no limit.
    RANGE = 2
    #: The head's centre in the robot's body frame (m), x forward.
    OFFSET_X = 3
    OFFSET_Y = 4


Array = NDArray[np.float64]


# ---------------------------------------------------------------- compiled kernels: measuring


@njit(cache=True)
def _positive_angle(angle: float) -> float:
    """``angle`` wrapped to [0, 2 pi)."""
    wrapped = angle % (2.0 * math.pi)
    return 0.0 if wrapped >= 2.0 * math.pi else wrapped


@njit(cache=True)
def _quantized(bearing: float, counts: float) -> float:
    """The head encoder's count at ``bearing`` in [0, 2 pi): the count the beam has reached."""
    if counts == 0.0:
        return bearing
    count = 2.0 * math.pi / counts
    return _positive_angle(math.floor(bearing / count) * count)


@njit(cache=True)
def _head_point(x, y, heading, offset_x, offset_y):
    """World position of the head, mounted at (offset_x, offset_y) in the body frame."""
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    return x + offset_x * cos_h - offset_y * sin_h, y + offset_x * sin_h + offset_y * cos_h


@njit(cache=True)
def sight_is_clear(
    head_x: float, head_y: float, reflector_x: float, reflector_y: float, walls: Array
) -> bool:
    """Whether no wall crosses the line of sight from the head to the reflector.

    A wall touching the line counts, except within :data:`REFLECTOR_CLEARANCE` of the
    reflector (a post's own walls do not hide it) and edge-on (parallel to the line).

    :param walls: (K, 4) segments [x0, y0, x1, y1]
    """
    sight_x, sight_y = reflector_x - head_x, reflector_y - head_y
    length = math.hypot(sight_x, sight_y)
    if length == 0.0:
        return True
    last = 1.0 - REFLECTOR_CLEARANCE / length
    for wall in range(walls.shape[0]):
        start_x, start_y = walls[wall, 0], walls[wall, 1]
        along_x, along_y = walls[wall, 2] - start_x, walls[wall, 3] - start_y
        denominator = sight_x * along_y - sight_y * along_x
        if denominator == 0.0:
            continue
        to_x, to_y = start_x - head_x, start_y - head_y
        t = (to_x * along_y - to_y * along_x) / denominator  # along the sight line
        u = (to_x * sight_y - to_y * sight_x) / denominator  # along the wall
        if 0.0 <= u <= 1.0 and 0.0 <= t < last:
            return False
    return True


@njit(cache=True)
def _seen_from(head_x, head_y, reflector_x, reflector_y, max_range, walls):
    distance = math.hypot(reflector_x - head_x, reflector_y - head_y)
    return 0.0 < distance <= max_range and sight_is_clear(
        head_x, head_y, reflector_x, reflector_y, walls
    )


@njit(cache=True)
def measure_bearings(
    pose: Array,
    reflectors: Array,
    walls: Array,
    head_parameters: Array,
    bearings: Array,
    visible: NDArray[np.bool_],
) -> None:
    """The head's readings from a robot standing still at ``pose``.

    :param pose: (3,) the robot's (x, y, heading)
    :param reflectors: (R, 2) positions (m)
    :param walls: (K, 4) wall segments, K may be 0
    :param head_parameters: :attr:`LaserHead.kernel_parameters`
    :param bearings: (R,) receives each bearing in [0, 2 pi), quantized to the encoder
    :param visible: (R,) receives whether the reflector is in range and in sight
    """
    head_x, head_y = _head_point(
        pose[0],
        pose[1],
        pose[2],
        head_parameters[HeadSetting.OFFSET_X],
        head_parameters[HeadSetting.OFFSET_Y],
    )
    for index in range(reflectors.shape[0]):
        reflector_x, reflector_y = reflectors[index, 0], reflectors[index, 1]
        bearing = math.atan2(reflector_y - head_y, reflector_x - head_x) - pose[2]
        bearings[index] = _quantized(_positive_angle(bearing), head_parameters[HeadSetting.COUNTS])
        visible[index] = _seen_from(
            head_x, head_y, reflector_x, reflector_y, head_parameters[HeadSetting.RANGE], walls
        )


@njit(cache=True)
def screw_pose(x, y, heading, forward, sideways, turn):
    """The pose after a rigid-body motion at a constant body twist: ``forward`` and
    ``sideways`` metres along the body's axes at the start (v_x t, v_y t) while turning by
    ``turn`` (omega t). The chord is the body-frame displacement turned by half the turn and
    shortened by sin(turn/2) / (turn/2) (eq. 25, which this is for ``sideways`` 0)."""
    half = 0.5 * turn
    chord_forward, chord_sideways = forward, sideways
    if half != 0.0:
        chord_forward = forward * math.sin(half) / half
        chord_sideways = sideways * math.sin(half) / half
    direction = heading + half
    cos_d, sin_d = math.cos(direction), math.sin(direction)
    return (
        x + chord_forward * cos_d - chord_sideways * sin_d,
        y + chord_forward * sin_d + chord_sideways * cos_d,
        heading + turn,
    )


@njit(cache=True)
def _arc_pose(x, y, heading, distance, turn):
    """The pose after driving ``distance`` along an arc that turns by ``turn`` (eq. 25)."""
    return screw_pose(x, y, heading, distance, 0.0, turn)


@njit(cache=True)
def _sight_at(pose, velocity_x, velocity_y, yaw_rate, t, head_parameters, reflector):
    """(bearing, its rate, head x, head y) of ``reflector`` at time t for a robot leaving
    ``pose`` at a constant body twist (:func:`screw_pose`). The bearing turns at the sight
    line's rate, from the head's world velocity (the body's plus omega x offset), less the
    yaw rate."""
    offset_x, offset_y = (
        head_parameters[HeadSetting.OFFSET_X],
        head_parameters[HeadSetting.OFFSET_Y],
    )
    turn = yaw_rate * t
    half = 0.5 * turn
    forward, sideways = velocity_x * t, velocity_y * t
    if half != 0.0:
        forward = forward * math.sin(half) / half
        sideways = sideways * math.sin(half) / half
    direction = pose[2] + half
    cos_d, sin_d = math.cos(direction), math.sin(direction)
    heading = pose[2] + turn
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    head_x = pose[0] + forward * cos_d - sideways * sin_d + offset_x * cos_h - offset_y * sin_h
    head_y = pose[1] + forward * sin_d + sideways * cos_d + offset_x * sin_h + offset_y * cos_h
    dx, dy = reflector[0] - head_x, reflector[1] - head_y
    along = velocity_x - yaw_rate * offset_y
    across = velocity_y + yaw_rate * offset_x
    head_vx, head_vy = along * cos_h - across * sin_h, along * sin_h + across * cos_h
    squared = dx * dx + dy * dy
    rate = -yaw_rate if squared == 0.0 else (dy * head_vx - dx * head_vy) / squared - yaw_rate
    return math.atan2(dy, dx) - heading, rate, head_x, head_y


@njit(cache=True)
def sweep_screw_bearings(
    pose: Array,
    velocity_x: float,
    velocity_y: float,
    yaw_rate: float,
    start_angle: float,
    duration: float,
    reflectors: Array,
    walls: Array,
    head_parameters: Array,
    bearings: Array,
    times: Array,
    visible: NDArray[np.bool_],
    noise: Array | None = None,
) -> float:
    """The head's readings while the robot moves at a constant body twist for ``duration``.

    At time t the beam points at start_angle + 2 pi f t in the body frame and the robot is
    at ``pose`` moved by the screw of (v_x t, v_y t, omega t) (:func:`screw_pose`). A
    reflector is read at the first instant in [0, duration) at which the beam reaches its
    bearing, found by Newton's iteration on the angle between beam and bearing (which turns at
    2 pi f less the bearing's rate, a few percent of it): three or four steps reach 1e-16 s.

    :param pose: (3,) the robot's pose at t = 0
    :param velocity_x: body-frame velocity of the reference point along the robot's axis
    :param velocity_y: and across it, to the left (m/s); 0 for wheeled robots
    :param yaw_rate: the yaw rate (rad/s)
    :param start_angle: the beam's angle in the body frame at t = 0 (rad)
    :param duration: how long the head turns (s), at most one revolution's worth counts
    :param bearings: (R,) receives each reading, quantized, in [0, 2 pi)
    :param times: (R,) receives each reading's instant in [0, duration)
    :param visible: (R,) receives whether the reflector was read (swept, in range, in sight)
    :param noise: (R,) errors (rad) of the readings, added to each bearing before the
        encoder counts it (the head's reading noise); None for none
    :return: the beam's angle at t = duration, wrapped to [0, 2 pi)
    """
    spin = 2.0 * math.pi * head_parameters[HeadSetting.FREQUENCY]
    for index in range(reflectors.shape[0]):
        reflector = reflectors[index]
        # From t = 0 (where the beam first reaches the bearing seen then after turning the
        # angle between, less what the bearing turns meanwhile), Newton's steps.
        t = 0.0
        for _ in range(12):
            bearing, rate, head_x, head_y = _sight_at(
                pose, velocity_x, velocity_y, yaw_rate, t, head_parameters, reflector
            )
            # The instant the beam would point at this bearing, on the turn nearest to t
            # (the first turn from t = 0), is the fixed-point step; Newton's divides it by
            # 1 - (bearing rate) / spin.
            turned = _positive_angle(bearing - start_angle)
            if t > 0.0:
                turned += 2.0 * math.pi * round((spin * t - turned) / (2.0 * math.pi))
            step = (turned / spin - t) / (1.0 - rate / spin)
            t += step
            # Converging quadratically, a step under 1 ns leaves an error below 1e-16 s.
            if abs(step) < 1e-9:
                break
        visible[index] = False
        if not 0.0 <= t < duration:
            continue
        bearing, _, head_x, head_y = _sight_at(
            pose, velocity_x, velocity_y, yaw_rate, t, head_parameters, reflector
        )
        if noise is not None:
            bearing += noise[index]
        times[index] = t
        bearings[index] = _quantized(_positive_angle(bearing), head_parameters[HeadSetting.COUNTS])
        visible[index] = _seen_from(
            head_x, head_y, reflector[0], reflector[1], head_parameters[HeadSetting.RANGE], walls
        )
    return _positive_angle(start_angle + spin * duration)


@njit(cache=True)
def correct_robot_bearings(
    reflectors: Array,
    bearings: Array,
    relative_poses: Array,
    estimate: Array,
    head_parameters: Array,
    corrected: Array,
) -> None:
    """Bearings read from different poses, brought to one reference pose (seed 003, [7]).

    Bearing i was read with the robot at ``relative_poses[i]``, given in the frame of the
    reference pose. From the estimated reference pose the kernel predicts the bearing at both
    poses and adds the difference: the correction is exact for a right estimate and only its
    second-order part depends on the estimate's error.

    :param relative_poses: (R, 3) (dx, dy, dheading) of each reading's pose, in the
        reference pose's frame
    :param estimate: (3,) the estimated reference pose
    :param corrected: (R,) receives the corrected bearings in [0, 2 pi), not re-quantized
    """
    offset_x, offset_y = (
        head_parameters[HeadSetting.OFFSET_X],
        head_parameters[HeadSetting.OFFSET_Y],
    )
    x, y, heading = estimate[0], estimate[1], estimate[2]
    head_x, head_y = _head_point(x, y, heading, offset_x, offset_y)
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    for index in range(reflectors.shape[0]):
        reflector_x, reflector_y = reflectors[index, 0], reflectors[index, 1]
        at_reference = math.atan2(reflector_y - head_y, reflector_x - head_x) - heading
        dx, dy, turn = relative_poses[index, 0], relative_poses[index, 1], relative_poses[index, 2]
        read_x, read_y = _head_point(
            x + dx * cos_h - dy * sin_h,
            y + dx * sin_h + dy * cos_h,
            heading + turn,
            offset_x,
            offset_y,
        )
        at_reading = math.atan2(reflector_y - read_y, reflector_x - read_x) - (heading + turn)
        corrected[index] = _positive_angle(bearings[index] + at_reference - at_reading)


# ---------------------------------------------------------------- compiled kernels: the fix


@njit(cache=True)
def _intersection(ax, ay, angle_a, bx, by, angle_b):
    """Where the line through A at ``angle_a`` meets the line through B at ``angle_b``."""
    sin_between = math.sin(angle_b - angle_a)
    dx, dy = bx - ax, by - ay
    s = (dx * math.sin(angle_b) - dy * math.cos(angle_b)) / sin_between
    return ax + s * math.cos(angle_a), ay + s * math.sin(angle_a)


@njit(cache=True)
def _area(ax, ay, bx, by, cx, cy):
    """Signed area of triangle ABC, positive counter-clockwise."""
    return 0.5 * ((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))


@njit(cache=True)
def _weighted_position(reflectors, bearings, members, count, heading):
    """P as eq. 7's weighted mean of the pairwise intersections of the lines through the
    reflectors ``members[:count]`` at the absolute angles heading + bearing.

    :return: (x, y, total weight); total weight 0 when every pair is parallel
    """
    sum_x, sum_y, total = 0.0, 0.0, 0.0
    for first in range(count):
        i = members[first]
        for second in range(first + 1, count):
            j = members[second]
            sin_alpha = abs(math.sin(bearings[j] - bearings[i]))
            if sin_alpha <= _PARALLEL:
                continue
            ix, iy, jx, jy = reflectors[i, 0], reflectors[i, 1], reflectors[j, 0], reflectors[j, 1]
            px, py = _intersection(ix, iy, heading + bearings[i], jx, jy, heading + bearings[j])
            baseline = math.hypot(jx - ix, jy - iy)
            rho = math.hypot(px - 0.5 * (ix + jx), py - 0.5 * (iy + jy))
            if baseline == 0.0:
                continue  # two reflectors at one point fix nothing between them
            weight = sin_alpha / max(baseline, 2.0 * rho)
            sum_x += weight * px
            sum_y += weight * py
            total += weight
    if total == 0.0:
        return 0.0, 0.0, 0.0
    return sum_x / total, sum_y / total, total


@njit(cache=True)
def _sensitivity(reflectors, i, j, k, x, y):
    """First-order gains of a fix from reflectors i, j, k at (x, y).

    The bearings theta_m = atan2(R_m - P) - psi have the Jacobian rows
    (a_m, b_m, -1) = ((y_m - y) / d_m^2, -(x_m - x) / d_m^2, -1) in (x, y, psi); its inverse
    maps bearing errors to pose errors. Expanding along the column of -1s, the inverse's
    column m is (b_p - b_q, a_q - a_p, a_p b_q - a_q b_p) / det for (m, p, q) a cyclic turn
    of (0, 1, 2), with det = -sum over the turns of (a_p b_q - a_q b_p).

    :return: (position gain: sum over bearings of |d P / d theta_m| in metres per radian,
        heading gain: sum of |d psi / d theta_m|), both inf where the Jacobian is singular
        (on the circle through the three reflectors)
    """
    dx0, dy0 = reflectors[i, 0] - x, reflectors[i, 1] - y
    dx1, dy1 = reflectors[j, 0] - x, reflectors[j, 1] - y
    dx2, dy2 = reflectors[k, 0] - x, reflectors[k, 1] - y
    squared0, squared1 = dx0 * dx0 + dy0 * dy0, dx1 * dx1 + dy1 * dy1
    squared2 = dx2 * dx2 + dy2 * dy2
    if squared0 == 0.0 or squared1 == 0.0 or squared2 == 0.0:
        return math.inf, math.inf
    a0, b0 = dy0 / squared0, -dx0 / squared0
    a1, b1 = dy1 / squared1, -dx1 / squared1
    a2, b2 = dy2 / squared2, -dx2 / squared2
    minor0, minor1, minor2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    determinant = abs(minor0 + minor1 + minor2)
    scale = max(abs(a0), abs(b0), abs(a1), abs(b1), abs(a2), abs(b2))
    if determinant <= 1e-12 * scale * scale:
        return math.inf, math.inf
    position_gain = (
        math.hypot(b1 - b2, a2 - a1) + math.hypot(b2 - b0, a0 - a2) + math.hypot(b0 - b1, a1 - a0)
    ) / determinant
    heading_gain = (abs(minor0) + abs(minor1) + abs(minor2)) / determinant
    return position_gain, heading_gain


# Below this |sin(alpha)| of its worst pair, P is nearly aligned with two reflectors and their
# vertex nearly at infinity: delta comes from the other two vertices (eq. 5), not the areas.
_ALIGNED = math.sin(math.radians(5.0))


@njit(cache=True)
def _heading_error(reflectors, bearings, triple, heading_estimate):
    """delta = psi_est - psi from the triple's error triangle and triangle of centres
    (eqs. 1, 4-6); nan when the triangle of centres collapses (P on the circle through the
    three reflectors)."""
    centre_x, centre_y = np.empty(3), np.empty(3)
    vertex_x, vertex_y = np.empty(3), np.empty(3)
    sin_alpha = np.empty(3)
    for pair in range(3):
        a, b = triple[_PAIRS[pair][0]], triple[_PAIRS[pair][1]]
        ax, ay, bx, by = reflectors[a, 0], reflectors[a, 1], reflectors[b, 0], reflectors[b, 1]
        alpha = bearings[b] - bearings[a]  # the angle R_a P R_b that the chord R_a R_b subtends
        sin_alpha[pair] = math.sin(alpha)
        if abs(sin_alpha[pair]) <= _PARALLEL:
            centre_x[pair] = centre_y[pair] = vertex_x[pair] = vertex_y[pair] = math.inf
            continue
        half_cot = 0.5 * math.cos(alpha) / sin_alpha[pair]
        centre_x[pair] = 0.5 * (ax + bx) - half_cot * (by - ay)
        centre_y[pair] = 0.5 * (ay + by) + half_cot * (bx - ax)
        vertex_x[pair], vertex_y[pair] = _intersection(
            ax, ay, heading_estimate + bearings[a], bx, by, heading_estimate + bearings[b]
        )
    worst = int(np.argmin(np.abs(sin_alpha)))
    if abs(sin_alpha[worst]) < _ALIGNED:
        # eq. 5 on the side joining the two finite vertices.
        first, second = (worst + 1) % 3, (worst + 2) % 3
        centre_side = math.hypot(
            centre_x[second] - centre_x[first], centre_y[second] - centre_y[first]
        )
        span = math.hypot(
            centre_x[first] - reflectors[triple[0], 0], centre_y[first] - reflectors[triple[0], 1]
        )
        if centre_side <= 1e-9 * span:
            return math.nan
        error_side = math.hypot(
            vertex_x[second] - vertex_x[first], vertex_y[second] - vertex_y[first]
        )
        ratio = error_side / centre_side
    else:
        centres = _area(
            centre_x[0], centre_y[0], centre_x[1], centre_y[1], centre_x[2], centre_y[2]
        )
        errors = _area(vertex_x[0], vertex_y[0], vertex_x[1], vertex_y[1], vertex_x[2], vertex_y[2])
        # eq. 6 below takes the longest side of the triangle of centres.
        first, second, longest = 0, 1, 0.0
        for side in range(3):
            p, q = (0, 1, 0)[side], (1, 2, 2)[side]
            length = math.hypot(centre_x[q] - centre_x[p], centre_y[q] - centre_y[p])
            if length > longest:
                first, second, longest = p, q, length
        if abs(centres) <= 1e-12 * longest * longest:
            return math.nan
        ratio = math.sqrt(max(errors / centres, 0.0))  # eq. 4: r^2 = A_e / A_c
    error_side_x = vertex_x[second] - vertex_x[first]
    error_side_y = vertex_y[second] - vertex_y[first]
    centre_side_x = centre_x[second] - centre_x[first]
    centre_side_y = centre_y[second] - centre_y[first]
    cross = error_side_x * centre_side_y - error_side_y * centre_side_x  # eq. 6
    return math.copysign(math.asin(min(0.5 * ratio, 1.0)), cross)


@njit(cache=True)
def bearing_error(head_parameters: Array, noise: float) -> float:
    """The bound e on a reading's error that the fix's fallback test takes: one count of the
    head's encoder (0 for exact bearings) plus :data:`NOISE_BOUND` standard deviations of the
    reading noise.

    :param head_parameters: :attr:`LaserHead.kernel_parameters`
    :param noise: the standard deviation (rad) of each reading's error before it is counted
    """
    counts = head_parameters[HeadSetting.COUNTS]
    resolution = 0.0 if counts == 0.0 else 2.0 * math.pi / counts
    return resolution + NOISE_BOUND * noise


@njit(cache=True)
def _keeps_estimate(heading_gain, delta, max_heading_gain, bearing_error):
    """Whether the fix's heading is no better than psi_est's (the module's docstring): its
    gain is above ``max_heading_gain`` and its first-order error g e at least the error
    |delta| it finds in psi_est. An infinite gain (on the critical circle) keeps psi_est."""
    if heading_gain <= max_heading_gain:
        return False
    return not heading_gain * max(bearing_error, _ROUNDING) < abs(delta)


@njit(cache=True)
def _fix_from_triple(
    reflectors, bearings, triple, heading_estimate, max_heading_gain, bearing_error
):
    """(x, y, heading, status) of the head from one triple; the heading kept at its estimate
    where the fix cannot tell it from the truth (:func:`_keeps_estimate`)."""
    delta = _heading_error(reflectors, bearings, triple, heading_estimate)
    if not math.isnan(delta):
        heading = heading_estimate - delta
        x, y, weight = _weighted_position(reflectors, bearings, triple, 3, heading)
        if weight > 0.0:
            _, heading_gain = _sensitivity(reflectors, triple[0], triple[1], triple[2], x, y)
            if not _keeps_estimate(heading_gain, delta, max_heading_gain, bearing_error):
                return x, y, heading, FIX
    x, y, weight = _weighted_position(reflectors, bearings, triple, 3, heading_estimate)
    if weight == 0.0:
        return 0.0, 0.0, heading_estimate, NO_FIX
    return x, y, heading_estimate, HEADING_KEPT


@njit(cache=True)
def _collinear(reflectors, i, j, k):
    ax, ay = reflectors[i, 0], reflectors[i, 1]
    area = _area(ax, ay, reflectors[j, 0], reflectors[j, 1], reflectors[k, 0], reflectors[k, 1])
    longest = max(
        math.hypot(reflectors[j, 0] - ax, reflectors[j, 1] - ay),
        math.hypot(reflectors[k, 0] - ax, reflectors[k, 1] - ay),
        math.hypot(reflectors[k, 0] - reflectors[j, 0], reflectors[k, 1] - reflectors[j, 1]),
    )
    return abs(area) <= 1e-9 * longest * longest


@njit(cache=True)
def _best_triple(reflectors, members, count, x, y, triple):
    """Write into ``triple`` the non-collinear triple of ``members[:count]`` whose fix at
    (x, y) is least sensitive to the bearings; False when every triple is collinear."""
    best, found = math.inf, False
    for first in range(count):
        for second in range(first + 1, count):
            for third in range(second + 1, count):
                i, j, k = members[first], members[second], members[third]
                if _collinear(reflectors, i, j, k):
                    continue
                gain, _ = _sensitivity(reflectors, i, j, k, x, y)
                if not found or gain < best:
                    best, found = gain, True
                    triple[0], triple[1], triple[2] = i, j, k
    return found


@njit(cache=True)
def _nearest_candidates(reflectors, members, x, y):
    """The :data:`MAX_CANDIDATES` reflectors of ``members`` (row indices of ``reflectors``)
    nearest (x, y), nearest first; ``members`` itself, in its order, when it has no more."""
    count = len(members)
    if count <= MAX_CANDIDATES:
        return members
    distances = np.empty(count)
    for n in range(count):
        m = members[n]
        distances[n] = math.hypot(reflectors[m, 0] - x, reflectors[m, 1] - y)
    return members[np.argsort(distances)[:MAX_CANDIDATES]]


@njit(cache=True)
def _fix_near(
    reflectors, bearings, members, x, y, heading_estimate, max_heading_gain, bearing_error,
    pick_again,
):  # fmt: skip
    """(x, y, heading, status) from the best-conditioned triple at (x, y) among the
    :data:`MAX_CANDIDATES` of ``members`` nearest it; with ``pick_again`` and more than three
    candidates, the triple is picked again at its own fix and, if another wins there, that one
    fixes. :data:`NO_FIX` (x, y and the heading estimate back) when every triple is collinear."""
    members = _nearest_candidates(reflectors, members, x, y)
    count = len(members)
    triple = np.empty(3, dtype=np.int64)
    if not _best_triple(reflectors, members, count, x, y, triple):
        return x, y, heading_estimate, NO_FIX
    x, y, heading, status = _fix_from_triple(
        reflectors, bearings, triple, heading_estimate, max_heading_gain, bearing_error
    )
    if pick_again and count > 3 and status != NO_FIX:
        first_triple = triple.copy()
        _best_triple(reflectors, members, count, x, y, triple)
        if (triple != first_triple).any():
            x, y, heading, status = _fix_from_triple(
                reflectors, bearings, triple, heading_estimate, max_heading_gain, bearing_error
            )
    return x, y, heading, status


@njit(cache=True)
def _store_fix(x, y, heading, status, out):
    """Write a fix into ``out`` (the head's x, y and the heading wrapped into (-pi, pi]),
    unless ``status`` is :data:`NO_FIX`, which leaves ``out`` alone; return ``status``."""
    if status != NO_FIX:
        out[0], out[1] = x, y
        out[2] = wrap_scalar_angle(heading)
    return status


@njit(cache=True)
def triangulate_robot(
    reflectors: Array,
    bearings: Array,
    visible: NDArray[np.bool_],
    heading_estimate: float,
    max_heading_gain: float,
    bearing_error: float,
    out: Array,
) -> int:
    """One robot's fix from the bearings of its visible reflectors (eqs. 1-7).

    With more than three in view, a preliminary position (the lines at psi_est, eq. 7's
    weights) picks the best-conditioned triple among the :data:`MAX_CANDIDATES` nearest, by
    the position gain of :func:`bearing_sensitivity`; the triple is picked again at its own
    fix and, if another wins there, that one fixes.

    :param reflectors: (R, 2) positions (m)
    :param bearings: (R,) bearings (rad) from the head, relative to the robot's axis, all
        from one pose
    :param visible: (R,) which bearings were read
    :param heading_estimate: psi_est (rad), within 90 degrees of the true heading
    :param max_heading_gain: up to this heading gain the fix is always taken
    :param bearing_error: the bound on a bearing's error (rad; :func:`bearing_error`): above
        ``max_heading_gain`` the heading stays psi_est where the gain times this is at least
        the error the fix finds in psi_est
    :param out: (3,) receives the head's (x, y) and the robot's heading in (-pi, pi]; left
        alone when there is no fix
    :return: :data:`FIX`, :data:`HEADING_KEPT` or :data:`NO_FIX`
    """
    members = np.flatnonzero(visible)
    count = len(members)
    if count < 3:
        return NO_FIX
    x, y, weight = _weighted_position(reflectors, bearings, members, count, heading_estimate)
    if weight == 0.0:
        return NO_FIX
    x, y, heading, status = _fix_near(
        reflectors, bearings, members, x, y, heading_estimate, max_heading_gain, bearing_error,
        True,
    )  # fmt: skip
    return _store_fix(x, y, heading, status, out)


@njit(cache=True)
def triangulate_near(
    reflectors: Array,
    bearings: Array,
    count: int,
    prior_x: float,
    prior_y: float,
    heading_estimate: float,
    max_heading_gain: float,
    bearing_error: float,
    out: Array,
) -> int:
    """One robot's fix from the bearings of reflectors ``[:count]`` when the head's position
    is known roughly (from odometry or the last fix, as in the environments): the
    best-conditioned triple at the prior among the :data:`MAX_CANDIDATES` nearest fixes, in
    one pass (:func:`triangulate_robot` finds its prior from the bearings first and picks
    again at its fix). A poor prior costs conditioning, not exactness: every usable triple
    gives the exact pose for exact bearings.

    :param reflectors: (R, 2) positions (m), of which the first ``count`` were read
    :param bearings: (R,) their bearings (rad), all from one pose
    :param prior_x: the head's rough position (m)
    :param prior_y: and its y (m)
    :param heading_estimate: psi_est (rad), within 90 degrees of the true heading
    :param max_heading_gain: up to this heading gain the fix is always taken
    :param bearing_error: the bound on a bearing's error (rad), as :func:`triangulate_robot`
    :param out: (3,) receives the head's (x, y) and the robot's heading in (-pi, pi]; left
        alone when there is no fix
    :return: :data:`FIX`, :data:`HEADING_KEPT` or :data:`NO_FIX`
    """
    if count < 3:
        return NO_FIX
    x, y, heading, status = _fix_near(
        reflectors, bearings, np.arange(count), prior_x, prior_y, heading_estimate,
        max_heading_gain, bearing_error, False,
    )  # fmt: skip
    return _store_fix(x, y, heading, status, out)


@njit(cache=True)
def _measure_rows(poses, reflectors, walls, head_parameters):
    bearings = np.empty((poses.shape[0], reflectors.shape[0]))
    visible = np.empty((poses.shape[0], reflectors.shape[0]), dtype=np.bool_)
    for robot in range(poses.shape[0]):
        measure_bearings(
            poses[robot], reflectors, walls, head_parameters, bearings[robot], visible[robot]
        )
    return bearings, visible


@njit(cache=True)
def _sweep_rows(poses, twists, start_angles, duration, reflectors, walls, head_parameters):
    robots, count = poses.shape[0], reflectors.shape[0]
    bearings, times = np.zeros((robots, count)), np.zeros((robots, count))
    visible = np.zeros((robots, count), dtype=np.bool_)
    end_angles = np.empty(robots)
    for robot in range(robots):
        end_angles[robot] = sweep_screw_bearings(
            poses[robot],
            twists[robot, 0],
            0.0,
            twists[robot, 1],
            start_angles[robot],
            duration,
            reflectors,
            walls,
            head_parameters,
            bearings[robot],
            times[robot],
            visible[robot],
        )
    return bearings, times, visible, end_angles


@njit(cache=True)
def _visible_rows(points, reflectors, walls, max_range):
    visible = np.empty((points.shape[0], reflectors.shape[0]), dtype=np.bool_)
    for row in range(points.shape[0]):
        for index in range(reflectors.shape[0]):
            visible[row, index] = _seen_from(
                points[row, 0],
                points[row, 1],
                reflectors[index, 0],
                reflectors[index, 1],
                max_range,
                walls,
            )
    return visible


@njit(cache=True)
def _sensitivity_rows(reflectors, points):
    gains = np.empty((points.shape[0], 2))
    for row in range(points.shape[0]):
        gains[row, 0], gains[row, 1] = _sensitivity(
            reflectors, 0, 1, 2, points[row, 0], points[row, 1]
        )
    return gains


# ---------------------------------------------------------------- validation


def _points(value: ArrayLike, name: str, minimum: int = 0) -> Array:
    """(R, 2) C-contiguous float64 positions."""
    array = as_finite_array(name, value)
    if array.ndim != 2 or array.shape[1] != 2 or len(array) < minimum:
        at_least = f" with at least {minimum} rows" if minimum else ""
        raise ValueError(f"{name} must have shape (R, 2){at_least}, got {array.shape}")
    return np.ascontiguousarray(array)


def _walls(walls: ArrayLike | None) -> Array:
    """Wall segments as (K, 4) [x0, y0, x1, y1]; (K, 2, 2) (the maze's layout) is accepted."""
    if walls is None:
        return np.zeros((0, 4))
    array = as_finite_array("walls", walls)
    if array.ndim == 3 and array.shape[1:] == (2, 2):
        array = array.reshape(len(array), 4)
    if array.ndim != 2 or array.shape[1] != 4:
        raise ValueError(f"walls must have shape (K, 4) or (K, 2, 2), got {array.shape}")
    return np.ascontiguousarray(array)


# ---------------------------------------------------------------- public numpy API


class LaserHead:
    """Seed 003's rotating laser goniometer, mounted on the robot.

    :param frequency: revolutions per second (Hz); seed 003's head turns at 8 Hz
    :param counts_per_revolution: the head encoder's counts in one turn, a positive integer
        (65535: 0.096 mrad), or None for exact bearings
    :param max_range: the farthest reflector it reads (m); 30 m in seed 003
    :param offset: (x, y) of the head's centre in the robot's body frame (m), x forward
    """

    def __init__(
        self,
        frequency: float = 8.0,
        counts_per_revolution: int | None = 65535,
        max_range: float = 30.0,
        offset: ArrayLike = (0.0, 0.0),
    ):
        self.frequency = as_positive("frequency", frequency)
        self.counts_per_revolution = as_optional_count(
            "counts_per_revolution", counts_per_revolution
        )
        self.max_range = as_limit("max_range", max_range)
        self.offset = as_point("offset", offset)
        #: The settings for the kernels, in the columns :class:`HeadSetting` names.
        self.kernel_parameters = np.zeros(len(HeadSetting))
        self.kernel_parameters[HeadSetting.FREQUENCY] = self.frequency
        self.kernel_parameters[HeadSetting.COUNTS] = self.counts_per_revolution or 0
        self.kernel_parameters[HeadSetting.RANGE] = self.max_range
        self.kernel_parameters[HeadSetting.OFFSET_X] = self.offset[0]
        self.kernel_parameters[HeadSetting.OFFSET_Y] = self.offset[1]

    @property
    def bearing_resolution(self) -> float:
        """One encoder count (rad); 0 for exact bearings."""
        counts = self.counts_per_revolution
        return 0.0 if counts is None else 2.0 * math.pi / counts

    @property
    def period(self) -> float:
        """The time of one revolution (s)."""
        return 1.0 / self.frequency

    def head_position(self, poses: ArrayLike) -> Array:
        """World (x, y) of the head's centre for robot poses (x, y, heading), (3,) or (N, 3)."""
        rows, batched = as_rows("poses", poses, 3)
        cos_h, sin_h = exact_math.cos(rows[:, 2]), exact_math.sin(rows[:, 2])
        ox, oy = self.offset
        points = np.column_stack(
            (rows[:, 0] + ox * cos_h - oy * sin_h, rows[:, 1] + ox * sin_h + oy * cos_h)
        )
        return points if batched else points[0]

    def robot_position(self, head: ArrayLike, heading: ArrayLike) -> Array:
        """The robot's reference point (x, y) from its head's centre and its heading.

        :param head: (2,) or (N, 2) the head's centre, as :func:`triangulate` returns it
        :param heading: scalar or (N,) the robot's heading
        """
        points, batched = as_rows("head", head, 2)
        angle = np.broadcast_to(as_finite_array("heading", heading), (len(points),))
        cos_h, sin_h = exact_math.cos(angle), exact_math.sin(angle)
        ox, oy = self.offset
        robot = points - np.column_stack((ox * cos_h - oy * sin_h, ox * sin_h + oy * cos_h))
        return robot if batched else robot[0]

    def measure(
        self, poses: ArrayLike, reflectors: ArrayLike, walls: ArrayLike | None = None
    ) -> tuple[Array, NDArray[np.bool_]]:
        """The bearings read from robots standing still (:func:`measure_bearings`).

        :param poses: (x, y, heading) of the robots' reference points, (3,) or (N, 3)
        :param reflectors: (R, 2) positions (m)
        :param walls: wall segments (K, 4) [x0, y0, x1, y1] or (K, 2, 2) as
            :attr:`mobile_envs.world.maze.Maze.walls`; None in open space
        :return: (bearings in [0, 2 pi), visible): (R,) each, or (N, R) for a batch
        """
        rows, batched = as_rows("poses", poses, 3)
        bearings, visible = _measure_rows(
            rows, _points(reflectors, "reflectors"), _walls(walls), self.kernel_parameters
        )
        return (bearings, visible) if batched else (bearings[0], visible[0])

    def sweep(
        self,
        poses: ArrayLike,
        twists: ArrayLike,
        reflectors: ArrayLike,
        walls: ArrayLike | None = None,
        start_angle: ArrayLike = 0.0,
        duration: float | None = None,
    ) -> tuple[Array, Array, NDArray[np.bool_], Array]:
        """The bearings read while the robots drive at constant twists
        (:func:`sweep_screw_bearings`, without sideways motion).

        :param poses: the robots' poses at t = 0, (3,) or (N, 3)
        :param twists: their (forward speed, yaw rate), (2,) or (N, 2)
        :param reflectors: (R, 2) positions (m)
        :param walls: as in :meth:`measure`
        :param start_angle: the beam's angle in the body frame at t = 0, scalar or (N,)
        :param duration: how long to turn (s); one revolution by default
        :return: (bearings, times, visible, end angles): (R,) each and a scalar for one robot,
            (N, R) and (N,) for a batch; a bearing and time are meaningful where visible
        """
        rows, batched = as_rows("poses", poses, 3)
        motion, motion_batched = as_rows("twists", twists, 2)
        if motion_batched and len(motion) != len(rows):
            raise ValueError(f"twists hold {len(motion)} robots and poses {len(rows)}")
        motion = np.ascontiguousarray(np.broadcast_to(motion, (len(rows), 2)))
        angles = as_finite_array("start_angle", start_angle)
        if angles.ndim > 1 or (angles.ndim == 1 and len(angles) != len(rows)):
            raise ValueError(f"start_angle must be a scalar or ({len(rows)},), got {angles.shape}")
        angles = np.ascontiguousarray(np.broadcast_to(angles, (len(rows),)))
        span = self.period if duration is None else as_positive("duration", duration)
        bearings, times, visible, ends = _sweep_rows(
            rows,
            motion,
            angles,
            span,
            _points(reflectors, "reflectors"),
            _walls(walls),
            self.kernel_parameters,
        )
        if batched:
            return bearings, times, visible, ends
        return bearings[0], times[0], visible[0], ends[0]

    def __repr__(self) -> str:
        return (
            f"LaserHead(frequency={self.frequency}, counts_per_revolution="
            f"{self.counts_per_revolution}, max_range={self.max_range}, "
            f"offset={tuple(float(v) for v in self.offset)})"
        )


def visible_reflectors(
    points: ArrayLike,
    reflectors: ArrayLike,
    walls: ArrayLike | None = None,
    max_range: float = math.inf,
) -> NDArray[np.bool_]:
    """Which reflectors a head at each point sees: in range and not hidden by a wall.

    A wall touching the line of sight hides the reflector, except within 1 um of the
    reflector itself (a reflector on a post is seen past the walls that end at the post).

    :param points: (2,) or (N, 2) the head's centre (m)
    :param reflectors: (R, 2) positions (m)
    :param walls: (K, 4) [x0, y0, x1, y1] or (K, 2, 2) segments (as
        :attr:`mobile_envs.world.maze.Maze.walls`); None in open space
    :param max_range: the head's reach (m)
    :return: (R,) or (N, R) booleans
    """
    rows, batched = as_rows("points", points, 2)
    visible = _visible_rows(
        rows,
        _points(reflectors, "reflectors"),
        _walls(walls),
        as_limit("max_range", max_range),
    )
    return visible if batched else visible[0]


def bearing_sensitivity(reflectors: ArrayLike, position: ArrayLike) -> tuple[Array, Array]:
    """First-order sensitivity of a three-reflector fix at ``position`` to its bearings.

    Inverting the Jacobian of the bearings theta_i = atan2(R_i - P) - psi in (x, y, psi):
    the position gain is sum_i |dP/dtheta_i| (m/rad) and the heading gain
    sum_i |dpsi/dtheta_i|. A bearing error of at most e moves the fix by at most e times the
    gains (to first order); both are inf on the circle through the reflectors.

    :param reflectors: (3, 2) positions (m)
    :param position: the head's centre, (2,) or (N, 2)
    :return: (position gain, heading gain): scalars (0-d) or (N,)
    """
    triple = _points(reflectors, "reflectors")
    if len(triple) != 3:
        raise ValueError(f"reflectors must have shape (3, 2), got {triple.shape}")
    rows, batched = as_rows("position", position, 2)
    gains = _sensitivity_rows(triple, rows)
    return (gains[:, 0], gains[:, 1]) if batched else (gains[0, 0], gains[0, 1])


class Fix(NamedTuple):
    """What :func:`triangulate` found.

    :param x: the head's centre (m): the fix's, or the held ``position_estimate`` when
        ``status`` is :data:`NO_FIX`
    :param y: and its y (m)
    :param heading: the robot's heading (rad) in (-pi, pi]: the fix's, or psi_est when
        ``status`` is :data:`HEADING_KEPT` or :data:`NO_FIX`
    :param status: :data:`FIX`, :data:`HEADING_KEPT` (near the critical circle) or
        :data:`NO_FIX` (bearings that no pose gives: the estimate is held)
    """

    x: float
    y: float
    heading: float
    status: int


def triangulate(
    reflectors: ArrayLike,
    bearings: ArrayLike,
    heading_estimate: float,
    max_heading_gain: float = DEFAULT_MAX_HEADING_GAIN,
    bearing_error: float = DEFAULT_BEARING_ERROR,
    position_estimate: ArrayLike = (0.0, 0.0),
) -> Fix:
    """Position of the head's centre and heading of the robot from reflector bearings
    (seed 003 eqs. 1-7; see the module's docstring).

    Exact, to rounding, whenever |psi_est - psi| < 90 degrees and the head is off the circle
    through the reflectors: the pose that gives the bearings exactly. Near that circle the
    heading stays psi_est where the fix's first-order heading error, its gain
    (:func:`bearing_sensitivity`) times ``bearing_error``, is at least the error it finds in
    psi_est and the gain is above ``max_heading_gain``; the position is then where the lines
    at psi_est meet. Bearings that no pose gives (all lines parallel) are no error: a control
    loop gets the estimate back, flagged :data:`NO_FIX`.

    :param reflectors: (R, 2) positions (m), R >= 3; three of them must not be collinear.
        With more than three, the best-conditioned triple fixes
    :param bearings: (R,) the bearing of each reflector from the head (rad), relative to the
        robot's longitudinal axis, counter-clockwise positive, all read from one pose
    :param heading_estimate: psi_est (rad), e.g. from odometry
    :param max_heading_gain: radians of heading error per radian of bearing error up to which
        the fix is always taken, positive
    :param bearing_error: the bound on each bearing's error (rad), >= 0: the encoder's count
        plus the reading noise (:func:`bearing_error`, about 3 standard deviations); one
        count of the default head by default, 0 for bearings known exactly
    :param position_estimate: (x, y) of the head to hold when the bearings fix nothing
    :return: the :class:`Fix` (x, y, heading, status)
    :raises ValueError: naming the argument for invalid input: shapes, NaN, infinities,
        collinear reflectors, a gain limit that is not positive, a negative bearing error
    """
    positions = validate_reflectors(reflectors)
    angles = as_finite_array("bearings", bearings)
    if angles.shape != (len(positions),):
        raise ValueError(
            f"bearings must have shape ({len(positions)},), one per reflector, got {angles.shape}"
        )
    estimate = as_real("heading_estimate", heading_estimate)
    gain_limit = as_limit("max_heading_gain", max_heading_gain)
    error_bound = as_non_negative("bearing_error", bearing_error)
    held = as_point("position_estimate", position_estimate)
    out = np.empty(3)
    status = triangulate_robot(
        positions,
        np.ascontiguousarray(angles),
        np.ones(len(positions), dtype=np.bool_),
        estimate,
        gain_limit,
        error_bound,
        out,
    )
    if status == NO_FIX:
        out[0], out[1], out[2] = held[0], held[1], wrap_scalar_angle(estimate)
    return Fix(float(out[0]), float(out[1]), float(out[2]), int(status))


def twist_relative_poses(
    speed: float, yaw_rate: float, times: ArrayLike, reference_time: float
) -> Array:
    """Where a robot driving at a constant twist is at ``times``, in the frame of its pose at
    ``reference_time``: the arcs of (speed dt, yaw_rate dt), dt = time - reference_time.

    :return: (R, 3) (dx, dy, dheading), as :func:`correct_bearings` takes them
    """
    v = float(as_finite_array("speed", speed))
    omega = float(as_finite_array("yaw_rate", yaw_rate))
    elapsed = as_finite_array("times", times).reshape(-1) - float(
        as_finite_array("reference_time", reference_time)
    )
    poses = np.empty((len(elapsed), 3))
    for row, dt in enumerate(elapsed):
        poses[row] = _arc_pose(0.0, 0.0, 0.0, v * dt, omega * dt)
    return poses


def correct_bearings(
    reflectors: ArrayLike,
    bearings: ArrayLike,
    relative_poses: ArrayLike,
    estimated_pose: ArrayLike,
    head: LaserHead | None = None,
) -> Array:
    """Bearings read from different poses of one sweep, brought to one reference pose
    (:func:`correct_robot_bearings`; seed 003's dynamic positioning).

    :param reflectors: (R, 2) positions (m)
    :param bearings: (R,) the bearings as read (rad)
    :param relative_poses: (R, 3) the robot's pose at each reading in the frame of the
        reference pose, from odometry or :func:`twist_relative_poses`
    :param estimated_pose: (3,) the estimated reference pose (x, y, heading)
    :param head: the head (its offset matters); the default head at the reference point
    :return: (R,) the bearings as read from the reference pose, in [0, 2 pi)
    """
    positions = _points(reflectors, "reflectors")
    angles = as_finite_array("bearings", bearings)
    if angles.shape != (len(positions),):
        raise ValueError(f"bearings must have shape ({len(positions)},), got {angles.shape}")
    motions = as_finite_array("relative_poses", relative_poses)
    if motions.shape != (len(positions), 3):
        raise ValueError(
            f"relative_poses must have shape ({len(positions)}, 3), got {motions.shape}"
        )
    estimate = as_finite_array("estimated_pose", estimated_pose)
    if estimate.shape != (3,):
        raise ValueError(f"estimated_pose must have shape (3,), got {estimate.shape}")
    corrected = np.empty(len(positions))
    correct_robot_bearings(
        positions,
        np.ascontiguousarray(angles),
        np.ascontiguousarray(motions),
        np.ascontiguousarray(estimate),
        (head or LaserHead()).kernel_parameters,
        corrected,
    )
    return corrected


# ---------------------------------------------------------------- reflector layouts


def default_reflectors(path_set: PathSet | str) -> Array:
    """A path set's reflector layout (:attr:`~mobile_envs.tracks.sets.PathSet.reflectors`),
    which each set carries: the course's area and random paths
    (:data:`~mobile_envs.tracks.course.OPEN_AREA_REFLECTORS`), a post of the maze grid each
    (:func:`~mobile_envs.tracks.mazes.maze_reflectors`), seed 003's lab
    (:data:`~mobile_envs.tracks.arc_straight.LAB_REFLECTORS`), both for the training mix.

    :param path_set: a path set, or the name of a registered one
    :return: (R, 2) positions (m), a new array
    :raises ValueError: naming ``path_set_name`` for an unknown name or a set without a layout
    """
    if isinstance(path_set, str):
        if path_set not in PATH_SETS:
            known = ", ".join(PATH_SETS.names())
            raise ValueError(
                f"path_set_name {path_set!r} is not a registered path set; known: {known}"
            )
        path_set = catalogued_path_set(path_set)
    if path_set.reflectors is None:
        raise ValueError(
            f"path_set_name {path_set.name!r} has no default reflector layout (a PathSet's "
            "reflectors). Give the reflectors' positions instead"
        )
    return np.array(path_set.reflectors)


def validate_reflectors(reflectors: ArrayLike) -> Array:
    """User-given reflector positions as a read-only (R, 2) float64 array.

    :raises ValueError: naming ``reflectors`` unless they are finite, (R, 2) with R >= 3 and
        not all on one line (three aligned reflectors fix nothing)
    """
    positions = _points(reflectors, "reflectors", minimum=3).copy()
    # All on one line iff the centred positions span one dimension.
    spread = np.linalg.svd(positions - positions.mean(axis=0), compute_uv=False)
    if spread[1] <= 1e-9 * spread[0]:
        raise ValueError(f"reflectors must not all be collinear, got {positions.tolist()}")
    positions.flags.writeable = False
    return positions

"""Compiled path geometry: projection onto a path and lookups by arc length, per robot.

These kernels read the packed segment table of :class:`mobile_envs.world.paths.PathTable`: an array
``columns`` of shape (``NUM_COLUMNS``, capacity) holding, for segment j of every path, the
quantities named by the column constants below, each path's segments side by side. Path p
(row p of the table) has ``spans[p] = (first, last)``: its segments are columns ``first`` to
``first + last``, and ``last`` is its last segment's index on the path. The per-robot
functions take a row's ``first_segment`` and ``last_segment`` and count segments from the
path's start, so a segment index means the same whatever column it is stored in.
:class:`~mobile_envs.world.paths.PathTable` validates and batches; the per-robot functions are
also called from the environment's compiled step, so the env and the public path queries
share one copy of the geometry.

All kernels are compiled by numba without fast-math: the same inputs give the same bits.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# Rows of the packed segment table, one column per segment.
(
    START_X,
    START_Y,
    DELTA_X,
    DELTA_Y,
    INV_LENGTH_SQ,
    START_S,
    LENGTH,
    INV_LENGTH,
    HEADING,
) = range(9)
NUM_COLUMNS = 9


# Distances (m) closer than this count as equal, and so do arc lengths: two points of a path
# that lie this close together are one point (see mobile_envs.world.paths.DUPLICATE_TOLERANCE).
TIE_TOLERANCE = 1e-9
# Angles (rad) closer than this count as equal when a tie is broken by the robot's heading.
HEADING_TOLERANCE = 1e-9


@njit(cache=True)
def _closest_on_segment(columns, first_segment, segment, x, y):
    """The point of one segment closest to (x, y): (squared distance, fraction along the
    segment, side), the side positive left of the segment's direction."""
    column = first_segment + segment
    delta_x = columns[DELTA_X, column]
    delta_y = columns[DELTA_Y, column]
    offset_x = x - columns[START_X, column]
    offset_y = y - columns[START_Y, column]
    fraction = (offset_x * delta_x + offset_y * delta_y) * columns[INV_LENGTH_SQ, column]
    fraction = min(max(fraction, 0.0), 1.0)
    gap_x = offset_x - fraction * delta_x
    gap_y = offset_y - fraction * delta_y
    return gap_x * gap_x + gap_y * gap_y, fraction, delta_x * offset_y - delta_y * offset_x


@njit(cache=True)
def _heading_gap(columns, first_segment, segment, heading):
    """The angle (rad, in [0, pi]) between a segment's direction and ``heading``; NaN for a NaN
    heading. No trigonometry: a library call in the projection kernel slows its loop."""
    gap = heading - columns[HEADING, first_segment + segment]
    return abs(gap - 2.0 * math.pi * np.floor((gap + math.pi) / (2.0 * math.pi)))


@njit(cache=True)
def _equally_close(distance_sq, best_distance_sq):
    """Whether two distances d and b, given squared, are within :data:`TIE_TOLERANCE` t of
    each other: d^2 - b^2 <= t (2 b + t) when d >= b, and b^2 - d^2 <= t (2 b - t) (or b < t)
    when d < b. One bound for both sides would stretch the tie below b to (1 + sqrt 2) t."""
    best = math.sqrt(best_distance_sq)
    if distance_sq >= best_distance_sq:
        return distance_sq - best_distance_sq <= TIE_TOLERANCE * (2.0 * best + TIE_TOLERANCE)
    return best < TIE_TOLERANCE or (
        best_distance_sq - distance_sq <= TIE_TOLERANCE * (2.0 * best - TIE_TOLERANCE)
    )


@njit(cache=True)
def project_on_row(
    columns, first_segment, last_segment, x, y, heading, first, windowed, search_distance
):
    """The closest point to (x, y) on the path whose segments start at column
    ``first_segment``: (s, cross_track_error, segment).

    The search starts at segment ``first``. Windowed, it follows the robot's own progress, as
    MATLAB's controllerPurePursuit walks forward from its current segment: segment ``first``
    always counts, and a later segment counts while it starts within ``search_distance`` beyond
    the robot's projection on ``first``. A leg that doubles back over the one being driven
    starts far ahead of the robot, so it cannot take the projection until the robot nears the
    turn. Otherwise every segment from ``first`` to ``last_segment`` counts.

    Two distinct points of the path (arc lengths more than :data:`TIE_TOLERANCE` apart) at the
    same distance (within :data:`TIE_TOLERANCE`), as on legs that overlap, are a tie: the
    earlier point wins, except that a windowed search takes the later one when its segment
    points closer to ``heading`` (rad; NaN when unknown), the way the robot faces, so a robot
    that has turned round follows the return leg. Between equally close candidates that are one
    point (a vertex), the closer by floating point, and then the earlier, wins. The cross-track
    error is positive left of the closest segment's direction.
    """
    limit = math.inf
    best_distance_sq = band = math.inf
    best_segment, best_fraction, best_side = first, 0.0, 0.0
    for segment in range(first, last_segment + 1):
        start_s = columns[START_S, first_segment + segment]
        if windowed and segment > first and start_s > limit:
            break  # start arc lengths only grow along the path
        distance_sq, fraction, side = _closest_on_segment(columns, first_segment, segment, x, y)
        if segment == first:
            limit = start_s + fraction * columns[LENGTH, first_segment + segment] + search_distance
        if distance_sq >= best_distance_sq + band:
            continue  # farther, the usual case
        if segment > first and distance_sq > best_distance_sq - band:
            # Nearly as close as the best (rare): decide on the exact tie width.
            if _equally_close(distance_sq, best_distance_sq):
                s = start_s + fraction * columns[LENGTH, first_segment + segment]
                best_s = columns[START_S, first_segment + best_segment]
                best_s += best_fraction * columns[LENGTH, first_segment + best_segment]
                if abs(s - best_s) > TIE_TOLERANCE:  # two points of the path: a tie
                    later_wins = windowed and _heading_gap(
                        columns, first_segment, segment, heading
                    ) < (
                        _heading_gap(columns, first_segment, best_segment, heading)
                        - HEADING_TOLERANCE
                    )
                    if not later_wins:
                        continue
                elif not distance_sq < best_distance_sq:  # one vertex, seen from two segments
                    continue
            elif distance_sq > best_distance_sq:
                continue
        best_distance_sq, best_segment, best_fraction = distance_sq, segment, fraction
        best_side = side
        # A band of squared distances that holds every tie (2 b t <= (b^2 + 1) t), found
        # without a square root: the exact test runs inside it only.
        band = TIE_TOLERANCE * (distance_sq + 1.0 + TIE_TOLERANCE)
    s = (
        columns[START_S, first_segment + best_segment]
        + best_fraction * columns[LENGTH, first_segment + best_segment]
    )
    return s, math.copysign(math.sqrt(best_distance_sq), best_side), best_segment


@njit(cache=True)
def locate_on_row(columns, first_segment, last_segment, length, s):
    """The segment holding arc length ``s`` (clamped to [0, length]) and the fraction along it.

    On a vertex, the segment that starts there; at the path's end, the last segment.
    """
    s = min(max(s, 0.0), length)
    low, high = 0, last_segment  # the answer lies in [low, high]
    while low < high:
        middle = (low + high + 1) // 2
        if columns[START_S, first_segment + middle] <= s:
            low = middle
        else:
            high = middle - 1
    return low, _fraction_along(columns, first_segment + low, s)


@njit(cache=True)
def _fraction_along(columns, column, s):
    """How far along the segment stored in column ``column`` arc length ``s`` lies, clamped
    to [0, 1]."""
    fraction = (s - columns[START_S, column]) * columns[INV_LENGTH, column]
    return min(max(fraction, 0.0), 1.0)


@njit(cache=True)
def _point_of_column(columns, column, fraction):
    """(x, y) at ``fraction`` along the segment stored in column ``column``."""
    x = columns[START_X, column] + fraction * columns[DELTA_X, column]
    y = columns[START_Y, column] + fraction * columns[DELTA_Y, column]
    return x, y


@njit(cache=True)
def point_on_row(columns, first_segment, last_segment, length, s):
    """(x, y) of the path at arc length ``s``, clamped to the path."""
    segment, fraction = locate_on_row(columns, first_segment, last_segment, length, s)
    return _point_of_column(columns, first_segment + segment, fraction)


@njit(cache=True)
def heading_on_row(columns, first_segment, last_segment, length, s):
    """Heading (rad) of the path at arc length ``s``: the segment's that starts on a vertex."""
    segment, _ = locate_on_row(columns, first_segment, last_segment, length, s)
    return columns[HEADING, first_segment + segment]


@njit(cache=True)
def _walk_to(columns, first_segment, last_segment, length, s, segment):
    """:func:`locate_on_row` for an ``s`` at or past segment ``segment``'s start: the same
    answer, found by walking forward from ``segment`` instead of bisecting the whole path."""
    s = min(max(s, 0.0), length)
    while segment < last_segment and columns[START_S, first_segment + segment + 1] <= s:
        segment += 1
    return segment, _fraction_along(columns, first_segment + segment, s)


@njit(cache=True)
def heading_from(columns, first_segment, last_segment, length, s, segment):
    """:func:`heading_on_row` for an ``s`` at or past segment ``segment``'s start (a
    projection's own segment): the same heading, found by walking on from ``segment``
    instead of bisecting the whole path."""
    segment, _ = _walk_to(columns, first_segment, last_segment, length, s, segment)
    return columns[HEADING, first_segment + segment]


@njit(cache=True)
def preview_on_row(
    columns, first_segment, last_segment, length, x, y, heading, s, segment, offsets, out
):  # fmt: skip
    """Points ``offsets`` ahead of arc length ``s`` on the path in the frame of the pose
    (x, y, heading), written to ``out`` (K, 2): forward, left. Past the end: the goal.

    ``segment`` is a segment that starts at or before ``s`` (the one ``s`` was projected
    on), or -1 when none is known. Each point is found by walking on from the segment of the
    point before (from ``segment`` for the first) while the offsets grow (the usual preview),
    else by bisection: the same answer either way, the walk cheaper.
    """
    cos_heading, sin_heading = math.cos(heading), math.sin(heading)
    for k in range(offsets.shape[0]):
        ahead = s + offsets[k]
        if (k > 0 and offsets[k] >= offsets[k - 1]) or (
            k == 0 and segment >= 0 and offsets[0] >= 0.0
        ):
            segment, fraction = _walk_to(
                columns, first_segment, last_segment, length, ahead, segment
            )
        else:
            segment, fraction = locate_on_row(columns, first_segment, last_segment, length, ahead)
        point_x, point_y = _point_of_column(columns, first_segment + segment, fraction)
        to_x, to_y = point_x - x, point_y - y
        out[k, 0] = cos_heading * to_x + sin_heading * to_y
        out[k, 1] = cos_heading * to_y - sin_heading * to_x


# ---------------------------------------------------------------- batched over robots


@njit(cache=True)
def project_robots(columns, spans, rows, xy, headings, first, windowed, search_distance):
    """:func:`project_on_row` for each robot i on row ``rows[i]`` at ``xy[i]``, heading
    ``headings[i]``."""
    count = rows.shape[0]
    s = np.empty(count)
    cross_track_error = np.empty(count)
    segment = np.empty(count, dtype=np.int64)
    for i in range(count):
        row = rows[i]
        s[i], cross_track_error[i], segment[i] = project_on_row(
            columns, spans[row, 0], spans[row, 1], xy[i, 0], xy[i, 1], headings[i], first[i],
            windowed, search_distance,
        )  # fmt: skip
    return s, cross_track_error, segment


@njit(cache=True)
def points_at(columns, spans, lengths, rows, s):
    """(n, 2) points at arc lengths ``s[i]`` on rows ``rows[i]``."""
    points = np.empty((s.shape[0], 2))
    for i in range(s.shape[0]):
        row = rows[i]
        points[i, 0], points[i, 1] = point_on_row(
            columns, spans[row, 0], spans[row, 1], lengths[row], s[i]
        )
    return points


@njit(cache=True)
def headings_at(columns, spans, lengths, rows, s):
    """(n,) path headings at arc lengths ``s[i]`` on rows ``rows[i]``."""
    headings = np.empty(s.shape[0])
    for i in range(s.shape[0]):
        row = rows[i]
        headings[i] = heading_on_row(columns, spans[row, 0], spans[row, 1], lengths[row], s[i])
    return headings


@njit(cache=True)
def previews(columns, spans, lengths, rows, poses, s, offsets):
    """(N, K, 2) preview points of each robot, in its own frame: see :func:`preview_on_row`."""
    out = np.empty((rows.shape[0], offsets.shape[0], 2))
    for i in range(rows.shape[0]):
        row = rows[i]
        preview_on_row(
            columns, spans[row, 0], spans[row, 1], lengths[row], poses[i, 0], poses[i, 1],
            poses[i, 2], s[i], -1, offsets, out[i],
        )  # fmt: skip
    return out

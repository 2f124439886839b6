"""The compiled per-robot step of :class:`mobile_envs.core.PathFollowingCore`.

A step is three kernels over all N robots, each one call from Python whatever N is:

1. :func:`move_robots`: actions to native inputs, the kinematic step, the projection onto the
   path and the running episode metrics;
2. (in a maze, the walls are sensed between the two, by :meth:`mobile_envs.maze.Maze.sense`);
3. :func:`score_robots`: success, failure, truncation and the reward;

and :func:`observe_robots` writes observations. Every per-robot scalar lives in one of three
packed arrays, ``floats``, ``ints`` and ``flags`` (N, columns), whose columns are named by the
constants below; the core exposes each column as a named view. Packing keeps the kernels'
argument lists short: a call costs about 30 ns per array argument, and a single environment
step must cost no more than Pendulum-v1's (a few microseconds).

The physics and geometry come from :mod:`mobile_envs.kinematics` and
:mod:`mobile_envs.path_geometry`; nothing here is a second copy of them. No fast-math: the same
inputs give the same bits, and robot i's result does not depend on N.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from mobile_envs.kinematics import advance_robot, robot_twist, wrap_scalar_angle
from mobile_envs.path_geometry import heading_on_row, preview_on_row, project_on_row

# Columns of ``floats``.
FLOAT_FIELDS = (
    "arc_length",
    "cross_track_error",
    "heading_error",
    "speed",
    "yaw_rate",
    "path_length",
    "progress",
    "farthest_arc_length",
    "sum_abs_cte",
    "sum_sq_cte",
    "max_abs_cte",
    "distance",
    "reward",
)
(
    ARC_LENGTH,
    CROSS_TRACK_ERROR,
    HEADING_ERROR,
    SPEED,
    YAW_RATE,
    PATH_LENGTH,
    PROGRESS,
    FARTHEST_ARC_LENGTH,
    SUM_ABS_CTE,
    SUM_SQ_CTE,
    MAX_ABS_CTE,
    DISTANCE,
    REWARD,
) = range(len(FLOAT_FIELDS))

# Columns of ``ints``.
INT_FIELDS = ("path_row", "segment", "steps", "time_limit", "steps_without_progress")
ROW, SEGMENT, STEPS, TIME_LIMIT, STEPS_WITHOUT_PROGRESS = range(len(INT_FIELDS))

# Columns of ``flags``.
FLAG_FIELDS = ("collision", "success", "off_track", "stalled", "terminated", "truncated")
COLLISION, SUCCESS, OFF_TRACK, STALLED, TERMINATED, TRUNCATED = range(len(FLAG_FIELDS))

# Entries of ``settings``: the configuration as numbers.
SETTING_FIELDS = (
    "dt",
    "search_distance",
    "goal_radius",
    "max_cross_track",
    "stall_steps",
    "stall_progress",
    "progress_weight",
    "time_weight",
    "cross_track_weight",
    "cross_track_squared_weight",
    "heading_weight",
    "action_change_weight",
    "goal_bonus",
    "failure_penalty",
)
(
    DT,
    SEARCH_DISTANCE,
    GOAL_RADIUS,
    MAX_CROSS_TRACK,
    STALL_STEPS,
    STALL_PROGRESS,
    PROGRESS_WEIGHT,
    TIME_WEIGHT,
    CROSS_TRACK_WEIGHT,
    CROSS_TRACK_SQUARED_WEIGHT,
    HEADING_WEIGHT,
    ACTION_CHANGE_WEIGHT,
    GOAL_BONUS,
    FAILURE_PENALTY,
) = range(len(SETTING_FIELDS))

# Entries of ``scales``: what each observation element is divided by, as a factor.
SCALE_FIELDS = (
    "preview",
    "cross_track",
    "heading",
    "fine_cross_track",
    "fine_heading",
    "speed",
    "yaw_rate",
    "extra_state",
    "range",
)
(
    PREVIEW_SCALE,
    CROSS_TRACK_SCALE,
    HEADING_SCALE,
    FINE_CROSS_TRACK_SCALE,
    FINE_HEADING_SCALE,
    SPEED_SCALE,
    YAW_RATE_SCALE,
    EXTRA_STATE_SCALE,
    RANGE_SCALE,
) = range(len(SCALE_FIELDS))

# What the observation's model-specific element reads: nothing, the tricycle's wheel angle
# (state column 3), or the holonomic robot's lateral velocity (input column 1).
NO_EXTRA_STATE, WHEEL_ANGLE, LATERAL_VELOCITY = range(3)


@njit(cache=True)
def _bounded(value):
    """``value`` clipped to [-1, 1]."""
    return min(max(value, -1.0), 1.0)


@njit(cache=True)
def actions_are_finite(actions):
    """Whether every action is finite (checked before any robot moves)."""
    for value in actions.flat:  # noqa: SIM110 (numba compiles no generator into all())
        if not math.isfinite(value):
            return False
    return True


@njit(cache=True)
def clipped_to_unit(actions, rows, columns):
    """A (rows, columns) float64 copy of ``actions`` clipped to [-1, 1]."""
    clipped = np.empty((rows, columns))
    flat = clipped.reshape(rows * columns)
    for index, value in enumerate(actions.flat):
        flat[index] = _bounded(value)
    return clipped


@njit(cache=True)
def project_robot(i, first_segment, settings, columns, last_segments, lengths, state, floats, ints):
    """Project robot ``i`` onto its path, searching from ``first_segment`` on; record its arc
    length, cross-track error, segment and heading error."""
    row = ints[i, ROW]
    s, cross_track_error, segment = project_on_row(
        columns, row, last_segments[row], state[i, 0], state[i, 1], first_segment, True,
        settings[SEARCH_DISTANCE],
    )  # fmt: skip
    floats[i, ARC_LENGTH] = s
    floats[i, CROSS_TRACK_ERROR] = cross_track_error
    ints[i, SEGMENT] = segment
    tangent = heading_on_row(columns, row, last_segments[row], lengths[row], s)
    floats[i, HEADING_ERROR] = wrap_scalar_angle(state[i, 2] - tangent)


@njit(cache=True)
def locate_robots(indices, settings, columns, last_segments, lengths, state, floats, ints):
    """Project freshly reset robots ``indices`` from their path's first segment on."""
    for i in indices:
        project_robot(i, 0, settings, columns, last_segments, lengths, state, floats, ints)
        floats[i, FARTHEST_ARC_LENGTH] = floats[i, ARC_LENGTH]


@njit(cache=True)
def move_robots(
    model_code, model_parameters, integrator_code, settings, columns, last_segments, lengths,
    actions, action_center, action_half_range, state, inputs, floats, ints,
):  # fmt: skip
    """Step every robot under its (clipped, finite) action; update its projection and metrics.

    The twist recorded is the one at the step's start (the tricycle's wheel turns during it).
    """
    dt = settings[DT]
    for i in range(state.shape[0]):
        for j in range(inputs.shape[1]):
            inputs[i, j] = action_center[j] + actions[i, j] * action_half_range[j]
        floats[i, SPEED], floats[i, YAW_RATE] = robot_twist(
            model_code, model_parameters, state[i], inputs[i]
        )
        start_x, start_y = state[i, 0], state[i, 1]
        advance_robot(
            model_code, model_parameters, state[i], inputs[i], dt, integrator_code, state[i]
        )
        previous_arc_length = floats[i, ARC_LENGTH]
        project_robot(
            i, ints[i, SEGMENT], settings, columns, last_segments, lengths, state, floats, ints
        )
        floats[i, PROGRESS] = floats[i, ARC_LENGTH] - previous_arc_length

        cross_track_error = floats[i, CROSS_TRACK_ERROR]
        abs_cte = abs(cross_track_error)
        ints[i, STEPS] += 1
        floats[i, SUM_ABS_CTE] += abs_cte
        floats[i, SUM_SQ_CTE] += cross_track_error * cross_track_error
        floats[i, MAX_ABS_CTE] = max(floats[i, MAX_ABS_CTE], abs_cte)
        floats[i, DISTANCE] += math.hypot(state[i, 0] - start_x, state[i, 1] - start_y)


@njit(cache=True)
def score_robots(settings, goals, actions, previous_action, state, floats, ints, flags):
    """Success, failure and truncation of every robot after :func:`move_robots` (and wall
    sensing), and its reward; the actions become the previous actions."""
    dt = settings[DT]
    for i in range(state.shape[0]):
        row = ints[i, ROW]
        s = floats[i, ARC_LENGTH]
        abs_cte = abs(floats[i, CROSS_TRACK_ERROR])
        goal_distance = math.hypot(state[i, 0] - goals[row, 0], state[i, 1] - goals[row, 1])
        success = goal_distance <= settings[GOAL_RADIUS] and s >= 0.9 * floats[i, PATH_LENGTH]
        off_track = abs_cte > settings[MAX_CROSS_TRACK]
        # A robot that stops short of the goal must not look safer than one that tries: with
        # discounting, waiting for the time limit would cost far less than a collision.
        if s > floats[i, FARTHEST_ARC_LENGTH] + settings[STALL_PROGRESS]:
            floats[i, FARTHEST_ARC_LENGTH] = s
            ints[i, STEPS_WITHOUT_PROGRESS] = 0
        else:
            ints[i, STEPS_WITHOUT_PROGRESS] += 1
        stalled = ints[i, STEPS_WITHOUT_PROGRESS] >= settings[STALL_STEPS]
        failure = (off_track or flags[i, COLLISION] or stalled) and not success
        terminated = success or failure
        flags[i, SUCCESS] = success
        flags[i, OFF_TRACK] = off_track
        flags[i, STALLED] = stalled and not success
        flags[i, TERMINATED] = terminated
        flags[i, TRUNCATED] = ints[i, STEPS] >= ints[i, TIME_LIMIT] and not terminated

        action_change = 0.0
        for j in range(actions.shape[1]):
            change = actions[i, j] - previous_action[i, j]
            action_change += change * change
            previous_action[i, j] = actions[i, j]
        action_change /= actions.shape[1]
        floats[i, REWARD] = (
            settings[PROGRESS_WEIGHT] * floats[i, PROGRESS]
            - settings[TIME_WEIGHT]
            - (settings[CROSS_TRACK_WEIGHT] + settings[CROSS_TRACK_SQUARED_WEIGHT] * abs_cte)
            * abs_cte
            * dt
            - settings[HEADING_WEIGHT] * abs(floats[i, HEADING_ERROR]) * dt
            - settings[ACTION_CHANGE_WEIGHT] * action_change
            + settings[GOAL_BONUS] * success
            - settings[FAILURE_PENALTY] * failure
        )


@njit(cache=True)
def observe_robots(
    indices, scales, extra_state, columns, last_segments, lengths, preview_offsets,
    state, inputs, previous_action, floats, ints, ranges, preview, out,
):  # fmt: skip
    """Observation of each robot in ``indices`` into the rows of ``out`` (float32), every
    element clipped to [-1, 1]; the layout is :attr:`mobile_envs.core.CoreConfig.observation_names`.

    :param preview: (K, 2) float64 scratch space for the preview points
    """
    num_points = preview_offsets.shape[0]
    for k in range(indices.shape[0]):
        i = indices[k]
        row = ints[i, ROW]
        preview_on_row(
            columns, row, last_segments[row], lengths[row], state[i, 0], state[i, 1],
            state[i, 2], floats[i, ARC_LENGTH], preview_offsets, preview,
        )  # fmt: skip
        for p in range(num_points):
            out[k, 2 * p] = _bounded(preview[p, 0] * scales[PREVIEW_SCALE])
            out[k, 2 * p + 1] = _bounded(preview[p, 1] * scales[PREVIEW_SCALE])
        column = 2 * num_points
        cross_track_error, heading_error = floats[i, CROSS_TRACK_ERROR], floats[i, HEADING_ERROR]
        out[k, column] = _bounded(cross_track_error * scales[CROSS_TRACK_SCALE])
        out[k, column + 1] = _bounded(heading_error * scales[HEADING_SCALE])
        out[k, column + 2] = math.tanh(cross_track_error * scales[FINE_CROSS_TRACK_SCALE])
        out[k, column + 3] = math.tanh(heading_error * scales[FINE_HEADING_SCALE])
        out[k, column + 4] = _bounded(floats[i, SPEED] * scales[SPEED_SCALE])
        out[k, column + 5] = _bounded(floats[i, YAW_RATE] * scales[YAW_RATE_SCALE])
        column += 6
        if extra_state == WHEEL_ANGLE:
            out[k, column] = _bounded(state[i, 3] * scales[EXTRA_STATE_SCALE])
            column += 1
        elif extra_state == LATERAL_VELOCITY:
            out[k, column] = _bounded(inputs[i, 1] * scales[EXTRA_STATE_SCALE])
            column += 1
        out[k, column] = _bounded(1.0 - floats[i, ARC_LENGTH] / floats[i, PATH_LENGTH])
        column += 1
        for j in range(previous_action.shape[1]):
            out[k, column + j] = previous_action[i, j]
        column += previous_action.shape[1]
        for r in range(ranges.shape[1]):
            out[k, column + r] = _bounded(ranges[i, r] * scales[RANGE_SCALE])

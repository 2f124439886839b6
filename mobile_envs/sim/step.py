"""The compiled per-robot step of :class:`mobile_envs.sim.core.PathFollowingCore`.

A step is two kernels over all N robots, each one call from Python whatever N is:

1. :func:`move_robots`: actions to native inputs, the kinematic step, the projection onto the
   path and the running episode metrics;
2. (between the two, the core finds maze-wall collisions, localizes and its sensors measure;)
3. :func:`score_robots`: success, failure, truncation and the reward;

or one, :func:`move_and_score_robots`, when nothing runs between them; and
:func:`observe_robots` writes observations. A single environment's usual step (no
localization, no sensor but maze rays) is one call in all, :func:`step_and_observe_robots`.
Every per-robot scalar lives in a column of one of three packed arrays, ``floats``, ``ints``
and ``flags``, named in :mod:`mobile_envs.sim.columns` (here ``F``, ``Z`` for the ints and
``B`` for the flags). The kernels take the core's robot arrays as one tuple (``robots``:
state, inputs, floats, ints, flags, previous action) and the path table's as another
(``path``: columns, spans, lengths, goals), so each argument is one fact; a call costs about
30 ns per array, and a single environment step must cost no more than Pendulum-v1's (a few
microseconds).

The physics comes from the model's module and the geometry from
:mod:`mobile_envs.world.geometry`; nothing here is a second copy of them. The kernels that move
robots are templates (:func:`~mobile_envs._kernels.specialize.per_model`) that call the
model's compiled ``advance`` and ``twist`` through ``model``: the core compiles them for its
model with :func:`~mobile_envs._kernels.specialize.for_model`, so they name no model. No
fast-math: the same inputs give the same bits, and robot i's result does not depend on N.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from mobile_envs._kernels.angles import wrap_scalar_angle
from mobile_envs._kernels.specialize import model, per_model
from mobile_envs.robots import FROM_STATE
from mobile_envs.sim.columns import FlagColumn, FloatColumn, IntColumn, Setting
from mobile_envs.sim.observation import LayoutEntry, PathScale
from mobile_envs.sim.plant import actuate, slip
from mobile_envs.world.geometry import heading_from, preview_on_row, project_on_row
from mobile_envs.world.maze import sense_packed

# Short local names, so the kernels read like the formulas: F for the floats' columns, Z (the
# integers) for the ints', B (booleans) for the flags' and S for the settings.
F, Z, B, S = FloatColumn, IntColumn, FlagColumn, Setting
_PATH_SCALES = len(PathScale)
_LAYOUT_HEADER = len(LayoutEntry)


@njit(cache=True)
def _bounded(value):
    """``value`` clipped to [-1, 1]."""
    return min(max(value, -1.0), 1.0)


@njit(cache=True)
def clipped_to_unit(actions, rows, columns):
    """A (rows, columns) float64 copy of ``actions`` clipped to [-1, 1], and whether every
    action was finite (checked before any robot moves; one call for both)."""
    clipped = np.empty((rows, columns))
    flat = clipped.reshape(rows * columns)
    finite = True
    for index, value in enumerate(actions.flat):
        finite = finite and math.isfinite(value)
        flat[index] = _bounded(value)
    return clipped, finite


# Where the believed projection lives, relative to the true one (the same three columns).
BELIEF = F.ESTIMATED_ARC_LENGTH - F.ARC_LENGTH


@njit(cache=True, inline="always")
def project_robot(
    i, start_segment, settings, columns, spans, lengths, poses, floats, ints, belief,
    segment_column,
):  # fmt: skip
    """Project pose ``poses[i]`` of robot ``i`` onto its path, searching from segment
    ``start_segment`` on; record its arc length, cross-track error and heading error
    ``belief`` columns after ARC_LENGTH (0: the truth, :data:`BELIEF`: the estimate) and its
    segment in ``segment_column``."""
    row = ints[i, Z.PATH_ROW]
    s, cross_track_error, segment = project_on_row(
        columns, spans[row, 0], spans[row, 1], poses[i, 0], poses[i, 1], poses[i, 2],
        start_segment, True, settings[S.SEARCH_DISTANCE],
    )  # fmt: skip
    floats[i, F.ARC_LENGTH + belief] = s
    floats[i, F.CROSS_TRACK_ERROR + belief] = cross_track_error
    ints[i, segment_column] = segment
    tangent = heading_from(columns, spans[row, 0], spans[row, 1], lengths[row], s, segment)
    floats[i, F.HEADING_ERROR + belief] = wrap_scalar_angle(poses[i, 2] - tangent)


@njit(cache=True)
def start_robots(indices, poses, time_limits, settings, path, robots):
    """Start robots ``indices`` (already on their path rows) at ``poses[k]`` (x, y and a
    heading, wrapped here): every other state, metric, counter, flag, input and previous
    action zeroed, the path length and ``time_limits[k]`` recorded, and the robot projected
    from its path's first segment on."""
    columns, spans, lengths, _ = path
    state, inputs, floats, ints, flags, previous_action = robots
    for k in range(indices.shape[0]):
        i = indices[k]
        state[i] = 0.0
        state[i, 0], state[i, 1] = poses[k, 0], poses[k, 1]
        state[i, 2] = wrap_scalar_angle(poses[k, 2])
        floats[i] = 0.0
        ints[i, Z.PATH_ROW + 1 :] = 0
        flags[i] = False
        inputs[i] = 0.0
        previous_action[i] = 0.0
        floats[i, F.PATH_LENGTH] = lengths[ints[i, Z.PATH_ROW]]
        ints[i, Z.TIME_LIMIT] = time_limits[k]
        # From segment 0, typed int64: a literal 0 would have numba compile the projection
        # once more, for that constant alone.
        first = np.int64(0)
        project_robot(
            i, first, settings, columns, spans, lengths, state, floats, ints, 0, Z.SEGMENT
        )  # fmt: skip
        floats[i, F.FARTHEST_ARC_LENGTH] = floats[i, F.ARC_LENGTH]
        floats[i, F.PEAK_ABS_CTE] = abs(floats[i, F.CROSS_TRACK_ERROR])


@njit(cache=True)
def track_estimates(indices, from_start, settings, path, robots, estimate):
    """Project the estimated poses of robots ``indices`` (from the path's start for freshly
    reset robots, else from their last estimated segment) and record their localization
    error, the distance from the estimated to the true position, and the heading's; steps
    (not resets) add the distance to the episode's sum and max."""
    columns, spans, lengths, _ = path
    state, _, floats, ints, _, _ = robots
    for i in indices:
        first = 0 if from_start else ints[i, Z.ESTIMATED_SEGMENT]
        project_robot(
            i, first, settings, columns, spans, lengths, estimate, floats, ints, BELIEF,
            Z.ESTIMATED_SEGMENT,
        )  # fmt: skip
        error = math.hypot(estimate[i, 0] - state[i, 0], estimate[i, 1] - state[i, 1])
        floats[i, F.LOCALIZATION_ERROR] = error
        floats[i, F.HEADING_LOCALIZATION_ERROR] = wrap_scalar_angle(estimate[i, 2] - state[i, 2])
        if not from_start:
            floats[i, F.SUM_LOCALIZATION_ERROR] += error
            floats[i, F.MAX_LOCALIZATION_ERROR] = max(floats[i, F.MAX_LOCALIZATION_ERROR], error)


@njit(cache=True)
def _chunk(chunk, chunks, count):
    """The range [first, stop) of items that chunk ``chunk`` of ``chunks`` takes of ``count``."""
    return chunk * count // chunks, (chunk + 1) * count // chunks


@per_model()
def move_robots(
    model_parameters, integrator_code, settings, path, actions, action_map, robots, plant
):
    """Step every robot under its (clipped, finite) action; update its projection and metrics.

    :param model_parameters: the nominal model's ``kernel_parameters``
    :param integrator_code: ``INTEGRATORS.index(integrator)``
    :param settings: the core's settings (:class:`~mobile_envs.sim.columns.Setting`)
    :param path: the path table's ``kernel_arrays`` (columns, spans, lengths, goals)
    :param actions: (N, m) in [-1, 1]
    :param action_map: (2, m): each action's centre and half range in native inputs
    :param robots: the core's packed robot arrays (state, inputs, floats, ints, flags,
        previous action)
    :param plant: None for the ideal robot, else the :class:`~mobile_envs.sim.plant.Plant`'s
        ``kernel_arrays``: the inputs are the realized ones and the true robot moves

    The twist recorded is the one at the step's start (the tricycle's wheel turns during it),
    of the realized inputs through the nominal model: what the encoders measure.
    """
    _move_range(
        0, robots[0].shape[0], model_parameters, integrator_code, settings, path, actions,
        action_map, robots, plant,
    )  # fmt: skip


@per_model(parallel=True)
def move_robots_parallel(
    chunks, and_score, model_parameters, integrator_code, settings, path, actions, action_map,
    robots, plant,
):  # fmt: skip
    """:func:`move_robots` (with ``and_score``, :func:`move_and_score_robots`) with the robots
    split into ``chunks`` contiguous chunks, run on numba's threads (the caller sets how many:
    ``numba.set_num_threads`` inside a kernel would stop numba caching it). Each chunk moves
    its robots, then scores them (no robot's score reads another robot), so the threads start
    once a step instead of twice. Each robot's arithmetic is the serial one, and so are its
    bits. Separate from the serial kernels because calling any parallel kernel loads numba's
    threading layer, whose OpenMP slowed torch in the same process 80-fold here."""
    count = robots[0].shape[0]
    for chunk in prange(chunks):
        first, stop = _chunk(chunk, chunks, count)
        _move_chunk(
            first, stop, model_parameters, integrator_code, settings, path, actions, action_map,
            robots, plant,
        )  # fmt: skip
        if and_score:
            _score_chunk(first, stop, settings, path, actions, robots)


@per_model()
def _move_chunk(
    first, stop, model_parameters, integrator_code, settings, path, actions, action_map, robots,
    plant,
):  # fmt: skip
    """:func:`_move_range` as a call of its own: inlined into a ``prange`` body, its loop's
    exits would make numba run that loop serially."""
    _move_range(
        first, stop, model_parameters, integrator_code, settings, path, actions, action_map,
        robots, plant,
    )  # fmt: skip


@per_model()
def move_and_score_robots(
    model_parameters, integrator_code, settings, path, actions, action_map, robots, plant
):
    """:func:`move_robots` then :func:`score_robots`, in one call, for a step with nothing
    between the two (no maze, no localization, no sensor that reads anything): the same
    arithmetic robot by robot, so the same bits, for one call's cost instead of two."""
    count = robots[0].shape[0]
    _move_range(
        0, count, model_parameters, integrator_code, settings, path, actions, action_map,
        robots, plant,
    )  # fmt: skip
    _score_range(0, count, settings, path, actions, robots)


@per_model()
def step_and_observe_robots(
    model_parameters, integrator_code, settings, path, actions, action_map, robots, plant,
    walls, observation, out,
):  # fmt: skip
    """A whole step of every robot in one call, the same bits as the calls it replaces:
    :func:`move_robots`, the maze-wall collisions, :func:`score_robots`, then
    :func:`observe_robots` of every robot. For steps where nothing else runs between the move
    and the score (no localization, no sensor but one that casts maze rays): a single
    environment's usual step, which then costs one call from Python instead of three to five.

    :param walls: None in open space, else :func:`~mobile_envs.world.maze.sense_packed`'s
        arguments after the poses (robots, slots, radius, ray angles, max range, walls,
        collision out, ranges out): the collision test and the range sensor's rays
    :param observation: :func:`observe_robots`' arguments but the path, the robots and
        ``out``: (indices, scales, layout, preview offsets, poses, belief, readings, preview)
    :param out: (N, D) float32, the observations
    """
    count = robots[0].shape[0]
    _move_range(
        0, count, model_parameters, integrator_code, settings, path, actions, action_map,
        robots, plant,
    )  # fmt: skip
    if walls is not None:
        indices, slots, radius, angles, max_range, grids, collisions, ranges = walls
        sense_packed(
            robots[0], indices, slots, radius, angles, max_range, grids, collisions, ranges
        )
    _score_range(0, count, settings, path, actions, robots)
    indices, scales, layout, preview_offsets, poses, belief, readings, preview = observation
    _observe_range(
        0, indices.shape[0], indices, scales, layout, path, preview_offsets, robots, poses,
        belief, readings, preview, out,
    )  # fmt: skip


@per_model(inline="always")
def _move_range(
    first, stop, model_parameters, integrator_code, settings, path, actions, action_map, robots,
    plant,
):  # fmt: skip
    """:func:`move_robots` for robots ``first`` to ``stop - 1``."""
    columns, spans, lengths, _ = path
    state, inputs, floats, ints, _, _ = robots
    dt = settings[S.DT]
    if plant is not None:
        # Unpacked once: in the loop each robot would pay for references to five arrays.
        robot_parameters, plant_floats, plant_ints, commands, slip_normals = plant
    for i in range(first, stop):
        if plant is None:
            for j in range(inputs.shape[1]):
                inputs[i, j] = action_map[0, j] + actions[i, j] * action_map[1, j]
            true_parameters = model_parameters
        else:
            actuate(i, actions, action_map, plant_floats, plant_ints, commands, inputs)
            true_parameters = robot_parameters[i]
        floats[i, F.SPEED], floats[i, F.YAW_RATE] = model.twist(
            model_parameters, state[i], inputs[i]
        )
        start_x, start_y, start_heading = state[i, 0], state[i, 1], state[i, 2]
        model.advance(true_parameters, state[i], inputs[i], dt, integrator_code, state[i])
        if plant is not None:
            slip(i, start_x, start_y, start_heading, state, plant_floats, plant_ints, slip_normals)
        previous_arc_length = floats[i, F.ARC_LENGTH]
        project_robot(
            i, ints[i, Z.SEGMENT], settings, columns, spans, lengths, state, floats,
            ints, 0, Z.SEGMENT,
        )  # fmt: skip
        floats[i, F.PROGRESS] = floats[i, F.ARC_LENGTH] - previous_arc_length

        cross_track_error = floats[i, F.CROSS_TRACK_ERROR]
        abs_cte = abs(cross_track_error)
        ints[i, Z.STEPS] += 1
        floats[i, F.SUM_ABS_CTE] += abs_cte
        floats[i, F.SUM_SQ_CTE] += cross_track_error * cross_track_error
        floats[i, F.MAX_ABS_CTE] = max(floats[i, F.MAX_ABS_CTE], abs_cte)
        peak_growth = max(abs_cte - floats[i, F.PEAK_ABS_CTE], 0.0)
        floats[i, F.PEAK_GROWTH] = peak_growth
        floats[i, F.PEAK_ABS_CTE] = max(floats[i, F.PEAK_ABS_CTE], abs_cte)
        floats[i, F.DISTANCE] += math.hypot(state[i, 0] - start_x, state[i, 1] - start_y)


@njit(cache=True)
def score_robots(settings, path, actions, robots):
    """Success, failure and truncation of every robot after :func:`move_robots` (and wall
    sensing), and its reward; the actions become the previous actions."""
    _score_range(0, robots[0].shape[0], settings, path, actions, robots)


@njit(cache=True, parallel=True)
def score_robots_parallel(chunks, settings, path, actions, robots):
    """:func:`score_robots` in ``chunks`` chunks on numba's threads, as
    :func:`move_robots_parallel`."""
    count = robots[0].shape[0]
    for chunk in prange(chunks):
        first, stop = _chunk(chunk, chunks, count)
        _score_chunk(first, stop, settings, path, actions, robots)


@njit(cache=True)
def _score_chunk(first, stop, settings, path, actions, robots):
    """:func:`_score_range` as a call of its own: inlined into a ``prange`` body, its loop's
    exits would make numba run that loop serially."""
    _score_range(first, stop, settings, path, actions, robots)


@njit(cache=True, inline="always")
def _score_range(first, stop, settings, path, actions, robots):
    """:func:`score_robots` for robots ``first`` to ``stop - 1``."""
    goals = path[3]
    state, _, floats, ints, flags, previous_action = robots
    dt = settings[S.DT]
    for i in range(first, stop):
        row = ints[i, Z.PATH_ROW]
        s = floats[i, F.ARC_LENGTH]
        abs_cte = abs(floats[i, F.CROSS_TRACK_ERROR])
        goal_distance = math.hypot(state[i, 0] - goals[row, 0], state[i, 1] - goals[row, 1])
        success = goal_distance <= settings[S.GOAL_RADIUS] and s >= 0.9 * floats[i, F.PATH_LENGTH]
        off_track = abs_cte > settings[S.MAX_CROSS_TRACK]
        # A robot that stops short of the goal must not look safer than one that tries: with
        # discounting, waiting for the time limit would cost far less than a collision.
        if s > floats[i, F.FARTHEST_ARC_LENGTH] + settings[S.STALL_PROGRESS]:
            floats[i, F.FARTHEST_ARC_LENGTH] = s
            ints[i, Z.STEPS_WITHOUT_PROGRESS] = 0
        else:
            ints[i, Z.STEPS_WITHOUT_PROGRESS] += 1
        stalled = ints[i, Z.STEPS_WITHOUT_PROGRESS] >= settings[S.STALL_STEPS]
        failure = (off_track or flags[i, B.COLLISION] or stalled) and not success
        terminated = success or failure
        flags[i, B.SUCCESS] = success
        flags[i, B.OFF_TRACK] = off_track
        flags[i, B.STALLED] = stalled and not success
        flags[i, B.TERMINATED] = terminated
        flags[i, B.TRUNCATED] = ints[i, Z.STEPS] >= ints[i, Z.TIME_LIMIT] and not terminated

        action_change = 0.0
        for j in range(actions.shape[1]):
            change = actions[i, j] - previous_action[i, j]
            action_change += change * change
            previous_action[i, j] = actions[i, j]
        action_change /= actions.shape[1]
        floats[i, F.REWARD] = (
            settings[S.PROGRESS_WEIGHT] * floats[i, F.PROGRESS]
            - settings[S.TIME_WEIGHT]
            - (settings[S.CROSS_TRACK_WEIGHT] + settings[S.CROSS_TRACK_SQUARED_WEIGHT] * abs_cte)
            * abs_cte
            * dt
            - settings[S.HEADING_WEIGHT] * abs(floats[i, F.HEADING_ERROR]) * dt
            - settings[S.ACTION_CHANGE_WEIGHT] * action_change
            - settings[S.PEAK_CROSS_TRACK_WEIGHT] * floats[i, F.PEAK_GROWTH]
            + settings[S.GOAL_BONUS] * success
            - settings[S.FAILURE_PENALTY] * failure
        )


@njit(cache=True)
def observe_robots(
    indices, scales, layout, path, preview_offsets, robots, poses, belief, readings, preview, out
):
    """Observation of each robot in ``indices`` into the rows of ``out`` (float32), every
    element clipped to [-1, 1], laid out as :class:`mobile_envs.sim.observation.ObservationLayout`
    says.

    :param scales: the layout's ``scales``
    :param layout: the layout's ``kernel_layout``
    :param poses: the poses the robots see the path from: the state itself, or what they
        believe (then ``belief`` is :data:`BELIEF`, else 0)
    :param readings: (N, S) the sensors' readings, raw; scaled by the tail of ``scales``
    :param preview: (K, 2) float64 scratch space for the preview points
    """
    _observe_range(
        0, indices.shape[0], indices, scales, layout, path, preview_offsets, robots, poses,
        belief, readings, preview, out,
    )  # fmt: skip


@njit(cache=True, parallel=True)
def observe_robots_parallel(
    chunks, indices, scales, layout, path, preview_offsets, robots, poses, belief, readings,
    preview, out,
):  # fmt: skip
    """:func:`observe_robots` in ``chunks`` chunks on numba's threads, as
    :func:`move_robots_parallel`; each chunk makes its own preview scratch."""
    count = indices.shape[0]
    for chunk in prange(chunks):
        first, stop = _chunk(chunk, chunks, count)
        _observe_chunk(
            first, stop, indices, scales, layout, path, preview_offsets, robots, poses, belief,
            readings, np.empty_like(preview), out,
        )  # fmt: skip


@njit(cache=True)
def _observe_chunk(
    first, stop, indices, scales, layout, path, preview_offsets, robots, poses, belief,
    readings, preview, out,
):  # fmt: skip
    """:func:`_observe_range` as a call of its own: inlined into a ``prange`` body, its loop's
    exits would make numba run that loop serially."""
    _observe_range(
        first, stop, indices, scales, layout, path, preview_offsets, robots, poses, belief,
        readings, preview, out,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _observe_range(
    first, stop, indices, scales, layout, path, preview_offsets, robots, poses, belief,
    readings, preview, out,
):  # fmt: skip
    """:func:`observe_robots` for the robots ``indices[first:stop]``."""
    columns, spans, lengths, _ = path
    state, inputs, floats, ints, _, previous_action = robots
    num_points = preview_offsets.shape[0]
    observed = layout[LayoutEntry.OBSERVED_COUNT]
    sensors = layout[LayoutEntry.SENSORS]
    sensor_scales = _PATH_SCALES + observed
    for k in range(first, stop):
        i = indices[k]
        row = ints[i, Z.PATH_ROW]
        preview_on_row(
            columns, spans[row, 0], spans[row, 1], lengths[row], poses[i, 0], poses[i, 1],
            poses[i, 2], floats[i, F.ARC_LENGTH + belief],
            ints[i, Z.ESTIMATED_SEGMENT if belief else Z.SEGMENT], preview_offsets, preview,
        )  # fmt: skip
        for p in range(num_points):
            out[k, 2 * p] = _bounded(preview[p, 0] * scales[PathScale.PREVIEW])
            out[k, 2 * p + 1] = _bounded(preview[p, 1] * scales[PathScale.PREVIEW])
        column = 2 * num_points
        cross_track_error = floats[i, F.CROSS_TRACK_ERROR + belief]
        heading_error = floats[i, F.HEADING_ERROR + belief]
        out[k, column] = _bounded(cross_track_error * scales[PathScale.CROSS_TRACK])
        out[k, column + 1] = _bounded(heading_error * scales[PathScale.HEADING])
        out[k, column + 2] = math.tanh(cross_track_error * scales[PathScale.FINE_CROSS_TRACK])
        out[k, column + 3] = math.tanh(heading_error * scales[PathScale.FINE_HEADING])
        out[k, column + 4] = _bounded(floats[i, F.SPEED] * scales[PathScale.SPEED])
        out[k, column + 5] = _bounded(floats[i, F.YAW_RATE] * scales[PathScale.YAW_RATE])
        column = layout[LayoutEntry.MODEL_STATE]
        for q in range(observed):
            source = layout[_LAYOUT_HEADER + 2 * q]
            source_column = layout[_LAYOUT_HEADER + 2 * q + 1]
            value = state[i, source_column] if source == FROM_STATE else inputs[i, source_column]
            out[k, column + q] = _bounded(value * scales[_PATH_SCALES + q])
        out[k, layout[LayoutEntry.REMAINING_FRACTION]] = _bounded(
            1.0 - floats[i, F.ARC_LENGTH + belief] / floats[i, F.PATH_LENGTH]
        )
        column = layout[LayoutEntry.PREVIOUS_ACTION]
        for j in range(previous_action.shape[1]):
            out[k, column + j] = previous_action[i, j]
        for r in range(readings.shape[1]):
            out[k, sensors + r] = _bounded(readings[i, r] * scales[sensor_scales + r])


@njit(cache=True)
def step_info_arrays(float_columns, flag_columns, floats, flags, state):
    """Every robot's step info in one pass: the ``floats`` columns ``float_columns`` then the
    progress along the path, ``arc_length / path_length`` clipped to [0, 1] as ``np.clip``
    does it, as rows of a (len(float_columns) + 1, N) array; the ``flags`` columns
    ``flag_columns`` as rows of a bool array; and the (N, 3) poses."""
    count = floats.shape[0]
    values = np.empty((float_columns.shape[0] + 1, count))
    flag_values = np.empty((flag_columns.shape[0], count), dtype=np.bool_)
    poses = np.empty((count, 3))
    progress_row = float_columns.shape[0]
    for i in range(count):
        for row in range(float_columns.shape[0]):
            values[row, i] = floats[i, float_columns[row]]
        progress = floats[i, F.ARC_LENGTH] / floats[i, F.PATH_LENGTH]
        if not math.isnan(progress):  # np.clip keeps NaN, and takes the bound on a tie
            progress = progress if progress > 0.0 else 0.0
            progress = progress if progress < 1.0 else 1.0
        values[progress_row, i] = progress
        for row in range(flag_columns.shape[0]):
            flag_values[row, i] = flags[i, flag_columns[row]]
        for axis in range(3):
            poses[i, axis] = state[i, axis]
    return values, flag_values, poses


#: The rows of :func:`episode_metric_arrays`' values, in order.
EPISODE_METRIC_ROWS = (
    "mean_abs_cte",
    "max_abs_cte",
    "rms_cte",
    "episode_time",
    "distance_travelled",
    "mean_localization_error",
    "max_localization_error",
)


@njit(cache=True)
def episode_metric_arrays(floats, ints, flags, ended, dt, localized):
    """The episode metrics of the robots whose episode ``ended`` (zeros elsewhere): a (7, N)
    array (5, N without ``localized``) in the order of :data:`EPISODE_METRIC_ROWS`, and
    whether each completed its path. Means divide by the steps taken (at least 1)."""
    count = floats.shape[0]
    values = np.zeros((7 if localized else 5, count))
    completed = np.zeros(count, dtype=np.bool_)
    for i in range(count):
        if not ended[i]:
            continue
        steps = ints[i, Z.STEPS]
        divisor = max(steps, 1)
        values[0, i] = floats[i, F.SUM_ABS_CTE] / divisor
        values[1, i] = floats[i, F.MAX_ABS_CTE]
        values[2, i] = math.sqrt(floats[i, F.SUM_SQ_CTE] / divisor)
        values[3, i] = steps * dt
        values[4, i] = floats[i, F.DISTANCE]
        if localized:
            values[5, i] = floats[i, F.SUM_LOCALIZATION_ERROR] / divisor
            values[6, i] = floats[i, F.MAX_LOCALIZATION_ERROR]
        completed[i] = flags[i, B.SUCCESS]
    return values, completed

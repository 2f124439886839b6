"""MPPI's compiled core: sampling, rollouts, costs and the softmax update for N robots.

One call of :func:`plan_robots` (a template compiled per model with
:func:`~mobile_envs._kernels.specialize.for_model`) plans every robot of a batch: for robot
i it draws K perturbations of its mean action sequence from its own PCG64 stream, rolls
each out over T steps through the model's own ``advance`` (the env's kinematics, the same
bits), scores the rollouts against robot i's path (and maze), and moves the mean sequence to
the softmax-weighted average of the samples. Robot i reads and writes only row i of every
per-robot array, so a batch gives each robot the bits it gets alone.

Actions are the env's normalized actions in [-1, 1]: a model's native inputs are
``center + action * half_range``, as the env's step maps them. The costs follow Nav2's
critics (``nav2_mppi_controller``), written for a polyline with arc-length queries
(:mod:`mobile_envs.world.geometry`); :class:`agents.controllers.mppi.MPPI` documents them.
No fast-math: the same inputs give the same bits.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from mobile_envs._kernels.angles import wrap_scalar_angle
from mobile_envs._kernels.pcg64 import draw_double
from mobile_envs._kernels.specialize import model, per_model
from mobile_envs.sim.plant import lag_towards
from mobile_envs.world.geometry import HEADING, locate_on_row, project_on_row

# The entries of the settings array the kernels read (MPPI.kernel_settings writes them).
(
    DT,
    INTEGRATOR,
    TEMPERATURE,
    GAMMA,
    NOISE_STD,
    NOISE_CORRELATION,
    REGENERATE_NOISE,
    MANOEUVRES,
    PATH_WEIGHT,
    PROGRESS_WEIGHT,
    PROGRESS_SCALE,
    HEADING_WEIGHT,
    TURN_LENGTH,
    ANTICIPATION,
    GOAL_WEIGHT,
    GOAL_DISTANCE,
    GOAL_RADIUS,
    FORWARD_WEIGHT,
    TOP_SPEED,
    SMOOTHNESS_WEIGHT,
    WALL_WEIGHT,
    WALL_MARGIN,
    ROBOT_RADIUS,
    COLLISION_COST,
    TRACK_LIMIT,
    SEARCH_DISTANCE,
    SMOOTHING,
    PATIENCE,
    LAG,
) = range(29)
NUM_SETTINGS = 29

#: Savitzky-Golay's quadratic 9-point smoothing weights (Nav2's), over 231.
SAVITZKY_GOLAY = np.array([-21.0, 14.0, 39.0, 54.0, 59.0, 54.0, 39.0, 14.0, -21.0]) / 231.0
#: Applied actions a robot remembers for the smoothing window's past half.
HISTORY = 4
#: The columns of a rollout's end: position, heading and the arc length of its projection.
END_X, END_Y, END_HEADING, END_S, END_REACHED = range(5)
END_COLUMNS = 5
#: The fraction of its path a robot must have covered for the goal to count (the env's).
GOAL_FRACTION = 0.9
#: What counts as progress (m beyond the farthest point reached): the env's stall rule's.
STALL_PROGRESS = 0.01
#: The columns of a robot's progress record: its farthest arc length, steps since.
FARTHEST, STUCK_STEPS = range(2)


@njit(cache=True)
def normal_pair(stream):
    """Two independent standard normal draws from a PCG64 stream (Marsaglia's polar method:
    a point uniform in the unit disc, scaled; no trigonometry)."""
    while True:
        a = 2.0 * draw_double(stream) - 1.0
        b = 2.0 * draw_double(stream) - 1.0
        radius_sq = a * a + b * b
        if 0.0 < radius_sq < 1.0:
            scale = math.sqrt(-2.0 * math.log(radius_sq) / radius_sq)
            return a * scale, b * scale


@njit(cache=True)
def draw_noise(stream, correlation, noise):
    """Fill ``noise`` (S, T, m) with standard normal sequences from ``stream``, each
    correlated in time: n_t = c n_{t-1} + sqrt(1 - c^2) z_t with ``correlation`` c (AR(1);
    c = 0 is white noise), so every n_t is standard normal."""
    flat = noise.reshape(noise.size)
    for index in range(0, flat.shape[0], 2):
        first, second = normal_pair(stream)
        flat[index] = first
        if index + 1 < flat.shape[0]:
            flat[index + 1] = second
    if correlation == 0.0:
        return
    fresh = math.sqrt(1.0 - correlation * correlation)
    for k in range(noise.shape[0]):
        for t in range(1, noise.shape[1]):
            for j in range(noise.shape[2]):
                noise[k, t, j] = correlation * noise[k, t - 1, j] + fresh * noise[k, t, j]


@njit(cache=True)
def _draw_level(stream):
    """One of the levels -1, -1/2, 0, 1/2, 1, uniformly."""
    return 0.5 * (math.floor(5.0 * draw_double(stream)) - 2.0)


@njit(cache=True)
def _sample(sequence, primitives, manoeuvres, stream, noise, noise_std, actions):
    """Fill ``actions`` (K, T, m): sample 0 the mean ``sequence``, then the fixed
    ``primitives`` (P, T, m), then ``manoeuvres`` two-piece sequences drawn from ``stream``
    (each piece's action elements from -1, -1/2, 0, 1/2, 1, the switch at a random step),
    then the mean plus ``noise_std`` times ``noise`` (K - 1 - P - M, T, m), clipped to
    [-1, 1]."""
    samples, horizon, width = actions.shape
    fixed = 1 + primitives.shape[0]
    noisy = fixed + manoeuvres
    actions[0] = sequence
    actions[1:fixed] = primitives
    for k in range(fixed, noisy):
        switch = 1 + math.floor((horizon - 1) * draw_double(stream))
        for j in range(width):
            before, after = _draw_level(stream), _draw_level(stream)
            for t in range(horizon):
                actions[k, t, j] = before if t < switch else after
    for k in range(noisy, samples):
        for t in range(horizon):
            for j in range(width):
                value = sequence[t, j] + noise_std * noise[k - noisy, t, j]
                actions[k, t, j] = min(max(value, -1.0), 1.0)


@njit(cache=True)
def wall_distance(x, y, reach, vertical, horizontal, rows, cols, origin_x, origin_y, cell_size):
    """Distance (m) from (x, y) to the nearest wall of a maze's grids, or ``reach`` when no
    wall is closer; 0 for a point outside the maze.

    ``vertical[row, line]`` is the wall on vertical grid line ``line`` beside row ``row``,
    ``horizontal[line, col]`` the one on horizontal line ``line`` beside column ``col``
    (:class:`mobile_envs.world.maze.Maze`'s layout; the grids may be padded beyond ``rows``
    x ``cols``). Only the lines and wall segments within ``reach`` are looked at.
    """
    grid_x = (x - origin_x) / cell_size
    grid_y = (y - origin_y) / cell_size
    if not (0.0 <= grid_x < cols and 0.0 <= grid_y < rows):
        return 0.0
    cells = reach / cell_size
    # Horizontal walls are vertical ones with x and y swapped: transposed, the same search.
    nearest = _nearest_on_lines(
        x, y, grid_x, grid_y, cells, reach, vertical, rows, cols, origin_x, origin_y, cell_size
    )
    return _nearest_on_lines(
        y, x, grid_y, grid_x, cells, nearest, horizontal.T, cols, rows, origin_y, origin_x,
        cell_size,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _nearest_on_lines(
    across, along, grid_across, grid_along, cells, nearest, walls, segments, lines,
    origin_across, origin_along, cell_size,
):  # fmt: skip
    """The distance to the nearest wall on a family of parallel grid lines, or ``nearest``
    when none is closer: ``walls[segment, line]`` is the wall on line ``line`` (crossed by
    the ``across`` axis) between grid points ``segment`` and ``segment + 1`` along it, for
    ``lines + 1`` lines and ``segments`` segments; only those within ``cells`` are looked at."""
    first_line = max(math.ceil(grid_across - cells), 0)
    last_line = min(math.floor(grid_across + cells), lines)
    first_segment = max(math.floor(grid_along - cells), 0)
    last_segment = min(math.floor(grid_along + cells), segments - 1)
    for line in range(first_line, last_line + 1):
        gap_across = abs(across - (origin_across + line * cell_size))
        if gap_across >= nearest:
            continue
        for segment in range(first_segment, last_segment + 1):
            if walls[segment, line]:
                low = origin_along + segment * cell_size
                gap_along = max(low - along, along - low - cell_size, 0.0)
                nearest = min(nearest, math.hypot(gap_across, gap_along))
    return nearest


@per_model(inline="always")
def advance_on_action(parameters, settings, center, half_range, action, command, realized, state):
    """Advance ``state`` in place by one step under the normalized ``action``: its native
    command ``center + action * half_range`` (into ``command``) through the lag into
    ``realized``, held over ``settings[DT]``."""
    for j in range(command.shape[0]):
        command[j] = center[j] + action[j] * half_range[j]
    lag_towards(settings[LAG], command, realized)
    model.advance(parameters, state, realized, settings[DT], int(settings[INTEGRATOR]), state)


@per_model(inline="always")
def predict_over_delay(parameters, settings, pending, state, realized):
    """Advance ``state`` and ``realized`` in place over the commands already sent and not yet
    applied (``pending``, (d, m) native inputs, oldest first), as the plant applies them:
    where the robot will be, and what its actuators do, when the next command takes effect
    (delay compensation, as :mod:`agents.controllers.delay_compensation` predicts)."""
    for d in range(pending.shape[0]):
        lag_towards(settings[LAG], pending[d], realized)
        model.advance(parameters, state, realized, settings[DT], int(settings[INTEGRATOR]), state)


@per_model()
def rollout_states(parameters, settings, center, half_range, state, realized, pending, actions):
    """The states (d + T + 1, k) a robot passes through from ``state``, its actuators at
    ``realized`` (native inputs), over the ``pending`` commands (d, m) and then under
    ``actions`` (T, m): MPPI's prediction over the delay and its rollout, step for step the
    env's."""
    delay = pending.shape[0]
    states = np.empty((delay + actions.shape[0] + 1, state.shape[0]))
    states[0] = state
    current = state.copy()
    applied = realized.copy()
    for d in range(delay):
        predict_over_delay(parameters, settings, pending[d : d + 1], current, applied)
        states[d + 1] = current
    command = np.empty(center.shape[0])
    for t in range(actions.shape[0]):
        advance_on_action(
            parameters, settings, center, half_range, actions[t], command, applied, current
        )
        states[delay + t + 1] = current
    return states


@per_model()
def plan_robots(
    parameters, settings, center, half_range, primitives, columns, spans, lengths, goals, verticals,
    horizontals, sizes, frames, slots, robots, states, sequences, histories, noises, streams,
    segments, progress, pending, applied, out,
):  # fmt: skip
    """One MPPI iteration for robots ``robots``; robot ``robots[r]``'s action into ``out[r]``.

    Per robot i: ``states[i]`` its (believed) state, ``sequences[i]`` (T, m) its mean
    action sequence (updated, then shifted one step), ``histories[i]`` (HISTORY, m) its
    last applied actions, oldest first, ``streams[i]`` its PCG64 stream, ``segments[i]``
    its projection's segment (updated), ``slots[i]`` its maze's slot in the packed grids
    (-1: no maze), ``pending[i]`` (d, m) the native commands it sent that the plant's delay
    still holds, oldest first, and ``applied[i]`` (m,) the native inputs its actuators
    applied last step (both updated); its path is row i of the path table (``columns``,
    ``spans``, ``lengths``, ``goals``). Robot i reads and writes row i alone.
    """
    horizon, width = sequences.shape[1], sequences.shape[2]
    samples = 1 + primitives.shape[0] + int(settings[MANOEUVRES]) + noises.shape[1]
    actions = np.empty((samples, horizon, width))
    costs = np.empty(samples)
    ends = np.empty((samples, END_COLUMNS))
    start = np.empty(states.shape[1])
    rollout = np.empty(states.shape[1])
    realized = np.empty(width)
    inputs = np.empty(width)
    command = np.empty(width)
    smoothed = np.empty((horizon, width))
    for r in range(robots.shape[0]):
        _plan_robot(
            robots[r], r, parameters, settings, center, half_range, primitives, columns, spans,
            lengths, goals, verticals, horizontals, sizes, frames, slots, states, sequences,
            histories, noises, streams, segments, progress, pending, applied, out, actions,
            costs, ends, start, rollout, realized, inputs, command, smoothed,
        )  # fmt: skip


@per_model()
def _plan_robot(
    i, row, parameters, settings, center, half_range, primitives, columns, spans, lengths, goals,
    verticals, horizontals, sizes, frames, slots, states, sequences, histories, noises, streams,
    segments, progress, pending, applied, out, actions, costs, ends, start, rollout, realized,
    inputs, command, smoothed,
):  # fmt: skip
    """:func:`plan_robots` for robot i (its action into ``out[row]``), in the caller's
    scratch arrays."""
    samples, horizon, width = actions.shape
    sequence = sequences[i]
    start[:] = states[i]
    realized[:] = applied[i]
    predict_over_delay(parameters, settings, pending[i], start, realized)
    if settings[REGENERATE_NOISE] != 0.0:
        draw_noise(streams[i], settings[NOISE_CORRELATION], noises[i])
    _sample(
        sequence, primitives, int(settings[MANOEUVRES]), streams[i], noises[i],
        settings[NOISE_STD], actions,
    )  # fmt: skip
    s_start = _score_samples(
        i, parameters, settings, center, half_range, columns, spans, lengths, goals,
        verticals, horizontals, sizes, frames, slots, start, realized, sequences, histories,
        segments, progress, actions, costs, ends, rollout, inputs, command,
    )  # fmt: skip
    if s_start > progress[i, FARTHEST] + STALL_PROGRESS:
        progress[i, FARTHEST] = s_start
        progress[i, STUCK_STEPS] = 0.0
    else:
        progress[i, STUCK_STEPS] += 1.0

    # Softmax over the costs: the mean moves to the weighted average of the samples.
    lowest = costs.min()
    total = 0.0
    for k in range(samples):
        costs[k] = math.exp(-(costs[k] - lowest) / settings[TEMPERATURE])
        total += costs[k]
    for t in range(horizon):
        for j in range(width):
            mean = 0.0
            for k in range(samples):
                mean += costs[k] * actions[k, t, j]
            sequence[t, j] = mean / total

    if settings[SMOOTHING] != 0.0:
        _savitzky_golay(sequence, histories[i], smoothed)
    for j in range(width):
        out[row, j] = sequence[0, j]
    # The command as the env applies it (it takes float32 actions) enters the delay line;
    # the one it pushes out reaches the actuators, through the lag.
    delay = pending.shape[1]
    for j in range(width):
        command[j] = center[j] + np.float64(np.float32(sequence[0, j])) * half_range[j]
    if delay > 0:
        for j in range(width):
            inputs[j] = pending[i, 0, j]
        for d in range(delay - 1):
            pending[i, d] = pending[i, d + 1]
        pending[i, delay - 1] = command
        lag_towards(settings[LAG], inputs, applied[i])
    else:
        lag_towards(settings[LAG], command, applied[i])
    history = histories[i]
    for h in range(HISTORY - 1):
        history[h] = history[h + 1]
    history[HISTORY - 1] = sequence[0]
    # Warm start for the next step: the sequence shifted by one, its last action repeated.
    for t in range(horizon - 1):
        sequence[t] = sequence[t + 1]


@per_model(inline="always")
def _score_samples(
    i, parameters, settings, center, half_range, columns, spans, lengths, goals, verticals,
    horizontals, sizes, frames, slots, state, realized, sequences, histories, segments,
    progress, actions, costs, ends, rollout, inputs, command,
):  # fmt: skip
    """The cost of each of robot i's sampled sequences ``actions`` into ``costs``, rolled
    out from ``state`` with its actuators at ``realized``; the projection of ``state`` (from
    ``segments[i]`` on) updates ``segments[i]``. Returns the arc length of that projection.

    The path critic's weight is ``PATH_WEIGHT`` x patience / (patience + time stuck),
    with the time the robot has spent without gaining :data:`STALL_PROGRESS` beyond its
    farthest point (``progress[i]``): a robot stuck behind a turn it cannot make on the
    path gets the room to manoeuvre off it, and the path's full weight once it moves on."""
    first, last, length = spans[i, 0], spans[i, 1], lengths[i]
    s_start, _, segment_start = project_on_row(
        columns, first, last, state[0], state[1], state[2], segments[i], True,
        settings[SEARCH_DISTANCE],
    )  # fmt: skip
    segments[i] = segment_start
    near_goal = length - s_start < settings[GOAL_DISTANCE]
    patience = settings[PATIENCE]
    stuck = progress[i, STUCK_STEPS] * settings[DT]
    path_weight = settings[PATH_WEIGHT] * (patience / (patience + stuck) if patience > 0 else 1.0)
    for k in range(actions.shape[0]):
        costs[k] = _rollout_cost(
            i, k, parameters, settings, center, half_range, columns, first, last, length,
            goals, verticals, horizontals, sizes, frames, slots, state, realized, sequences[i],
            histories, actions, rollout, inputs, command, segment_start, s_start, near_goal,
            path_weight, ends,
        )  # fmt: skip
    _score_ends(settings, columns, first, last, length, s_start, segment_start, ends, costs)
    return s_start


@per_model()
def score_robot(
    parameters, settings, center, half_range, columns, spans, lengths, goals, verticals,
    horizontals, sizes, frames, slots, states, sequences, histories, segments, progress,
    pending, applied, robot, actions,
):  # fmt: skip
    """The costs (K,) :func:`plan_robots` gives robot ``robot``'s sequences ``actions``
    (K, T, m) in its current state (``segments[robot]`` is updated as a step would)."""
    costs = np.empty(actions.shape[0])
    ends = np.empty((actions.shape[0], END_COLUMNS))
    start = states[robot].copy()
    realized = applied[robot].copy()
    predict_over_delay(parameters, settings, pending[robot], start, realized)
    rollout = np.empty(states.shape[1])
    inputs = np.empty(actions.shape[2])
    command = np.empty(actions.shape[2])
    _score_samples(
        robot, parameters, settings, center, half_range, columns, spans, lengths, goals,
        verticals, horizontals, sizes, frames, slots, start, realized, sequences, histories,
        segments, progress, actions, costs, ends, rollout, inputs, command,
    )  # fmt: skip
    return costs


@njit(cache=True)
def _score_ends(settings, columns, first, last, length, s_start, segment_start, ends, costs):
    """Add each rollout's cost to go from its end to ``costs``, in metres of driving
    weighted by ``PROGRESS_WEIGHT`` per ``PROGRESS_SCALE`` metres:

    - the arc length it did not gain (Nav2's PathFollow: progress along the path);
    - the turning it leaves (PathAngle): ``HEADING_WEIGHT`` x ``TURN_LENGTH`` (the metres
      the robot drives, or could drive, while turning a radian) x (the angle between its
      end heading and the path's heading ``ANTICIPATION`` metres beyond its end's
      projection, plus the turns of the path's corners between there and a reference
      point beyond every rollout's reach).

    Counting the corners still ahead makes the turning a rollout leaves the same whether
    it stops before a corner or at it: none gains by hanging back from a turn it must make.
    """
    per_metre = settings[PROGRESS_WEIGHT] / settings[PROGRESS_SCALE]
    turn_length = settings[HEADING_WEIGHT] * settings[TURN_LENGTH]
    anticipation = settings[ANTICIPATION]
    beyond, _ = locate_on_row(
        columns, first, last, length, s_start + settings[PROGRESS_SCALE] + anticipation
    )
    # turned[j]: the corners' turns from segment_start's end to the start of segment
    # segment_start + j, summed.
    turned = np.zeros(beyond - segment_start + 1)
    for j in range(1, turned.shape[0]):
        column = first + segment_start + j
        turn = wrap_scalar_angle(columns[HEADING, column] - columns[HEADING, column - 1])
        turned[j] = turned[j - 1] + abs(turn)
    for k in range(costs.shape[0]):
        left = 0.0
        if ends[k, END_REACHED] == 0.0:
            target, _ = locate_on_row(columns, first, last, length, ends[k, END_S] + anticipation)
            heading = columns[HEADING, first + target]
            left = abs(wrap_scalar_angle(heading - ends[k, END_HEADING]))
            # A rollout's projection cannot start before the robot's (its search starts
            # there), but it may outrun the reference where the path doubles back.
            left += turned[-1] - turned[min(max(target, segment_start), beyond) - segment_start]
        costs[k] += per_metre * (turn_length * left - (ends[k, END_S] - s_start))


@per_model(inline="always")
def _rollout_cost(
    i, k, parameters, settings, center, half_range, columns, first, last, length, goals,
    verticals, horizontals, sizes, frames, slots, state, realized, sequence, histories, actions,
    rollout, inputs, command, segment, s_start, near_goal, path_weight, ends,
):  # fmt: skip
    """Roll sample k of robot i out from ``state``, its actuators at ``realized``; return
    the sum of its per-step critics (each averaged over the horizon) and write its end pose
    and arc length into ``ends[k]``."""
    horizon, width = actions.shape[1], actions.shape[2]
    rollout[:] = state
    inputs[:] = realized
    slot = slots[i]
    radius = settings[ROBOT_RADIUS]
    reach = radius + settings[WALL_MARGIN]
    path_sum = goal_sum = backward_sum = wall_sum = smooth_sum = energy_sum = 0.0
    collided = reached = False
    s = 0.0
    for t in range(horizon):
        action = actions[k, t]
        for j in range(width):
            before = histories[i, HISTORY - 1, j] if t == 0 else actions[k, t - 1, j]
            change = action[j] - before
            smooth_sum += change * change
            energy_sum += sequence[t, j] * (action[j] - sequence[t, j])
            command[j] = center[j] + action[j] * half_range[j]
        lag_towards(settings[LAG], command, inputs)
        v, _ = model.twist(parameters, rollout, inputs)
        backward_sum += max(-v, 0.0)
        model.advance(parameters, rollout, inputs, settings[DT], int(settings[INTEGRATOR]), rollout)
        x, y = rollout[0], rollout[1]
        s, cross_track_error, segment = project_on_row(
            columns, first, last, x, y, rollout[2], segment, True,
            settings[SEARCH_DISTANCE],
        )  # fmt: skip
        distance = abs(cross_track_error)
        path_sum += distance
        if distance > settings[TRACK_LIMIT]:
            collided = True
        to_goal = math.hypot(x - goals[i, 0], y - goals[i, 1])
        if to_goal <= settings[GOAL_RADIUS] and s >= GOAL_FRACTION * length:
            # The env ends the episode here: what is left of the horizon costs nothing.
            reached = True
            break
        if near_goal:
            goal_sum += to_goal
        if slot >= 0:
            clearance = wall_distance(
                x, y, reach, verticals[slot], horizontals[slot], sizes[slot, 0],
                sizes[slot, 1], frames[slot, 0], frames[slot, 1], frames[slot, 2],
            )  # fmt: skip
            if clearance <= radius:
                collided = True
            else:
                wall_sum += (reach - clearance) / settings[WALL_MARGIN]
    ends[k, END_X], ends[k, END_Y], ends[k, END_HEADING] = rollout[0], rollout[1], rollout[2]
    ends[k, END_S] = s
    ends[k, END_REACHED] = reached
    noise_std = settings[NOISE_STD]
    cost = (
        path_weight * path_sum
        + settings[GOAL_WEIGHT] * goal_sum
        + settings[FORWARD_WEIGHT] * backward_sum / settings[TOP_SPEED]
        + settings[WALL_WEIGHT] * wall_sum
        + settings[SMOOTHNESS_WEIGHT] * smooth_sum
    ) / horizon
    cost += settings[GAMMA] / (noise_std * noise_std) * energy_sum
    if collided:
        cost += settings[COLLISION_COST]
    return cost


@njit(cache=True)
def _savitzky_golay(sequence, history, smoothed):
    """Smooth ``sequence`` (T, m) in place with Savitzky-Golay's quadratic 9-point weights:
    the window reaches into the applied ``history`` before it and repeats the last action
    after it (Nav2's ``savitskyGolayFilter``, on the unsmoothed values)."""
    horizon, width = sequence.shape
    half = SAVITZKY_GOLAY.shape[0] // 2
    for t in range(horizon):
        for j in range(width):
            total = 0.0
            for offset in range(-half, half + 1):
                index = t + offset
                if index < 0:
                    value = history[HISTORY + index, j]
                else:
                    value = sequence[min(index, horizon - 1), j]
                total += SAVITZKY_GOLAY[offset + half] * value
            smoothed[t, j] = total
    for t in range(horizon):
        for j in range(width):
            sequence[t, j] = min(max(smoothed[t, j], -1.0), 1.0)

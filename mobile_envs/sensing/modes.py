"""The localizations of the seeds: wheel odometry, laser beacons, and odometry corrected by them.

Three :class:`~mobile_envs.sensing.localization.Localization` classes, built by name with
``localization="..."`` and their settings in ``localization_params={...}``:

- ``"odometry"`` (:class:`OdometryLocalization`, seed 000): dead reckoning from the wheel
  encoders (eq. 16 and the model's encoders,
  :func:`mobile_envs.sensing.odometry.measure_increments`)
  with the noise of eq. 17, the systematic errors and the encoders' quantization. The
  estimate drifts without bound.
- ``"beacons"`` (:class:`BeaconLocalization`, seed 003 section 2): the rotating laser head
  reads the reflectors' bearings while the robot moves; at the end of every step the latest
  reading of each reflector within the last revolution, brought to the robot's pose at that
  instant (the dynamic correction), fixes position and heading by the absolute-angle
  triangulation. The estimate is the last fix, held while no fix can be made (fewer than
  three reflectors in sight). The motion between readings, and the heading the triangulation
  starts from, come from the robot's commands: its last fix moved as its model says its
  inputs move it.
- ``"odometry+beacons"`` (:class:`OdometryBeaconLocalization`): odometry between fixes,
  corrected by each fix, as seed 003's robot combines them: odometry moves the estimate,
  gives the heading the triangulation starts from and the motion between the readings of a
  revolution (its encoders' increments: eq. 17's noise is the estimate's drift, not a
  motion the robot knows of); a fix replaces the estimate (its position alone where the
  heading is ill-conditioned, near the circle through the reflectors).

Every robot starts an episode knowing its pose (the start pose is given, as seed 000's
odometry and seed 003's run assume). The per-robot work of a step is one compiled call for
all robots (:func:`localize_robots`). Odometry noise comes from each robot's own generator in
blocks of :data:`NOISE_BLOCK_STEPS` steps of three standard normals, drawn at the robot's
reset and whenever its block runs out, so the draws depend on that robot's history alone: a
vector env of N robots equals N single envs bit for bit. The beam's angle at a reset is one
uniform draw from the robot's generator, and the readings' optional noise
(``bearing_noise``) comes in blocks as the odometry's does.
"""

from __future__ import annotations

import collections
import dataclasses
import enum
import inspect
import math
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from mobile_envs._kernels.angles import wrap_scalar_angle
from mobile_envs._kernels.specialize import for_model, model, per_model
from mobile_envs.robots import INTEGRATORS, KinematicModel
from mobile_envs.sensing.beacons import (
    DEFAULT_MAX_HEADING_GAIN,
    NO_FIX,
    HeadSetting,
    LaserHead,
    bearing_error,
    correct_robot_bearings,
    default_reflectors,
    screw_pose,
    sight_is_clear,
    sweep_screw_bearings,
    triangulate_near,
    validate_reflectors,
)
from mobile_envs.sensing.localization import (
    Array,
    Generators,
    Indices,
    Localization,
    LocalizationWorld,
)
from mobile_envs.sensing.odometry import (
    OdometrySettings,
    WheelOdometry,
    measure_increments,
    noisy_dead_reckoning,
    odometry_motion,
)
from mobile_envs.tracks.sets import PathSet
from mobile_envs.validation import as_count, as_limit, as_non_negative, as_point
from mobile_envs.world.maze import Maze

__all__ = [
    "DEFAULT_MAX_READINGS",
    "NOISE_BLOCK_STEPS",
    "BeaconFloat",
    "BeaconInt",
    "BeaconLocalization",
    "BeaconSettings",
    "LocalizationSetting",
    "OdometryBeaconLocalization",
    "OdometryLocalization",
    "Reading",
    "ReadingFlag",
    "age_and_carry_readings",
    "fix_and_hold",
    "localize_robots",
    "predict_by_commands",
    "predict_by_odometry",
    "store_readings",
    "sweep_head",
]

#: Steps of odometry noise (three standard normals each) a robot draws at a time.
NOISE_BLOCK_STEPS = 64
#: The reflectors a head reads each step, at most: the nearest in sight.
DEFAULT_MAX_READINGS = 6

#: Where :func:`localize_robots` takes each step's motion from: the odometry, or the commands.
FROM_ODOMETRY, FROM_COMMANDS = 0, 1
#: What :func:`localize_robots` reports: flags of the blocks of normals to refill.
ODOMETRY_BLOCK_USED, BEARING_BLOCK_LOW = 1, 2
_EXACT = INTEGRATORS.index("exact")


# ---------------------------------------------------------------- the kernels' packed arrays
# Each column named once; the kernels index with the members (numba folds them to constants).


class LocalizationSetting(enum.IntEnum):
    """The entries of the float64 array of a localization's settings the kernel reads."""

    #: Where the prediction's motion comes from: :data:`FROM_ODOMETRY` or :data:`FROM_COMMANDS`.
    MOTION = 0
    #: 1 when a laser head reads the reflectors, 0 without beacons.
    USE_BEACONS = 1
    #: 1 when the estimate is the last fix, held between fixes (the beacons alone); 0 when
    #: the estimate is the prediction itself.
    HOLD_FIX = 2
    #: Above this heading error per bearing error a fix keeps the predicted heading.
    MAX_HEADING_GAIN = 3
    #: The most reflectors a step reads: ``max_readings``, or all of them if fewer.
    READINGS_PER_STEP = 4
    #: The standard deviation (rad) of each reading's error; 0 for none.
    BEARING_NOISE = 5


class BeaconFloat(enum.IntEnum):
    """The columns of each robot's floats for the beacons (``beacon_floats``, (N, 4))."""

    #: The beam's angle in the body frame (rad), in [0, 2 pi).
    BEAM = 0
    #: The last fix: the pose (x, y, heading) of the robot's reference point.
    FIX_X = 1
    FIX_Y = 2
    FIX_HEADING = 3


class BeaconInt(enum.IntEnum):
    """The columns of each robot's integers for the beacons (``beacon_ints``, (N, 4))."""

    #: The fixes made since its reset.
    FIXES = 0
    #: Its maze's walls: the rows ``[WALL_START, WALL_START + WALL_COUNT)`` of ``walls``.
    WALL_START = 1
    WALL_COUNT = 2
    #: The next unused normal of its block for the readings' noise.
    NOISE_CURSOR = 3


class Reading(enum.IntEnum):
    """The columns of a robot's stored reading of a reflector (``readings``, (N, R, 5))."""

    #: The bearing as the head read it (rad).
    BEARING = 0
    #: The robot's pose when it was read, in the frame of the predicted pose at the end of
    #: the step: the motion the bearing is corrected for.
    X = 1
    Y = 2
    HEADING = 3
    #: The time since it was read (s).
    AGE = 4


class ReadingFlag(enum.IntEnum):
    """The columns of a robot's flags for each reflector (``reading_flags``, (N, R, 2))."""

    #: A reading is stored: read within the last two revolutions, and not missed since.
    READ = 0
    #: Its reading made the last fix.
    IN_FIX = 1


# The steps' scratch arrays, allocated once a call. A step unpacks its tuple once: each read
# of a tuple's field counts a reference to the array, which costs in the steps' loops.

#: Scratch arrays of one sweep of the head, one row per reflector (the first ``chosen``
#: used): the reflectors read (their indices and positions) and what the head made of them.
SweepWork = collections.namedtuple(
    "SweepWork", ["start_pose", "candidates", "positions", "bearings", "times", "swept", "errors"]
)
#: Scratch arrays of one fix: the readings triangulated (their reflectors, bearings and
#: relative poses), the bearings corrected to the predicted pose, and the fix.
FixWork = collections.namedtuple("FixWork", ["positions", "bearings", "poses", "corrected", "fix"])


# ---------------------------------------------------------------- compiled kernels


@njit(cache=True)
def _relative_pose(ax, ay, a_heading, bx, by, b_heading):
    """Pose b in the frame of pose a."""
    cos_a, sin_a = math.cos(a_heading), math.sin(a_heading)
    dx, dy = bx - ax, by - ay
    return (
        cos_a * dx + sin_a * dy,
        cos_a * dy - sin_a * dx,
        wrap_scalar_angle(b_heading - a_heading),
    )


@njit(cache=True)
def _twist_between(dx, dy, turn, dt):
    """The constant body twist (v_x, v_y, omega) that moves a body by (dx, dy, turn), given
    in its frame at the start, in ``dt``: the inverse of
    :func:`~mobile_envs.sensing.beacons.screw_pose`
    (the chord is the body velocity times dt sin(turn/2) / (turn/2), turned by turn/2)."""
    half = 0.5 * turn
    shrink = dt if half == 0.0 else dt * math.sin(half) / half
    cos_h, sin_h = math.cos(half), math.sin(half)
    return (cos_h * dx + sin_h * dy) / shrink, (cos_h * dy - sin_h * dx) / shrink, turn / dt


@njit(cache=True)
def _nearest_in_sight(pose, reflectors, walls, head, most, candidates):
    """Write into ``candidates`` the reflectors the head at ``pose`` reads, and return how
    many: all of them when there are at most ``most``, else the ``most`` nearest in range
    and in sight."""
    count = reflectors.shape[0]
    if count <= most:
        for r in range(count):
            candidates[r] = r
        return count
    cos_h, sin_h = math.cos(pose[2]), math.sin(pose[2])
    offset_x, offset_y = head[HeadSetting.OFFSET_X], head[HeadSetting.OFFSET_Y]
    head_x = pose[0] + offset_x * cos_h - offset_y * sin_h
    head_y = pose[1] + offset_x * sin_h + offset_y * cos_h
    distances = np.empty(count)
    for r in range(count):
        distances[r] = math.hypot(reflectors[r, 0] - head_x, reflectors[r, 1] - head_y)
    chosen = 0
    for r in np.argsort(distances):
        if distances[r] > head[HeadSetting.RANGE]:
            break
        if distances[r] > 0.0 and sight_is_clear(
            head_x, head_y, reflectors[r, 0], reflectors[r, 1], walls
        ):
            candidates[chosen] = r
            chosen += 1
            if chosen == most:
                break
    return chosen


# The steps of localize_robots, one robot each. Those in its per-robot loop are inlined into
# it (inline="always"): called as functions, they made the step 5-26 % slower (the counting
# of references to the array views they take), inlined they cost 0-3 %.


@njit(cache=True)
def predict_by_odometry(odometry_parameters, pose, delta_distance, delta_heading, normals):
    """Step 1, by the odometry: eq. 14 on ``pose``, in place, from the increments U(k) the
    encoders measured (:func:`~mobile_envs.sensing.odometry.measure_increments`) and the
    robot's next three normals (:func:`~mobile_envs.sensing.odometry.noisy_dead_reckoning`).

    :param normals: (3,) the robot's next three standard normals
    :return: (dx, dy, dheading), the motion the encoders read, in the frame of the pose at
        the step's start: the odometry's step without its noise
        (:func:`~mobile_envs.sensing.odometry.odometry_motion`), for eq. 17's noise is the
        estimate's drift, not a motion the robot could know of
    """
    noisy_dead_reckoning(odometry_parameters, pose, delta_distance, delta_heading, normals)
    return odometry_motion(odometry_parameters, delta_distance, delta_heading)


@per_model(inline="always")
def predict_by_commands(model_parameters, state_before, inputs, dt, pose, scratch_state):
    """Step 1, by the commands: ``pose`` moved, in place, by the model's exact step under
    the robot's inputs, with the state's other columns as the robot's at the step's start.

    :param scratch_state: (k,) scratch for the model's state
    :return: (dx, dy, dheading), the commanded motion in the frame of the pose at the
        step's start
    """
    before_x, before_y, before_heading = pose[0], pose[1], pose[2]
    scratch_state[:] = state_before
    scratch_state[:3] = pose
    model.advance(model_parameters, scratch_state, inputs, dt, _EXACT, scratch_state)
    pose[:] = scratch_state[:3]
    return _relative_pose(before_x, before_y, before_heading, pose[0], pose[1], pose[2])


@njit(cache=True, inline="always")
def age_and_carry_readings(readings, flags, moved_x, moved_y, turned, dt, period):
    """Step 2: a robot's stored readings age by ``dt``; those older than two revolutions are
    forgotten (the beam reaches a reflector once a revolution, give or take the robot's
    turn), and the poses the others were read from are carried by the known motion into the
    frame of the pose at the step's end.

    :param readings: (R, 5) the robot's readings (:class:`Reading`), updated in place
    :param flags: (R, 2) its flags (:class:`ReadingFlag`), updated in place
    :param moved_x: the known motion over the step (step 1's), in the frame of the pose at
        its start
    :param period: the head's revolution (s)
    """
    for r in range(readings.shape[0]):
        if flags[r, ReadingFlag.READ]:
            readings[r, Reading.AGE] += dt
            if readings[r, Reading.AGE] > 2.0 * period:
                flags[r, ReadingFlag.READ] = False
                continue
            x, y, heading = _relative_pose(
                moved_x,
                moved_y,
                turned,
                readings[r, Reading.X],
                readings[r, Reading.Y],
                readings[r, Reading.HEADING],
            )
            readings[r, Reading.X], readings[r, Reading.Y] = x, y
            readings[r, Reading.HEADING] = heading


@njit(cache=True, inline="always")
def sweep_head(
    state_before, state_after, dt, head, reflectors, walls, most, noise, normals, beam, work
):
    """Step 3: the head sweeps the step's last revolution (at most) while the robot moves
    along the screw that joins its true poses at the step's start and end (exact for rigid
    bodies under the exact integrator), reading the reflectors :func:`_nearest_in_sight`
    picks at the sweep's start.

    :param state_before: the robot's true state at the step's start
    :param state_after: and at its end
    :param dt: the step (s)
    :param head: :attr:`~mobile_envs.sensing.beacons.LaserHead.kernel_parameters`
    :param reflectors: (R, 2) positions (m)
    :param walls: (K, 4) the walls of the robot's maze, K may be 0
    :param most: the most reflectors a step reads
    :param noise: the readings' standard deviation (rad); 0 for none
    :param normals: standard normals for the readings' errors, one per reflector picked
    :param beam: the beam's angle at the step's start (rad)
    :param work: a :data:`SweepWork`, receives the sweep: the ``chosen`` reflectors picked,
        where each was read and when (``times`` negative where the beam did not reach it)
        and whether it was (``swept``)
    :return: (chosen, the sweep's start in the step (s), the beam's angle at the step's end)
    """
    start_pose, candidates, positions, bearings, times, swept, errors = work
    period = 1.0 / head[HeadSetting.FREQUENCY]
    spin = 2.0 * math.pi * head[HeadSetting.FREQUENCY]
    true_x, true_y, true_turn = _relative_pose(
        state_before[0],
        state_before[1],
        state_before[2],
        state_after[0],
        state_after[1],
        state_after[2],
    )
    true_vx, true_vy, true_omega = _twist_between(true_x, true_y, true_turn, dt)
    start = max(0.0, dt - period)
    start_pose[0], start_pose[1], start_pose[2] = screw_pose(
        state_before[0],
        state_before[1],
        state_before[2],
        true_vx * start,
        true_vy * start,
        true_omega * start,
    )
    chosen = _nearest_in_sight(start_pose, reflectors, walls, head, most, candidates)
    for n in range(chosen):
        positions[n] = reflectors[candidates[n]]
        times[n] = -1.0  # stays negative where the beam does not reach the reflector
    if noise > 0.0:
        for n in range(chosen):
            errors[n] = noise * normals[n]
    beam_after = sweep_screw_bearings(
        start_pose,
        true_vx,
        true_vy,
        true_omega,
        beam + spin * start,
        dt - start,
        positions[:chosen],
        walls,
        head,
        bearings,
        times,
        swept,
        errors[:chosen],
    )
    return chosen, start, beam_after


@njit(cache=True, inline="always")
def store_readings(readings, flags, work, chosen, start, moved_x, moved_y, turned, dt):
    """Step 4: each reflector the sweep read replaces its stored reading, with the pose it
    was read from on the known motion's screw, in the frame of the pose at the step's end;
    a reflector swept but not seen (hidden, out of range) loses its stored one: the head
    reads nothing there.

    :param readings: (R, 5) the robot's readings (:class:`Reading`), updated in place
    :param flags: (R, 2) its flags (:class:`ReadingFlag`), updated in place
    :param work: the :data:`SweepWork` of step 3, ``chosen`` reflectors from ``start`` (s)
    :param moved_x: the known motion over the step (step 1's)
    """
    candidates, bearings, times, swept = work.candidates, work.bearings, work.times, work.swept
    believed_vx, believed_vy, believed_omega = _twist_between(moved_x, moved_y, turned, dt)
    for n in range(chosen):
        r = candidates[n]
        if not swept[n]:
            if times[n] >= 0.0:
                flags[r, ReadingFlag.READ] = False
            continue
        t = start + times[n]
        read_x, read_y, read_heading = screw_pose(
            0.0, 0.0, 0.0, believed_vx * t, believed_vy * t, believed_omega * t
        )
        x, y, heading = _relative_pose(moved_x, moved_y, turned, read_x, read_y, read_heading)
        readings[r, Reading.X], readings[r, Reading.Y] = x, y
        readings[r, Reading.HEADING] = heading
        readings[r, Reading.BEARING] = bearings[n]
        readings[r, Reading.AGE] = dt - t
        flags[r, ReadingFlag.READ] = True


@njit(cache=True, inline="always")
def fix_and_hold(readings, flags, reflectors, head, max_heading_gain, error_bound, pose, work):
    """Step 5: the stored readings, corrected to ``pose`` (the predicted pose), are
    triangulated from its heading (three at least); a fix replaces ``pose`` in place (its
    position alone where the heading is kept, near the circle through the triple) and marks
    the readings that made it.

    :param readings: (R, 5) the robot's readings (:class:`Reading`)
    :param flags: (R, 2) its flags (:class:`ReadingFlag`); ``IN_FIX`` set on a fix
    :param head: the head's settings (its offset matters)
    :param max_heading_gain: up to this heading error per bearing error the fix is taken
    :param error_bound: a bearing's expected error (rad): the head's resolution and noise
        (:func:`~mobile_envs.sensing.beacons.bearing_error`)
    :param pose: (3,) the predicted pose of the robot's reference point
    :param work: a :data:`FixWork`
    :return: whether a fix was made
    """
    positions, bearings, poses, corrected, fix = work
    members = 0
    for r in range(readings.shape[0]):
        if flags[r, ReadingFlag.READ]:
            positions[members] = reflectors[r]
            bearings[members] = readings[r, Reading.BEARING]
            poses[members, 0] = readings[r, Reading.X]
            poses[members, 1] = readings[r, Reading.Y]
            poses[members, 2] = readings[r, Reading.HEADING]
            members += 1
    if members < 3:
        return False
    correct_robot_bearings(
        positions[:members],
        bearings[:members],
        poses[:members],
        pose,
        head,
        corrected[:members],
    )
    offset_x, offset_y = head[HeadSetting.OFFSET_X], head[HeadSetting.OFFSET_Y]
    cos_h, sin_h = math.cos(pose[2]), math.sin(pose[2])
    status = triangulate_near(
        positions,
        corrected,
        members,
        pose[0] + offset_x * cos_h - offset_y * sin_h,
        pose[1] + offset_x * sin_h + offset_y * cos_h,
        pose[2],
        max_heading_gain,
        error_bound,
        fix,
    )
    if status == NO_FIX:
        return False
    cos_h, sin_h = math.cos(fix[2]), math.sin(fix[2])
    pose[0] = fix[0] - (offset_x * cos_h - offset_y * sin_h)
    pose[1] = fix[1] - (offset_x * sin_h + offset_y * cos_h)
    pose[2] = fix[2]
    for r in range(flags.shape[0]):
        flags[r, ReadingFlag.IN_FIX] = flags[r, ReadingFlag.READ]
    return True


@per_model()
def localize_robots(
    indices,
    settings,
    head,
    model_parameters,
    encoder_settings,
    odometry_parameters,
    previous_state,
    state,
    inputs,
    dt,
    predicted,
    estimate,
    residuals,
    odometry_normals,
    odometry_cursor,
    reflectors,
    walls,
    beacon_floats,
    beacon_ints,
    readings,
    reading_flags,
    bearing_normals,
):
    """One step of the robots ``indices``' localization, robot by robot:

    1. the prediction moves: by the odometry (the encoders' increments,
       :func:`~mobile_envs.sensing.odometry.measure_increments`, then
       :func:`predict_by_odometry` with the robot's next three normals) or by the commands
       (:func:`predict_by_commands`), as ``settings`` say;
    2. with beacons, :func:`age_and_carry_readings`;
    3. :func:`sweep_head` (with the robot's next normals for the readings' errors);
    4. :func:`store_readings`;
    5. :func:`fix_and_hold`: a fix replaces the prediction and is stored as the robot's last
       fix; with ``HOLD_FIX`` it is also the estimate.

    :param settings: the localization's settings (:class:`LocalizationSetting`)
    :param head: the laser head's (:class:`~mobile_envs.sensing.beacons.HeadSetting`)
    :param model_parameters: the model's ``kernel_parameters``
    :param encoder_settings: the encoders' settings, as the model's ``encoder_increments``
        reads them
    :param odometry_parameters: the dead reckoning's settings
        (:attr:`~mobile_envs.sensing.odometry.OdometrySettings.kernel_parameters`)
    :param previous_state: (N, k) the robots' true states at the step's start
    :param state: (N, k) at its end
    :param inputs: (N, m) the saturated native inputs held over the step
    :param predicted: (N, 3) the predicted poses; the estimate itself unless ``HOLD_FIX``
    :param estimate: (N, 3) the estimated poses
    :param residuals: (N, 2) the encoders' carried fractions of a count
    :param odometry_normals: (N, B, 3) each robot's block of standard normals for the
        odometry, used from ``odometry_cursor``
    :param odometry_cursor: (N,) each robot's next unused step of its block
    :param reflectors: (R, 2) the reflectors' positions (m)
    :param walls: (K, 4) the walls of every maze a robot is in (see :class:`BeaconInt`)
    :param beacon_floats: (N, 4) each robot's beam and last fix (:class:`BeaconFloat`)
    :param beacon_ints: (N, 4) its fixes, walls and noise cursor (:class:`BeaconInt`)
    :param readings: (N, R, 5) each robot's stored readings (:class:`Reading`)
    :param reading_flags: (N, R, 2) and their flags (:class:`ReadingFlag`)
    :param bearing_normals: (N, C) each robot's block of standard normals for the readings'
        errors, used from its ``NOISE_CURSOR``
    :return: :data:`ODOMETRY_BLOCK_USED` if some robot has used up its block of normals,
        plus :data:`BEARING_BLOCK_LOW` if some robot has fewer normals left for the readings
        than a step may take
    """
    from_odometry = settings[LocalizationSetting.MOTION] == FROM_ODOMETRY
    use_beacons = settings[LocalizationSetting.USE_BEACONS] != 0.0
    hold_fix = settings[LocalizationSetting.HOLD_FIX] != 0.0
    max_heading_gain = settings[LocalizationSetting.MAX_HEADING_GAIN]
    per_step = int(settings[LocalizationSetting.READINGS_PER_STEP])
    noise = settings[LocalizationSetting.BEARING_NOISE]
    period = 1.0 / head[HeadSetting.FREQUENCY]
    error_bound = bearing_error(head, noise)
    count = reflectors.shape[0]
    scratch_state = np.empty(state.shape[1])
    sweep = SweepWork(
        np.empty(3),
        np.empty(count, dtype=np.int64),
        np.empty((count, 2)),
        np.empty(count),
        np.empty(count),
        np.empty(count, dtype=np.bool_),
        np.zeros(count),
    )
    fixing = FixWork(
        np.empty((count, 2)), np.empty(count), np.empty((count, 3)), np.empty(count), np.empty(3)
    )
    exhausted = bearings_low = False
    for i in indices:
        pose = predicted[i]
        if from_odometry:
            delta_distance, delta_heading = measure_increments(
                model_parameters,
                encoder_settings,
                previous_state[i],
                state[i],
                inputs[i],
                dt,
                residuals[i],
            )
            moved_x, moved_y, turned = predict_by_odometry(
                odometry_parameters,
                pose,
                delta_distance,
                delta_heading,
                odometry_normals[i, odometry_cursor[i]],
            )
            odometry_cursor[i] += 1
            exhausted = exhausted or odometry_cursor[i] == odometry_normals.shape[1]
        else:
            moved_x, moved_y, turned = predict_by_commands(
                model_parameters, previous_state[i], inputs[i], dt, pose, scratch_state
            )
        if not use_beacons:
            continue
        turned = wrap_scalar_angle(turned)
        age_and_carry_readings(readings[i], reading_flags[i], moved_x, moved_y, turned, dt, period)
        first_wall = beacon_ints[i, BeaconInt.WALL_START]
        robot_walls = walls[first_wall : first_wall + beacon_ints[i, BeaconInt.WALL_COUNT]]
        cursor = beacon_ints[i, BeaconInt.NOISE_CURSOR]
        chosen, start, beam = sweep_head(
            previous_state[i],
            state[i],
            dt,
            head,
            reflectors,
            robot_walls,
            per_step,
            noise,
            bearing_normals[i, cursor:],
            beacon_floats[i, BeaconFloat.BEAM],
            sweep,
        )
        beacon_floats[i, BeaconFloat.BEAM] = beam
        if noise > 0.0:
            beacon_ints[i, BeaconInt.NOISE_CURSOR] = cursor + chosen
            bearings_low = bearings_low or cursor + chosen + per_step > bearing_normals.shape[1]
        store_readings(
            readings[i], reading_flags[i], sweep, chosen, start, moved_x, moved_y, turned, dt
        )
        if not fix_and_hold(
            readings[i],
            reading_flags[i],
            reflectors,
            head,
            max_heading_gain,
            error_bound,
            pose,
            fixing,
        ):
            continue
        beacon_floats[i, BeaconFloat.FIX_X] = pose[0]
        beacon_floats[i, BeaconFloat.FIX_Y] = pose[1]
        beacon_floats[i, BeaconFloat.FIX_HEADING] = pose[2]
        beacon_ints[i, BeaconInt.FIXES] += 1
        if hold_fix:
            estimate[i] = pose
    return (ODOMETRY_BLOCK_USED if exhausted else 0) + (BEARING_BLOCK_LOW if bearings_low else 0)


# ---------------------------------------------------------------- settings


@dataclass(frozen=True, eq=False)
class BeaconSettings:
    """Laser-beacon positioning's settings (seed 003 section 2), validated when made: the
    reflectors, the laser head, and how its readings make a fix.

    :param reflectors: (R, 2) positions (m), R >= 3 and not all on a line; None for the path
        set's layout (:func:`mobile_envs.sensing.beacons.default_reflectors`)
    :param frequency: the head's revolutions per second (Hz)
    :param counts_per_revolution: the head encoder's counts a turn; None for exact bearings
    :param max_range: the farthest reflector the head reads (m); inf for no limit
    :param head_offset: (x, y) of the head's centre in the body frame (m)
    :param max_heading_gain: up to this heading error per bearing error the fix is always
        taken; above it (near the circle through the three reflectors) the predicted heading
        is kept where the fix cannot tell it from the truth
        (:func:`mobile_envs.sensing.beacons.triangulate_robot`)
    :param max_readings: with more reflectors than this (the maze's 81 posts), each step
        reads only this many, the nearest in sight; at least 3. The fix takes the
        best-conditioned triple among them: in the maze six give the fixes eight do, 30 %
        faster
    :param bearing_noise: standard deviation (rad) of each reading's error before the
        encoder counts it (the paper's head reads with errors beyond its resolution); 0,
        the default, for a head whose only error is its count. Drawn from the robot's own
        generator, in blocks as the odometry's
    :raises ValueError: naming the first bad setting
    """

    reflectors: ArrayLike | None = None
    frequency: float = 8.0
    counts_per_revolution: int | None = 65535
    max_range: float = 30.0
    head_offset: ArrayLike = (0.0, 0.0)
    max_heading_gain: float = DEFAULT_MAX_HEADING_GAIN
    max_readings: int = DEFAULT_MAX_READINGS
    bearing_noise: float = 0.0

    def __post_init__(self) -> None:
        reflectors = None if self.reflectors is None else validate_reflectors(self.reflectors)
        offset = as_point("head_offset", self.head_offset)
        head = LaserHead(self.frequency, self.counts_per_revolution, self.max_range, offset)
        checked = {
            "reflectors": reflectors,
            "frequency": head.frequency,
            "counts_per_revolution": head.counts_per_revolution,
            "max_range": head.max_range,
            "head_offset": (float(offset[0]), float(offset[1])),
            "max_heading_gain": as_limit("max_heading_gain", self.max_heading_gain),
            "max_readings": as_count("max_readings", self.max_readings, minimum=3),
            "bearing_noise": as_non_negative("bearing_noise", self.bearing_noise),
        }
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    @property
    def head(self) -> LaserHead:
        """The laser head these settings describe."""
        return LaserHead(
            self.frequency, self.counts_per_revolution, self.max_range, self.head_offset
        )


# ---------------------------------------------------------------- the localizations


#: The settings records a localization may take.
RecordT = TypeVar("RecordT", OdometrySettings, BeaconSettings)


class _KernelLocalization(Localization):
    """What the three localizations share: their settings, every robot's buffers and the
    compiled step (:func:`localize_robots`).

    A localization's settings are the fields of its :attr:`settings_records`, given by
    keyword; its signature (what ``localization_params`` is checked against) is made from
    them, so each setting is stated once, in its record. The records say what it does: with
    odometry, the odometry moves the estimate and a fix replaces it; without, the commands
    move the last fix, which is the estimate, held between fixes.

    :raises ValueError: naming the first bad setting, or the settings it does not take
    """

    #: The records whose fields are its settings.
    settings_records: ClassVar[tuple[type[OdometrySettings] | type[BeaconSettings], ...]]
    __signature__: ClassVar[inspect.Signature]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.__signature__ = inspect.Signature(
            [
                inspect.Parameter(
                    field.name,
                    inspect.Parameter.KEYWORD_ONLY,
                    default=field.default,
                    annotation=field.type,
                )
                for record in cls.settings_records
                for field in dataclasses.fields(record)
            ]
        )

    def __init__(self, **settings: Any):
        accepted = list(self.__signature__.parameters)
        unknown = sorted(set(settings) - set(accepted), key=str)
        if unknown:
            raise ValueError(
                f"{unknown} are not settings of localization {self.name!r}; its settings: "
                f"{accepted}"
            )
        #: Its odometry's settings; None without odometry.
        self.odometry_settings = self._record(OdometrySettings, settings)
        #: Its laser head's and fixes' settings; None without beacons.
        self.beacon_settings = self._record(BeaconSettings, settings)
        #: Whether the estimate is the last fix, held between fixes (no odometry to move it).
        self._hold_fix = self.odometry_settings is None

    def _record(self, record: type[RecordT], settings: dict[str, Any]) -> RecordT | None:
        """The ``record`` made of its fields among ``settings``, if this localization takes it."""
        if record not in self.settings_records:
            return None
        names = [field.name for field in dataclasses.fields(record)]
        return record(**{name: settings[name] for name in names if name in settings})

    def allocate(self, num_robots: int, model: KinematicModel, path_set: PathSet) -> None:
        self._model = model
        #: The localization step compiled for this model (its physics and encoders).
        self._localize = for_model(localize_robots, model.compiled)
        self.predicted = np.zeros((num_robots, 3))
        self._allocate_odometry(num_robots, model)
        self._allocate_beacons(num_robots, path_set)
        # The steering encoder reads the wheel angle: its column among those beyond the pose.
        self._gamma_column = (
            model.state_names.index("gamma") - 3 if "gamma" in model.state_names else None
        )

    def _allocate_odometry(self, num_robots: int, model: KinematicModel) -> None:
        # Without odometry the kernel still takes its (unused) arrays: one compiled version.
        settings = self.odometry_settings or OdometrySettings()
        self.wheels: WheelOdometry | None = None
        if self.odometry_settings is not None:
            try:
                self.wheels = WheelOdometry(model, settings)
            except ValueError as error:
                raise ValueError(f"localization={self.name!r}: {error}") from None
        self._odometry_parameters = settings.kernel_parameters
        self._encoder_settings = settings.encoder_settings
        blocks = NOISE_BLOCK_STEPS if self.wheels is not None else 1
        self.residuals = np.zeros((num_robots, 2))
        self.odometry_normals = np.zeros((num_robots, blocks, 3))
        self.odometry_cursor = np.zeros(num_robots, dtype=np.int64)

    def _allocate_beacons(self, num_robots: int, path_set: PathSet) -> None:
        # Without beacons the kernel still takes their (empty) arrays: one compiled version.
        settings = self.beacon_settings or BeaconSettings()
        reflectors: ArrayLike
        if self.beacon_settings is None:
            reflectors = np.zeros((0, 2))
        elif settings.reflectors is not None:
            reflectors = settings.reflectors
        else:
            try:
                reflectors = default_reflectors(path_set)
            except ValueError as error:
                raise ValueError(
                    f"localization={self.name!r}: {error} (localization_params="
                    "{'reflectors': [[x, y], ...]})"
                ) from None
        # A writeable copy: numba compiles read-only arrays as another type.
        self.reflectors = np.array(reflectors, dtype=np.float64, order="C")
        self.head = settings.head
        count = len(self.reflectors)
        #: The most readings a step takes.
        self.per_step = min(count, settings.max_readings)
        self._settings = np.zeros(len(LocalizationSetting))
        self._settings[LocalizationSetting.MOTION] = (
            FROM_COMMANDS if self.odometry_settings is None else FROM_ODOMETRY
        )
        self._settings[LocalizationSetting.USE_BEACONS] = self.beacon_settings is not None
        self._settings[LocalizationSetting.HOLD_FIX] = self._hold_fix
        self._settings[LocalizationSetting.MAX_HEADING_GAIN] = settings.max_heading_gain
        self._settings[LocalizationSetting.READINGS_PER_STEP] = self.per_step
        self._settings[LocalizationSetting.BEARING_NOISE] = settings.bearing_noise
        self.beacon_floats = np.zeros((num_robots, len(BeaconFloat)))
        self.beacon_ints = np.zeros((num_robots, len(BeaconInt)), dtype=np.int64)
        self.readings = np.zeros((num_robots, count, len(Reading)))
        self.reading_flags = np.zeros((num_robots, count, len(ReadingFlag)), dtype=bool)
        self.walls = np.zeros((0, 4))
        self._wall_slots: dict[Maze, tuple[int, int]] = {}
        # The readings' noise: a block of NOISE_BLOCK_STEPS steps' worth of the most readings
        # a step takes (one unused column without noise: one compiled kernel for both).
        columns = NOISE_BLOCK_STEPS * self.per_step if settings.bearing_noise > 0.0 else 1
        self.bearing_normals = np.zeros((num_robots, columns))

    def reset(
        self, world: LocalizationWorld, indices: Indices, rngs: Generators, estimate: Array
    ) -> None:
        estimate[indices] = world.state[indices, :3]
        self.predicted[indices] = estimate[indices]
        if self.wheels is not None:
            self.residuals[indices] = 0.0
            for index in indices:
                self._refill_odometry_noise(index, rngs)
        if self.beacon_settings is not None:
            self._reset_beacons(world, indices, rngs)

    def _refill_odometry_noise(self, index: int, rngs: Generators) -> None:
        rngs[index].standard_normal(out=self.odometry_normals[index])
        self.odometry_cursor[index] = 0

    def _reset_beacons(self, world: LocalizationWorld, indices: Indices, rngs: Generators) -> None:
        assert self.beacon_settings is not None
        noisy = self.beacon_settings.bearing_noise > 0.0
        self.reading_flags[indices] = False
        self.beacon_ints[indices, BeaconInt.FIXES] = 0
        if noisy:
            self.beacon_ints[indices, BeaconInt.NOISE_CURSOR] = self.bearing_normals.shape[1]
        for index in indices:
            self.beacon_floats[index, BeaconFloat.BEAM] = rngs[index].uniform(0.0, 2.0 * math.pi)
            if noisy:
                self._refill_bearing_noise(np.array([index]), rngs)
            track = world.tracks[index]
            maze = None if track is None else track.maze
            if maze is None:
                self.beacon_ints[index, BeaconInt.WALL_START : BeaconInt.WALL_COUNT + 1] = 0
                continue
            if maze not in self._wall_slots and len(self._wall_slots) >= 2 * world.num_robots:
                self._pack_walls(world)  # random mazes: forget those no robot drives in
            if maze not in self._wall_slots:
                self._add_walls(maze)
            self._place_walls(index, maze)

    def _refill_bearing_noise(self, indices: Indices, rngs: Generators) -> None:
        """New blocks of normals for the robots among ``indices`` that have fewer left than a
        step may take (all of ``indices`` right after their reset)."""
        cursors = self.beacon_ints[indices, BeaconInt.NOISE_CURSOR]
        for index in indices[cursors + self.per_step > self.bearing_normals.shape[1]]:
            rngs[index].standard_normal(out=self.bearing_normals[index])
            self.beacon_ints[index, BeaconInt.NOISE_CURSOR] = 0

    def _add_walls(self, maze: Maze) -> None:
        segments = np.asarray(maze.walls, dtype=np.float64).reshape(-1, 4)
        self._wall_slots[maze] = (len(self.walls), len(segments))
        self.walls = np.ascontiguousarray(np.vstack((self.walls, segments)))

    def _place_walls(self, robot: int, maze: Maze) -> None:
        start, count = self._wall_slots[maze]
        self.beacon_ints[robot, BeaconInt.WALL_START] = start
        self.beacon_ints[robot, BeaconInt.WALL_COUNT] = count

    def _pack_walls(self, world: LocalizationWorld) -> None:
        self.walls, self._wall_slots = np.zeros((0, 4)), {}
        for robot, track in enumerate(world.tracks):
            maze = None if track is None else track.maze
            if maze is not None:
                if maze not in self._wall_slots:
                    self._add_walls(maze)
                self._place_walls(robot, maze)

    def update(
        self, world: LocalizationWorld, indices: Indices, rngs: Generators, estimate: Array
    ) -> None:
        refill = self._localize(
            indices,
            self._settings,
            self.head.kernel_parameters,
            self._model.kernel_parameters,
            self._encoder_settings,
            self._odometry_parameters,
            world.previous_state,
            world.state,
            world.inputs,
            world.dt,
            self.predicted if self._hold_fix else estimate,
            estimate,
            self.residuals,
            self.odometry_normals,
            self.odometry_cursor,
            self.reflectors,
            self.walls,
            self.beacon_floats,
            self.beacon_ints,
            self.readings,
            self.reading_flags,
            self.bearing_normals,
        )
        if refill & ODOMETRY_BLOCK_USED and self.wheels is not None:
            for index in indices[self.odometry_cursor[indices] == NOISE_BLOCK_STEPS]:
                self._refill_odometry_noise(index, rngs)
        if refill & BEARING_BLOCK_LOW:
            self._refill_bearing_noise(indices, rngs)

    @property
    def landmarks(self) -> Array | None:
        return None if self.beacon_settings is None else self.reflectors.copy()

    def sightings(self, index: int) -> Array:
        """(L, 2, 2) segments from the head at robot ``index``'s last fix to the reflectors
        whose readings made it."""
        if self.beacon_settings is None or self.beacon_ints[index, BeaconInt.FIXES] == 0:
            return np.zeros((0, 2, 2))
        fix = self.beacon_floats[index, BeaconFloat.FIX_X : BeaconFloat.FIX_HEADING + 1]
        head = self.head.head_position(fix)
        seen = self.reflectors[self.reading_flags[index, :, ReadingFlag.IN_FIX]]
        return np.stack((np.broadcast_to(head, seen.shape), seen), axis=1)

    def read_model_state(self, states: Array) -> Array:
        believed = np.array(states, dtype=np.float64)
        if self.wheels is not None and self._gamma_column is not None:
            column = self._gamma_column
            believed[..., column] = self.wheels.read_steering(believed[..., column])
        return believed


class OdometryLocalization(_KernelLocalization):
    """Wheel odometry (seed 000): ``localization="odometry"``.

    Each step the encoders measure U(k) = (dD, dtheta) (eq. 16 for the differential drive, a
    traction and a steering encoder for the bicycle and the tricycle) and the estimate
    advances by ``method``'s step plus v(k) ~ N(0, Q(k)) of eq. 17. The constant-velocity
    model has no wheels: refused (``ValueError``).

    Its settings are the fields of :class:`~mobile_envs.sensing.odometry.OdometrySettings`,
    by keyword: ``localization_params={"k_distance": 0.002, "encoder_counts": 1024}``.
    """

    name = "odometry"
    env_id = "Odometry"
    needs_encoders = True
    settings_records = (OdometrySettings,)


class BeaconLocalization(_KernelLocalization):
    """Laser-beacon positioning (seed 003 section 2): ``localization="beacons"``.

    The head turns at ``frequency`` and reads each reflector in range and in sight when its
    beam sweeps it (quantized to ``counts_per_revolution``); walls hide reflectors. At the end
    of every step the latest reading of each reflector within the last revolution, brought to
    the robot's pose at that instant (dynamic positioning), fixes position and heading; the
    estimate is the last fix, held while fewer than three reflectors give a fix. The motion
    between readings and the heading the triangulation starts from come from the commands
    (the last fix moved by the model's exact step under the robot's inputs). Works for every
    model.

    Its settings are the fields of :class:`BeaconSettings`, by keyword:
    ``localization_params={"bearing_noise": 0.001}``.
    """

    name = "beacons"
    env_id = "Beacons"
    settings_records = (BeaconSettings,)


class OdometryBeaconLocalization(_KernelLocalization):
    """Odometry corrected by the beacons' fixes, as seed 003 combines them:
    ``localization="odometry+beacons"``.

    The odometry of :class:`OdometryLocalization` moves the estimate every step, gives the
    heading the triangulation starts from and the motion between the readings; each fix of
    :class:`BeaconLocalization` replaces the estimate (only its position near the critical
    circle, where the heading stays the odometry's). Its settings are the fields of both
    records, :class:`~mobile_envs.sensing.odometry.OdometrySettings` and
    :class:`BeaconSettings`.
    """

    name = "odometry+beacons"
    env_id = "OdometryBeacons"
    needs_encoders = True
    settings_records = (OdometrySettings, BeaconSettings)

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

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from mobile_envs._kernels.angles import wrap_scalar_angle
from mobile_envs._kernels.specialize import for_model, model, per_model
from mobile_envs.robots import INTEGRATORS, KinematicModel
from mobile_envs.sensing.beacons import (
    DEFAULT_MAX_HEADING_GAIN,
    NO_FIX,
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
    DEFAULT_K_DISTANCE,
    DEFAULT_K_DISTANCE_HEADING,
    DEFAULT_K_HEADING,
    OdometrySettings,
    WheelOdometry,
    measure_increments,
    noisy_dead_reckoning,
    odometry_motion,
)
from mobile_envs.tracks.sets import PathSet
from mobile_envs.world.maze import Maze

__all__ = [
    "DEFAULT_MAX_READINGS",
    "NOISE_BLOCK_STEPS",
    "BeaconLocalization",
    "OdometryBeaconLocalization",
    "OdometryLocalization",
    "localize_robots",
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
def _nearest_in_sight(pose, reflectors, walls, head_parameters, most, candidates):
    """Write into ``candidates`` the reflectors the head at ``pose`` reads, and return how
    many: all of them when there are at most ``most``, else the ``most`` nearest in range
    and in sight."""
    count = reflectors.shape[0]
    if count <= most:
        for r in range(count):
            candidates[r] = r
        return count
    cos_h, sin_h = math.cos(pose[2]), math.sin(pose[2])
    head_x = pose[0] + head_parameters[3] * cos_h - head_parameters[4] * sin_h
    head_y = pose[1] + head_parameters[3] * sin_h + head_parameters[4] * cos_h
    distances = np.empty(count)
    for r in range(count):
        distances[r] = math.hypot(reflectors[r, 0] - head_x, reflectors[r, 1] - head_y)
    chosen = 0
    for r in np.argsort(distances):
        if distances[r] > head_parameters[2]:
            break
        if distances[r] > 0.0 and sight_is_clear(
            head_x, head_y, reflectors[r, 0], reflectors[r, 1], walls
        ):
            candidates[chosen] = r
            chosen += 1
            if chosen == most:
                break
    return chosen


@per_model()
def localize_robots(
    indices, motion, use_beacons, hold_fix, model_parameters, encoder_settings,
    odometry_parameters, head_parameters, max_heading_gain, max_readings, reflectors, walls,
    wall_starts, wall_counts,
    previous_state, state, inputs, dt, residuals, normals, cursor, predicted, predicted_before,
    estimate, beam, bearings, relative, ages, read, fix_pose, fix_used, has_fix, bearing_noise,
    bearing_normals, bearing_cursor,
):  # fmt: skip
    """One step of the robots ``indices``' localization.

    1. The prediction moves: by the odometry (the encoders' increments, then eq. 14 with the
       robot's next three normals, as :func:`~mobile_envs.sensing.odometry.advance_odometry`) or by
       the commands (the model's exact step from the predicted pose, with the other state
       columns as the robot is). The motion the robot knows of is the odometry's without
       its noise (:func:`~mobile_envs.sensing.odometry.odometry_motion`), or the commanded one.
    2. With beacons: the readings stored from earlier steps age by ``dt`` and their poses
       are carried by the known motion into the frame of the pose at the step's end. The
       head sweeps the step (its last revolution, at most) while the robot moves along the
       screw that joins its true poses at the step's start and end (exact for rigid bodies
       under the exact integrator), reading the reflectors :func:`_nearest_in_sight`
       picks. Each new reading replaces the reflector's last, with its pose on the known
       motion's screw; a reflector swept but not seen loses its last, as do readings older
       than two revolutions (the beam reaches a reflector once a revolution, give or take
       the robot's turn). Then the stored readings, corrected to the predicted pose, are
       triangulated from the predicted heading; a fix replaces the prediction (its
       position, when the heading is kept) and, with ``hold_fix``, the estimate.

    :param motion: :data:`FROM_ODOMETRY` or :data:`FROM_COMMANDS`
    :param predicted: (N, 3) the predicted poses; the estimate itself unless ``hold_fix``
    :param predicted_before: (N, 3) receives the predicted poses at the step's start
    :param normals: (N, B, 3) each robot's block of standard normals, used from ``cursor``
    :param relative: (N, R, 3) each stored reading's pose in the frame of the predicted pose
    :param bearing_noise: the standard deviation (rad) of each reading's error; 0 for none
    :param bearing_normals: (N, B) each robot's block of standard normals for the readings,
        used from ``bearing_cursor``
    :return: :data:`ODOMETRY_BLOCK_USED` if some robot has used up its block of normals,
        plus :data:`BEARING_BLOCK_LOW` if some robot has fewer normals left for the readings
        than a step may take
    """
    exhausted = False
    bearings_low = False
    per_step = min(reflectors.shape[0], max_readings)
    count = reflectors.shape[0]
    scratch_state = np.empty(state.shape[1])
    sweep_start = np.empty(3)
    fresh, times = np.empty(count), np.empty(count)
    swept = np.empty(count, dtype=np.bool_)
    member_positions, member_bearings = np.empty((count, 2)), np.empty(count)
    member_poses, corrected = np.empty((count, 3)), np.empty(count)
    candidates = np.empty(count, dtype=np.int64)
    candidate_positions = np.empty((count, 2))
    errors = np.zeros(count)
    fix = np.empty(3)
    period = 1.0 / head_parameters[0]
    error_bound = bearing_error(head_parameters, bearing_noise)
    spin = 2.0 * math.pi * head_parameters[0]
    offset_x, offset_y = head_parameters[3], head_parameters[4]
    for i in indices:
        for c in range(3):
            predicted_before[i, c] = predicted[i, c]
        before, after = predicted_before[i], predicted[i]
        if motion == FROM_ODOMETRY:
            delta_distance, delta_heading = measure_increments(
                model_parameters, encoder_settings, previous_state[i], state[i], inputs[i], dt,
                residuals[i],
            )  # fmt: skip
            noisy_dead_reckoning(
                odometry_parameters, after, delta_distance, delta_heading, normals[i, cursor[i]]
            )
            cursor[i] += 1
            exhausted = exhausted or cursor[i] == normals.shape[1]
            # The motion the encoders read: eq. 17's noise is the estimate's drift, not a
            # motion the robot could know of.
            moved_x, moved_y, turned = odometry_motion(
                odometry_parameters, delta_distance, delta_heading
            )
        else:
            scratch_state[:] = previous_state[i]
            scratch_state[:3] = after
            model.advance(model_parameters, scratch_state, inputs[i], dt, _EXACT, scratch_state)
            after[:] = scratch_state[:3]
            moved_x, moved_y, turned = _relative_pose(
                before[0], before[1], before[2], after[0], after[1], after[2]
            )
        if not use_beacons:
            continue
        turned = wrap_scalar_angle(turned)
        for r in range(count):
            if read[i, r]:
                ages[i, r] += dt
                if ages[i, r] > 2.0 * period:
                    read[i, r] = False
                    continue
                relative[i, r, 0], relative[i, r, 1], relative[i, r, 2] = _relative_pose(
                    moved_x, moved_y, turned, relative[i, r, 0], relative[i, r, 1],
                    relative[i, r, 2],
                )  # fmt: skip

        true_x, true_y, true_turn = _relative_pose(
            previous_state[i, 0], previous_state[i, 1], previous_state[i, 2], state[i, 0],
            state[i, 1], state[i, 2],
        )  # fmt: skip
        true_vx, true_vy, true_omega = _twist_between(true_x, true_y, true_turn, dt)
        start = max(0.0, dt - period)
        sweep_start[0], sweep_start[1], sweep_start[2] = screw_pose(
            previous_state[i, 0], previous_state[i, 1], previous_state[i, 2], true_vx * start,
            true_vy * start, true_omega * start,
        )  # fmt: skip
        robot_walls = walls[wall_starts[i] : wall_starts[i] + wall_counts[i]]
        chosen = _nearest_in_sight(
            sweep_start, reflectors, robot_walls, head_parameters, max_readings, candidates
        )
        for n in range(chosen):
            candidate_positions[n] = reflectors[candidates[n]]
            times[n] = -1.0  # stays negative where the beam does not reach the reflector
        if bearing_noise > 0.0:
            for n in range(chosen):
                errors[n] = bearing_noise * bearing_normals[i, bearing_cursor[i] + n]
            bearing_cursor[i] += chosen
            bearings_low = bearings_low or (bearing_cursor[i] + per_step > bearing_normals.shape[1])
        beam[i] = sweep_screw_bearings(
            sweep_start, true_vx, true_vy, true_omega, beam[i] + spin * start, dt - start,
            candidate_positions[:chosen], robot_walls, head_parameters, fresh, times, swept,
            errors[:chosen],
        )  # fmt: skip
        believed_vx, believed_vy, believed_omega = _twist_between(moved_x, moved_y, turned, dt)
        for n in range(chosen):
            r = candidates[n]
            if not swept[n]:
                # Swept but not seen (hidden, out of range): the head reads nothing there.
                if times[n] >= 0.0:
                    read[i, r] = False
                continue
            t = start + times[n]
            read_x, read_y, read_heading = screw_pose(
                0.0, 0.0, 0.0, believed_vx * t, believed_vy * t, believed_omega * t
            )
            relative[i, r, 0], relative[i, r, 1], relative[i, r, 2] = _relative_pose(
                moved_x, moved_y, turned, read_x, read_y, read_heading
            )
            bearings[i, r] = fresh[n]
            ages[i, r] = dt - t
            read[i, r] = True

        members = 0
        for r in range(count):
            if read[i, r]:
                member_positions[members] = reflectors[r]
                member_bearings[members] = bearings[i, r]
                member_poses[members] = relative[i, r]
                members += 1
        if members < 3:
            continue
        correct_robot_bearings(
            member_positions[:members], member_bearings[:members], member_poses[:members],
            after, head_parameters, corrected[:members],
        )  # fmt: skip
        cos_h, sin_h = math.cos(after[2]), math.sin(after[2])
        status = triangulate_near(
            member_positions, corrected, members,
            after[0] + offset_x * cos_h - offset_y * sin_h,
            after[1] + offset_x * sin_h + offset_y * cos_h, after[2], max_heading_gain,
            error_bound, fix,
        )  # fmt: skip
        if status == NO_FIX:
            continue
        cos_h, sin_h = math.cos(fix[2]), math.sin(fix[2])
        after[0] = fix[0] - (offset_x * cos_h - offset_y * sin_h)
        after[1] = fix[1] - (offset_x * sin_h + offset_y * cos_h)
        after[2] = fix[2]
        fix_pose[i] = after
        fix_used[i] = read[i]
        has_fix[i] = True
        if hold_fix:
            estimate[i] = after
    return (ODOMETRY_BLOCK_USED if exhausted else 0) + (BEARING_BLOCK_LOW if bearings_low else 0)


# ---------------------------------------------------------------- settings


def _non_negative(value: object, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    number = float(value)
    if not (math.isfinite(number) and number >= 0.0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return number


def _positive(value: object, name: str, allow_inf: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    number = float(value)
    if math.isnan(number) or number <= 0.0 or (math.isinf(number) and not allow_inf):
        raise ValueError(
            f"{name} must be a positive {'' if allow_inf else 'finite '}number, got {value!r}"
        )
    return number


class _Odometry:
    """The wheel-odometry settings and per-robot buffers two localizations share."""

    def __init__(self, settings: OdometrySettings):
        self.settings = settings
        self.wheels: WheelOdometry | None = None

    def allocate(self, num_robots: int, model: KinematicModel, name: str) -> None:
        try:
            self.wheels = WheelOdometry(model, self.settings)
        except ValueError as error:
            raise ValueError(f"localization={name!r}: {error}") from None
        self.residuals = np.zeros((num_robots, 2))
        self.normals = np.zeros((num_robots, NOISE_BLOCK_STEPS, 3))
        self.cursor = np.zeros(num_robots, dtype=np.int64)

    def reset(self, indices: Indices, rngs: Generators) -> None:
        self.residuals[indices] = 0.0
        for index in indices:
            self.refill(index, rngs)

    def refill(self, index: int, rngs: Generators) -> None:
        rngs[index].standard_normal(out=self.normals[index])
        self.cursor[index] = 0

    def refill_exhausted(self, indices: Indices, rngs: Generators) -> None:
        for index in indices[self.cursor[indices] == NOISE_BLOCK_STEPS]:
            self.refill(index, rngs)


class _Beacons:
    """The laser head, the reflectors and each robot's readings."""

    def __init__(
        self,
        reflectors: ArrayLike | None,
        frequency: float,
        counts_per_revolution: int | None,
        max_range: float,
        head_offset: ArrayLike,
        max_heading_gain: float,
        max_readings: int,
        bearing_noise: float,
    ):
        try:
            self.head = LaserHead(frequency, counts_per_revolution, max_range, head_offset)
        except ValueError as error:  # the head calls it offset; the setting is head_offset
            if not str(error).startswith("offset "):
                raise
            raise ValueError(f"head_{error}") from None
        self.given_reflectors = None if reflectors is None else validate_reflectors(reflectors)
        self.max_heading_gain = _positive(max_heading_gain, "max_heading_gain", allow_inf=True)
        if (
            isinstance(max_readings, bool)
            or not isinstance(max_readings, (int, np.integer))
            or max_readings < 3
        ):
            raise ValueError(f"max_readings must be an integer >= 3, got {max_readings!r}")
        self.max_readings = int(max_readings)
        self.bearing_noise = _non_negative(bearing_noise, "bearing_noise")
        self.reflectors = np.zeros((0, 2))

    def allocate(self, num_robots: int, path_set: PathSet, name: str) -> None:
        if self.given_reflectors is not None:
            reflectors = np.array(self.given_reflectors)
        else:
            try:
                reflectors = default_reflectors(path_set)
            except ValueError as error:
                raise ValueError(
                    f"localization={name!r}: {error} (localization_params={{'reflectors': "
                    "[[x, y], ...]}})"
                ) from None
        self.allocate_readings(num_robots, reflectors)

    def allocate_readings(self, num_robots: int, reflectors: Array) -> None:
        """Per-robot buffers for the readings of ``reflectors`` (R, 2)."""
        self.reflectors = np.ascontiguousarray(reflectors, dtype=np.float64)
        count = len(self.reflectors)
        self.beam = np.zeros(num_robots)
        self.bearings = np.zeros((num_robots, count))
        self.relative = np.zeros((num_robots, count, 3))
        self.ages = np.zeros((num_robots, count))
        self.read = np.zeros((num_robots, count), dtype=bool)
        self.fix_pose = np.zeros((num_robots, 3))
        self.fix_used = np.zeros((num_robots, count), dtype=bool)
        self.has_fix = np.zeros(num_robots, dtype=bool)
        self.wall_starts = np.zeros(num_robots, dtype=np.int64)
        self.wall_counts = np.zeros(num_robots, dtype=np.int64)
        self.walls = np.zeros((0, 4))
        self._wall_slots: dict[Maze, tuple[int, int]] = {}
        # The readings' noise: a block of NOISE_BLOCK_STEPS steps' worth of the most readings
        # a step takes (one unused column without noise: one compiled kernel for both).
        self.per_step = min(count, self.max_readings)
        columns = NOISE_BLOCK_STEPS * self.per_step if self.bearing_noise > 0.0 else 1
        self.bearing_normals = np.zeros((num_robots, columns))
        self.bearing_cursor = np.zeros(num_robots, dtype=np.int64)

    def refill_bearing_noise(self, indices: Indices, rngs: Generators) -> None:
        """New blocks of normals for the robots among ``indices`` that have fewer left than a
        step may take (all of ``indices`` right after their reset)."""
        low = self.bearing_cursor[indices] + self.per_step > self.bearing_normals.shape[1]
        for index in indices[low]:
            rngs[index].standard_normal(out=self.bearing_normals[index])
            self.bearing_cursor[index] = 0

    def reset(self, world: LocalizationWorld, indices: Indices, rngs: Generators) -> None:
        self.read[indices] = False
        self.has_fix[indices] = False
        if self.bearing_noise > 0.0:
            self.bearing_cursor[indices] = self.bearing_normals.shape[1]
        for index in indices:
            self.beam[index] = rngs[index].uniform(0.0, 2.0 * math.pi)
            if self.bearing_noise > 0.0:
                self.refill_bearing_noise(np.array([index]), rngs)
            track = world.tracks[index]
            maze = None if track is None else track.maze
            if maze is None:
                self.wall_starts[index] = self.wall_counts[index] = 0
                continue
            if maze not in self._wall_slots and len(self._wall_slots) >= 2 * world.num_robots:
                self._pack_walls(world)  # random mazes: forget those no robot drives in
            if maze not in self._wall_slots:
                self._add_walls(maze)
            self.wall_starts[index], self.wall_counts[index] = self._wall_slots[maze]

    def _add_walls(self, maze: Maze) -> None:
        segments = np.asarray(maze.walls, dtype=np.float64).reshape(-1, 4)
        self._wall_slots[maze] = (len(self.walls), len(segments))
        self.walls = np.ascontiguousarray(np.vstack((self.walls, segments)))

    def _pack_walls(self, world: LocalizationWorld) -> None:
        self.walls, self._wall_slots = np.zeros((0, 4)), {}
        for robot, track in enumerate(world.tracks):
            maze = None if track is None else track.maze
            if maze is not None:
                if maze not in self._wall_slots:
                    self._add_walls(maze)
                self.wall_starts[robot], self.wall_counts[robot] = self._wall_slots[maze]

    def sightings(self, index: int) -> Array:
        """(L, 2, 2) segments from the head at robot ``index``'s last fix to the reflectors
        whose readings made it."""
        if not self.has_fix[index]:
            return np.zeros((0, 2, 2))
        head = self.head.head_position(self.fix_pose[index])
        seen = self.reflectors[self.fix_used[index]]
        return np.stack((np.broadcast_to(head, seen.shape), seen), axis=1)


def _no_odometry(num_robots: int) -> tuple[Array, Array, NDArray[np.int64]]:
    return np.zeros((num_robots, 2)), np.zeros((num_robots, 1, 3)), np.zeros(num_robots, np.int64)


# ---------------------------------------------------------------- the localizations


class _KernelLocalization(Localization):
    """What the three localizations share: the prediction, the buffers and the kernel call."""

    _motion: int
    _hold_fix: bool

    def __init__(self, odometry: _Odometry | None, beacons: _Beacons | None):
        self._odometry = odometry
        self._beacons = beacons

    def allocate(self, num_robots: int, model: KinematicModel, path_set: PathSet) -> None:
        self._model = model
        if self._odometry is not None:
            self._odometry.allocate(num_robots, model, self.name)
            odometry = self._odometry
            self._odometry_arrays = (odometry.residuals, odometry.normals, odometry.cursor)
            assert odometry.wheels is not None
            self._odometry_parameters = odometry.wheels.kernel_parameters
            self._encoder_settings = odometry.wheels.encoder_settings
        else:
            self._odometry_arrays = _no_odometry(num_robots)
            self._odometry_parameters = OdometrySettings().kernel_parameters
            self._encoder_settings = OdometrySettings().encoder_settings
        #: The localization step compiled for this model (its physics and encoders).
        self._localize = for_model(localize_robots, model.compiled)
        # Without beacons the kernel still takes their (empty) arrays: one compiled version.
        beacons = self._beacons or _Beacons(None, 8.0, None, 1.0, (0.0, 0.0), 1.0, 3, 0.0)
        if self._beacons is None:
            beacons.allocate_readings(num_robots, np.zeros((0, 2)))
        else:
            beacons.allocate(num_robots, path_set, self.name)
        self._beacon_arrays = beacons
        self.predicted = np.zeros((num_robots, 3))
        self.predicted_before = np.zeros((num_robots, 3))
        # The steering encoder reads the wheel angle: its column among those beyond the pose.
        self._gamma_column = (
            model.state_names.index("gamma") - 3 if "gamma" in model.state_names else None
        )

    def reset(
        self, world: LocalizationWorld, indices: Indices, rngs: Generators, estimate: Array
    ) -> None:
        estimate[indices] = world.state[indices, :3]
        self.predicted[indices] = estimate[indices]
        if self._odometry is not None:
            self._odometry.reset(indices, rngs)
        if self._beacons is not None:
            self._beacons.reset(world, indices, rngs)

    def update(
        self, world: LocalizationWorld, indices: Indices, rngs: Generators, estimate: Array
    ) -> None:
        beacons = self._beacon_arrays
        residuals, normals, cursor = self._odometry_arrays
        predicted = self.predicted if self._hold_fix else estimate
        refill = self._localize(
            indices, self._motion, self._beacons is not None, self._hold_fix,
            self._model.kernel_parameters, self._encoder_settings, self._odometry_parameters,
            beacons.head.kernel_parameters, beacons.max_heading_gain, beacons.max_readings,
            beacons.reflectors,
            beacons.walls, beacons.wall_starts, beacons.wall_counts, world.previous_state,
            world.state, world.inputs, world.dt, residuals, normals, cursor, predicted,
            self.predicted_before, estimate, beacons.beam, beacons.bearings, beacons.relative,
            beacons.ages, beacons.read, beacons.fix_pose, beacons.fix_used, beacons.has_fix,
            beacons.bearing_noise, beacons.bearing_normals, beacons.bearing_cursor,
        )  # fmt: skip
        if refill & ODOMETRY_BLOCK_USED and self._odometry is not None:
            self._odometry.refill_exhausted(indices, rngs)
        if refill & BEARING_BLOCK_LOW:
            beacons.refill_bearing_noise(indices, rngs)

    @property
    def landmarks(self) -> Array | None:
        return None if self._beacons is None else self._beacons.reflectors.copy()

    def sightings(self, index: int) -> Array:
        if self._beacons is None:
            return np.zeros((0, 2, 2))
        return self._beacons.sightings(index)

    def read_model_state(self, states: Array) -> Array:
        believed = np.array(states, dtype=np.float64)
        if self._odometry is not None and self._gamma_column is not None:
            wheels = self._odometry.wheels
            assert wheels is not None
            column = self._gamma_column
            believed[..., column] = wheels.read_steering(believed[..., column])
        return believed


class OdometryLocalization(_KernelLocalization):
    """Wheel odometry (seed 000): ``localization="odometry"``.

    Each step the encoders measure U(k) = (dD, dtheta) (eq. 16 for the differential drive, a
    traction and a steering encoder for the bicycle and the tricycle) and the estimate
    advances by ``method``'s step plus v(k) ~ N(0, Q(k)) of eq. 17. The constant-velocity
    model has no wheels: refused (``ValueError``).

    :param method: ``"euler"`` (eq. 20), ``"midpoint"`` (eq. 26) or ``"exact"`` (eq. 25)
    :param k_distance: K_D of eq. 17 (m^2/m), >= 0
    :param k_distance_heading: K_Dtheta (rad^2/m), >= 0
    :param k_heading: K_theta (rad^2/rad), >= 0
    :param wheel_radius_error: relative error of the wheel radii the odometry assumes, in
        (-1, 1) (see :class:`~mobile_envs.sensing.odometry.WheelOdometry`)
    :param wheelbase_error: relative error of the track width / wheelbase, in (-1, 1)
    :param encoder_counts: traction encoder counts per revolution; None for ideal encoders
    :param steering_counts: steering encoder counts per revolution; None for an ideal one
    :param traction_wheel_radius: the car-like robots' traction wheel radius (m), needed with
        ``encoder_counts``
    :raises ValueError: naming the first bad setting
    """

    name = "odometry"
    env_id = "Odometry"
    needs_encoders = True
    _motion = FROM_ODOMETRY
    _hold_fix = False

    def __init__(
        self,
        method: str = "exact",
        k_distance: float = DEFAULT_K_DISTANCE,
        k_distance_heading: float = DEFAULT_K_DISTANCE_HEADING,
        k_heading: float = DEFAULT_K_HEADING,
        wheel_radius_error: float = 0.0,
        wheelbase_error: float = 0.0,
        encoder_counts: int | None = None,
        steering_counts: int | None = None,
        traction_wheel_radius: float | None = None,
    ):
        settings = OdometrySettings(
            method, k_distance, k_distance_heading, k_heading, wheel_radius_error,
            wheelbase_error, encoder_counts, steering_counts, traction_wheel_radius,
        )  # fmt: skip
        super().__init__(_Odometry(settings), None)


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

    :param reflectors: (R, 2) positions (m), R >= 3 and not all on a line; None for the path
        set's layout (:func:`mobile_envs.sensing.beacons.default_reflectors`)
    :param frequency: the head's revolutions per second (Hz)
    :param counts_per_revolution: the head encoder's counts a turn; None for exact bearings
    :param max_range: the farthest reflector the head reads (m)
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

    name = "beacons"
    env_id = "Beacons"
    _motion = FROM_COMMANDS
    _hold_fix = True

    def __init__(
        self,
        reflectors: ArrayLike | None = None,
        frequency: float = 8.0,
        counts_per_revolution: int | None = 65535,
        max_range: float = 30.0,
        head_offset: ArrayLike = (0.0, 0.0),
        max_heading_gain: float = DEFAULT_MAX_HEADING_GAIN,
        max_readings: int = DEFAULT_MAX_READINGS,
        bearing_noise: float = 0.0,
    ):
        beacons = _Beacons(
            reflectors, frequency, counts_per_revolution, max_range, head_offset,
            max_heading_gain, max_readings, bearing_noise,
        )  # fmt: skip
        super().__init__(None, beacons)


class OdometryBeaconLocalization(_KernelLocalization):
    """Odometry corrected by the beacons' fixes, as seed 003 combines them:
    ``localization="odometry+beacons"``.

    The odometry of :class:`OdometryLocalization` moves the estimate every step, gives the
    heading the triangulation starts from and the motion between the readings; each fix of
    :class:`BeaconLocalization` replaces the estimate (only its position near the critical
    circle, where the heading stays the odometry's). Takes the settings of both.
    """

    name = "odometry+beacons"
    env_id = "OdometryBeacons"
    needs_encoders = True
    _motion = FROM_ODOMETRY
    _hold_fix = False

    def __init__(
        self,
        method: str = "exact",
        k_distance: float = DEFAULT_K_DISTANCE,
        k_distance_heading: float = DEFAULT_K_DISTANCE_HEADING,
        k_heading: float = DEFAULT_K_HEADING,
        wheel_radius_error: float = 0.0,
        wheelbase_error: float = 0.0,
        encoder_counts: int | None = None,
        steering_counts: int | None = None,
        traction_wheel_radius: float | None = None,
        reflectors: ArrayLike | None = None,
        frequency: float = 8.0,
        counts_per_revolution: int | None = 65535,
        max_range: float = 30.0,
        head_offset: ArrayLike = (0.0, 0.0),
        max_heading_gain: float = DEFAULT_MAX_HEADING_GAIN,
        max_readings: int = DEFAULT_MAX_READINGS,
        bearing_noise: float = 0.0,
    ):
        settings = OdometrySettings(
            method, k_distance, k_distance_heading, k_heading, wheel_radius_error,
            wheelbase_error, encoder_counts, steering_counts, traction_wheel_radius,
        )  # fmt: skip
        beacons = _Beacons(
            reflectors, frequency, counts_per_revolution, max_range, head_offset,
            max_heading_gain, max_readings, bearing_noise,
        )  # fmt: skip
        super().__init__(_Odometry(settings), beacons)

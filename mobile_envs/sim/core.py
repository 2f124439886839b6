"""The batched simulation behind both environments: N robots, each on its own track.

:class:`PathFollowingCore` owns every per-robot array (state, path row, progress, metrics,
sensor readings) and advances all robots with a few calls into compiled kernels
(:mod:`mobile_envs.sim.step`). The single environment is the N = 1 case and the vector
environment the N > 1 case, so both compute observations, rewards and terminations with the
same code, bit for bit. The core composes the model (:mod:`mobile_envs.robots.model`), the
path table (:mod:`mobile_envs.world.paths`), the mazes and the sensors
(:mod:`mobile_envs.sensing.sensors`)
and never asks which model or sensor it has.
"""

from __future__ import annotations

import copy
import functools
import itertools
import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from mobile_envs._kernels.pcg64 import draw_doubles, store_streams, stream_doubles, streams_of
from mobile_envs._kernels.specialize import for_model
from mobile_envs._kernels.threads import on_threads, start_kernel_threads
from mobile_envs.robots import INTEGRATORS
from mobile_envs.sensing.sensors import Array, Generators, Indices, Sensor
from mobile_envs.sim.columns import FlagColumn, FloatColumn, IntColumn, PackedColumn, Setting
from mobile_envs.sim.config import STALL_PROGRESS, CoreConfig
from mobile_envs.sim.observation import preview_offsets
from mobile_envs.sim.plant import Plant
from mobile_envs.sim.step import (
    BELIEF,
    move_and_score_robots,
    move_robots,
    move_robots_parallel,
    observe_robots,
    observe_robots_parallel,
    score_robots,
    score_robots_parallel,
    start_robots,
    step_and_observe_robots,
    track_estimates,
)
from mobile_envs.tracks.sets import Track
from mobile_envs.world.maze import Maze
from mobile_envs.world.maze_pack import MazePack
from mobile_envs.world.paths import DEFAULT_SEARCH_DISTANCE, Path, PathTable

_NO_RAYS = np.empty(0)
# A plain int for the packed column reset reads (IntEnum arithmetic costs on a hot path).
_PATH_ROW = int(IntColumn.PATH_ROW)


class PathFollowingCore:
    """N robots following paths, advanced together.

    Every per-robot scalar lives in a column of one of three packed arrays, ``floats``,
    ``ints`` and ``flags`` (:mod:`mobile_envs.sim.columns`), and each column is also an attribute
    of the same name: ``core.arc_length`` is ``core.floats[:, FloatColumn.ARC_LENGTH]``, a
    view. After :meth:`step`, ``reward``, ``terminated``, ``truncated``, ``success``,
    ``off_track``, ``stalled`` and ``collision`` hold the step's outcome; they are views that
    the next step overwrites, so callers that hand them out copy them. ``readings`` (N, S)
    holds the sensors' raw readings, each sensor in its columns.

    :param config: the validated settings
    :param num_robots: N
    """

    arc_length = PackedColumn[np.float64](FloatColumn)
    cross_track_error = PackedColumn[np.float64](FloatColumn)
    heading_error = PackedColumn[np.float64](FloatColumn)
    speed = PackedColumn[np.float64](FloatColumn)
    yaw_rate = PackedColumn[np.float64](FloatColumn)
    path_length = PackedColumn[np.float64](FloatColumn)
    progress = PackedColumn[np.float64](FloatColumn)
    farthest_arc_length = PackedColumn[np.float64](FloatColumn)
    sum_abs_cte = PackedColumn[np.float64](FloatColumn)
    sum_sq_cte = PackedColumn[np.float64](FloatColumn)
    max_abs_cte = PackedColumn[np.float64](FloatColumn)
    peak_abs_cte = PackedColumn[np.float64](FloatColumn)
    peak_growth = PackedColumn[np.float64](FloatColumn)
    distance = PackedColumn[np.float64](FloatColumn)
    reward = PackedColumn[np.float64](FloatColumn)
    estimated_arc_length = PackedColumn[np.float64](FloatColumn)
    estimated_cross_track_error = PackedColumn[np.float64](FloatColumn)
    estimated_heading_error = PackedColumn[np.float64](FloatColumn)
    sum_localization_error = PackedColumn[np.float64](FloatColumn)
    max_localization_error = PackedColumn[np.float64](FloatColumn)
    localization_error = PackedColumn[np.float64](FloatColumn)
    heading_localization_error = PackedColumn[np.float64](FloatColumn)
    path_row = PackedColumn[np.int64](IntColumn)
    segment = PackedColumn[np.int64](IntColumn)
    steps = PackedColumn[np.int64](IntColumn)
    time_limit = PackedColumn[np.int64](IntColumn)
    steps_without_progress = PackedColumn[np.int64](IntColumn)
    estimated_segment = PackedColumn[np.int64](IntColumn)
    collision = PackedColumn[np.bool_](FlagColumn)
    success = PackedColumn[np.bool_](FlagColumn)
    off_track = PackedColumn[np.bool_](FlagColumn)
    stalled = PackedColumn[np.bool_](FlagColumn)
    terminated = PackedColumn[np.bool_](FlagColumn)
    truncated = PackedColumn[np.bool_](FlagColumn)

    def __init__(self, config: CoreConfig, num_robots: int):
        self.config = config
        self.model = config.model
        self.num_robots = num_robots
        n, m = num_robots, self.model.input_dim
        self.action_center = 0.5 * (self.model.input_high + self.model.input_low)
        self.action_half_range = 0.5 * (self.model.input_high - self.model.input_low)
        # The step's map from actions to native inputs: each input's centre and half range.
        self._action_map = np.stack([self.action_center, self.action_half_range])
        self.robots = np.arange(n)
        self.floats = np.zeros((n, len(FloatColumn)))
        self.ints = np.zeros((n, len(IntColumn)), dtype=np.int64)
        self.flags = np.zeros((n, len(FlagColumn)), dtype=bool)
        self.state = np.zeros((n, self.model.state_dim))
        self.previous_action = np.zeros((n, m))
        #: (N, m) the native inputs the robots apply: the commanded ones, or with a plant the
        #: delayed and lagged ones (what their encoders measure).
        self.inputs = np.zeros((n, m))
        #: The robots' arrays as the compiled kernels take them, one argument.
        self._robots = (
            self.state,
            self.inputs,
            self.floats,
            self.ints,
            self.flags,
            self.previous_action,
        )
        #: What the true robots do with their commands (None: the ideal robot).
        self.plant = None if config.plant is None else Plant(config.plant, n)
        self._plant_arrays = None if self.plant is None else self.plant.kernel_arrays
        self.layout = config.layout
        # Each core works on its own sensors and localization: they hold per-robot buffers.
        self.sensors = copy.deepcopy(config.sensors)
        self.readings = np.zeros((n, sum(sensor.width for sensor in self.sensors)))
        self.localization = copy.deepcopy(config.localization)
        #: (N, 3) what each robot believes its pose is; the true pose without a localization.
        self.estimate = self.state
        self.previous_state = self.state
        self._belief = 0
        if self.localization is not None:
            self.estimate = np.zeros((n, 3))
            self.previous_state = np.zeros_like(self.state)
            self._belief = BELIEF
            self.localization.allocate(n, self.model, config.path_set)
        for sensor in self.sensors:
            sensor.allocate(n)
        # Each sensor's columns of ``readings``, in the layout's order; None for a sensor that
        # has them all (the usual single sensor), which then writes ``readings`` itself.
        starts = np.cumsum([0] + [sensor.width for sensor in self.sensors])
        self._sensor_columns: list[tuple[Sensor, slice | None]] = [
            (sensor, None if len(self.sensors) == 1 else slice(int(start), int(stop)))
            for sensor, (start, stop) in zip(self.sensors, itertools.pairwise(starts), strict=True)
        ]
        # Robots on the same path share a row of the path table (reference counted), so a
        # course set costs one row however many robots drive it. Paths and mazes are keyed
        # by the objects themselves (identity), which copies and pickles preserve.
        self._row_of_path: dict[Path, int] = {}
        self._row_users: list[int] = []  # robots on each row
        self._free_rows: list[int] = []
        self.tracks: list[Track | None] = [None] * n
        self.table: PathTable | None = None
        # The mazes robots drive in, one slot each, sensed all in one call.
        self.maze_pack = MazePack(n, config.num_threads)
        #: The maze of each slot of :attr:`maze_pack` (None: free); empty until a robot is
        #: in a maze.
        self.mazes: list[Maze | None] = self.maze_pack.mazes
        self.maze_slot = np.full(n, -1, dtype=np.int64)
        #: The maze every robot is in, when they all share one (checked at each reset).
        self.shared_maze: Maze | None = None
        self._no_ranges = np.empty((n, 0))
        self._settings = _kernel_settings(config)
        self._noisy_start = any(noise > 0 for noise in config.start_noise)
        self._nothing_between = False  # set at each reset (see reset_robots)
        self._senses = True
        self._walls_arguments: tuple[object, ...] | None = None
        position_noise, heading_noise = config.start_noise
        # The start noise's uniform draws, low + (high - low) * u, on x, y and the heading.
        self._noise_lows = np.array([-position_noise, -position_noise, -heading_noise])
        self._noise_ranges = np.array([position_noise, position_noise, heading_noise])
        self._noise_ranges -= self._noise_lows
        #: Threads the step and observation kernels run on (CoreConfig.num_threads).
        self.num_threads = config.num_threads
        # One thread calls the serial kernels directly: a single env's step costs microseconds.
        # The kernels that move robots, compiled for this model (its own module's physics).
        compiled = self.model.compiled
        self._move: Callable[..., None] = for_model(move_robots, compiled)
        self._score: Callable[..., None] = score_robots
        self._move_and_score: Callable[..., None] = for_model(move_and_score_robots, compiled)
        self._step_and_observe: Callable[..., None] = for_model(step_and_observe_robots, compiled)
        self._observe: Callable[..., None] = observe_robots
        if self.num_threads > 1:
            start_kernel_threads()
            threads = self.num_threads
            move_parallel = for_model(move_robots_parallel, compiled)
            self._move = functools.partial(on_threads, move_parallel, threads, False)
            self._score = functools.partial(on_threads, score_robots_parallel, threads)
            self._move_and_score = functools.partial(on_threads, move_parallel, threads, True)
            self._observe = functools.partial(on_threads, observe_robots_parallel, threads)
        self._observation_scales = self.layout.scales
        self._observation_layout = self.layout.kernel_layout
        self._preview_offsets = preview_offsets()
        self._preview_scratch = np.empty((len(self._preview_offsets), 2))
        self._integrator_code = INTEGRATORS.index(config.integrator)
        self._model_parameters = self.model.kernel_parameters
        # observe_robots' arguments for every robot, but the path, the robots and the output.
        self._observation_arrays = (
            self.robots, self._observation_scales, self._observation_layout,
            self._preview_offsets, self.estimate, self._belief, self.readings,
            self._preview_scratch,
        )  # fmt: skip

    # ------------------------------------------------------------------ reset

    def reset_robots(
        self,
        indices: Indices,
        rngs: Generators,
        track: Track | None = None,
        start_pose: Sequence[float] | Array | None = None,
    ) -> None:
        """Start new episodes for robots ``indices``, each drawing its track and start pose
        from its own generator ``rngs[index]`` (in the order a single env would); read their
        first observations with :meth:`observe`.

        :param track: the same track for all of them instead of a draw from the path set
        :param start_pose: the same (x, y, heading) for all of them instead of the track's
            start pose plus start noise
        """
        # Every robot draws its track, then its start pose: the generators are distinct, so
        # drawing all tracks first (in one call where the set can) changes no draw. PCG64
        # generators are read once, as streams, drawn from in compiled code and written
        # back once, before the localization and the sensors draw from them.
        restarting = [rngs[index] for index in indices]
        path_set = self.config.path_set
        draws = (track is None and path_set.draws) or (start_pose is None and self._noisy_start)
        streams = streams_of(restarting) if draws else None
        if track is not None:
            drawn = [track] * len(indices)
        elif streams is None:
            drawn = path_set.sample_many(restarting)
        else:
            drawn = path_set.sample_streams(restarting, streams)
        if start_pose is None:
            poses = self._start_poses([track.path for track in drawn], restarting, streams)
        else:
            poses = np.empty((len(indices), 3))
            poses[:] = start_pose
        if streams is not None:
            store_streams(restarting, streams)
        # Each robot leaves its row and maze and takes its new ones, in order; the columns
        # are read and written once, as lists (a numpy scalar costs more than a list item).
        path_rows = self.ints[indices, _PATH_ROW].tolist()
        maze_slots = self.maze_slot[indices].tolist()
        new_rows: list[int] = []
        new_paths: list[Path] = []
        for k, index in enumerate(indices.tolist()):
            left = self.tracks[index]
            if left is not None:
                self._release_row(path_rows[k], left.path)
            if maze_slots[k] >= 0:
                self.maze_pack.release(maze_slots[k])
            track_k = drawn[k]
            self.tracks[index] = track_k
            maze_slots[k] = -1 if track_k.maze is None else self.maze_pack.acquire(track_k.maze)
            path_rows[k] = self._assign_row(track_k.path, new_rows, new_paths)
        self.ints[indices, _PATH_ROW] = path_rows
        self.maze_slot[indices] = maze_slots
        if new_rows:
            self._table.set_paths(new_rows, new_paths)
        first_slot = self.maze_slot[0]
        shared = (
            first_slot >= 0
            and len(self.maze_pack) == 1
            and self.maze_pack.users(first_slot) == self.num_robots
        )
        self.shared_maze = self.mazes[first_slot] if shared else None
        path = self._table.kernel_arrays
        time_limits = self.config.time_limit(path[2][self.ints[indices, _PATH_ROW]])
        start_robots(indices, poses, time_limits, self._settings, path, self._robots)
        self._detect_collisions(indices)
        if self.plant is not None:
            self.plant.reset(indices, rngs)
        if self.localization is not None:
            self.localization.reset(self, indices, rngs, self.estimate)
            track_estimates(indices, True, self._settings, path, self._robots, self.estimate)
        for sensor, sensor_columns in self._sensor_columns:
            readings = self.readings if sensor_columns is None else self.readings[:, sensor_columns]
            sensor.reset(self, indices, rngs, readings)
        # What a step runs between the move and the score, until the next reset.
        measuring = [
            (sensor, cols) for sensor, cols in self._sensor_columns if sensor.measures(self)
        ]
        rays = measuring[0][0].maze_rays() if len(measuring) == 1 else None
        self._nothing_between = not (self.mazes or measuring or self.localization is not None)
        # Whether the step needs more than its one compiled call (a localization, a sensor
        # other than one that casts maze rays, which that call casts with the collisions).
        self._senses = self.localization is not None or (bool(measuring) and rays is None)
        self._walls_arguments = None
        if self.mazes and not self._senses:
            ranges = self._no_ranges
            if rays is not None:
                columns = measuring[0][1]
                ranges = self.readings if columns is None else self.readings[:, columns]
            self._walls_arguments = self._collision_arguments(rays, ranges)

    @property
    def dt(self) -> float:
        """The step (s)."""
        return self.config.dt

    @property
    def _table(self) -> PathTable:
        if self.table is None:
            raise RuntimeError("no robot has been reset yet")
        return self.table

    def _start_poses(
        self, paths: Sequence[Path], rngs: Generators, streams: NDArray[np.uint64] | None
    ) -> Array:
        """(k, 3) each path's start pose plus uniform start noise drawn from its generator
        (from its row of ``streams``, when not None): x and y in +-position noise, the
        heading in +-heading noise (``rng.uniform`` each, in order; the heading is wrapped
        later)."""
        poses = np.array([(*path.points[0].tolist(), path.start_heading) for path in paths])
        if self._noisy_start:
            # rng.uniform(low, high) is low + (high - low) * rng.random(): three doubles a
            # generator, drawn for all of them in one compiled call where they are PCG64s.
            draws = draw_doubles(rngs, 3) if streams is None else stream_doubles(streams, 3)
            poses += self._noise_lows + self._noise_ranges * draws
        return poses

    def _assign_row(self, path: Path, new_rows: list[int], new_paths: list[Path]) -> int:
        """The table row holding ``path``, for one more robot; if no robot drives that path
        yet, a free row, added with the path to ``new_rows`` and ``new_paths`` for the caller
        to write into the table (all at once)."""
        row = self._row_of_path.get(path)
        if row is None:
            if not self._free_rows:
                self._grow_table(path)
            row = self._free_rows.pop()
            new_rows.append(row)
            new_paths.append(path)
            self._row_of_path[path] = row
        self._row_users[row] += 1
        return row

    def _grow_table(self, path: Path) -> None:
        """Double the table's rows (at most one per robot); new rows start free."""
        old_rows = 0 if self.table is None else len(self.table)
        new_rows = min(max(2 * old_rows, 1), self.num_robots)
        kept = [] if self.table is None else list(self.table.paths)
        self.table = PathTable(kept + [path] * (new_rows - old_rows))
        self._row_users.extend([0] * (new_rows - old_rows))
        self._free_rows = list(range(new_rows - 1, old_rows - 1, -1))

    def _release_row(self, row: int, path: Path) -> None:
        """A robot leaves ``path``, in table row ``row``; the row is freed when no robot
        uses it."""
        self._row_users[row] -= 1
        if self._row_users[row] == 0:
            del self._row_of_path[path]
            self._free_rows.append(row)

    def robots_by_maze(self, indices: Indices | None = None) -> list[tuple[Maze, Indices | None]]:
        """The mazes robots ``indices`` (all by default) drive in, each with its robots among
        them; ``None`` stands for all N robots in order (the single env, a vector env on one
        maze), so results can be written in place."""
        if not self.maze_pack:
            return []
        if self.shared_maze is not None and (indices is None or len(indices) == self.num_robots):
            return [(self.shared_maze, None)]
        if indices is None:
            indices = self.robots
        slots = self.maze_slot[indices]
        groups = []
        for slot in np.unique(slots[slots >= 0]):
            maze = self.mazes[slot]
            assert maze is not None
            groups.append((maze, indices[slots == slot]))
        return groups

    def sense_mazes(
        self,
        indices: Indices | None,
        radius: float,
        angles: Array,
        max_range: float,
        collision_out: NDArray[np.bool_],
        ranges_out: Array,
    ) -> None:
        """:meth:`~mobile_envs.world.maze.Maze.sense` for robots ``indices`` (all by default), each
        in its own maze, in one call; robots in open space are left as they are.

        :param collision_out: (N,) set for those robots, or empty (0,) for ranges alone
        :param ranges_out: (N, R) set for those robots; (N, 0) for collisions alone
        """
        if self.maze_pack:
            self.maze_pack.sense(
                self.state, self.robots if indices is None else indices, self.maze_slot, radius,
                angles, max_range, collision_out, ranges_out,
            )  # fmt: skip

    def _detect_collisions(self, indices: Indices | None = None) -> None:
        """Whether each robot of ``indices`` (all by default) in a maze touches a wall (or left
        the maze)."""
        self.sense_mazes(
            indices, self.config.robot_radius, _NO_RAYS, 1.0, self.collision, self._no_ranges
        )

    def _collision_arguments(
        self, rays: tuple[Array, float] | None, ranges: Array
    ) -> tuple[object, ...]:
        """:meth:`_detect_collisions` of every robot, and the ranges along ``rays`` (angles,
        reach; None: no rays) into ``ranges``, as the arguments of
        :func:`~mobile_envs.world.maze.sense_packed` after the poses."""
        angles, max_range = (_NO_RAYS, 1.0) if rays is None else rays
        return (
            self.robots, self.maze_slot, float(self.config.robot_radius), angles,
            float(max_range), self.maze_pack.walls, self.collision, ranges,
        )  # fmt: skip

    # ------------------------------------------------------------------ step

    def actions_from_inputs(self, inputs: Array) -> Array:
        """Normalized actions that apply ``inputs``, clipped to [-1, 1]: the inverse of the
        step's linear map ``inputs = action_center + actions * action_half_range``."""
        return np.clip((inputs - self.action_center) / self.action_half_range, -1.0, 1.0)

    def step(self, actions: Array, rngs: Generators, active: Indices | None = None) -> None:
        """Advance every robot by one step under normalized actions of shape (N, m), clipped
        to [-1, 1] and finite (see :func:`mobile_envs.envs.interface.validate_actions`); the
        outcome is left in ``reward``, ``terminated``, ``truncated`` and the other flags.

        :param rngs: every robot's generator, from which stochastic sensors draw
        :param active: the robots whose step counts, by default all; the others are about to
            restart, so sensors do not read them (and draw no noise for them)

        Observations are left to :meth:`observe`, so a caller that restarts some robots
        first observes every robot once.
        """
        path = self.table.kernel_arrays  # type: ignore[union-attr]
        localization = self.localization
        if self._nothing_between:
            # Nothing runs between the move and the score: one call for both.
            self._move_and_score(
                self._model_parameters, self._integrator_code, self._settings, path, actions,
                self._action_map, self._robots, self._plant_arrays,
            )  # fmt: skip
            self._refill_plant(active, rngs)
            return
        if localization is not None:
            np.copyto(self.previous_state, self.state)
        self._move(
            self._model_parameters, self._integrator_code, self._settings, path, actions,
            self._action_map, self._robots, self._plant_arrays,
        )  # fmt: skip
        self._refill_plant(active, rngs)
        if self.mazes:
            self._detect_collisions()
        if active is None:
            active = self.robots
        if localization is not None:
            localization.update(self, active, rngs, self.estimate)
            track_estimates(active, False, self._settings, path, self._robots, self.estimate)
        for sensor, sensor_columns in self._sensor_columns:
            if sensor_columns is None:
                sensor.measure(self, active, rngs, self.readings)
            else:
                sensor.measure(self, active, rngs, self.readings[:, sensor_columns])
        self._score(self._settings, path, actions, self._robots)

    def step_and_observe(self, actions: Array, rngs: Generators) -> NDArray[np.float32]:
        """:meth:`step` every robot, then :meth:`observe` them all: one compiled call when
        only maze walls are sensed between the move and the score (a single env's usual
        step), the same bits either way."""
        if self._senses or self.num_threads > 1:
            self.step(actions, rngs)
            return self.observe()
        observations = np.empty((self.num_robots, self.layout.size), dtype=np.float32)
        self._step_and_observe(
            self._model_parameters, self._integrator_code, self._settings,
            self.table.kernel_arrays,  # type: ignore[union-attr]
            actions, self._action_map, self._robots, self._plant_arrays, self._walls_arguments,
            self._observation_arrays, observations,
        )  # fmt: skip
        self._refill_plant(None, rngs)
        return observations

    def _refill_plant(self, active: Indices | None, rngs: Generators) -> None:
        """Give each robot that goes on and used up its block of slip normals a new one."""
        if self.plant is not None:
            self.plant.refill_used(self.robots if active is None else active, rngs)

    # ------------------------------------------------------------------ observation

    def observe(self, indices: Indices | None = None) -> NDArray[np.float32]:
        """The observations of ``indices`` (all robots by default), shape (n, D); the layout
        is :attr:`CoreConfig.layout`."""
        # A few robots (those restarting) are observed faster than a parallel start costs.
        kernel = self._observe if indices is None else observe_robots
        indices = self.robots if indices is None else indices
        observations = np.empty((len(indices), self.layout.size), dtype=np.float32)
        kernel(
            indices, self._observation_scales, self._observation_layout,
            self.table.kernel_arrays,  # type: ignore[union-attr]
            self._preview_offsets, self._robots, self.estimate, self._belief, self.readings,
            self._preview_scratch, observations,
        )  # fmt: skip
        return observations


def _kernel_settings(config: CoreConfig) -> Array:
    """The configuration as the numbers :mod:`mobile_envs.sim.step` reads."""
    weights = config.reward
    values = {
        Setting.DT: config.dt,
        Setting.SEARCH_DISTANCE: DEFAULT_SEARCH_DISTANCE,  # the path table's
        Setting.GOAL_RADIUS: config.goal_radius,
        Setting.MAX_CROSS_TRACK: config.max_cross_track,
        Setting.STALL_STEPS: math.inf
        if config.stall_time is None
        else math.ceil(config.stall_time / config.dt),
        Setting.STALL_PROGRESS: STALL_PROGRESS,
        Setting.PROGRESS_WEIGHT: weights.progress,
        Setting.TIME_WEIGHT: weights.time,
        Setting.CROSS_TRACK_WEIGHT: weights.cross_track,
        Setting.CROSS_TRACK_SQUARED_WEIGHT: weights.cross_track_squared,
        Setting.HEADING_WEIGHT: weights.heading,
        Setting.ACTION_CHANGE_WEIGHT: weights.action_change,
        Setting.PEAK_CROSS_TRACK_WEIGHT: weights.peak_cross_track,
        Setting.GOAL_BONUS: weights.goal_bonus,
        Setting.FAILURE_PENALTY: weights.failure_penalty,
    }
    return np.array([values[setting] for setting in Setting], dtype=np.float64)

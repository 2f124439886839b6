"""The batched simulation behind both environments: N robots, each on its own track.

:class:`PathFollowingCore` owns every per-robot array (state, path row, progress, metrics)
and advances all robots with one call into the kinematic models and the path table. The
single environment is the N = 1 case and the vector environment the N > 1 case, so both
compute observations, rewards and terminations with the same compiled kernels
(:mod:`mobile_envs.robot_step`), bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mobile_envs.kinematics import (
    INTEGRATORS,
    Bicycle,
    ConstantVelocity,
    DifferentialDrive,
    KinematicModel,
    Tricycle,
    make_model,
    wrap_angle,
)
from mobile_envs.maze import Maze
from mobile_envs.paths import (
    DEFAULT_SEARCH_DISTANCE,
    FixedPathSet,
    Path,
    PathSet,
    PathTable,
    Track,
    path_set,
)
from mobile_envs.robot_step import (
    FLAG_FIELDS,
    FLOAT_FIELDS,
    INT_FIELDS,
    LATERAL_VELOCITY,
    NO_EXTRA_STATE,
    ROW,
    SCALE_FIELDS,
    SETTING_FIELDS,
    WHEEL_ANGLE,
    locate_robots,
    move_robots,
    observe_robots,
    score_robots,
)

Array = NDArray[np.float64]

#: The models the environments build by name, with finite limits: top speed about 1 m/s.
ENV_MODEL_DEFAULTS: dict[str, dict[str, float]] = {
    "constant_velocity": {"max_speed": 1.0, "max_angular_speed": 2.0},
    "diff_drive": {"wheel_radius": 0.05, "track_width": 1.0, "max_wheel_speed": 20.0},
    "bicycle": {"wheelbase": 1.0, "max_steering": math.pi / 4, "max_speed": 1.0},
    "tricycle": {
        "wheelbase": 1.0,
        "max_steering": math.radians(85.0),
        "max_speed": 1.0,
        "max_steering_rate": 2.0,
    },
}

#: Preview points: K points ahead on the path at a fixed arc-length spacing.
PREVIEW_POINTS = 10
PREVIEW_SPACING = 0.25
#: Range sensor: rays evenly spread around the robot, readings normalized by the max range.
RANGE_RAYS = 16
RANGE_MAX = 3.0
#: Saturating, high-gain copies of the errors make centimetres visible to the policy: the
#: linear ones, scaled by the off-track distance, read 0.01 for 1 cm.
FINE_CROSS_TRACK = 0.05
FINE_HEADING = 0.1
#: Progress (m) beyond the farthest point reached that counts as advancing; see stall_time.
STALL_PROGRESS = 0.01
#: Nominal speed that sets the time limit, and how many nominal traversals it allows.
NOMINAL_SPEED = 0.6
TIME_LIMIT_FACTOR = 3.0


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward terms; see :class:`mobile_envs.env.PathFollowingEnv`."""

    progress: float = 1.0
    time: float = 0.01
    cross_track: float = 8.0
    cross_track_squared: float = 20.0
    heading: float = 0.2
    action_change: float = 0.02
    goal_bonus: float = 10.0
    failure_penalty: float = 10.0


def build_model(model: str | KinematicModel, parameters: dict | None = None) -> KinematicModel:
    """A model instance from a name (with the environment defaults) or an instance."""
    if isinstance(model, KinematicModel):
        if parameters:
            raise ValueError("model_params can only be given with a model name, not an instance")
        built = model
    else:
        built = make_model(model, **{**ENV_MODEL_DEFAULTS.get(model, {}), **(parameters or {})})
    if not np.isfinite(built.input_high).all():
        raise ValueError(
            f"the environment maps actions in [-1, 1] onto the model's input limits, which "
            f"must be finite; {built!r} has input limits {built.input_high}"
        )
    return built


def build_path_set(paths: str | Path | Track | Sequence[Path | Track] | PathSet) -> PathSet:
    """A path set from a registered name, a path, a track, or a list of them."""
    if isinstance(paths, PathSet):
        return paths
    if isinstance(paths, str):
        return path_set(paths)
    if isinstance(paths, (Path, Track)):
        paths = [paths]
    tracks = []
    for item in paths:
        if isinstance(item, Path):
            tracks.append(Track(item))
        elif isinstance(item, Track):
            tracks.append(item)
        else:
            raise ValueError(f"paths must hold Path or Track objects, got {type(item).__name__}")
    if not tracks:
        raise ValueError("paths is an empty list")
    return FixedPathSet("custom", tracks)


@dataclass
class CoreConfig:
    """Validated settings shared by the single and the vector environment."""

    model: KinematicModel
    path_set: PathSet
    dt: float = 0.1
    integrator: str = "exact"
    goal_radius: float = 0.1
    max_cross_track: float = 1.0
    max_episode_steps: int | None = None
    start_noise: tuple[float, float] = (0.0, 0.0)
    robot_radius: float = 0.25
    stall_time: float | None = 10.0
    reward: RewardWeights = field(default_factory=RewardWeights)

    def __post_init__(self) -> None:
        for name in ("dt", "goal_radius", "max_cross_track", "robot_radius"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if self.stall_time is not None and not (
            isinstance(self.stall_time, (int, float))
            and math.isfinite(self.stall_time)
            and self.stall_time > 0
        ):
            raise ValueError(
                f"stall_time must be a positive number or None, got {self.stall_time!r}"
            )
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {self.integrator!r}")
        steps = self.max_episode_steps
        if steps is not None and (int(steps) != steps or steps < 1):
            raise ValueError(f"max_episode_steps must be a positive integer, got {steps!r}")
        noise = self.start_noise
        if isinstance(noise, (int, float)):
            noise = (float(noise), float(noise))
        if len(noise) != 2 or not all(math.isfinite(n) and n >= 0 for n in noise):
            raise ValueError(
                f"start_noise must be a non-negative (position m, heading rad) pair, got {noise!r}"
            )
        self.start_noise = (float(noise[0]), float(noise[1]))
        if not isinstance(self.reward, RewardWeights):
            raise ValueError(f"reward must be a RewardWeights, got {self.reward!r}")

    @property
    def preview_offsets(self) -> Array:
        return PREVIEW_SPACING * np.arange(1, PREVIEW_POINTS + 1, dtype=np.float64)

    @property
    def preview_scale(self) -> float:
        """Preview coordinates are divided by this: the farthest a preview point can be."""
        return PREVIEW_SPACING * PREVIEW_POINTS + self.max_cross_track

    @property
    def extra_state_names(self) -> tuple[str, ...]:
        """Model state beyond the twist that the observation carries."""
        if isinstance(self.model, Tricycle):
            return ("wheel_angle",)
        if isinstance(self.model, ConstantVelocity):
            return ("lateral_velocity",)
        return ()

    @property
    def observation_names(self) -> tuple[str, ...]:
        preview = [f"preview_{axis}_{k}" for k in range(PREVIEW_POINTS) for axis in "xy"]
        actions = [f"previous_action_{k}" for k in range(self.model.input_dim)]
        ranges = [f"range_{k}" for k in range(RANGE_RAYS)]
        return (
            *preview,
            "cross_track_error",
            "heading_error",
            "cross_track_error_fine",
            "heading_error_fine",
            "speed",
            "yaw_rate",
            *self.extra_state_names,
            "remaining_fraction",
            *actions,
            *ranges,
        )

    @property
    def max_yaw_rate(self) -> float:
        """The largest |omega| the model reaches within its limits (normalizes yaw rate)."""
        model = self.model
        if isinstance(model, DifferentialDrive):
            return 2.0 * model.wheel_radius * model.max_wheel_speed / model.track_width
        if isinstance(model, Bicycle):
            return model.max_speed * math.tan(model.max_steering) / model.wheelbase
        if isinstance(model, Tricycle):
            return model.max_speed * math.sin(model.max_steering) / model.wheelbase
        return model.max_angular_speed

    @property
    def max_speed(self) -> float:
        model = self.model
        if isinstance(model, DifferentialDrive):
            return model.wheel_radius * model.max_wheel_speed
        return model.max_speed

    def time_limit(self, path_length: Array) -> NDArray[np.int64]:
        """Steps allowed on a path: TIME_LIMIT_FACTOR traversals at NOMINAL_SPEED."""
        if self.max_episode_steps is not None:
            return np.full(np.shape(path_length), self.max_episode_steps, dtype=np.int64)
        steps = TIME_LIMIT_FACTOR * np.asarray(path_length) / (NOMINAL_SPEED * self.dt)
        return np.ceil(steps).astype(np.int64)


class PathFollowingCore:
    """N robots following paths, advanced together.

    Every per-robot scalar lives in a column of one of three packed arrays, ``floats``,
    ``ints`` and ``flags`` (see :mod:`mobile_envs.robot_step`), and each column is also an
    attribute named after it: ``core.arc_length`` is ``core.floats[:, ARC_LENGTH]``, a view.
    After :meth:`step`, ``reward``, ``terminated``, ``truncated``, ``success``, ``off_track``,
    ``stalled`` and ``collision`` hold the step's outcome; they are views that the next step
    overwrites, so callers that hand them out copy them.

    :param config: the validated settings
    :param num_robots: N
    """

    def __init__(self, config: CoreConfig, num_robots: int):
        self.config = config
        self.model = config.model
        self.num_robots = num_robots
        n, m = num_robots, self.model.input_dim
        self.action_center = 0.5 * (self.model.input_high + self.model.input_low)
        self.action_half_range = 0.5 * (self.model.input_high - self.model.input_low)
        self.robots = np.arange(n)
        self.floats = np.zeros((n, len(FLOAT_FIELDS)))
        self.ints = np.zeros((n, len(INT_FIELDS)), dtype=np.int64)
        self.flags = np.zeros((n, len(FLAG_FIELDS)), dtype=bool)
        for packed, names in ((self.floats, FLOAT_FIELDS), (self.ints, INT_FIELDS)):
            for column, name in enumerate(names):
                setattr(self, name, packed[:, column])
        for column, name in enumerate(FLAG_FIELDS):
            setattr(self, name, self.flags[:, column])
        self.state = np.zeros((n, self.model.state_dim))
        self.previous_action = np.zeros((n, m))
        self.inputs = np.zeros((n, m))
        self.ranges = np.full((n, RANGE_RAYS), RANGE_MAX)
        # Robots on the same path share a row of the path table (reference counted), so a
        # course set costs one row however many robots drive it.
        self._row_of_path: dict[int, int] = {}  # id(path) -> its row, while a robot uses it
        self._row_users = np.zeros(0, dtype=np.int64)
        self._free_rows: list[int] = []
        self.tracks: list[Track | None] = [None] * n
        self.table: PathTable | None = None
        self.mazes: list[Maze] = []
        self._maze_slots: dict[int, int] = {}  # id(maze) -> index in self.mazes (keeps it alive)
        self.maze_slot = np.full(n, -1, dtype=np.int64)
        self._ray_angles = np.linspace(-math.pi, math.pi, RANGE_RAYS, endpoint=False)
        self._settings = _kernel_settings(config)
        self._scales = _observation_scales(config)
        self._extra_state = NO_EXTRA_STATE
        if isinstance(self.model, Tricycle):
            self._extra_state = WHEEL_ANGLE
        elif isinstance(self.model, ConstantVelocity):
            self._extra_state = LATERAL_VELOCITY
        self._preview_offsets = config.preview_offsets
        self._preview_scratch = np.empty((PREVIEW_POINTS, 2))
        self._observation_size = len(config.observation_names)
        self._integrator_code = INTEGRATORS.index(config.integrator)
        self._model_code = self.model.kernel_code
        self._model_parameters = self.model.kernel_parameters

    # ------------------------------------------------------------------ reset

    def reset_robots(
        self,
        indices: NDArray[np.int64],
        rngs: Sequence[np.random.Generator],
        track: Track | None = None,
        start_pose: Sequence[float] | None = None,
    ) -> None:
        """Start new episodes for robots ``indices``, each drawing its track and start pose
        from its own generator in ``rngs`` (in the order a single env would); read their
        first observations with :meth:`observe`.

        :param track: the same track for all of them instead of a draw from the path set
        :param start_pose: the same (x, y, heading) for all of them instead of the track's
            start pose plus start noise
        """
        poses = np.empty((len(indices), 3))
        for k, (index, rng) in enumerate(zip(indices, rngs, strict=True)):
            drawn = self.config.path_set.sample(rng) if track is None else track
            poses[k] = self._start_pose(drawn.path, rng) if start_pose is None else start_pose
            if self.tracks[index] is not None:
                self._release_row(index)
            self.tracks[index] = drawn
            self._assign_maze(index, drawn.maze)
            self._assign_row(index, drawn.path)
        self.state[indices] = 0.0
        self.state[indices, :2] = poses[:, :2]
        self.state[indices, 2] = wrap_angle(poses[:, 2])
        self.floats[indices] = 0.0
        self.ints[indices, ROW + 1 :] = 0
        self.flags[indices] = False
        self.inputs[indices] = 0.0
        self.previous_action[indices] = 0.0
        self.ranges[indices] = RANGE_MAX
        self.path_length[indices] = self.table.lengths[self.path_row[indices]]
        self.time_limit[indices] = self.config.time_limit(self.path_length[indices])
        columns, last_segments, lengths, _ = self.table.kernel_arrays
        locate_robots(
            indices, self._settings, columns, last_segments, lengths, self.state, self.floats,
            self.ints,
        )  # fmt: skip
        self._sense_walls(indices)

    def _start_pose(self, path: Path, rng: np.random.Generator) -> Array:
        """The path's start pose plus uniform start noise drawn from ``rng``."""
        pose = np.array(path.start_pose, dtype=np.float64)
        position_noise, heading_noise = self.config.start_noise
        if position_noise > 0 or heading_noise > 0:
            pose[:2] += rng.uniform(-position_noise, position_noise, 2)
            pose[2] += rng.uniform(-heading_noise, heading_noise)
        return pose

    def _assign_row(self, index: int, path: Path) -> None:
        """Point robot ``index`` at the table row holding ``path``, filling a free row if no
        robot drives that path yet."""
        row = self._row_of_path.get(id(path))
        if row is None:
            if not self._free_rows:
                self._grow_table(path)
            row = self._free_rows.pop()
            self.table.set_path(row, path)
            self._row_of_path[id(path)] = row
        self._row_users[row] += 1
        self.path_row[index] = row

    def _grow_table(self, path: Path) -> None:
        """Double the table's rows (at most one per robot); new rows start free."""
        old_rows = 0 if self.table is None else len(self.table)
        new_rows = min(max(2 * old_rows, 1), self.num_robots)
        kept = [] if self.table is None else list(self.table.paths)
        self.table = PathTable(kept + [path] * (new_rows - old_rows))
        self._row_users = np.concatenate([self._row_users, np.zeros(new_rows - old_rows, int)])
        self._free_rows = list(range(new_rows - 1, old_rows - 1, -1))

    def _release_row(self, index: int) -> None:
        """Robot ``index`` leaves its path; the row is freed when no robot uses it."""
        row = self.path_row[index]
        self._row_users[row] -= 1
        if self._row_users[row] == 0:
            del self._row_of_path[id(self.tracks[index].path)]
            self._free_rows.append(row)

    def _assign_maze(self, index: int, maze: Maze | None) -> None:
        """Record which maze robot ``index`` drives in; robots in one maze are sensed together."""
        if maze is not None and id(maze) not in self._maze_slots:
            if len(self.mazes) >= 2 * self.num_robots:
                self._forget_unused_mazes()
            self._maze_slots[id(maze)] = len(self.mazes)
            self.mazes.append(maze)
        self.maze_slot[index] = -1 if maze is None else self._maze_slots[id(maze)]

    def _forget_unused_mazes(self) -> None:
        """Renumber the mazes robots drive in now, so random mazes do not pile up."""
        self.mazes, self._maze_slots = [], {}
        for robot, track in enumerate(self.tracks):
            maze = None if track is None else track.maze
            if maze is not None and id(maze) not in self._maze_slots:
                self._maze_slots[id(maze)] = len(self.mazes)
                self.mazes.append(maze)
            self.maze_slot[robot] = -1 if maze is None else self._maze_slots[id(maze)]

    # ------------------------------------------------------------------ step

    def actions_from_inputs(self, inputs: Array) -> Array:
        """Normalized actions that apply ``inputs``, clipped to [-1, 1]: the inverse of the
        step's linear map ``inputs = action_center + actions * action_half_range``."""
        return np.clip((inputs - self.action_center) / self.action_half_range, -1.0, 1.0)

    def step(self, actions: Array) -> None:
        """Advance every robot by one step under normalized actions of shape (N, m), clipped
        to [-1, 1] and finite (see :func:`validate_actions`); the outcome is left in
        ``reward``, ``terminated``, ``truncated`` and the other flags.

        Observations are left to :meth:`observe`, so a caller that restarts some robots
        first observes every robot once.
        """
        columns, last_segments, lengths, goals = self.table.kernel_arrays
        move_robots(
            self._model_code, self._model_parameters, self._integrator_code, self._settings,
            columns, last_segments, lengths, actions, self.action_center,
            self.action_half_range, self.state, self.inputs, self.floats, self.ints,
        )  # fmt: skip
        if self.mazes:
            self._sense_walls(self.robots)
        score_robots(
            self._settings, goals, actions, self.previous_action, self.state, self.floats,
            self.ints, self.flags,
        )  # fmt: skip

    def _sense_walls(self, indices: NDArray[np.int64]) -> None:
        """Collisions and range readings of ``indices``; readings stay at the max range away
        from walls."""
        if not self.mazes:
            return
        radius, slots = self.config.robot_radius, self.maze_slot[indices]
        first = slots[0]
        if first >= 0 and len(indices) == self.num_robots and (slots == first).all():
            # Every robot in one maze (the single env, a vector env on one maze): in place.
            self.mazes[first].sense(
                self.state, radius, self._ray_angles, RANGE_MAX, self.collision, self.ranges
            )
            return
        for slot in np.unique(slots[slots >= 0]):
            robots = indices[slots == slot]
            collision = np.empty(len(robots), dtype=bool)
            ranges = np.empty((len(robots), RANGE_RAYS))
            self.mazes[slot].sense(
                self.state[robots], radius, self._ray_angles, RANGE_MAX, collision, ranges
            )
            self.collision[robots] = collision
            self.ranges[robots] = ranges

    # ------------------------------------------------------------------ observation

    def observe(self, indices: NDArray[np.int64] | None = None) -> NDArray[np.float32]:
        """The observations of ``indices`` (all robots by default), shape (n, D); the layout
        is :attr:`CoreConfig.observation_names`."""
        indices = self.robots if indices is None else indices
        observations = np.empty((len(indices), self._observation_size), dtype=np.float32)
        columns, last_segments, lengths, _ = self.table.kernel_arrays
        observe_robots(
            indices, self._scales, self._extra_state, columns, last_segments, lengths,
            self._preview_offsets, self.state, self.inputs, self.previous_action, self.floats,
            self.ints, self.ranges, self._preview_scratch, observations,
        )  # fmt: skip
        return observations

    # ------------------------------------------------------------------ metrics

    def episode_metrics(self, index: int, completed: bool) -> dict[str, float | bool]:
        """Metrics of robot ``index``'s episode so far."""
        steps = max(int(self.steps[index]), 1)
        return {
            "mean_abs_cte": float(self.sum_abs_cte[index] / steps),
            "max_abs_cte": float(self.max_abs_cte[index]),
            "rms_cte": float(math.sqrt(self.sum_sq_cte[index] / steps)),
            "episode_time": float(self.steps[index] * self.config.dt),
            "distance_travelled": float(self.distance[index]),
            "completed": bool(completed),
        }


def _kernel_settings(config: CoreConfig) -> Array:
    """The configuration as the numbers :mod:`mobile_envs.robot_step` reads."""
    weights = config.reward
    values = {
        "dt": config.dt,
        "search_distance": DEFAULT_SEARCH_DISTANCE,  # the path table's
        "goal_radius": config.goal_radius,
        "max_cross_track": config.max_cross_track,
        "stall_steps": math.inf
        if config.stall_time is None
        else math.ceil(config.stall_time / config.dt),
        "stall_progress": STALL_PROGRESS,
        "progress_weight": weights.progress,
        "time_weight": weights.time,
        "cross_track_weight": weights.cross_track,
        "cross_track_squared_weight": weights.cross_track_squared,
        "heading_weight": weights.heading,
        "action_change_weight": weights.action_change,
        "goal_bonus": weights.goal_bonus,
        "failure_penalty": weights.failure_penalty,
    }
    return np.array([values[name] for name in SETTING_FIELDS], dtype=np.float64)


def _observation_scales(config: CoreConfig) -> Array:
    """The factors that bring each observation element to about [-1, 1]."""
    model = config.model
    extra_state = 1.0
    if isinstance(model, Tricycle):
        extra_state = 1.0 / model.max_steering
    elif isinstance(model, ConstantVelocity):
        extra_state = 1.0 / config.max_speed
    values = {
        "preview": 1.0 / config.preview_scale,
        "cross_track": 1.0 / config.max_cross_track,
        "heading": 1.0 / math.pi,
        "fine_cross_track": 1.0 / FINE_CROSS_TRACK,
        "fine_heading": 1.0 / FINE_HEADING,
        "speed": 1.0 / config.max_speed,
        "yaw_rate": 1.0 / config.max_yaw_rate,
        "extra_state": extra_state,
        "range": 1.0 / RANGE_MAX,
    }
    return np.array([values[name] for name in SCALE_FIELDS], dtype=np.float64)

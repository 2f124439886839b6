"""MPPI: sampling-based model-predictive path tracking after Nav2's ``nav2_mppi_controller``.

Model Predictive Path Integral control (Williams et al. 2017, "Information theoretic MPC for
model-based reinforcement learning"; Nav2's MPPI controller, Macenski et al.): each control
step, K action sequences ``u + eps_k`` over T steps, ``eps_k`` Gaussian, are rolled out from
the robot's state through its own kinematic model and scored; the mean sequence moves to the
softmax-weighted average ``u += sum_k w_k eps_k``, ``w_k = exp(-(S_k - min S) / lambda) /
sum``; its first action is applied and the sequence, shifted one step, warm-starts the next.

Written for this project's robots (not a port): the samples are the env's normalized actions
of any model (wheel speeds, speed and steering angle, the tricycle's steering rate, the
holonomic robot's lateral speed, the mecanum robot's four wheels), clipped to their limits,
and the rollouts step the model's own compiled ``advance`` with the env's ``dt`` and
integrator, so the prediction is the env's motion, bit for bit. All robots of a batch are
planned in one compiled call (:mod:`agents.controllers.mppi_kernels`), each from its own
random stream, so a batch gives every robot the actions it gets alone.

Three ways to use it:

- as a classical agent, through the harness: ``evaluate(MPPI(), env_id, episodes)``, or
  ``MPPI().bind(env)`` for SB3's ``predict`` on a single or a vector env (one compiled call
  for all robots of a vector env per step);
- without an env, one robot: ``mppi.reset(path, maze)``, then ``mppi.inputs(state, model,
  dt)`` once per control step;
- batched, for a harness of its own: ``planner = MPPI().planner(model, dt, num_robots)``,
  ``planner.restart(robots, tracks)`` when episodes start, ``planner.act(states)`` each step
  (the normalized actions of every robot; :meth:`MPPIPlanner.inputs_of` gives native inputs).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agents.controllers import mppi_kernels as kernels
from agents.controllers.base import ClassicalAgent
from mobile_envs._kernels.pcg64 import STREAM_WORDS, streams_of
from mobile_envs._kernels.specialize import for_model
from mobile_envs.robots import INTEGRATORS, KinematicModel
from mobile_envs.tracks.sets import Track
from mobile_envs.validation import as_count, as_positive, as_real
from mobile_envs.world.maze import Maze
from mobile_envs.world.maze_pack import MazePack
from mobile_envs.world.paths import DEFAULT_SEARCH_DISTANCE, Path, PathTable

#: The largest cost weight, temperature or collision cost: sums of K x T costs stay finite.
MAX_WEIGHT = 1e6
#: The most samples and steps: one robot's K x T x m actions must fit in memory.
MAX_SAMPLES, MAX_HORIZON = 100_000, 10_000
#: The env's settings MPPI plans with when it is not bound to an env (CoreConfig's defaults).
DEFAULT_ROBOT_RADIUS = 0.25
DEFAULT_MAX_CROSS_TRACK = 1.0
DEFAULT_GOAL_RADIUS = 0.1

Array = NDArray[np.float64]


def _non_negative(name: str, value: Any, maximum: float = MAX_WEIGHT) -> float:
    """``value`` as a float in [0, maximum]; a ValueError naming ``name`` otherwise."""
    number = as_real(name, value)
    if not 0.0 <= number <= maximum:
        raise ValueError(f"{name} must lie in [0, {maximum:g}], got {value!r}")
    return number


def _count(name: str, value: Any, maximum: int) -> int:
    """``value`` as an int in [0, maximum] (0 allowed, unlike ``as_count``)."""
    zero = isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value == 0
    return 0 if zero else as_count(name, value, maximum)


def _positive(name: str, value: Any, maximum: float = MAX_WEIGHT) -> float:
    return as_positive(name, value, maximum)


def episode_stream(seed: int, path: Path) -> NDArray[np.uint64]:
    """The PCG64 stream (:mod:`mobile_envs._kernels.pcg64`) an episode on ``path`` samples
    from: ``np.random.default_rng([seed, digest of the path's points])``'s state. The same
    seed and path give the same noise, whether the robot is planned alone or in a batch,
    first or hundredth."""
    points = np.ascontiguousarray(path.points, dtype=np.float64)
    digest = int.from_bytes(hashlib.blake2b(points.tobytes(), digest_size=8).digest(), "little")
    streams = streams_of([np.random.default_rng([seed, digest])])
    assert streams is not None  # default_rng builds a PCG64
    return streams[0]


def primitive_actions(width: int) -> Array:
    """The constant actions sampled every step besides the random ones: the corners of the
    action box, {-1, 1}^m, then +-1 along each axis: (2^m + 2m, m)."""
    corners = np.array(np.meshgrid(*[[-1.0, 1.0]] * width, indexing="ij")).reshape(width, -1).T
    return np.concatenate([corners, np.eye(width), 0.0 - np.eye(width)])


class MPPI(ClassicalAgent):
    """Model Predictive Path Integral path tracking (Nav2's MPPI controller, our code).

    **Each control step**, for a robot at (believed) state x0 on its path:

    1. K - 1 samples ``a_k = clip(u + eps_k, -1, 1)``, ``eps_k ~ N(0, noise_std^2)`` per
       action element and step, in the env's normalized action space, plus the mean ``u``
       itself (sample 0);
    2. each rolled out T steps from x0 with the model's own kinematics (the env's ``dt`` and
       integrator) and scored by the sum of Nav2-style critics, each averaged over the
       horizon (position errors in m, angles in rad, speeds over the top speed):

       - ``path_weight`` x |distance to the path| (Nav2's PathAlign/PathFollow: stay on it),
       - ``heading_weight`` x |heading - path tangent| (PathAngle),
       - ``- progress_weight`` x arc length gained over the horizon / (top speed x T dt), once
         (PathFollow's pull along the path),
       - ``goal_weight`` x distance to the goal, while the remaining path is shorter than
         ``goal_distance`` (GoalCritic),
       - ``forward_weight`` x backward speed / top speed (PreferForward),
       - ``smoothness_weight`` x |a_t - a_{t-1}|^2 (actions, from the last applied one),
       - in a maze, ``wall_weight`` x (1 - clearance / ``wall_margin``) where the robot's disc
         (the env's ``robot_radius``) comes within ``wall_margin`` of a wall (CostCritic's
         inflation), and ``collision_cost`` once for a rollout that touches a wall or leaves
         the env's ``max_cross_track`` (its failure conditions),
       - Nav2's control cost ``gamma / noise_std^2 sum_t u_t . (a_t - u_t)``;
    3. the softmax update with ``temperature``; optionally Nav2's Savitzky-Golay smoothing of
       the new sequence (quadratic, 9 points, reaching into the applied actions);
    4. the first action is applied, the sequence shifts one step (its last action repeated).

    The first step of an episode starts from all-zero actions (the robot at rest: for the
    wheel models zero wheel speeds). Randomness: each episode samples from its own
    generator, seeded by ``seed`` and the episode's path (:func:`episode_stream`): the same
    seed gives the same trajectory, planned alone or among any number of robots.

    The defaults (K = 256 samples over T = 20 steps, 2 s at the envs' 0.1 s) were tuned on
    random paths and random mazes for every model at once, never on the course's paths or
    the canonical maze; ``docs/agents.md`` says how.

    :param samples: K, sampled sequences per step (Nav2's ``batch_size``), at least 2
    :param horizon: T, steps per sequence (Nav2's ``time_steps``)
    :param temperature: lambda of the softmax (Nav2's ``temperature``), in cost units
    :param noise_std: standard deviation of the perturbations, in normalized action units
        (1 is half an input's range: Nav2's ``vx_std``/``wz_std`` as fractions)
    :param gamma: weight of Nav2's control cost (its ``gamma``)
    :param path_weight: weight of the distance to the path (1/m)
    :param heading_weight: weight of the heading error (1/rad)
    :param progress_weight: weight of the progress along the path
    :param goal_weight: weight of the distance to the goal near it (1/m)
    :param goal_distance: remaining path length (m) below which the goal critic scores
    :param forward_weight: weight of backward motion
    :param smoothness_weight: weight of the change between consecutive actions
    :param wall_weight: weight of the approach to a maze wall
    :param wall_margin: clearance (m) from the robot's disc to a wall below which
        ``wall_weight`` scores
    :param collision_cost: cost of a rollout that hits a wall or leaves the track
    :param smoothing: whether to apply the Savitzky-Golay smoothing
    :param seed: seed of the episodes' generators, a non-negative integer
    :raises ValueError: naming the parameter, unless the counts are integers (K >= 2, T >=
        1), the weights, costs and ``goal_distance`` finite numbers in [0, 1e6],
        ``temperature`` and ``wall_margin`` in (0, 1e6], ``noise_std`` in [1e-6, 10],
        ``smoothing`` a bool and ``seed`` an integer in [0, 2**63)
    """

    def __init__(
        self,
        samples: int = 256,
        horizon: int = 20,
        temperature: float = 0.3,
        noise_std: float = 0.3,
        noise_correlation: float = 0.0,
        primitives: bool = True,
        regenerate_noise: bool = True,
        manoeuvres: int = 32,
        gamma: float = 0.0,
        path_weight: float = 10.0,
        progress_weight: float = 5.0,
        heading_weight: float = 1.0,
        anticipation: float = 1.0,
        goal_weight: float = 5.0,
        goal_distance: float = 1.5,
        forward_weight: float = 2.0,
        smoothness_weight: float = 1.0,
        wall_weight: float = 5.0,
        wall_margin: float = 0.2,
        collision_cost: float = 1000.0,
        smoothing: bool = True,
        patience: float = 1.0,
        seed: int = 0,
    ):
        self.samples = as_count("samples", samples, MAX_SAMPLES)
        if self.samples < 2:
            raise ValueError(f"samples must be at least 2 (the mean and one sample), got {samples!r}")
        self.horizon = as_count("horizon", horizon, MAX_HORIZON)
        self.temperature = _positive("temperature", temperature)
        self.noise_std = as_real("noise_std", noise_std)
        if not 1e-6 <= self.noise_std <= 10.0:
            raise ValueError(f"noise_std must lie in [1e-6, 10], got {noise_std!r}")
        self.noise_correlation = _non_negative("noise_correlation", noise_correlation, 0.99)
        if not isinstance(primitives, (bool, np.bool_)):
            raise ValueError(f"primitives must be True or False, got {primitives!r}")
        self.primitives = bool(primitives)
        if not isinstance(regenerate_noise, (bool, np.bool_)):
            raise ValueError(f"regenerate_noise must be True or False, got {regenerate_noise!r}")
        self.regenerate_noise = bool(regenerate_noise)
        self.manoeuvres = _count("manoeuvres", manoeuvres, MAX_SAMPLES)
        self.gamma = _non_negative("gamma", gamma)
        self.path_weight = _non_negative("path_weight", path_weight)
        self.progress_weight = _non_negative("progress_weight", progress_weight)
        self.heading_weight = _non_negative("heading_weight", heading_weight)
        self.anticipation = _non_negative("anticipation", anticipation)
        self.goal_weight = _non_negative("goal_weight", goal_weight)
        self.goal_distance = _non_negative("goal_distance", goal_distance)
        self.forward_weight = _non_negative("forward_weight", forward_weight)
        self.smoothness_weight = _non_negative("smoothness_weight", smoothness_weight)
        self.wall_weight = _non_negative("wall_weight", wall_weight)
        self.wall_margin = _positive("wall_margin", wall_margin)
        self.collision_cost = _non_negative("collision_cost", collision_cost)
        if not isinstance(smoothing, (bool, np.bool_)):
            raise ValueError(f"smoothing must be True or False, got {smoothing!r}")
        self.smoothing = bool(smoothing)
        self.patience = _non_negative("patience", patience)
        if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
            raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
        if not 0 <= seed < 2**63:
            raise ValueError(f"seed must lie in [0, 2**63), got {seed!r}")
        self.seed = int(seed)
        self._track: Track | None = None
        self._planner: MPPIPlanner | None = None
        self._restart = False

    def planner(
        self,
        model: KinematicModel,
        dt: float,
        num_robots: int = 1,
        *,
        integrator: str = "exact",
        robot_radius: float = DEFAULT_ROBOT_RADIUS,
        max_cross_track: float = DEFAULT_MAX_CROSS_TRACK,
        goal_radius: float = DEFAULT_GOAL_RADIUS,
    ) -> MPPIPlanner:
        """A batched planner with these parameters for ``num_robots`` robots of ``model``:
        see :class:`MPPIPlanner`."""
        return MPPIPlanner(
            self,
            model,
            dt,
            num_robots,
            integrator=integrator,
            robot_radius=robot_radius,
            max_cross_track=max_cross_track,
            goal_radius=goal_radius,
        )

    def reset(self, path: Path, maze: Maze | None = None) -> None:
        """Start following ``path`` (between the walls of ``maze``, if given)."""
        self._track = Track(path, maze)
        self._restart = True

    def inputs(self, state: NDArray[np.float64], model: KinematicModel, dt: float) -> ArrayLike:
        if self._track is None:
            raise RuntimeError("call reset(path) before asking for a command")
        planner = self._planner
        if planner is None or planner.model is not model or planner.dt != dt:
            planner = self._planner = self.planner(model, dt)
            self._restart = True
        if self._restart:
            planner.restart([0], [self._track])
            self._restart = False
        actions = planner.act(np.asarray(state, dtype=np.float64).reshape(1, -1))
        return planner.inputs_of(actions)[0]

    def bind(self, env: Any) -> BoundMPPI:
        """This agent bound to ``env`` (single or vector): SB3's ``predict``, every robot
        planned in one compiled call, with the env's ``dt``, integrator, robot radius and
        ``max_cross_track``, reading its believed states and its tracks (paths and mazes)."""
        return BoundMPPI(self, env)

    def __deepcopy__(self, memo: dict[int, Any]) -> MPPI:
        # A copy is a fresh agent with the same parameters: planners hold compiled state.
        return type(self)(**self.parameters())


class MPPIPlanner:
    """MPPI's state for N robots of one model, planned in one compiled call per step.

    :param mppi: the parameters
    :param model: the robots' kinematic model, with finite input limits
    :param dt: the control period (s), also the rollouts' step
    :param num_robots: N
    :param integrator: the env's integrator (``"exact"``, ``"euler"``, ...)
    :param robot_radius: the robots' disc radius (m) against maze walls
    :param max_cross_track: the distance (m) from the path that ends an episode
    :raises ValueError: naming the argument for a model without finite limits, a bad
        ``dt``, count, integrator, radius or ``max_cross_track``
    """

    def __init__(
        self,
        mppi: MPPI,
        model: KinematicModel,
        dt: float,
        num_robots: int,
        *,
        integrator: str = "exact",
        robot_radius: float = DEFAULT_ROBOT_RADIUS,
        max_cross_track: float = DEFAULT_MAX_CROSS_TRACK,
        goal_radius: float = DEFAULT_GOAL_RADIUS,
    ) -> None:
        if not isinstance(model, KinematicModel):
            raise ValueError(f"model must be a KinematicModel, got {model!r}")
        if not (np.isfinite(model.input_low).all() and np.isfinite(model.input_high).all()):
            raise ValueError(f"MPPI samples within the input limits: {model!r} has none")
        if integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
        self.mppi = mppi
        self.model = model
        self.dt = as_positive("dt", dt)
        self.num_robots = as_count("num_robots", num_robots)
        robot_radius = _non_negative("robot_radius", robot_radius)
        max_cross_track = _positive("max_cross_track", max_cross_track)
        self.goal_radius = _non_negative("goal_radius", goal_radius)
        count, width = self.num_robots, model.input_dim
        self.center = 0.5 * (model.input_high + model.input_low)
        self.half_range = 0.5 * (model.input_high - model.input_low)
        constants = primitive_actions(width) if mppi.primitives else np.zeros((0, width))
        # The samples that fit beside the mean and at least one noisy sample.
        constants = constants[: mppi.samples - 2]
        self.primitives = np.ascontiguousarray(
            np.broadcast_to(constants[:, np.newaxis], (len(constants), mppi.horizon, width))
        )
        manoeuvres = min(mppi.manoeuvres, mppi.samples - 2 - len(constants))
        self.settings = self._kernel_settings(integrator, robot_radius, max_cross_track)
        self.settings[kernels.MANOEUVRES] = manoeuvres
        self.sequences = np.zeros((count, mppi.horizon, width))
        self.histories = np.zeros((count, kernels.HISTORY, width))
        noisy = mppi.samples - 1 - len(self.primitives) - manoeuvres
        self.noises = np.zeros((count, noisy, mppi.horizon, width))
        self.streams = np.zeros((count, STREAM_WORDS), dtype=np.uint64)
        self.segments = np.zeros(count, dtype=np.int64)
        self.progress = np.zeros((count, 2))
        self.started = np.zeros(count, dtype=bool)
        self.table = PathTable([Path([[0.0, 0.0], [1.0, 0.0]])] * count)
        self.mazes = MazePack(count)
        self.slots = np.full(count, -1, dtype=np.int64)
        self._plan = for_model(kernels.plan_robots, model.compiled)
        self._rollout = for_model(kernels.rollout_states, model.compiled)
        self._score = for_model(kernels.score_robot, model.compiled)

    def _kernel_settings(self, integrator: str, robot_radius: float, max_cross_track: float) -> Array:
        mppi = self.mppi
        settings = np.zeros(kernels.NUM_SETTINGS)
        top_speed = self.model.top_speed
        settings[kernels.DT] = self.dt
        settings[kernels.INTEGRATOR] = INTEGRATORS.index(integrator)
        settings[kernels.TEMPERATURE] = mppi.temperature
        settings[kernels.GAMMA] = mppi.gamma
        settings[kernels.NOISE_STD] = mppi.noise_std
        settings[kernels.NOISE_CORRELATION] = mppi.noise_correlation
        settings[kernels.REGENERATE_NOISE] = float(mppi.regenerate_noise)
        settings[kernels.PATH_WEIGHT] = mppi.path_weight
        settings[kernels.PROGRESS_WEIGHT] = mppi.progress_weight
        settings[kernels.PROGRESS_SCALE] = top_speed * mppi.horizon * self.dt
        settings[kernels.HEADING_WEIGHT] = mppi.heading_weight
        # How far the robot drives to turn by a radian: its smallest turning radius, or
        # for robots that turn on the spot, the distance it could drive while turning.
        settings[kernels.TURN_LENGTH] = max(
            self.model.min_turning_radius, top_speed / self.model.top_yaw_rate
        )
        settings[kernels.ANTICIPATION] = mppi.anticipation * self.model.min_turning_radius
        settings[kernels.GOAL_WEIGHT] = mppi.goal_weight
        settings[kernels.GOAL_DISTANCE] = mppi.goal_distance
        settings[kernels.GOAL_RADIUS] = self.goal_radius
        settings[kernels.FORWARD_WEIGHT] = mppi.forward_weight
        settings[kernels.TOP_SPEED] = top_speed
        settings[kernels.SMOOTHNESS_WEIGHT] = mppi.smoothness_weight
        settings[kernels.WALL_WEIGHT] = mppi.wall_weight
        settings[kernels.WALL_MARGIN] = mppi.wall_margin
        settings[kernels.ROBOT_RADIUS] = robot_radius
        settings[kernels.COLLISION_COST] = mppi.collision_cost
        settings[kernels.TRACK_LIMIT] = max_cross_track
        # Rollouts are projected as the env projects the robot: each step from the last
        # step's segment, within the env's search distance.
        settings[kernels.SEARCH_DISTANCE] = DEFAULT_SEARCH_DISTANCE
        settings[kernels.SMOOTHING] = float(mppi.smoothing)
        settings[kernels.PATIENCE] = mppi.patience
        return settings

    def restart(self, robots: Sequence[int] | NDArray[np.int64], tracks: Sequence[Track | Path]) -> None:
        """Start new episodes: robot ``robots[j]`` follows ``tracks[j]`` (a Track, or a Path
        in open space) from rest, with the episode's own random stream."""
        robots = [int(robot) for robot in robots]
        if len(robots) != len(tracks):
            raise ValueError(f"got {len(robots)} robots and {len(tracks)} tracks")
        paths = []
        for robot, track in zip(robots, tracks, strict=True):
            if not 0 <= robot < self.num_robots:
                raise ValueError(f"robot index {robot} is not in [0, {self.num_robots})")
            if isinstance(track, Path):
                track = Track(track)
            paths.append(track.path)
            if self.slots[robot] >= 0:
                self.mazes.release(int(self.slots[robot]))
            self.slots[robot] = -1 if track.maze is None else self.mazes.acquire(track.maze)
            self.streams[robot] = episode_stream(self.mppi.seed, track.path)
            kernels.draw_noise(self.streams[robot], self.mppi.noise_correlation, self.noises[robot])
        self.table.set_paths(robots, paths)
        self.sequences[robots] = 0.0
        self.histories[robots] = 0.0
        self.segments[robots] = 0
        self.progress[robots] = 0.0
        self.started[robots] = True

    def act(self, states: ArrayLike) -> Array:
        """Plan one step for every robot; return their normalized actions (N, m) in [-1, 1].

        :param states: (N, k) the robots' (believed) states
        :raises RuntimeError: when a robot has not been restarted on a track yet
        """
        states = self._checked_states(states)
        columns, spans, lengths, goals = self.table.kernel_arrays
        mazes = self.mazes
        actions = np.empty((self.num_robots, self.model.input_dim))
        self._plan(
            self.model.kernel_parameters, self.settings, self.center, self.half_range,
            self.primitives, columns, spans, lengths, goals, mazes.verticals, mazes.horizontals, mazes.sizes, mazes.frames,
            self.slots, states, self.sequences, self.histories, self.noises, self.streams,
            self.segments, self.progress, actions,
        )  # fmt: skip
        return actions

    def score(self, robot: int, states: ArrayLike, actions: ArrayLike) -> Array:
        """The costs MPPI gives action sequences ``actions`` (K, T, m) of robot ``robot``
        when the robots are in ``states`` (N, k), as a step's samples are scored; nothing
        changes. For inspecting the critics and testing them."""
        states = self._checked_states(states)
        actions = np.ascontiguousarray(actions, dtype=np.float64)
        shape = (self.mppi.horizon, self.model.input_dim)
        if actions.ndim != 3 or actions.shape[1:] != shape:
            raise ValueError(f"actions must have shape (K, {shape[0]}, {shape[1]})")
        columns, spans, lengths, goals = self.table.kernel_arrays
        mazes = self.mazes
        return self._score(
            self.model.kernel_parameters, self.settings, self.center, self.half_range, columns,
            spans, lengths, goals, mazes.verticals, mazes.horizontals, mazes.sizes, mazes.frames,
            self.slots, states, self.sequences, self.histories, self.segments.copy(),
            self.progress, int(robot), actions,
        )  # fmt: skip

    def _checked_states(self, states: ArrayLike) -> Array:
        states = np.ascontiguousarray(states, dtype=np.float64)
        shape = (self.num_robots, self.model.state_dim)
        if states.shape != shape:
            raise ValueError(f"states must have shape {shape}, got {states.shape}")
        if not np.isfinite(states).all():
            raise ValueError("states contain NaN or inf")
        if not self.started.all():
            missing = np.flatnonzero(~self.started).tolist()
            raise RuntimeError(f"restart robots {missing} on a track before planning")
        return states

    def inputs_of(self, actions: ArrayLike) -> Array:
        """The native inputs of normalized actions, as the env's step maps them."""
        return self.center + np.asarray(actions, dtype=np.float64) * self.half_range

    def rollout(self, state: ArrayLike, actions: ArrayLike) -> Array:
        """The states (T + 1, k) MPPI predicts for one robot from ``state`` under normalized
        ``actions`` (T, m): the rollout its costs score."""
        state = np.ascontiguousarray(state, dtype=np.float64)
        actions = np.ascontiguousarray(actions, dtype=np.float64)
        if state.shape != (self.model.state_dim,) or actions.ndim != 2:
            raise ValueError(f"need a state ({self.model.state_dim},) and actions (T, m)")
        return self._rollout(
            self.model.kernel_parameters, self.settings, self.center, self.half_range, state,
            actions,
        )  # fmt: skip


class BoundMPPI:
    """:class:`MPPI` driving every robot of one env, with SB3's ``predict``.

    A robot restarts on its track when ``episode_start[i]`` is true or, when
    ``episode_start`` is None, when it has taken no step in its episode or its track object
    changed (as after the vector env's autoreset), as :class:`~agents.controllers.base.
    BoundAgent` decides. It reads the env's documented state: ``believed_states`` /
    ``believed_state`` (the estimate when the env localizes), ``tracks`` / ``track``,
    ``elapsed_steps``, ``model``, ``dt`` and ``config`` (integrator, robot radius,
    ``max_cross_track``).

    :param agent: the parameters
    :param env: a PathFollowingEnv or PathFollowingVectorEnv, possibly wrapped
    """

    def __init__(self, agent: MPPI, env: Any) -> None:
        base = env.unwrapped
        self.agent = agent
        self.env = base
        self.batched = hasattr(base, "num_envs")
        count = base.num_envs if self.batched else 1
        config = base.config
        self.planner = agent.planner(
            base.model,
            base.dt,
            count,
            integrator=config.integrator,
            robot_radius=config.robot_radius,
            max_cross_track=config.max_cross_track,
            goal_radius=config.goal_radius,
        )
        self._tracks: list[Track | None] = [None] * count

    def bind(self, env: Any) -> BoundMPPI:
        """The same parameters bound to another env."""
        return self.agent.bind(env)

    def predict(
        self,
        observation: NDArray[np.float32],
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], Any]:
        """The env's normalized actions for the robots' current (believed) states.

        :param observation: the env's observation (unused: MPPI reads the believed state)
        :param state: passed through unchanged
        :param episode_start: per robot, whether its episode just started; None to detect it
        :param deterministic: ignored: the noise is the episode generator's
        :return: ``(actions, state)``: (m,) for a single env, (N, m) for a vector env
        """
        env = self.env
        if self.batched:
            states, tracks, steps = env.believed_states, env.tracks, env.elapsed_steps
        else:
            states = env.believed_state[np.newaxis]
            tracks, steps = [env.track], [env.elapsed_steps]
        starts = None if episode_start is None else np.atleast_1d(episode_start)
        restart = []
        for index, track in enumerate(tracks):
            if starts is None:
                new = steps[index] == 0 or track is not self._tracks[index]
            else:
                new = bool(starts[index]) or self._tracks[index] is None
            if new:
                restart.append(index)
                self._tracks[index] = track
        if restart:
            self.planner.restart(restart, [tracks[index] for index in restart])
        actions = self.planner.act(states).astype(np.float32)
        return (actions if self.batched else actions[0]), state

    def __repr__(self) -> str:
        return f"{self.agent!r}.bind({type(self.env).__name__})"


__all__ = ["MPPI", "BoundMPPI", "MPPIPlanner", "episode_stream"]

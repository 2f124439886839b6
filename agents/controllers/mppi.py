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

- as a classical agent, through the harness: ``evaluate(MPPI(), env_id, episodes)`` (its
  :meth:`MPPI.batch_agent` plans every robot still driving in one compiled call per step),
  or ``MPPI().bind(env)`` for SB3's ``predict`` on a single or a vector env;
- without an env, one robot: ``mppi.reset(path, maze)``, then ``mppi.inputs(state, model,
  dt)`` once per control step;
- batched, for a harness of its own: ``planner = MPPI().planner(model, dt, num_robots)``,
  ``planner.restart(robots, tracks)`` when episodes start, ``planner.act(states)`` each step
  (the normalized actions of every robot; :meth:`MPPIPlanner.inputs_of` gives native inputs).

With a plant (:mod:`mobile_envs.sim.plant`) whose delay and lag it knows (the env's nominal
ones when bound), MPPI replays the commands it sent that have not reached the actuators yet
through the nominal model and the lag, and plans from the predicted state; its rollouts go
through the lag too.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agents.controllers import mppi_kernels as kernels
from agents.controllers.base import BoundController, ClassicalAgent
from agents.controllers.batch import Indices, robot_indices
from mobile_envs._kernels import exact_math
from mobile_envs._kernels.pcg64 import STREAM_WORDS, streams_of
from mobile_envs._kernels.specialize import for_model
from mobile_envs.robots import INTEGRATORS, KinematicModel
from mobile_envs.sim.plant import DELAY_TOLERANCE, MAX_DELAY
from mobile_envs.tracks.sets import Track
from mobile_envs.validation import as_count, as_flag, as_non_negative, as_positive, as_real
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


def episode_stream(seed: int, path: Path, start: ArrayLike) -> NDArray[np.uint64]:
    """The PCG64 stream (:mod:`mobile_envs._kernels.pcg64`) an episode samples from:
    ``np.random.default_rng([seed, digest])``'s state, the digest (BLAKE2b, 8 bytes) of the
    episode's path points and of the robot's (believed) state when it is first planned. So
    the episode, not the order or company it runs in, seeds its generator: the same seed gives
    the same noise whether the robot is planned alone or in a batch, first or hundredth.

    :param seed: MPPI's seed
    :param path: the episode's path
    :param start: the robot's state at the episode's first control step
    """
    points = np.ascontiguousarray(path.points, dtype=np.float64)
    state = np.ascontiguousarray(start, dtype=np.float64)
    hashed = hashlib.blake2b(points.tobytes() + state.tobytes(), digest_size=8).digest()
    digest = int.from_bytes(hashed, "little")
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
    generator, seeded by ``seed``, the episode's path and the robot's state at its first
    step (:func:`episode_stream`): the same seed gives the same trajectory, planned alone or
    among any number of robots.

    With an actuator delay of d steps and a lag of time constant tau (``delay``,
    ``time_constant``; the env's plant's nominal ones when left None), x0 is the state
    predicted over the d commands already sent, through the nominal model and the lag, and
    every rollout passes its actions through the lag (delay compensation).

    The defaults (K = 256 samples over T = 20 steps, 2 s at the envs' 0.1 s) were tuned on
    random paths and random mazes for every model at once, never on the course's paths or
    the canonical maze; ``docs/mppi.md`` says how.

    :param samples: K, sampled sequences per step (Nav2's ``batch_size``), at least 2
    :param horizon: T, steps per sequence (Nav2's ``time_steps``)
    :param temperature: lambda of the softmax (Nav2's ``temperature``), in cost units
    :param noise_std: standard deviation of the perturbations, in normalized action units
        (1 is half an input's range: Nav2's ``vx_std``/``wz_std`` as fractions)
    :param noise_correlation: correlation of each step's noise with the step before's, in
        [0, 0.99] (0: white noise)
    :param primitives: whether the constant actions (the action box's corners and axes)
        are among the samples
    :param regenerate_noise: whether the noise is drawn anew every step (Nav2's
        ``regenerate_noises``); otherwise once per episode
    :param manoeuvres: how many of the samples are two-piece manoeuvres (each action
        element at one of -1, -1/2, 0, 1/2, 1, then at another from a random step on: a
        reverse-and-turn out of a corner is among them); capped so that the mean, the
        primitives and at least one noisy sample keep their places
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
    :param anticipation: how far beyond a rollout's end (in turning radii) the heading
        critic reads the path's heading
    :param smoothing: whether to apply the Savitzky-Golay smoothing
    :param patience: time (s) without progress after which the path weight has halved
        (0: it never relaxes)
    :param seed: seed of the episodes' generators, a non-negative integer
    :param delay: the actuators' delay (s), a whole number of control steps; None: the env's
        plant's configured delay when bound (not an episode's draw), 0 otherwise
    :param time_constant: the actuators' first-order lag (s), 0 for none; None: the env's
        plant's when bound, 0 otherwise
    :raises ValueError: naming the parameter, unless the counts are integers (K >= 2, T >=
        1), the weights, costs and ``goal_distance`` finite numbers in [0, 1e6],
        ``temperature`` and ``wall_margin`` in (0, 1e6], ``noise_std`` in [1e-6, 10],
        ``smoothing`` a bool, ``seed`` an integer in [0, 2**63), ``delay`` None or in
        [0, 60] and ``time_constant`` None or in [0, 1e6]
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
        manoeuvres: int = 160,
        gamma: float = 0.0,
        path_weight: float = 30.0,
        progress_weight: float = 4.0,
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
        delay: float | None = None,
        time_constant: float | None = None,
    ):
        self.samples = as_count("samples", samples, MAX_SAMPLES)
        if self.samples < 2:
            raise ValueError(
                f"samples must be at least 2 (the mean and one sample), got {samples!r}"
            )
        self.horizon = as_count("horizon", horizon, MAX_HORIZON)
        self.temperature = as_positive("temperature", temperature, MAX_WEIGHT)
        self.noise_std = as_real("noise_std", noise_std)
        if not 1e-6 <= self.noise_std <= 10.0:
            raise ValueError(f"noise_std must lie in [1e-6, 10], got {noise_std!r}")
        self.noise_correlation = as_non_negative("noise_correlation", noise_correlation, 0.99)
        self.primitives = as_flag("primitives", primitives)
        self.regenerate_noise = as_flag("regenerate_noise", regenerate_noise)
        self.manoeuvres = as_count("manoeuvres", manoeuvres, MAX_SAMPLES, minimum=0)
        self.gamma = as_non_negative("gamma", gamma, MAX_WEIGHT)
        self.path_weight = as_non_negative("path_weight", path_weight, MAX_WEIGHT)
        self.progress_weight = as_non_negative("progress_weight", progress_weight, MAX_WEIGHT)
        self.heading_weight = as_non_negative("heading_weight", heading_weight, MAX_WEIGHT)
        self.anticipation = as_non_negative("anticipation", anticipation, MAX_WEIGHT)
        self.goal_weight = as_non_negative("goal_weight", goal_weight, MAX_WEIGHT)
        self.goal_distance = as_non_negative("goal_distance", goal_distance, MAX_WEIGHT)
        self.forward_weight = as_non_negative("forward_weight", forward_weight, MAX_WEIGHT)
        self.smoothness_weight = as_non_negative("smoothness_weight", smoothness_weight, MAX_WEIGHT)
        self.wall_weight = as_non_negative("wall_weight", wall_weight, MAX_WEIGHT)
        self.wall_margin = as_positive("wall_margin", wall_margin, MAX_WEIGHT)
        self.collision_cost = as_non_negative("collision_cost", collision_cost, MAX_WEIGHT)
        self.smoothing = as_flag("smoothing", smoothing)
        self.patience = as_non_negative("patience", patience, MAX_WEIGHT)
        if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
            raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
        if not 0 <= seed < 2**63:
            raise ValueError(f"seed must lie in [0, 2**63), got {seed!r}")
        self.seed = int(seed)
        self.delay = None if delay is None else as_non_negative("delay", delay, MAX_DELAY)
        self.time_constant = (
            None
            if time_constant is None
            else as_non_negative("time_constant", time_constant, MAX_WEIGHT)
        )
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
        plant: Any = None,
    ) -> MPPIPlanner:
        """A batched planner with these parameters for ``num_robots`` robots of ``model``
        (see :class:`MPPIPlanner`); a ``delay`` or ``time_constant`` left None is ``plant``'s
        (a :class:`~mobile_envs.sim.plant.PlantSettings`), or 0 without one."""
        delay = self.delay if self.delay is not None else getattr(plant, "delay", 0.0)
        time_constant = self.time_constant
        if time_constant is None:
            time_constant = getattr(plant, "time_constant", 0.0)
        return MPPIPlanner(
            self,
            model,
            dt,
            num_robots,
            integrator=integrator,
            robot_radius=robot_radius,
            max_cross_track=max_cross_track,
            goal_radius=goal_radius,
            delay=delay,
            time_constant=time_constant,
        )

    def reset(self, path: Path, maze: Maze | None = None) -> None:
        """Start following ``path`` (between the walls of ``maze``, if given)."""
        self._track = Track(path, maze)
        self._restart = True

    def inputs(self, state: ArrayLike, model: KinematicModel, dt: float) -> NDArray[np.float64]:
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

    # BoundMPPI is not a BoundAgent: it shares BoundController's predict with it, but plans
    # in its own arrays, not through laws.
    def bind(self, env: Any) -> BoundMPPI:  # type: ignore[override]
        """This agent bound to ``env`` (single or vector): SB3's ``predict``, every robot
        planned in one compiled call, with the env's ``dt``, integrator, robot radius and
        ``max_cross_track``, reading its believed states and its tracks (paths and mazes)."""
        return BoundMPPI(self, env)

    def batch_agent(self, env: Any) -> MPPIBatchAgent:
        """This agent driving the robots of the vector env ``env`` for the evaluation harness
        (a :class:`~agents.controllers.batch.BatchAgent`): the robots still driving are
        planned in one compiled call per step."""
        return MPPIBatchAgent(self, env)

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
    :param goal_radius: the distance (m) to the goal that completes an episode
    :param delay: the actuators' delay (s), a whole number of steps
    :param time_constant: the actuators' first-order lag (s), 0 for none
    :raises ValueError: naming the argument for a model without finite limits, a bad
        ``dt``, count, integrator, radius, ``max_cross_track``, ``delay`` or
        ``time_constant``
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
        delay: float = 0.0,
        time_constant: float = 0.0,
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
        robot_radius = as_non_negative("robot_radius", robot_radius, MAX_WEIGHT)
        max_cross_track = as_positive("max_cross_track", max_cross_track, MAX_WEIGHT)
        self.goal_radius = as_non_negative("goal_radius", goal_radius, MAX_WEIGHT)
        delay = as_non_negative("delay", delay, MAX_DELAY)
        self.delay_steps = round(delay / self.dt)
        if abs(self.delay_steps * self.dt - delay) > DELAY_TOLERANCE:
            raise ValueError(f"delay must be a multiple of dt = {self.dt} s, got {delay} s")
        time_constant = as_non_negative("time_constant", time_constant, MAX_WEIGHT)
        # The plant's lag factor, computed as the plant computes it (the same bits).
        self.lag = (
            1.0 if time_constant == 0.0 else float(-exact_math.expm1(-self.dt / time_constant))
        )
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
        #: (N, d, m) the native commands sent and not yet applied, oldest first.
        self.pending = np.zeros((count, self.delay_steps, width))
        #: (N, m) the native inputs the actuators applied last step, as the lag has them.
        self.applied = np.zeros((count, width))
        self.started = np.zeros(count, dtype=bool)
        self.seeded = np.zeros(count, dtype=bool)
        self.paths: list[Path | None] = [None] * count
        self.table = PathTable([Path([[0.0, 0.0], [1.0, 0.0]])] * count)
        self.mazes = MazePack(count)
        self.slots = np.full(count, -1, dtype=np.int64)
        self._plan = for_model(kernels.plan_robots, model.compiled)
        self._rollout = for_model(kernels.rollout_states, model.compiled)
        self._score = for_model(kernels.score_robot, model.compiled)

    def _kernel_settings(
        self, integrator: str, robot_radius: float, max_cross_track: float
    ) -> Array:
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
        settings[kernels.LAG] = self.lag
        return settings

    def restart(self, robots: ArrayLike, tracks: Sequence[Track | Path]) -> None:
        """Start new episodes: robot ``robots[j]`` follows ``tracks[j]`` (a Track, or a Path
        in open space) from rest; its generator is seeded at its first :meth:`act`."""
        indices = robot_indices(robots).tolist()
        if len(indices) != len(tracks):
            raise ValueError(f"got {len(indices)} robots and {len(tracks)} tracks")
        paths = []
        for robot, track in zip(indices, tracks, strict=True):
            if not 0 <= robot < self.num_robots:
                raise ValueError(f"robot index {robot} is not in [0, {self.num_robots})")
            if isinstance(track, Path):
                track = Track(track)
            paths.append(track.path)
            self.paths[robot] = track.path
            if self.slots[robot] >= 0:
                self.mazes.release(int(self.slots[robot]))
            self.slots[robot] = -1 if track.maze is None else self.mazes.acquire(track.maze)
        if not indices:
            return
        self.table.set_paths(indices, paths)
        self.sequences[indices] = 0.0
        self.histories[indices] = 0.0
        self.segments[indices] = 0
        self.progress[indices] = 0.0
        self.pending[indices] = 0.0
        self.applied[indices] = 0.0
        self.started[indices] = True
        self.seeded[indices] = False

    def act(self, states: ArrayLike, robots: ArrayLike | None = None) -> Array:
        """Plan one step for robots ``robots`` (all when None); return their normalized
        actions (len(robots), m) in [-1, 1].

        :param states: (N, k) the robots' (believed) states; only the rows of ``robots`` are
            read
        :param robots: the robots to plan for, each restarted on a track
        :raises RuntimeError: when a robot has not been restarted on a track yet
        """
        indices = (
            np.arange(self.num_robots, dtype=np.int64) if robots is None else robot_indices(robots)
        )
        states = self._checked_states(states, indices)
        for robot in indices[~self.seeded[indices]].tolist():
            path = self.paths[robot]
            assert path is not None
            self.streams[robot] = episode_stream(self.mppi.seed, path, states[robot])
            kernels.draw_noise(self.streams[robot], self.mppi.noise_correlation, self.noises[robot])
            self.seeded[robot] = True
        columns, spans, lengths, goals = self.table.kernel_arrays
        mazes = self.mazes
        actions = np.empty((len(indices), self.model.input_dim))
        self._plan(
            self.model.kernel_parameters, self.settings, self.center, self.half_range,
            self.primitives, columns, spans, lengths, goals, mazes.verticals, mazes.horizontals,
            mazes.sizes, mazes.frames, self.slots, indices, states, self.sequences,
            self.histories, self.noises, self.streams, self.segments, self.progress,
            self.pending, self.applied, actions,
        )  # fmt: skip
        return actions

    def score(self, robot: int, states: ArrayLike, actions: ArrayLike) -> Array:
        """The costs MPPI gives action sequences ``actions`` (K, T, m) of robot ``robot``
        when the robots are in ``states`` (N, k), as a step's samples are scored; nothing
        changes. For inspecting the critics and testing them."""
        states = self._checked_states(states, np.array([robot], dtype=np.int64))
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
            self.progress, self.pending, self.applied, int(robot), actions,
        )  # fmt: skip

    def _checked_states(self, states: ArrayLike, robots: Indices) -> Array:
        states = np.ascontiguousarray(states, dtype=np.float64)
        shape = (self.num_robots, self.model.state_dim)
        if states.shape != shape:
            raise ValueError(f"states must have shape {shape}, got {states.shape}")
        if ((robots < 0) | (robots >= self.num_robots)).any():
            raise ValueError(f"robot indices must lie in [0, {self.num_robots}), got {robots}")
        if not np.isfinite(states[robots]).all():
            raise ValueError("states contain NaN or inf")
        if not self.started[robots].all():
            missing = robots[~self.started[robots]].tolist()
            raise RuntimeError(f"restart robots {missing} on a track before planning")
        return states

    def inputs_of(self, actions: ArrayLike) -> Array:
        """The native inputs of normalized actions, as the env's step maps them."""
        return self.center + np.asarray(actions, dtype=np.float64) * self.half_range

    def rollout(
        self,
        state: ArrayLike,
        actions: ArrayLike,
        pending: ArrayLike | None = None,
        applied: ArrayLike | None = None,
    ) -> Array:
        """The states (d + T + 1, k) MPPI predicts for one robot from ``state``: over the
        ``pending`` native commands (d, m) of the delay (zeros, the plant's start, when None),
        then under the normalized ``actions`` (T, m), all through the lag from the actuators'
        ``applied`` native inputs (zeros when None): the prediction its costs score."""
        width = self.model.input_dim
        state = np.ascontiguousarray(state, dtype=np.float64)
        actions = np.ascontiguousarray(actions, dtype=np.float64)
        pending = np.zeros((self.delay_steps, width)) if pending is None else pending
        pending = np.ascontiguousarray(pending, dtype=np.float64)
        applied = np.zeros(width) if applied is None else applied
        applied = np.ascontiguousarray(applied, dtype=np.float64)
        if (
            state.shape != (self.model.state_dim,)
            or actions.ndim != 2
            or actions.shape[1] != width
            or pending.ndim != 2
            or pending.shape[1] != width
            or applied.shape != (width,)
        ):
            raise ValueError(
                f"need a state ({self.model.state_dim},), actions (T, {width}), pending "
                f"(d, {width}) and applied ({width},)"
            )
        return self._rollout(
            self.model.kernel_parameters, self.settings, self.center, self.half_range, state,
            applied, pending, actions,
        )  # fmt: skip


def _planner_for(agent: MPPI, env: Any, count: int) -> MPPIPlanner:
    """``agent``'s planner for ``count`` robots of the unwrapped env ``env``: its model,
    ``dt``, integrator, robot radius, ``max_cross_track``, goal radius and plant."""
    config = env.config
    return agent.planner(
        env.model,
        env.dt,
        count,
        integrator=config.integrator,
        robot_radius=config.robot_radius,
        max_cross_track=config.max_cross_track,
        goal_radius=config.goal_radius,
        plant=config.plant,
    )


class MPPIBatchAgent:
    """:class:`MPPI` driving the robots of a vector env for the evaluation harness: a
    :class:`~agents.controllers.batch.BatchAgent` that plans the robots it is asked for in one
    compiled call, from their believed states.

    :param agent: the parameters
    :param env: a PathFollowingVectorEnv, possibly wrapped
    """

    def __init__(self, agent: MPPI, env: Any) -> None:
        base = env.unwrapped
        self.planner = _planner_for(agent, base, base.num_envs)

    def reset(self, robots: Indices, tracks: Sequence[Track]) -> None:
        self.planner.restart(robots, tracks)

    def act(
        self,
        robots: Indices,
        observations: NDArray[np.float32],
        believed_states: NDArray[np.float64],
    ) -> NDArray[np.float32]:
        return self.planner.act(believed_states, robots).astype(np.float32)


class BoundMPPI(BoundController):
    """:class:`MPPI` driving every robot of one env, with SB3's ``predict``.

    A robot restarts on its track when ``episode_start[i]`` is true or, when
    ``episode_start`` is None, when it has taken no step in its episode or its track object
    changed (as after the vector env's autoreset), as :class:`~agents.controllers.base.
    BoundAgent` decides. It reads the env's documented state: ``believed_states`` /
    ``believed_state`` (the estimate when the env localizes), ``tracks`` / ``track``,
    ``elapsed_steps``, ``model``, ``dt`` and ``config`` (integrator, robot radius,
    ``max_cross_track``, goal radius, plant).

    :param agent: the parameters
    :param env: a PathFollowingEnv or PathFollowingVectorEnv, possibly wrapped
    """

    agent: MPPI

    def __init__(self, agent: MPPI, env: Any) -> None:
        super().__init__(agent, env)
        self.planner = _planner_for(agent, self.env, self.count)

    def bind(self, env: Any) -> BoundMPPI:
        """The same parameters bound to another env."""
        return self.agent.bind(env)

    def followed(self) -> Sequence[Track]:
        """Each robot's track now (its path and, in a maze, the maze)."""
        return self.env.tracks if self.batched else [self.env.track]

    def restart(self, robots: list[int], followed: list[Any]) -> None:
        """Robots ``robots`` start planning on their tracks ``followed``."""
        self.planner.restart(robots, followed)

    def actions(self, states: NDArray[np.float64]) -> NDArray[np.float32]:
        """Every robot's planned action, normalized, from its believed state."""
        return self.planner.act(states).astype(np.float32)


__all__ = ["MPPI", "BoundMPPI", "MPPIBatchAgent", "MPPIPlanner", "episode_stream"]

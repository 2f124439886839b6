"""PathFollowingEnv: one wheeled robot following a path, as a Gymnasium environment."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from mobile_envs.envs.interface import (
    action_space_for,
    observation_space_for,
    parse_reset_options,
    robot_episode_info,
    robot_info,
    robot_localization_info,
    robot_plant_info,
    validate_actions,
)
from mobile_envs.robots import KinematicModel
from mobile_envs.sensing.localization import Localization, believed_states
from mobile_envs.sensing.sensors import SensorSpec
from mobile_envs.sim.columns import FlagColumn, FloatColumn
from mobile_envs.sim.config import PathsArgument, RewardWeights, make_core_config
from mobile_envs.sim.core import PathFollowingCore
from mobile_envs.sim.observation import preview_offsets
from mobile_envs.tracks.sets import Track
from mobile_envs.world.paths import Path

__all__ = [
    "PathFollowingEnv",
]

if TYPE_CHECKING:
    from mobile_envs.rendering.frame import Renderer

# Plain ints index the Python lists of the hot single-robot step fastest.
_REWARD = int(FloatColumn.REWARD)
_TERMINATED, _TRUNCATED = int(FlagColumn.TERMINATED), int(FlagColumn.TRUNCATED)


class PathFollowingEnv(gym.Env[NDArray[np.float32], NDArray[np.float32]]):
    """
    ## Description

    A wheeled robot follows a planar path: the course's straight lines and segments (the course on
    mobile-robot kinematics, after Corke), the arc-and-straight run of Font-Llagunes & Batlle
    (2006), maze routes with walls, or random paths for training. The kinematic models of
    :mod:`mobile_envs.robots` drive it: a holonomic constant-velocity robot, a differential drive
    (Bermúdez 2003), a bicycle (the course), a tricycle (Font-Llagunes & Batlle 2006) and a
    mecanum-wheeled omnidirectional robot. The robot starts at the path's first waypoint (heading 0
    on the course paths, as in the course) and must reach the last one, staying on the path, as fast
    as is safe.

    ## Example

    >>> import gymnasium as gym
    >>> import mobile_envs
    >>> env = gym.make("mobile_envs/DiffDrive-Segments-v0")
    >>> observation, info = env.reset(seed=0)
    >>> observation.shape, info["pose"]  # the first waypoint, heading 0
    ((45,), array([2., 1., 0.]))
    >>> action = [0.5, 0.5]  # both wheels at half their top speed: 10 rad/s, so 0.5 m/s
    >>> observation, reward, terminated, truncated, info = env.step(action)
    >>> info["pose"].round(3), terminated, truncated  # 0.05 m along x in 0.1 s
    (array([2.05, 1.  , 0.  ]), False, False)

    ## Action Space

    ``Box(-1, 1, (m,), float32)``, mapped linearly onto the model's native inputs between
    its limits (``-1`` is the lower limit, ``1`` the upper). Finite actions outside
    [-1, 1] are clipped; NaN, inf or a wrong shape raise ``ValueError``.

    | model             | m | action[0]            | action[1]              | action[2], ...    |
    |-------------------|---|----------------------|------------------------|-------------------|
    | constant_velocity | 3 | v_x in [-1, 1]       | v_y in [-1, 1]         | omega in [-2, 2]  |
    | diff_drive        | 2 | omega_R in [-20, 20] | omega_L in [-20, 20]   |                   |
    | bicycle           | 2 | v in [-1, 1]         | gamma in [-pi/4, pi/4] |                   |
    | tricycle          | 2 | v of C in [-1, 1]    | gamma rate in [-2, 2]  |                   |
    | mecanum           | 4 | omega_fl in [-20, 20]| omega_fr in [-20, 20]  | omega_rl, omega_rr |

    Speeds are in m/s, angles in rad, angular speeds and rates in rad/s.

    The differential drive has wheel radius 0.05 m and track width 1 m (the course's), so
    its top speed is 1 m/s and its top yaw rate 2 rad/s. Bicycle and tricycle wheelbases
    are 1 m; the tricycle's wheel angle is held within +-85 degrees. The mecanum robot's
    wheels (front-left, front-right, rear-left, rear-right) have radius 0.05 m, 0.2 m from
    its centre along and across: top speed 1 m/s in any direction, top yaw rate 2.5 rad/s.
    Other limits: pass
    ``model_params`` or a model instance with finite limits.

    ## Observation Space

    A 1-D float32 ``Box`` in [-1, 1]; the same layout on every path set of a model, so a
    policy trained on one set runs on all of them. ``D = 43 + m + e`` where ``e`` is 1 for
    the tricycle and the constant-velocity model and 0 otherwise (the default sensors; the
    layout is :class:`mobile_envs.sim.observation.ObservationLayout`).

    | index    | observation                                          | scaling                   |
    |----------|------------------------------------------------------|---------------------------|
    | 0 .. 19  | (x, y) of 10 points ahead on the path, robot frame   | / (2.5 + max_cross_track) |
    | 20       | signed cross-track error e (+ left of the path)      | / max_cross_track         |
    | 21       | heading error xi to the path tangent                 | / pi                      |
    | 22       | e again, at fine resolution                          | tanh(e / 0.05 m)          |
    | 23       | xi again, at fine resolution                         | tanh(xi / 0.1 rad)        |
    | 24       | forward speed v of the reference point               | / top speed               |
    | 25       | yaw rate omega                                       | / top yaw rate            |
    | 26 (e=1) | wheel angle gamma (tricycle); v_y (holonomic)        | / its limit               |
    | 26+e     | remaining fraction of the path, 1 - s / L            | in [0, 1]                 |
    | 27+e ..  | the previous action (m values)                       | in [-1, 1]                |
    | last 16  | ranges every 22.5 deg, counter-clockwise from behind | / 3 m, at most 1          |

    ``env.unwrapped.observation_names`` names every element. The preview points lie 0.25 m
    to 2.5 m ahead of the robot's projection, clamped to the path's end; range readings are
    1 off mazes.

    ## Rewards

    Each step, with ``Delta s`` the progress along the path (metres, negative backwards):

        r = Delta s - 0.01 - (8 |e_ct| + 20 e_ct^2) dt - 0.2 |e_heading| dt
            - 0.02 mean((a - a_prev)^2) - w_peak Delta peak
            + 10 [goal reached] - 10 [left the track, hit a wall or stalled]

    The path's length is the total progress on offer; every second spent costs the time
    term and the error terms, so reaching the goal accurately and promptly scores best.
    ``Delta peak`` is how much this step raised the largest |e_ct| of the episode so far,
    counted from the start pose's: over an episode the term sums to ``w_peak`` times the
    worst excursion beyond where the robot started, the quantity a max |cte| target
    measures. ``w_peak`` (``peak_cross_track``) is 0 unless set.
    Weights: ``reward_weights`` (:class:`mobile_envs.sim.config.RewardWeights`).

    ## Starting State

    The path's start pose: its first waypoint with heading 0 on the course paths (the
    course's convention), the first segment's heading on random paths and maze routes, the
    arc's tangent on ``arc_straight``. ``start_noise=(p, h)`` adds a uniform offset in
    [-p, p] metres to x and y and in [-h, h] radians to the heading (off by default on the
    course paths). The tricycle starts with its wheel straight.

    ## Episode End

    Terminated when the robot is within ``goal_radius`` of the last waypoint after covering
    at least 90% of the path (success), when ``|cross-track error| > max_cross_track``
    (off track), when it touches a maze wall (a circle of ``robot_radius``), or when it has
    not advanced 1 cm beyond its farthest point along the path for ``stall_time`` seconds
    (stalled; otherwise, with discounting, waiting for the time limit would look cheaper
    than risking a corner). All but success cost the failure penalty. Truncated after
    ``step_limit`` steps, by default 3 times the steps the path takes at 0.6 m/s.

    ``info`` every step: ``cross_track_error``, ``heading_error``, ``progress`` (0..1),
    ``is_success``, ``collision``, ``off_track``, ``stalled``, ``pose`` (x, y, heading); at the
    episode's end also ``mean_abs_cte``, ``max_abs_cte``, ``rms_cte``, ``episode_time``,
    ``distance_travelled`` and ``completed`` (:meth:`episode_metrics` gives them at any
    time, e.g. after ``gym.make(..., max_episode_steps=n)``'s own TimeLimit, which the env
    cannot see). When the robot localizes (``localization`` other than ``"exact"``) every
    info also holds ``estimated_pose`` (x, y, heading), ``localization_error`` (m, estimated
    to true position) and ``heading_localization_error`` (rad, estimate minus truth), and the
    episode metrics ``mean_localization_error`` and ``max_localization_error`` (m).

    ## Arguments

    - ``model``: ``"constant_velocity"``, ``"diff_drive"``, ``"bicycle"``, ``"tricycle"``,
      ``"mecanum"`` (any name of :data:`mobile_envs.robots.MODELS`) or a
      :class:`~mobile_envs.robots.model.KinematicModel` with finite input limits.
    - ``paths``: a path-set name, a ``Path``, a ``Track`` or a list of them, or a ``PathSet``.
      The named sets (``mobile_envs.tracks.path_set_names()``; ids in parentheses):
      ``"lines"`` (``Lines``: the course's three straight lines, ``"horizontal_line"``,
      ``"vertical_line"`` and ``"diagonal_line"`` one each), ``"segments"`` (``Segments``),
      ``"sharp_segments"`` (``SharpSegments``), ``"maze"`` (``Maze``: the canonical 8 x 8
      maze), ``"figure_eight"`` (``FigureEight``: the lemniscate of Bernoulli across the
      course's area, 28.8 m, crossing itself at its centre), ``"arc_straight"``
      (``ArcStraight``, the tricycle's: seed 003's run), ``"random"`` (random paths),
      ``"random_maze"`` (random mazes), ``"training"`` (``Random``: both, 3 to 1, with
      ``start_noise=(0.2, 0.3)``), ``"random_short_ends"`` and ``"training_short_ends"``
      (the same draws, but a polyline may end as soon as 0.5 m after its last corner, as
      ``Segments`` does: the tricycle's recipe trains on them), and ``"training_half_mazes"``
      (random paths and random mazes 1 to 1, for a training mix heavier in mazes). Code
      registers more with ``mobile_envs.tracks.register_path_set`` (then
      ``mobile_envs.register_envs()`` for their ids).
    - ``model_params``: overrides of the model's defaults when ``model`` is a name.
    - ``dt`` (0.1 s), ``integrator`` (``"exact"``; ``"euler"`` reproduces the course),
      ``goal_radius`` (0.1 m), ``max_cross_track`` (1.0 m), ``step_limit`` (the env's own
      time limit in steps), ``start_noise`` (0), ``robot_radius`` (0.25 m), ``stall_time``
      (10 s; None disables it), ``reward_weights``, ``render_mode`` (``"human"`` or
      ``"rgb_array"``).
    - ``sensors``: the sensors whose readings end the observation, in order
      (:mod:`mobile_envs.sensing.sensors`), by default the 16-ray range ring. Each is a
      ``Sensor`` object, a name or a mapping of a name and settings (so a YAML file or
      ``--env-kwargs`` can choose them): ``sensors=["range", {"type": "gnss", "rate": 10.0,
      "noise": 0.02}]``. Names: ``"range"`` (rays to the maze walls: ``rays`` 16,
      ``max_range`` 3 m) and ``"gnss"`` (a noisy position fix at a set rate, read from the
      believed pose: ``rate`` 5 Hz, ``noise`` 0.05 m, ``max_offset`` 1 m); code registers more
      with ``mobile_envs.sensing.sensors.register_sensor``. Bad ones raise ``ValueError``
      naming them (``sensors[1]: ...``).
    - ``localization``: what the robot knows of its pose. ``"exact"`` (the default): the
      truth. ``"odometry"`` (wheel encoders with Bermúdez's error model: eq. 17's noise,
      systematic errors, quantization), ``"beacons"`` (Font-Llagunes & Batlle's rotating
      laser head and reflectors, triangulated each step, the last fix held) or
      ``"odometry+beacons"`` (odometry corrected by each fix, as they combine them), or
      ``"randomized"`` (each episode one of several of these, drawn for domain
      randomization: :mod:`mobile_envs.sensing.randomized`):
      the observation (preview points, errors, progress) is then computed from the
      *estimated* pose, while reward, termination and metrics use the true one
      (:mod:`mobile_envs.sensing.modes`); or a
      :class:`~mobile_envs.sensing.localization.Localization`. ``localization_params``: its
      settings, e.g. ``{"k_distance": 0.002}`` or ``{"reflectors": [[0, 0], [5, 0], [0, 5]]}``
      (bad ones raise ``ValueError`` naming them). ``believed_state`` is what a controller
      on the robot reads; ``render`` draws the reflectors, the laser lines of the last fix
      and the estimated pose (hollow, blue) beside the true one.

    - ``plant``: what the true robot does with its commands (:mod:`mobile_envs.sim.plant`).
      None (the default) or ``"ideal"``: exactly what the model says. ``"realistic"``: a 0.1 s
      delay, a 0.1 s first-order lag on each native input, parameter errors drawn each
      episode within +-3% (steering offsets within +-0.02 rad) and slip at eq. 17's Crowley
      coefficients (0.001, 0.003, 0.001) acting on the true pose. Or a dict of ``delay``
      (s, whole steps), ``time_constant`` (s), ``parameter_errors`` (by name: the model's
      ``parameter_errors``, fractions; ``steering_offset`` in rad), ``slip`` (K_D, K_Dtheta,
      K_theta) and ``randomize`` (per-episode draws: ``delay`` and ``time_constant`` ranges,
      a ``parameter_errors`` size, a ``steering_offset`` size, a ``slip`` scale range). The
      controllers and the observation's scaling use the nominal model; the observation's
      twist is the realized one (what the encoders measure). The reset's ``info`` reports the
      episode's ``plant_delay``, ``plant_time_constant``, ``plant_slip`` and
      ``plant_parameter_errors``.
    - ``num_threads`` (1): threads the compiled step splits the robots over, for the vector
      env's batches (:attr:`mobile_envs.sim.config.CoreConfig.num_threads`); the results are the
      same, bit for bit, whatever it is.

    ``reset(seed=..., options={"path": name_or_Path, "start_pose": (x, y, heading)})``: a
    set with several paths draws one with the env's RNG; ``options`` overrides the draw.

    ## Version History

    - v0: initial release.

    ## References

    - G. R. Bermúdez Bohórquez (2003), *Modelamiento cinemático y odométrico de robots
      móviles: aspectos matemáticos* (differential drive, odometry and its error).
    - J. M. Font-Llagunes, J. A. Batlle (2006), *Posicionamiento dinámico y guiado de un
      robot móvil con cinemática de triciclo*, Revista Iberoamericana de Ingeniería
      Mecánica 10(1) (tricycle, laser-beacon positioning, guidance law).
    - The course *Programación de robots: robots móviles, cinemática*, after P. Corke,
      *Robotics, Vision and Control* (constant-velocity, differential and bicycle models,
      pure pursuit).
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    def __init__(
        self,
        model: str | KinematicModel = "diff_drive",
        paths: PathsArgument = "segments",
        *,
        model_params: dict | None = None,
        dt: float = 0.1,
        integrator: str = "exact",
        goal_radius: float = 0.1,
        max_cross_track: float = 1.0,
        step_limit: int | None = None,
        start_noise: float | tuple[float, float] = 0.0,
        robot_radius: float = 0.25,
        stall_time: float | None = 10.0,
        reward_weights: RewardWeights | Mapping[str, float] | None = None,
        sensors: Sequence[SensorSpec] | None = None,
        localization: str | Localization = "exact",
        localization_params: dict[str, Any] | None = None,
        plant: str | Mapping[str, Any] | None = None,
        num_threads: int = 1,
        render_mode: str | None = None,
    ):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, "
                f"got {render_mode!r}"
            )
        self.config = make_core_config(
            model,
            paths,
            model_params=model_params,
            dt=dt,
            integrator=integrator,
            goal_radius=goal_radius,
            max_cross_track=max_cross_track,
            step_limit=step_limit,
            start_noise=start_noise,
            robot_radius=robot_radius,
            stall_time=stall_time,
            reward_weights=reward_weights,
            sensors=sensors,
            localization=localization,
            localization_params=localization_params,
            plant=plant,
            num_threads=num_threads,
        )
        self.core = PathFollowingCore(self.config, num_robots=1)
        self.model = self.config.model
        self.dt = self.config.dt
        self.observation_names = self.config.observation_names
        self.observation_space = observation_space_for(self.config)  # type: ignore[assignment]
        self.action_space = action_space_for(self.config)  # type: ignore[assignment]
        self._action_shape = (self.model.input_dim,)
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.dt)}
        self.render_mode = render_mode
        self._renderer: Renderer | None = None
        self._trail: list[NDArray[np.float64]] = []

    # ------------------------------------------------------------------ documented state

    @property
    def path(self) -> Path:
        """The path of the current episode."""
        return self.track.path

    @property
    def track(self) -> Track:
        """The current episode's track: its path and, in a maze, the maze."""
        track = self.core.tracks[0]
        if track is None:
            raise RuntimeError("call reset() before reading the track")
        return track

    @property
    def state(self) -> NDArray[np.float64]:
        """The model's state: (x, y, heading), plus the wheel angle for the tricycle."""
        return self.core.state[0].copy()

    @property
    def pose(self) -> NDArray[np.float64]:
        """(x, y, heading) of the robot's reference point."""
        return self.core.state[0, :3].copy()

    @property
    def believed_state(self) -> NDArray[np.float64]:
        """What the robot believes its state is, as a controller on board reads it: the
        estimated (x, y, heading) of its localization, then the model's other state columns
        as its own encoders read them (the tricycle's wheel angle gamma from its steering
        encoder, to its counts when ``steering_counts`` is set); equal to :attr:`state` with
        ``localization="exact"``."""
        core = self.core
        return believed_states(core.localization, core.estimate[:1], core.state[:1])[0]

    @property
    def elapsed_steps(self) -> int:
        """Steps taken in the current episode (0 right after reset)."""
        return int(self.core.steps[0])

    def episode_metrics(self) -> dict[str, float | bool]:
        """The current episode's metrics so far: what ``info`` holds at the episode's end.

        An outer ``TimeLimit`` (``gym.make(..., max_episode_steps=n)``) truncates without
        the env knowing, so that final info lacks them; read them here, or pass the env's own
        ``step_limit=n`` instead.
        """
        return robot_episode_info(self.core)

    def action_from_inputs(self, inputs: NDArray[np.float64]) -> NDArray[np.float32]:
        """The normalized action that applies native ``inputs`` (clipped to the limits)."""
        return self.core.actions_from_inputs(np.asarray(inputs, np.float64)).astype(np.float32)

    # ------------------------------------------------------------------ gymnasium API

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        if isinstance(seed, np.integer):
            seed = int(seed)
        elif seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
            raise ValueError(f"seed must be None or a non-negative integer, got {seed!r}")
        super().reset(seed=seed)
        track, start_pose = parse_reset_options(options)
        self.core.reset_robots(np.array([0]), [self.np_random], track, start_pose)
        self._trail = [self.core.state[0, :2].copy()]
        if self.render_mode == "human":
            self.render()
        values = self.core.floats[0].tolist()
        info = robot_info(self.core, values, self.core.flags[0].tolist())
        if self.core.localization is not None:
            info.update(robot_localization_info(self.core, values))
        info.update(robot_plant_info(self.core))
        return self.core.observe()[0], info

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        core = self.core
        if core.tracks[0] is None:
            raise RuntimeError("call reset() before step()")
        observation = core.step_and_observe(
            validate_actions(action, self._action_shape), [self.np_random]
        )[0]
        # One conversion each to Python numbers: SB3 and Gymnasium's checkers want a float
        # reward and bool flags, and reading them one element at a time costs microseconds.
        values, flags = core.floats[0].tolist(), core.flags[0].tolist()
        info = robot_info(core, values, flags)
        if core.localization is not None:
            info.update(robot_localization_info(core, values))
        reward, terminated, truncated = values[_REWARD], flags[_TERMINATED], flags[_TRUNCATED]
        if terminated or truncated:
            info.update(self.episode_metrics())
        if self.render_mode is not None:
            self._trail.append(core.state[0, :2].copy())
            if self.render_mode == "human":
                self.render()
        return observation, reward, terminated, truncated, info

    def render(self) -> NDArray[np.uint8] | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode to make()")
            return None
        if self.core.tracks[0] is None:
            raise RuntimeError("call reset() before render()")
        from mobile_envs.rendering.frame import Renderer, Scene

        if self._renderer is None:
            self._renderer = Renderer(self.render_mode, fps=self.metadata["render_fps"])
        maze = self.track.maze
        localization = self.core.localization
        # The preview points the policy sees: ahead of where it believes it is.
        seen_from = self.core.arc_length if localization is None else self.core.estimated_arc_length
        preview = self.path.point_at(seen_from[0] + preview_offsets())
        scene = Scene(
            path=self.path.points,
            walls=None if maze is None else maze.walls,
            pose=self.pose,
            robot_radius=self.config.robot_radius,
            trail=np.array(self._trail),
            preview=preview,
            goal_radius=self.config.goal_radius,
            estimated_pose=None if localization is None else self.core.estimate[0].copy(),
            landmarks=None if localization is None else localization.landmarks,
            sightings=None if localization is None else localization.sightings(0),
        )
        return self._renderer.render(scene)

    def __getstate__(self) -> dict[str, Any]:
        # The renderer holds pygame objects, which neither pickle nor copy: a copy draws anew.
        state = self.__dict__.copy()
        state["_renderer"] = None
        return state

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

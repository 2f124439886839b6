"""PathFollowingVectorEnv: N robots stepped together by the batched core."""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, TypeGuard

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from mobile_envs.envs.interface import (
    action_space_for,
    batch_episode_info,
    batch_plant_info,
    batch_step_info,
    observation_space_for,
    parse_reset_options,
    validate_actions,
)
from mobile_envs.robots import KinematicModel
from mobile_envs.sensing.localization import believed_states
from mobile_envs.sim.config import PathsArgument, as_count, make_core_config
from mobile_envs.sim.core import PathFollowingCore
from mobile_envs.tracks.sets import Track
from mobile_envs.validation import is_list
from mobile_envs.world.paths import Path

__all__ = [
    "AUTORESET_MODES",
    "PathFollowingVectorEnv",
    "StepResult",
]

if TYPE_CHECKING:
    from mobile_envs.rendering.batch import VectorRenderer

#: What ``step`` returns: observations, rewards, terminated, truncated, infos.
StepResult = tuple[
    NDArray[np.float32], NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_], dict[str, Any]
]

#: The autoreset modes the vector env runs.
AUTORESET_MODES = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP, AutoresetMode.DISABLED)


class PathFollowingVectorEnv(VectorEnv):
    """N robots following paths, with the observations, rewards, terminations and info of N
    :class:`~mobile_envs.envs.path_following.PathFollowingEnv` seeded alike, bit for bit.

    Every id registers this class as its ``vector_entry_point``::

        envs = gym.make_vec("mobile_envs/DiffDrive-Segments-v0", num_envs=1024)

    The arguments are ``num_envs`` and those of
    :class:`~mobile_envs.envs.path_following.PathFollowingEnv`
    (``model``, ``paths`` and its keyword-only settings, ``localization`` and
    ``localization_params`` among them), which it validates the same way.
    The step path holds no per-robot Python loop: the kinematics, path projection,
    observation and reward of all robots are compiled kernels over arrays of N. Only robots
    that reset (at most the ones whose episode ended) are visited one by one, to draw
    their next track from their own RNG.

    ``num_threads`` (1; :attr:`mobile_envs.sim.config.CoreConfig.num_threads`) splits the robots
    of the step, observation and maze-sensing kernels over that many threads, at most numba's
    ``NUMBA_NUM_THREADS``. Every result is the same, bit for bit, whatever it is. It pays with
    TBB (the ``parallel`` extra), from a few hundred robots on cores that nothing else keeps
    busy: the kernels then run on TBB's threads, else on numba's workqueue, which takes about
    100 us to start each kernel and is slower than one thread at N = 1024. A
    ``NUMBA_THREADING_LAYER`` the user sets wins (numba's OpenMP beside torch's made torch in
    the same process 80 times slower). With ``num_threads=1`` numba starts no threads at all.

    ``autoreset_mode`` (``metadata["autoreset_mode"]`` says which is active), as in
    :class:`gymnasium.vector.SyncVectorEnv`:

    - ``AutoresetMode.NEXT_STEP`` (Gymnasium's default): the step after a robot's episode
      ends resets it, returning its first observation with reward 0 and both flags False.
      ``infos`` hold the step keys of :class:`~mobile_envs.envs.path_following.PathFollowingEnv`
      (``cross_track_error``, ..., ``pose`` (N, 3)) every step, and its episode metrics for
      the robots whose episode just ended, each with its ``_key`` mask.
    - ``AutoresetMode.SAME_STEP`` (SB3's convention): a robot whose episode ends is reset in
      the same step; the observation and step info are the new episode's first, and the
      last ones are in ``infos["final_obs"]`` (an object array, None where no episode
      ended) and ``infos["final_info"]`` (step keys and episode metrics), masked by
      ``infos["_final_obs"]``.
    - ``AutoresetMode.DISABLED``: nothing restarts by itself; infos as in ``NEXT_STEP``.
      Restart the robots whose episode ended with ``reset(options={"reset_mask": ended})``
      before the next step: stepping a robot whose episode ended raises ``RuntimeError``.

    ``reset(options={"reset_mask": mask})`` (a bool array of shape (N,), at least one True)
    restarts only the robots where ``mask`` is True, as :class:`gymnasium.vector.SyncVectorEnv`
    does: seeds apply to them alone, the others keep their state and pending autoreset. It
    returns every robot's observation and infos for the restarted robots (zeros elsewhere,
    each key with its ``_key`` mask). The other options (``path``, ``start_pose``) apply to
    the restarted robots.

    ``reset(seed=s)`` seeds robot i with ``s + i``, ``reset(seed=[s0, s1, ...])`` each robot
    with its own seed (None: leave its generator as it is), as
    :class:`gymnasium.vector.SyncVectorEnv` does; seeds are non-negative integers.
    ``max_episode_steps`` (what ``gym.make_vec`` passes on) truncates episodes after that
    many steps, like ``step_limit``; the smaller of the two holds.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": ["human", "rgb_array"]}

    def __init__(
        self,
        num_envs: int,
        model: str | KinematicModel = "diff_drive",
        paths: PathsArgument = "segments",
        *,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        max_episode_steps: int | None = None,
        render_mode: str | None = None,
        **settings: Any,
    ):
        num_envs = as_count("num_envs", num_envs)
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            mode = None
        if mode not in AUTORESET_MODES:
            raise ValueError(
                f"autoreset_mode must be one of {[m.value for m in AUTORESET_MODES]}, "
                f"got {autoreset_mode!r}"
            )
        self.autoreset_mode = mode
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, "
                f"got {render_mode!r}"
            )
        self.num_envs = int(num_envs)
        if max_episode_steps is not None:
            max_episode_steps = as_count("max_episode_steps", max_episode_steps)
            own_limit = settings.get("step_limit")
            settings["step_limit"] = (
                max_episode_steps
                if own_limit is None
                else min(as_count("step_limit", own_limit), max_episode_steps)
            )
        self.config = make_core_config(model, paths, **settings)
        self.core = PathFollowingCore(self.config, self.num_envs)
        self.model = self.config.model
        self.dt = self.config.dt
        self.observation_names = self.config.observation_names
        self.single_observation_space = observation_space_for(self.config)
        self.single_action_space = action_space_for(self.config)
        self.metadata["render_fps"] = round(1.0 / self.dt)
        self.render_mode = render_mode
        self._renderer: VectorRenderer | None = None
        self.rngs = [seeding.np_random()[0] for _ in range(self.num_envs)]
        self._needs_reset = np.zeros(self.num_envs, dtype=bool)
        self._was_reset = False

    # The batched spaces hold (N, D) bounds, ~0.5 KB a robot: built on first use only.
    @functools.cached_property
    def observation_space(self) -> spaces.Space:  # type: ignore[override]
        return batch_space(self.single_observation_space, self.num_envs)

    @functools.cached_property
    def action_space(self) -> spaces.Space:  # type: ignore[override]
        return batch_space(self.single_action_space, self.num_envs)

    # ------------------------------------------------------------------ documented state

    @property
    def tracks(self) -> list[Track]:
        """Each robot's current track."""
        if not self._was_reset:
            raise RuntimeError("call reset() before reading the tracks")
        return [track for track in self.core.tracks if track is not None]

    @property
    def paths(self) -> list[Path]:
        """Each robot's current path."""
        return [track.path for track in self.tracks]

    @property
    def states(self) -> NDArray[np.float64]:
        """(N, k) model states."""
        return self.core.state.copy()

    @property
    def poses(self) -> NDArray[np.float64]:
        """(N, 3) poses (x, y, heading)."""
        return self.core.state[:, :3].copy()

    @property
    def believed_states(self) -> NDArray[np.float64]:
        """(N, k) what the robots believe their states are, as controllers on board read them
        (see :attr:`mobile_envs.envs.path_following.PathFollowingEnv.believed_state`); equal to
        :attr:`states` with ``localization="exact"``."""
        return believed_states(self.core.localization, self.core.estimate, self.core.state)

    @property
    def elapsed_steps(self) -> NDArray[np.int64]:
        """(N,) steps taken in each robot's current episode (0 right after its reset)."""
        return self.core.steps.copy()

    def action_from_inputs(self, inputs: NDArray[np.float64]) -> NDArray[np.float32]:
        """Normalized actions that apply native ``inputs`` (N, m), clipped to the limits."""
        return self.core.actions_from_inputs(np.asarray(inputs, np.float64)).astype(np.float32)

    # One frame for the whole batch, where Gymnasium's type says one per env: at N = 1024,
    # N frames would cost N times the drawing and ~1 GB a step.
    def render(self) -> NDArray[np.uint8] | None:  # type: ignore[override]
        """One frame of the whole batch (see :mod:`mobile_envs.rendering.batch`): a tile per
        fixed track with every robot on it, or the first robots' own tracks for generated
        path sets. ``"rgb_array"``: the frame, ``(600, 600, 3)`` uint8; ``"human"``: draws
        it in a window (call it after each step) and returns None."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode to make_vec()")
            return None
        if not self._was_reset:
            raise RuntimeError("call reset() before render()")
        from mobile_envs.rendering.batch import VectorRenderer

        if self._renderer is None:
            self._renderer = VectorRenderer(
                self.render_mode,
                fps=self.metadata["render_fps"],
                fixed_tracks=self.config.path_set.tracks,
                robot_radius=self.config.robot_radius,
                goal_radius=self.config.goal_radius,
                max_cross_track=self.config.max_cross_track,
            )
        return self._renderer.render(self.core.tracks, self.core.state[:, :3])

    def close_extras(self, **kwargs: Any) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # ------------------------------------------------------------------ vector API

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        # Everything is validated before any robot's generator or state changes.
        seeds = self._robot_seeds(seed)
        mask, options = _split_reset_mask(options, self.num_envs)
        track, start_pose = parse_reset_options(options)
        if mask is None:
            indices = np.arange(self.num_envs)
        elif not self._was_reset:
            raise RuntimeError("call reset() without a reset_mask first: no robot has started")
        else:
            indices = np.flatnonzero(mask)
        for index in indices:
            if seeds[index] is not None or not self._was_reset:
                self.rngs[index] = seeding.np_random(seeds[index])[0]
        self.core.reset_robots(indices, self.rngs, track=track, start_pose=start_pose)
        observations = self.core.observe()
        self._needs_reset[indices] = False
        self._was_reset = True
        infos = batch_step_info(self.core)
        infos.update(batch_plant_info(self.core, np.ones(self.num_envs, dtype=bool)))
        return observations, infos if mask is None else _only_robots(infos, mask)

    def restart(self, indices: NDArray[np.int64]) -> None:
        """Start new episodes for robots ``indices``, each drawing from its own RNG; their
        first observations come from ``core.observe``."""
        self.core.reset_robots(indices, self.rngs)

    def _robot_seeds(self, seed: int | Sequence[int | None] | None) -> list[int | None]:
        """Each robot's seed (None: keep its generator), validated."""
        if seed is None:
            return [None] * self.num_envs
        if _is_seed(seed):
            return [int(seed) + index for index in range(self.num_envs)]
        if not is_list(seed):
            raise ValueError(
                f"seed must be None, a non-negative integer or a list of {self.num_envs} of "
                f"them (None for robots to leave as they are), got {seed!r}"
            )
        seeds = list(seed)
        if len(seeds) != self.num_envs:
            raise ValueError(f"reset got {len(seeds)} seeds for {self.num_envs} environments")
        for index, robot_seed in enumerate(seeds):
            if robot_seed is not None and not _is_seed(robot_seed):
                raise ValueError(
                    f"seed[{index}] must be None or a non-negative integer, got {robot_seed!r}"
                )
        return [None if robot_seed is None else int(robot_seed) for robot_seed in seeds]

    def step(self, actions: NDArray[np.float32]) -> StepResult:
        if not self._was_reset:
            raise RuntimeError("call reset() before step()")
        clipped = validate_actions(actions, (self.num_envs, self.model.input_dim))
        if self.autoreset_mode == AutoresetMode.SAME_STEP:
            result = self._step_same_step(clipped)
        else:
            result = self._step_restarting_pending(clipped)
        if self.render_mode == "human":
            self.render()
        return result

    def _step_restarting_pending(self, clipped: NDArray[np.float64]) -> StepResult:
        """A step in which robots whose episode ended at the last step restart (next-step
        autoreset), or, with autoreset disabled, no robot may be pending."""
        core = self.core
        if self.autoreset_mode == AutoresetMode.DISABLED and self._needs_reset.any():
            raise RuntimeError(
                f"the episodes of robots {np.flatnonzero(self._needs_reset).tolist()} have "
                f"ended and autoreset_mode is DISABLED: restart them with "
                f"reset(options={{'reset_mask': mask}}) before the next step"
            )
        restarting = np.flatnonzero(self._needs_reset)
        active = np.flatnonzero(~self._needs_reset) if len(restarting) else None
        core.step(clipped, self.rngs, active)
        if len(restarting):
            # A restart zeroes the robot's reward and flags: it reads as a fresh env's reset.
            self.restart(restarting)
        observations = core.observe()  # once for every robot, restarted or not
        rewards, terminated, truncated = self._outcome()
        ended = terminated | truncated
        infos = batch_step_info(core)
        infos.update(batch_episode_info(core, ended))
        if len(restarting):
            infos.update(batch_plant_info(core, self._needs_reset))
        self._needs_reset = ended
        return observations, rewards, terminated, truncated, infos

    def _outcome(self) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_]]:
        """Copies of the step's rewards and flags (the next step overwrites the core's)."""
        core = self.core
        return core.reward.copy(), core.terminated.copy(), core.truncated.copy()

    def _step_same_step(self, clipped: NDArray[np.float64]) -> StepResult:
        """A step in which robots whose episode ends restart at once."""
        core = self.core
        core.step(clipped, self.rngs)
        observations = core.observe()
        rewards, terminated, truncated = self._outcome()
        ended = np.flatnonzero(terminated | truncated)
        if not len(ended):
            return observations, rewards, terminated, truncated, batch_step_info(core)
        mask = terminated | truncated
        final_info = _only_robots(batch_step_info(core), mask)
        final_info.update(batch_episode_info(core, mask))
        # As Gymnasium's SyncVectorEnv gives them: an object array, None where no episode ended.
        final_observations = np.full(self.num_envs, None, dtype=object)
        for index in ended:
            final_observations[index] = observations[index].copy()
        self.restart(ended)
        observations[ended] = core.observe(ended)
        infos = batch_step_info(core)
        infos.update(batch_plant_info(core, mask))
        infos.update(
            final_obs=final_observations,
            _final_obs=mask.copy(),
            final_info=final_info,
            _final_info=mask.copy(),
        )
        return observations, rewards, terminated, truncated, infos


def _is_seed(seed: Any) -> TypeGuard[int | np.integer]:
    """Whether ``seed`` is a non-negative Python or numpy integer (not a bool)."""
    return isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and bool(seed >= 0)


def _split_reset_mask(options: Any, num_envs: int) -> tuple[NDArray[np.bool_] | None, Any]:
    """The ``reset_mask`` of the reset options (None: every robot) and the other options,
    without changing the caller's dict."""
    if not isinstance(options, Mapping) or "reset_mask" not in options:
        return None, options
    requested = options["reset_mask"]
    try:
        mask = np.asarray(requested)
    except (TypeError, ValueError):  # ragged nesting, objects numpy cannot read
        mask = np.empty(0)
    if mask.shape != (num_envs,) or mask.dtype != np.bool_:
        raise ValueError(
            f"reset_mask must be a bool array of shape ({num_envs},), got {requested!r}"
        )
    if not mask.any():
        raise ValueError("reset_mask must be True for at least one robot, got all False")
    return mask.copy(), {key: value for key, value in options.items() if key != "reset_mask"}


def _only_robots(infos: dict[str, Any], mask: NDArray[np.bool_]) -> dict[str, Any]:
    """``infos`` for the robots where ``mask`` is True, as Gymnasium's vector envs give a
    subset: zeros elsewhere, and every ``_key`` mask equal to ``mask``."""
    kept: dict[str, Any] = {}
    for key, value in infos.items():
        if key.startswith("_"):
            kept[key] = mask.copy()
        else:
            rows = mask.reshape(-1, *[1] * (value.ndim - 1))
            kept[key] = np.where(rows, value, np.zeros_like(value))
    return kept

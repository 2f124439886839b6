"""PathFollowingVectorEnv: N robots stepped together by the batched core."""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from mobile_envs.core import PathFollowingCore
from mobile_envs.env import (
    action_space_for,
    make_core_config,
    observation_space_for,
    parse_reset_options,
    validate_actions,
)
from mobile_envs.kinematics import KinematicModel
from mobile_envs.paths import Path, PathSet, Track

#: Info keys present for every robot at every step.
STEP_INFO_KEYS = (
    "cross_track_error",
    "heading_error",
    "progress",
    "is_success",
    "collision",
    "off_track",
    "stalled",
)
#: Info keys present only for robots whose episode ended at this step.
EPISODE_INFO_KEYS = (
    "mean_abs_cte",
    "max_abs_cte",
    "rms_cte",
    "episode_time",
    "distance_travelled",
    "completed",
)


class PathFollowingVectorEnv(VectorEnv):
    """N robots following paths, with the observations, rewards, terminations and info of N
    :class:`~mobile_envs.env.PathFollowingEnv` seeded alike, bit for bit.

    Every id registers this class as its ``vector_entry_point``::

        envs = gym.make_vec("mobile_envs/DiffDrive-Segments-v0", num_envs=1024)

    The arguments are ``num_envs`` and those of :class:`~mobile_envs.env.PathFollowingEnv`
    (``model``, ``paths`` and its keyword-only settings), which it validates the same way.
    The step path holds no per-robot Python loop: the kinematics, path projection,
    observation and reward of all robots are compiled kernels over arrays of N. Only robots
    that reset (at most the ones whose episode ended) are visited one by one, to draw
    their next track from their own RNG.

    Autoreset is Gymnasium's default, ``AutoresetMode.NEXT_STEP``: the step after a robot's
    episode ends resets it, returning its first observation with reward 0 and both flags
    False. ``reset(seed=s)`` seeds robot i with ``s + i``, ``reset(seed=[s0, s1, ...])`` each
    robot with its own seed, as :class:`gymnasium.vector.SyncVectorEnv` does.

    ``infos``: ``cross_track_error``, ``heading_error``, ``progress``, ``is_success``,
    ``collision``, ``off_track``, ``stalled`` and ``pose`` (N, 3) every step; the episode metrics of
    :class:`~mobile_envs.env.PathFollowingEnv` for the robots whose episode just ended, each
    with its ``_key`` mask.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int,
        model: str | KinematicModel = "diff_drive",
        paths: str | Path | Track | Sequence[Path | Track] | PathSet = "segments",
        *,
        render_mode: str | None = None,
        **settings: Any,
    ):
        if int(num_envs) != num_envs or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        if render_mode is not None:
            raise ValueError(
                "the vector env does not render; render a single env "
                "(gym.make(..., render_mode='rgb_array')) instead"
            )
        self.num_envs = int(num_envs)
        self.config = make_core_config(model, paths, **settings)
        self.core = PathFollowingCore(self.config, self.num_envs)
        self.model = self.config.model
        self.dt = self.config.dt
        self.observation_names = self.config.observation_names
        self.single_observation_space = observation_space_for(self.config)
        self.single_action_space = action_space_for(self.config)
        self.render_mode = None
        self.rngs = [seeding.np_random()[0] for _ in range(self.num_envs)]
        self._needs_reset = np.zeros(self.num_envs, dtype=bool)
        self._was_reset = False

    # The batched spaces hold (N, D) bounds, ~0.5 KB a robot: built on first use only.
    @functools.cached_property
    def observation_space(self) -> spaces.Box:
        return batch_space(self.single_observation_space, self.num_envs)

    @functools.cached_property
    def action_space(self) -> spaces.Box:
        return batch_space(self.single_action_space, self.num_envs)

    # ------------------------------------------------------------------ documented state

    @property
    def tracks(self) -> list[Track]:
        """Each robot's current track."""
        if not self._was_reset:
            raise RuntimeError("call reset() before reading the tracks")
        return list(self.core.tracks)

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
    def elapsed_steps(self) -> NDArray[np.int64]:
        """(N,) steps taken in each robot's current episode (0 right after its reset)."""
        return self.core.steps.copy()

    def action_from_inputs(self, inputs: NDArray[np.float64]) -> NDArray[np.float32]:
        """Normalized actions that apply native ``inputs`` (N, m), clipped to the limits."""
        return self.core.actions_from_inputs(np.asarray(inputs, np.float64)).astype(np.float32)

    # ------------------------------------------------------------------ vector API

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        for index, robot_seed in enumerate(self._robot_seeds(seed)):
            if robot_seed is not None or not self._was_reset:
                self.rngs[index] = seeding.np_random(robot_seed)[0]
        track, start_pose = parse_reset_options(options)
        self.core.reset_robots(
            np.arange(self.num_envs), self.rngs, track=track, start_pose=start_pose
        )
        observations = self.core.observe()
        self._needs_reset[:] = False
        self._was_reset = True
        return observations, self._step_infos()

    def restart(self, indices: NDArray[np.int64]) -> None:
        """Start new episodes for robots ``indices``, each drawing from its own RNG; their
        first observations come from ``core.observe``."""
        self.core.reset_robots(indices, [self.rngs[index] for index in indices])

    def _robot_seeds(self, seed: int | Sequence[int | None] | None) -> list[int | None]:
        if seed is None:
            return [None] * self.num_envs
        if isinstance(seed, (int, np.integer)):
            return [int(seed) + index for index in range(self.num_envs)]
        seeds = list(seed)
        if len(seeds) != self.num_envs:
            raise ValueError(f"reset got {len(seeds)} seeds for {self.num_envs} environments")
        return seeds

    def step(
        self, actions: NDArray[np.float32]
    ) -> tuple[
        NDArray[np.float32],
        NDArray[np.float64],
        NDArray[np.bool_],
        NDArray[np.bool_],
        dict[str, Any],
    ]:
        if not self._was_reset:
            raise RuntimeError("call reset() before step()")
        clipped = validate_actions(actions, (self.num_envs, self.model.input_dim))
        restarting = np.flatnonzero(self._needs_reset)
        core = self.core
        core.step(clipped)
        if len(restarting):
            # A restart zeroes the robot's reward and flags: it reads as a fresh env's reset.
            self.restart(restarting)
        observations = core.observe()  # once for every robot, restarted or not
        rewards, terminated, truncated = (
            core.reward.copy(),
            core.terminated.copy(),
            core.truncated.copy(),
        )
        infos = self._step_infos()
        self._add_episode_infos(infos, terminated | truncated, core.success)
        self._needs_reset = terminated | truncated
        return observations, rewards, terminated, truncated, infos

    # ------------------------------------------------------------------ infos

    def _step_infos(self) -> dict[str, Any]:
        core, everyone = self.core, np.ones(self.num_envs, dtype=bool)
        infos: dict[str, Any] = {
            "cross_track_error": core.cross_track_error.copy(),
            "heading_error": core.heading_error.copy(),
            "progress": np.clip(core.arc_length / core.path_length, 0.0, 1.0),
            "is_success": core.success.copy(),
            "collision": core.collision.copy(),
            "off_track": core.off_track.copy(),
            "stalled": core.stalled.copy(),
            "pose": core.state[:, :3].copy(),
        }
        for key in list(infos):
            infos[f"_{key}"] = everyone
        return infos

    def _add_episode_infos(
        self, infos: dict[str, Any], ended: NDArray[np.bool_], success: NDArray[np.bool_]
    ) -> None:
        if not ended.any():
            return
        core = self.core
        steps = np.maximum(core.steps, 1)
        values = {
            "mean_abs_cte": core.sum_abs_cte / steps,
            "max_abs_cte": core.max_abs_cte.copy(),
            "rms_cte": np.sqrt(core.sum_sq_cte / steps),
            "episode_time": core.steps * self.dt,
            "distance_travelled": core.distance.copy(),
            "completed": success & ended,
        }
        for key in EPISODE_INFO_KEYS:
            infos[key] = np.where(ended, values[key], np.zeros_like(values[key]))
            infos[f"_{key}"] = ended.copy()

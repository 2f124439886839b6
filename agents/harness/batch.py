"""Every episode of an (agent, env) pair at once, in one vector env.

Episode i starts on robot i with seed ``seed + i``, as the single env's ``reset(seed=seed +
i)`` starts it (the vector env equals N single envs bit for bit), so the episodes are those
of the one-at-a-time loop (:func:`agents.harness.evaluate.run_episode`). With more episodes
than robots, a robot whose episode ends takes the next seed; once no seed is left it waits
(it drives on under zero actions, unmeasured) until the last episode ends. The agent acts for
every robot still measured in one call per step (:class:`~agents.controllers.batch.BatchAgent`):
a classical agent's compiled law, or a policy's batched ``predict``.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.controllers.base import BoundAgent, ClassicalAgent
from agents.controllers.batch import BatchAgent, Indices
from agents.harness.records import EpisodeRecord
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.tracks.sets import Track

#: The most robots one evaluation steps together; more episodes refill them.
MAX_ROBOTS = 1024


#: The fewest rows a policy predicts at once: torch gives a row the same bits in any batch of
#: at least this many (on one thread; as measured with MKL's kernels), so a policy's episodes
#: do not depend on how many others still run beside them.
MIN_POLICY_BATCH = 8


class PolicyBatchAgent:
    """A policy with Stable-Baselines3's batched ``predict`` acting for the robots of a
    vector env: a :class:`~agents.controllers.batch.BatchAgent`.

    An SB3 model predicts through its policy's ``_predict``, the call ``predict`` makes, after
    switching the policy to evaluation mode once (``predict`` switches it on every call, which
    costs more than predicting for a thousand robots); anything else through ``predict``.
    Fewer than :data:`MIN_POLICY_BATCH` rows are padded with zeros.

    :param policy: an SB3 model (or anything whose ``predict`` takes (n, D) observations and
        an (n,) ``episode_start``)
    :param num_robots: the vector env's robots
    """

    def __init__(self, policy: Any, num_robots: int):
        self.policy = policy
        self.episode_starts = np.ones(num_robots, dtype=bool)
        self._sb3_policy = _sb3_policy(policy)
        if self._sb3_policy is not None:
            self._sb3_policy.set_training_mode(False)

    def reset(self, robots: Indices, tracks: Sequence[Track]) -> None:
        self.episode_starts[robots] = True

    def act(
        self,
        robots: Indices,
        observations: NDArray[np.float32],
        believed_states: NDArray[np.float64],
    ) -> NDArray[np.float32]:
        count = len(robots)
        rows = max(count, MIN_POLICY_BATCH)
        batch = np.zeros((rows, observations.shape[1]), dtype=observations.dtype)
        batch[:count] = observations[robots]
        starts = np.zeros(rows, dtype=bool)
        starts[:count] = self.episode_starts[robots]
        self.episode_starts[robots] = False
        if self._sb3_policy is None:
            actions, _ = self.policy.predict(batch, episode_start=starts, deterministic=True)
        else:
            actions = _sb3_predict(self._sb3_policy, batch)
        return np.asarray(actions, dtype=np.float32).reshape(rows, -1)[:count]


def _sb3_policy(model: Any) -> Any:
    """The Stable-Baselines3 policy (a ``BasePolicy``) of an SB3 model, or None."""
    if "stable_baselines3" not in sys.modules:  # no SB3 model exists without it
        return None
    from stable_baselines3.common.policies import BasePolicy

    policy = getattr(model, "policy", None)
    return policy if isinstance(policy, BasePolicy) else None


def _sb3_predict(policy: Any, observations: NDArray[np.float32]) -> NDArray[np.float32]:
    """``policy.predict(observations, deterministic=True)[0]`` for a batch of observations,
    the policy already in evaluation mode: the same operations, on one torch thread.

    A policy's layers are too small for torch's threads to pay: on cores other processes
    keep busy, two threads made a step of 50 robots 20 to 50 times slower than one.
    """
    import torch
    from gymnasium import spaces

    tensor, _ = policy.obs_to_tensor(observations)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        with torch.no_grad():
            actions = policy._predict(tensor, deterministic=True)
    finally:
        torch.set_num_threads(threads)
    actions = actions.cpu().numpy().reshape((-1, *policy.action_space.shape))
    if isinstance(policy.action_space, spaces.Box):
        if policy.squash_output:
            return policy.unscale_action(actions)
        return np.clip(actions, policy.action_space.low, policy.action_space.high)
    return actions


def batch_agent_for(agent: Any, envs: PathFollowingVectorEnv) -> BatchAgent:
    """The :class:`~agents.controllers.batch.BatchAgent` that drives ``envs`` for ``agent``.

    :param agent: a classical agent (bound or not) or a policy with ``predict``
    :raises TypeError: for anything else
    """
    if isinstance(agent, BoundAgent):
        agent = agent.agent
    if isinstance(agent, ClassicalAgent):
        return agent.batch_agent(envs)
    if hasattr(agent, "predict"):
        return PolicyBatchAgent(agent, envs.num_envs)
    raise TypeError(
        f"cannot drive a vector env with {agent!r}: it has neither batch() nor predict()"
    )


def vector_env_like(
    env: PathFollowingEnv, num_envs: int, **overrides: Any
) -> PathFollowingVectorEnv:
    """A vector env of ``num_envs`` robots with the settings of the single env ``env``: its
    robot i equals ``env`` reset with the same seed, bit for bit.

    :param env: an unwrapped single env
    :param overrides: settings to take instead of ``env``'s (a policy's own sensors), under
        the names the environments take them by
    """
    return PathFollowingVectorEnv(num_envs, **{**env_settings(env), **overrides})


def env_settings(env: PathFollowingEnv) -> dict[str, Any]:
    """The keyword arguments that make an env with the settings of the single env ``env``:
    every setting :class:`~mobile_envs.sim.config.CoreConfig` holds, validated as it is,
    under the name the environments take it by."""
    config = env.config
    settings = {
        _ARGUMENT_NAMES.get(item.name, item.name): getattr(config, item.name)
        for item in dataclasses.fields(config)
        if item.init
    }
    if settings["localization"] is None:
        settings["localization"] = "exact"
    return settings


#: The environments' argument for each CoreConfig field that has another name.
_ARGUMENT_NAMES = {"path_set": "paths", "reward": "reward_weights"}


class EpisodeLog:
    """Every robot's poses and cross-track errors, from the start of the oldest episode still
    measured: row t holds the poses after the t-th step of the evaluation (a robot's start
    pose in the row its episode starts at) and the errors of that step.

    :param num_robots: N
    """

    def __init__(self, num_robots: int, capacity: int = 256):
        self.poses = np.empty((capacity, num_robots, 3))
        self.errors = np.empty((capacity, num_robots))
        self.now = 0
        #: (N,) the row each robot's current episode starts at.
        self.starts = np.zeros(num_robots, dtype=np.int64)

    def start(self, robots: Indices, poses: NDArray[np.float64]) -> None:
        """Robots ``robots`` start episodes at the poses ``poses[robots]`` ((N, 3))."""
        self.poses[self.now, robots] = poses[robots]
        self.starts[robots] = self.now

    def append(
        self,
        poses: NDArray[np.float64],
        errors: NDArray[np.float64],
        measured: NDArray[np.bool_],
    ) -> None:
        """One step of every robot: (N, 3) poses and (N,) cross-track errors; ``measured``
        says whose episodes still count (the others' rows may be dropped)."""
        if self.now + 1 == len(self.poses):
            self._make_room(measured)
        self.now += 1
        self.poses[self.now] = poses
        self.errors[self.now] = errors

    def episode(self, robot: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Robot ``robot``'s current episode: its (T + 1, 3) trajectory and (T,) errors."""
        first = self.starts[robot]
        trajectory = self.poses[first : self.now + 1, robot].copy()
        return trajectory, self.errors[first + 1 : self.now + 1, robot]

    def _make_room(self, measured: NDArray[np.bool_]) -> None:
        """Drop the rows no measured episode needs; grow when that frees less than half."""
        oldest = int(self.starts[measured].min()) if measured.any() else self.now
        kept = slice(oldest, self.now + 1)
        capacity = len(self.poses)
        if oldest < capacity // 2:
            capacity *= 2
        poses = np.empty((capacity, *self.poses.shape[1:]))
        errors = np.empty((capacity, self.errors.shape[1]))
        size = self.now + 1 - oldest
        poses[:size], errors[:size] = self.poses[kept], self.errors[kept]
        self.poses, self.errors = poses, errors
        self.now -= oldest
        self.starts = np.maximum(self.starts - oldest, 0)


def run_episodes(
    agent: Any,
    envs: PathFollowingVectorEnv,
    episodes: int,
    seed: int,
    check_stop: Callable[[], None] | None = None,
    step_limit: int | None = None,
) -> list[EpisodeRecord]:
    """Run ``episodes`` episodes of ``agent`` on the robots of ``envs`` (next-step
    autoreset, at most ``episodes`` robots), episode i from seed ``seed + i``.

    :param agent: a classical agent (bound or not) or a policy with batched ``predict``
    :param check_stop: called before every step; raises to stop
    :param step_limit: episodes end after this many steps, as under Gymnasium's
        ``TimeLimit`` (the env's own limit holds too)
    :return: one record per episode, in seed order
    """
    count = envs.num_envs
    if not 1 <= count <= episodes:
        raise ValueError(f"need 1 <= num_envs <= episodes, got {count} and {episodes}")
    driver = batch_agent_for(agent, envs)
    robots = np.arange(count, dtype=np.int64)
    observations, infos = envs.reset(seed=[seed + index for index in range(count)])
    driver.reset(robots, envs.tracks)
    log = EpisodeLog(count)
    log.start(robots, infos["pose"])
    episode_of = robots.copy()
    steps = np.zeros(count, dtype=np.int64)
    measured = np.ones(count, dtype=bool)
    actions = np.zeros((count, envs.model.input_dim), dtype=np.float32)
    records: list[EpisodeRecord | None] = [None] * episodes
    next_episode = count
    while measured.any():
        if check_stop is not None:
            check_stop()
        active = np.flatnonzero(measured)
        actions[active] = driver.act(active, observations, envs.believed_states)
        observations, _, terminated, truncated, infos = envs.step(actions)
        log.append(infos["pose"], infos["cross_track_error"], measured)
        steps[active] += 1
        ended = measured & (terminated | truncated)
        if step_limit is not None:
            ended |= measured & (steps >= step_limit)
        if not ended.any():
            continue
        ended_robots = np.flatnonzero(ended)
        tracks = envs.tracks
        for robot in ended_robots.tolist():
            trajectory, errors = log.episode(robot)
            last_info = {key: infos[key][robot] for key in ("is_success", "collision", "off_track")}
            records[episode_of[robot]] = EpisodeRecord.measured(
                errors, trajectory, last_info, envs.dt, tracks[robot]
            )
        refilled = ended_robots[: episodes - next_episode]
        waiting = ended_robots[len(refilled) :]
        measured[waiting] = False
        actions[waiting] = 0.0
        if len(refilled):
            seeds: list[int | None] = [None] * count
            for robot in refilled.tolist():
                seeds[robot] = seed + next_episode
                episode_of[robot] = next_episode
                next_episode += 1
            mask = np.zeros(count, dtype=bool)
            mask[refilled] = True
            restarted, infos = envs.reset(seed=seeds, options={"reset_mask": mask})
            observations[refilled] = restarted[refilled]
            tracks = envs.tracks
            driver.reset(refilled, [tracks[robot] for robot in refilled.tolist()])
            log.start(refilled, infos["pose"])
            steps[refilled] = 0
    assert all(record is not None for record in records)
    return records  # type: ignore[return-value]

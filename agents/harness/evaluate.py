"""One loop that runs any agent on an env and measures it.

Classical agents (:mod:`agents.controllers.pure_pursuit`, :mod:`agents.controllers.guidance`) and
Stable-Baselines3 models go through the same ``predict`` call and the same episodes: episode i
resets with seed ``seed + i``, so every agent compared on an env meets the same paths from the same
start poses. The metrics are those the env reports at an episode's end, computed from the same
per-step cross-track errors, so training logs, evaluation and comparison all measure alike.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

import mobile_envs  # noqa: F401  (registers the env ids)
from mobile_envs.world.maze import Maze
from mobile_envs.world.paths import Path


@dataclass
class EpisodeRecord:
    """What one episode did.

    :param completed: whether the robot reached the goal
    :param mean_abs_cte: mean |cross-track error| over the episode's steps (m)
    :param max_abs_cte: largest |cross-track error| (m)
    :param rms_cte: root mean square cross-track error (m)
    :param time: the episode's duration (s)
    :param time_to_goal: the time to reach the goal (s), NaN if it was not reached
    :param collision: whether it ended on a maze wall
    :param off_track: whether it ended beyond the env's ``max_cross_track``
    :param steps: the number of env steps
    :param trajectory: (T + 1, 3) poses (x, y, heading), from the start pose to the last one
    :param path: the episode's path
    :param maze: the maze whose walls the robot drove between, None in open space
    """

    completed: bool
    mean_abs_cte: float
    max_abs_cte: float
    rms_cte: float
    time: float
    time_to_goal: float
    collision: bool
    off_track: bool
    steps: int
    trajectory: NDArray[np.float64] = field(repr=False)
    path: Path = field(repr=False)
    maze: Maze | None = field(default=None, repr=False)


@dataclass
class EvaluationResult:
    """The episodes of one agent on one env, and their summary.

    :param episodes: one record per episode, in seed order
    """

    episodes: list[EpisodeRecord]

    @property
    def summary(self) -> dict[str, float]:
        """Aggregates over the episodes, each episode weighted equally.

        - ``completion_rate``, ``collision_rate``, ``off_track_rate``: fractions of episodes
        - ``mean_abs_cte``: mean of the episodes' mean |cte| (m)
        - ``max_abs_cte``: largest |cte| of any episode (m)
        - ``rms_cte``: sqrt of the mean of the episodes' mean squared cte (m)
        - ``mean_time``: mean time to goal (s) over the completed episodes; NaN if none was
        - ``episodes``: the number of episodes
        """
        records = self.episodes
        if not records:
            raise ValueError("no episodes to summarize")
        times = [record.time_to_goal for record in records if record.completed]
        return {
            "completion_rate": float(np.mean([record.completed for record in records])),
            "mean_abs_cte": float(np.mean([record.mean_abs_cte for record in records])),
            "max_abs_cte": float(np.max([record.max_abs_cte for record in records])),
            "rms_cte": float(np.sqrt(np.mean([record.rms_cte**2 for record in records]))),
            "mean_time": float(np.mean(times)) if times else math.nan,
            "collision_rate": float(np.mean([record.collision for record in records])),
            "off_track_rate": float(np.mean([record.off_track for record in records])),
            "episodes": len(records),
        }


def bind_agent(agent: Any, env: gym.Env) -> Any:
    """An agent with ``predict`` for ``env``.

    :param agent: an object with ``bind(env)`` (a classical agent, bound or not), a class or a
        zero-argument factory that makes one, or anything with ``predict`` (an SB3 model)
    """
    if isinstance(agent, type):
        return bind_agent(agent(), env)
    if hasattr(agent, "bind"):
        return agent.bind(env)
    if hasattr(agent, "predict"):
        return agent
    if callable(agent):
        return bind_agent(agent(), env)
    raise TypeError(f"cannot drive an env with {agent!r}: it has neither bind() nor predict()")


def run_episode(
    agent: Any, env: gym.Env, seed: int, check_stop: Callable[[], None] | None = None
) -> EpisodeRecord:
    """Run one episode of a bound ``agent`` (see :func:`bind_agent`) from ``reset(seed=seed)``.

    ``check_stop`` is called before every step; it raises to stop the episode (a stop
    signal: :meth:`agents.interrupts.StopRequests.raise_if_requested`).

    The metrics come from the per-step ``info`` (the cross-track error after every step), as
    the env computes its own end-of-episode metrics, so an episode cut short by an outer
    wrapper (``gym.make(..., max_episode_steps=...)`` adds a TimeLimit) is measured too.
    """
    observation, info = env.reset(seed=seed)
    unwrapped: Any = env.unwrapped  # a PathFollowingEnv: its track and dt are documented
    track = unwrapped.track
    poses, cross_track_errors = [info["pose"]], []
    episode_start = True
    while True:
        if check_stop is not None:
            check_stop()
        action, _ = agent.predict(
            observation, episode_start=np.array([episode_start]), deterministic=True
        )
        observation, _, terminated, truncated, info = env.step(action)
        poses.append(info["pose"])
        cross_track_errors.append(info["cross_track_error"])
        episode_start = False
        if terminated or truncated:
            break
    errors = np.abs(cross_track_errors)
    completed = bool(info["is_success"])
    time = len(errors) * unwrapped.dt
    return EpisodeRecord(
        completed=completed,
        mean_abs_cte=float(np.mean(errors)),
        max_abs_cte=float(np.max(errors)),
        rms_cte=float(np.sqrt(np.mean(errors**2))),
        time=time,
        time_to_goal=time if completed else math.nan,
        collision=bool(info["collision"]),
        off_track=bool(info["off_track"]),
        steps=len(errors),
        trajectory=np.array(poses),
        path=track.path,
        maze=track.maze,
    )


def evaluate(
    agent: Any,
    env: str | gym.Env,
    episodes: int,
    seed: int = 0,
    *,
    check_stop: Callable[[], None] | None = None,
    **env_kwargs: Any,
) -> EvaluationResult:
    """Run ``episodes`` episodes of ``agent`` on ``env`` and record them.

    Episode i resets with seed ``seed + i``: identical seeds give identical results, and every
    agent evaluated with the same seed meets the same paths and start poses.

    :param agent: a classical agent (bound or not; see :func:`bind_agent`), a class or factory
        making one, or an SB3 model
    :param env: an env id (made with ``gym.make(env, **env_kwargs)`` and closed afterwards)
        or a single (not vector) env
    :param episodes: number of episodes, at least 1
    :param seed: seed of the first episode
    :param check_stop: called before every step; raises to stop the evaluation
    :param env_kwargs: keyword arguments for ``gym.make``; only with an env id
    """
    if episodes < 1:
        raise ValueError(f"episodes must be at least 1, got {episodes}")
    owned = isinstance(env, str)
    if isinstance(env, str):
        single = gym.make(env, **env_kwargs)
    elif env_kwargs:
        raise ValueError("env_kwargs only apply when env is an id")
    else:
        single = env
    try:
        bound = bind_agent(agent, single)
        return EvaluationResult(
            [run_episode(bound, single, seed + index, check_stop) for index in range(episodes)]
        )
    finally:
        if owned:
            single.close()

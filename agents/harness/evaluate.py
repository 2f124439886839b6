"""Run any agent on an env and measure it: every episode at once.

Classical agents (:mod:`agents.controllers.pure_pursuit`, :mod:`agents.controllers.guidance`) and
Stable-Baselines3 models meet the same episodes: episode i resets with seed ``seed + i``, so
every agent compared on an env meets the same paths from the same start poses. The metrics
are those the env reports at an episode's end, computed from the same per-step cross-track
errors, so training logs, evaluation and comparison all measure alike.

:func:`evaluate` runs all episodes together in one vector env (:mod:`agents.harness.batch`):
a classical agent computes every robot's command in one compiled call, a policy predicts for
every robot in one batch. Its episodes and metrics are those of :func:`run_episode`, the
loop that runs one episode at a time in the single env: bit for bit for classical agents.
A policy's batch adds each layer's products in another order than one row does, so its
actions differ in the last float32 bits (up to about 1e-6); its metrics stay within 1e-6 of
the one-at-a-time loop's unless the closed loop amplifies that (an episode that ends a step
later).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.wrappers import OrderEnforcing, PassiveEnvChecker, TimeLimit

import mobile_envs  # noqa: F401  (registers the env ids)
from agents.controllers.base import BoundAgent, ClassicalAgent
from agents.harness.batch import MAX_ROBOTS, run_episodes, vector_env_like
from agents.harness.policies import recorded_observation_settings
from agents.harness.records import EpisodeRecord, EvaluationResult
from mobile_envs.envs.path_following import PathFollowingEnv

__all__ = ["EpisodeRecord", "EvaluationResult", "bind_agent", "evaluate", "run_episode"]

#: Wrappers ``gym.make`` adds that change nothing the harness measures; an outer
#: ``TimeLimit`` the batched harness applies itself.
_TRANSPARENT_WRAPPERS = (OrderEnforcing, PassiveEnvChecker)


def resolve_agent(agent: Any) -> Any:
    """The agent itself: an object with ``bind`` or ``predict``, a class or a zero-argument
    factory called until it gives one.

    :raises TypeError: for anything else
    """
    if isinstance(agent, type):
        return resolve_agent(agent())
    if hasattr(agent, "bind") or hasattr(agent, "predict"):
        return agent
    if callable(agent):
        return resolve_agent(agent())
    raise TypeError(f"cannot drive an env with {agent!r}: it has neither bind() nor predict()")


def bind_agent(agent: Any, env: gym.Env) -> Any:
    """An agent with ``predict`` for ``env``.

    :param agent: an object with ``bind(env)`` (a classical agent, bound or not), a class or a
        zero-argument factory that makes one, or anything with ``predict`` (an SB3 model)
    """
    resolved = resolve_agent(agent)
    return resolved.bind(env) if hasattr(resolved, "bind") else resolved


def run_episode(
    agent: Any, env: gym.Env, seed: int, check_stop: Callable[[], None] | None = None
) -> EpisodeRecord:
    """Run one episode of a bound ``agent`` (see :func:`bind_agent`) from ``reset(seed=seed)``,
    one step at a time: what :func:`evaluate` does for envs it cannot batch.

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
    return EpisodeRecord.measured(
        np.array(cross_track_errors), np.array(poses), info, unwrapped.dt, track
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

    The episodes run together in one vector env of the env's settings, at most
    :data:`~agents.harness.batch.MAX_ROBOTS` robots at a time, unless the env cannot be
    batched: a wrapper other than those ``gym.make`` adds (``TimeLimit``, ``OrderEnforcing``,
    ``PassiveEnvChecker``), an env that renders, or an agent that is neither a classical one
    nor a policy with SB3's batched ``predict``; those run one episode at a time
    (:func:`run_episode`).

    :param agent: a classical agent (bound or not; see :func:`bind_agent`), a class or factory
        making one, or an SB3 model (anything whose ``predict`` takes a batch of observations)
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
        resolved = resolve_agent(agent)
        batchable = isinstance(resolved, (ClassicalAgent, BoundAgent)) or not hasattr(
            resolved, "bind"
        )
        plan = _batch_plan(single)
        # A policy observes through the sensors it was trained with.
        own_settings = recorded_observation_settings(resolved)
        if batchable and plan is not None:
            base, step_limit = plan
            envs = vector_env_like(base, min(episodes, MAX_ROBOTS), **own_settings)
            try:
                return EvaluationResult(
                    run_episodes(resolved, envs, episodes, seed, check_stop, step_limit)
                )
            finally:
                envs.close()
        observed: Any = getattr(resolved, "observation_space", None)
        if own_settings and observed.shape != single.observation_space.shape:
            raise ValueError(
                f"the policy observes with {own_settings}, which this env cannot be made again "
                "with (a wrapper of its own or rendering): make it with them"
            )
        bound = bind_agent(resolved, single)
        return EvaluationResult(
            [run_episode(bound, single, seed + index, check_stop) for index in range(episodes)]
        )
    finally:
        if owned:
            single.close()


def _batch_plan(env: gym.Env) -> tuple[PathFollowingEnv, int | None] | None:
    """The single env under ``env`` and the step limit of its ``TimeLimit`` wrappers (None:
    no limit but the env's own), or None when a vector env cannot run its episodes: another
    wrapper, another env class or rendering."""
    step_limit = None
    while isinstance(env, gym.Wrapper):
        if isinstance(env, TimeLimit):
            limit = env._max_episode_steps
            step_limit = limit if step_limit is None else min(step_limit, limit)
        elif not isinstance(env, _TRANSPARENT_WRAPPERS):
            return None
        env = env.env
    if type(env) is not PathFollowingEnv or env.render_mode is not None:
        return None
    return env, step_limit

"""Warm starts by behaviour cloning: a policy that drives like a classical agent before RL.

PPO from scratch on a car-like robot rarely learns to reach the goal of a sharp path in a
few minutes: a corner taken too fast is failed many steps after the decision that caused it.
A classical agent (regulated pure pursuit by default) already completes those paths, so its
episodes make a starting point:

1. :func:`record_demonstrations` runs the agent on N robots of the training env (the same
   batched env PPO trains on, same-step autoreset) and keeps the episodes it completed:
   observations, its normalized actions and the discounted returns of the env's reward;
2. :func:`clone` fits the policy's mean action to the agent's actions and its value
   function to those returns (mean squared errors, Adam), so PPO's first advantages come
   from a critic that already knows what the actor does;
3. RL then improves on the agent (:func:`warm_start` does steps 1 and 2 for ``train.py``,
   driven by a ``warm_start:`` entry in ``hyperparams/ppo.yml``).

Everything is seeded from the run's seed: the same command gives the same weights.
Requires the ``train`` extra.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from numpy.typing import NDArray
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.policies import ActorCriticPolicy

import mobile_envs  # noqa: F401  (registers the env ids)
from agents.controllers.base import ClassicalAgent
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit

#: The agents a warm start can imitate, by name.
TEACHERS: dict[str, type[ClassicalAgent]] = {
    "pure_pursuit": PurePursuit,
    "regulated_pure_pursuit": RegulatedPurePursuit,
}


@dataclass
class Demonstrations:
    """The completed episodes of a teacher, flattened over robots and steps.

    :param observations: (n, D) what the robot observed
    :param actions: (n, m) the teacher's normalized actions
    :param returns: (n,) the discounted return from each step to the episode's end
    :param episodes: how many episodes ended, completed or not
    :param completed: how many of them reached the goal (only those are kept)
    """

    observations: NDArray[np.float32]
    actions: NDArray[np.float32]
    returns: NDArray[np.float32]
    episodes: int
    completed: int


def _discounted(rewards: list[float], gamma: float) -> list[float]:
    """Returns from each step to the end of an episode that terminated (nothing after it)."""
    total, returns = 0.0, []
    for reward in reversed(rewards):
        total = reward + gamma * total
        returns.append(total)
    return returns[::-1]


def record_demonstrations(
    teacher: str,
    env_id: str,
    *,
    robots: int,
    steps: int,
    gamma: float,
    seed: int = 0,
    env_kwargs: dict[str, Any] | None = None,
    check_stop: Callable[[], None] | None = None,
) -> Demonstrations:
    """Run ``teacher`` on ``robots`` robots of ``env_id`` for ``steps`` vector steps.

    Only the episodes the teacher completed are kept: imitating its failures would teach
    them. Episodes still running at the end are dropped too (their returns are unknown).

    :param teacher: a key of :data:`TEACHERS`
    :param gamma: the discount of the returns (the RL algorithm's)
    :param seed: the vector env's reset seed
    :param check_stop: called before every step; raises to stop recording
    :raises ValueError: for an unknown teacher, counts below 1, or a teacher that completed
        no episode
    """
    if teacher not in TEACHERS:
        raise ValueError(f"unknown teacher {teacher!r}; known: {', '.join(TEACHERS)}")
    for name, value in (("robots", robots), ("steps", steps)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"warm_start {name} must be a positive integer, got {value!r}")
    envs = gym.make_vec(env_id, num_envs=robots, autoreset_mode="SameStep", **(env_kwargs or {}))
    agent = TEACHERS[teacher]().bind(envs)
    observations, _ = envs.reset(seed=seed)
    running: list[list[tuple[NDArray[np.float32], NDArray[np.float32], float]]] = [
        [] for _ in range(robots)
    ]
    kept_observations: list[NDArray[np.float32]] = []
    kept_actions: list[NDArray[np.float32]] = []
    kept_returns: list[float] = []
    episodes = completed = 0
    for _ in range(steps):
        if check_stop is not None:
            check_stop()
        actions, _ = agent.predict(observations)
        actions = actions.astype(np.float32)
        next_observations, rewards, terminated, truncated, infos = envs.step(actions)
        ended = terminated | truncated
        for robot in range(robots):
            running[robot].append((observations[robot], actions[robot], float(rewards[robot])))
            if not ended[robot]:
                continue
            episodes += 1
            if infos["final_info"]["is_success"][robot]:
                completed += 1
                episode = running[robot]
                kept_observations.extend(step[0] for step in episode)
                kept_actions.extend(step[1] for step in episode)
                kept_returns.extend(_discounted([step[2] for step in episode], gamma))
            running[robot] = []
        observations = next_observations
    envs.close()
    if not kept_observations:
        raise ValueError(
            f"{teacher} completed none of {episodes} episodes on {env_id} in {steps} steps: "
            "nothing to imitate"
        )
    return Demonstrations(
        np.array(kept_observations, dtype=np.float32),
        np.array(kept_actions, dtype=np.float32),
        np.array(kept_returns, dtype=np.float32),
        episodes,
        completed,
    )


def clone(
    policy: ActorCriticPolicy,
    demonstrations: Demonstrations,
    *,
    epochs: int,
    batch_size: int,
    learning_rate: float,
    seed: int = 0,
    check_stop: Callable[[], None] | None = None,
) -> dict[str, float]:
    """Fit ``policy``'s mean action to the teacher's actions and its value to the returns.

    The action noise (``log_std``) is left as the policy was built: PPO still explores
    around the cloned mean.

    :param check_stop: called before every minibatch; raises to stop cloning
    :return: the last epoch's ``action_mse`` and ``value_mse``
    """
    generator = torch.Generator().manual_seed(seed)
    observations = torch.as_tensor(demonstrations.observations, device=policy.device)
    actions = torch.as_tensor(demonstrations.actions, device=policy.device)
    returns = torch.as_tensor(demonstrations.returns, device=policy.device)
    parameters = [p for name, p in policy.named_parameters() if name != "log_std"]
    optimizer = torch.optim.Adam(parameters, lr=learning_rate)
    losses = {"action_mse": float("nan"), "value_mse": float("nan")}
    policy.set_training_mode(True)
    for _ in range(epochs):
        order = torch.randperm(len(observations), generator=generator)
        action_total = value_total = 0.0
        for start in range(0, len(order), batch_size):
            if check_stop is not None:
                check_stop()
            batch = order[start : start + batch_size]
            distribution = policy.get_distribution(observations[batch])
            mean = distribution.distribution.mean  # type: ignore[union-attr]
            action_loss = torch.nn.functional.mse_loss(mean, actions[batch])
            values = policy.predict_values(observations[batch]).flatten()
            value_loss = torch.nn.functional.mse_loss(values, returns[batch])
            optimizer.zero_grad()
            (action_loss + value_loss).backward()
            optimizer.step()
            action_total += action_loss.item() * len(batch)
            value_total += value_loss.item() * len(batch)
        losses = {
            "action_mse": action_total / len(order),
            "value_mse": value_total / len(order),
        }
    policy.set_training_mode(False)
    return losses


def warm_start(
    model: BaseAlgorithm,
    env_id: str,
    *,
    seed: int = 0,
    env_kwargs: dict[str, Any] | None = None,
    teacher: str = "regulated_pure_pursuit",
    robots: int = 64,
    steps: int = 2000,
    epochs: int = 20,
    batch_size: int = 1024,
    learning_rate: float = 1e-3,
    check_stop: Callable[[], None] | None = None,
) -> dict[str, float]:
    """Clone ``teacher``'s completed episodes on ``env_id`` into ``model``'s policy, in place.

    :param model: a PPO (or any actor-critic with a Gaussian policy) model, not yet trained
    :param seed: seeds the demonstrations' env and the cloning's minibatch order
    :param robots: robots driven at once while recording
    :param steps: vector steps recorded (``robots * steps`` samples before filtering)
    :param epochs: passes over the demonstrations
    :param check_stop: called between the recording's steps and the cloning's minibatches;
        raises to stop the warm start (a stop signal:
        :meth:`agents.interrupts.StopRequests.raise_if_requested`)
    :return: how many samples and episodes were kept, and the final losses
    :raises ValueError: for a model whose policy is not an actor-critic, or bad settings
    """
    policy = model.policy
    if not isinstance(policy, ActorCriticPolicy):
        raise ValueError(
            f"warm_start needs an actor-critic policy (PPO, A2C), got {type(policy).__name__}"
        )
    for name, value in (("epochs", epochs), ("batch_size", batch_size)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"warm_start {name} must be a positive integer, got {value!r}")
    if not learning_rate > 0:
        raise ValueError(f"warm_start learning_rate must be > 0, got {learning_rate!r}")
    demonstrations = record_demonstrations(
        teacher,
        env_id,
        robots=robots,
        steps=steps,
        gamma=float(getattr(model, "gamma", 0.99)),
        seed=seed,
        env_kwargs=env_kwargs,
        check_stop=check_stop,
    )
    losses = clone(
        policy,
        demonstrations,
        epochs=epochs,
        batch_size=batch_size,
        learning_rate=learning_rate,
        seed=seed,
        check_stop=check_stop,
    )
    return {
        "samples": float(len(demonstrations.actions)),
        "episodes": float(demonstrations.episodes),
        "completed": float(demonstrations.completed),
        **losses,
    }

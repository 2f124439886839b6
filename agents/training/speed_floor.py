"""PPO's MlpPolicy whose deterministic driving never stands still.

A policy that reverses (a three-point turn) has a mean speed that is forward in some states
and backward in others, so 0 between them. A robot whose pose only changes while it moves (the
bicycle, the tricycle) and which reaches such a state stands still for good: its observation
stops changing, and so does the command, until the stall ends the episode. PPO's sampled
actions move it off those states in training, so training rarely pays for them; the
deterministic action (``predict(..., deterministic=True)``, what the harness, the run's
evaluations and the ONNX export use) does not (docs/training.md, "What did not work").

:class:`SpeedFloorPolicy` keeps a gear: when the deterministic speed command is slower than
``speed_floor``, it becomes ``speed_floor`` in the direction of the previous command (an
observation, ``previous_action_0`` for the envs), so the direction only changes where the
policy asks for more than ``speed_floor`` the other way. Sampled actions are left alone, so
PPO's rollouts, and with them the training, are those of ``MlpPolicy``.

Use it by its import path, in a hyperparameter entry (train.py and rl-baselines3-zoo both
import a policy named with dots)::

    policy: agents.training.speed_floor.SpeedFloorPolicy
    policy_kwargs:
      net_arch: [64, 64]
      speed_floor: 0.05              # in action units
      speed_action: 0                # the action that is the speed command
      previous_speed_observation: 27 # env.unwrapped.observation_names[27] == "previous_action_0"

Requires the ``train`` extra.
"""

from __future__ import annotations

import math
from typing import Any

import torch
from gymnasium import spaces
from stable_baselines3.common.policies import ActorCriticPolicy


class SpeedFloorPolicy(ActorCriticPolicy):
    """An ``ActorCriticPolicy`` (PPO's ``MlpPolicy``) whose deterministic speed command is at
    least ``speed_floor`` in magnitude.

    :param speed_floor: the slowest deterministic speed command, in action units (0: none,
        the policy is ``MlpPolicy``); it must lie within the action's bounds both ways
    :param speed_action: the index of the speed command in the action
    :param previous_speed_observation: the index of the observation that is the previous
        speed command (its sign gives the direction a slower command is raised in; 0 counts
        as forward); required when ``speed_floor`` is above 0
    :param args: ``ActorCriticPolicy``'s arguments (observation space, action space, schedule)
    :param kwargs: ``ActorCriticPolicy``'s keyword arguments (``net_arch``, ``log_std_init``...)
    :raises ValueError: naming the setting that does not fit the spaces
    """

    speed_column: torch.Tensor

    def __init__(
        self,
        *args: Any,
        speed_floor: float = 0.0,
        speed_action: int = 0,
        previous_speed_observation: int | None = None,
        **kwargs: Any,
    ):
        super().__init__(*args, **kwargs)
        check_speed_floor(
            self.observation_space,
            self.action_space,
            speed_floor,
            speed_action,
            previous_speed_observation,
        )
        self.speed_floor = float(speed_floor)
        self.speed_action = int(speed_action)
        self.previous_speed_observation = previous_speed_observation
        assert isinstance(self.action_space, spaces.Box)
        column = torch.arange(self.action_space.shape[0]) == self.speed_action
        self.register_buffer("speed_column", column, persistent=False)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.update(
            speed_floor=self.speed_floor,
            speed_action=self.speed_action,
            previous_speed_observation=self.previous_speed_observation,
        )
        return data

    def _predict(self, observation: Any, deterministic: bool = False) -> torch.Tensor:
        actions = super()._predict(observation, deterministic)
        return self.floor_speed(observation, actions) if deterministic else actions

    def floor_speed(self, observations: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """``actions`` (n, action size) with each speed command slower than ``speed_floor``
        raised to it in the direction of the previous command in ``observations`` (n,
        observation size). Written with ``torch.where`` only, so it exports to ONNX."""
        if self.speed_floor <= 0.0:
            return actions
        previous = observations[:, self.previous_speed_observation].to(actions.dtype)
        direction = torch.where(previous < 0.0, -1.0, 1.0).unsqueeze(1)
        slow = self.speed_column & (actions.abs() < self.speed_floor)
        return torch.where(slow, direction * self.speed_floor, actions)


def check_speed_floor(
    observation_space: spaces.Space,
    action_space: spaces.Space,
    speed_floor: object,
    speed_action: object,
    previous_speed_observation: object,
) -> None:
    """Raise ValueError naming the setting of :class:`SpeedFloorPolicy` that does not fit a
    policy of these spaces (flat Box observations and actions)."""
    if not isinstance(action_space, spaces.Box) or len(action_space.shape) != 1:
        raise ValueError(f"SpeedFloorPolicy needs a flat Box action space, not {action_space}")
    if not isinstance(observation_space, spaces.Box) or len(observation_space.shape) != 1:
        raise ValueError(
            f"SpeedFloorPolicy needs a flat Box observation space, not {observation_space}"
        )
    if not _is_index(speed_action, action_space.shape[0]):
        raise ValueError(
            f"speed_action must be an action index in [0, {action_space.shape[0]}), "
            f"got {speed_action!r}"
        )
    assert isinstance(speed_action, int)
    low, high = float(action_space.low[speed_action]), float(action_space.high[speed_action])
    if (
        isinstance(speed_floor, bool)
        or not isinstance(speed_floor, (int, float))
        or not math.isfinite(speed_floor)
        or not 0.0 <= speed_floor <= min(-low, high)
    ):
        raise ValueError(
            f"speed_floor must be a number in [0, {min(-low, high):g}] (within action "
            f"{speed_action}'s bounds [{low:g}, {high:g}] both ways), got {speed_floor!r}"
        )
    if speed_floor > 0 and not _is_index(previous_speed_observation, observation_space.shape[0]):
        raise ValueError(
            "previous_speed_observation must be the index of the previous speed command in "
            f"the observation, in [0, {observation_space.shape[0]}), got "
            f"{previous_speed_observation!r}"
        )


def _is_index(value: object, size: int) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < size

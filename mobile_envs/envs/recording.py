"""The info as recorders want it: the same keys at every step, as numpy values.

The env adds its episode metrics (:data:`~mobile_envs.envs.interface.EPISODE_INFO_KEYS`) to
the info of an episode's last step only, and gives a single robot's numbers as Python floats
and bools, which is what SB3 and Gymnasium's checkers want and the fastest to build. Two kinds
of recorder want otherwise:

- Minari's ``DataCollector(record_infos=True)`` needs one info structure every step (else:
  ``pytree structure error``);
- TorchRL's ``default_info_dict_reader`` reads ``value.dtype`` (a Python float has none).

:class:`UniformInfo` gives them that, for the users who record, at a cost to no one else.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from mobile_envs.envs.interface import episode_info_placeholders


class UniformInfo(gym.Wrapper):
    """Every ``reset`` and ``step`` info holds the same keys: the step keys, and the episode
    metrics, NaN (``completed``: False) until the step that ends the episode; every value is a
    numpy scalar or array.

    ``DataCollector(UniformInfo(gym.make("mobile_envs/DiffDrive-Lines-v0")), record_infos=True)``
    records; ``GymWrapper(UniformInfo(gym.make(id)))`` with
    ``set_info_dict_reader(default_info_dict_reader())`` reads every key into TorchRL's
    tensordicts. Observations, rewards and flags are the env's own.

    :param env: a ``mobile_envs`` single env, possibly wrapped (wrap it last: a wrapper
        above that adds info keys at an episode's end, such as ``RecordEpisodeStatistics``,
        changes the structure again)
    """

    def __init__(self, env: gym.Env):
        super().__init__(env)
        unwrapped: Any = env.unwrapped  # a PathFollowingEnv
        self._placeholders = episode_info_placeholders(unwrapped.core.localization is not None)

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        observation, info = self.env.reset(**kwargs)
        return observation, self._uniform(info)

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict[str, Any]]:
        observation, reward, terminated, truncated, info = self.env.step(action)
        return observation, reward, terminated, truncated, self._uniform(info)

    def _uniform(self, info: dict[str, Any]) -> dict[str, Any]:
        merged = {**self._placeholders, **info}
        return {key: np.asarray(value)[()] for key, value in merged.items()}

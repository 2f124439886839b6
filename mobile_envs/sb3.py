"""Stable-Baselines3 ``VecEnv`` over the batched core, for training on many robots at once.

SB3 resets an env in the same step its episode ends, returning the first observation of
the next episode and the last one of the old in ``infos[i]["terminal_observation"]``, with
``infos[i]["TimeLimit.truncated"]`` set when the episode ran out of time rather than ended
in a terminal state (so PPO bootstraps its value). That is the vector env's
``AutoresetMode.SAME_STEP``; this adapter reshapes its outputs for SB3. Requires the
``train`` extra (stable-baselines3).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from numpy.typing import NDArray
from stable_baselines3.common.vec_env import VecEnv

from mobile_envs.interface import EPISODE_INFO_KEYS
from mobile_envs.vector import PathFollowingVectorEnv


class PathFollowingSB3VecEnv(VecEnv):
    """N robots behind SB3's ``VecEnv`` interface: a reshape of the batched vector env in
    ``AutoresetMode.SAME_STEP``, nothing more.

    :param env_id: a registered ``mobile_envs/...`` id
    :param num_envs: N
    :param seed: seeds robot i with ``seed + i`` at the first reset
    :param env_kwargs: keyword arguments for the environment
    """

    def __init__(self, env_id: str, num_envs: int, seed: int | None = None, **env_kwargs: Any):
        vector = gym.make_vec(
            env_id, num_envs=num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **env_kwargs
        )
        if not isinstance(vector, PathFollowingVectorEnv):
            raise ValueError(f"{env_id} does not have the batched vector env as vector_entry_point")
        self.vector_env = vector
        self.env_id = env_id
        self._actions: NDArray[np.float32] | None = None
        super().__init__(num_envs, vector.single_observation_space, vector.single_action_space)
        if seed is not None:
            self.seed(seed)

    def reset(self) -> NDArray[np.float32]:
        """Reset every robot; seeds set by :meth:`seed` apply to this reset only."""
        seeds = None if all(seed is None for seed in self._seeds) else self._seeds
        observations, _ = self.vector_env.reset(seed=seeds)
        self._reset_seeds()
        return observations

    def step_async(self, actions: NDArray[np.float32]) -> None:
        self._actions = actions

    def step_wait(
        self,
    ) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.bool_], list[dict]]:
        if self._actions is None:
            raise RuntimeError("step_async() must come before step_wait()")
        observations, rewards, terminated, truncated, vector_infos = self.vector_env.step(
            self._actions
        )
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if dones.any():
            final_observations = vector_infos["final_obs"]
            final_info = vector_infos["final_info"]
            for index in np.flatnonzero(dones):
                info = infos[index]
                info["terminal_observation"] = final_observations[index]
                info["TimeLimit.truncated"] = bool(truncated[index])
                info["is_success"] = bool(final_info["is_success"][index])
                for key in EPISODE_INFO_KEYS:
                    info[key] = final_info[key][index].item()
        return observations, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        self.vector_env.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        return [getattr(self.vector_env, attr_name)] * len(list(self._get_indices(indices)))

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        setattr(self.vector_env, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any
    ) -> list[Any]:
        result = getattr(self.vector_env, method_name)(*method_args, **method_kwargs)
        return [result] * len(list(self._get_indices(indices)))

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False] * len(list(self._get_indices(indices)))

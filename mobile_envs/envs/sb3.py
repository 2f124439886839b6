"""Stable-Baselines3 ``VecEnv`` over the batched core, for training on many robots at once.

SB3 resets an env in the same step its episode ends, returning the first observation of
the next episode and the last one of the old in ``infos[i]["terminal_observation"]``, with
``infos[i]["TimeLimit.truncated"]`` set when the episode ran out of time rather than ended
in a terminal state (so PPO bootstraps its value). That is the vector env's
``AutoresetMode.SAME_STEP``; this adapter reshapes its outputs for SB3, as SB3's
``DummyVecEnv`` over N single envs gives them: each robot's info holds every key of the
single env's step info (its episode metrics where its episode ended), ``reset_infos`` the
infos of each robot's last reset, ``set_options`` applies at the next reset, and
``env_method("reset", indices=...)`` restarts only those robots. Requires the ``train`` extra
(stable-baselines3).
"""

from __future__ import annotations

import warnings
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from numpy.typing import NDArray
from stable_baselines3.common.vec_env import VecEnv

from mobile_envs.envs.vector import PathFollowingVectorEnv

__all__ = [
    "PER_ROBOT_ATTRIBUTES",
    "PathFollowingSB3VecEnv",
]

#: The single env's attributes that differ from robot to robot, and the vector env's batch of
#: them (robot i's value is entry i).
PER_ROBOT_ATTRIBUTES = {
    "track": "tracks",
    "path": "paths",
    "state": "states",
    "pose": "poses",
    "elapsed_steps": "elapsed_steps",
    "np_random": "rngs",
}


#: The vector env's same-step infos that are not one robot's step info.
_NOT_PER_ROBOT = ("final_obs", "final_info")


class PathFollowingSB3VecEnv(VecEnv):
    """N robots behind SB3's ``VecEnv`` interface: a reshape of the batched vector env in
    ``AutoresetMode.SAME_STEP``, nothing more.

    :param env_id: a registered ``mobile_envs/...`` id
    :param num_envs: N
    :param seed: seeds robot i with ``seed + i`` at the first reset
    :param env_kwargs: keyword arguments for the environment; ``render_mode="rgb_array"``
        makes :meth:`render` return one frame of the whole batch (see
        :mod:`mobile_envs.rendering.batch`), as SB3's ``VecVideoRecorder`` records it;
        ``"human"`` draws it in a window after every step.
    """

    def __init__(self, env_id: str, num_envs: int, seed: int | None = None, **env_kwargs: Any):
        vector = gym.make_vec(
            env_id, num_envs=num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **env_kwargs
        )
        if not isinstance(vector, PathFollowingVectorEnv):
            raise ValueError(f"{env_id} does not have the batched vector env as vector_entry_point")
        self.vector_env = vector
        self.env_id = env_id
        # What step_async got, checked when the vector env steps: any input, valid or not.
        self._actions: Any = None
        self._waiting = False
        self._started = False  # whether every robot has been reset once
        super().__init__(num_envs, vector.single_observation_space, vector.single_action_space)
        # VecVideoRecorder reads the frame rate from here.
        self.metadata = {**self.metadata, "render_fps": vector.metadata["render_fps"]}
        if seed is not None:
            self.seed(seed)

    def reset(self) -> NDArray[np.float32]:
        """Reset every robot; seeds set by :meth:`seed` and options set by
        :meth:`set_options` apply to this reset only (robot i's to robot i), as SB3's
        ``DummyVecEnv`` passes them to each env. Fills :attr:`reset_infos`."""
        seeds, options = list(self._seeds), list(self._options)
        first = options[0]
        if all(_same(robot_options, first) for robot_options in options):
            observations, infos = self.vector_env.reset(
                seed=None if all(seed is None for seed in seeds) else seeds,
                options=first or None,
            )
            self.reset_infos = _robot_infos(infos, self.num_envs)
        else:
            observations = self._reset_one_by_one(seeds, options)
        self._started = True
        self._reset_seeds()
        self._reset_options()
        if self.render_mode == "human":
            self.vector_env.render()
        return observations

    def _reset_one_by_one(
        self, seeds: list[int | None], options: list[dict[str, Any]]
    ) -> NDArray[np.float32]:
        """Each robot reset with its own options (N resets: options that differ between
        robots are rare). A vector env's first reset is of all robots: each is reset again,
        from its own seed where it has one, so it starts as the single env would."""
        if not self._started:
            self.vector_env.reset(seed=seeds)
        width = self.vector_env.single_observation_space.shape
        assert width is not None
        observations = np.empty((self.num_envs, *width), np.float32)
        for robot in range(self.num_envs):
            observation, info = self._reset_robots([robot], seeds[robot], options[robot])
            observations[robot] = observation[0]
            self.reset_infos[robot] = info[0]
        return observations

    def _reset_robots(
        self, robots: list[int], seed: int | None, options: dict[str, Any] | None
    ) -> tuple[NDArray[np.float32], list[dict[str, Any]]]:
        """Restart ``robots`` (each from ``seed`` when given, as a single env's
        ``reset(seed=seed, options=options)``); their observations and reset infos."""
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[robots] = True
        seeds = None if seed is None else [seed if mask[i] else None for i in range(self.num_envs)]
        observations, infos = self.vector_env.reset(
            seed=seeds, options={**(options or {}), "reset_mask": mask}
        )
        all_infos = _robot_infos(infos, self.num_envs)
        return observations[robots], [all_infos[robot] for robot in robots]

    def step_async(self, actions: NDArray[np.float32]) -> None:
        self._actions, self._waiting = actions, True

    def step_wait(
        self,
    ) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.bool_], list[dict]]:
        if not self._waiting:
            raise RuntimeError("step_async() must come before step_wait()")
        self._waiting = False
        observations, rewards, terminated, truncated, vector_infos = self.vector_env.step(
            self._actions
        )
        if self.render_mode == "human":
            self.vector_env.render()
        dones = terminated | truncated
        infos = _robot_infos(vector_infos, self.num_envs)
        if dones.any():
            final_observations = vector_infos["final_obs"]
            final_infos = _robot_infos(vector_infos["final_info"], self.num_envs)
            for index in np.flatnonzero(dones).tolist():
                # The reset info of the episode that began is the step info now reported.
                self.reset_infos[index] = infos[index]
                infos[index] = final_infos[index]
                infos[index]["terminal_observation"] = final_observations[index]
        # DummyVecEnv's convention: truncated by time, not ended by the task.
        time_limit = (truncated & ~terminated).tolist()
        for info, truncated_by_time in zip(infos, time_limit, strict=True):
            info["TimeLimit.truncated"] = truncated_by_time
        return observations, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        self.vector_env.close()

    def render(self, mode: str | None = None) -> NDArray[np.uint8] | None:
        """The frame of the whole batch in ``"rgb_array"`` mode; otherwise as SB3's
        ``VecEnv.render``.

        :param mode: None or the ``render_mode`` the adapter was made with
        """
        if self.render_mode == "rgb_array" and mode in (None, "rgb_array"):
            return self.vector_env.render()
        return super().render(mode)

    def get_images(self) -> list[NDArray[np.uint8] | None]:
        """One image: the batch in one frame, not one per robot."""
        if self.render_mode != "rgb_array":
            warnings.warn(
                f"the render mode is {self.render_mode}, but get_images() needs 'rgb_array'",
                stacklevel=2,
            )
            return [None]
        return [self.vector_env.render()]

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        """Each indexed robot's value of ``attr_name``, as SB3's ``DummyVecEnv`` reads it from
        each of its single envs.

        The single env's per-robot attributes (``track``, ``path``, ``state``, ``pose``,
        ``elapsed_steps``, ``np_random``) are robot i's entry of the vector env's batch; the
        spaces are one robot's; any other attribute is the vector env's (one value shared by
        every robot), else the adapter's own (``env_id``).

        :param attr_name: the attribute
        :param indices: the robots (None: all)
        :return: one value per robot in ``indices``
        :raises AttributeError: when neither the vector env nor the adapter has it
        """
        robots = list(self._get_indices(indices))
        if attr_name in PER_ROBOT_ATTRIBUTES:
            batch = getattr(self.vector_env, PER_ROBOT_ATTRIBUTES[attr_name])
            return [_python_scalar(batch[robot]) for robot in robots]
        if attr_name in ("observation_space", "action_space"):
            value = getattr(self, attr_name)
        elif hasattr(self.vector_env, attr_name):
            value = getattr(self.vector_env, attr_name)
        elif attr_name in self.__dict__:
            value = self.__dict__[attr_name]
        else:
            raise AttributeError(f"the environment has no attribute {attr_name!r}")
        return [value] * len(robots)

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Set ``attr_name`` to ``value`` for the indexed robots, as SB3's ``DummyVecEnv``
        sets it on each of its single envs.

        ``np_random`` is each robot's own generator and may be set for any robots; every
        other attribute is one setting of the vector env that all robots share, so it can
        only be set for all of them.

        :param attr_name: the attribute
        :param value: its new value
        :param indices: the robots (None: all)
        :raises AttributeError: for the read-only per-robot attributes (``pose``, ...)
        :raises ValueError: when a shared attribute is set for only some robots
        """
        robots = list(self._get_indices(indices))
        if attr_name == "np_random":
            for robot in robots:
                self.vector_env.rngs[robot] = value
            return
        if attr_name in PER_ROBOT_ATTRIBUTES:
            raise AttributeError(f"{attr_name!r} is read-only: it follows the robot's motion")
        if sorted(set(robots)) != list(range(self.num_envs)):
            raise ValueError(
                f"{attr_name!r} is one setting shared by all {self.num_envs} robots of the "
                f"batch: set it with indices=None, not for robots {robots}"
            )
        setattr(self.vector_env, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any
    ) -> list[Any]:
        """Call ``method_name`` as SB3's ``DummyVecEnv`` calls it on each indexed single env.

        ``reset`` restarts only the indexed robots (each from ``seed`` when given, with the
        ``options`` given) and returns each one's ``(observation, info)``; a method of the
        vector env that concerns every robot at once is called once, its result given for
        each indexed robot.

        :param method_name: the method
        :param indices: the robots (None: all)
        :return: one result per robot in ``indices``
        """
        robots = list(self._get_indices(indices))
        if method_name == "reset":
            return self._env_reset(robots, *method_args, **method_kwargs)
        result = getattr(self.vector_env, method_name)(*method_args, **method_kwargs)
        return [result] * len(robots)

    def _env_reset(
        self, robots: list[int], *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> list[tuple[NDArray[np.float32], dict[str, Any]]]:
        """``env_method("reset")``: each indexed robot's ``reset(seed=seed, options=options)``
        (like DummyVecEnv's, it leaves :attr:`reset_infos` alone)."""
        observations, infos = self._reset_robots(robots, seed, options)
        return [(observation, info) for observation, info in zip(observations, infos, strict=True)]

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False] * len(list(self._get_indices(indices)))


def _robot_infos(batch: dict[str, Any], count: int) -> list[dict[str, Any]]:
    """A vector env's infos (arrays with their ``_key`` masks) as one dict per robot, each
    with the keys its mask holds and Python numbers where the single env gives them."""
    infos: list[dict[str, Any]] = [{} for _ in range(count)]
    for key, values in batch.items():
        if key.startswith("_") or key in _NOT_PER_ROBOT:
            continue
        mask = batch.get(f"_{key}")
        if mask is None or mask.all():  # every step's infos: no robot to skip
            robots, rows = infos, values
        else:  # an ending's infos: only its robots
            chosen = np.flatnonzero(mask)
            robots, rows = [infos[robot] for robot in chosen.tolist()], values[chosen]
        column = rows.tolist() if rows.ndim == 1 else list(rows)
        for info, value in zip(robots, column, strict=True):
            info[key] = value
    return infos


def _same(first: Any, second: Any) -> bool:
    """Whether two robots' reset options are equal (options holding arrays count as equal
    only when they are the same objects)."""
    if first is second:
        return True
    try:
        return bool(first == second)
    except (TypeError, ValueError):  # arrays compare elementwise
        return False


def _python_scalar(value: Any) -> Any:
    """A numpy scalar as the Python number a single env returns; anything else as it is."""
    return value.item() if isinstance(value, np.generic) else value

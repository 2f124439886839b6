"""PPO helpers for train.py and the evaluation harness: loading with checks, atomic saves,
checkpoints that survive interruption, and periodic evaluation with the harness's metrics.

Requires the ``train`` extra (stable-baselines3, torch).
"""

from __future__ import annotations

import os
import pathlib
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback


def check_spaces(model: PPO, env: gym.Env | Any, model_path: str | os.PathLike[str]) -> None:
    """Raise ValueError naming both sides when a policy's spaces do not fit an env.

    :param model: the loaded policy
    :param env: a single env or a vector env (its single spaces are compared)
    :param model_path: the file the policy came from, for the message
    """
    observation_space = getattr(env, "single_observation_space", env.observation_space)
    action_space = getattr(env, "single_action_space", env.action_space)
    env_name = getattr(getattr(env, "spec", None), "id", None) or type(env).__name__
    for kind, expected, actual in (
        ("observation", model.observation_space, observation_space),
        ("action", model.action_space, action_space),
    ):
        if expected.shape != actual.shape or expected.dtype != actual.dtype:
            raise ValueError(
                f"the policy in {model_path} does not fit {env_name}: its {kind} space is "
                f"{expected}, the env's is {actual}"
            )


def trained_model_name(model: PPO) -> str | None:
    """The kinematic model (``"diff_drive"``, ...) a policy was trained for, if it recorded
    its training env in ``trained_on`` (train.py does), else None."""
    env_id = getattr(model, "trained_on", None)
    if env_id is None or env_id not in gym.registry:
        return None
    return gym.spec(env_id).kwargs.get("model")


def drives_same_model(model: PPO, env: gym.Env | Any) -> bool:
    """False when the policy was trained for another kinematic model than ``env``'s.

    Observation sizes alone cannot tell: the differential drive and the bicycle both have
    45 observations and 2 actions.
    """
    trained = trained_model_name(model)
    return trained is None or trained == env.unwrapped.model.name


def load_policy(path: str | os.PathLike[str], env: gym.Env | Any | None = None) -> PPO:
    """Load a PPO policy; with ``env``, check that its spaces and kinematic model fit.

    :param path: a ``.zip`` saved by SB3
    :param env: the env it will act in, or None to skip the checks
    :raises ValueError: for a missing file, or a policy that does not fit ``env``
    """
    if not pathlib.Path(path).is_file():
        raise ValueError(f"no policy file at {path}")
    model = PPO.load(path, device="cpu")
    if env is not None:
        check_spaces(model, env, path)
        if not drives_same_model(model, env):
            raise ValueError(
                f"the policy in {path} was trained on {model.trained_on} "
                f"({trained_model_name(model)}), not for the {env.unwrapped.model.name} model"
            )
    return model


def save_atomically(model: PPO, path: str | os.PathLike[str]) -> pathlib.Path:
    """Save ``model`` to ``path`` (a .zip) by writing a temporary file and renaming it, so an
    interruption never leaves a half-written model behind."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.stem}.partial.zip")
    model.save(temporary)
    os.replace(temporary, path)
    return path


class AtomicCheckpointCallback(BaseCallback):
    """Every ``every`` environment steps, save ``checkpoints/latest.zip`` atomically.

    :param folder: the run folder
    :param every: steps between checkpoints (0 disables them)
    """

    def __init__(self, folder: pathlib.Path, every: int):
        super().__init__()
        self.folder = folder
        self.every = every
        self._last = 0

    def _on_step(self) -> bool:
        if self.every and self.num_timesteps - self._last >= self.every:
            self._last = self.num_timesteps
            save_atomically(self.model, self.folder / "checkpoints" / "latest.zip")
        return True


class HarnessEvalCallback(BaseCallback):
    """Evaluate the policy with :func:`agents.evaluate.evaluate` every ``every`` steps, log the
    summary (``eval/...``, also to TensorBoard when enabled) and keep the best model.

    Best means the highest completion rate, then the lowest mean |cross-track error|.

    :param env_id: the env to evaluate on
    :param folder: the run folder; the best model goes to ``best_model.zip``
    :param every: steps between evaluations (0 disables them)
    :param episodes: episodes per evaluation (seeds ``seed .. seed + episodes - 1``)
    :param seed: the first evaluation seed
    :param env_kwargs: keyword arguments for the evaluation env
    """

    def __init__(
        self,
        env_id: str,
        folder: pathlib.Path,
        every: int,
        episodes: int = 10,
        seed: int = 10_000,
        env_kwargs: dict[str, Any] | None = None,
    ):
        super().__init__()
        self.env_id = env_id
        self.folder = folder
        self.every = every
        self.episodes = episodes
        self.seed = seed
        self.env_kwargs = env_kwargs or {}
        self.best_score: tuple[float, float] = (-np.inf, -np.inf)
        self._last = 0

    def _on_step(self) -> bool:
        if self.every and self.num_timesteps - self._last >= self.every:
            self._last = self.num_timesteps
            self.run_evaluation()
        return True

    def run_evaluation(self) -> dict[str, float]:
        """Evaluate now; return the summary."""
        from agents.evaluate import evaluate

        summary = evaluate(
            self.model, self.env_id, self.episodes, seed=self.seed, **self.env_kwargs
        ).summary
        for key in ("completion_rate", "mean_abs_cte", "max_abs_cte", "mean_time"):
            if key in summary and np.isfinite(summary[key]):
                self.logger.record(f"eval/{key}", float(summary[key]))
        self.logger.dump(self.num_timesteps)
        score = (summary["completion_rate"], -summary["mean_abs_cte"])
        if score > self.best_score:
            self.best_score = score
            save_atomically(self.model, self.folder / "best_model.zip")
        return summary

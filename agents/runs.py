"""Training runs as a library: the settings of a run, and a run folder trained to the end.

The sweep (:mod:`agents.sweep`) and the grid (:mod:`agents.grid`) train many runs; each one is
a run folder exactly like ``python train.py``'s, so ``python train.py --resume FOLDER`` and
``python train.py evaluate --model FOLDER/final_model.zip`` work on any of them:

- ``config.yml``: the resolved settings (:func:`run_config`), the schema train.py writes
- ``checkpoints/latest.zip``: written atomically every ``checkpoint_freq`` steps and at the end
- ``final_model.zip``, and ``best_model.zip`` when a harness evaluation ran

Requires the ``train`` extra (stable-baselines3, torch, PyYAML).
"""

from __future__ import annotations

import copy
import pathlib
from collections.abc import Sequence
from typing import Any

import yaml
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback

#: The algorithms a run can train, by the name a config's ``algo`` key (and its section) uses.
ALGORITHMS = ("ppo",)


def algorithm_class(algo: str) -> type[BaseAlgorithm]:
    """The Stable-Baselines3 class for ``algo``.

    :raises ValueError: for an algorithm not in :data:`ALGORITHMS`
    """
    if algo == "ppo":
        from stable_baselines3 import PPO

        return PPO
    raise ValueError(f"unknown algo {algo!r}; known: {', '.join(ALGORITHMS)}")


def hyperparameter_entry(hyperparams: pathlib.Path, env_id: str) -> dict[str, Any]:
    """The entry for ``env_id`` in a hyperparameter YAML (``hyperparams/ppo.yml``), or its
    ``default`` entry.

    :raises ValueError: for a missing file or a file with neither entry
    """
    if not hyperparams.is_file():
        raise ValueError(f"hyperparameter file not found: {hyperparams}")
    table = yaml.safe_load(hyperparams.read_text()) or {}
    if env_id not in table and "default" not in table:
        raise ValueError(f"{hyperparams} has no entry for {env_id} and no 'default'")
    entry: dict[str, Any] = table[env_id] if env_id in table else table["default"]
    return copy.deepcopy(dict(entry))


def run_config(
    env_id: str,
    hyperparams: pathlib.Path,
    *,
    algo: str = "ppo",
    seed: int = 0,
    timesteps: int | None = None,
    n_envs: int | None = None,
    eval_freq: int = 0,
    eval_episodes: int = 10,
    checkpoint_freq: int = 0,
) -> dict[str, Any]:
    """The settings of a new run, as train.py resolves them: the YAML entry, then overrides.

    :param env_id: the registered env id to train on
    :param hyperparams: the hyperparameter YAML for ``algo``
    :param algo: one of :data:`ALGORITHMS`; its keyword arguments go under ``config[algo]``
    :param timesteps: total steps (default: the entry's ``n_timesteps``)
    :param n_envs: robots collecting experience (default: the entry's ``n_envs``)
    :param eval_freq: steps between harness evaluations during training (0: none)
    :param eval_episodes: episodes per evaluation
    :param checkpoint_freq: steps between checkpoints (0: only the one at the end)
    """
    if algo not in ALGORITHMS:
        raise ValueError(f"unknown algo {algo!r}; known: {', '.join(ALGORITHMS)}")
    entry = hyperparameter_entry(hyperparams, env_id)
    entry_timesteps = entry.pop("n_timesteps", 1_000_000)
    entry_n_envs = entry.pop("n_envs", 16)
    config = {
        "env": env_id,
        "algo": algo,
        "seed": int(seed),
        "timesteps": int(timesteps or entry_timesteps),
        "n_envs": int(n_envs or entry_n_envs),
        "env_kwargs": entry.pop("env_kwargs", {}),
        "vec_env": "native",
        "eval_freq": int(eval_freq),
        "eval_episodes": int(eval_episodes),
        "checkpoint_freq": int(checkpoint_freq),
        algo: entry,
    }
    for name in ("timesteps", "n_envs"):
        if config[name] < 1:
            raise ValueError(f"{name} must be at least 1, got {config[name]}")
    return config


def env_kwargs_for(config: dict[str, Any]) -> dict[str, Any]:
    """The run's ``env_kwargs`` as the environment takes them: a ``reward_weights`` mapping
    (as YAML stores it) becomes a :class:`~mobile_envs.config.RewardWeights`.

    :raises ValueError: for a reward weight the environment does not have
    """
    from mobile_envs.config import RewardWeights

    kwargs = dict(config.get("env_kwargs") or {})
    weights = kwargs.get("reward_weights")
    if isinstance(weights, dict):
        known = set(RewardWeights.__dataclass_fields__)
        unknown = sorted(set(weights) - known)
        if unknown:
            raise ValueError(f"unknown reward weights {unknown}; known: {sorted(known)}")
        kwargs["reward_weights"] = RewardWeights(**{**vars(RewardWeights()), **weights})
    return kwargs


def make_training_env(config: dict[str, Any]) -> Any:
    """The VecEnv a run collects experience from, seeded from the run's seed."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecMonitor

    import mobile_envs  # noqa: F401  (registers the ids)
    from mobile_envs.sb3 import PathFollowingSB3VecEnv

    if config.get("vec_env", "native") == "native":
        env = PathFollowingSB3VecEnv(
            config["env"], config["n_envs"], seed=config["seed"], **env_kwargs_for(config)
        )
        return VecMonitor(env, info_keywords=("is_success",))
    return make_vec_env(
        config["env"],
        n_envs=config["n_envs"],
        seed=config["seed"],
        env_kwargs=env_kwargs_for(config),
        monitor_kwargs={"info_keywords": ("is_success",)},
    )


def write_config(folder: pathlib.Path, config: dict[str, Any]) -> None:
    """Write ``config.yml`` into a new run folder."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "config.yml").write_text(yaml.safe_dump(config, sort_keys=False))


def train_run(
    folder: pathlib.Path,
    config: dict[str, Any] | None = None,
    *,
    callbacks: Sequence[BaseCallback] = (),
    threads: int = 1,
) -> BaseAlgorithm:
    """Train the run in ``folder`` to ``config["timesteps"]`` steps and return the model.

    A folder that already holds ``checkpoints/latest.zip`` continues from it with its own
    ``config.yml`` (as ``train.py --resume`` does); otherwise ``config`` starts a new run
    there. The checkpoint and ``final_model.zip`` are saved at the end, also when a callback
    stops training early or an exception (Ctrl-C included) interrupts it.

    :param folder: the run folder
    :param config: the settings of a new run (:func:`run_config`); ignored when resuming
    :param callbacks: more SB3 callbacks, after the checkpoint callback
    :param threads: torch threads; 1, since on 2 cores 2 threads made PPO ~15x slower
    :raises ValueError: when there is neither a checkpoint nor a config
    """
    import torch

    from agents.ppo import AtomicCheckpointCallback, save_atomically

    torch.set_num_threads(threads)
    checkpoint = folder / "checkpoints" / "latest.zip"
    resuming = checkpoint.is_file()
    if resuming:
        config = yaml.safe_load((folder / "config.yml").read_text())
    elif config is None:
        raise ValueError(f"{folder} holds no checkpoint to continue, and no config was given")
    else:
        write_config(folder, config)
    assert config is not None
    algo = config.get("algo", "ppo")
    algorithm = algorithm_class(algo)
    env = make_training_env(config)
    if resuming:
        model = algorithm.load(checkpoint, device="cpu")
        model.set_env(env)
    else:
        kwargs = dict(config[algo])
        model = algorithm(
            kwargs.pop("policy", "MlpPolicy"),
            env,
            seed=config["seed"],
            device="cpu",
            verbose=0,
            **kwargs,
        )
    model.trained_on = config["env"]  # type: ignore[attr-defined]  # see agents.ppo
    remaining = config["timesteps"] - model.num_timesteps
    try:
        if remaining > 0:
            model.learn(
                remaining,
                callback=[
                    AtomicCheckpointCallback(folder, config["checkpoint_freq"]),
                    *callbacks,
                ],
                reset_num_timesteps=not resuming,
            )
    finally:
        save_atomically(model, checkpoint)
        save_atomically(model, folder / "final_model.zip")
        env.close()
    return model

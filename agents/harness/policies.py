"""Trained policies as the harness loads them: the algorithms a run can train, which one
saved a model zip, and whether a policy fits an env.

Importing this module needs no Stable-Baselines3; loading a policy needs the ``train`` extra.
"""

from __future__ import annotations

import json
import os
import pathlib
import pickle
import zipfile
import zlib
from typing import TYPE_CHECKING, Any

import gymnasium as gym

if TYPE_CHECKING:
    from stable_baselines3.common.base_class import BaseAlgorithm

#: What every SB3 model zip holds: the class parameters and the policy's weights.
MODEL_ZIP_MEMBERS = ("data", "policy.pth")


#: The module of a saved model's policy class, for each algorithm. PPO's policies live in
#: SB3's common module (A2C's too: PPO's zip is told apart by its ``clip_range``), and ours
#: (:mod:`agents.training.speed_floor`) in agents.training.
POLICY_MODULES = {
    "stable_baselines3.common.policies": "ppo",
    "agents.training.speed_floor": "ppo",
    "stable_baselines3.sac.policies": "sac",
    "stable_baselines3.td3.policies": "td3",
    "sb3_contrib.tqc.policies": "tqc",
}


#: The env settings that shape what a policy observes. A policy records those it was trained
#: with (train.py saves them as its ``observation_settings``), and the harness evaluates it in
#: envs made with them: one policy trained with ``command_history`` is measured on the ideal
#: and the realistic robot alike.
OBSERVATION_SETTINGS = ("sensors",)


def observation_settings(env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """The :data:`OBSERVATION_SETTINGS` among an env's keyword arguments."""
    return {name: env_kwargs[name] for name in OBSERVATION_SETTINGS if name in env_kwargs}


def recorded_observation_settings(model: Any) -> dict[str, Any]:
    """The observation settings ``model`` was trained with, if it recorded any (empty: the
    envs' defaults, as for a policy saved before they were recorded)."""
    recorded = getattr(model, "observation_settings", None)
    return observation_settings(recorded) if isinstance(recorded, dict) else {}


def check_spaces(
    model: BaseAlgorithm, env: gym.Env | Any, model_path: str | os.PathLike[str]
) -> None:
    """Raise ValueError naming both sides when a policy's spaces do not fit an env (made with
    the observation settings the policy records, as the harness makes it).

    :param model: the loaded policy
    :param env: a single env or a vector env (its single spaces are compared)
    :param model_path: the file the policy came from, for the message
    """
    observation_space = getattr(env, "single_observation_space", env.observation_space)
    recorded = recorded_observation_settings(model)
    if recorded and not hasattr(env, "single_observation_space"):
        from agents.harness.batch import env_settings
        from mobile_envs.envs.path_following import PathFollowingEnv

        unwrapped = env.unwrapped
        if isinstance(unwrapped, PathFollowingEnv):
            own = PathFollowingEnv(**{**env_settings(unwrapped), **recorded})
            observation_space = own.observation_space
            own.close()
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


def trained_model_name(model: BaseAlgorithm) -> str | None:
    """The kinematic model (``"diff_drive"``, ...) a policy was trained for, if it recorded
    its training env in ``trained_on`` (train.py does), else None."""
    env_id = getattr(model, "trained_on", None)
    if env_id is None or env_id not in gym.registry:
        return None
    return gym.spec(env_id).kwargs.get("model")


def drives_same_model(model: BaseAlgorithm, env: gym.Env | Any) -> bool:
    """False when the policy was trained for another kinematic model than ``env``'s.

    Observation sizes alone cannot tell: the differential drive and the bicycle both have
    45 observations and 2 actions.
    """
    trained = trained_model_name(model)
    return trained is None or trained == _kinematic_model_name(env)


def _kinematic_model_name(env: gym.Env | Any) -> str:
    unwrapped: Any = env.unwrapped  # a PathFollowingEnv, whose ``model`` is documented
    return unwrapped.model.name


def load_policy(
    path: str | os.PathLike[str], env: gym.Env | Any | None = None, algo: str | None = None
) -> BaseAlgorithm:
    """Load a saved policy of any algorithm in :data:`agents.harness.policies.ALGORITHMS`; with
    ``env``,
    check that its spaces and kinematic model fit.

    :param path: a ``.zip`` saved by SB3 or sb3-contrib
    :param env: the env it will act in, or None to skip the checks
    :param algo: the algorithm the zip must hold, or None to take the one it holds
    :raises ValueError: naming ``path`` for a missing, truncated or corrupt file, a model of
        another algorithm than ``algo``, or a policy that does not fit ``env``
    """

    path = pathlib.Path(path)
    if not path.is_file():
        raise ValueError(f"no policy file at {path}")
    check_model_zip(path)
    saved = model_algorithm(path)
    if algo is not None and algo != saved:
        raise ValueError(f"{path} holds a {saved.upper()} model, not {algo.upper()}")
    try:
        model = algorithm_class(saved).load(path, device="cpu")
    except (ValueError, KeyError, RuntimeError, EOFError, pickle.UnpicklingError) as error:
        # A complete zip with the right members whose contents do not decode: SB3 and torch
        # report that with these types; anything else is a bug and keeps its traceback.
        raise ValueError(
            f"{path} is not a loadable {saved.upper()} policy: "
            f"{type(error).__name__}: {first_line(error)}"
        ) from error
    if env is not None:
        check_spaces(model, env, path)
        if not drives_same_model(model, env):
            raise ValueError(
                f"the policy in {path} was trained on {getattr(model, 'trained_on', None)} "
                f"({trained_model_name(model)}), not for the {_kinematic_model_name(env)} model"
            )
    return model


def model_algorithm(path: str | os.PathLike[str]) -> str:
    """The algorithm (``"ppo"``, ``"sac"``, ``"td3"``, ``"tqc"``) that saved the model zip at
    ``path``, read from its policy class without loading torch's weights.

    :raises ValueError: naming ``path`` for a file that is not a model zip of one of them
    """
    path = pathlib.Path(path)
    check_model_zip(path)
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
        module = data["policy_class"]["__module__"]
    except (ValueError, KeyError, TypeError, zipfile.BadZipFile, zlib.error) as error:
        raise ValueError(
            f"{path} is not a loadable policy: its 'data' does not name a policy class "
            f"({type(error).__name__})"
        ) from None
    algo = POLICY_MODULES.get(module) if isinstance(module, str) else None
    if algo == "ppo" and "clip_range" not in data:
        algo = None
    if algo is None:
        raise ValueError(
            f"{path} holds a model of another algorithm (policy from {module!r:.80}); "
            "train.py knows PPO, SAC, TD3 and TQC"
        )
    return algo


def check_model_zip(path: pathlib.Path) -> None:
    """Raise ValueError naming ``path`` unless it is a complete, undamaged SB3 model zip.

    SB3 itself reports a truncated file as ``AssertionError: No data found``: the zip reader
    finds the end record of a torch archive nested inside it.
    """
    try:
        with zipfile.ZipFile(path) as archive:
            damaged = archive.testzip()  # reads every member and checks its CRC
            members = set(archive.namelist())
    except (zipfile.BadZipFile, EOFError, zlib.error) as error:
        raise ValueError(
            f"{path} is not a model zip (truncated or corrupt?): {first_line(error)}"
        ) from None
    if damaged is not None:
        raise ValueError(f"{path} is corrupt: its member {damaged!r} fails the CRC check")
    missing = [name for name in MODEL_ZIP_MEMBERS if name not in members]
    if missing:
        raise ValueError(
            f"{path} is not a Stable-Baselines3 model (truncated?): it has no "
            + " and no ".join(repr(name) for name in missing)
        )


def first_line(error: BaseException) -> str:
    lines = str(error).strip().splitlines()
    return lines[0] if lines else repr(error)


#: The algorithms a run can train, by the name a config's ``algo`` key (and its section) uses.
ALGORITHMS = ("ppo", "sac", "td3", "tqc")


def algorithm_class(algo: str) -> type[BaseAlgorithm]:
    """The Stable-Baselines3 (or sb3-contrib) class for ``algo``.

    :raises ValueError: for an algorithm not in :data:`ALGORITHMS`
    """
    if algo == "ppo":
        from stable_baselines3 import PPO

        return PPO
    if algo == "sac":
        from stable_baselines3 import SAC

        return SAC
    if algo == "td3":
        from stable_baselines3 import TD3

        return TD3
    if algo == "tqc":
        from sb3_contrib import TQC

        return TQC
    raise ValueError(f"unknown algo {algo!r}; known: {', '.join(ALGORITHMS)}")

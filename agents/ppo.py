"""Policy helpers for train.py and the evaluation harness: loading with checks, atomic saves,
checkpoints that survive interruption, and periodic evaluation with the harness's metrics.

Named after PPO, the first algorithm, they serve all of :data:`agents.runs.ALGORITHMS`: a
model zip says which algorithm saved it (:func:`model_algorithm`), and an off-policy run's
checkpoint keeps its replay buffer beside it (:func:`save_checkpoint`).

Requires the ``train`` extra (stable-baselines3, sb3-contrib for TQC, torch).
"""

from __future__ import annotations

import contextlib
import errno
import io
import json
import math
import os
import pathlib
import pickle
import zipfile
import zlib
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from agents.interrupts import StopRequests

#: What every SB3 model zip holds: the class parameters and the policy's weights.
MODEL_ZIP_MEMBERS = ("data", "policy.pth")
#: The module of a saved model's policy class, for each algorithm. PPO's policies live in
#: SB3's common module (A2C's too: PPO's zip is told apart by its ``clip_range``).
POLICY_MODULES = {
    "stable_baselines3.common.policies": "ppo",
    "stable_baselines3.sac.policies": "sac",
    "stable_baselines3.td3.policies": "td3",
    "sb3_contrib.tqc.policies": "tqc",
}


def check_spaces(
    model: BaseAlgorithm, env: gym.Env | Any, model_path: str | os.PathLike[str]
) -> None:
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
    """Load a saved policy of any algorithm in :data:`agents.runs.ALGORITHMS`; with ``env``,
    check that its spaces and kinematic model fit.

    :param path: a ``.zip`` saved by SB3 or sb3-contrib
    :param env: the env it will act in, or None to skip the checks
    :param algo: the algorithm the zip must hold, or None to take the one it holds
    :raises ValueError: naming ``path`` for a missing, truncated or corrupt file, a model of
        another algorithm than ``algo``, or a policy that does not fit ``env``
    """
    from agents.runs import algorithm_class

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
            f"{type(error).__name__}: {_first_line(error)}"
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
            f"{path} is not a model zip (truncated or corrupt?): {_first_line(error)}"
        ) from None
    if damaged is not None:
        raise ValueError(f"{path} is corrupt: its member {damaged!r} fails the CRC check")
    missing = [name for name in MODEL_ZIP_MEMBERS if name not in members]
    if missing:
        raise ValueError(
            f"{path} is not a Stable-Baselines3 model (truncated?): it has no "
            + " and no ".join(repr(name) for name in missing)
        )


def _first_line(error: BaseException) -> str:
    lines = str(error).strip().splitlines()
    return lines[0] if lines else repr(error)


def write_atomically(
    path: str | os.PathLike[str], write: Callable[[io.BufferedWriter], object]
) -> pathlib.Path:
    """Write a file so that a crash, a signal or a power loss leaves either its old or its new
    contents at ``path``, never a mix, and no temporary file.

    ``write`` fills a temporary file in the same folder, which is flushed and synced to disk
    (``os.fsync``), renamed over ``path`` (``os.replace``, atomic on POSIX and Windows), and
    then the folder itself is synced so that the rename survives a power loss (POSIX only;
    skipped where the OS or file system cannot sync a folder).

    :param path: the file to write; its folder is created if needed
    :param write: writes the contents to the binary file it is given
    :raises OSError: with ``path`` as its file name when the folder is not writable or full
    """
    path = pathlib.Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.partial")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(temporary, "wb") as file:
            write(file)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, path)
    except OSError as error:
        _remove_partial(temporary)
        raise OSError(error.errno, error.strerror or str(error), str(path)) from error
    except BaseException:  # KeyboardInterrupt included: never leave a .partial file behind
        _remove_partial(temporary)
        raise
    _sync_folder(path.parent)
    return path


def _remove_partial(temporary: pathlib.Path) -> None:
    """Remove a temporary file if it was made; where it could not be (its folder is a file,
    or is missing) there is nothing to remove."""
    with contextlib.suppress(FileNotFoundError, NotADirectoryError):
        temporary.unlink()


def _sync_folder(folder: pathlib.Path) -> None:
    if os.name != "posix":
        return  # Windows cannot open a folder with os.open, so there is nothing to sync
    descriptor = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        os.fsync(descriptor)
    except OSError as error:
        if error.errno not in (errno.EINVAL, errno.ENOTSUP, errno.EBADF):
            raise  # some file systems cannot sync a folder; a failing disk still raises
    finally:
        os.close(descriptor)


def save_atomically(model: BaseAlgorithm, path: str | os.PathLike[str]) -> pathlib.Path:
    """Save ``model`` to ``path`` (a .zip) with :func:`write_atomically`: an interruption or a
    power loss never leaves a half-written model behind, nor a temporary file.

    :raises OSError: naming ``path`` when the folder is not writable or the disk is full
    """
    return write_atomically(path, lambda file: model.save(file))


#: An off-policy checkpoint's replay buffer: ``checkpoints/replay_buffer_STEPS.pkl``.
REPLAY_BUFFER_PATTERN = "replay_buffer_{steps}.pkl"


def replay_buffer_path(folder: pathlib.Path, steps: int) -> pathlib.Path:
    """Where a run's checkpoint at ``steps`` keeps its replay buffer."""
    return folder / "checkpoints" / REPLAY_BUFFER_PATTERN.format(steps=steps)


def save_checkpoint(model: BaseAlgorithm, folder: pathlib.Path) -> pathlib.Path:
    """Save ``checkpoints/latest.zip`` atomically, and an off-policy model's replay buffer
    first, named after the step, so that a resume continues with the transitions the model
    had seen: an interruption between the two saves leaves the previous checkpoint with its
    own buffer (the newer buffer is removed at the next save). Returns the checkpoint's path.

    :raises OSError: naming the file when the folder is not writable or the disk is full
    """
    buffer = getattr(model, "replay_buffer", None)
    kept = None
    if buffer is not None:
        kept = replay_buffer_path(folder, model.num_timesteps)
        # What SB3's save_replay_buffer writes, into the atomic writer's own file.
        write_atomically(kept, lambda file: pickle.dump(buffer, file, pickle.HIGHEST_PROTOCOL))
    checkpoint = save_atomically(model, folder / "checkpoints" / "latest.zip")
    for stale in (folder / "checkpoints").glob(REPLAY_BUFFER_PATTERN.format(steps="*")):
        if stale != kept:
            stale.unlink(missing_ok=True)
    return checkpoint


def load_checkpoint(
    folder: pathlib.Path, env: Any | None = None, algo: str | None = None
) -> BaseAlgorithm:
    """The model of ``checkpoints/latest.zip`` on ``env``, with the replay buffer of the same
    step for the off-policy algorithms.

    :param folder: the run folder
    :param env: the VecEnv training goes on in (SB3 checks its spaces), or None
    :param algo: the algorithm the run's config names, or None to take the checkpoint's
    :raises ValueError: naming the checkpoint when it is missing, damaged or not a model, or
        the replay buffer of its step when that cannot be read
    """
    checkpoint = folder / "checkpoints" / "latest.zip"
    model = load_policy(checkpoint, algo=algo)
    if env is not None:
        model.set_env(env)
    if getattr(model, "replay_buffer", None) is not None:
        buffer = replay_buffer_path(folder, model.num_timesteps)
        if not buffer.is_file():
            raise ValueError(
                f"{checkpoint} is an off-policy checkpoint without its replay buffer {buffer}"
            )
        try:
            model.load_replay_buffer(buffer)  # type: ignore[attr-defined]
        except (EOFError, pickle.UnpicklingError, ValueError, AttributeError) as error:
            raise ValueError(
                f"{buffer} is not a readable replay buffer: {type(error).__name__}: "
                f"{_first_line(error)}"
            ) from None
    return model


def _stores_after_callbacks(model: BaseAlgorithm) -> bool:
    """Whether ``model`` stores a step's transitions after its callbacks' ``on_step``: SB3's
    off-policy algorithms do, so a step is only whole in their replay buffer at the end of
    the collection (``on_rollout_end``)."""
    return isinstance(model, OffPolicyAlgorithm)


class StopOnRequest(CallbackList):
    """Run ``callbacks`` until a stop signal is recorded in ``requests``, then end training at
    the first point where the model is whole, before they run again:

    - on-policy (PPO): at the next step; ``learn`` returns normally, so call
      :meth:`~agents.interrupts.StopRequests.raise_if_requested` after it;
    - off-policy (SAC, TD3, TQC): once the collection's transitions are in the replay
      buffer (every step at ``train_freq`` 1), raising
      :class:`~agents.interrupts.Interrupted` out of ``learn``.

    :param requests: the stop requests, polled once a step
    :param callbacks: the run's other callbacks
    """

    def __init__(self, requests: StopRequests, callbacks: Sequence[BaseCallback] = ()):
        super().__init__(list(callbacks))
        self.requests = requests

    def _on_step(self) -> bool:
        if self.requests.requested:
            return _stores_after_callbacks(self.model)  # off-policy: store the step first
        return super()._on_step()

    def _on_rollout_end(self) -> None:
        if _stores_after_callbacks(self.model):
            self.requests.raise_if_requested()
        super()._on_rollout_end()


class AtomicCheckpointCallback(BaseCallback):
    """Every ``every`` environment steps, save ``checkpoints/latest.zip`` atomically (with the
    replay buffer of an off-policy model: :func:`save_checkpoint`).

    Counted from the step training starts at, so a resumed run does not save again at once.
    An off-policy model saves at the end of a collection, once the step's transitions are in
    its replay buffer, so the buffer holds every step the checkpoint counts.

    :param folder: the run folder
    :param every: steps between checkpoints (0 disables them)
    """

    def __init__(self, folder: pathlib.Path, every: int):
        super().__init__()
        self.folder = folder
        self.every = every
        self._last = 0

    def _on_training_start(self) -> None:
        self._last = self.num_timesteps

    def _save_when_due(self) -> None:
        if self.every and self.num_timesteps - self._last >= self.every:
            self._last = self.num_timesteps
            save_checkpoint(self.model, self.folder)

    def _on_step(self) -> bool:
        if not _stores_after_callbacks(self.model):
            self._save_when_due()
        return True

    def _on_rollout_end(self) -> None:
        if _stores_after_callbacks(self.model):
            self._save_when_due()


class HarnessEvalCallback(BaseCallback):
    """Evaluate the policy with :func:`agents.evaluate.evaluate` every ``every`` steps, log the
    summary (``eval/...``, also to TensorBoard when enabled) and keep the best model.

    Best means the highest completion rate, then the lowest mean |cross-track error|. The
    best score is kept in ``best_model.json`` beside the model, so a resumed run only replaces
    ``best_model.zip`` with a better policy; evaluations are counted from the step training
    starts at, so a resumed run does not evaluate at once.

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
        self.best_score = _read_best_score(folder / BEST_SCORE_FILE)
        self._last = 0

    def _on_training_start(self) -> None:
        self._last = self.num_timesteps

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
            # The model first: an interruption between the two leaves an older, lower score,
            # which a later evaluation can only beat with a policy at least as good.
            save_atomically(self.model, self.folder / "best_model.zip")
            record = {"completion_rate": score[0], "mean_abs_cte": -score[1]}
            write_atomically(
                self.folder / BEST_SCORE_FILE, lambda file: file.write(json.dumps(record).encode())
            )
        return summary


#: Beside ``best_model.zip``: the score it was kept for.
BEST_SCORE_FILE = "best_model.json"


def _read_best_score(path: pathlib.Path) -> tuple[float, float]:
    """The score a run's ``best_model.zip`` was kept for; the lowest score when it has none
    (a new run, or a file that cannot be read: the next evaluation then decides)."""
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
        score = (float(record["completion_rate"]), -float(record["mean_abs_cte"]))
    except (OSError, ValueError, KeyError, TypeError):
        return (-math.inf, -math.inf)
    return score if all(math.isfinite(value) for value in score) else (-math.inf, -math.inf)

"""Checkpoints that survive interruption, and periodic evaluation with the harness's metrics.

They serve all of :data:`agents.harness.policies.ALGORITHMS`: an off-policy run's checkpoint
keeps its replay buffer beside it (:func:`save_checkpoint`), and every save is atomic.

Requires the ``train`` extra (stable-baselines3, sb3-contrib for TQC, torch).
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import pickle
import resource
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from agents.harness.policies import first_line, load_policy
from agents.interrupts import StopRequests
from agents.training.files import write_atomically


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
    folder: pathlib.Path,
    env: Any | None = None,
    algo: str | None = None,
    config: dict[str, Any] | None = None,
) -> BaseAlgorithm:
    """The model of ``checkpoints/latest.zip`` on ``env``, with the replay buffer of the same
    step for the off-policy algorithms.

    :param folder: the run folder
    :param env: the VecEnv training goes on in (SB3 checks its spaces), or None
    :param algo: the algorithm the run's config names, or None to take the checkpoint's
    :param config: the run's settings (its ``config.yml``), checked against the checkpoint,
        or None
    :raises ValueError: naming the checkpoint when it is missing, damaged or not a model, or
        the replay buffer of its step when that cannot be read, or naming ``config.yml``
        when its ``n_envs`` is not the checkpoint's
    """
    checkpoint = folder / "checkpoints" / "latest.zip"
    model = load_policy(checkpoint, algo=algo)
    if config is not None and config.get("n_envs") != model.n_envs:
        raise ValueError(
            f"{folder / 'config.yml'}: 'n_envs' is {config.get('n_envs')!r}, but {checkpoint} "
            f"trained on {model.n_envs} robots: a run resumes with the robots it had; set "
            f"n_envs back to {model.n_envs}"
        )
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
                f"{first_line(error)}"
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


class EveryStepsCallback(BaseCallback):
    """A callback that acts every ``every`` environment steps, counted from the step training
    starts at, so a resumed run does not act again at once.

    :param every: steps between two actions (0: never)
    """

    def __init__(self, every: int):
        super().__init__()
        self.every = every
        self._last = 0

    def _on_training_start(self) -> None:
        self._last = self.num_timesteps

    def _due(self) -> bool:
        """Whether ``every`` steps have passed since the last action; if so, the next ones
        are counted from now."""
        if self.every and self.num_timesteps - self._last >= self.every:
            self._last = self.num_timesteps
            return True
        return False


class AtomicCheckpointCallback(EveryStepsCallback):
    """Every ``every`` environment steps, save ``checkpoints/latest.zip`` atomically (with the
    replay buffer of an off-policy model: :func:`save_checkpoint`).

    Counted from the step training starts at, so a resumed run does not save again at once.
    An off-policy model saves at the end of a collection, once the step's transitions are in
    its replay buffer, so the buffer holds every step the checkpoint counts.

    :param folder: the run folder
    :param every: steps between checkpoints (0 disables them)
    """

    def __init__(self, folder: pathlib.Path, every: int):
        super().__init__(every)
        self.folder = folder

    def _save_when_due(self) -> None:
        if self._due():
            save_checkpoint(self.model, self.folder)

    def _on_step(self) -> bool:
        if not _stores_after_callbacks(self.model):
            self._save_when_due()
        return True

    def _on_rollout_end(self) -> None:
        if _stores_after_callbacks(self.model):
            self._save_when_due()


#: A run's snapshots: ``snapshots/steps_STEPS.zip``, and when each was taken.
SNAPSHOT_PATTERN = "steps_{steps:010d}.zip"
SNAPSHOT_TIMES = "times.csv"


def process_cpu_seconds() -> float:
    """CPU time (user + system) this process has used since it started."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


class SnapshotCallback(BaseCallback):
    """Keep the policy every ``every`` steps: ``snapshots/steps_STEPS.zip``, and a line
    ``steps,unix_time,cpu_seconds`` in ``snapshots/times.csv`` saying when it was saved (the
    wall clock, and the CPU time the process had used), so a benchmark can tell when a run
    first met its targets (``benchmarks/bench_time_to_target.py``).

    A snapshot is taken between two collections, once the policy has learned from every
    step it counts: when training starts (the policy RL starts from: a warm start's clone),
    before the first collection at least ``every`` steps after the last snapshot, and when
    training ends.

    :param folder: the run folder
    :param every: steps between snapshots, at least 1
    """

    def __init__(self, folder: pathlib.Path, every: int):
        super().__init__()
        if isinstance(every, bool) or not isinstance(every, int) or every < 1:
            raise ValueError(f"snapshots need every >= 1 step, got {every!r}")
        self.folder = folder / "snapshots"
        self.every = every
        self._last: int | None = None

    def _on_training_start(self) -> None:
        self.save()

    def _on_rollout_start(self) -> None:
        if self._last is not None and self.num_timesteps - self._last >= self.every:
            self.save()

    def _on_step(self) -> bool:
        return True

    def _on_training_end(self) -> None:
        if self.num_timesteps != self._last:
            self.save()

    def save(self) -> pathlib.Path:
        """Save the policy now and record when."""
        path = save_atomically(
            self.model, self.folder / SNAPSHOT_PATTERN.format(steps=self.num_timesteps)
        )
        line = f"{self.num_timesteps},{time.time():.3f},{process_cpu_seconds():.3f}\n"
        with (self.folder / SNAPSHOT_TIMES).open("a", encoding="utf-8") as times:
            times.write(line)
        self._last = self.num_timesteps
        return path


class HarnessEvalCallback(EveryStepsCallback):
    """Evaluate the policy with :func:`agents.harness.evaluate.evaluate` every ``every`` steps, log
    the summary (``eval/...``, also to TensorBoard when enabled) and keep the best model.

    An evaluation runs between two collections, once the policy has learned from every step
    it counts (the policies :class:`SnapshotCallback` keeps at the same ``every``), and
    :meth:`finish` measures the final policy too. Best means the highest completion rate,
    then the lowest mean |cross-track error|; of equal scores the first is kept. The best
    score and step are kept in ``best_model.json`` beside the model, so a resumed run only replaces
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
        super().__init__(every)
        self.env_id = env_id
        self.folder = folder
        self.episodes = episodes
        self.seed = seed
        self.env_kwargs = env_kwargs or {}
        self.best_score = _read_best_score(folder / BEST_SCORE_FILE)
        self._evaluated_at: int | None = None
        self._last_summary: dict[str, float] | None = None

    @classmethod
    def for_run(cls, folder: pathlib.Path, config: dict[str, Any]) -> HarnessEvalCallback:
        """The evaluations a run's ``config`` asks for: its ``eval_episodes`` episodes of its
        training env, with its settings, every ``eval_freq`` steps; the best model in
        ``folder``."""
        return cls(
            config["env"],
            folder,
            config["eval_freq"],
            episodes=config["eval_episodes"],
            env_kwargs=config["env_kwargs"],
        )

    def _on_rollout_start(self) -> None:
        if self._due():
            self.run_evaluation()

    def _on_step(self) -> bool:
        return True

    def finish(self, model: BaseAlgorithm) -> dict[str, float] | None:
        """Evaluate the final policy, unless it was the last one evaluated; call it once
        training has reached its total.

        :param model: the trained model; when this callback never ran (an earlier attempt
            trained it to its total), it is evaluated as it is
        :return: the final policy's summary; None when evaluations are off
        """
        if not self.every:
            return None
        if getattr(self, "model", None) is None:  # nothing trained in this process
            from stable_baselines3.common.logger import configure

            model.set_logger(configure(None, []))
            self.init_callback(model)
            self.num_timesteps = model.num_timesteps
        if self._evaluated_at != self.num_timesteps:
            self.run_evaluation()
        return self._last_summary

    def run_evaluation(self) -> dict[str, float]:
        """Evaluate now; return the summary."""
        from agents.harness.evaluate import evaluate

        self._evaluated_at = self.num_timesteps
        summary = evaluate(
            self.model, self.env_id, self.episodes, seed=self.seed, **self.env_kwargs
        ).summary
        self._last_summary = summary
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
            record = {
                "completion_rate": score[0],
                "mean_abs_cte": -score[1],
                "steps": self.num_timesteps,
            }
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

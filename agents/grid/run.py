"""One run of the grid: its settings, its training and its harness evaluation; and the local
backend, which runs many in processes."""

from __future__ import annotations

import json
import multiprocessing
import os
import pathlib
import shutil
import socket
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from typing import Any

from agents.grid.table import split_env_id

HYPERPARAMS = pathlib.Path(__file__).resolve().parents[2] / "hyperparams"


#: As in the sweep: no training env is seeded from these, so random paths are held out.
DEFAULT_EVAL_SEED = 1_000_000


@dataclass(frozen=True)
class RunSpec:
    """Everything that determines one run of the grid, and so its results.

    :param env: the env id to train on, ``mobile_envs/MODEL-PATHS-v0``
    :param algo: the algorithm (:data:`agents.harness.policies.ALGORITHMS`)
    :param seed: the training seed
    :param timesteps: training steps (None: the hyperparameter entry's)
    :param n_envs: robots collecting experience (None: the entry's)
    :param hyperparams: the algorithm's hyperparameter YAML, as text
    :param eval_envs: env ids the final policy is evaluated on
    :param episodes: episodes per evaluation env
    :param eval_seed: seed of the first evaluation episode
    :param eval_env_kwargs: keyword arguments for the evaluation envs
    :param checkpoint_freq: steps between checkpoints (0: only at the end)
    """

    env: str
    algo: str
    seed: int
    timesteps: int | None
    n_envs: int | None
    hyperparams: str
    eval_envs: tuple[str, ...]
    episodes: int
    eval_seed: int
    eval_env_kwargs: dict[str, Any] = field(default_factory=dict)
    checkpoint_freq: int = 0

    @property
    def name(self) -> str:
        return f"{self.env.split('/')[-1]}_{self.algo}_seed{self.seed}"

    def to_json(self) -> dict[str, Any]:
        record = asdict(self)
        record["eval_envs"] = list(self.eval_envs)
        return record


def parse_seeds(text: str) -> list[int]:
    """Seeds from ``0-9``, ``0,3,7`` or ``0-4,10``.

    :raises ValueError: for anything else, or a seed that repeats
    """
    seeds: list[int] = []
    for part in text.split(","):
        first, dash, last = part.strip().partition("-")
        if not first.isdigit() or (dash and not last.isdigit()):
            raise ValueError(f"--seeds: expected e.g. 0-9 or 0,3,7, got {text!r}")
        low, high = int(first), int(last) if dash else int(first)
        if high < low:
            raise ValueError(f"--seeds: range {part!r} runs backwards")
        seeds.extend(range(low, high + 1))
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"--seeds: {text!r} repeats a seed")
    return seeds


def evaluation_envs(env_id: str, path_sets: Sequence[str]) -> tuple[str, ...]:
    """The ids of ``env_id``'s robot on each path set."""
    import gymnasium as gym

    model, _ = split_env_id(env_id)
    ids = tuple(f"mobile_envs/{model}-{paths}-v0" for paths in path_sets)
    for candidate in ids:
        if candidate not in gym.registry:
            raise ValueError(f"no env {candidate} for path set {candidate.split('-')[1]!r}")
    return ids


def run_config_of(spec: RunSpec) -> dict[str, Any]:
    """The run folder's config for ``spec``."""
    import tempfile

    from agents.training.runs import run_config

    # The YAML travels as text, so a remote worker needs no copy of the caller's file.
    with tempfile.TemporaryDirectory() as folder:
        hyperparams = pathlib.Path(folder) / "hyperparams.yml"
        hyperparams.write_text(spec.hyperparams)
        return run_config(
            spec.env,
            hyperparams,
            algo=spec.algo,
            seed=spec.seed,
            timesteps=spec.timesteps,
            n_envs=spec.n_envs,
            checkpoint_freq=spec.checkpoint_freq,
        )


def log_attempt(folder: pathlib.Path) -> None:
    """Append this attempt (time, host, process) to ``attempts.log``: retries show there."""
    folder.mkdir(parents=True, exist_ok=True)
    with (folder / "attempts.log").open("a") as log:
        log.write(f"{time.strftime('%Y-%m-%dT%H:%M:%S')} {socket.gethostname()} {os.getpid()}\n")
        log.flush()
        os.fsync(log.fileno())


def finished_record(spec: RunSpec, output: pathlib.Path) -> dict[str, Any] | None:
    """The record of ``spec``'s run if it finished in ``output`` before, else None.

    :raises ValueError: when its folder holds a finished run of other settings
    """
    result_file = output / "runs" / spec.name / "evaluation.json"
    if not result_file.is_file():
        return None
    record: dict[str, Any] = json.loads(result_file.read_text())
    if record["spec"] != spec.to_json():
        raise ValueError(
            f"{result_file.parent} holds a run of other settings; use another --output"
        )
    return record


def run_one(spec: RunSpec, output: str) -> dict[str, Any]:
    """Train (or finish) and evaluate one run; return its record (also ``evaluation.json``).

    :param spec: the run
    :param output: the grid folder (absolute on a cluster)
    :raises ValueError: when the run folder holds a run of other settings
    """
    import mobile_envs  # noqa: F401  (registers the ids)
    from agents.harness.evaluate import evaluate
    from agents.harness.policies import algorithm_class, load_policy
    from agents.interrupts import stop_requests_on_main_thread
    from agents.training.runs import train_run

    folder = pathlib.Path(output) / "runs" / spec.name
    result_file = folder / "evaluation.json"
    finished = finished_record(spec, pathlib.Path(output))
    if finished is not None:
        return finished
    log_attempt(folder)
    config = run_config_of(spec)
    checkpoint = folder / "checkpoints" / "latest.zip"
    if checkpoint.is_file():
        steps = algorithm_class(spec.algo).load(checkpoint, device="cpu").num_timesteps
        if steps < config["timesteps"] and spec.checkpoint_freq == 0:
            # Continuing would not retrace the uninterrupted run bit for bit: start again.
            shutil.rmtree(folder / "checkpoints")
    # A worker's Ctrl-C or SIGTERM stops training at its next step and keeps the checkpoint.
    with stop_requests_on_main_thread() as requests:
        train_run(folder, config, requests=requests)
    policy = load_policy(folder / "final_model.zip")
    results = {
        env_id: evaluate(
            policy, env_id, spec.episodes, seed=spec.eval_seed, **spec.eval_env_kwargs
        ).summary
        for env_id in spec.eval_envs
    }
    record = {"spec": spec.to_json(), "run": spec.name, "results": results}
    temporary = result_file.with_name(".evaluation.json.partial")
    temporary.write_text(json.dumps(record, indent=1))
    os.replace(temporary, result_file)
    return record


def run_local(
    specs: Sequence[RunSpec], output: pathlib.Path, workers: int
) -> tuple[list[dict[str, Any]], dict[str, str]]:
    """Run ``specs`` in ``workers`` processes; return the records and the errors by run."""
    records, errors = [], {}
    context = multiprocessing.get_context("spawn")  # torch and numba do not survive fork
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        futures = {pool.submit(run_one, spec, str(output.resolve())): spec for spec in specs}
        for future in as_completed(futures):
            spec = futures[future]
            try:
                records.append(future.result())
                print(f"done: {spec.name}", flush=True)
            except Exception as error:  # one failed run must not stop the others
                errors[spec.name] = f"{type(error).__name__}: {error}"
                print(f"failed: {spec.name}: {errors[spec.name]}", flush=True)
    return records, errors

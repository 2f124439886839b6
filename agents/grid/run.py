"""One run of the grid: its settings, its training and its harness evaluation; and the local
backend, which runs many in processes."""

from __future__ import annotations

import json
import multiprocessing
import multiprocessing.connection
import os
import pathlib
import re
import shutil
import signal
import socket
import threading
import time
import typing
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from agents.arguments import SEED_LIMIT
from agents.grid.table import split_env_id

if TYPE_CHECKING:
    from multiprocessing.connection import Connection
    from multiprocessing.process import BaseProcess

    from agents.interrupts import StopRequests


#: Seconds between two progress lines of one training run.
PROGRESS_INTERVAL = 30.0


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
    :param select_every: steps between the evaluations on the training env that pick the
        policy the grid measures, ``best_model.zip``, as ``train.py --eval-freq`` does (0: the
        final policy)
    :param select_episodes: episodes of those evaluations (``train.py --eval-episodes``)
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
    select_every: int = 0
    select_episodes: int = 100

    @property
    def name(self) -> str:
        return f"{self.env.split('/')[-1]}_{self.algo}_seed{self.seed}"

    def to_json(self) -> dict[str, Any]:
        record = asdict(self)
        record["eval_envs"] = list(self.eval_envs)
        return record


class Recorded(Protocol):
    """What the grid evaluates and records in ``OUTPUT/runs/NAME/evaluation.json``: a training
    run (:class:`RunSpec`) or a classical agent (:class:`agents.grid.baselines.BaselineSpec`)."""

    @property
    def name(self) -> str: ...

    @property
    def eval_envs(self) -> tuple[str, ...]: ...

    @property
    def episodes(self) -> int: ...

    @property
    def eval_seed(self) -> int: ...

    @property
    def eval_env_kwargs(self) -> dict[str, Any]: ...

    def to_json(self) -> dict[str, Any]: ...


def parse_seeds(text: str) -> list[int]:
    """Seeds from ``0-9``, ``0,3,7`` or ``0-4,10``, each below 2**32.

    :raises ValueError: for anything else, or a seed that repeats
    """
    seeds: list[int] = []
    for part in text.split(","):
        match = re.fullmatch(r"\s*([0-9]+)\s*(?:-\s*([0-9]+)\s*)?", part)
        if match is None:
            raise ValueError(f"--seeds: expected e.g. 0-9 or 0,3,7, got {text!r}")
        low = int(match[1])
        high = low if match[2] is None else int(match[2])
        if high < low:
            raise ValueError(f"--seeds: range {part!r} runs backwards")
        if high >= SEED_LIMIT:
            raise ValueError(f"--seeds: seeds must be below 2**32, got {high}")
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
            eval_freq=spec.select_every,
            eval_episodes=spec.select_episodes,
            checkpoint_freq=spec.checkpoint_freq,
        )


def log_attempt(folder: pathlib.Path) -> None:
    """Append this attempt (time, host, process) to ``attempts.log``: retries show there."""
    folder.mkdir(parents=True, exist_ok=True)
    with (folder / "attempts.log").open("a") as log:
        log.write(f"{time.strftime('%Y-%m-%dT%H:%M:%S')} {socket.gethostname()} {os.getpid()}\n")
        log.flush()
        os.fsync(log.fileno())


def read_record(result_file: pathlib.Path) -> dict[str, Any]:
    """The record in a run's ``evaluation.json``.

    :raises ValueError: naming the file and what is wrong when it is not a record
    """
    try:
        record = json.loads(result_file.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"{result_file} is not a run's record: {error}") from None
    shape_ok = (
        isinstance(record, dict)
        and isinstance(record.get("spec"), dict)
        and isinstance(record.get("run"), str)
        and isinstance(record.get("results"), dict)
        and all(isinstance(summary, dict) for summary in record["results"].values())
    )
    if not shape_ok:
        raise ValueError(
            f"{result_file} is not a run's record: expected an object with 'spec', 'run' "
            f"and 'results', got {json.dumps(record)[:60]}"
        )
    return record


def finished_record(spec: Recorded, output: pathlib.Path) -> dict[str, Any] | None:
    """The record of ``spec``'s run if it finished in ``output`` before, else None.

    A damaged ``evaluation.json`` (cut short, edited) is moved aside to
    ``evaluation.json.damaged``, with a line saying so, and the run counts as unfinished: it
    is evaluated again (its training is done, so only the evaluation runs).

    :raises ValueError: when its folder holds a finished run of other settings
    """
    result_file = output / "runs" / spec.name / "evaluation.json"
    if not result_file.is_file():
        return None
    try:
        record = read_record(result_file)
    except ValueError as error:
        aside = result_file.with_name("evaluation.json.damaged")
        os.replace(result_file, aside)
        print(f"{error}; moved it to {aside.name}: the run is evaluated again", flush=True)
        return None
    if record["spec"] != spec.to_json():
        raise ValueError(
            f"{result_file.parent} holds a run of other settings; use another --output"
        )
    return record


def run_one(spec: RunSpec, output: str, requests: StopRequests | None = None) -> dict[str, Any]:
    """Train (or finish) and evaluate one run; return its record (also ``evaluation.json``).

    :param spec: the run
    :param output: the grid folder (absolute on a cluster)
    :param requests: the stop requests training and evaluation honour at their next step;
        None for ones installed here for the training, on the main thread
    :raises ValueError: when the run folder holds a run of other settings
    :raises agents.interrupts.Interrupted: when a stop was requested, once the checkpoint is
        saved
    """
    import mobile_envs  # noqa: F401  (registers the ids)
    from agents.harness.policies import algorithm_class, load_policy
    from agents.interrupts import stop_requests_on_main_thread
    from agents.training.checkpoints import BEST_SCORE_FILE, HarnessEvalCallback
    from agents.training.progress import ProgressLines
    from agents.training.runs import train_run

    folder = pathlib.Path(output) / "runs" / spec.name
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
            for name in ("best_model.zip", BEST_SCORE_FILE):
                (folder / name).unlink(missing_ok=True)
    # Runs train side by side for minutes: each says where it is, named (its warm start too).
    print(f"{spec.name}: training to {config['timesteps']:,} steps", flush=True)
    progress = ProgressLines(config["timesteps"], interval=PROGRESS_INTERVAL, label=spec.name)
    selection = HarnessEvalCallback.for_run(folder, config)
    callbacks = [progress, selection]
    # A worker's Ctrl-C or SIGTERM stops training at its next step and keeps the checkpoint.
    if requests is None:
        with stop_requests_on_main_thread() as own:
            model = train_run(folder, config, callbacks=callbacks, requests=own, label=spec.name)
    else:
        model = train_run(folder, config, callbacks=callbacks, requests=requests, label=spec.name)
    selection.finish(model)  # the final policy may be the best
    chosen = folder / ("best_model.zip" if spec.select_every else "final_model.zip")
    check_stop = None if requests is None else requests.raise_if_requested
    return record_evaluation(spec, load_policy(chosen), output, check_stop)


def record_evaluation(
    spec: Recorded,
    agent: Any,
    output: str | pathlib.Path,
    check_stop: Callable[[], None] | None = None,
) -> dict[str, Any]:
    """Drive ``agent`` through ``spec``'s evaluation episodes with the harness; return the
    record, written atomically to ``OUTPUT/runs/NAME/evaluation.json``."""
    from agents.harness.evaluate import evaluate
    from agents.training.files import write_atomically

    results = {
        env_id: evaluate(
            agent,
            env_id,
            spec.episodes,
            seed=spec.eval_seed,
            check_stop=check_stop,
            **spec.eval_env_kwargs,
        ).summary
        for env_id in spec.eval_envs
    }
    record = {"spec": spec.to_json(), "run": spec.name, "results": results}
    text = json.dumps(record, indent=1)
    result_file = pathlib.Path(output) / "runs" / spec.name / "evaluation.json"
    result_file.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(result_file, lambda file: file.write(text.encode()))
    return record


def _run_in_process(spec: RunSpec, output: str, sender: Connection, stop: threading.Event) -> None:
    """A local worker process: run ``spec`` and send ``("done", record)``, ``("failed",
    message)`` or ``("interrupted", signum)``. Its own Ctrl-C or SIGTERM, or ``stop`` set by
    the parent, stops it at the next step of training or evaluation, after saving."""
    from agents.interrupts import StopRequests, interruption_in, signum_of

    requests = StopRequests()

    def pass_on_stop() -> None:
        stop.wait()
        requests.request(signal.SIGTERM)

    with requests.installed():
        threading.Thread(target=pass_on_stop, daemon=True).start()
        try:
            sender.send(("done", run_one(spec, output, requests)))
        except BaseException as error:
            interruption = interruption_in(error)
            if interruption is None:
                sender.send(("failed", f"{type(error).__name__}: {error}"))
            else:
                sender.send(("interrupted", signum_of(interruption)))
        finally:
            sender.close()


def run_local(
    specs: Sequence[RunSpec],
    output: pathlib.Path,
    workers: int,
    requests: StopRequests | None = None,
) -> tuple[list[dict[str, Any]], dict[str, str]]:
    """Run ``specs`` in ``workers`` processes at a time; return the records and the errors by
    run.

    A stop recorded in ``requests`` (Ctrl-C or SIGTERM to this process) starts no more runs
    and asks the running ones to stop: each ends its training at the next step, saves its
    checkpoint and exits; once all have, :class:`~agents.interrupts.Interrupted` is raised.
    A second signal kills them at once.

    :raises agents.interrupts.Interrupted: after a stop request, once the workers are done
    """
    from agents.interrupts import Interrupted

    records: list[dict[str, Any]] = []
    errors: dict[str, str] = {}
    context = multiprocessing.get_context("spawn")  # torch and numba do not survive fork
    stop = context.Event()
    waiting = list(specs)
    running: dict[Connection, tuple[BaseProcess, RunSpec]] = {}
    folder = str(output.resolve())
    try:
        while waiting or running:
            if requests is not None and requests.requested:
                break
            while waiting and len(running) < workers:
                spec = waiting.pop(0)
                receiver, sender = context.Pipe(duplex=False)
                process = context.Process(
                    target=_run_in_process, args=(spec, folder, sender, stop), name=spec.name
                )
                process.start()
                sender.close()
                running[receiver] = (process, spec)
            for ready in multiprocessing.connection.wait(list(running), timeout=0.2):
                receiver = typing.cast("Connection", ready)
                _collect(receiver, running[receiver], records, errors)
                del running[receiver]
        if running:
            stop.set()
            for receiver in list(running):
                _collect(receiver, running[receiver], records, errors)
                del running[receiver]
    finally:
        for worker, _ in running.values():  # a second signal: no waiting for saves
            worker.kill()
            worker.join()
    if requests is not None and requests.signum is not None:
        raise Interrupted(requests.signum)
    return records, errors


def _collect(
    receiver: Connection,
    worker: tuple[BaseProcess, RunSpec],
    records: list[dict[str, Any]],
    errors: dict[str, str],
) -> None:
    """Read a worker's outcome into ``records`` or ``errors`` and wait for its process."""
    process, spec = worker
    try:
        kind, payload = receiver.recv()
    except EOFError:  # the process died before it could say anything
        process.join()
        kind, payload = "failed", f"its process ended with exit status {process.exitcode}"
    receiver.close()
    process.join()
    if kind == "done":
        records.append(payload)
        print(f"done: {spec.name}", flush=True)
    elif kind == "failed":  # one failed run must not stop the others
        errors[spec.name] = payload
        print(f"failed: {spec.name}: {payload}", flush=True)
    else:
        print(f"stopped: {spec.name} (its checkpoint is saved)", flush=True)

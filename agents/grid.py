"""``python train.py grid``: many independent, deterministic trainings, one harness evaluation
each, and one table of the results across seeds.

Run ``python train.py grid --help``. Every (training env, algo, seed) is a run folder
``OUTPUT/runs/ENV_ALGO_seedN`` (:mod:`agents.runs`) trained to ``--timesteps`` steps; its
final policy is then driven by the evaluation harness through ``--episodes`` episodes of
each ``--eval-paths`` path set of the same robot (the same episodes for every run: seeds
``--eval-seed`` on), and the summaries go to the folder's ``evaluation.json``.

``OUTPUT/grid.md`` holds one row per (model, path set, agent): the mean over seeds with its
95% Student-t interval, and rliable's interquartile mean (IQM) with its 95% stratified
bootstrap interval (:mod:`agents.grid_stats`), plus one row per (model, agent) over all path
sets. ``OUTPUT/grid.json`` holds every run's numbers, ``OUTPUT/iqm.png`` the IQMs.

Backends: ``--backend local`` runs ``--workers`` trainings at a time in processes;
``--backend ray --address HOST:PORT`` runs each as a Ray task on a cluster
(:mod:`agents.ray_grid`), which Ray retries when its worker or node dies. Either way a run
is a pure function of its settings, so the numbers are the same bit for bit whichever backend
ran them. A run that was cut short restarts from zero, which keeps that true; with
``--checkpoint-freq N`` it continues from its last checkpoint instead (faster after a crash,
but no longer bit-identical to an uninterrupted run). Running the same command again
restores an interrupted grid: finished runs are read back, the others run.

Requires the ``train`` and ``sweep`` extras (scipy), and ``ray`` for the Ray backend.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import pathlib
import shutil
import socket
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from typing import Any

from agents.grid_table import split_env_id, write_results

PROG = "train.py grid"
HYPERPARAMS = pathlib.Path(__file__).resolve().parents[1] / "hyperparams"
DEFAULT_PATH_SETS = ("Random", "Lines", "Segments", "SharpSegments", "Maze")
#: As in the sweep: no training env is seeded from these, so random paths are held out.
DEFAULT_EVAL_SEED = 1_000_000


@dataclass(frozen=True)
class RunSpec:
    """Everything that determines one run of the grid, and so its results.

    :param env: the env id to train on, ``mobile_envs/MODEL-PATHS-v0``
    :param algo: the algorithm (:data:`agents.runs.ALGORITHMS`)
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

    from agents.runs import run_config

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
    from agents.evaluate import evaluate
    from agents.interrupts import stop_requests_on_main_thread
    from agents.ppo import load_policy
    from agents.runs import algorithm_class, train_run

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


# ---------------------------------------------------------------------------- command line


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description=(
            "Train every (env, algo, seed), evaluate each final policy with the harness, and "
            "tabulate mean ± 95% CI and IQM across seeds."
        ),
    )
    parser.add_argument("--seeds", default="0-4", help="training seeds: 0-9, 0,3,7 (default: 0-4)")
    parser.add_argument(
        "--envs",
        nargs="+",
        default=["mobile_envs/DiffDrive-Random-v0"],
        metavar="ID",
        help="env ids to train on (default: mobile_envs/DiffDrive-Random-v0)",
    )
    parser.add_argument("--algos", nargs="+", default=["ppo"], help="algorithms (default: ppo)")
    parser.add_argument(
        "--eval-paths",
        nargs="+",
        default=list(DEFAULT_PATH_SETS),
        metavar="PATHS",
        help=f"path sets to evaluate on (default: {' '.join(DEFAULT_PATH_SETS)})",
    )
    parser.add_argument(
        "--episodes", type=int, default=20, help="episodes per path set (default: 20)"
    )
    parser.add_argument(
        "--eval-seed",
        type=int,
        default=DEFAULT_EVAL_SEED,
        help=f"seed of the first evaluation episode (default: {DEFAULT_EVAL_SEED})",
    )
    parser.add_argument(
        "--eval-env-kwargs",
        type=json.loads,
        default={},
        metavar="JSON",
        help="keyword arguments for the evaluation envs, e.g. '{\"start_noise\": [0.2, 0.3]}'",
    )
    parser.add_argument("--timesteps", type=int, help="training steps per run (default: YAML)")
    parser.add_argument("--n-envs", type=int, help="robots collecting experience (default: YAML)")
    parser.add_argument("--hyperparams", type=pathlib.Path, help="default: hyperparams/ALGO.yml")
    parser.add_argument(
        "--checkpoint-freq",
        type=int,
        default=0,
        help="steps between checkpoints a retry continues from (default: 0, runs restart)",
    )
    parser.add_argument("--output", type=pathlib.Path, default=pathlib.Path("grids/grid"))
    parser.add_argument("--backend", choices=("local", "ray"), default="local")
    parser.add_argument("--workers", type=int, default=2, help="local processes (default: 2)")
    parser.add_argument("--address", help="Ray cluster HOST:PORT (default: RAY_ADDRESS)")
    parser.add_argument(
        "--retries", type=int, default=2, help="Ray retries of a run whose worker died (default: 2)"
    )
    args = parser.parse_args(argv)
    for name in ("episodes", "workers"):
        if getattr(args, name) < 1:
            parser.error(f"--{name} must be at least 1")
    for name in ("retries", "checkpoint_freq"):
        if getattr(args, name) < 0:
            parser.error(f"--{name.replace('_', '-')} must be at least 0")
    if args.timesteps is not None and args.timesteps < 1:
        parser.error("--timesteps must be at least 1")
    if not isinstance(args.eval_env_kwargs, dict):
        parser.error("--eval-env-kwargs must be a JSON object")
    return args


def specs_from_args(args: argparse.Namespace) -> list[RunSpec]:
    """Every run the flags ask for.

    :raises ValueError: for an unknown algo, env or path set, or a bad seed list
    """
    from agents.runs import ALGORITHMS

    seeds = parse_seeds(args.seeds)
    specs = []
    for algo in args.algos:
        if algo not in ALGORITHMS:
            raise ValueError(f"unknown algo {algo!r}; known: {', '.join(ALGORITHMS)}")
        hyperparams = args.hyperparams or HYPERPARAMS / f"{algo}.yml"
        if not hyperparams.is_file():
            raise ValueError(f"hyperparameter file not found: {hyperparams}")
        for env_id in args.envs:
            eval_envs = evaluation_envs(env_id, args.eval_paths)
            for seed in seeds:
                specs.append(
                    RunSpec(
                        env=env_id,
                        algo=algo,
                        seed=seed,
                        timesteps=args.timesteps,
                        n_envs=args.n_envs,
                        hyperparams=hyperparams.read_text(),
                        eval_envs=eval_envs,
                        episodes=args.episodes,
                        eval_seed=args.eval_seed,
                        eval_env_kwargs=args.eval_env_kwargs,
                        checkpoint_freq=args.checkpoint_freq,
                    )
                )
    return specs


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit code (1 when a run failed).

    :param argv: the arguments after ``grid``, ``sys.argv[1:]`` when None
    """
    args = parse_args(argv)
    try:
        specs = specs_from_args(args)
        records, pending = [], []
        for spec in specs:
            finished = finished_record(spec, args.output)
            if finished is None:
                pending.append(spec)
            else:
                records.append(finished)
        args.output.mkdir(parents=True, exist_ok=True)
        print(
            f"grid: {len(specs)} runs into {args.output}, {len(records)} finished before; "
            f"{len(pending)} on the {args.backend} backend"
        )
        errors: dict[str, str] = {}
        if pending and args.backend == "ray":
            from agents.ray_grid import run_on_ray

            new, errors = run_on_ray(pending, args.output, args.address, args.retries)
            records += new
        elif pending:
            new, errors = run_local(pending, args.output, args.workers)
            records += new
        if records:
            print(write_results(records, args.output), end="")
        if errors:
            for name, error in sorted(errors.items()):
                print(f"{PROG}: error: run {name} failed: {error}", file=sys.stderr)
            print(
                f"{PROG}: error: {len(errors)} of {len(specs)} runs failed; run the same command "
                f"again to retry them (finished runs are kept)",
                file=sys.stderr,
            )
            return 1
        return 0
    except ValueError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(
            f"\n{PROG}: interrupted; run the same command again to finish the grid (finished "
            f"runs are kept, the others restart)",
            file=sys.stderr,
        )
        return 130


if __name__ == "__main__":
    sys.exit(main())

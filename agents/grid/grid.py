"""``python train.py grid``: many independent, deterministic trainings, one harness evaluation
each, and one table of the results across seeds.

Run ``python train.py grid --help``. Every (training env, algo, seed) is a run folder
``OUTPUT/runs/ENV_ALGO_seedN`` (:mod:`agents.training.runs`) trained to ``--timesteps`` steps. Its
policy is the one ``train.py`` keeps as ``best_model.zip``: every ``--select-every`` steps and at
the end, ``--select-episodes`` episodes of the training env (seeds 10,000 on, which training
never draws) score the policy, and the best is kept (``--select-every 0``: the final policy).
That policy is then driven by the evaluation harness through ``--episodes`` episodes of
each ``--eval-paths`` path set of the same robot (the same episodes for every run: seeds
``--eval-seed`` on), and the summaries go to the folder's ``evaluation.json``.

``OUTPUT/grid.md`` holds one row per (model, path set, agent): the mean over seeds with its
95% Student-t interval, and rliable's interquartile mean (IQM) with its 95% stratified
bootstrap interval (:mod:`agents.grid.stats`), plus one row per (model, agent) over all path
sets. ``OUTPUT/grid.json`` holds every run's numbers, ``OUTPUT/iqm.png`` the IQMs.

``--baselines mppi regulated_pure_pursuit ...`` adds classical rows: each agent drives every
robot of ``--envs`` through the same evaluation episodes, once (nothing trains, so it has no
seeds and no interval; :mod:`agents.grid.baselines`), before the trainings start.

Backends: ``--backend local`` runs ``--workers`` trainings at a time in processes;
``--backend ray --address HOST:PORT`` runs each as a Ray task on a cluster
(:mod:`agents.grid.ray_backend`), which Ray retries when its worker or node dies. Either way a run
is a pure function of its settings, so the numbers are the same bit for bit whichever backend
ran them. A run that was cut short restarts from zero, which keeps that true; with
``--checkpoint-freq N`` it continues from its last checkpoint instead (faster after a crash,
but no longer bit-identical to an uninterrupted run). Running the same command again
restores an interrupted grid: finished runs are read back, the others run.

Every setting is checked before the first run trains: the hyperparameter entries, the
training and evaluation envs with their keyword arguments. Ctrl-C or SIGTERM stops the
running runs at their next step (each saves its checkpoint), waits for them, prints the
command that finishes the grid and exits with 128 + the signal; a second signal stops them at
once, without saving, and says so.

Requires the ``train`` and ``sweep`` extras (scipy), and ``ray`` for the Ray backend.
"""

from __future__ import annotations

import argparse
import contextlib
import pathlib
import shlex
import signal
import sys
from collections.abc import Sequence
from typing import Any

from agents.arguments import (
    add_count_argument,
    add_eval_seed_argument,
    add_hyperparams_argument,
    add_n_envs_argument,
    at_least,
)
from agents.grid.baselines import BaselineSpec, baseline_specs, evaluate_baseline
from agents.grid.run import (
    RunSpec,
    evaluation_envs,
    finished_record,
    parse_seeds,
    run_local,
)
from agents.grid.table import write_results
from agents.harness.compare import json_object
from agents.interrupts import StopRequests, signum_of
from agents.training.runs import default_hyperparams
from mobile_envs.envs.registration import path_set_ids

PROG = "train.py grid"
DEFAULT_PATH_SETS = tuple(path_set_ids())
#: Seconds the Ray backend waits for a cluster to answer (default of ``--ray-timeout``).
DEFAULT_RAY_TIMEOUT = 60


# ---------------------------------------------------------------------------- command line


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description=(
            "Train every (env, algo, seed), evaluate each run's best policy with the harness, and "
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
        "--baselines",
        nargs="+",
        default=[],
        metavar="AGENT",
        help=(
            "classical agents evaluated on the same episodes, e.g. mppi pure_pursuit "
            "regulated_pure_pursuit (python -m agents.harness.compare --help lists them; "
            "default: none)"
        ),
    )
    parser.add_argument(
        "--eval-paths",
        nargs="+",
        default=list(DEFAULT_PATH_SETS),
        metavar="PATHS",
        help=f"path sets to evaluate on (default: {' '.join(DEFAULT_PATH_SETS)})",
    )
    add_count_argument(parser, "--episodes", 1, 20, "episodes per path set")
    add_eval_seed_argument(parser)
    parser.add_argument(
        "--eval-env-kwargs",
        type=json_object,
        default={},
        metavar="JSON",
        help="keyword arguments for the evaluation envs, e.g. '{\"start_noise\": [0.2, 0.3]}'",
    )
    parser.add_argument(
        "--timesteps", type=at_least(1), help="training steps per run (default: YAML)"
    )
    add_n_envs_argument(parser)
    add_hyperparams_argument(parser)
    parser.add_argument(
        "--checkpoint-freq",
        type=at_least(0),
        default=0,
        help="steps between checkpoints a retry continues from (default: 0, runs restart)",
    )
    parser.add_argument(
        "--select-every",
        type=at_least(0),
        default=100_000,
        metavar="STEPS",
        help=(
            "the policy each run's row measures: every STEPS steps and at the end, "
            "--select-episodes episodes of the training env pick best_model.zip, as train.py "
            "--eval-freq does (default: 100000; 0: the final policy)"
        ),
    )
    add_count_argument(parser, "--select-episodes", 1, 100, "episodes of each selecting evaluation")
    parser.add_argument("--output", type=pathlib.Path, default=pathlib.Path("grids/grid"))
    parser.add_argument("--backend", choices=("local", "ray"), default="local")
    add_count_argument(parser, "--workers", 1, 2, "local processes")
    parser.add_argument("--address", help="Ray cluster HOST:PORT (default: RAY_ADDRESS)")
    add_count_argument(parser, "--retries", 0, 2, "Ray retries of a run whose worker died")
    add_count_argument(
        parser,
        "--ray-timeout",
        1,
        DEFAULT_RAY_TIMEOUT,
        "seconds to wait for the Ray cluster to answer",
    )
    args = parser.parse_args(argv)
    if args.output.exists() and not args.output.is_dir():
        parser.error(f"--output: {args.output} is a file, not a folder")
    return args


def specs_from_args(args: argparse.Namespace) -> list[RunSpec]:
    """Every run the flags ask for.

    :raises ValueError: for an unknown algo, env or path set, or a bad seed list
    """
    from agents.harness.policies import ALGORITHMS

    seeds = parse_seeds(args.seeds)
    specs = []
    for algo in args.algos:
        if algo not in ALGORITHMS:
            raise ValueError(f"unknown algo {algo!r}; known: {', '.join(ALGORITHMS)}")
        hyperparams = args.hyperparams or default_hyperparams(algo)
        if not hyperparams.is_file():
            raise ValueError(f"hyperparameter file not found: {hyperparams}")
        for env_id in args.envs:
            eval_envs = evaluation_envs(env_id, args.eval_paths)
            check_settings(args, algo, hyperparams, env_id, eval_envs)
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
                        select_every=args.select_every,
                        select_episodes=args.select_episodes,
                    )
                )
    return specs


def check_settings(
    args: argparse.Namespace,
    algo: str,
    hyperparams: pathlib.Path,
    env_id: str,
    eval_envs: Sequence[str],
) -> None:
    """Everything a run of ``algo`` on ``env_id`` will use, checked before any run trains: the
    hyperparameter entry and its settings (a model is built once from them), the training env
    with its ``env_kwargs`` and the evaluation envs with ``--eval-env-kwargs``.

    :raises ValueError: naming the file or the flag
    """
    from agents.training.runs import (
        check_algorithm_settings,
        check_env_kwargs,
        check_model_builds,
        run_config,
    )

    config = run_config(
        env_id, hyperparams, algo=algo, timesteps=args.timesteps, n_envs=args.n_envs
    )
    check_algorithm_settings(algo, config[algo], hyperparams)
    check_env_kwargs(env_id, config, f"{hyperparams}: env_kwargs")
    check_model_builds(config, hyperparams)
    for eval_env in eval_envs:
        check_env_kwargs(eval_env, {"env_kwargs": args.eval_env_kwargs}, "--eval-env-kwargs")


def finish_command(argv: Sequence[str]) -> str:
    """The command that finishes this grid: the same one."""
    script = pathlib.Path(__file__).resolve().parents[2] / "train.py"
    with contextlib.suppress(ValueError):
        script = script.relative_to(pathlib.Path.cwd())
    return shlex.join(["python", str(script), "grid", *argv])


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit code (1 when a run failed).

    :param argv: the arguments after ``grid``, ``sys.argv[1:]`` when None
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv)
    requests = StopRequests()
    try:
        with requests.installed():
            return run_grid(args, requests)
    except ValueError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        from agents.harness.compare import describe_os_error

        print(f"{PROG}: error: {describe_os_error(error)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as interruption:
        signum = signum_of(interruption)
        running = (
            "a second signal stopped the running runs at once, without saving (each goes on "
            "from its last checkpoint, or starts again)"
            if requests.forced
            else "the running runs saved their checkpoints"
        )
        print(
            f"\n{PROG}: interrupted by {signal.Signals(signum).name}: {running}; finish the "
            f"grid (finished runs are kept) with: {finish_command(argv)}",
            file=sys.stderr,
        )
        return 128 + signum


def run_grid(args: argparse.Namespace, requests: StopRequests) -> int:
    """The grid the flags ask for, in the folder they name; the exit status.

    :raises ValueError: for bad settings
    :raises KeyboardInterrupt: when a stop signal ended it
    """
    specs = specs_from_args(args)
    baselines = baseline_specs(
        args.baselines,
        args.envs,
        args.eval_paths,
        args.episodes,
        args.eval_seed,
        args.eval_env_kwargs,
    )
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
    records += run_baselines(baselines, args.output, requests)
    errors: dict[str, str] = {}
    new: list[dict[str, Any]] = []
    if pending and args.backend == "ray":
        from agents.grid.ray_backend import run_on_ray

        new, errors = run_on_ray(
            pending, args.output, args.address, args.retries, args.ray_timeout, requests
        )
    elif pending:
        new, errors = run_local(pending, args.output, args.workers, requests)
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


def run_baselines(
    baselines: Sequence[BaselineSpec], output: pathlib.Path, requests: StopRequests
) -> list[dict[str, Any]]:
    """Evaluate (or read back) every classical agent of the grid in this process; their
    records.

    :raises KeyboardInterrupt: when a stop signal ended it
    """
    records = []
    for baseline in baselines:
        print(
            f"baseline: {baseline.agent} drives the {baseline.model} through "
            f"{len(baseline.eval_envs)} path sets x {baseline.episodes} episodes",
            flush=True,
        )
        records.append(evaluate_baseline(baseline, output, requests.raise_if_requested))
    return records


if __name__ == "__main__":
    sys.exit(main())

"""``python train.py sweep``: an Optuna study over an algorithm's hyperparameters and the
reward's weights, scored by the evaluation harness on held-out paths.

Run ``python train.py sweep --help``. Every trial is an ordinary run folder
(``OUTPUT/trials/STUDY/trial_NNNN``: ``config.yml``, checkpoints, ``final_model.zip``; see
:mod:`agents.training.runs`) trained for ``--timesteps`` steps. The folders are keyed by the
study's name (:func:`study_folder_name`), so studies that share an ``--output`` (and its
journal) never reuse each other's runs. Every ``--eval-freq`` steps and at
the end the harness (:func:`agents.harness.evaluate.evaluate`) drives the policy through
``--eval-episodes`` episodes of ``--eval-env`` from seed ``--eval-seed`` on (by default random paths
from seeds no training env is given), and the objective
(:class:`agents.sweeps.objectives.Objective`) turns its summary into the trial's value. The periodic
values feed Optuna's median pruner, which stops trials that trail the others.

Storage and workers:

- by default the study lives in ``OUTPUT/study.journal`` (Optuna's JournalFileStorage), so
  ``python train.py sweep --trials 20`` needs no server, and several commands started at
  once on the same ``--output`` share one study;
- ``--storage postgresql://USER@HOST/DB --study-name NAME`` joins a study on a server, from
  any number of workers on any number of machines.

Robustness: workers create the study under a lock (a PostgreSQL advisory lock, or a lock file
beside a journal or SQLite file), because fresh databases race on table creation. Every
worker checks that it runs the study's own settings. On a database, trials send heartbeats;
a trial whose worker died is failed after ``2 x --heartbeat`` seconds by the next worker that
starts a trial, and queued again with the same parameters. With a journal file, a worker
fails and queues again the trials of dead processes on its own machine before each trial. A
queued retry continues from the checkpoint its failed attempt left. A trial that raises is
recorded FAIL with its error (user attribute ``error``) and the sweep goes on, unless the
system failed it (an ``OSError``: a full disk, a folder it cannot write): then the trial is
queued again and the worker stops with exit status 1, as it does when the study's storage
fails (a full disk under the journal, a database gone: the trial stays RUNNING until a
later worker queues it again). Ctrl-C or SIGTERM fails the running trial, queues it again
and stops the worker. Every setting is checked before the first trial trains.

``--report`` writes ``OUTPUT/report/STUDY/``: the best trial's settings as a hyperparameter YAML
entry, a table of the top trials and plots (:mod:`agents.sweeps.report`).

Requires the ``train`` and ``sweep`` extras (optuna; psycopg for PostgreSQL).
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import pathlib
import shutil
import sys
import urllib.parse
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import optuna
import yaml
from optuna.trial import TrialState

from agents.arguments import (
    add_count_argument,
    add_eval_seed_argument,
    add_hyperparams_argument,
    add_n_envs_argument,
    at_least,
    seed,
)
from agents.harness.compare import describe_os_error
from agents.harness.evaluate import evaluate
from agents.harness.policies import ALGORITHMS
from agents.interrupts import StopRequests, interruption_in, signum_of
from agents.sweeps.objectives import DEFAULT_METRICS, DIRECTIONS, Objective
from agents.sweeps.search_space import Parameter, load_search_space, suggest_config
from agents.sweeps.storage import (
    check_storage,
    default_storage,
    describe_storage_failure,
    fail_dead_local_trials,
    is_database,
    open_study,
    owner_of_this_process,
    process_start,
    quiet_storage_failures_in_threads,
    retry_callback,
    storage_failure_in,
)
from agents.training.checkpoints import HarnessEvalCallback
from agents.training.runs import (
    HYPERPARAMS,
    check_algorithm_settings,
    check_env_kwargs,
    check_model_builds,
    default_hyperparams,
    env_kwargs_for,
    run_config,
    train_run,
)

DEFAULT_ENV = "mobile_envs/DiffDrive-Random-v0"
PROG = "train.py sweep"


@dataclass(frozen=True)
class SweepSettings:
    """What every trial of a study shares; a worker that joins must bring the same.

    :param base_config: the run config before sampling (:func:`agents.training.runs.run_config`)
    :param space: the search space, as the YAML gives it for the algorithm
    :param objective: what the trials are scored on
    :param eval_env: the env id of the harness evaluations
    :param eval_episodes: episodes per evaluation
    :param eval_seed: seed of the first evaluation episode
    :param eval_freq: steps between the evaluations that pruning reads (0: only the last)
    :param parameters: the parsed search space (``space`` is what the study stores)
    """

    base_config: dict[str, Any]
    space: dict[str, Any]
    objective: Objective
    eval_env: str
    eval_episodes: int
    eval_seed: int
    eval_freq: int
    parameters: list[Parameter] = field(default_factory=list, compare=False)

    def to_attrs(self) -> dict[str, Any]:
        """The settings as the study stores them."""
        attrs = asdict(self)
        attrs.pop("parameters")
        attrs["objective"] = self.objective.to_attrs()
        return attrs


# ---------------------------------------------------------------------------- trials


class PruningHarnessCallback(HarnessEvalCallback):
    """The harness evaluation of :class:`agents.training.checkpoints.HarnessEvalCallback`, reported
    to an Optuna trial as the objective's value; stops training when the pruner says so.

    :param trial: the Optuna trial
    :param objective: turns each summary into the reported value
    :param final_step: the run's last step, at which a trial is complete, never pruned
    :param kwargs: :class:`~agents.training.checkpoints.HarnessEvalCallback`'s arguments
    """

    def __init__(self, trial: optuna.Trial, objective: Objective, final_step: int, **kwargs: Any):
        super().__init__(**kwargs)
        self.trial = trial
        self.objective = objective
        self.final_step = final_step
        self.pruned_at: int | None = None

    def run_evaluation(self) -> dict[str, float]:
        summary = super().run_evaluation()
        if not self.objective.pareto:  # Optuna cannot prune multi-objective trials
            self.trial.report(self.objective.values(summary)[0], self.num_timesteps)
            if self.num_timesteps < self.final_step and self.trial.should_prune():
                self.pruned_at = self.num_timesteps
        return summary

    def _on_step(self) -> bool:
        super()._on_step()
        return self.pruned_at is None


def study_folder_name(study_name: str) -> str:
    """The folder name of a study's trials and report: its name, with every character but
    ASCII letters, digits, ``-``, ``_`` and ``.`` percent-encoded (a study on a server may be
    named anything, ``/`` included), and ``.`` and ``..`` encoded whole."""
    name = urllib.parse.quote(study_name, safe="")
    return name.replace(".", "%2E") if name in (".", "..") else name


def trial_folder(output: pathlib.Path, study_name: str, number: int) -> pathlib.Path:
    """Where trial ``number`` of study ``study_name`` trains: ``OUTPUT/trials/STUDY/trial_NNNN``."""
    return output / "trials" / study_folder_name(study_name) / f"trial_{number:04d}"


class TrialObjective:
    """The function Optuna calls with each trial: sample, train, evaluate, score.

    :param settings: the study's settings
    :param output: the sweep folder; trial n of study S trains in :func:`trial_folder`
    """

    def __init__(self, settings: SweepSettings, output: pathlib.Path):
        self.settings = settings
        self.output = output
        self.current_trial: int | None = None
        #: Polled by the trials' training; :func:`run_worker` installs its own.
        self.stop_requests: StopRequests | None = None
        #: The system's failure (an ``OSError``) that failed the current trial, if one did.
        self.system_failure: OSError | None = None

    def trial_folder(self, study_name: str, number: int) -> pathlib.Path:
        return trial_folder(self.output, study_name, number)

    def continue_failed_attempt(self, trial: optuna.Trial, folder: pathlib.Path) -> None:
        """For a retried trial, start from the newest checkpoint a failed attempt left."""
        frozen = trial.study.get_trials(deepcopy=False)[trial.number]
        for number in reversed(frozen.system_attrs.get("retry_history", [])):
            previous = self.trial_folder(trial.study.study_name, number)
            if (previous / "checkpoints" / "latest.zip").is_file():
                folder.mkdir(parents=True, exist_ok=True)
                shutil.copytree(
                    previous / "checkpoints", folder / "checkpoints", dirs_exist_ok=True
                )
                shutil.copy2(previous / "config.yml", folder / "config.yml")
                trial.set_user_attr("continued_from", number)
                return

    def __call__(self, trial: optuna.Trial) -> float | list[float]:
        self.current_trial = trial.number
        self.system_failure = None
        trial.set_user_attr("owner", owner_of_this_process(trial.number))
        trial.set_user_attr("owner_start", process_start(os.getpid()))
        if trial.user_attrs.get("error") is not None:  # inherited from the failed attempt
            trial.set_user_attr("error", None)
        folder = self.trial_folder(trial.study.study_name, trial.number)
        trial.set_user_attr("folder", str(folder.resolve()))
        try:
            return self.run(trial, folder)
        except optuna.TrialPruned:
            raise
        except BaseException as error:
            interruption = interruption_in(error)  # also one that compiled code wrapped
            if interruption is None:
                if isinstance(error, OSError):
                    self.system_failure = error
                trial.set_user_attr("error", f"{type(error).__name__}: {error}")
                raise
            trial.set_user_attr("error", "interrupted (Ctrl-C or SIGTERM); queued again")
            if interruption is error:
                raise
            raise interruption from None

    def run(self, trial: optuna.Trial, folder: pathlib.Path) -> float | list[float]:
        settings = self.settings
        if folder.exists() and any(folder.iterdir()):
            # Trial numbers are the study's own: a folder already there was left by another
            # study of this name (one deleted and made again), never by this trial.
            raise ValueError(
                f"{folder} already holds files that are not this trial's; move them away"
            )
        config = suggest_config(trial, settings.base_config, settings.parameters)
        algo = config["algo"]
        trial.set_user_attr(
            "settings",
            {
                "n_timesteps": config["timesteps"],
                "n_envs": config["n_envs"],
                **config[algo],
                "env_kwargs": config["env_kwargs"],
                # A warm start is part of how the trial trained: the best entry keeps it.
                **({"warm_start": config["warm_start"]} if config.get("warm_start") else {}),
            },
        )
        self.continue_failed_attempt(trial, folder)
        evaluation = PruningHarnessCallback(
            trial,
            settings.objective,
            config["timesteps"],
            env_id=settings.eval_env,
            folder=folder,
            every=settings.eval_freq,
            episodes=settings.eval_episodes,
            seed=settings.eval_seed,
            env_kwargs=env_kwargs_for(config),
        )
        model = train_run(folder, config, callbacks=[evaluation], requests=self.stop_requests)
        if evaluation.pruned_at is not None:
            raise optuna.TrialPruned(f"pruned at step {evaluation.pruned_at}")
        # The trained policy is measured once more, unless the last evaluation measured it.
        summary = evaluation.finish(model)
        if summary is None:  # no periodic evaluations
            summary = evaluate(
                model,
                settings.eval_env,
                settings.eval_episodes,
                seed=settings.eval_seed,
                **env_kwargs_for(config),
            ).summary
        for metric in DIRECTIONS:
            trial.set_user_attr(metric, float(summary[metric]))
        values = settings.objective.values(summary)
        return values if settings.objective.pareto else values[0]


class _WithoutTraceback(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        record.exc_info = None
        record.exc_text = None
        return True


@contextlib.contextmanager
def failed_trials_without_tracebacks() -> Iterator[None]:
    """Within the block, Optuna reports a failed trial in one line: its error is kept in the
    trial's ``error`` attribute, and a sweep of many trials should not scroll tracebacks."""
    logger = logging.getLogger("optuna.study._optimize")
    quiet = _WithoutTraceback()
    logger.addFilter(quiet)
    try:
        yield
    finally:
        logger.removeFilter(quiet)


def run_worker(
    study: optuna.Study,
    storage: str,
    objective: TrialObjective,
    trials: int,
) -> int:
    """Run ``trials`` trials of ``study`` in this process; return the exit code: 0, 130 after
    Ctrl-C, 143 after SIGTERM (128 + the signal, as train.py), 1 when every trial failed or
    the system failed one (its storage included), 2 when the database refused the URL."""
    outcomes: list[TrialState] = []
    last_error = None
    # Ctrl-C and SIGTERM stop the running trial's training at its next step (a second signal
    # at once); the trial is failed, queued again and checkpointed instead of left RUNNING.
    with (
        StopRequests().installed() as requests,
        failed_trials_without_tracebacks(),
        quiet_storage_failures_in_threads(),
    ):
        objective.stop_requests = requests
        for _ in range(trials):
            objective.current_trial = None
            try:
                if not is_database(storage):
                    for number in fail_dead_local_trials(study, storage):
                        print(f"trial {number}: its worker died; failed and queued again")
                requests.raise_if_requested()  # a signal between two trials
                study.optimize(objective, n_trials=1, catch=(Exception,))
                if objective.system_failure is not None:
                    return stop_for_system_failure(study, objective)
            except Exception as error:
                failure = storage_failure_in(error)
                if failure is None:
                    raise
                return stop_for_storage_failure(failure, storage, objective.current_trial)
            except KeyboardInterrupt as interruption:
                if objective.current_trial is not None:
                    frozen = study.get_trials(deepcopy=False)[objective.current_trial]
                    if frozen.state == TrialState.FAIL:
                        retry_callback()(study, frozen)
                    print(
                        f"\n{PROG}: interrupted: trial {objective.current_trial} failed and "
                        f"queued again",
                        file=sys.stderr,
                    )
                return 128 + signum_of(interruption)
            if objective.current_trial is not None:
                frozen = study.get_trials(deepcopy=False)[objective.current_trial]
                outcomes.append(frozen.state)
                last_error = frozen.user_attrs.get("error")
    if outcomes and all(state == TrialState.FAIL for state in outcomes):
        print(
            f"{PROG}: error: all {len(outcomes)} trials of this worker failed; the last: "
            f"{last_error}",
            file=sys.stderr,
        )
        return 1
    return 0


def stop_for_system_failure(study: optuna.Study, objective: TrialObjective) -> int:
    """Queue again the trial the system failed (a full disk), say so in one line, return 1:
    the next trials would fail alike."""
    number = objective.current_trial
    failure = objective.system_failure
    assert number is not None and failure is not None
    retry_callback()(study, study.get_trials(deepcopy=False)[number])
    print(
        f"{PROG}: error: trial {number} failed: {describe_os_error(failure)}; queued again. "
        "This worker stopped: fix that, then run the same command",
        file=sys.stderr,
    )
    return 1


def stop_for_storage_failure(failure: BaseException, storage: str, trial_number: int | None) -> int:
    """Say in one line that the study's storage failed, and return the exit status."""
    message, status = describe_storage_failure(failure, storage)
    if trial_number is not None:
        recovery = (
            "after two missed heartbeats" if is_database(storage) else "once this worker is gone"
        )
        message += (
            f"; trial {trial_number} could not be recorded: the next worker queues it again "
            f"{recovery}"
        )
    print(f"{PROG}: error: {message}", file=sys.stderr)
    return status


# ---------------------------------------------------------------------------- command line


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description=(
            "Tune an algorithm's hyperparameters and the reward's weights with Optuna, scoring "
            "each trial with the evaluation harness on held-out paths."
        ),
    )
    parser.add_argument(
        "--env", default=DEFAULT_ENV, help=f"env id to train on (default: {DEFAULT_ENV})"
    )
    parser.add_argument(
        "--algo", choices=ALGORITHMS, default="ppo", help="algorithm (default: ppo)"
    )
    parser.add_argument(
        "--trials", type=at_least(0), help="trials this worker runs (default: 20; 0 with --report)"
    )
    add_count_argument(parser, "--timesteps", 1, 300_000, "steps per trial")
    add_n_envs_argument(parser)
    parser.add_argument(
        "--seed", type=seed, default=0, help="training seed of every trial (default: 0)"
    )
    parser.add_argument(
        "--output", type=pathlib.Path, help="the sweep folder (default: sweeps/ENV_ALGO)"
    )
    parser.add_argument(
        "--storage",
        help=(
            "a database URL (postgresql://USER@HOST:PORT/DB) or a journal file "
            "(default: OUTPUT/study.journal)"
        ),
    )
    parser.add_argument("--study-name", help="the study's name (default: ENV_ALGO)")
    parser.add_argument(
        "--report",
        action="store_true",
        help="write OUTPUT/report/STUDY/ (after this worker's trials)",
    )
    add_hyperparams_argument(parser)
    parser.add_argument(
        "--search-space",
        type=pathlib.Path,
        default=HYPERPARAMS / "sweep.yml",
        help="search spaces per algo (default: hyperparams/sweep.yml)",
    )
    parser.add_argument(
        "--objective",
        nargs="+",
        default=list(DEFAULT_METRICS),
        metavar="METRIC",
        help=(
            f"harness metrics, most important first, ranked lexicographically (default: "
            f"{' '.join(DEFAULT_METRICS)}); from {', '.join(DIRECTIONS)}"
        ),
    )
    parser.add_argument(
        "--pareto",
        action="store_true",
        help="one objective per metric and a Pareto front (no pruning)",
    )
    parser.add_argument("--eval-env", help="env id of the harness evaluations (default: --env)")
    add_count_argument(parser, "--eval-episodes", 1, 20, "episodes per evaluation")
    add_eval_seed_argument(parser)
    parser.add_argument(
        "--eval-freq",
        type=at_least(0),
        default=100_000,
        help="steps between evaluations for pruning (default: 100000; 0: only the last)",
    )
    add_count_argument(parser, "--prune-after", 0, 5, "completed trials before pruning starts")
    add_count_argument(
        parser, "--heartbeat", 1, 60, "seconds between a database trial's heartbeats"
    )
    parser.add_argument(
        "--sampler-seed", type=seed, help="seed of this worker's sampler (default: random)"
    )
    args = parser.parse_args(argv)
    name = f"{args.env.split('/')[-1]}_{args.algo}"
    args.output = args.output or pathlib.Path("sweeps") / name
    args.study_name = args.study_name or name
    args.storage = args.storage or default_storage(args.output)
    args.hyperparams = args.hyperparams or default_hyperparams(args.algo)
    args.eval_env = args.eval_env or args.env
    if args.trials is None:
        args.trials = 0 if args.report else 20
    if args.output.exists() and not args.output.is_dir():
        parser.error(f"--output: {args.output} is a file, not a folder")
    try:
        check_storage(args.storage)
    except ValueError as error:
        parser.error(str(error))
    return args


def settings_from_args(args: argparse.Namespace) -> SweepSettings:
    """The study settings the flags describe, checked before any trial trains: the
    hyperparameter entry and its settings (a model is built once from them), the training
    and evaluation envs with the entry's ``env_kwargs``.

    :raises ValueError: for a bad search space, objective or hyperparameter file
    """
    import gymnasium as gym

    import mobile_envs  # noqa: F401  (registers the ids)

    for flag, env_id in (("--env", args.env), ("--eval-env", args.eval_env)):
        if env_id not in gym.registry:
            raise ValueError(f"{flag}: unknown env id {env_id!r}")
    base = run_config(
        args.env,
        args.hyperparams,
        algo=args.algo,
        seed=args.seed,
        timesteps=args.timesteps,
        n_envs=args.n_envs,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        # A retried trial continues from its failed attempt's last evaluation.
        checkpoint_freq=args.eval_freq,
    )
    check_algorithm_settings(args.algo, base[args.algo], args.hyperparams)
    for env_id in (args.env, args.eval_env):
        check_env_kwargs(env_id, base, f"{args.hyperparams}: env_kwargs")
    check_model_builds(base, args.hyperparams)
    parameters = load_search_space(args.search_space, args.algo)
    space = yaml.safe_load(args.search_space.read_text())[args.algo]
    return SweepSettings(
        base_config=base,
        space=space,
        objective=Objective(tuple(args.objective), args.pareto),
        eval_env=args.eval_env,
        eval_episodes=args.eval_episodes,
        eval_seed=args.eval_seed,
        eval_freq=args.eval_freq,
        parameters=parameters,
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit code.

    :param argv: the arguments after ``sweep``, ``sys.argv[1:]`` when None
    """
    args = parse_args(argv)
    try:
        from agents.sweeps.report import write_report

        settings = settings_from_args(args) if args.trials or not args.report else None
        study = open_study(
            args.storage,
            args.study_name,
            None if settings is None else settings.to_attrs(),
            heartbeat=args.heartbeat,
            sampler_seed=args.sampler_seed,
            prune_after=args.prune_after,
        )
        code = 0
        if settings is not None:
            done = len(study.get_trials(deepcopy=False))
            print(
                f"study {args.study_name!r} in {args.storage}: {done} trials so far; "
                f"this worker runs {args.trials}, objective {settings.objective.label}"
            )
            code = run_worker(
                study, args.storage, TrialObjective(settings, args.output), args.trials
            )
        if args.report and code < 128:
            report = args.output / "report" / study_folder_name(args.study_name)
            for path in write_report(study, report):
                print(f"wrote {path}")
        return code
    except ValueError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    except Exception as error:
        failure = storage_failure_in(error)
        if failure is None:
            raise
        return stop_for_storage_failure(failure, args.storage, None)


if __name__ == "__main__":
    sys.exit(main())

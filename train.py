"""Train a policy on a mobile_envs task (PPO, SAC, TD3 or TQC), evaluate it, export it to
ONNX, or compare agents.

    python train.py                                   # PPO on DiffDrive-Random, ~5 min
    python train.py --env mobile_envs/Bicycle-Random-v0 --timesteps 2000000
    python train.py --algo sac                        # settings: hyperparams/sac.yml
    python train.py --resume runs/DiffDrive-Random-v0_seed0
    python train.py --resume runs/DiffDrive-Random-v0_seed0 --timesteps 5000000
    python train.py --env mobile_envs/Bicycle-Random-v0 --trained-agent models/bicycle_ppo.zip \\
        --hyperparams hyperparams/ppo_finetune.yml    # fine-tune a saved policy
    python train.py evaluate --model models/diffdrive_ppo.zip \\
        --env mobile_envs/DiffDrive-SharpSegments-v0
    python train.py compare --agents pure_pursuit ppo:models/diffdrive_ppo.zip
    python train.py dataset --agent regulated_pure_pursuit --env mobile_envs/DiffDrive-Lines-v0
    python train.py export --model models/diffdrive_ppo.zip --output diffdrive.onnx

--algo picks the algorithm (ppo, the default; sac, td3 and tqc learn off-policy from a
replay buffer) and with it the default --hyperparams, hyperparams/ALGO.yml: an entry per env
id and a `default`, in rl-baselines3-zoo's style. An entry's warm_start mapping is handed to
agents.training.imitation.warm_start before a new run trains (see agents/training/runs.py).

--trained-agent MODEL (rl-baselines3-zoo's -i) starts a new run from MODEL's weights
instead of a fresh network and the entry's warm start: the entry's settings (learning
rate, batch, epochs) replace the saved ones, the steps count from 0, the run's config.yml
records MODEL. MODEL must be of the run's algorithm, trained on the same robot, with the
network the entry's policy_kwargs describe (if it gives any).

A run folder holds config.yml (the resolved settings), machine.yml (the CPU, libraries and
thread settings of each training session), command.txt, checkpoints/latest.zip (written
atomically and synced to disk every --checkpoint-freq steps, on Ctrl-C and on SIGTERM; an
off-policy run's replay buffer beside it, checkpoints/replay_buffer_STEPS.pkl, so that a
resumed run learns from the transitions it had), best_model.zip and final_model.zip
(written when the run reaches its total); with --snapshot-every N,
snapshots/steps_STEPS.zip every N steps from the start of training and snapshots/times.csv,
when each was taken (benchmarks/bench_time_to_target.py reads them; give the flag again to
--resume to go on keeping them). There is no normalization state to save: the
environments' observations are already scaled to [-1, 1]. A new run refuses a folder that
is not empty, and claims the folder it takes by creating its command.txt, so that of two
runs started at once on one --output the second is refused.

Every --eval-freq steps (between two collections) and at the end, the harness drives the
policy through --eval-episodes episodes of the training env, its settings included, from
seed 10,000 on (tracks and robots no training env draws); best_model.zip is the policy
of the best evaluation (the highest completion, then the lowest mean |cte|; the earliest of
equal ones) and best_model.json its score and step. Picking it is part of the recipes in
hyperparams/ppo.yml: a run's last policy can lose a skill its earlier ones had (see
docs/training.md, "The recipes").

--timesteps is the run's total number of environment steps (robots x vector steps), as
n_timesteps in the YAML: --resume RUN --timesteps N trains RUN on until it has N steps and
records N in its config.yml; without --timesteps, RUN goes on to the total it records.
A total below the steps RUN has already trained is an error. PPO trains in whole rollouts
(n_envs x n_steps), the off-policy algorithms in whole collections (n_envs x train_freq), so
a run may end a little past its total.

export writes the policy's deterministic action (what predict(obs, deterministic=True)
returns) as an ONNX graph with input "observation" (batch x observation size, float32) and
output "action"; see agents/training/export.py. It never replaces the model, nor anything at
--output that is not a regular file, and replaces an existing file only with --force.

Ctrl-C and SIGTERM (what Slurm, Kubernetes and Ray send before they kill a job) stop
training at its next step, save the checkpoint, print the command that resumes the run, and
exit with 130 (Ctrl-C) or 143 (SIGTERM), 128 + the signal. A signal during the warm start
stops it at its next step and saves its progress (checkpoints/warm_start.pkl, beside
config.yml): --resume goes on with it, to the weights an uninterrupted run has. A second
signal stops the run at once; during the save it abandons it, and the previous checkpoint
stays.

Exit status: 0 done; 2 bad input, an argument or a file it names (an unknown env id, a
truncated model, a malformed config.yml, a new run's folder that is not empty); 1 the
system failed the command (a folder that is not writable, a full disk); 130 or 143
interrupted. Errors are one line on stderr, "train.py: error: ...".
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import pathlib
import shlex
import signal
import sys
from collections.abc import Callable
from typing import Any

import yaml

PROG = "train.py"
DEFAULT_ENV = "mobile_envs/DiffDrive-Random-v0"
DEFAULT_ALGO = "ppo"
SUBCOMMANDS = ("train", "evaluate", "export", "compare", "dataset", "sweep", "grid")
#: Exit statuses: bad input (arguments or the files they name), and a failure of the system.
EXIT_USAGE = 2
EXIT_FAILURE = 1
#: The settings a run's config.yml holds, with their types.
RUN_CONFIG_TYPES: dict[str, type] = {
    "env": str,
    "seed": int,
    "timesteps": int,
    "n_envs": int,
    "env_kwargs": dict,
    "vec_env": str,
    "eval_freq": int,
    "eval_episodes": int,
    "checkpoint_freq": int,
    "algo": str,
}
KIND_NAMES = {int: "an integer", str: "a string", dict: "a mapping"}
VEC_ENVS = ("native", "dummy")


def json_object(text: str) -> dict[str, Any]:
    """An ``--env-kwargs`` value: a JSON object (see :func:`agents.harness.compare.json_object`)."""
    from agents.harness.compare import json_object as parse

    return parse(text)


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog=PROG, description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    commands = parser.add_subparsers(dest="command")

    from agents.arguments import add_hyperparams_argument, add_n_envs_argument, at_least, seed
    from agents.harness.policies import ALGORITHMS

    train = commands.add_parser("train", help="train a policy (the default command)")
    train.add_argument("--env", default=DEFAULT_ENV, help="registered env id")
    train.add_argument(
        "--algo",
        choices=ALGORITHMS,
        help=f"algorithm (default: {DEFAULT_ALGO}; with --resume, the run's own)",
    )
    train.add_argument(
        "--timesteps",
        type=at_least(1),
        help="the run's total environment steps (default: n_timesteps in the YAML); with "
        "--resume, the run's new total",
    )
    train.add_argument("--seed", type=seed, default=0, help="training seed, 0 to 2**32 - 1")
    add_n_envs_argument(train)
    add_hyperparams_argument(train)
    train.add_argument(
        "--output",
        type=pathlib.Path,
        help="run folder, new or empty (default: runs/ENV_seedN)",
    )
    train.add_argument(
        "--eval-freq",
        type=at_least(0),
        default=100_000,
        help="steps between evaluations (0: none, and no best_model.zip)",
    )
    train.add_argument("--eval-episodes", type=at_least(1), default=100)
    train.add_argument(
        "--checkpoint-freq", type=at_least(0), default=50_000, help="steps between checkpoints"
    )
    train.add_argument(
        "--resume",
        type=pathlib.Path,
        help="continue the run in this folder, with the settings in its config.yml",
    )
    train.add_argument(
        "-i",
        "--trained-agent",
        type=pathlib.Path,
        help="a new run starts from this saved model's weights, with the entry's settings "
        "and no warm start (fine-tuning; rl-baselines3-zoo's flag)",
    )
    train.add_argument("--tensorboard", action="store_true", help="log to RUN/tensorboard")
    train.add_argument(
        "--snapshot-every",
        type=at_least(0),
        default=0,
        help="keep the policy every N steps in RUN/snapshots, with when (0: none, the default)",
    )
    train.add_argument(
        "--threads",
        type=at_least(1),
        default=1,
        help="torch threads; 1 by default: on 2 cores, 2 threads made PPO ~15x slower",
    )
    train.add_argument(
        "--vec-env",
        choices=VEC_ENVS,
        default="native",
        help="native: the batched vector env (default, faster); dummy: SB3 DummyVecEnv",
    )
    train.add_argument("--no-progress", action="store_true", help="no progress bar")

    evaluate = commands.add_parser("evaluate", help="measure a saved policy with the harness")
    evaluate.add_argument("--model", type=pathlib.Path, required=True)
    evaluate.add_argument("--env", required=True, action="append", help="env id (repeatable)")
    evaluate.add_argument("--episodes", type=at_least(1), default=50)
    evaluate.add_argument("--seed", type=seed, default=0, help="seed of the first episode")
    evaluate.add_argument("--env-kwargs", type=json_object, default={}, help="JSON env kwargs")

    export = commands.add_parser("export", help="write a policy's deterministic actor as ONNX")
    export.add_argument("--model", type=pathlib.Path, required=True, help="a saved model .zip")
    export.add_argument("--output", type=pathlib.Path, required=True, help="the .onnx to write")
    export.add_argument("--opset", type=at_least(9), default=17, help="ONNX opset (default: 17)")
    export.add_argument("--force", action="store_true", help="replace an existing --output file")

    commands.add_parser(
        "compare", help="compare agents (python -m agents.harness.compare --help)", add_help=False
    )
    commands.add_parser(
        "dataset",
        help="record a Minari dataset (python -m agents.harness.datasets --help)",
        add_help=False,
    )
    for name in ("sweep", "grid"):  # agents.training.multirun parses their arguments
        commands.add_parser(name, help=f"see {PROG} {name} --help", add_help=False)
    if not argv or argv[0] not in (*SUBCOMMANDS, "-h", "--help"):
        argv = ["train", *argv]
    if argv[0] in ("compare", "dataset"):
        return argparse.Namespace(command=argv[0], forwarded_argv=argv[1:])
    if argv[0] in ("sweep", "grid"):
        return argparse.Namespace(command=argv[0], multirun_argv=argv[1:])
    args = parser.parse_args(argv)
    if args.command == "train" and args.hyperparams is None:
        from agents.training.runs import default_hyperparams

        args.hyperparams = default_hyperparams(args.algo or DEFAULT_ALGO)
    return args


# ---------------------------------------------------------------------------- configuration


def resolve_config(args: argparse.Namespace) -> dict[str, Any]:
    """Settings of a new run: the YAML's entry for the env (or its ``default``), then flags."""
    from agents.training.runs import pop_warm_start

    algo = args.algo or DEFAULT_ALGO
    table = read_yaml(args.hyperparams, "--hyperparams")
    if not isinstance(table, dict):
        raise ValueError(f"{args.hyperparams} must map env ids to {algo.upper()} settings")
    if args.env not in table and "default" not in table:
        raise ValueError(f"{args.hyperparams} has no entry for {args.env} and no 'default'")
    entry = table.get(args.env, table.get("default"))
    if not isinstance(entry, dict):
        raise ValueError(f"{args.hyperparams}: the entry for {args.env} must be a mapping")
    settings = dict(entry)
    timesteps = settings.pop("n_timesteps", 1_000_000)
    n_envs = settings.pop("n_envs", 16)
    env_kwargs = settings.pop("env_kwargs", {})
    warm_start = pop_warm_start(settings, args.hyperparams)
    config = {
        "env": args.env,
        "seed": args.seed,
        "timesteps": timesteps if args.timesteps is None else args.timesteps,
        "n_envs": n_envs if args.n_envs is None else args.n_envs,
        "env_kwargs": env_kwargs,
        "vec_env": args.vec_env,
        "eval_freq": args.eval_freq,
        "eval_episodes": args.eval_episodes,
        "checkpoint_freq": args.checkpoint_freq,
        "algo": algo,
        **({} if warm_start is None else {"warm_start": warm_start}),
        algo: settings,
    }
    if args.trained_agent is not None:  # its weights replace the warm start's clone
        config.pop("warm_start", None)
        config["trained_agent"] = str(args.trained_agent)
    return check_run_config(config, args.hyperparams)


def check_run_config(config: dict[str, Any], source: pathlib.Path) -> dict[str, Any]:
    """``config`` with whole-number floats (YAML's ``!!float 3e6``) made ints; ValueError
    naming ``source`` and the setting when one is missing, of the wrong type or out of range.

    A config without ``algo`` is a PPO run's from before ``--algo``: it gets ``algo: ppo``.
    """
    from agents.harness.policies import ALGORITHMS

    config.setdefault("algo", DEFAULT_ALGO)
    for key, kind in RUN_CONFIG_TYPES.items():
        if key not in config:
            raise ValueError(f"{source} has no {key!r} setting")
        value = config[key]
        if kind is int and isinstance(value, float) and value.is_integer():
            value = config[key] = int(value)
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            raise ValueError(f"{source}: {key!r} must be {KIND_NAMES[kind]}, got {value!r:.60}")
    minimums = {
        "timesteps": 1,
        "n_envs": 1,
        "eval_episodes": 1,
        "eval_freq": 0,
        "checkpoint_freq": 0,
    }
    for key, minimum in minimums.items():
        if config[key] < minimum:
            raise ValueError(f"{source}: {key!r} must be at least {minimum}, got {config[key]}")
    if config["vec_env"] not in VEC_ENVS:
        raise ValueError(
            f"{source}: 'vec_env' must be one of {VEC_ENVS}, got {config['vec_env']!r}"
        )
    algo = config["algo"]
    if algo not in ALGORITHMS:
        raise ValueError(f"{source}: 'algo' must be one of {ALGORITHMS}, got {algo!r:.60}")
    if not isinstance(config.get(algo), dict):
        raise ValueError(
            f"{source}: {algo!r} must be a mapping of {algo.upper()} settings, "
            f"got {config.get(algo)!r:.60}"
        )
    if not isinstance(config.get("warm_start", {}), dict):
        raise ValueError(
            f"{source}: 'warm_start' must be a mapping, got {config['warm_start']!r:.60}"
        )
    return config


def read_yaml(path: pathlib.Path, flag: str) -> Any:
    """The YAML document in ``path``; ValueError naming the file (or ``flag``) when unreadable."""
    if not path.is_file():
        raise ValueError(f"{flag}: no file at {path}")
    try:
        return yaml.safe_load(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as error:
        raise ValueError(
            f"{path} is not UTF-8 text: {error.reason} at byte {error.start}"
        ) from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise ValueError(f"{path} is not valid YAML: {problem}{where}") from None


def read_run_config(folder: pathlib.Path) -> dict[str, Any]:
    """The settings of the run in ``folder``, checked: ValueError naming config.yml and the
    setting when one is missing or of the wrong type."""
    if not folder.is_dir():
        raise ValueError(f"--resume: no run folder at {folder}")
    path = folder / "config.yml"
    if not path.is_file():
        raise ValueError(f"--resume: {folder} is not a run folder: it has no config.yml")
    config = read_yaml(path, "--resume")
    if not isinstance(config, dict):
        raise ValueError(f"{path} is not a run's config: expected settings, got {config!r:.60}")
    return check_run_config(config, path)


def new_run_folder(args: argparse.Namespace, config: dict[str, Any]) -> pathlib.Path:
    """The folder a new run goes to (--output, or runs/ENV_seedN): it must be new or empty, so
    a run never overwrites anything."""
    name = f"{config['env'].split('/')[-1]}_seed{config['seed']}"
    folder: pathlib.Path = args.output or pathlib.Path("runs") / name
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"--output: {folder} is a file, not a folder")
    from agents.training.runs import warm_start_checkpoint

    checkpoints = (folder / "checkpoints" / "latest.zip", warm_start_checkpoint(folder))
    if (folder / "config.yml").is_file() and any(path.is_file() for path in checkpoints):
        raise ValueError(
            f"{folder} already holds a run: continue it with --resume {folder}, "
            "or train into another --output"
        )
    if folder.is_dir() and any(folder.iterdir()):
        raise ValueError(
            f"{folder} is not empty and holds no run to resume (no config.yml and "
            "checkpoints/latest.zip); train into another --output, or empty it yourself"
        )
    return folder


def claim_run_folder(folder: pathlib.Path) -> Callable[[], None]:
    """Make a new run's folder if needed and claim it by creating its ``command.txt``, which
    only one process can (``O_EXCL``); return what undoes the claim, for a run that stops
    before it trains (a rerun then finds the folder as it was).

    :raises ValueError: naming ``--output`` when another run claimed it first
    """
    made = not folder.exists()
    folder.mkdir(parents=True, exist_ok=True)  # fails early on a read-only parent
    claim = folder / "command.txt"
    try:
        descriptor = os.open(claim, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
    except FileExistsError:
        raise ValueError(
            f"--output: {folder} was claimed by another run started at the same time; "
            "train into another --output"
        ) from None
    with os.fdopen(descriptor, "w") as log:
        log.write(shlex.join([sys.executable, *sys.argv]) + "\n")

    def release() -> None:
        claim.unlink(missing_ok=True)
        if made:
            with contextlib.suppress(OSError):
                folder.rmdir()

    return release


def write_config(folder: pathlib.Path, config: dict[str, Any]) -> None:
    from agents.training.files import write_atomically

    text = yaml.safe_dump(config, sort_keys=False)
    write_atomically(folder / "config.yml", lambda file: file.write(text.encode()))


def make_training_env(config: dict[str, Any]) -> Any:
    """The VecEnv the run collects experience from, seeded from the run's seed."""
    from agents.training.runs import make_training_env as make

    try:
        return make(config)
    except (TypeError, ValueError, OverflowError) as error:  # the env refuses its kwargs
        raise ValueError(
            f"env_kwargs {config['env_kwargs']} for {config['env']}: {error}"
        ) from error


def resume_command(folder: pathlib.Path) -> str:
    script = pathlib.Path(__file__)
    with contextlib.suppress(ValueError):
        script = script.relative_to(pathlib.Path.cwd())
    return shlex.join(["python", str(script), "--resume", str(folder)])


# ---------------------------------------------------------------------------- commands


def train(args: argparse.Namespace) -> int:
    # Settings and folder first, before the slow imports, so a mistake is reported at once.
    if args.resume and args.output:
        raise ValueError("--output cannot go with --resume: a run continues in its own folder")
    if args.resume and args.trained_agent:
        raise ValueError(
            "--trained-agent cannot go with --resume: a run continues from its own checkpoint"
        )
    if args.resume:
        folder = args.resume
        config = read_run_config(folder)
        env_source = f"{folder / 'config.yml'}: 'env'"
    else:
        config = resolve_config(args)
        folder = new_run_folder(args, config)
        env_source = "--env"
    from agents.training.runs import warm_start_checkpoint

    checkpoint = folder / "checkpoints" / "latest.zip"
    warm_start_file = warm_start_checkpoint(folder)
    # A run stopped during its warm start has no model yet: it is built again and the warm
    # start goes on from its own checkpoint.
    resuming = args.resume is not None and checkpoint.is_file()
    if args.resume and not resuming and not warm_start_file.is_file():
        raise ValueError(f"--resume: {folder} has no checkpoint to resume from: {checkpoint}")
    if args.resume and args.algo is not None and args.algo != config["algo"]:
        raise ValueError(
            f"--algo {args.algo}: {folder} is a {config['algo']} run; resume it without --algo"
        )

    import mobile_envs  # noqa: F401  (registers the ids)
    from agents.harness.compare import check_env_ids
    from agents.interrupts import StopRequests, interruption_in, signum_of
    from mobile_envs._kernels.kernel_cache import kernels_cached

    check_env_ids([config["env"]], env_source)
    if not args.resume and args.trained_agent is not None:  # before the folder is claimed
        from agents.training.runs import check_trained_agent

        check_trained_agent(args.trained_agent, config)

    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    from agents.training.checkpoints import (
        AtomicCheckpointCallback,
        HarnessEvalCallback,
        SnapshotCallback,
        StopOnRequest,
        load_checkpoint,
        save_atomically,
        save_checkpoint,
    )
    from agents.training.machine import record_machine
    from agents.training.progress import ProgressLines
    from agents.training.runs import check_algorithm_settings, label_policy

    torch.set_num_threads(args.threads)
    tensorboard = str(folder / "tensorboard") if args.tensorboard else None
    release_claim = None
    if args.resume and not resuming and args.timesteps is not None:
        config["timesteps"] = args.timesteps
    if resuming:
        model = load_checkpoint(folder, algo=config["algo"], config=config)
        done = model.num_timesteps
        if args.timesteps is not None:
            if args.timesteps < done:
                raise ValueError(
                    f"--timesteps {args.timesteps} is below the {done} steps {folder} has "
                    f"trained; it is the run's total: give more than {done}"
                )
            config["timesteps"] = args.timesteps
        if config["timesteps"] <= done:
            if not (folder / "final_model.zip").is_file():
                save_atomically(model, folder / "final_model.zip")
            print(
                f"{folder} has trained {done} steps, its total of {config['timesteps']}: "
                f"nothing to do. Extend it with --resume {folder} --timesteps TOTAL"
            )
            return 0
    else:
        check_algorithm_settings(config["algo"], config[config["algo"]], args.hyperparams)
        if not args.resume:  # a run stopped in its warm start has its folder already
            release_claim = claim_run_folder(folder)

    model_ready = False  # True once config.yml describes the model a checkpoint would save
    requests = StopRequests()
    with requests.installed():
        try:
            if not args.no_progress and not kernels_cached():
                print(
                    "compiling the kernels first: numba has none cached (the first run after "
                    "installing, or after an edit to mobile_envs), about 30 s, once",
                    flush=True,
                )
            env = make_training_env(config)
            if resuming:
                model.set_env(env)  # SB3 checks the spaces: the run's own config made both
                model.tensorboard_log = tensorboard
            else:
                model = build_new_model(
                    config,
                    env,
                    tensorboard,
                    requests,
                    args.hyperparams,
                    warm_start_file=warm_start_file,
                    progress=not args.no_progress,
                )
            requests.raise_if_requested()  # a signal while the env and model were made
            label_policy(model, config)  # saved with the policy
            write_config(folder, config)
            record_machine(folder, model.num_timesteps)
            model_ready = True
            if args.resume:
                with (folder / "command.txt").open("a") as log:
                    log.write(shlex.join([sys.executable, *sys.argv]) + "\n")
            remaining = config["timesteps"] - model.num_timesteps
            print(
                f"run folder: {folder}\ntraining {config['algo']} on {config['env']} for "
                f"{remaining} more steps ({model.num_timesteps} done) on {config['n_envs']} robots"
                + (
                    ""
                    if resuming or "trained_agent" not in config
                    else f", from the weights of {config['trained_agent']}"
                ),
                flush=True,
            )
            evaluation = HarnessEvalCallback.for_run(folder, config)
            callbacks: list[BaseCallback] = [
                AtomicCheckpointCallback(folder, config["checkpoint_freq"]),
                evaluation,
            ]
            if args.snapshot_every:
                callbacks.append(SnapshotCallback(folder, args.snapshot_every))
            # SB3's bar draws in a terminal only: to a log file, a line every few seconds.
            bar = not args.no_progress and sys.stdout.isatty()
            if not args.no_progress and not bar:
                callbacks.append(ProgressLines(config["timesteps"]))
            model.learn(  # a signal ends it at the next step
                remaining,
                callback=StopOnRequest(requests, callbacks),
                reset_num_timesteps=not resuming,
                progress_bar=bar,
            )
            requests.raise_if_requested()
            evaluation.finish(model)  # the final policy may be the best
            save_checkpoint(model, folder)
            save_atomically(model, folder / "final_model.zip")
        except BaseException as error:
            if not model_ready and release_claim is not None:
                release_claim()
            interruption = interruption_in(error)
            if interruption is None:
                raise
            signum = signum_of(interruption)
            name = signal.Signals(signum).name
            if not model_ready and not resuming and warm_start_file.is_file():
                write_config(folder, config)
                print(
                    f"\ninterrupted by {name} during the warm start; saved its progress in "
                    f"{warm_start_file}. Continue with: {resume_command(folder)}"
                )
                return 128 + signum
            if not model_ready:
                unchanged = f"{folder} is unchanged" if args.resume else "nothing was saved"
                print(f"\ninterrupted by {name} before training started; {unchanged}")
                return 128 + signum
            return save_interrupted_run(model, folder, checkpoint, signum)
    env.close()
    print(f"done: {model.num_timesteps} steps; models in {folder}")
    best = best_model_line(folder)
    if best:
        print(best)
    return 0


def best_model_line(folder: pathlib.Path) -> str | None:
    """What the run's ``best_model.json`` says of ``best_model.zip``; None without one."""
    from agents.training.checkpoints import BEST_SCORE_FILE

    try:
        record = json.loads((folder / BEST_SCORE_FILE).read_text(encoding="utf-8"))
        return (
            f"best_model.zip: the policy at step {int(record['steps']):,} (completion "
            f"{float(record['completion_rate']):.2f}, mean |cte| "
            f"{float(record['mean_abs_cte']):.4f} m on the training env's evaluation episodes)"
        )
    except (OSError, ValueError, KeyError, TypeError):
        return None


def build_new_model(
    config: dict[str, Any],
    env: Any,
    tensorboard: str | None,
    requests: Any,
    source: pathlib.Path,
    *,
    warm_start_file: pathlib.Path,
    progress: bool,
) -> Any:
    """The new run's model (:func:`agents.training.runs.build_model`), its warm start going
    on from ``warm_start_file`` when a stopped one left it.

    :raises ValueError: naming ``source`` when the algorithm refuses its settings
    """
    from agents.interrupts import interruption_in
    from agents.training.runs import build_model

    try:
        return build_model(
            config,
            env,
            tensorboard_log=tensorboard,
            check_stop=requests.raise_if_requested,
            warm_start_file=warm_start_file,
            progress=progress,
        )
    except (AssertionError, TypeError, ValueError) as error:
        if interruption_in(error) is not None:
            raise
        raise ValueError(
            f"{source}: {config['algo'].upper()} refuses these settings: "
            f"{type(error).__name__}: {error}"
        ) from None


def save_interrupted_run(
    model: Any, folder: pathlib.Path, checkpoint: pathlib.Path, signum: int
) -> int:
    """Save the checkpoint of a run that signal ``signum`` interrupted and say how to resume;
    return the exit status, 128 + the signal.

    A second signal raises (:class:`agents.interrupts.StopRequests`), so it abandons the
    save: the atomic write leaves the previous checkpoint and no temporary file.
    """
    from agents.interrupts import interruption_in, signum_of
    from agents.training.checkpoints import save_checkpoint

    name = signal.Signals(signum).name
    print(f"\ninterrupted by {name} at step {model.num_timesteps}; saving", flush=True)
    try:
        save_checkpoint(model, folder)
    except BaseException as error:
        again = interruption_in(error)
        if again is None:
            raise
        kept = f"{checkpoint} is the last complete one" if checkpoint.is_file() else "none saved"
        print(
            f"interrupted by {signal.Signals(signum_of(again)).name} again during the save: "
            f"abandoned it; {kept}"
        )
        if checkpoint.is_file():
            print(f"Continue with: {resume_command(folder)}")
        return 128 + signum_of(again)
    print(f"saved {checkpoint}. Continue with: {resume_command(folder)}")
    return 128 + signum


def evaluate_policy(args: argparse.Namespace, check_stop: Callable[[], None] | None = None) -> int:
    import mobile_envs  # noqa: F401
    from agents.harness.compare import check_env_ids, make_env

    check_env_ids(args.env, "--env")  # before torch loads, so a typo is reported at once

    from agents.harness.evaluate import evaluate
    from agents.harness.policies import load_policy

    envs = [make_env(env_id, args.env_kwargs) for env_id in args.env]
    policies = [load_policy(args.model, env) for env in envs]
    print(f"{'env':<40} {'completion':>10} {'mean|cte|':>10} {'max|cte|':>10} {'time':>8}")
    for env_id, env, policy in zip(args.env, envs, policies, strict=True):
        summary = evaluate(
            policy, env, args.episodes, seed=args.seed, check_stop=check_stop
        ).summary
        print(
            f"{env_id:<40} {summary['completion_rate']:>10.2%} {summary['mean_abs_cte']:>10.4f} "
            f"{summary['max_abs_cte']:>10.4f} {summary['mean_time']:>8.1f}"
        )
    return 0


def export_policy(args: argparse.Namespace) -> int:
    from agents.harness.policies import load_policy
    from agents.training.export import check_opset, check_output, export_onnx

    try:
        check_opset(args.opset)
    except ValueError as error:
        raise ValueError(f"--opset: {error}") from None
    try:
        check_output(args.output, args.model, overwrite=args.force)
    except ValueError as error:
        raise ValueError(f"--output: {error}") from None
    model = load_policy(args.model)
    path = export_onnx(
        model, args.output, opset=args.opset, overwrite=args.force, model_file=args.model
    )
    print(f"wrote {path}: the deterministic actor of {args.model}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run the command; return its exit status (see the module docstring)."""
    args = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        if args.command == "compare":
            from agents.harness.compare import cli as compare

            return compare(args.forwarded_argv, prog=f"{PROG} compare")
        if args.command == "dataset":
            from agents.harness.datasets import cli as dataset

            return dataset(args.forwarded_argv, prog=f"{PROG} dataset")
        if args.command == "evaluate":
            from agents.interrupts import StopRequests

            with StopRequests().installed() as requests:  # stops at the next step
                return evaluate_policy(args, requests.raise_if_requested)
        if args.command == "export":
            return export_policy(args)
        if args.command in ("sweep", "grid"):
            from agents.training.multirun import main as multirun

            return multirun(args.command, args.multirun_argv)
        return train(args)
    except ValueError as error:
        return report_error(str(error), EXIT_USAGE)
    except OSError as error:
        from agents.harness.compare import describe_os_error

        return report_error(describe_os_error(error), EXIT_FAILURE)
    except BaseException as error:
        from agents.interrupts import interruption_in, signum_of

        interruption = interruption_in(error)  # also one a numba kernel's call wrapped
        if interruption is None:
            raise
        print(f"\n{PROG}: interrupted", file=sys.stderr)
        return 128 + signum_of(interruption)


def report_error(message: str, status: int) -> int:
    from agents.harness.compare import report_error as report

    return report(PROG, message, status)


if __name__ == "__main__":
    sys.exit(main())

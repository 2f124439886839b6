"""Train PPO on a mobile_envs task, evaluate a policy, or compare agents.

    python train.py                                   # PPO on DiffDrive-Random, ~5 min
    python train.py --env mobile_envs/Bicycle-Random-v0 --timesteps 2000000
    python train.py --resume runs/DiffDrive-Random-v0_seed0
    python train.py evaluate --model models/diffdrive_ppo.zip \
        --env mobile_envs/DiffDrive-SharpSegments-v0
    python train.py compare --agents pure_pursuit ppo:models/diffdrive_ppo.zip

A run folder holds config.yml (the resolved settings), command.txt, checkpoints/latest.zip
(written atomically every --checkpoint-freq steps and on Ctrl-C), best_model.zip (best
periodic evaluation) and final_model.zip. There is no normalization state to save: the
environments' observations are already scaled to [-1, 1].
"""

from __future__ import annotations

import argparse
import json
import pathlib
import shlex
import sys
from typing import Any

import yaml

DEFAULT_ENV = "mobile_envs/DiffDrive-Random-v0"
DEFAULT_HYPERPARAMS = pathlib.Path(__file__).with_name("hyperparams") / "ppo.yml"
SUBCOMMANDS = ("train", "evaluate", "compare")


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    commands = parser.add_subparsers(dest="command")

    train = commands.add_parser("train", help="train PPO (the default command)")
    train.add_argument("--env", default=DEFAULT_ENV, help="registered env id")
    train.add_argument("--timesteps", type=int, help="total environment steps (default: YAML)")
    train.add_argument("--seed", type=int, default=0)
    train.add_argument("--n-envs", type=int, help="robots collecting experience (default: YAML)")
    train.add_argument("--hyperparams", type=pathlib.Path, default=DEFAULT_HYPERPARAMS)
    train.add_argument("--output", type=pathlib.Path, help="run folder (default: runs/ENV_seedN)")
    train.add_argument("--eval-freq", type=int, default=50_000, help="steps between evaluations")
    train.add_argument("--eval-episodes", type=int, default=10)
    train.add_argument(
        "--checkpoint-freq", type=int, default=50_000, help="steps between checkpoints"
    )
    train.add_argument("--resume", type=pathlib.Path, help="continue the run in this folder")
    train.add_argument("--tensorboard", action="store_true", help="log to RUN/tensorboard")
    train.add_argument(
        "--threads",
        type=int,
        default=1,
        help="torch threads; 1 by default: on 2 cores, 2 threads made PPO ~15x slower",
    )
    train.add_argument(
        "--vec-env",
        choices=("native", "dummy"),
        default="native",
        help="native: the batched vector env (default, faster); dummy: SB3 DummyVecEnv",
    )
    train.add_argument("--no-progress", action="store_true", help="no progress bar")

    evaluate = commands.add_parser("evaluate", help="measure a saved policy with the harness")
    evaluate.add_argument("--model", type=pathlib.Path, required=True)
    evaluate.add_argument("--env", required=True, action="append", help="env id (repeatable)")
    evaluate.add_argument("--episodes", type=int, default=50)
    evaluate.add_argument("--seed", type=int, default=0)
    evaluate.add_argument("--env-kwargs", type=json.loads, default={}, help="JSON env kwargs")

    commands.add_parser(
        "compare", help="compare agents (python -m agents.compare --help)", add_help=False
    )
    if not argv or argv[0] not in (*SUBCOMMANDS, "-h", "--help"):
        argv = ["train", *argv]
    if argv[0] == "compare":
        return argparse.Namespace(command="compare", compare_argv=argv[1:])
    return parser.parse_args(argv)


# ---------------------------------------------------------------------------- configuration


def resolve_config(args: argparse.Namespace) -> dict[str, Any]:
    """Settings of a new run: the YAML's entry for the env (or its ``default``), then flags."""
    if args.resume:
        return yaml.safe_load((args.resume / "config.yml").read_text())
    if not args.hyperparams.is_file():
        raise ValueError(f"hyperparameter file not found: {args.hyperparams}")
    table = yaml.safe_load(args.hyperparams.read_text()) or {}
    if args.env not in table and "default" not in table:
        raise ValueError(f"{args.hyperparams} has no entry for {args.env} and no 'default'")
    ppo = dict(table.get(args.env, table.get("default")))
    config = {
        "env": args.env,
        "seed": args.seed,
        "timesteps": int(args.timesteps or ppo.pop("n_timesteps", 1_000_000)),
        "n_envs": int(args.n_envs or ppo.pop("n_envs", 16)),
        "env_kwargs": ppo.pop("env_kwargs", {}),
        "vec_env": args.vec_env,
        "eval_freq": args.eval_freq,
        "eval_episodes": args.eval_episodes,
        "checkpoint_freq": args.checkpoint_freq,
        "ppo": ppo,
    }
    config["ppo"].pop("n_timesteps", None)
    config["ppo"].pop("n_envs", None)
    return config


def run_folder(args: argparse.Namespace, config: dict[str, Any]) -> pathlib.Path:
    if args.resume:
        return args.resume
    name = f"{config['env'].split('/')[-1]}_seed{config['seed']}"
    folder = args.output or pathlib.Path("runs") / name
    if (folder / "checkpoints" / "latest.zip").exists():
        raise ValueError(f"{folder} already holds a run; continue it with --resume {folder}")
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "config.yml").write_text(yaml.safe_dump(config, sort_keys=False))
    return folder


def make_training_env(config: dict[str, Any]):
    """The VecEnv PPO collects experience from, seeded from the run's seed."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecMonitor

    from mobile_envs.sb3 import PathFollowingSB3VecEnv

    if config["vec_env"] == "native":
        env = PathFollowingSB3VecEnv(
            config["env"], config["n_envs"], seed=config["seed"], **config["env_kwargs"]
        )
        return VecMonitor(env, info_keywords=("is_success",))
    return make_vec_env(
        config["env"],
        n_envs=config["n_envs"],
        seed=config["seed"],
        env_kwargs=config["env_kwargs"],
        monitor_kwargs={"info_keywords": ("is_success",)},
    )


# ---------------------------------------------------------------------------- commands


def train(args: argparse.Namespace) -> int:
    import torch
    from stable_baselines3 import PPO

    import mobile_envs  # noqa: F401  (registers the ids)
    from agents.ppo import (
        AtomicCheckpointCallback,
        HarnessEvalCallback,
        load_policy,
        save_atomically,
    )

    torch.set_num_threads(args.threads)
    config = resolve_config(args)
    folder = run_folder(args, config)
    with (folder / "command.txt").open("a") as log:
        log.write(shlex.join([sys.executable, *sys.argv]) + "\n")
    env = make_training_env(config)
    tensorboard = str(folder / "tensorboard") if args.tensorboard else None

    checkpoint = folder / "checkpoints" / "latest.zip"
    if args.resume:
        if not checkpoint.is_file():
            raise ValueError(f"no checkpoint to resume from at {checkpoint}")
        model = load_policy(checkpoint)
        model.set_env(env)  # SB3 checks the spaces: the run's own config made both
        model.tensorboard_log = tensorboard
    else:
        ppo = dict(config["ppo"])
        model = PPO(
            ppo.pop("policy", "MlpPolicy"),
            env,
            seed=config["seed"],
            device="cpu",
            tensorboard_log=tensorboard,
            verbose=0,
            **ppo,
        )
    model.trained_on = config["env"]  # saved with the policy; see agents.ppo.drives_same_model
    remaining = config["timesteps"] - model.num_timesteps
    print(
        f"run folder: {folder}\ntraining {config['env']} for {remaining} more steps "
        f"({model.num_timesteps} done) on {config['n_envs']} robots"
    )

    callbacks = [
        AtomicCheckpointCallback(folder, config["checkpoint_freq"]),
        HarnessEvalCallback(
            config["env"],
            folder,
            config["eval_freq"],
            episodes=config["eval_episodes"],
            env_kwargs=config["env_kwargs"],
        ),
    ]
    interrupted = False
    try:
        if remaining > 0:
            model.learn(
                remaining,
                callback=callbacks,
                reset_num_timesteps=not args.resume,
                progress_bar=not args.no_progress,
            )
    except KeyboardInterrupt:
        interrupted = True
    save_atomically(model, checkpoint)
    save_atomically(model, folder / "final_model.zip")
    env.close()
    if interrupted:
        print(
            f"\ninterrupted at step {model.num_timesteps}; saved {checkpoint}. "
            f"Continue with: python train.py --resume {folder}"
        )
        return 130
    print(f"done: {model.num_timesteps} steps; models in {folder}")
    return 0


def evaluate_policy(args: argparse.Namespace) -> int:
    import gymnasium as gym

    import mobile_envs  # noqa: F401
    from agents.evaluate import evaluate
    from agents.ppo import load_policy

    print(f"{'env':<40} {'completion':>10} {'mean|cte|':>10} {'max|cte|':>10} {'time':>8}")
    for env_id in args.env:
        env = gym.make(env_id, **args.env_kwargs)
        model = load_policy(args.model, env)
        summary = evaluate(model, env, args.episodes, seed=args.seed).summary
        print(
            f"{env_id:<40} {summary['completion_rate']:>10.2%} {summary['mean_abs_cte']:>10.4f} "
            f"{summary['max_abs_cte']:>10.4f} {summary['mean_time']:>8.1f}"
        )
    return 0


def main(argv: list[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        if args.command == "compare":
            from agents.compare import main as compare

            return compare(args.compare_argv) or 0
        if args.command == "evaluate":
            return evaluate_policy(args)
        return train(args)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

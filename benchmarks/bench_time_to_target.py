"""Wall time to target: how long a training recipe takes to a policy that meets every target.

    python benchmarks/bench_time_to_target.py --models diff_drive
    python benchmarks/bench_time_to_target.py --models tricycle --cold-cache   # as after installing
    python benchmarks/bench_time_to_target.py --models bicycle --hyperparams faster.yml \\
        --snapshot-every 50000 --output runs/time_to_target_faster
    python benchmarks/bench_time_to_target.py --models diff_drive \\
        --run runs/time_to_target/diff_drive        # evaluate a finished run's snapshots again

For each model, train.py trains ``mobile_envs/<Model>-Random-v0`` with the recipe (the
default hyperparams/ppo.yml, or ``--hyperparams``; its ``--timesteps`` unless given) into
``OUTPUT/<model>/run``, keeping a snapshot of the policy every ``--snapshot-every`` steps
(``train.py --snapshot-every``; the first is the warm start's clone, the last the final
policy) with the wall and CPU time at which it was saved. Once training has ended (so that
evaluating never takes the trainer's cores), the snapshots meet the targets of
``bench_ppo_targets.py`` in the order they were taken, with the batched harness, on the
targets' episodes only (the course sets, the canonical maze and held-out random tracks,
which no training run draws): the learned-tracker table's by default (start noise and none,
the held-out tracks, a localization), the realistic plant's too with ``--realistic``. Each
snapshot stops at its first missed target; the first snapshot that meets them all is the
time to target.

The wall time counts from the moment the benchmark launched train.py, so the cold start is
in it: Python, the imports, compiling the kernels (or loading them from numba's cache), the
warm start. ``--cold-cache`` gives train.py an empty numba cache (``NUMBA_CACHE_DIR`` at
``OUTPUT/<model>/numba_cache``), so it compiles every kernel as the first run after
installing does. The CPU time is
train.py's own (user + system). The launch time is kept in ``OUTPUT/<model>/launched.txt``,
so ``--run`` can evaluate a run again without training it again. Prints one line per
snapshot and, per model, the step, wall time and CPU time at which every target first held.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pathlib
import subprocess
import sys
import time

from bench_ppo_targets import MODELS, Targets, add_localization_argument

from agents.training.checkpoints import SNAPSHOT_PATTERN, SNAPSHOT_TIMES

ROOT = pathlib.Path(__file__).resolve().parents[1]
LAUNCHED = "launched.txt"
#: Exit statuses: bad input, and a training run that failed.
EXIT_USAGE = 2
EXIT_FAILURE = 1


@dataclasses.dataclass(frozen=True)
class Snapshot:
    """A policy a run kept, and when.

    :param steps: the steps it had learned from
    :param wall: seconds from the benchmark's launch of train.py to its save
    :param cpu: train.py's CPU seconds at its save
    :param path: its zip
    """

    steps: int
    wall: float
    cpu: float
    path: pathlib.Path


def read_snapshots(folder: pathlib.Path) -> list[Snapshot]:
    """The snapshots of the benchmark's folder ``folder`` (its ``launched.txt`` and its run's
    ``snapshots/``), in the order they were taken.

    :raises ValueError: naming the file that is missing or malformed
    """
    launched_file = folder / LAUNCHED
    times_file = folder / "run" / "snapshots" / SNAPSHOT_TIMES
    for path in (launched_file, times_file):
        if not path.is_file():
            raise ValueError(f"--run: {folder} has no {path.relative_to(folder)}")
    try:
        launched = float(launched_file.read_text(encoding="utf-8"))
        rows = [line.split(",") for line in times_file.read_text(encoding="utf-8").splitlines()]
        snapshots = [
            Snapshot(
                int(steps),
                float(wall) - launched,
                float(cpu),
                times_file.parent / SNAPSHOT_PATTERN.format(steps=int(steps)),
            )
            for steps, wall, cpu in rows
        ]
    except ValueError as error:
        raise ValueError(f"--run: {folder} holds a malformed time: {error}") from None
    for snapshot in snapshots:
        if not snapshot.path.is_file():
            raise ValueError(f"--run: {snapshot.path} is listed in {times_file} but missing")
    return snapshots


def train(model: str, folder: pathlib.Path, args: argparse.Namespace) -> int:
    """Launch train.py for ``model`` into ``folder/run``, its output shown as it comes;
    return its exit status. ``folder/launched.txt`` records the launch time."""
    command = [
        sys.executable,
        str(ROOT / "train.py"),
        "--env",
        f"mobile_envs/{MODELS[model].prefix}-Random-v0",
        "--seed",
        str(args.seed),
        "--output",
        str(folder / "run"),
        "--eval-freq",
        "0",
        "--snapshot-every",
        str(args.snapshot_every),
    ]
    if args.timesteps is not None:
        command += ["--timesteps", str(args.timesteps)]
    if args.hyperparams is not None:
        command += ["--hyperparams", str(args.hyperparams)]
    folder.mkdir(parents=True)
    environment = dict(os.environ)
    if args.cold_cache:
        cache = folder / "numba_cache"
        cache.mkdir()
        environment["NUMBA_CACHE_DIR"] = str(cache)
        print(f"{model}: numba's cache starts empty at {cache}")
    launched = time.time()
    (folder / LAUNCHED).write_text(f"{launched:.3f}\n", encoding="utf-8")
    print(f"{model}: {' '.join(command)}", flush=True)
    status = subprocess.call(command, cwd=ROOT, env=environment)
    print(f"{model}: train.py ended with status {status} after {time.time() - launched:.1f} s")
    return status


def first_on_target(model: str, snapshots: list[Snapshot], targets: Targets) -> Snapshot | None:
    """The first of ``snapshots`` that meets every target (None: none does), each
    measured until its first miss and reported in one line."""
    for snapshot in snapshots:
        _, checks = targets.run(snapshot.path, stop_at_first_miss=True)
        missed = [target for target, met, _ in checks if not met]
        verdict = f"misses {missed[0]}" if missed else "meets every target"
        print(
            f"{model}: step {snapshot.steps:>9,} wall {snapshot.wall:7.1f} s "
            f"cpu {snapshot.cpu:7.1f} s: {verdict}",
            flush=True,
        )
        if not missed:
            return snapshot
    return None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["diff_drive"], choices=list(MODELS))
    parser.add_argument("--seed", type=int, default=0, help="the training seed")
    parser.add_argument("--timesteps", type=int, help="the run's total (default: the YAML's)")
    parser.add_argument(
        "--hyperparams", type=pathlib.Path, help="the recipe (default: hyperparams/ppo.yml)"
    )
    parser.add_argument("--snapshot-every", type=int, default=100_000, help="steps")
    parser.add_argument(
        "--cold-cache",
        action="store_true",
        help="train with an empty numba cache: the time to target includes compiling",
    )
    parser.add_argument("--episodes", type=int, default=50, help="episodes per path set")
    add_localization_argument(parser)
    parser.add_argument(
        "--realistic", action="store_true", help="the realistic plant's targets too"
    )
    parser.add_argument(
        "--output",
        type=pathlib.Path,
        default=ROOT / "runs" / "time_to_target",
        help="a folder per model is made in it (default: runs/time_to_target)",
    )
    parser.add_argument(
        "--run",
        type=pathlib.Path,
        help="evaluate this folder of an earlier benchmark (OUTPUT/MODEL) instead of training",
    )
    args = parser.parse_args()
    for name in ("timesteps", "snapshot_every", "episodes"):
        value = getattr(args, name)
        if value is not None and value < 1:
            parser.error(f"--{name.replace('_', '-')} must be at least 1, got {value}")
    if args.seed < 0:
        parser.error(f"--seed must be at least 0, got {args.seed}")
    if args.run is not None and len(args.models) != 1:
        parser.error("--run needs exactly one model in --models")
    if args.hyperparams is not None and not args.hyperparams.is_file():
        parser.error(f"--hyperparams: no file at {args.hyperparams}")
    folders = {model: args.run or args.output / model for model in args.models}
    if args.run is None:
        for folder in folders.values():
            if folder.exists():
                parser.error(f"--output: {folder} exists; give another --output")
    results = {}
    for model, folder in folders.items():
        if args.run is None:
            status = train(model, folder, args)
            if status != 0:
                print(f"bench_time_to_target: train.py failed for {model}", file=sys.stderr)
                return EXIT_FAILURE
        try:
            snapshots = read_snapshots(folder)
        except ValueError as error:
            parser.error(str(error))
        targets = Targets(model, args.episodes, args.localization, realistic=args.realistic)
        results[model] = (first_on_target(model, snapshots, targets), snapshots[-1])
    print()
    for model, (first, last) in results.items():
        if first is None:
            print(
                f"{model}: no snapshot met every target; the run ended at step {last.steps:,}, "
                f"{last.wall:.1f} s of wall time ({last.cpu:.1f} s CPU) after its launch"
            )
        else:
            print(
                f"{model}: every target first held at step {first.steps:,}, "
                f"{first.wall:.1f} s of wall time ({first.cpu:.1f} s CPU) after train.py's "
                f"launch; the run ended at step {last.steps:,}, {last.wall:.1f} s"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())

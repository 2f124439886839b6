"""What the first run after installing pays: compiling the kernels a training run needs.

    python benchmarks/bench_compile.py
    python benchmarks/bench_compile.py --models tricycle bicycle --repeats 3

numba compiles each kernel the first time a process calls it and keeps the machine code in its
cache (``mobile_envs/__pycache__``, or ``NUMBA_CACHE_DIR``); later processes load it. For each
model, ``train.py`` trains ``mobile_envs/<Model>-Random-v0`` with the model's entry of
``hyperparams/ppo.yml`` cut short (the warm start's teacher drives 400 steps and the clone
fits one epoch, then 4,096 PPO steps, no evaluations), so that the run calls every kernel a
full run calls before its first PPO update: twice on one empty cache folder, first cold
(compiling every kernel), then warm (loading them). Printed per model: both wall times,
their difference (the compiling) and their ratio; with ``--repeats``, the median of each
over that many pairs, each pair on a new empty folder. The shortened runs' folders and
caches are made in a temporary folder and deleted.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time
from typing import Any

import yaml
from bench_ppo_targets import MODELS

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: The warm start shortened: enough teacher steps for completed episodes to clone.
SHORT_WARM_START = {"steps": 400, "epochs": 1}
SHORT_TIMESTEPS = 4096
#: The models with a shipped policy, whose recipes the issue times.
TRAINED = ("constant_velocity", "diff_drive", "tricycle", "bicycle")


def short_recipes(hyperparams: pathlib.Path) -> dict[str, Any]:
    """The entries of ``hyperparams`` with every warm start cut to :data:`SHORT_WARM_START`."""
    entries = yaml.safe_load(hyperparams.read_text(encoding="utf-8"))
    for entry in entries.values():
        for callback in entry.get("callback", []) if isinstance(entry, dict) else []:
            for settings in callback.values() if isinstance(callback, dict) else []:
                if isinstance(settings, dict) and "teacher" in settings:
                    settings.update(SHORT_WARM_START)
    return dict(entries)


def timed_run(
    model: str, recipes: pathlib.Path, cache: pathlib.Path, output: pathlib.Path
) -> float:
    """Wall seconds of one shortened ``train.py`` run of ``model`` with numba's cache in
    ``cache``, its run folder ``output``.

    :raises RuntimeError: when train.py fails, with its output's last lines
    """
    command = [
        sys.executable,
        str(ROOT / "train.py"),
        "--env",
        f"mobile_envs/{MODELS[model].prefix}-Random-v0",
        "--hyperparams",
        str(recipes),
        "--timesteps",
        str(SHORT_TIMESTEPS),
        "--eval-freq",
        "0",
        "--no-progress",
        "--output",
        str(output),
    ]
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    start = time.perf_counter()
    done = subprocess.run(command, cwd=ROOT, env=environment, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        tail = "\n".join((done.stdout + done.stderr).splitlines()[-5:])
        raise RuntimeError(f"train.py failed for {model} (status {done.returncode}):\n{tail}")
    return seconds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--models",
        nargs="+",
        default=list(TRAINED),
        choices=list(MODELS),
        help="default: the four trained",
    )
    parser.add_argument("--repeats", type=int, default=1, help="cold-warm pairs per model")
    parser.add_argument(
        "--hyperparams",
        type=pathlib.Path,
        default=ROOT / "hyperparams" / "ppo.yml",
        help="the recipes (default: hyperparams/ppo.yml)",
    )
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error(f"--repeats must be at least 1, got {args.repeats}")
    if not args.hyperparams.is_file():
        parser.error(f"--hyperparams: no file at {args.hyperparams}")
    with tempfile.TemporaryDirectory(prefix="bench_compile_") as scratch:
        folder = pathlib.Path(scratch)
        recipes = folder / "short.yml"
        recipes.write_text(yaml.safe_dump(short_recipes(args.hyperparams)), encoding="utf-8")
        print(f"{'model':<18} {'cold s':>7} {'warm s':>7} {'compiling s':>12} {'cold / warm':>12}")
        for model in args.models:
            pairs = []
            for repeat in range(args.repeats):
                cache = folder / f"cache_{model}_{repeat}"
                cache.mkdir()
                runs = folder / f"runs_{model}_{repeat}"
                try:
                    cold = timed_run(model, recipes, cache, runs / "cold")
                    warm = timed_run(model, recipes, cache, runs / "warm")
                except RuntimeError as error:
                    print(f"bench_compile: {error}", file=sys.stderr)
                    return 1
                pairs.append((cold, warm))
            cold = statistics.median(pair[0] for pair in pairs)
            warm = statistics.median(pair[1] for pair in pairs)
            compiling = statistics.median(pair[0] - pair[1] for pair in pairs)
            ratio = statistics.median(pair[0] / pair[1] for pair in pairs)
            print(
                f"{model:<18} {cold:7.1f} {warm:7.1f} {compiling:12.1f} {ratio:11.1f}x", flush=True
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())

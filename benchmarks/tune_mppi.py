"""How MPPI's defaults were chosen: candidate settings on random tracks, every model at once.

    python benchmarks/tune_mppi.py [--episodes 64] [--seed 3000000]
        [--models diff_drive bicycle ...] [--candidate '{"heading_weight": 3}' ...]

Each candidate (a JSON object of :class:`agents.controllers.mppi.MPPI` arguments; the
defaults alone when none is given) drives ``--episodes`` episodes of every model's
``<Model>-Random-v0`` (random paths and random mazes, start noise (0.2 m, 0.3 rad)), from
seeds ``--seed`` on: never the course's paths or the canonical maze, which the defaults are
then measured on (``benchmarks/bench_ppo_targets.py``). All episodes of a model run at once
through the batched harness, MPPI planning every robot in one call. Prints, per candidate
and model, the completion rate, the mean |cross-track error| and the mean time to goal,
then per candidate the worst completion and the mean |cte| over the models: the defaults
are the candidate with the best worst completion, then the lowest mean |cte|.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

import mobile_envs  # noqa: F401  (registers the ids)
from agents.arguments import at_least
from agents.controllers.mppi import MPPI
from agents.harness.evaluate import evaluate
from mobile_envs.robots import MODELS

#: Tuning seeds: apart from the evaluation seeds (0 on) and the policies' held-out tracks
#: (1,000,000 on).
TUNING_SEED = 3_000_000
START_NOISE = (0.2, 0.3)


def parse_candidate(text: str) -> dict[str, Any]:
    """An argparse ``type``: a JSON object of valid MPPI arguments."""
    try:
        arguments = json.loads(text)
        if not isinstance(arguments, dict):
            raise ValueError("expected a JSON object")
        MPPI(**arguments)
    except (ValueError, TypeError) as error:
        raise argparse.ArgumentTypeError(f"{text!r}: {error}") from None
    return arguments


def random_tracks(env_id: str, episodes: int, seed: int, agent: MPPI) -> dict[str, float]:
    """Completion rate, mean |cte| and mean time to goal of ``episodes`` episodes (seeds
    ``seed`` on, start noise (0.2 m, 0.3 rad)), through the batched harness."""
    summary = evaluate(agent, env_id, episodes, seed=seed, start_noise=START_NOISE).summary
    return {
        "completion": summary["completion_rate"],
        "mean_abs_cte": summary["mean_abs_cte"],
        "time": summary["mean_time"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=at_least(1), default=64)
    parser.add_argument("--seed", type=at_least(0), default=TUNING_SEED)
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    parser.add_argument(
        "--candidate", action="append", type=parse_candidate, default=[], metavar="JSON"
    )
    args = parser.parse_args()
    candidates: list[dict[str, Any]] = args.candidate or [{}]
    summary = []
    for candidate in candidates:
        agent = MPPI(**candidate)
        completions, ctes = [], []
        for name in args.models:
            env_id = f"mobile_envs/{MODELS[name].env_id}-Random-v0"
            start = time.perf_counter()
            result = random_tracks(env_id, args.episodes, args.seed, agent)
            completions.append(result["completion"])
            ctes.append(result["mean_abs_cte"])
            print(
                f"{json.dumps(candidate)} {name:<18} completion {result['completion']:.3f} "
                f"mean|cte| {result['mean_abs_cte']:.4f} time {result['time']:.1f} s "
                f"({time.perf_counter() - start:.0f} s)",
                flush=True,
            )
        summary.append((min(completions), float(np.mean(ctes)), candidate))
    print("\n| candidate | worst completion | mean of mean abs cte (m) |\n|---|---|---|")
    for worst, cte, candidate in sorted(summary, key=lambda row: (-row[0], row[1])):
        print(f"| `{json.dumps(candidate)}` | {worst:.3f} | {cte:.4f} |")


if __name__ == "__main__":
    main()

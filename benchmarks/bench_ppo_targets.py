"""PPO against pure pursuit on paths it never trained on: the project's targets, checked.

    python benchmarks/bench_ppo_targets.py [--episodes 50] [--models diff_drive bicycle]

Policies from ``models/`` (trained on random paths and random mazes only) meet PurePursuit
(MATLAB mode, the course's controller) and RegulatedPurePursuit on Segments, SharpSegments,
Lines and the canonical Maze, with start-pose noise on and identical episodes for every
agent (episode i resets with seed i). Targets, per model:

- PPO completes at least 98% of episodes on every path set;
- its mean |cross-track error| is no worse than pure pursuit's;
- its max |cross-track error| on SharpSegments is at most half of pure pursuit's;
- its time to goal is at most 1.25 times pure pursuit's;
- where pure pursuit does not reach the goal (the bicycle on Segments), PPO does.

Prints a markdown table of every agent's summary and one line per target.
"""

from __future__ import annotations

import argparse
import math
import pathlib

from agents.evaluate import evaluate
from agents.ppo import load_policy
from agents.pure_pursuit import PurePursuit, RegulatedPurePursuit

ROOT = pathlib.Path(__file__).resolve().parents[1]
POLICIES = {
    "diff_drive": ("DiffDrive", ROOT / "models" / "diffdrive_ppo.zip"),
    "bicycle": ("Bicycle", ROOT / "models" / "bicycle_ppo.zip"),
}
PATH_SETS = ("Segments", "SharpSegments", "Lines", "Maze")
ENV_KWARGS = {"start_noise": (0.2, 0.3)}


def summaries(model: str, episodes: int) -> dict[tuple[str, str], dict[str, float]]:
    """(path set, agent) -> evaluation summary, every agent on the same episodes."""
    prefix, policy_path = POLICIES[model]
    results = {}
    for path_set in PATH_SETS:
        env_id = f"mobile_envs/{prefix}-{path_set}-v0"
        agents = {
            "ppo": load_policy(policy_path),
            "pure_pursuit": PurePursuit(),
            "regulated_pure_pursuit": RegulatedPurePursuit(),
        }
        for name, agent in agents.items():
            summary = evaluate(agent, env_id, episodes, seed=0, **ENV_KWARGS).summary
            results[path_set, name] = summary
            print(
                f"  {env_id:<36} {name:<24} completion {summary['completion_rate']:.2f} "
                f"mean|cte| {summary['mean_abs_cte']:.3f} max|cte| {summary['max_abs_cte']:.3f} "
                f"time {summary['mean_time']:.1f}",
                flush=True,
            )
    return results


def check_targets(results: dict[tuple[str, str], dict[str, float]]) -> list[tuple[str, bool, str]]:
    """(target, met, measured) for each target."""
    checks = []
    for path_set in PATH_SETS:
        ppo, pure = results[path_set, "ppo"], results[path_set, "pure_pursuit"]
        checks.append(
            (
                f"{path_set}: completion >= 0.98",
                ppo["completion_rate"] >= 0.98,
                f"{ppo['completion_rate']:.2f}",
            )
        )
        checks.append(
            (
                f"{path_set}: mean |cte| <= pure pursuit's",
                ppo["mean_abs_cte"] <= pure["mean_abs_cte"],
                f"{ppo['mean_abs_cte']:.3f} vs {pure['mean_abs_cte']:.3f} m",
            )
        )
        if math.isnan(pure["mean_time"]):
            checks.append(
                (
                    f"{path_set}: reaches the goal where pure pursuit does not",
                    ppo["completion_rate"] > 0.0,
                    f"{ppo['completion_rate']:.2f} vs {pure['completion_rate']:.2f}",
                )
            )
        else:
            checks.append(
                (
                    f"{path_set}: time <= 1.25 x pure pursuit's",
                    ppo["mean_time"] <= 1.25 * pure["mean_time"],
                    f"{ppo['mean_time']:.1f} vs {pure['mean_time']:.1f} s",
                )
            )
    ppo, pure = results["SharpSegments", "ppo"], results["SharpSegments", "pure_pursuit"]
    checks.append(
        (
            "SharpSegments: max |cte| <= half of pure pursuit's",
            ppo["max_abs_cte"] <= 0.5 * pure["max_abs_cte"],
            f"{ppo['max_abs_cte']:.3f} vs {pure['max_abs_cte']:.3f} m",
        )
    )
    return checks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--models", nargs="+", default=list(POLICIES), choices=list(POLICIES))
    args = parser.parse_args()
    tables = []
    for model in args.models:
        print(f"{model}: {args.episodes} episodes per path set, start noise {ENV_KWARGS}")
        results = summaries(model, args.episodes)
        tables.append((model, results, check_targets(results)))
    for model, results, checks in tables:
        print(f"\n### {model}\n")
        print("| path set | agent | completion | mean abs cte (m) | max abs cte (m) | time (s) |")
        print("|---|---|---|---|---|---|")
        for (path_set, agent), summary in results.items():
            print(
                f"| {path_set} | {agent} | {summary['completion_rate']:.2f} | "
                f"{summary['mean_abs_cte']:.3f} | {summary['max_abs_cte']:.3f} | "
                f"{summary['mean_time']:.1f} |"
            )
        print()
        for target, met, measured in checks:
            print(f"- [{'x' if met else ' '}] {target}: {measured}")


if __name__ == "__main__":
    main()

"""Learned trackers against the classical ones on paths they never trained on: the targets.

    python benchmarks/bench_ppo_targets.py [--episodes 50] [--models diff_drive bicycle ...]
        [--localization odometry+beacons] [--policy runs/X/final_model.zip]

Each shipped policy in ``models/`` (trained on random paths and random mazes only, never on
the course paths or the canonical maze) meets PurePursuit (MATLAB mode, the course's
controller) and RegulatedPurePursuit on Segments, SharpSegments, Lines and the canonical
Maze, every agent on the same episodes (episode i resets with seed i), once with start-pose
noise (0.2 m, 0.3 rad) and once without; MPPI (:class:`agents.controllers.mppi.MPPI`, the
model-predictive baseline) drives the same episodes. Targets, per model and per noise
setting:

- completion >= 98% on every path set;
- mean |cross-track error| below both pure pursuit's and regulated pure pursuit's;
- max |cross-track error| on SharpSegments at most regulated pure pursuit's;
- time to goal at most 1.1 times regulated pure pursuit's;
- on 200 random training-style tracks (paths and mazes) from the held-out seeds
  :data:`HELD_OUT_SEED` on, which no training run draws (train.py seeds its robots 0 to
  n_envs - 1), completion >= 98%.

With ``--localization MODE`` the same episodes run again with every agent steering on what
``MODE`` tells it (``odometry``, ``beacons``, ``odometry+beacons``), scored on the truth;
the target there is completion >= 95% for the policy (the constant-velocity model has no
wheel odometry, so it runs no mode that needs it). The targets against MPPI (completion
>= MPPI's, mean |cte| below MPPI's, time to goal <= 1.1 x MPPI's on every path set) are
reported beside these, not yet required. Prints a markdown table per model and one line per
target; the tables give each completion rate and mean |cte| with its 95% interval (Wilson
score; Student t), so ``--episodes 1000`` (seconds per agent and env: the harness runs every
episode at once) tells a margin from noise. ``--policy ZIP`` measures a candidate (one
model's) in place of the shipped one, on the same episodes.
"""

from __future__ import annotations

import argparse
import math
import pathlib
from collections.abc import Iterator
from typing import Any

from agents.controllers.mppi import MPPI
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from agents.harness.evaluate import evaluate
from agents.harness.policies import load_policy

ROOT = pathlib.Path(__file__).resolve().parents[1]
POLICIES = {
    "constant_velocity": ("ConstantVelocity", ROOT / "models" / "constant_velocity_ppo.zip"),
    "diff_drive": ("DiffDrive", ROOT / "models" / "diffdrive_ppo.zip"),
    "bicycle": ("Bicycle", ROOT / "models" / "bicycle_ppo.zip"),
    "tricycle": ("Tricycle", ROOT / "models" / "tricycle_ppo.zip"),
}
PATH_SETS = ("Segments", "SharpSegments", "Lines", "Maze")
START_NOISE = {"with start noise": (0.2, 0.3), "without start noise": (0.0, 0.0)}
#: The first seed of the held-out random tracks; training draws from seeds 0 to n_envs - 1.
HELD_OUT_SEED = 1_000_000
HELD_OUT_EPISODES = 200

Summaries = dict[tuple[str, str], dict[str, float]]
Intervals = dict[tuple[str, str], dict[str, tuple[float, float]]]


def agents_for(policy_path: pathlib.Path) -> dict[str, Any]:
    return {
        "ppo": load_policy(policy_path),
        "pure_pursuit": PurePursuit(),
        "regulated_pure_pursuit": RegulatedPurePursuit(),
        "mppi": MPPI(),
    }


def summaries(
    model: str, policy_path: pathlib.Path, episodes: int, env_kwargs: dict[str, Any]
) -> tuple[Summaries, Intervals]:
    """(path set, agent) -> evaluation summary and its 95% intervals, every agent on the same
    episodes."""
    prefix = POLICIES[model][0]
    results, intervals = {}, {}
    for path_set in PATH_SETS:
        env_id = f"mobile_envs/{prefix}-{path_set}-v0"
        for name, agent in agents_for(policy_path).items():
            result = evaluate(agent, env_id, episodes, seed=0, **env_kwargs)
            summary = result.summary
            results[path_set, name] = summary
            intervals[path_set, name] = result.intervals()
            print(
                f"  {env_id:<36} {name:<24} completion {summary['completion_rate']:.2f} "
                f"mean|cte| {summary['mean_abs_cte']:.3f} max|cte| {summary['max_abs_cte']:.3f} "
                f"time {summary['mean_time']:.1f}",
                flush=True,
            )
    return results, intervals


def held_out_completion(model: str, policy_path: pathlib.Path) -> float:
    """The policy's completion rate on the held-out random tracks."""
    prefix = POLICIES[model][0]
    env_id = f"mobile_envs/{prefix}-Random-v0"
    result = evaluate(load_policy(policy_path), env_id, HELD_OUT_EPISODES, seed=HELD_OUT_SEED)
    return result.summary["completion_rate"]


def check_targets(results: Summaries) -> Iterator[tuple[str, bool, str]]:
    """(target, met, measured) for each target of one noise setting."""
    for path_set in PATH_SETS:
        ppo = results[path_set, "ppo"]
        pure = results[path_set, "pure_pursuit"]
        regulated = results[path_set, "regulated_pure_pursuit"]
        yield (
            f"{path_set}: completion >= 0.98",
            ppo["completion_rate"] >= 0.98,
            f"{ppo['completion_rate']:.2f}",
        )
        best = min(pure["mean_abs_cte"], regulated["mean_abs_cte"])
        yield (
            f"{path_set}: mean |cte| below both pure pursuits'",
            ppo["mean_abs_cte"] < best,
            f"{ppo['mean_abs_cte']:.3f} vs {pure['mean_abs_cte']:.3f} / "
            f"{regulated['mean_abs_cte']:.3f} m",
        )
        yield (
            f"{path_set}: time <= 1.1 x regulated pure pursuit's",
            ppo["mean_time"] <= 1.1 * regulated["mean_time"]
            or (math.isnan(regulated["mean_time"]) and not math.isnan(ppo["mean_time"])),
            f"{ppo['mean_time']:.1f} vs {regulated['mean_time']:.1f} s",
        )
    ppo = results["SharpSegments", "ppo"]
    regulated = results["SharpSegments", "regulated_pure_pursuit"]
    yield (
        "SharpSegments: max |cte| <= regulated pure pursuit's",
        ppo["max_abs_cte"] <= regulated["max_abs_cte"],
        f"{ppo['max_abs_cte']:.3f} vs {regulated['max_abs_cte']:.3f} m",
    )


def mppi_targets(results: Summaries) -> Iterator[tuple[str, bool, str]]:
    """(target, met, measured) against MPPI for each path set of one noise setting:
    reported, not yet required."""
    for path_set in PATH_SETS:
        ppo, mppi = results[path_set, "ppo"], results[path_set, "mppi"]
        yield (
            f"{path_set}: completion >= MPPI's",
            ppo["completion_rate"] >= mppi["completion_rate"],
            f"{ppo['completion_rate']:.2f} vs {mppi['completion_rate']:.2f}",
        )
        yield (
            f"{path_set}: mean |cte| below MPPI's",
            ppo["mean_abs_cte"] < mppi["mean_abs_cte"],
            f"{ppo['mean_abs_cte']:.3f} vs {mppi['mean_abs_cte']:.3f} m",
        )
        yield (
            f"{path_set}: time <= 1.1 x MPPI's",
            ppo["mean_time"] <= 1.1 * mppi["mean_time"]
            or (math.isnan(mppi["mean_time"]) and not math.isnan(ppo["mean_time"])),
            f"{ppo['mean_time']:.1f} vs {mppi['mean_time']:.1f} s",
        )


def with_interval(value: float, interval: tuple[float, float], style: str) -> str:
    """``value [low, high]`` in ``style``; the value alone where the interval is undefined."""
    text = style.format(value)
    if not math.isnan(interval[0]):
        text += f" [{style.format(interval[0])}, {style.format(interval[1])}]"
    return text


def print_table(title: str, results: Summaries, intervals: Intervals) -> None:
    print(f"\n#### {title}\n")
    print(
        "| path set | agent | completion [95% Wilson] | mean \\|cte\\| (m) [95% t] "
        "| max \\|cte\\| (m) | time to goal (s) |"
    )
    print("|---|---|---|---|---|---|")
    for (path_set, agent), summary in results.items():
        bounds = intervals[path_set, agent]
        completion = with_interval(summary["completion_rate"], bounds["completion_rate"], "{:.2f}")
        cte = with_interval(summary["mean_abs_cte"], bounds["mean_abs_cte"], "{:.3f}")
        print(
            f"| {path_set} | {agent.replace('_', ' ')} | {completion} | {cte} | "
            f"{summary['max_abs_cte']:.3f} | {summary['mean_time']:.1f} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--models", nargs="+", default=list(POLICIES), choices=list(POLICIES))
    parser.add_argument(
        "--localization",
        choices=("odometry", "beacons", "odometry+beacons"),
        help="run the start-noise episodes again with this localization",
    )
    parser.add_argument(
        "--policy",
        type=pathlib.Path,
        help="a policy zip to measure instead of the shipped one (with a single --models)",
    )
    args = parser.parse_args()
    if args.policy is not None and len(args.models) != 1:
        parser.error("--policy needs exactly one model in --models")
    if args.policy is not None and not args.policy.is_file():
        parser.error(f"--policy: no such file {args.policy}")
    reports = []
    for model in args.models:
        policy_path = POLICIES[model][1] if args.policy is None else args.policy
        tables, checks, against_mppi = [], [], []
        for setting, noise in START_NOISE.items():
            print(f"{model}, {setting}: {args.episodes} episodes per path set", flush=True)
            results, intervals = summaries(
                model, policy_path, args.episodes, {"start_noise": noise}
            )
            tables.append((setting, results, intervals))
            checks += [(f"{setting}: {target}", met, text) for target, met, text in
                       check_targets(results)]  # fmt: skip
            against_mppi += [(f"{setting}: {target}", met, text) for target, met, text in
                             mppi_targets(results)]  # fmt: skip
        completion = held_out_completion(model, policy_path)
        checks.append(
            (
                f"{HELD_OUT_EPISODES} held-out random tracks (seeds {HELD_OUT_SEED:,} on): "
                "completion >= 0.98",
                completion >= 0.98,
                f"{completion:.3f}",
            )
        )
        if args.localization and not (
            model == "constant_velocity" and "odometry" in args.localization
        ):  # the holonomic model has no wheels to count
            kwargs = {"start_noise": START_NOISE["with start noise"]}
            kwargs["localization"] = args.localization  # type: ignore[assignment]
            results, intervals = summaries(model, policy_path, args.episodes, kwargs)
            tables.append(
                (f"localization {args.localization}, with start noise", results, intervals)
            )
            for path_set in PATH_SETS:
                rate = results[path_set, "ppo"]["completion_rate"]
                checks.append(
                    (f"{args.localization}, {path_set}: completion >= 0.95", rate >= 0.95,
                     f"{rate:.2f}")
                )  # fmt: skip
        reports.append((model, tables, checks, against_mppi))
    for model, tables, checks, against_mppi in reports:
        print(f"\n### {model}")
        for title, results, intervals in tables:
            print_table(title, results, intervals)
        print()
        for target, met, measured in checks:
            print(f"- [{'x' if met else ' '}] {target}: {measured}")
        print("\nAgainst MPPI (reported, not yet required):\n")
        for target, met, measured in against_mppi:
            print(f"- [{'x' if met else ' '}] {target}: {measured}")


if __name__ == "__main__":
    main()

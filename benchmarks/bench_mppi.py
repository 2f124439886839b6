"""MPPI's goals: its cost per control step, and its tracking against regulated pure pursuit.

    python benchmarks/bench_mppi.py [--part speed|tracking|both] [--models diff_drive ...]
        [--steps 40] [--repeats 3] [--batch 64] [--episodes 50]

**Speed.** For every model, MPPI with its default K and T plans the robots of
``<Model>-Random-v0`` (random paths and random mazes) from their reset (seed 0): ``--steps``
control steps of the bound agent's ``predict`` (restarts, the compiled plan of every robot
and the actions) with the env stepping in between, untimed. Timed at batch 1 (a single env)
and batch ``--batch`` (one vector env, every robot planned in one compiled call, on one core:
the plan runs no threads), best of ``--repeats``. The goal: at least 200 control steps per
second per robot at batch 64, i.e. at most 5 ms per robot-step. As a reference measured in
the same run (these machines are shared and noisy), regulated pure pursuit's ``predict`` on
the same single env: MPPI's ratio to it says what the K x T rollouts cost.

**Tracking.** For every model, MPPI (defaults) and regulated pure pursuit drive the same
``--episodes`` episodes (seeds 0 on, through the batched harness) of Lines, Segments,
SharpSegments and the canonical Maze, with start noise (0.2 m, 0.3 rad) and without. The
goals: MPPI completes at least 98% of every set, and its mean |cross-track error| is below
regulated pure pursuit's. MPPI's defaults were never tuned on these paths
(``benchmarks/tune_mppi.py`` tunes on random tracks).
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import gymnasium as gym

import mobile_envs  # noqa: F401  (registers the ids)
from agents.arguments import at_least
from agents.controllers.mppi import MPPI
from agents.controllers.pure_pursuit import RegulatedPurePursuit
from agents.harness.evaluate import evaluate
from mobile_envs.robots import MODELS

#: The goal: control steps per second per robot at batch 64.
GOAL_STEPS_PER_SECOND = 200.0
#: The goal: MPPI's completion rate on every set.
GOAL_COMPLETION = 0.98
PATH_SETS = ("Lines", "Segments", "SharpSegments", "Maze")
START_NOISE = {"start noise (0.2 m, 0.3 rad)": (0.2, 0.3), "no start noise": (0.0, 0.0)}


def seconds_per_robot_step(agent: Any, env: Any, steps: int, robots: int) -> float:
    """Seconds ``agent.bind(env).predict`` takes per robot and step, over ``steps`` steps
    from ``reset(seed=0)``; the env's own steps are not timed."""
    bound = agent.bind(env)
    observation, _ = env.reset(seed=0)
    action, _ = bound.predict(observation)  # compiles on first use: not timed
    elapsed = 0.0
    for _ in range(steps):
        observation, *_ = env.step(action)
        start = time.perf_counter()
        action, _ = bound.predict(observation)
        elapsed += time.perf_counter() - start
    return elapsed / (steps * robots)


def speed(models: list[str], steps: int, repeats: int, batch: int) -> None:
    """Print the speed table."""
    print(
        "| model | RPP ms/robot-step | MPPI ms/robot-step, batch 1 | MPPI ms/robot-step, "
        f"batch {batch} | steps/s per robot, batch {batch} | batch {batch} / "
        "RPP | goal |\n|---|---|---|---|---|---|---|"
    )
    for name in models:
        env_id = f"mobile_envs/{MODELS[name].env_id}-Random-v0"
        single = gym.make(env_id)
        vector = gym.make_vec(env_id, num_envs=batch)
        reference = min(
            seconds_per_robot_step(RegulatedPurePursuit(), single, steps, 1) for _ in range(repeats)
        )
        alone = min(seconds_per_robot_step(MPPI(), single, steps, 1) for _ in range(repeats))
        batched = min(seconds_per_robot_step(MPPI(), vector, steps, batch) for _ in range(repeats))
        rate = 1.0 / batched
        print(
            f"| {name} | {1e3 * reference:.3f} | {1e3 * alone:.3f} | {1e3 * batched:.3f} | "
            f"{rate:.0f} | {batched / reference:.0f} | "
            f"{'met' if rate >= GOAL_STEPS_PER_SECOND else 'missed'} |",
            flush=True,
        )
        single.close()
        vector.close()


def tracking(models: list[str], episodes: int) -> list[str]:
    """Print the tracking table; return the goals missed, one line each."""
    print(
        "| model | path set | start | MPPI completion | RPP completion | MPPI mean \\|cte\\| (m) "
        "| RPP mean \\|cte\\| (m) | MPPI time (s) | RPP time (s) | goals |\n"
        "|---|---|---|---|---|---|---|---|---|---|"
    )
    missed = []
    for name in models:
        for path_set in PATH_SETS:
            env_id = f"mobile_envs/{MODELS[name].env_id}-{path_set}-v0"
            for setting, noise in START_NOISE.items():
                mppi = evaluate(MPPI(), env_id, episodes, start_noise=noise).summary
                rpp = evaluate(RegulatedPurePursuit(), env_id, episodes, start_noise=noise).summary
                completes = mppi["completion_rate"] >= GOAL_COMPLETION
                tracks = mppi["mean_abs_cte"] < rpp["mean_abs_cte"]
                where = f"{name}, {path_set}, {setting}"
                if not completes:
                    missed.append(f"{where}: completion {mppi['completion_rate']:.2f} < 0.98")
                if not tracks:
                    missed.append(
                        f"{where}: mean |cte| {mppi['mean_abs_cte']:.4f} m >= RPP's "
                        f"{rpp['mean_abs_cte']:.4f} m"
                    )
                goals = "met" if completes and tracks else "missed"
                print(
                    f"| {name} | {path_set} | {setting} | {mppi['completion_rate']:.2f} | "
                    f"{rpp['completion_rate']:.2f} | {mppi['mean_abs_cte']:.4f} | "
                    f"{rpp['mean_abs_cte']:.4f} | {mppi['mean_time']:.1f} | "
                    f"{rpp['mean_time']:.1f} | {goals} |",
                    flush=True,
                )
    return missed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("speed", "tracking", "both"), default="both")
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    parser.add_argument("--steps", type=at_least(1), default=40)
    parser.add_argument("--repeats", type=at_least(1), default=3)
    parser.add_argument("--batch", type=at_least(1), default=64)
    parser.add_argument("--episodes", type=at_least(1), default=50)
    args = parser.parse_args()
    print(f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; {MPPI()!r}\n")
    if args.part in ("speed", "both"):
        speed(args.models, args.steps, args.repeats, args.batch)
        print()
    if args.part in ("tracking", "both"):
        missed = tracking(args.models, args.episodes)
        print(f"\n{len(missed)} tracking goals missed" + (":" if missed else "."))
        for line in missed:
            print(f"- {line}")


if __name__ == "__main__":
    main()

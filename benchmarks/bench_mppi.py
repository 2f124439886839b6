"""MPPI's cost per control step: ms per robot planned alone and per robot in a batch of 64.

    python benchmarks/bench_mppi.py [--steps 40] [--repeats 3] [--batch 64]
        [--models diff_drive bicycle ...]

For every model, MPPI with its default K and T plans the robots of ``<Model>-Random-v0``
(random paths and random mazes) from their reset (seed 0): ``--steps`` control steps of
the bound agent's ``predict`` (restarts, the compiled plan of every robot and the actions)
with the env stepping in between, untimed. Timed at batch 1 (a single env) and batch
``--batch`` (one vector env, every robot planned in one compiled call, on one core: the
plan runs no threads), best of ``--repeats``. The goal: at least 200 control steps per
second per robot at batch 64, i.e. at most 5 ms per robot-step. As a reference measured in
the same run (these machines are shared and noisy), regulated pure pursuit's ``predict``
on the same single env: MPPI's ratio to it says what the K x T rollouts cost.
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import gymnasium as gym

import mobile_envs  # noqa: F401  (registers the ids)
from agents.controllers.mppi import MPPI
from agents.controllers.pure_pursuit import RegulatedPurePursuit
from mobile_envs.robots import MODELS

#: The goal: control steps per second per robot at batch 64.
GOAL_STEPS_PER_SECOND = 200.0


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--batch", type=int, default=64)
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    args = parser.parse_args()
    print(f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; MPPI {MPPI()!r}\n")
    print(
        "| model | RPP ms/robot-step | MPPI ms/robot-step, batch 1 | MPPI ms/robot-step, "
        f"batch {args.batch} | steps/s per robot, batch {args.batch} | batch {args.batch} / "
        "RPP | goal |\n|---|---|---|---|---|---|---|"
    )
    for name in args.models:
        env_id = f"mobile_envs/{MODELS[name].env_id}-Random-v0"
        single = gym.make(env_id)
        vector = gym.make_vec(env_id, num_envs=args.batch)
        reference = min(
            seconds_per_robot_step(RegulatedPurePursuit(), single, args.steps, 1)
            for _ in range(args.repeats)
        )
        alone = min(
            seconds_per_robot_step(MPPI(), single, args.steps, 1) for _ in range(args.repeats)
        )
        batched = min(
            seconds_per_robot_step(MPPI(), vector, args.steps, args.batch)
            for _ in range(args.repeats)
        )
        rate = 1.0 / batched
        print(
            f"| {name} | {1e3 * reference:.3f} | {1e3 * alone:.3f} | {1e3 * batched:.3f} | "
            f"{rate:.0f} | {batched / reference:.0f} | "
            f"{'met' if rate >= GOAL_STEPS_PER_SECOND else 'missed'} |",
            flush=True,
        )
        single.close()
        vector.close()


if __name__ == "__main__":
    main()

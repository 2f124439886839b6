"""The evaluation harness's speed: robot-steps per second, against a single env stepping
random actions in the same run.

    python benchmarks/bench_harness.py [--episodes 50] [--repeats 3] [--sequential-repeats 1]

The episodes are those of the issue that asked for the batched harness (issue 29): 50
episodes of ``DiffDrive-SharpSegments-v0`` with start noise (0.2 m, 0.3 rad), seeds 0 to 49,
driven by pure pursuit (MATLAB mode), regulated pure pursuit and the shipped PPO policy
``models/diffdrive_ppo.zip`` (one torch thread, as training runs it). For each agent:

- ``evaluate``: :func:`agents.harness.evaluate.evaluate`, every episode at once;
- ``one at a time``: the loop it replaced, one episode after another in one single env
  (:func:`agents.harness.evaluate.run_episode`), the agent asked for one action a step.

Each is the episodes' steps divided by the wall time (best of ``--repeats``; compiling
excluded), printed with its ratio to the reference measured beside it in the same run: one
single env (``gym.make``) stepping random actions drawn in advance, resetting when an
episode ends, best of 3, measured again for every agent (the load of a shared machine drifts
within a run). The speed-up column is evaluate over one at a time.

Run with another checkout first on the path (``PYTHONPATH=/path/to/old python
benchmarks/bench_harness.py``) to measure that checkout's harness: both rows use only
``evaluate``, ``run_episode`` and ``bind_agent``, which every version has.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

import mobile_envs  # noqa: F401  (registers the ids)
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from agents.harness.evaluate import bind_agent, evaluate, run_episode

ENV_ID = "mobile_envs/DiffDrive-SharpSegments-v0"
START_NOISE = (0.2, 0.3)
POLICY = pathlib.Path(__file__).resolve().parents[1] / "models" / "diffdrive_ppo.zip"


def best_rate(run: Callable[[], int], repeats: int) -> float:
    """The highest steps per second of ``repeats`` calls of ``run`` (which returns the steps
    it took)."""
    best = 0.0
    for _ in range(repeats):
        start = time.perf_counter()
        steps = run()
        best = max(best, steps / (time.perf_counter() - start))
    return best


def random_single_env_rate(steps: int = 20_000) -> float:
    """Steps per second of one single env under random actions drawn in advance."""
    env = gym.make(ENV_ID, start_noise=START_NOISE)
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, 2)).astype(np.float32)

    def run() -> int:
        env.reset(seed=0)
        for action in actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        return steps

    run()
    return best_rate(run, 3)


def harness_rate(agent: Any, episodes: int, repeats: int) -> tuple[float, int]:
    """Steps per second of :func:`evaluate` on the episodes, and their steps."""

    def run() -> int:
        result = evaluate(agent, ENV_ID, episodes, seed=0, start_noise=START_NOISE)
        return sum(episode.steps for episode in result.episodes)

    steps = run()  # compiles what it needs
    return best_rate(run, repeats), steps


def sequential_rate(agent: Any, episodes: int, repeats: int) -> float:
    """Steps per second of the episodes one at a time in one single env."""
    env = gym.make(ENV_ID, start_noise=START_NOISE)
    bound = bind_agent(agent, env)
    run_episode(bound, env, 0)

    def run() -> int:
        return sum(run_episode(bound, env, index).steps for index in range(episodes))

    return best_rate(run, repeats)


def agents() -> dict[str, Any]:
    import torch

    from agents.harness.policies import load_policy

    torch.set_num_threads(1)
    return {
        "pure pursuit": PurePursuit(),
        "regulated pure pursuit": RegulatedPurePursuit(),
        "ppo (models/diffdrive_ppo.zip)": load_policy(POLICY),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=3, help="timed runs of evaluate")
    parser.add_argument(
        "--sequential-repeats", type=int, default=1, help="timed runs of the one-at-a-time loop"
    )
    args = parser.parse_args()
    for flag in ("episodes", "repeats", "sequential_repeats"):
        if getattr(args, flag) < 1:
            parser.error(f"--{flag.replace('_', '-')} must be at least 1")
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores", flush=True)
    rows = []
    for name, agent in agents().items():
        reference = random_single_env_rate()
        rate, steps = harness_rate(agent, args.episodes, args.repeats)
        one_at_a_time = sequential_rate(agent, args.episodes, args.sequential_repeats)
        print(
            f"{name}: evaluate {rate:,.0f} steps/s ({steps:,} steps), one at a time "
            f"{one_at_a_time:,.0f} steps/s, single env with random actions {reference:,.0f}",
            flush=True,
        )
        rows.append((name, reference, rate, one_at_a_time))
    print(
        f"\n{args.episodes} episodes of {ENV_ID.removeprefix('mobile_envs/')}, start noise "
        f"{START_NOISE}; x: ratio to one single env stepping random actions, measured beside\n"
    )
    print(
        "| agent | evaluate (steps/s) | x | one at a time (steps/s) | x | speed-up "
        "| single env (steps/s) |"
    )
    print("|---|---|---|---|---|---|---|")
    for name, reference, rate, one_at_a_time in rows:
        print(
            f"| {name} | {rate:,.0f} | {rate / reference:.2f} | {one_at_a_time:,.0f} | "
            f"{one_at_a_time / reference:.2f} | {rate / one_at_a_time:.1f} | {reference:,.0f} |"
        )


if __name__ == "__main__":
    main()

"""Single-env speed: steps per second through gym.make, against Pendulum-v1 in the same run.

    python benchmarks/bench_env.py [--steps 20000] [--repeats 5]

Both envs run the same loop (random actions drawn in advance, reset when an episode ends);
the figure that matters is the ratio, measured in one process because these machines are
noisy. The best of ``--repeats`` runs of each env is reported.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym

import mobile_envs  # noqa: F401  (registers the ids)

ENV_IDS = ("mobile_envs/DiffDrive-Segments-v0", "mobile_envs/Bicycle-Maze-v0")


def steps_per_second(env_id: str, steps: int) -> float:
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps)]
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    elapsed = time.perf_counter() - start
    env.close()
    return steps / elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    reference = max(steps_per_second("Pendulum-v1", args.steps) for _ in range(args.repeats))
    print(f"{'env':<36} {'steps/s':>10} {'ratio to Pendulum-v1':>22}")
    print(f"{'Pendulum-v1':<36} {reference:>10.0f} {1.0:>22.2f}")
    for env_id in ENV_IDS:
        rate = max(steps_per_second(env_id, args.steps) for _ in range(args.repeats))
        print(f"{env_id:<36} {rate:>10.0f} {rate / reference:>22.2f}")


if __name__ == "__main__":
    main()

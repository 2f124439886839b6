"""What the plant costs: robot-steps/s with ``plant="realistic"`` against the ideal robot.

    python benchmarks/bench_plant.py [--robots 1024] [--steps 300] [--repeats 5]

Both vector envs (DiffDrive-Segments, random actions drawn in advance) run in the same
process, alternating repeat by repeat, since these machines' speed drifts; the best repeat
of each is reported, and their ratio. The realistic plant adds a ring of commands, a lag and
the true parameters per robot, and three normals a step for slip.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import mobile_envs  # noqa: F401  (registers the ids)

ENV_ID = "mobile_envs/DiffDrive-Segments-v0"


def run(envs: gym.vector.VectorEnv, actions: np.ndarray) -> float:
    """Robot-steps per second over ``actions``."""
    envs.reset(seed=0)
    start = time.perf_counter()
    for action in actions:
        envs.step(action)
    return actions.shape[0] * actions.shape[1] / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", type=int, default=1024)
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    plants = {"ideal": None, "realistic": "realistic"}
    envs = {
        name: gym.make_vec(ENV_ID, num_envs=args.robots, plant=plant)
        for name, plant in plants.items()
    }
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (args.steps, args.robots, 2)).astype(np.float32)
    for vector in envs.values():  # compile and warm up
        run(vector, actions[:5])
    best = dict.fromkeys(plants, 0.0)
    for _ in range(args.repeats):
        for name, vector in envs.items():
            best[name] = max(best[name], run(vector, actions))
    print(f"{ENV_ID}, N = {args.robots}, best of {args.repeats} alternating repeats:")
    for name, figure in best.items():
        print(f"  {name:10s} {figure:12,.0f} robot-steps/s")
    print(f"  realistic / ideal: {best['realistic'] / best['ideal']:.2f}")


if __name__ == "__main__":
    main()

"""What a restart costs: the autoreset every vector step pays for the robots whose episode ended.

    python benchmarks/bench_restarts.py [--robots 8] [--calls 2000] [--num-envs 1024]

With random actions at N = 1024 about eight episodes end each step. For each id of
:data:`ENV_IDS`, a native vector env of ``--num-envs`` robots is reset once; then
``PathFollowingCore.reset_robots`` restarts ``--robots`` robots drawn at random among them,
``--calls`` times, each drawing its track and start pose from its own generator as an
autoreset does. The ids take turns call by call, so the machine's noise falls on all of them
alike. Printed: the median and the 10th percentile of a call, per call and per robot, and
each id's ratio to the course env (``DiffDrive-Segments-v0``, whose robots restart on one
fixed path) in the same run.
"""

from __future__ import annotations

import argparse
import time
from typing import cast

import gymnasium as gym
import numpy as np

import mobile_envs  # noqa: F401  (registers the ids)
from mobile_envs.vector import PathFollowingVectorEnv

ENV_IDS = (
    "mobile_envs/DiffDrive-Segments-v0",
    "mobile_envs/DiffDrive-Random-v0",
    "mobile_envs/Bicycle-Random-v0",
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=8, help="robots restarted per call")
    parser.add_argument("--calls", type=int, default=2000, help="timed calls per id")
    parser.add_argument("--num-envs", type=int, default=1024, help="robots in each vector env")
    arguments = parser.parse_args()
    if not 1 <= arguments.robots <= arguments.num_envs or arguments.calls < 1:
        parser.error("need 1 <= --robots <= --num-envs and --calls >= 1")
    envs = [
        cast(PathFollowingVectorEnv, gym.make_vec(env_id, num_envs=arguments.num_envs).unwrapped)
        for env_id in ENV_IDS
    ]
    for vector_env in envs:
        vector_env.reset(seed=0)
    choices = np.random.default_rng(1)
    picks = [
        np.sort(choices.choice(arguments.num_envs, arguments.robots, replace=False))
        for _ in range(arguments.calls)
    ]
    seconds = np.empty((len(envs), arguments.calls))
    warm_up = picks[: min(100, arguments.calls)]
    for call, indices in enumerate(warm_up + picks):
        for env_index, vector_env in enumerate(envs):
            core, rngs = vector_env.core, vector_env.rngs
            start = time.perf_counter()
            core.reset_robots(indices, rngs)
            if call >= len(warm_up):
                seconds[env_index, call - len(warm_up)] = time.perf_counter() - start
    print(f"{arguments.robots} of {arguments.num_envs} robots restarted per call, "
          f"{arguments.calls} calls per id, ids interleaved")  # fmt: skip
    print(f"{'env':<38} {'median us':>10} {'p10 us':>8} {'us/robot':>9} {'x course':>9}")
    reference = np.median(seconds[0])
    for env_id, row in zip(ENV_IDS, seconds, strict=True):
        median, tenth = np.median(row), np.percentile(row, 10)
        print(
            f"{env_id:<38} {median * 1e6:>10.1f} {tenth * 1e6:>8.1f} "
            f"{median * 1e6 / arguments.robots:>9.1f} {median / reference:>9.2f}"
        )


if __name__ == "__main__":
    main()

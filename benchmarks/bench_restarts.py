"""What a restart costs: the autoreset every vector step pays for the robots whose episode ended.

    python benchmarks/bench_restarts.py [--robots 1,8] [--calls 2000] [--num-envs 1024]

With random actions at N = 1024 about eight episodes end each step; at the robot counts PPO
trains with (16 to 256) a step restarts one or two robots, when any. For each id of
:data:`ENV_IDS`, a native vector env of ``--num-envs`` robots is reset once; then, for each
count k of ``--robots``, ``PathFollowingCore.reset_robots`` restarts k robots drawn at random
among them, ``--calls`` times, each drawing its track and start pose from its own generator
as an autoreset does. The ids take turns call by call, so the machine's noise falls on all of
them alike. Printed for each k: the median and the 10th percentile of a call, per call and per
robot, and each id's ratio to the course env (``DiffDrive-Segments-v0``, whose robots restart
on one fixed path) in the same run. Given two counts or more, a least-squares line through
the medians splits each id's restart into what a call costs whatever k is (drawing in one
compiled call, writing the table once) and what each robot adds.
"""

from __future__ import annotations

import argparse
import time
from typing import cast

import gymnasium as gym
import numpy as np
from bench_vector import positive_counts

import mobile_envs  # noqa: F401  (registers the ids)
from mobile_envs.envs.vector import PathFollowingVectorEnv

ENV_IDS = (
    "mobile_envs/DiffDrive-Segments-v0",
    "mobile_envs/DiffDrive-Random-v0",
    "mobile_envs/Bicycle-Random-v0",
)


def restart_seconds(
    envs: list[PathFollowingVectorEnv], robots: int, calls: int, choices: np.random.Generator
) -> np.ndarray:
    """(len(envs), calls) seconds of each timed call restarting ``robots`` robots, the envs
    taking turns call by call after 100 untimed calls (at most ``calls``) of warm-up."""
    num_envs = envs[0].num_envs
    picks = [np.sort(choices.choice(num_envs, robots, replace=False)) for _ in range(calls)]
    warm_up = picks[: min(100, calls)]
    seconds = np.empty((len(envs), calls))
    for call, indices in enumerate(warm_up + picks):
        for env_index, vector_env in enumerate(envs):
            core, rngs = vector_env.core, vector_env.rngs
            start = time.perf_counter()
            core.reset_robots(indices, rngs)
            if call >= len(warm_up):
                seconds[env_index, call - len(warm_up)] = time.perf_counter() - start
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--robots",
        type=positive_counts("--robots", distinct=True),
        default=[8],
        help="comma-separated robots restarted per call (default 8)",
    )
    parser.add_argument("--calls", type=int, default=2000, help="timed calls per id and count")
    parser.add_argument("--num-envs", type=int, default=1024, help="robots in each vector env")
    arguments = parser.parse_args()
    if max(arguments.robots) > arguments.num_envs or arguments.calls < 1:
        parser.error("need every --robots count <= --num-envs and --calls >= 1")
    envs = [
        cast(PathFollowingVectorEnv, gym.make_vec(env_id, num_envs=arguments.num_envs).unwrapped)
        for env_id in ENV_IDS
    ]
    for vector_env in envs:
        vector_env.reset(seed=0)
    choices = np.random.default_rng(1)
    medians = np.empty((len(ENV_IDS), len(arguments.robots)))
    for column, robots in enumerate(arguments.robots):
        seconds = restart_seconds(envs, robots, arguments.calls, choices)
        print(f"\n{robots} of {arguments.num_envs} robots restarted per call, "
              f"{arguments.calls} calls per id, ids interleaved")  # fmt: skip
        print(f"{'env':<38} {'median us':>10} {'p10 us':>8} {'us/robot':>9} {'x course':>9}")
        reference = np.median(seconds[0])
        for row, (env_id, env_seconds) in enumerate(zip(ENV_IDS, seconds, strict=True)):
            median, tenth = np.median(env_seconds), np.percentile(env_seconds, 10)
            medians[row, column] = median
            print(
                f"{env_id:<38} {median * 1e6:>10.1f} {tenth * 1e6:>8.1f} "
                f"{median * 1e6 / robots:>9.1f} {median / reference:>9.2f}"
            )
    if len(arguments.robots) > 1:
        print("\na call's cost, split by a least-squares line through the medians")
        print(f"{'env':<38} {'per call us':>12} {'per robot us':>13}")
        for env_id, env_medians in zip(ENV_IDS, medians, strict=True):
            per_robot, per_call = np.polyfit(arguments.robots, env_medians * 1e6, 1)
            print(f"{env_id:<38} {per_call:>12.1f} {per_robot:>13.1f}")


if __name__ == "__main__":
    main()

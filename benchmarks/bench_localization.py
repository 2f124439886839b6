"""Localization: what each mode costs, how the agents fare on it, and seed 003's run.

    python benchmarks/bench_localization.py [--episodes 10] [--output DIR] [--quick]

1. **Cost.** Robot-steps per second of the batched vector env at N = 1024 under each
   ``localization`` mode, against ``"exact"`` in the same run (best of 3: these machines
   are noisy), on the course's segments (6 reflectors) and in the maze (81 posts, walls).
2. **Agents.** For each mode, ``python -m agents.harness.compare`` with pure pursuit, regulated
   pure pursuit and the shipped PPO policies on the course sets and the maze,
   ``--env-kwargs '{"localization": MODE, "start_noise": [0.2, 0.3]}'`` (each mode's
   comparison.md and plots land in ``DIR/MODE``); also odometry with a tenth of Crowley's
   coefficients and the head with the paper's reading noise. One table of completion, mean
   and max |cross-track error| (the truth's) per agent, env and localization.
3. **Seed 003's run** on ``Tricycle-ArcStraight-Beacons-v0``: the lateral positioning error
   (estimate minus truth, across the heading) while the guidance law steers on the
   estimate, against the paper's mean 9.7 mm, sd 6.6 mm and bound 23 mm; and the drive
   wheel's lateral error after the correction of a 110 mm offset, against its 16.5 mm.
   Also with ``bearing_noise`` 3.5 mrad, the reading noise that gives the paper's mean.

Run it from the repository root (the policies' paths are relative). The default run takes
about 1.5 minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import shlex
import tempfile
import time
from typing import Any

import gymnasium as gym
import numpy as np

import mobile_envs  # noqa: F401  (registers the ids)
from agents.controllers.guidance import TricycleGuidance
from agents.harness import compare

MODES = ("exact", "odometry", "beacons", "odometry+beacons")
COST_ENVS = ("mobile_envs/DiffDrive-Segments-v0", "mobile_envs/DiffDrive-Maze-v0")
AGENTS = (
    "pure_pursuit",
    "regulated_pure_pursuit",
    "ppo:models/diffdrive_ppo.zip",
    "ppo:models/bicycle_ppo.zip",
)
COMPARE_ENVS = tuple(
    f"mobile_envs/{model}-{paths}-v0"
    for model in ("DiffDrive", "Bicycle")
    for paths in ("Lines", "Segments", "SharpSegments", "Maze")
)
START_NOISE = [0.2, 0.3]
#: The localizations the agents meet: each mode as it comes, then odometry ten times better
#: than Crowley's coefficients and the head as noisy as the paper's (see SEED_003_RUNS).
COMPARED: tuple[tuple[str, dict[str, Any]], ...] = (
    ("exact", {"localization": "exact"}),
    ("odometry", {"localization": "odometry"}),
    (
        "odometry K/10",
        {
            "localization": "odometry",
            "localization_params": {
                "k_distance": 1e-4, "k_distance_heading": 3e-4, "k_heading": 1e-4,
            },
        },
    ),
    ("beacons", {"localization": "beacons"}),
    (
        "beacons 3.5 mrad",
        {"localization": "beacons", "localization_params": {"bearing_noise": 0.0035}},
    ),
    ("odometry+beacons", {"localization": "odometry+beacons"}),
)  # fmt: skip
#: Seed 003's run under these localizations: the head as specified (its counts the only
#: error), then with the reading noise (rad) that gives the paper's mean error.
SEED_003_RUNS: tuple[tuple[str, dict[str, float]], ...] = (
    ("beacons", {}),
    ("beacons", {"bearing_noise": 0.0035}),
    ("odometry+beacons", {}),
    ("odometry", {}),
)


def robot_steps_per_second(env_id: str, mode: str, count: int, steps: int) -> float:
    """Time ``steps`` vector steps of ``count`` robots under random actions (drawn in
    advance), after a reset with seed 0 and one warm-up step."""
    envs = gym.make_vec(env_id, num_envs=count, localization=mode)
    shape = envs.single_action_space.shape or ()
    actions = np.random.default_rng(0).uniform(-1, 1, (16, count, *shape)).astype(np.float32)
    envs.reset(seed=0)
    envs.step(actions[0])
    start = time.perf_counter()
    for step in range(steps):
        envs.step(actions[step % 16])
    rate = steps * count / (time.perf_counter() - start)
    envs.close()
    return rate


def measure_costs(count: int, robot_steps: int) -> None:
    print(f"## Cost: robot-steps/s at N = {count} (best of 3)\n")
    print("| env | localization | robot-steps/s | against exact |")
    print("|---|---|---:|---:|")
    for env_id in COST_ENVS:
        rates = {}
        for mode in MODES:
            steps = max(5, robot_steps // count)
            if mode != "exact":  # the beacons cost ~10x: fewer steps, the same error bars
                steps = max(5, steps // 5)
            rates[mode] = max(robot_steps_per_second(env_id, mode, count, steps) for _ in range(3))
            print(
                f"| {env_id.removeprefix('mobile_envs/')} | {mode} | {rates[mode]:,.0f} | "
                f"{rates[mode] / rates['exact']:.2f} |",
                flush=True,
            )
    print()


def compare_command(
    label: str, settings: dict[str, Any], episodes: int, output: pathlib.Path
) -> list[str]:
    kwargs = json.dumps({**settings, "start_noise": START_NOISE})
    folder = "".join(char if char.isalnum() else "_" for char in label)
    return [
        "--agents", *AGENTS, "--envs", *COMPARE_ENVS, "--episodes", str(episodes),
        "--env-kwargs", kwargs, "--output", str(output / folder),
    ]  # fmt: skip


def table_rows(markdown: str) -> dict[tuple[str, str], dict[str, str]]:
    """agents.harness.compare's table as {(env, agent): {column title: value}}, without the
    95% intervals (``completion [95% Wilson]``: ``1.00 [0.72, 1.00]`` is ``completion``:
    ``1.00``)."""
    lines = [
        [cell.split(" [")[0] for cell in line.strip("| ").split(" | ")]
        for line in markdown.strip().splitlines()
    ]
    header, rows = lines[0], lines[2:]
    return {(row[0], row[1]): dict(zip(header, row, strict=True)) for row in rows}


def compare_agents(episodes: int, output: pathlib.Path) -> None:
    tables = {}
    for label, settings in COMPARED:
        argv = compare_command(label, settings, episodes, output)
        print(f"python -m agents.harness.compare {shlex.join(argv)}", flush=True)
        tables[label] = table_rows(compare.main(argv))
    labels = [label for label, _ in COMPARED]
    print("\n## Agents: completion / mean |cte| (m) / max |cte| (m), per localization\n")
    print("| env | agent | " + " | ".join(labels) + " |")
    print("|---|---|" + "---|" * len(labels))
    for key in tables["exact"]:
        cells = []
        for label in labels:
            row = tables[label][key]
            cells.append(
                f"{row['completion']} / {row['mean abs cte (m)']} / {row['max abs cte (m)']}"
            )
        print(f"| {key[0]} | {key[1]} | " + " | ".join(cells) + " |")
    print()


def seed_003_run(
    mode: str, params: dict[str, float], offset: float
) -> tuple[np.ndarray, np.ndarray]:
    """Seed 003's validation run (as tests/test_guidance.py drives it) with the guidance law
    on the estimate: the lateral positioning errors of O and the drive wheel C's lateral
    errors against the arc and straight, per step while C is on the path."""
    radius, centre, straight_y, end_x = 1.24, np.array([2.24, 1.0]), 2.24, 5.24
    env = gym.make(
        "mobile_envs/Tricycle-ArcStraight-Beacons-v0",
        max_cross_track=3.0,
        step_limit=400,
        localization=mode,
        localization_params=params,
    ).unwrapped
    agent = TricycleGuidance.from_poles(3.0, 0.9, speed=0.2).bind(env)
    observation, _ = env.reset(seed=0, options={"start_pose": (1.0 - offset, 0.0, math.pi / 2)})
    positioning, wheel = [], []
    while True:
        action, _ = agent.predict(observation)
        observation, *_, info = env.step(action)
        x, y, psi = info["pose"]
        c = np.array([x + math.cos(psi), y + math.sin(psi)])
        if c[0] > end_x:
            break
        if c[0] < centre[0] and c[1] >= centre[1]:
            wheel.append(math.dist(c, centre) - radius)
        else:
            wheel.append(c[1] - straight_y if c[1] >= centre[1] else 1.0 - c[0])
        error_x, error_y = info["estimated_pose"][:2] - (x, y)
        positioning.append(math.cos(psi) * error_y - math.sin(psi) * error_x)
    return np.abs(positioning), np.abs(wheel)


def measure_seed_003() -> None:
    print("## Seed 003's run at 0.2 m/s, guidance law on the estimate (offsets +-110 mm)\n")
    print(
        "| localization | lateral positioning error mean / sd / max (mm) "
        "| wheel's max |e_c| after 3 s (mm) |"
    )
    print("|---|---|---|")
    print("| paper (Font-Llagunes & Batlle 2006) | 9.7 / 6.6 / < 23 | < 16.5 |")
    for mode, params in SEED_003_RUNS:
        runs = [seed_003_run(mode, params, offset) for offset in (0.110, -0.110)]
        positioning = np.concatenate([run[0] for run in runs])
        wheel = max(run[1][29:].max() for run in runs)  # from step 30 on
        label = mode + "".join(f", {key} {value:g}" for key, value in params.items())
        print(
            f"| {label} | {1e3 * positioning.mean():.3f} / {1e3 * positioning.std():.3f} / "
            f"{1e3 * positioning.max():.3f} | {1e3 * wheel:.1f} |"
        )
    print()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=10, help="per agent and env (10)")
    parser.add_argument("--output", type=pathlib.Path, help="folder for the comparisons")
    parser.add_argument("--quick", action="store_true", help="fewer steps and episodes")
    args = parser.parse_args()
    measure_costs(1024, 50_000 if args.quick else 200_000)
    measure_seed_003()
    episodes = 2 if args.quick else args.episodes
    if args.output is not None:
        compare_agents(episodes, args.output)
    else:
        with tempfile.TemporaryDirectory() as folder:
            compare_agents(episodes, pathlib.Path(folder))


if __name__ == "__main__":
    main()

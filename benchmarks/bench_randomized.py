"""Does domain randomization over the localization buy robustness? A shipped policy against
one trained with ``localization="randomized"``, under a localization harsher than either met.

    python benchmarks/bench_randomized.py --model diff_drive \
        --randomized runs/diffdrive_randomized/final_model.zip

The randomized policy comes from ``hyperparams/ppo_randomized.yml`` (its header has the
command). Each agent (pure pursuit, regulated pure pursuit, the shipped policy, the
randomized one) drives the same 30 episodes per course set and the maze, with start noise
(0.2 m, 0.3 rad), on odometry+beacons with four times eq. 17's K and 2 mrad of bearing
noise. Printed: completion / mean |cte| / max |cte| (m) of the true pose.
"""

from __future__ import annotations

import argparse
from typing import Any

from bench_ppo_targets import POLICIES

import mobile_envs  # noqa: F401  (registers the ids)
from agents import PurePursuit, RegulatedPurePursuit, evaluate
from agents.harness.policies import load_policy
from mobile_envs.sensing.odometry import (
    DEFAULT_K_DISTANCE,
    DEFAULT_K_DISTANCE_HEADING,
    DEFAULT_K_HEADING,
)

PATH_SETS = ("Lines", "Segments", "SharpSegments", "Maze")
EPISODES = 30
#: The localization neither policy trained on, with the course's start noise.
HARSH: dict[str, Any] = {
    "localization": "odometry+beacons",
    "localization_params": {
        "k_distance": 4 * DEFAULT_K_DISTANCE,
        "k_distance_heading": 4 * DEFAULT_K_DISTANCE_HEADING,
        "k_heading": 4 * DEFAULT_K_HEADING,
        "bearing_noise": 0.002,
    },
    "start_noise": [0.2, 0.3],
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", choices=sorted(POLICIES), default="diff_drive")
    parser.add_argument("--randomized", required=True, help="the randomized run's policy zip")
    args = parser.parse_args()
    prefix, shipped = POLICIES[args.model]
    agents = {
        "pure pursuit": PurePursuit,
        "regulated pure pursuit": RegulatedPurePursuit,
        "shipped ppo": load_policy(shipped),
        "randomized ppo": load_policy(args.randomized),
    }
    print(f"| {prefix} | " + " | ".join(agents) + " |")
    print("|---" * (len(agents) + 1) + "|")
    for paths in PATH_SETS:
        env_id = f"mobile_envs/{prefix}-{paths}-v0"
        cells = []
        for agent in agents.values():
            summary = evaluate(agent, env_id, EPISODES, seed=0, **HARSH).summary
            cells.append(
                f"{summary['completion_rate']:.2f} / {summary['mean_abs_cte']:.3f} / "
                f"{summary['max_abs_cte']:.3f}"
            )
        print(f"| {paths} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()

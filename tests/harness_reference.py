"""Episodes of the classical agents as the sequential harness measured them before it was
batched, recorded bit for bit: the truth the batched harness must reproduce.

``python tests/harness_reference.py tests/data/harness_reference.json`` records them with
whatever harness and agents are installed; the file in the repository was recorded at commit
2c3bd07 (the one-episode-at-a-time loop and the pure-Python control laws).
"""

from __future__ import annotations

import hashlib
import json
import pathlib
import sys
from typing import Any

from agents.controllers.guidance import TricycleGuidance
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit

NOISE = {"start_noise": (0.2, 0.3)}

#: (name, agent factory, env id, env kwargs, episodes, seed): every law, every model, mazes,
#: random paths, the localization modes, an outer time limit and a slow robot that the env's
#: own limit stops before the outer one.
CASES: list[tuple[str, Any, str, dict[str, Any], int, int]] = [
    ("pure pursuit", PurePursuit, "mobile_envs/DiffDrive-SharpSegments-v0", NOISE, 10, 0),
    ("pure pursuit maze", PurePursuit, "mobile_envs/DiffDrive-Maze-v0", NOISE, 4, 3),
    (
        "textbook pure pursuit",
        lambda: PurePursuit(mode="textbook", speed=0.8),
        "mobile_envs/Bicycle-Segments-v0",
        NOISE,
        6,
        1,
    ),
    ("rpp bicycle maze", RegulatedPurePursuit, "mobile_envs/Bicycle-Maze-v0", NOISE, 4, 0),
    ("rpp random", RegulatedPurePursuit, "mobile_envs/DiffDrive-Random-v0", {}, 8, 5),
    (
        "rpp constant velocity",
        RegulatedPurePursuit,
        "mobile_envs/ConstantVelocity-Segments-v0",
        NOISE,
        6,
        0,
    ),
    ("rpp tricycle", RegulatedPurePursuit, "mobile_envs/Tricycle-SharpSegments-v0", NOISE, 6, 2),
    (
        "guidance",
        TricycleGuidance.for_comparison,
        "mobile_envs/Tricycle-ArcStraight-v0",
        NOISE,
        4,
        0,
    ),
    (
        "guidance random",
        TricycleGuidance.for_comparison,
        "mobile_envs/Tricycle-Random-v0",
        {},
        6,
        9,
    ),
    (
        "general guidance on O",
        lambda: TricycleGuidance.from_roots(0.8, 1.5, 0.7, speed=0.4, point="O"),
        "mobile_envs/Tricycle-Segments-v0",
        NOISE,
        4,
        0,
    ),
    (
        "general guidance on C",
        lambda: TricycleGuidance.from_roots(0.8, 1.5, 0.7, speed=0.4, point="C"),
        "mobile_envs/Tricycle-Lines-v0",
        NOISE,
        4,
        4,
    ),
    ("odometry", RegulatedPurePursuit, "mobile_envs/DiffDrive-Segments-Odometry-v0", NOISE, 4, 0),
    (
        "odometry and beacons",
        RegulatedPurePursuit,
        "mobile_envs/Bicycle-SharpSegments-OdometryBeacons-v0",
        NOISE,
        4,
        0,
    ),
    (
        "beacons guidance",
        TricycleGuidance.for_comparison,
        "mobile_envs/Tricycle-ArcStraight-Beacons-v0",
        {},
        3,
        0,
    ),
    (
        "randomized localization",
        PurePursuit,
        "mobile_envs/DiffDrive-Random-v0",
        {"localization": "randomized"},
        6,
        0,
    ),
    (
        "outer time limit",
        PurePursuit,
        "mobile_envs/DiffDrive-Segments-v0",
        {"max_episode_steps": 150, **NOISE},
        3,
        0,
    ),
    (
        "own limit before the outer one",
        lambda: PurePursuit(speed=0.1),
        "mobile_envs/DiffDrive-Lines-v0",
        {"max_episode_steps": 5000},
        3,
        0,
    ),
]


def trajectory_digest(trajectory: Any) -> str:
    return hashlib.sha256(trajectory.tobytes()).hexdigest()[:16]


def episode_values(result: Any) -> list[dict[str, Any]]:
    """Every recorded quantity of each episode, floats as exact hex strings."""
    return [
        {
            "completed": episode.completed,
            "mean_abs_cte": episode.mean_abs_cte.hex(),
            "max_abs_cte": episode.max_abs_cte.hex(),
            "rms_cte": episode.rms_cte.hex(),
            "time": episode.time.hex(),
            "time_to_goal": episode.time_to_goal.hex(),
            "collision": episode.collision,
            "off_track": episode.off_track,
            "steps": episode.steps,
            "trajectory": trajectory_digest(episode.trajectory),
            "path": episode.path.name,
        }
        for episode in result.episodes
    ]


def main(output: pathlib.Path) -> None:
    from agents.harness.evaluate import evaluate

    recorded = {}
    for name, agent, env_id, env_kwargs, episodes, seed in CASES:
        result = evaluate(agent, env_id, episodes, seed=seed, **env_kwargs)
        recorded[name] = episode_values(result)
        summary = result.summary
        print(f"{name}: completion {summary['completion_rate']:.2f}", flush=True)
    output.write_text(json.dumps(recorded, indent=1) + "\n")
    print(f"wrote {output}")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]))


def evaluate_one_at_a_time(
    agent: Any, env_id: str, episodes: int, seed: int = 0, **env_kwargs: Any
) -> list[dict[str, Any]]:
    """The harness as it was before it was batched (commit 2c3bd07): each episode in its own
    ``gym.make`` env from ``reset(seed=seed + i)``, the agent asked for one action a step.

    :param agent: an SB3 model, or a classical agent (bound to the env here)
    :return: each episode's metrics and trajectory
    """
    import gymnasium as gym
    import numpy as np

    env = gym.make(env_id, **env_kwargs)
    actor = agent.bind(env) if hasattr(agent, "bind") else agent
    records = []
    for index in range(episodes):
        observation, info = env.reset(seed=seed + index)
        poses, errors = [info["pose"]], []
        episode_start = True
        while True:
            action, _ = actor.predict(
                observation, episode_start=np.array([episode_start]), deterministic=True
            )
            observation, _, terminated, truncated, info = env.step(action)
            poses.append(info["pose"])
            errors.append(info["cross_track_error"])
            episode_start = False
            if terminated or truncated:
                break
        absolute = np.abs(errors)
        records.append(
            {
                "completed": bool(info["is_success"]),
                "mean_abs_cte": float(np.mean(absolute)),
                "max_abs_cte": float(np.max(absolute)),
                "rms_cte": float(np.sqrt(np.mean(absolute**2))),
                "steps": len(absolute),
                "collision": bool(info["collision"]),
                "off_track": bool(info["off_track"]),
                "trajectory": np.array(poses),
            }
        )
    env.close()
    return records

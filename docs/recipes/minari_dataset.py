"""Minari and mobile_envs: Minari's own DataCollector on a single env, through UniformInfo; a
dataset of regulated pure pursuit recorded on the batched vector env
(agents.harness.datasets, which `python train.py dataset` runs); both loaded back.
tests/test_datasets.py runs this file; docs/integrations.md shows it. Datasets go to
MINARI_DATASETS_PATH, else ~/.minari/datasets.

    python docs/recipes/minari_dataset.py
"""

import gymnasium as gym
import minari
import numpy as np
from minari import DataCollector

import mobile_envs  # noqa: F401  (registers the ids)
from agents.harness.datasets import record_dataset
from mobile_envs.envs.recording import UniformInfo

if __name__ == "__main__":
    # Minari's collector steps one env; UniformInfo gives it the same info keys every step.
    env = DataCollector(UniformInfo(gym.make("mobile_envs/DiffDrive-Lines-v0")), record_infos=True)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(500):
        _, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        if terminated or truncated:
            env.reset()
    random_driving = env.create_dataset(
        "mobile_envs/DiffDrive-Lines/random-v0",
        algorithm_name="uniform random actions",
        author="you",
        description="random actions on the course's lines",
    )

    # Any harness agent, 16 robots at once; episode i resets with seed i, as in compare.
    record_dataset(
        "regulated_pure_pursuit",
        "mobile_envs/DiffDrive-Random-v0",
        "mobile_envs/DiffDrive-Random/regulated-pure-pursuit-v0",
        episodes=32,
        robots=16,
    )
    dataset = minari.load_dataset("mobile_envs/DiffDrive-Random/regulated-pure-pursuit-v0")
    completed = [bool(episode.infos["completed"][-1]) for episode in dataset.iterate_episodes()]
    print(f"{dataset.total_episodes} episodes, {dataset.total_steps} steps, ", end="")
    print(f"{np.mean(completed):.0%} completed; {random_driving.total_episodes} random ones")
    env = dataset.recover_environment()  # the env the dataset was recorded on

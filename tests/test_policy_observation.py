"""A policy records the sensors it was trained with, and the harness evaluates it with them."""

import gymnasium as gym
import pytest

pytest.importorskip("stable_baselines3", reason="policies need the [train] extra")

from stable_baselines3 import PPO

from agents.harness.evaluate import evaluate
from agents.harness.policies import (
    check_spaces,
    load_policy,
    recorded_observation_settings,
)
from agents.training.runs import label_policy

REALISTIC = "mobile_envs/DiffDrive-Segments-Realistic-v0"
SENSORS = ["range", {"type": "command_history", "steps": 4}]


@pytest.fixture(scope="module")
def saved_policy(tmp_path_factory):
    """An untrained PPO policy that observes the last 4 commands, saved as train.py saves."""
    env = gym.make("mobile_envs/DiffDrive-Random-v0", sensors=SENSORS)
    model = PPO("MlpPolicy", env, n_steps=64, batch_size=64, seed=0, device="cpu")
    label_policy(
        model, {"env": "mobile_envs/DiffDrive-Random-v0", "env_kwargs": {"sensors": SENSORS}}
    )
    path = tmp_path_factory.mktemp("policy") / "policy.zip"
    model.save(path)
    env.close()
    return path


def test_the_saved_policy_records_its_sensors(saved_policy):
    policy = load_policy(saved_policy)
    assert recorded_observation_settings(policy) == {"sensors": SENSORS}
    assert policy.trained_on == "mobile_envs/DiffDrive-Random-v0"


def test_a_policy_fits_an_env_of_other_sensors_through_its_own(saved_policy):
    env = gym.make(REALISTIC)  # the range sensor alone: 8 observations fewer than the policy's
    policy = load_policy(saved_policy)
    assert env.observation_space.shape[0] + 8 == policy.observation_space.shape[0]
    check_spaces(policy, env, saved_policy)  # made with the policy's sensors, it fits
    load_policy(saved_policy, env)
    env.close()


def test_the_harness_evaluates_a_policy_with_its_own_sensors(saved_policy):
    policy = load_policy(saved_policy)
    # The realistic env as registered (the range sensor alone) and as made with the
    # policy's sensors give the same episodes, number for number.
    by_id = evaluate(policy, REALISTIC, 6, seed=11)
    explicit = evaluate(policy, gym.make(REALISTIC, sensors=SENSORS), 6, seed=11)
    assert [episode_bits(record) for record in by_id.episodes] == [
        episode_bits(record) for record in explicit.episodes
    ]


def episode_bits(record):
    return (
        record.completed,
        repr(record.mean_abs_cte),
        repr(record.time_to_goal),
        record.steps,
        record.trajectory.tobytes(),
    )


def test_an_env_that_cannot_be_made_again_is_refused_naming_the_sensors(saved_policy):
    policy = load_policy(saved_policy)
    wrapped = gym.Wrapper(gym.make(REALISTIC))  # a wrapper of its own: no batch, no rebuild
    with pytest.raises(ValueError, match="command_history"):
        evaluate(policy, wrapped, 1)
    wrapped.close()

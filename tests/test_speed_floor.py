"""agents.training.speed_floor: a deterministic speed never below the floor, sampled actions
and training untouched.

Truths: the rule written out element by element in Python (the brute-force table); the ideal
bicycle driving straight at a constant speed (x = v t, closed form); MlpPolicy itself for
everything the floor must not change (weights at construction, sampled actions).
"""

import math
import pathlib

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason="the policy needs the train extra")

import torch
from stable_baselines3 import PPO

import mobile_envs  # noqa: F401  (registers the ids)
from agents.harness.policies import load_policy, model_algorithm
from agents.training.runs import (
    check_algorithm_settings,
    hyperparameter_entry,
    policy_class,
)
from agents.training.speed_floor import SpeedFloorPolicy

ROOT = pathlib.Path(__file__).resolve().parents[1]
BICYCLE = "mobile_envs/Bicycle-Random-v0"
PREVIOUS_SPEED = 27  # observation_names[27] == "previous_action_0" (checked below)
NET = {"net_arch": [16, 16], "log_std_init": -1.5}
FLOOR = {"speed_floor": 0.05, "speed_action": 0, "previous_speed_observation": PREVIOUS_SPEED}


def f32(value):
    """``value`` as the float32 an action holds."""
    return float(np.float32(value))


def floor_by_hand(observations, actions, floor, action, previous):
    """The rule, one element at a time."""
    floored = actions.copy()
    for row in range(len(actions)):
        speed = actions[row, action]
        if abs(speed) < floor:
            floored[row, action] = -floor if observations[row, previous] < 0 else floor
    return floored


def models(env_id="mobile_envs/Bicycle-Lines-v0", seed=0):
    env = gym.make(env_id)
    plain = PPO("MlpPolicy", env, seed=seed, device="cpu", policy_kwargs=NET)
    geared = PPO(SpeedFloorPolicy, env, seed=seed, device="cpu", policy_kwargs={**NET, **FLOOR})
    return env, plain, geared


def test_floor_speed_follows_the_rule_element_by_element():
    _, _, model = models()
    policy = model.policy
    rng = np.random.default_rng(0)
    observations = rng.uniform(-1, 1, (4000, 45)).astype(np.float32)
    observations[::7, PREVIOUS_SPEED] = 0.0  # no previous command: forward
    actions = rng.uniform(-0.1, 0.1, (4000, 2)).astype(np.float32)
    actions[::5, 0] = 0.05  # on the floor, just under it, and both zeros
    actions[1::5, 0] = -0.04999
    actions[2::5, 0] = -0.0
    actions[3::5, 0] = 0.0
    got = policy.floor_speed(torch.as_tensor(observations), torch.as_tensor(actions)).numpy()
    expected = floor_by_hand(observations, actions, 0.05, 0, PREVIOUS_SPEED)
    np.testing.assert_array_equal(got, expected)
    assert 0 < np.mean(got[:, 0] != actions[:, 0]) < 1  # both cases occur
    np.testing.assert_array_equal(got[:, 1], actions[:, 1])  # the steering is never touched
    assert np.all(np.abs(got[:, 0]) >= 0.05)


def test_deterministic_actions_are_mlp_policys_floored_and_sampled_ones_are_mlp_policys():
    _, plain, geared = models()
    for name, tensor in plain.policy.state_dict().items():  # the same weights from one seed
        assert torch.equal(tensor, geared.policy.state_dict()[name]), name
    observations = np.random.default_rng(1).uniform(-1, 1, (500, 45)).astype(np.float32)
    mean, _ = plain.predict(observations, deterministic=True)
    floored, _ = geared.predict(observations, deterministic=True)
    np.testing.assert_array_equal(
        floored, floor_by_hand(observations, mean, 0.05, 0, PREVIOUS_SPEED)
    )
    torch.manual_seed(7)
    sampled, _ = plain.predict(observations, deterministic=False)
    torch.manual_seed(7)
    geared_sampled, _ = geared.predict(observations, deterministic=False)
    np.testing.assert_array_equal(geared_sampled, sampled)
    assert np.mean(np.abs(sampled[:, 0]) < 0.05) > 0.05  # the floor would have changed some


def drive(model, env, observation, steps, speed_bias):
    """Step ``env`` from ``observation`` with the model's deterministic action, its mean
    speed forced to ``speed_bias`` and its steering to 0 (the action layer zeroed, its bias
    set); the robot's true pose (x, y, heading) and the last observation."""
    with torch.no_grad():
        model.policy.action_net.weight.zero_()
        model.policy.action_net.bias.copy_(torch.tensor([speed_bias, 0.0]))
    for _ in range(steps):
        action, _ = model.predict(observation, deterministic=True)
        observation, *_ = env.step(action)
    return np.array(env.unwrapped.state), observation


def test_a_policy_whose_mean_speed_is_zero_stands_still_without_the_floor_and_moves_with_it():
    """The deadlock, constructed: a mean speed of exactly 0. The ideal bicycle on Lines
    starts at the origin facing +x; going straight at v for n steps of 0.1 s, x = v n 0.1
    (v the float32 action)."""
    env, plain, geared = models()
    assert env.unwrapped.observation_names[PREVIOUS_SPEED] == "previous_action_0"
    pose, _ = drive(plain, env, env.reset(seed=0)[0], 20, 0.0)
    np.testing.assert_array_equal(pose, [0.0, 0.0, 0.0])
    (x, y, heading), _ = drive(geared, env, env.reset(seed=0)[0], 20, 0.0)  # forward
    assert x == pytest.approx(20 * 0.1 * f32(0.05), abs=1e-12) and y == heading == 0.0
    # Backing up at 0.2 m/s for 5 steps, then a mean speed of 0: it keeps backing up, slowly.
    (x, _, _), observation = drive(geared, env, env.reset(seed=0)[0], 5, -0.2)
    assert x == pytest.approx(-5 * 0.1 * f32(0.2), abs=1e-12)
    (x, _, _), _ = drive(geared, env, observation, 10, 0.0)
    assert x == pytest.approx(-5 * 0.1 * f32(0.2) - 10 * 0.1 * f32(0.05), abs=1e-12)
    env.close()


def test_the_floor_survives_save_and_load(tmp_path):
    _, _, model = models()
    model.save(tmp_path / "geared.zip")
    assert model_algorithm(tmp_path / "geared.zip") == "ppo"
    loaded = load_policy(tmp_path / "geared.zip")
    assert isinstance(loaded.policy, SpeedFloorPolicy)
    assert (loaded.policy.speed_floor, loaded.policy.previous_speed_observation) == (0.05, 27)
    observations = np.random.default_rng(2).uniform(-1, 1, (200, 45)).astype(np.float32)
    np.testing.assert_array_equal(
        loaded.predict(observations, deterministic=True)[0],
        model.predict(observations, deterministic=True)[0],
    )
    model.policy.save(tmp_path / "policy.pth")  # the policy alone keeps it too
    alone = SpeedFloorPolicy.load(tmp_path / "policy.pth")
    assert alone.speed_floor == 0.05 and alone.previous_speed_observation == 27


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"speed_floor": -0.1}, "speed_floor must be a number in \\[0, 1\\]"),
        ({"speed_floor": 1.5}, "speed_floor must be a number in \\[0, 1\\]"),
        ({"speed_floor": math.nan}, "speed_floor"),
        ({"speed_floor": True}, "speed_floor"),
        ({"speed_action": 2}, "speed_action must be an action index in \\[0, 2\\)"),
        ({"previous_speed_observation": None}, "previous_speed_observation must be"),
        ({"previous_speed_observation": 45}, "previous_speed_observation must be .* \\[0, 45\\)"),
    ],
)
def test_settings_that_do_not_fit_the_spaces_are_refused_by_name(settings, message):
    env = gym.make("mobile_envs/Bicycle-Lines-v0")
    with pytest.raises(ValueError, match=message):
        PPO(SpeedFloorPolicy, env, device="cpu", policy_kwargs={**NET, **FLOOR, **settings})
    env.close()


def test_a_policy_is_an_alias_or_a_dotted_path_to_a_policy_class():
    assert policy_class("ppo", "MlpPolicy", "x") == "MlpPolicy"
    assert policy_class("ppo", "agents.training.speed_floor.SpeedFloorPolicy", "x") is (
        SpeedFloorPolicy
    )
    for policy, message in [
        ("MlpPolicyy", "policy must be one of .*MlpPolicy"),
        ("agents.training.nowhere.Policy", "does not import"),
        ("agents.training.speed_floor.check_speed_floor", "is not a PPO policy"),
        ("agents.training.speed_floor.SpeedFloorPolicy.x", "does not import"),
    ]:
        with pytest.raises(ValueError, match=f"ppo.yml: .*{message}"):
            check_algorithm_settings("ppo", {"policy": policy}, "ppo.yml")
    with pytest.raises(ValueError, match="is not a SAC policy"):
        policy_class("sac", "agents.training.speed_floor.SpeedFloorPolicy", "sac.yml")


def test_the_bicycle_recipe_floors_its_speed_command_by_the_previous_one():
    """The recipe's indices name what its comment says, in the env it trains on: action 0 is
    the speed in m/s (the ideal bicycle at action 0.05 covers 0.05 m a second), observation
    27 the previous speed command."""
    entry = hyperparameter_entry(ROOT / "hyperparams" / "ppo.yml", BICYCLE)
    assert policy_class("ppo", entry["policy"], "ppo.yml") is SpeedFloorPolicy
    kwargs = entry["policy_kwargs"]
    env = gym.make(BICYCLE, **entry["env_kwargs"])
    names = env.unwrapped.observation_names
    assert names[kwargs["previous_speed_observation"]] == "previous_action_0"
    assert kwargs["speed_action"] == 0 and kwargs["speed_floor"] == 0.05
    env.reset(seed=0)
    action = np.array([-0.3, 0.5], dtype=np.float32)
    observation, *_ = env.step(action)
    assert observation[kwargs["previous_speed_observation"]] == np.float32(-0.3)
    env.close()
    straight = gym.make("mobile_envs/Bicycle-Lines-v0")
    straight.reset(seed=0)
    for _ in range(10):
        straight.step(np.array([0.05, 0.0], dtype=np.float32))
    assert straight.unwrapped.state[0] == pytest.approx(10 * 0.1 * f32(0.05), abs=1e-12)
    straight.close()

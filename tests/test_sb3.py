"""The SB3 VecEnv adapter: same-step autoreset over the same robots as the vector env."""

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason="the adapter needs the train extra")

from mobile_envs.sb3 import PathFollowingSB3VecEnv
from mobile_envs.vector import PathFollowingVectorEnv


def test_adapter_matches_the_vector_env_with_same_step_autoreset():
    env_id, count = "mobile_envs/DiffDrive-Random-v0", 5
    adapter = PathFollowingSB3VecEnv(env_id, count, seed=11, max_episode_steps=20)
    native = gym.make_vec(env_id, num_envs=count, max_episode_steps=20)
    assert isinstance(native, PathFollowingVectorEnv)
    observations = adapter.reset()
    native_obs, _ = native.reset(seed=11)
    np.testing.assert_array_equal(observations, native_obs)
    # Slow actions keep every robot on track, so all episodes end together at the time limit
    # and the two autoreset modes stay in step: after an ending, the native env spends one
    # extra step on the reset that the adapter did at once.
    rng = np.random.default_rng(0)
    pending = False
    endings = 0
    for _ in range(70):
        actions = rng.uniform(0.0, 0.3, (count, 2)).astype(np.float32)
        observations, rewards, dones, infos = adapter.step(actions)
        assert dones.all() or not dones.any()
        if pending:
            native.step(actions)  # the native env's next-step reset
        native_obs, native_rewards, terminated, truncated, _ = native.step(actions)
        live = ~dones
        np.testing.assert_array_equal(observations[live], native_obs[live])
        np.testing.assert_array_equal(rewards, native_rewards.astype(np.float32))
        np.testing.assert_array_equal(dones, terminated | truncated)
        for index in np.flatnonzero(dones):
            np.testing.assert_array_equal(infos[index]["terminal_observation"], native_obs[index])
            assert infos[index]["TimeLimit.truncated"] == bool(truncated[index])
            assert "mean_abs_cte" in infos[index] and "is_success" in infos[index]
        pending = dones.all()
        endings += dones.sum()
    assert endings == 3 * count  # three time limits of 20 steps in 70

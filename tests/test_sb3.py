"""The SB3 VecEnv adapter: same-step autoreset over the same robots as the vector env."""

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason="the adapter needs the train extra")

from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv


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


def _twin_batches(env_id: str, count: int, seed: int, steps: int):
    """The adapter and SB3's own DummyVecEnv over ``count`` single envs, seeded alike and
    stepped with the same random actions."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    adapter = PathFollowingSB3VecEnv(env_id, count, seed=seed, max_episode_steps=15)
    dummy = DummyVecEnv([lambda: gym.make(env_id, max_episode_steps=15) for _ in range(count)])
    dummy.seed(seed)
    adapter.reset()
    dummy.reset()
    rng = np.random.default_rng(3)
    for _ in range(steps):
        actions = rng.uniform(-1.0, 1.0, (count, 2)).astype(np.float32)
        adapter.step(actions)
        dummy.step(actions)
    return adapter, dummy


def test_get_attr_reads_each_robot_as_dummy_vec_env_reads_each_env():
    env_id = "mobile_envs/DiffDrive-Segments-v0"
    adapter, dummy = _twin_batches(env_id, count=4, seed=21, steps=23)  # past one time limit
    for indices in (None, [2], [0, 3], 1):
        for name in ("pose", "state"):
            for ours, theirs in zip(
                adapter.get_attr(name, indices), dummy.get_attr(name, indices), strict=True
            ):
                np.testing.assert_array_equal(ours, theirs)
        assert adapter.get_attr("elapsed_steps", indices) == dummy.get_attr(
            "elapsed_steps", indices
        )
        ours_paths = adapter.get_attr("path", indices)
        their_paths = dummy.get_attr("path", indices)
        for ours, theirs in zip(ours_paths, their_paths, strict=True):
            np.testing.assert_array_equal(ours.points, theirs.points)
        assert adapter.get_attr("observation_space", indices) == dummy.get_attr(
            "observation_space", indices
        )
        assert adapter.get_attr("dt", indices) == dummy.get_attr("dt", indices)
    # The robots' generators are in the same state as the single envs' after the same draws.
    for ours, theirs in zip(
        adapter.get_attr("np_random"), dummy.get_attr("np_random"), strict=True
    ):
        assert ours.bit_generator.state == theirs.bit_generator.state


def test_get_attr_finds_the_adapters_own_attributes_and_refuses_unknown_ones():
    adapter = PathFollowingSB3VecEnv("mobile_envs/Bicycle-Lines-v0", 3)
    assert adapter.get_attr("env_id") == ["mobile_envs/Bicycle-Lines-v0"] * 3
    assert adapter.get_attr("env_id", [1]) == ["mobile_envs/Bicycle-Lines-v0"]
    assert adapter.has_attr("env_id") and adapter.has_attr("dt")
    assert not adapter.has_attr("no_such_attribute")
    with pytest.raises(AttributeError, match="no_such_attribute"):
        adapter.get_attr("no_such_attribute")


def test_set_attr_honours_indices():
    adapter = PathFollowingSB3VecEnv("mobile_envs/DiffDrive-Lines-v0", 4, seed=0)
    adapter.reset()
    before = adapter.get_attr("np_random")
    generator = np.random.default_rng(99)
    adapter.set_attr("np_random", generator, indices=[1, 3])
    after = adapter.get_attr("np_random")
    assert after[1] is generator and after[3] is generator
    assert after[0] is before[0] and after[2] is before[2]
    # A shared setting cannot differ between robots: refused for a subset, set for all.
    with pytest.raises(ValueError, match="shared by all 4 robots"):
        adapter.set_attr("dt", 0.05, indices=[0])
    adapter.set_attr("custom_flag", 7)
    assert adapter.get_attr("custom_flag", [2]) == [7]
    with pytest.raises(AttributeError, match="read-only"):
        adapter.set_attr("pose", np.zeros(3), indices=[0])


# ---------------------------------------------------------------- method by method, as DummyVecEnv


def _twins(env_id: str, count: int, seed: int, **kwargs):
    """The adapter and SB3's DummyVecEnv over ``count`` single envs made with the same
    settings (the env's own ``step_limit``, so both report the episode metrics), seeded alike."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    adapter = PathFollowingSB3VecEnv(env_id, count, seed=seed, **kwargs)
    dummy = DummyVecEnv([lambda: gym.make(env_id, **kwargs) for _ in range(count)])
    dummy.seed(seed)
    return adapter, dummy


def assert_same_info(ours: dict, theirs: dict) -> None:
    """The same keys, and equal values (arrays element for element), as DummyVecEnv gives."""
    assert set(ours) == set(theirs), set(ours) ^ set(theirs)
    for key, value in theirs.items():
        np.testing.assert_array_equal(np.asarray(ours[key]), np.asarray(value), err_msg=key)


def step_both(adapter, dummy, actions):
    ours = adapter.step(actions)
    theirs = dummy.step(actions)
    for our_array, their_array in zip(ours[:3], theirs[:3], strict=True):
        np.testing.assert_array_equal(our_array, their_array)
    for our_info, their_info in zip(ours[3], theirs[3], strict=True):
        assert_same_info(our_info, their_info)
    for our_info, their_info in zip(adapter.reset_infos, dummy.reset_infos, strict=True):
        assert_same_info(our_info, their_info)
    return ours


@pytest.mark.parametrize("localization", ["exact", "odometry+beacons"])
def test_step_infos_and_reset_infos_are_dummy_vec_env_s(localization):
    """Every robot's info holds the single env's keys each step, its episode metrics (the
    localization's among them), TimeLimit.truncated and terminal_observation where its episode
    ended; reset_infos hold each robot's last reset info."""
    adapter, dummy = _twins(
        "mobile_envs/DiffDrive-Segments-v0", 3, 5, step_limit=12, localization=localization
    )
    np.testing.assert_array_equal(adapter.reset(), dummy.reset())
    for ours, theirs in zip(adapter.reset_infos, dummy.reset_infos, strict=True):
        assert_same_info(ours, theirs)
    rng = np.random.default_rng(8)
    endings = 0
    for _ in range(30):
        _, _, dones, _ = step_both(adapter, dummy, rng.uniform(-1, 1, (3, 2)).astype(np.float32))
        endings += dones.sum()
    assert endings >= 6  # time limits and failures among them


def test_set_options_apply_at_the_next_reset_as_dummy_vec_env_applies_them():
    from mobile_envs.world.paths import Path

    adapter, dummy = _twins("mobile_envs/DiffDrive-Segments-v0", 3, 2, step_limit=10)
    path = Path([[0.0, 0.0], [4.0, 3.0]])
    for options in (
        {"path": path, "start_pose": (0.0, 0.0, 0.9)},
        [{"path": path}, {}, {"start_pose": (1.0, 1.0, -0.3)}],  # robot by robot
    ):
        adapter.set_options(options)
        dummy.set_options(options)
        np.testing.assert_array_equal(adapter.reset(), dummy.reset())
        for ours, theirs in zip(adapter.reset_infos, dummy.reset_infos, strict=True):
            assert_same_info(ours, theirs)
        for ours, theirs in zip(adapter.get_attr("path"), dummy.get_attr("path"), strict=True):
            np.testing.assert_array_equal(ours.points, theirs.points)
        rng = np.random.default_rng(1)
        for _ in range(12):  # past the limit: the options held for that reset only
            step_both(adapter, dummy, rng.uniform(-1, 1, (3, 2)).astype(np.float32))
    assert adapter.get_attr("path")[0].points.tolist() != path.points.tolist()


def test_env_method_reset_restarts_only_the_indexed_robots():
    adapter, dummy = _twins("mobile_envs/Bicycle-Lines-v0", 4, 9, step_limit=20)
    adapter.reset()
    dummy.reset()
    rng = np.random.default_rng(2)
    for _ in range(5):
        step_both(adapter, dummy, rng.uniform(-1, 1, (4, 2)).astype(np.float32))
    resets = (([0], {}), ([1, 3], {"seed": 77}), (2, {"options": {"path": "horizontal_line"}}))
    for indices, kwargs in resets:
        ours = adapter.env_method("reset", indices=indices, **kwargs)
        theirs = dummy.env_method("reset", indices=indices, **kwargs)
        assert len(ours) == len(theirs)
        for (our_obs, our_info), (their_obs, their_info) in zip(ours, theirs, strict=True):
            np.testing.assert_array_equal(our_obs, their_obs)
            assert_same_info(our_info, their_info)
        assert adapter.get_attr("elapsed_steps") == dummy.get_attr("elapsed_steps")
        for _ in range(3):  # the other robots went on where they were
            step_both(adapter, dummy, rng.uniform(-1, 1, (4, 2)).astype(np.float32))


def test_vec_monitor_reads_the_localization_s_episode_metrics():
    from stable_baselines3.common.vec_env import VecMonitor

    adapter, dummy = _twins(
        "mobile_envs/DiffDrive-Lines-v0", 2, 0, step_limit=8, localization="odometry"
    )
    keywords = ("mean_localization_error", "max_localization_error", "is_success")
    ours, theirs = (
        VecMonitor(adapter, info_keywords=keywords),
        VecMonitor(dummy, info_keywords=keywords),
    )
    ours.reset()
    theirs.reset()
    episodes = 0
    for _ in range(20):
        actions = np.full((2, 2), 0.2, np.float32)
        _, _, dones, our_infos = ours.step(actions)
        _, _, _, their_infos = theirs.step(actions)
        for index in np.flatnonzero(dones):
            ours_episode, theirs_episode = (
                our_infos[index]["episode"],
                their_infos[index]["episode"],
            )
            for key in ("r", "l", *keywords):
                assert ours_episode[key] == theirs_episode[key], key
            assert ours_episode["mean_localization_error"] > 0.0
            episodes += 1
    assert episodes == 4

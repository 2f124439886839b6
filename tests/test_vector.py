"""The batched vector env equals N single envs, bit for bit, through resets and autoresets."""

import gymnasium as gym
import numpy as np
import pytest

import mobile_envs  # noqa: F401  (registers the ids)
from mobile_envs.env import PathFollowingEnv
from mobile_envs.interface import EPISODE_INFO_KEYS
from mobile_envs.vector import PathFollowingVectorEnv

STEP_KEYS = ("cross_track_error", "heading_error", "progress", "is_success", "collision", "pose")


def run_both(env_id, num_envs, steps, seed, max_episode_steps=None, **kwargs):
    """Drive a vector env and N single envs with the same actions; yield both results."""
    extra = {} if max_episode_steps is None else {"max_episode_steps": max_episode_steps}
    vector = gym.make_vec(env_id, num_envs=num_envs, **extra, **kwargs)
    # make_vec hands max_episode_steps to the vector env; the single env's own name for it
    # is step_limit (gym.make would add a TimeLimit wrapper): build the env itself.
    single_extra = {} if max_episode_steps is None else {"step_limit": max_episode_steps}
    spec_kwargs = {**gym.spec(env_id).kwargs, **single_extra, **kwargs}
    singles = [PathFollowingEnv(**spec_kwargs) for _ in range(num_envs)]
    observations, _ = vector.reset(seed=seed)
    single_obs = [env.reset(seed=seed + index)[0] for index, env in enumerate(singles)]
    np.testing.assert_array_equal(observations, np.array(single_obs))
    rng = np.random.default_rng(seed)
    needs_reset = np.zeros(num_envs, dtype=bool)
    for _ in range(steps):
        actions = rng.uniform(-1, 1, vector.action_space.shape).astype(np.float32)
        actions[:, 0] = np.abs(actions[:, 0])  # mostly forward, so episodes end by the goal too
        vector_result = vector.step(actions)
        single_results = []
        for index, env in enumerate(singles):
            if needs_reset[index]:
                observation, info = env.reset()
                single_results.append((observation, 0.0, False, False, info))
            else:
                single_results.append(env.step(actions[index]))
        yield vector_result, single_results
        needs_reset = vector_result[2] | vector_result[3]


@pytest.mark.parametrize(
    ("env_id", "max_episode_steps"),
    [
        ("mobile_envs/DiffDrive-Segments-v0", 25),
        ("mobile_envs/Bicycle-Random-v0", 40),
        ("mobile_envs/Tricycle-Maze-v0", 30),
        ("mobile_envs/ConstantVelocity-Lines-v0", None),
    ],
)
def test_vector_env_equals_single_envs_bit_for_bit(env_id, max_episode_steps):
    ended_episodes = 0
    for vector_result, single_results in run_both(env_id, 6, 120, 3, max_episode_steps):
        observations, rewards, terminated, truncated, infos = vector_result
        for index, (obs, reward, term, trunc, info) in enumerate(single_results):
            np.testing.assert_array_equal(observations[index], obs)
            assert rewards[index] == reward
            assert (terminated[index], truncated[index]) == (term, trunc)
            for key in STEP_KEYS:
                np.testing.assert_array_equal(infos[key][index], info[key])
            ended = term or trunc
            for key in EPISODE_INFO_KEYS:
                assert infos.get(f"_{key}", np.zeros(6, bool))[index] == ended
                if ended:
                    assert infos[key][index] == info[key]
            ended_episodes += ended
    assert ended_episodes >= 6  # autoreset was exercised


def test_make_vec_returns_the_native_vector_env():
    envs = gym.make_vec("mobile_envs/DiffDrive-Segments-v0", num_envs=4)
    assert isinstance(envs, PathFollowingVectorEnv)
    assert envs.observation_space.shape == (4, *envs.single_observation_space.shape)


def test_per_env_seeds_and_reproducibility():
    envs = PathFollowingVectorEnv(3, "diff_drive", "training", start_noise=(0.2, 0.3))
    first, _ = envs.reset(seed=[7, 8, 9])
    paths = [path.points.copy() for path in envs.paths]
    again, _ = envs.reset(seed=[7, 8, 9])
    np.testing.assert_array_equal(first, again)
    single = gym.make("mobile_envs/DiffDrive-Random-v0").unwrapped
    observation, _ = single.reset(seed=8)
    np.testing.assert_array_equal(first[1], observation)
    np.testing.assert_array_equal(paths[1], single.path.points)
    with pytest.raises(ValueError, match="2 seeds for 3"):
        envs.reset(seed=[1, 2])


def test_a_long_run_stays_finite_with_wrapped_headings():
    envs = PathFollowingVectorEnv(1000, "bicycle", "random", start_noise=(0.2, 0.3))
    envs.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(1000):  # 10^6 robot-steps
        observations, rewards, _, _, infos = envs.step(
            rng.uniform(-1, 1, envs.action_space.shape).astype(np.float32)
        )
        assert np.isfinite(rewards).all() and np.isfinite(observations).all()
        headings = infos["pose"][:, 2]
        assert ((headings > -np.pi) & (headings <= np.pi)).all()
    assert np.abs(observations).max() <= 1.0


def test_bad_arguments_and_actions_raise():
    with pytest.raises(ValueError, match="num_envs"):
        PathFollowingVectorEnv(0)
    with pytest.raises(ValueError, match=r"unknown environment arguments \['wheelbase'\]"):
        PathFollowingVectorEnv(2, "bicycle", wheelbase=2.0)
    with pytest.raises(ValueError, match="goal_radius"):
        PathFollowingVectorEnv(2, goal_radius=-1.0)
    envs = PathFollowingVectorEnv(2)
    envs.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        envs.step(np.zeros((3, 2), np.float32))
    with pytest.raises(ValueError, match="finite"):
        envs.step(np.full((2, 2), np.nan, np.float32))


def test_robots_on_one_path_share_a_table_row_and_rows_are_recycled():
    course = PathFollowingVectorEnv(64, "diff_drive", "segments")
    course.reset(seed=0)
    assert len(course.core.table) == 1 and (course.core.path_row == 0).all()
    random_paths = PathFollowingVectorEnv(8, "diff_drive", "random")
    for seed in range(5):  # 40 distinct paths drawn, never more than 8 rows
        random_paths.reset(seed=seed)
        rows = random_paths.core.path_row
        assert len(random_paths.core.table) <= 8 and len(set(rows.tolist())) == 8
        for robot, path in enumerate(random_paths.paths):
            assert random_paths.core.table.paths[rows[robot]] is path


def _same_step_pair(env_id, count, **kwargs):
    native = gym.make_vec(env_id, num_envs=count, autoreset_mode="SameStep", **kwargs)
    spec_kwargs = {**gym.spec(env_id).kwargs, **kwargs}
    reference = gym.vector.SyncVectorEnv(
        [lambda: PathFollowingEnv(**spec_kwargs) for _ in range(count)],
        autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
    )
    return native, reference


def _assert_infos_equal(native, reference):
    assert set(native) == set(reference)
    for key, value in reference.items():
        if isinstance(value, dict):
            _assert_infos_equal(native[key], value)
        elif value.dtype == object:  # final_obs: None where no episode ended
            assert native[key].dtype == object and len(native[key]) == len(value)
            for got, want in zip(native[key], value, strict=True):
                assert (got is None) == (want is None)
                if want is not None:
                    np.testing.assert_array_equal(got, want, err_msg=key)
        else:
            np.testing.assert_array_equal(native[key], value, err_msg=key)


@pytest.mark.parametrize(
    "env_id", ["mobile_envs/DiffDrive-Random-v0", "mobile_envs/Bicycle-Maze-v0"]
)
def test_same_step_autoreset_equals_gymnasiums_sync_vector_env_bit_for_bit(env_id):
    """Independent truth: Gymnasium's own SAME_STEP autoreset over single envs."""
    native, reference = _same_step_pair(env_id, 4, start_noise=(0.3, 0.4))
    assert native.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    observations, infos = native.reset(seed=5)
    expected, expected_infos = reference.reset(seed=5)
    np.testing.assert_array_equal(observations, expected)
    _assert_infos_equal(infos, expected_infos)
    rng = np.random.default_rng(1)
    ended = 0
    for _ in range(400):
        actions = rng.uniform(-1, 1, (4, 2)).astype(np.float32)
        results = native.step(actions)
        expected_results = reference.step(actions)
        for value, expected_value in zip(results[:4], expected_results[:4], strict=True):
            np.testing.assert_array_equal(value, expected_value)
        _assert_infos_equal(results[4], expected_results[4])
        ended += int((results[2] | results[3]).sum())
    assert ended > 0  # the autoreset itself was compared


def test_autoreset_mode_is_validated_and_reported():
    native = gym.make_vec("mobile_envs/DiffDrive-Lines-v0", num_envs=2)
    assert native.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    with pytest.raises(ValueError, match="autoreset_mode"):
        gym.make_vec("mobile_envs/DiffDrive-Lines-v0", num_envs=2, autoreset_mode="sometimes")

"""The batched vector env equals N single envs, bit for bit, through resets and autoresets."""

import math

import gymnasium as gym
import numpy as np
import pytest

import mobile_envs  # noqa: F401  (registers the ids)
from mobile_envs.envs.interface import EPISODE_INFO_KEYS, LOCALIZATION_EPISODE_KEYS
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.sim.config import available_threads

STEP_KEYS = ("cross_track_error", "heading_error", "progress", "is_success", "collision", "pose")


def run_both(env_id, num_envs, steps, seed, max_episode_steps=None, vector_kwargs=None, **kwargs):
    """Drive a vector env and N single envs with the same actions; yield both results.

    :param vector_kwargs: settings for the vector env alone
    """
    extra = {} if max_episode_steps is None else {"max_episode_steps": max_episode_steps}
    vector = gym.make_vec(env_id, num_envs=num_envs, **extra, **(vector_kwargs or {}), **kwargs)
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


# ---------------------------------------------------------------------------------------------
# Partial resets (reset_mask), AutoresetMode.DISABLED, seeds and bad input (issue 13)

AutoresetMode = gym.vector.AutoresetMode


def _pair(env_id, count, mode, max_episode_steps, **kwargs):
    native = gym.make_vec(
        env_id,
        num_envs=count,
        autoreset_mode=mode,
        max_episode_steps=max_episode_steps,
        **kwargs,
    )
    spec_kwargs = {**gym.spec(env_id).kwargs, **kwargs, "step_limit": max_episode_steps}
    reference = gym.vector.SyncVectorEnv(
        [lambda: PathFollowingEnv(**spec_kwargs) for _ in range(count)], autoreset_mode=mode
    )
    return native, reference


@pytest.mark.parametrize(
    ("env_id", "mode"),
    [
        ("mobile_envs/DiffDrive-Random-v0", AutoresetMode.DISABLED),
        ("mobile_envs/Tricycle-Maze-v0", AutoresetMode.DISABLED),
        ("mobile_envs/Bicycle-Random-v0", AutoresetMode.NEXT_STEP),
        ("mobile_envs/DiffDrive-Maze-v0", AutoresetMode.SAME_STEP),
    ],
)
def test_partial_resets_equal_gymnasiums_sync_vector_env_bit_for_bit(env_id, mode):
    """Independent truth: Gymnasium's SyncVectorEnv over single envs, in the same autoreset
    mode, given the same reset masks, seeds and options. In DISABLED mode the driver restarts
    the robots whose episode ended; in every mode it also restarts random running robots,
    sometimes with their own seeds, a start pose or a path."""
    count = 4
    native, reference = _pair(env_id, count, mode, 25, start_noise=(0.3, 0.4))
    assert native.metadata["autoreset_mode"] == mode
    observations, infos = native.reset(seed=5)
    expected, expected_infos = reference.reset(seed=5)
    np.testing.assert_array_equal(observations, expected)
    _assert_infos_equal(infos, expected_infos)
    rng = np.random.default_rng(2)
    partial_resets = restarted_ended = 0
    for step in range(300):
        actions = rng.uniform(-1, 1, (count, native.single_action_space.shape[0]))
        results = native.step(actions.astype(np.float32))
        expected_results = reference.step(actions.astype(np.float32))
        for value, expected_value in zip(results[:4], expected_results[:4], strict=True):
            np.testing.assert_array_equal(value, expected_value)
        _assert_infos_equal(results[4], expected_results[4])
        ended = results[2] | results[3]
        mask = ended.copy() if mode == AutoresetMode.DISABLED else np.zeros(count, bool)
        if step % 7 == 3:
            mask[rng.integers(count)] = True  # a running robot restarts too
        if not mask.any():
            continue
        seeds = [
            int(seed) if restart else None
            for seed, restart in zip(rng.integers(0, 99, count), mask, strict=True)
        ]
        options = [{}, {"start_pose": (0.5, -0.2, 1.0)}, {"path": "segments"}][step % 3]
        # Gymnasium's SyncVectorEnv pops reset_mask from the dict it is given: one dict each.
        observations, infos = native.reset(
            seed=seeds if step % 2 else None, options={"reset_mask": mask.copy(), **options}
        )
        expected, expected_infos = reference.reset(
            seed=seeds if step % 2 else None, options={"reset_mask": mask.copy(), **options}
        )
        np.testing.assert_array_equal(observations, expected)
        _assert_infos_equal(infos, expected_infos)
        partial_resets += 1
        restarted_ended += int(ended.sum())
    assert partial_resets > 20
    assert mode != AutoresetMode.DISABLED or restarted_ended > 4


def test_disabled_mode_refuses_to_step_a_robot_whose_episode_ended():
    envs = PathFollowingVectorEnv(3, "diff_drive", "segments", autoreset_mode="Disabled")
    envs.reset(seed=0)
    actions = np.array([[1.0, 1.0], [1.0, -1.0], [1.0, 1.0]], np.float32)  # robot 1 spins
    for _ in range(200):
        *_, terminated, truncated, _ = envs.step(actions)
        ended = terminated | truncated
        if ended.any():
            break
    assert ended.any() and not ended.all()
    poses = envs.poses
    with pytest.raises(RuntimeError, match="reset_mask"):
        envs.step(actions)
    np.testing.assert_array_equal(envs.poses, poses)  # the refused step moved no robot
    _, infos = envs.reset(options={"reset_mask": ended})
    assert (infos["_pose"] == ended).all() and (envs.elapsed_steps[ended] == 0).all()
    assert (envs.elapsed_steps[~ended] > 0).all()  # the others kept their episodes
    envs.step(actions)


def test_reset_mask_is_validated_and_leaves_the_callers_options_alone():
    envs = PathFollowingVectorEnv(3)
    with pytest.raises(RuntimeError, match="without a reset_mask first"):
        envs.reset(options={"reset_mask": np.array([True, False, False])})
    envs.reset(seed=0)
    for bad in (
        np.array([True, False]),
        np.array([1, 0, 1]),
        np.array([False, False, False]),
        "yes",
        [[True], [False, True]],
    ):
        with pytest.raises(ValueError, match="reset_mask"):
            envs.reset(options={"reset_mask": bad})
    options = {"reset_mask": np.array([False, True, False]), "start_pose": (1.0, 2.0, 0.5)}
    _, infos = envs.reset(options=options)
    assert set(options) == {"reset_mask", "start_pose"}
    np.testing.assert_array_equal(envs.poses[1], [1.0, 2.0, 0.5])
    np.testing.assert_array_equal(infos["_pose"], [False, True, False])
    np.testing.assert_array_equal(infos["pose"][[0, 2]], np.zeros((2, 3)))


@pytest.mark.parametrize("bad", [1.5, -1, True, "7", [1, 2, 2.5], [0, -3, 1], [0, True, 1], 7j])
def test_seeds_must_be_non_negative_integers(bad):
    envs = PathFollowingVectorEnv(3)
    with pytest.raises(ValueError, match="seed"):
        envs.reset(seed=bad)


def test_numpy_integer_seeds_seed_like_python_ints():
    first = PathFollowingVectorEnv(3, "bicycle", "random")
    second = PathFollowingVectorEnv(3, "bicycle", "random")
    np.testing.assert_array_equal(first.reset(seed=np.int64(4))[0], second.reset(seed=[4, 5, 6])[0])
    np.testing.assert_array_equal(
        first.reset(seed=[np.uint8(9), None, np.int32(2)])[0],
        second.reset(seed=[9, None, 2])[0],
    )


@pytest.mark.parametrize("bad", [math.inf, 10**25, math.nan, 0, -3, 2.5, True, "20"])
def test_max_episode_steps_is_validated_naming_it(bad):
    with pytest.raises(ValueError, match="max_episode_steps"):
        gym.make_vec("mobile_envs/DiffDrive-Lines-v0", num_envs=2, max_episode_steps=bad)


@pytest.mark.parametrize("bad", [math.inf, 10**25, math.nan, 0, True, "4"])
def test_num_envs_is_validated_naming_it(bad):
    with pytest.raises(ValueError, match="num_envs"):
        PathFollowingVectorEnv(bad)


@pytest.mark.parametrize("dtype", [np.float16, np.longdouble, np.int8, np.uint64, ">f4"])
def test_every_real_action_dtype_steps_like_the_float64_value_it_holds(dtype):
    values = np.array([[1, 0], [0, 1], [1, 1]]) if np.dtype(dtype).kind in "iu" else None
    if values is None:
        values = np.array([[0.5, -0.25], [0.75, 0.125], [-1.0, 1.0]])
    first, second = PathFollowingVectorEnv(3), PathFollowingVectorEnv(3)
    first.reset(seed=0)
    second.reset(seed=0)
    for _ in range(3):
        got = first.step(values.astype(dtype))
        want = second.step(values.astype(np.float64))
        for value, expected in zip(got[:4], want[:4], strict=True):
            np.testing.assert_array_equal(value, expected)


@pytest.mark.skipif(available_threads() < 2, reason="numba has one thread here (NUMBA_NUM_THREADS)")
@pytest.mark.parametrize(
    "env_id",
    [
        "mobile_envs/DiffDrive-Segments-v0",
        "mobile_envs/Bicycle-Maze-v0",
        "mobile_envs/DiffDrive-Segments-OdometryBeacons-v0",
        "mobile_envs/Tricycle-Maze-Odometry-v0",
    ],
)
def test_vector_env_on_two_threads_equals_single_envs_bit_for_bit(env_id):
    # The vector env splits its 7 robots over two threads; each single env runs on one. The
    # single env's episode metrics are plain Python arithmetic, the vector env's a kernel.
    localized = "Odometry" in env_id or "Beacons" in env_id
    episode_keys = EPISODE_INFO_KEYS + (LOCALIZATION_EPISODE_KEYS if localized else ())
    ended_episodes = 0
    assert gym.make_vec(env_id, num_envs=7, num_threads=2).core.num_threads == 2
    runs = run_both(env_id, 7, 90, 5, 30, vector_kwargs={"num_threads": 2})
    for vector_result, single_results in runs:
        observations, rewards, terminated, truncated, infos = vector_result
        for index, (obs, reward, term, trunc, info) in enumerate(single_results):
            assert observations[index].tobytes() == obs.tobytes()
            assert rewards[index] == reward
            assert (terminated[index], truncated[index]) == (term, trunc)
            for key in STEP_KEYS:
                assert np.asarray(infos[key][index]).tobytes() == np.asarray(info[key]).tobytes()
            if term or trunc:
                for key in episode_keys:
                    assert infos[f"_{key}"][index]
                    assert infos[key][index] == info[key]
                ended_episodes += 1
    assert ended_episodes >= 7

"""PathFollowingEnv: API conformance, scripted episodes, seeding and bad input."""

import math
import os
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import mobile_envs
from mobile_envs.env import PathFollowingEnv
from mobile_envs.kinematics import DifferentialDrive
from mobile_envs.paths import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

ALL_IDS = sorted(env_id for env_id in gym.registry if env_id.startswith("mobile_envs/"))


def test_every_model_and_path_set_is_registered():
    expected = {
        f"mobile_envs/{model}-{paths}-v0"
        for model in mobile_envs.MODEL_IDS
        for paths in mobile_envs.PATH_SET_IDS
    }
    expected |= {"mobile_envs/Tricycle-ArcStraight-v0", "mobile_envs/PathFollowing-v0"}
    assert expected == set(ALL_IDS)


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_gymnasium_and_sb3_checkers_pass(env_id):
    sb3_checker = pytest.importorskip(
        "stable_baselines3.common.env_checker", reason="SB3's checker needs the train extra"
    )
    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a checker warning is a failure here
        gym_check_env(env.unwrapped, skip_render_check=True)
        sb3_checker.check_env(env.unwrapped, warn=True)
    env.close()


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_observations_stay_inside_the_box_under_random_actions(env_id):
    env = gym.make(env_id)
    env.action_space.seed(0)
    observation, _ = env.reset(seed=0)
    assert len(env.unwrapped.observation_names) == env.observation_space.shape[0]
    for _ in range(200):
        assert env.observation_space.contains(observation)
        observation, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        assert isinstance(reward, float) and math.isfinite(reward)
        if terminated or truncated:
            observation, _ = env.reset()
    env.close()


def rollout(env, seed, steps=60):
    env.action_space.seed(seed)
    observation, _ = env.reset(seed=seed)
    observations, rewards = [observation], []
    for _ in range(steps):
        observation, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        observations.append(observation)
        rewards.append(reward)
        if terminated or truncated:
            observations.append(env.reset()[0])
    return np.array(observations), np.array(rewards)


def test_same_seed_same_trajectory_bit_for_bit():
    first = rollout(gym.make("mobile_envs/Bicycle-Random-v0"), seed=5)
    second = rollout(gym.make("mobile_envs/Bicycle-Random-v0"), seed=5)
    np.testing.assert_array_equal(first[0], second[0])
    np.testing.assert_array_equal(first[1], second[1])


def test_different_seeds_draw_different_random_paths():
    env = gym.make("mobile_envs/DiffDrive-Random-v0")
    env.reset(seed=1)
    first = env.unwrapped.path.points.copy()
    env.reset(seed=2)
    assert first.shape != env.unwrapped.path.points.shape or not np.array_equal(
        first, env.unwrapped.path.points
    )


def drive(env, action, max_steps=10_000):
    """Hold one action until the episode ends; return the step count and the last info."""
    for steps in range(1, max_steps + 1):
        _, _, terminated, truncated, info = env.step(np.asarray(action, np.float32))
        if terminated or truncated:
            return steps, terminated, truncated, info
    raise AssertionError("episode did not end")


def test_driving_straight_along_the_horizontal_line_reaches_the_goal_exactly_on_track():
    env = PathFollowingEnv("diff_drive", "horizontal_line")
    env.reset(seed=0)
    # Equal wheel speeds: 0.7 of 20 rad/s * 0.05 m = 0.7 m/s straight ahead along y = 6.
    steps, terminated, truncated, info = drive(env, [0.7, 0.7])
    assert terminated and not truncated and info["is_success"] and info["completed"]
    assert info["max_abs_cte"] == 0.0 and info["cross_track_error"] == 0.0
    # 10 m at 0.07 m a step: the goal circle of 0.1 m is entered at step ceil(9.9 / 0.07).
    assert steps == math.ceil(9.9 / 0.07)
    assert info["distance_travelled"] == pytest.approx(steps * 0.07)
    assert info["episode_time"] == pytest.approx(steps * 0.1)
    assert info["progress"] == pytest.approx(steps * 0.07 / 10.0)


def test_leaving_the_track_terminates_with_the_penalty():
    env = PathFollowingEnv("constant_velocity", "horizontal_line", max_cross_track=0.45)
    env.reset(seed=0)
    # Pure sideways motion at 1 m/s to the left: 0.1 m a step, off track after 5 steps.
    steps, terminated, _, info = drive(env, [0.0, 1.0, 0.0])
    assert terminated and steps == 5 and info["off_track"] and not info["is_success"]
    assert info["cross_track_error"] == pytest.approx(0.5)


def test_hitting_a_maze_wall_terminates():
    env = PathFollowingEnv("diff_drive", "maze")
    env.reset(seed=0)
    maze = env.unwrapped.track.maze
    x, y = env.unwrapped.pose[:2]
    # Face straight down at the outer wall below the start cell and drive into it.
    env.reset(options={"start_pose": (x, y, -math.pi / 2)})
    steps, terminated, _, info = drive(env, [0.6, 0.6])
    assert terminated and info["collision"]
    assert maze.collides(np.array([info["pose"][:2]]), 0.25)[0]
    # The wall is half a cell below the start; the footprint reaches it a radius earlier.
    assert steps == math.ceil((0.5 * 1.5 - 0.25) / 0.06)


def test_time_limit_truncates():
    env = PathFollowingEnv("bicycle", "segments", step_limit=7)
    env.reset(seed=0)
    steps, terminated, truncated, info = drive(env, [0.0, 0.0])
    assert steps == 7 and truncated and not terminated and not info["completed"]


def test_standing_still_ends_the_episode_as_stalled():
    env = PathFollowingEnv("bicycle", "horizontal_line")
    env.reset(seed=0)
    total, steps, done = 0.0, 0, False
    while not done:
        _, reward, terminated, truncated, info = env.step(np.zeros(2, np.float32))
        total, steps, done = total + reward, steps + 1, terminated or truncated
    assert terminated and info["stalled"] and not info["is_success"]
    assert steps == 100  # stall_time 10 s at dt 0.1 s
    assert total == pytest.approx(-0.01 * steps - 10.0)


def test_default_time_limit_scales_with_the_path_length():
    env = PathFollowingEnv("bicycle", "horizontal_line", stall_time=None)
    env.reset(seed=0)
    steps, _, truncated, _ = drive(env, [0.0, 0.0])
    assert truncated and steps == math.ceil(3 * 10.0 / (0.6 * 0.1))


def episode_return(env, action):
    env.reset(seed=0)
    total, done = 0.0, False
    while not done:
        _, reward, terminated, truncated, info = env.step(np.asarray(action, np.float32))
        total += reward
        done = terminated or truncated
    return total, info


def test_reaching_the_goal_promptly_and_accurately_scores_best():
    env = PathFollowingEnv("diff_drive", "horizontal_line")
    fast, fast_info = episode_return(env, [0.9, 0.9])
    slow, slow_info = episode_return(env, [0.3, 0.3])
    drifting, drifting_info = episode_return(env, [0.9, 0.88])
    idle, idle_info = episode_return(env, [0.0, 0.0])
    assert fast_info["is_success"] and slow_info["is_success"]
    assert not drifting_info["is_success"] and not idle_info["completed"]
    assert fast > slow > idle and fast > drifting


def test_reset_options_choose_the_path_and_start_pose():
    env = PathFollowingEnv("diff_drive", "lines")
    _, info = env.reset(seed=0, options={"path": "vertical_line", "start_pose": (6.2, 2.0, 1.0)})
    assert env.path.name == "vertical_line"
    np.testing.assert_array_equal(info["pose"], [6.2, 2.0, 1.0])
    assert info["cross_track_error"] == pytest.approx(-0.2)  # right of a path heading +y
    custom = Path([[0, 0], [3, 4]])
    env.reset(options={"path": custom})
    assert env.path is custom


def test_start_noise_moves_the_start_pose_within_bounds():
    env = PathFollowingEnv("diff_drive", "segments", start_noise=(0.2, 0.3))
    poses = np.array([env.reset(seed=seed)[1]["pose"] for seed in range(30)])
    offsets = poses - [2.0, 1.0, 0.0]
    assert np.abs(offsets[:, :2]).max() <= 0.2 and np.abs(offsets[:, 2]).max() <= 0.3
    assert np.abs(offsets).min(axis=0).max() < 0.05 and offsets.std(axis=0).min() > 0.05


@pytest.mark.parametrize("bad", [[np.nan, 0.0], [np.inf, 0.0], [0.0], [[0.0, 0.0]]])
def test_bad_actions_raise_value_error(bad):
    env = PathFollowingEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(np.array(bad, dtype=np.float32))


def test_out_of_range_actions_are_clipped():
    clipped, raw = PathFollowingEnv(), PathFollowingEnv()
    clipped.reset(seed=0)
    raw.reset(seed=0)
    first = clipped.step(np.array([1.0, -1.0], np.float32))[0]
    second = raw.step(np.array([7.0, -3.0], np.float32))[0]
    np.testing.assert_array_equal(first, second)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"model": "hovercraft"}, "hovercraft"),
        ({"paths": "moon"}, "moon"),
        ({"dt": 0.0}, "dt"),
        ({"goal_radius": -1.0}, "goal_radius"),
        ({"max_cross_track": math.nan}, "max_cross_track"),
        ({"integrator": "leapfrog"}, "integrator"),
        ({"step_limit": 0}, "step_limit"),
        ({"start_noise": (-0.1, 0.0)}, "start_noise"),
        ({"stall_time": 0.0}, "stall_time"),
        ({"render_mode": "ascii"}, "render_mode"),
        ({"model": DifferentialDrive()}, "finite"),
        ({"model_params": {"track_width": -1.0}}, "track_width"),
        ({"paths": []}, "empty"),
    ],
)
def test_bad_constructor_arguments_raise_value_error(kwargs, message):
    with pytest.raises(ValueError, match=message):
        PathFollowingEnv(**kwargs)


def test_bad_reset_options_raise_value_error():
    env = PathFollowingEnv()
    with pytest.raises(ValueError, match="unknown reset options"):
        env.reset(options={"goal": (1, 2)})
    with pytest.raises(ValueError, match="start_pose"):
        env.reset(options={"start_pose": (1, 2)})


def test_rgb_array_frames_show_the_robot_moving():
    env = gym.make("mobile_envs/DiffDrive-Segments-v0", render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    assert first.shape[2] == 3 and first.dtype == np.uint8 and first.shape[0] > 100
    for _ in range(10):
        env.step(np.array([1.0, 1.0], np.float32))
    assert (env.render() != first).any()
    assert env.metadata["render_fps"] == 10
    env.close()


def test_record_video_writes_a_file(tmp_path):
    pytest.importorskip("moviepy", reason="RecordVideo needs moviepy (the render extra)")
    env = gym.make("mobile_envs/DiffDrive-Segments-v0", render_mode="rgb_array")
    env = gym.wrappers.RecordVideo(env, str(tmp_path), episode_trigger=lambda _: True)
    env.reset(seed=0)
    for _ in range(15):
        env.step(env.action_space.sample())
    env.close()
    videos = list(tmp_path.glob("*.mp4"))
    assert videos and videos[0].stat().st_size > 1000


@pytest.mark.parametrize(
    ("model", "size"),
    [
        ("constant_velocity", 43 + 3 + 1),
        ("diff_drive", 43 + 2),
        ("bicycle", 43 + 2),
        ("tricycle", 43 + 2 + 1),
    ],
)
def test_observation_size_is_the_documented_43_plus_m_plus_e(model, size):
    env = PathFollowingEnv(model, "segments")
    assert env.observation_space.shape == (size,)
    names = env.observation_names
    assert names[20:24] == (
        "cross_track_error",
        "heading_error",
        "cross_track_error_fine",
        "heading_error_fine",
    )


def test_fine_error_features_resolve_centimetres():
    env = PathFollowingEnv("diff_drive", "horizontal_line")
    observation, _ = env.reset(options={"start_pose": (3.0, 6.01, 0.0)})
    assert observation[20] == pytest.approx(0.01, abs=1e-6)  # 1 cm of a 1 m off-track range
    assert observation[22] == pytest.approx(np.tanh(0.01 / 0.05), abs=1e-6)  # ~0.2


def test_step_limit_through_gym_make_ends_the_episode_with_its_metrics():
    env = gym.make("mobile_envs/DiffDrive-Segments-v0", step_limit=6)
    env.reset(seed=0)
    for step in range(1, 7):
        _, _, terminated, truncated, info = env.step(np.array([0.3, 0.3], np.float32))
        assert not terminated and truncated == (step == 6)
    assert info["episode_time"] == pytest.approx(0.6)
    assert info["completed"] is False
    assert info == {**info, **env.unwrapped.episode_metrics()}


def test_episode_metrics_so_far_after_an_outer_time_limit():
    """gym.make(..., max_episode_steps=n) adds Gymnasium's TimeLimit, which the env cannot see;
    its metrics so far are one call away, and equal what its own limit would report."""
    wrapped = gym.make("mobile_envs/DiffDrive-Segments-v0", max_episode_steps=6)
    own = gym.make("mobile_envs/DiffDrive-Segments-v0", step_limit=6)
    for env in (wrapped, own):
        env.reset(seed=0)
        for _ in range(6):
            *_, truncated, info = env.step(np.array([0.3, 0.2], np.float32))
        assert truncated
    assert wrapped.unwrapped.episode_metrics() == own.unwrapped.episode_metrics()
    assert {key: info[key] for key in own.unwrapped.episode_metrics()} == (
        wrapped.unwrapped.episode_metrics()
    )


def test_the_envs_own_step_limit_is_step_limit():
    env = PathFollowingEnv("diff_drive", "lines", step_limit=3)
    env.reset(seed=0)
    flags = [env.step(np.zeros(2, np.float32))[3] for _ in range(3)]
    assert flags == [False, False, True]

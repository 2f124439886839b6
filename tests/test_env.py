"""PathFollowingEnv: API conformance, scripted episodes, seeding and bad input."""

import math
import os
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

from mobile_envs._kernels.angles import wrap_angle
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.registration import (
    has_encoders,
    localization_ids,
    model_ids,
    path_set_ids,
)
from mobile_envs.robots import MODELS, DifferentialDrive
from mobile_envs.sensing.localization import LOCALIZATIONS
from mobile_envs.sim.plant import PRESET_IDS
from mobile_envs.tracks import PATH_SETS, path_set
from mobile_envs.world.paths import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

ALL_IDS = sorted(env_id for env_id in gym.registry if env_id.startswith("mobile_envs/"))


def test_every_model_and_path_set_is_registered():
    models, path_sets = model_ids(), path_set_ids()
    assert {"Lines", "Segments", "SharpSegments", "Maze", "Random"} <= set(path_sets)
    expected = {f"mobile_envs/{model}-{paths}-v0" for model in models for paths in path_sets}
    expected |= {"mobile_envs/Tricycle-ArcStraight-v0", "mobile_envs/PathFollowing-v0"}
    localized_sets = [
        paths for paths, name in path_sets.items() if PATH_SETS[name].env_localizations is None
    ]
    expected |= {
        f"mobile_envs/{model}-{paths}-{suffix}-v0"
        for model, name in models.items()
        for suffix, localization in localization_ids().items()
        if has_encoders(MODELS[name]) or not LOCALIZATIONS[localization].needs_encoders
        for paths in localized_sets
    }
    expected.add("mobile_envs/Tricycle-ArcStraight-Beacons-v0")
    expected |= {
        f"mobile_envs/{model}-{paths}-{suffix}-v0"
        for model in models
        for suffix in PRESET_IDS
        for paths in localized_sets
    }
    expected.add("mobile_envs/Tricycle-ArcStraight-Realistic-v0")
    assert expected == set(ALL_IDS)


def assert_gymnasium_and_sb3_checkers_pass(env_id):
    """Gymnasium's and SB3's env checkers pass on ``env_id`` without a single warning."""
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
def test_gymnasium_and_sb3_checkers_pass(env_id):
    assert_gymnasium_and_sb3_checkers_pass(env_id)


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


@pytest.mark.parametrize("make", [np.random.PCG64, np.random.MT19937])
def test_a_restart_draws_the_track_then_the_start_pose_from_the_envs_generator(make):
    # PCG64 generators are drawn from in compiled code, others in Python: the same numbers.
    env = PathFollowingEnv("diff_drive", "training", start_noise=(0.2, 0.3))
    env.reset(seed=0)
    for seed in range(6):
        env.np_random = np.random.Generator(make(seed))
        reference = np.random.Generator(make(seed))
        env.reset()
        track = path_set("training").sample(reference)
        noise = reference.uniform(-0.2, 0.2), reference.uniform(-0.2, 0.2)
        heading = wrap_angle(track.path.start_heading + reference.uniform(-0.3, 0.3))
        assert np.array_equal(env.path.points, track.path.points)
        expected = (*(track.path.points[0] + noise), heading)
        assert env.unwrapped.core.state[0, :3].tolist() == list(expected)
        next_draws = env.np_random.integers(2**32, size=4).tolist()
        assert next_draws == reference.integers(2**32, size=4).tolist()


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
    pytest.importorskip("pygame", reason="rendering needs pygame (the render extra)")
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
    folder = tmp_path / "videos"  # a new folder: RecordVideo warns when it overwrites one
    env = gym.wrappers.RecordVideo(env, str(folder), episode_trigger=lambda _: True)
    env.reset(seed=0)
    for _ in range(15):
        env.step(env.action_space.sample())
    env.close()
    videos = list(folder.glob("*.mp4"))
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


# ---------------------------------------------------------------------------------------------
# Settings: numpy scalars, bools, and the bounds that keep every number finite (issue 13)


def python_twin(value):
    """The Python number a numpy scalar (or a pair of them) stands for."""
    if isinstance(value, (tuple, list, np.ndarray)):
        return tuple(python_twin(item) for item in value)
    return int(value) if isinstance(value, np.integer) else float(value)


def numpy_settings(float_type, int_type):
    """Every float and int setting of a tricycle env, as numpy scalars."""
    return {
        "model_params": {
            "wheelbase": float_type(0.9),
            "max_steering": float_type(1.2),
            "max_speed": float_type(0.8),
            "max_steering_rate": float_type(1.5),
            "substeps": int_type(3),
        },
        "dt": float_type(0.05),
        "goal_radius": float_type(0.2),
        "max_cross_track": float_type(0.8),
        "step_limit": int_type(40),
        "start_noise": (float_type(0.2), float_type(0.3)),
        "robot_radius": float_type(0.3),
        "stall_time": float_type(5.0),
    }


@pytest.mark.parametrize(
    ("float_type", "int_type"),
    [(np.float16, np.int8), (np.float32, np.uint16), (np.float64, np.int64), (np.longdouble, int)],
)
def test_numpy_scalar_settings_behave_as_the_python_numbers_they_equal(float_type, int_type):
    from mobile_envs.sim.config import RewardWeights

    numpy_kwargs = numpy_settings(float_type, int_type)
    python_kwargs = {
        key: {name: python_twin(item) for name, item in value.items()}
        if isinstance(value, dict)
        else python_twin(value)
        for key, value in numpy_kwargs.items()
    }
    weights = {"progress": 2.0, "time": 0.02, "cross_track": 4.0, "heading": 0.3}
    numpy_env = PathFollowingEnv(
        "tricycle",
        "random",
        reward_weights=RewardWeights(**{k: float_type(v) for k, v in weights.items()}),
        **numpy_kwargs,
    )
    python_env = PathFollowingEnv(
        "tricycle",
        "random",
        reward_weights=RewardWeights(**{k: float(float_type(v)) for k, v in weights.items()}),
        **python_kwargs,
    )
    for got, want in zip(rollout(numpy_env, 4), rollout(python_env, 4), strict=True):
        np.testing.assert_array_equal(got, want)
    # The same start noise as a numpy array of two:
    array_noise = PathFollowingEnv(start_noise=np.array([0.2, 0.3], dtype=float_type))
    assert array_noise.config.start_noise == python_twin(np.array([0.2, 0.3], dtype=float_type))


NUMBER_SETTINGS = [
    ("dt", {}),
    ("goal_radius", {}),
    ("max_cross_track", {}),
    ("step_limit", {}),
    ("start_noise", {}),
    ("robot_radius", {}),
    ("stall_time", {}),
    ("wheel_radius", {"model": "diff_drive"}),
    ("track_width", {"model": "diff_drive"}),
    ("max_wheel_speed", {"model": "diff_drive"}),
    ("wheelbase", {"model": "bicycle"}),
    ("max_steering", {"model": "bicycle"}),
    ("max_speed", {"model": "constant_velocity"}),
    ("max_angular_speed", {"model": "constant_velocity"}),
    ("max_steering_rate", {"model": "tricycle"}),
    ("substeps", {"model": "tricycle"}),
]


def build_with(name, value, model=None):
    """An env with one setting (an env argument or a model parameter) set to ``value``."""
    if model is None:
        return PathFollowingEnv(**{name: value})
    return PathFollowingEnv(model, model_params={name: value})


@pytest.mark.parametrize("bad", [True, np.True_, "0.1", None, [0.1], {"value": 0.1}])
@pytest.mark.parametrize(("name", "where"), NUMBER_SETTINGS)
def test_a_number_setting_refuses_anything_but_a_number_naming_it(name, where, bad):
    if bad is None and name in ("step_limit", "stall_time"):
        assert build_with(name, None, **where).config  # None is the documented "no limit"
        return
    if isinstance(bad, list) and name == "start_noise":
        bad = [True, 0.1]  # a list is start_noise's pair: a bool inside it
    with pytest.raises(ValueError, match=name):
        build_with(name, bad, **where)


def test_every_reward_weight_must_be_a_finite_real_number():
    from mobile_envs.sim.config import RewardWeights

    for name in RewardWeights.__dataclass_fields__:
        for bad in (math.nan, math.inf, -math.inf, True, "1.0", None):
            with pytest.raises(ValueError, match=name):
                RewardWeights(**{name: bad})
        assert RewardWeights(**{name: np.float32(0.5)}) == RewardWeights(**{name: 0.5})


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"max_cross_track": 5e-324}, "max_cross_track"),  # 1 / 5e-324 = inf: obs[20] NaN
        ({"model_params": {"wheel_radius": 1e-320}}, "wheel_radius"),  # obs[24:26] NaN
        ({"model_params": {"wheel_radius": 10**400}}, "wheel_radius"),  # beyond float64
        ({"model_params": {"track_width": 1e-320}}, "track_width"),  # yaw rate inf
        ({"model_params": {"max_wheel_speed": 1e200}}, "max_wheel_speed"),  # reward -inf
        ({"dt": 1e300}, "dt"),  # reward -inf
        ({"dt": 1e9 * (1 + 1e-15)}, "dt"),  # one step beyond the world at 1 m/s
        ({"dt": 5e-324}, "dt"),  # OverflowError before
        ({"step_limit": math.inf}, "step_limit"),
        ({"step_limit": 10**25}, "step_limit"),
        ({"step_limit": math.nan}, "step_limit"),
        ({"step_limit": 2.5}, "step_limit"),
        ({"start_noise": (1e308, 0.0)}, "start_noise"),
        ({"start_noise": (0.0, 1e308)}, "start_noise"),
        ({"start_noise": (1e9 * (1 + 1e-15), 0.0)}, "start_noise"),
        ({"stall_time": 1e308}, "stall_time"),  # the stall limit in steps: inf
        ({"goal_radius": 2e9}, "goal_radius"),
        ({"robot_radius": 2e9}, "robot_radius"),
        ({"max_cross_track": 2e9}, "max_cross_track"),
        ({"model": "tricycle", "model_params": {"substeps": math.inf}}, "substeps"),
        ({"model": "tricycle", "model_params": {"substeps": 10**25}}, "substeps"),
        ({"model": "tricycle", "model_params": {"max_steering": 1e-320}}, "max_steering"),
        ({"model": "constant_velocity", "model_params": {"max_speed": 1e-320}}, "max_speed"),
        ({"model_params": {"bogus": 1.0}}, "bogus"),
        ({"model_params": [("wheel_radius", 0.1)]}, "model_params"),
        ({"model": ["diff_drive"]}, "model"),
        ({"paths": 7}, "paths"),
        ({"sensors": 7}, "sensors"),
        ({"reward_weights": "heavy"}, "reward_weights"),
    ],
)
def test_settings_that_would_overflow_raise_naming_the_setting(kwargs, message):
    with pytest.raises(ValueError, match=message):
        PathFollowingEnv(**kwargs)


def test_reward_weights_that_could_overflow_float32_raise_naming_the_weight():
    from mobile_envs.sim.config import RewardWeights

    with pytest.raises(ValueError, match="cross_track_squared"):
        PathFollowingEnv(reward_weights=RewardWeights(cross_track_squared=1e30))
    with pytest.raises(ValueError, match="progress"):
        PathFollowingEnv(reward_weights=RewardWeights(progress=1e30))


def smallest_with_finite_reciprocal():
    """The smallest float64 x with a finite 1/x, found by stepping up from 1/max."""
    value = 1.0 / np.finfo(np.float64).max
    with np.errstate(over="ignore", divide="ignore"):
        while not np.isfinite(np.float64(1.0) / np.float64(value)):
            value = float(np.nextafter(value, 1.0))
    return value


def run_finite(env, steps=30, seed=0):
    """Random actions for ``steps`` steps (resetting at episode ends); every observation and
    reward must be finite, and every reward within float32 (what SB3 takes)."""
    from mobile_envs.sim.config import REWARD_LIMIT

    env.action_space.seed(seed)
    observation, _ = env.reset(seed=seed)
    rewards = []
    for _ in range(steps):
        assert np.isfinite(observation).all() and np.abs(observation).max() <= 1.0
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert math.isfinite(reward) and abs(reward) <= REWARD_LIMIT
        assert math.isfinite(info["cross_track_error"]) and np.isfinite(info["pose"]).all()
        rewards.append(reward)
        if terminated or truncated:
            assert all(math.isfinite(value) for value in env.unwrapped.episode_metrics().values())
            observation, _ = env.reset()
    return rewards


def test_the_bounds_are_exact_the_last_accepted_value_runs_finite():
    """Each derived bound admits its extreme value, which then runs without NaN or inf, and
    refuses the next float beyond it."""
    smallest = smallest_with_finite_reciprocal()
    run_finite(PathFollowingEnv(max_cross_track=smallest))
    with pytest.raises(ValueError, match="max_cross_track"):
        PathFollowingEnv(max_cross_track=float(np.nextafter(smallest, 0.0)))
    run_finite(PathFollowingEnv(dt=smallest, stall_time=None))  # 10 s / dt would overflow
    with pytest.raises(ValueError, match="dt"):
        PathFollowingEnv(dt=float(np.nextafter(smallest, 0.0)))
    # The course robot's top speed is 1 m/s: one step of 1e9 s crosses the whole world.
    run_finite(PathFollowingEnv(dt=1e9, stall_time=None))
    with pytest.raises(ValueError, match="dt"):
        PathFollowingEnv(dt=float(np.nextafter(1e9, np.inf)), stall_time=None)


def test_a_tiny_dt_saturates_the_time_limit_instead_of_wrapping_to_int64_min():
    """dt = 1e-300 s asks for 3 x 18 m / (0.6 m/s x 1e-300 s) ~ 1e302 steps: more than int64
    counts, so the limit is the largest count it holds and the episode runs on."""
    env = PathFollowingEnv(dt=1e-300, stall_time=None)
    env.reset(seed=0)
    assert env.core.time_limit[0] == int(np.nextafter(2.0**63, 0.0)) > 0
    for _ in range(5):
        _, reward, terminated, truncated, _ = env.step(np.array([0.5, 0.5], np.float32))
        assert math.isfinite(reward) and not terminated and not truncated


@pytest.mark.parametrize("dt", [0.1, 0.05, 0.37, 1e-3, 1e-300, 1e9])
def test_time_limits_are_three_traversals_at_nominal_speed_rounded_up(dt: float) -> None:
    """The limit is ceil(3 L / (0.6 m/s x dt)) steps, saturated at int64's largest float,
    for lengths from 0 to the largest float: the formula in exact rational arithmetic,
    rounded as the float ops are."""
    from fractions import Fraction

    from mobile_envs.sim.config import make_core_config

    config = make_core_config("diff_drive", "segments", dt=dt)
    lengths = np.concatenate(
        [np.random.default_rng(0).uniform(0.0, 100.0, 200), [0.0, 5e-324, 18.25, 1e300, 1.7e308]]
    )
    saturated = int(np.nextafter(2.0**63, 0.0))
    per_step = 0.6 * dt
    cap = saturated * per_step / 3.0
    for length, limit in zip(lengths.tolist(), config.time_limit(lengths).tolist(), strict=True):
        steps = 3.0 * min(length, cap) / per_step  # the float quotient the limit rounds up
        expected = min(math.ceil(Fraction(steps)), saturated)
        assert limit == expected, (length, limit, expected)
        if 1e-300 < length < cap:  # uncapped, no underflow: the exact ratio's ceiling, but
            # for two float roundings
            exact, rounding = 3 * Fraction(length) / Fraction(per_step), Fraction(1, 10**15)
            assert exact * (1 - rounding) <= limit < exact * (1 + rounding) + 1


def test_the_worst_case_world_keeps_every_reward_within_its_derived_bound():
    """Every length at its bound at once: a path across the world's diagonal and back, start
    noise and the off-track distance of WORLD_EXTENT, one step's travel of WORLD_EXTENT, and
    the heaviest cross-track weight the float32 limit admits. Each step's |reward| stays below
    the bound RewardWeights.step_bounds derives from REACH, hence finite in float32."""
    from mobile_envs.sim.config import REACH, REWARD_LIMIT, WORLD_EXTENT, RewardWeights

    extent = WORLD_EXTENT
    path = Path([[-extent, -extent], [extent, extent], [extent, -extent]])
    dt = extent  # the course robot's 1 m/s top speed carries it WORLD_EXTENT in one step
    heaviest = RewardWeights(
        progress=0.0, cross_track=0.0, cross_track_squared=0.9 * REWARD_LIMIT / (REACH**2 * dt)
    )
    env = PathFollowingEnv(
        paths=path,
        dt=dt,
        start_noise=(extent, math.pi),
        max_cross_track=extent,
        goal_radius=extent,
        robot_radius=extent,
        stall_time=None,
        reward_weights=heaviest,
    )
    bound = sum(heaviest.step_bounds(dt).values())
    for seed in range(5):
        rewards = run_finite(env, steps=40, seed=seed)
        assert max(abs(reward) for reward in rewards) <= bound
    assert np.isfinite(np.float32(bound))


@pytest.mark.parametrize(
    "dtype",
    [np.float16, np.float32, np.float64, np.longdouble, ">f4", ">f8", np.int8, np.int64],
)
def test_every_real_action_dtype_steps_like_the_float64_value_it_holds(dtype):
    values = [1, -1] if np.dtype(dtype).kind == "i" else [0.7, -0.3]
    actions = np.array(values, dtype=dtype)
    env, twin = PathFollowingEnv(), PathFollowingEnv()
    env.reset(seed=1)
    twin.reset(seed=1)
    for _ in range(3):  # float16 and longdouble hold values float64 holds exactly
        got, want = env.step(actions), twin.step(actions.astype(np.float64))
        np.testing.assert_array_equal(got[0], want[0])
        assert got[1:4] == want[1:4]


def test_a_longdouble_action_beyond_float64_is_clipped_not_made_infinite():
    huge = np.array([np.longdouble(10) ** 400, -(np.longdouble(10) ** 400)])
    if not np.isfinite(huge).all():
        pytest.skip("this platform's longdouble is float64")
    env, twin = PathFollowingEnv(), PathFollowingEnv()
    env.reset(seed=1)
    twin.reset(seed=1)
    np.testing.assert_array_equal(env.step(huge)[0], twin.step(np.array([1.0, -1.0]))[0])


@pytest.mark.parametrize(
    "bad",
    [
        np.array([True, False]),
        np.array([0.5 + 1j, 0.0]),
        np.array(["0.5", "0.1"]),
        np.array([0.5, None], dtype=object),
        np.array([1, 2], dtype="datetime64[s]"),
        [[0.1, 0.2], [0.3]],  # ragged
        np.array([np.float16(np.inf), 0.0], dtype=np.float16),
        np.array([np.longdouble("nan"), 0.0], dtype=np.longdouble),
    ],
)
def test_actions_that_are_not_finite_reals_raise_value_error(bad):
    env = PathFollowingEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(bad)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"path": "random"}, "randomly drawn"),
        ({"path": "lines"}, "3 paths"),
        ({"path": [Path([[0, 0], [1, 0]]), Path([[0, 0], [2, 0]])]}, "2 paths"),
        ({"path": "nowhere"}, "nowhere"),
        ({"path": 7}, "path"),
        (["path"], "dict"),
        ("path", "dict"),
        ({"start_pose": "abc"}, "start_pose"),
        ({"start_pose": (1e308, 0.0, 0.0)}, "start_pose"),
        ({"start_pose": (0.0, 0.0, math.nan)}, "start_pose"),
        ({1: 2, "a": 3}, "unknown reset options"),
        ({"reset_mask": np.array([True])}, "unknown reset options"),
    ],
)
def test_bad_reset_options_name_the_problem(options, message):
    env = PathFollowingEnv("diff_drive", "lines")
    with pytest.raises(ValueError, match=message):
        env.reset(seed=0, options=options)


def test_a_path_set_of_one_path_or_a_list_of_one_is_a_valid_reset_path():
    from mobile_envs.tracks import path_set

    env = PathFollowingEnv("diff_drive", "lines")
    env.reset(seed=0, options={"path": path_set("vertical_line")})
    assert env.path.name == "vertical_line"
    custom = Path([[0, 0], [3, 4]])
    env.reset(options={"path": [custom]})
    assert env.path is custom


def test_reset_takes_numpy_integer_seeds_and_refuses_other_seeds():
    env = PathFollowingEnv("diff_drive", "training", start_noise=(0.2, 0.3))
    by_numpy, _ = env.reset(seed=np.int64(3))
    by_int, _ = env.reset(seed=3)
    np.testing.assert_array_equal(by_numpy, by_int)
    for bad in (1.5, True, "3"):
        with pytest.raises(ValueError, match="seed"):
            env.reset(seed=bad)


def test_reward_weights_may_be_a_mapping_over_the_defaults():
    """As YAML files and sweeps store them."""
    from mobile_envs.sim.config import RewardWeights

    env = PathFollowingEnv(reward_weights={"cross_track": 2.0})
    assert env.config.reward == RewardWeights(cross_track=2.0)
    with pytest.raises(ValueError, match=r"unknown reward_weights \['cross'\]"):
        PathFollowingEnv(reward_weights={"cross": 2.0})

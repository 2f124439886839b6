"""The plant against closed forms: delay, lag, parameter errors and slip (eq. 17), and the
vector env against N single envs with every imperfection on."""

import math

import gymnasium as gym
import numpy as np
import pytest

import mobile_envs  # noqa: F401  (registers the ids)
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.robots import MODELS, Bicycle, DifferentialDrive, make_model
from mobile_envs.sim.plant import CROWLEY_SLIP, PRESETS
from mobile_envs.world.paths import Path

DT = 0.1
ALONG_X = Path([[0.0, 0.0], [300.0, 0.0]])
# Both wheels at half their top speed: 10 rad/s, 0.5 m/s on the course's robot.
HALF_AHEAD = np.array([0.5, 0.5], dtype=np.float32)


def straight_env(plant, **settings):
    env = PathFollowingEnv("diff_drive", ALONG_X, plant=plant, stall_time=None, **settings)
    env.reset(seed=0, options={"start_pose": (0.0, 0.0, 0.0)})
    return env


def drive(env, action, steps):
    poses = []
    for _ in range(steps):
        env.step(action)
        poses.append(env.pose.copy())
    return np.array(poses)


def test_no_plant_and_the_ideal_preset_are_the_ideal_robot_bit_for_bit():
    ideal = drive(straight_env(None), HALF_AHEAD, 20)
    np.testing.assert_array_equal(drive(straight_env("ideal"), HALF_AHEAD, 20), ideal)
    np.testing.assert_array_equal(drive(straight_env({}), HALF_AHEAD, 20), ideal)


@pytest.mark.parametrize("steps", [1, 3])
def test_a_delay_keeps_the_robot_at_rest_for_its_steps_then_applies_the_old_commands(steps):
    env = straight_env({"delay": steps * DT})
    poses = drive(env, HALF_AHEAD, steps + 4)
    assert (poses[:steps] == 0.0).all(), "moved before the first command arrived"
    # From then on it moves 0.05 m a step, as the ideal robot did `steps` steps earlier.
    np.testing.assert_allclose(np.diff(poses[steps - 1 :, 0]), 0.05, rtol=0, atol=1e-12)
    assert env.unwrapped.core.inputs[0] == pytest.approx([10.0, 10.0])


def test_a_lag_follows_the_step_response_sum_of_c_one_minus_a_to_the_j_dt():
    tau = 0.35
    a = math.exp(-DT / tau)
    env = straight_env({"time_constant": tau})
    poses = drive(env, HALF_AHEAD, 25)
    speed = 0.5  # m/s: the command c mapped through the wheel radius
    expected = np.cumsum([speed * (1.0 - a**j) * DT for j in range(1, 26)])
    np.testing.assert_allclose(poses[:, 0], expected, rtol=1e-12, atol=1e-15)
    # The observation's twist is the realized one, the encoders' view.
    info_speed = env.unwrapped.core.speed[0]
    assert info_speed == pytest.approx(speed * (1.0 - a**25), rel=1e-12)


def test_delay_and_lag_together_delay_the_lag():
    tau, steps = 0.2, 2
    a = math.exp(-DT / tau)
    poses = drive(straight_env({"delay": steps * DT, "time_constant": tau}), HALF_AHEAD, 12)
    expected = np.cumsum([0.5 * (1.0 - a ** max(j - steps, 0)) * DT for j in range(1, 13)])
    np.testing.assert_allclose(poses[:, 0], expected, rtol=1e-12, atol=1e-15)


def test_equal_wheel_radius_errors_scale_a_straight_line():
    error = 0.04
    plant = {"parameter_errors": {"wheel_radius_right": error, "wheel_radius_left": error}}
    poses = drive(straight_env(plant), HALF_AHEAD, 10)
    np.testing.assert_allclose(poses[:, 0], 0.05 * (1 + error) * np.arange(1, 11), rtol=1e-12)
    np.testing.assert_allclose(poses[:, 1:], 0.0, atol=1e-15)


def test_unequal_wheel_radii_drive_the_exact_arc_of_the_true_radii():
    right_error, left_error, track_error = 0.03, -0.02, 0.05
    plant = {
        "parameter_errors": {
            "wheel_radius_right": right_error,
            "wheel_radius_left": left_error,
            "track_width": track_error,
        }
    }
    poses = drive(straight_env(plant), HALF_AHEAD, 30)
    # The true robot: its own radii and track, turning on a circle around its ICR.
    r_right, r_left, track = 0.05 * (1 + right_error), 0.05 * (1 + left_error), 1 + track_error
    v = (r_right * 10.0 + r_left * 10.0) / 2
    omega = (r_right * 10.0 - r_left * 10.0) / track
    radius = v / omega
    t = DT * np.arange(1, 31)
    np.testing.assert_allclose(poses[:, 0], radius * np.sin(omega * t), rtol=0, atol=1e-12)
    np.testing.assert_allclose(poses[:, 1], radius * (1 - np.cos(omega * t)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(poses[:, 2], omega * t, rtol=0, atol=1e-12)


@pytest.mark.parametrize("model", ["bicycle", "tricycle"])
def test_a_wheelbase_error_moves_the_robot_as_a_model_built_with_the_true_wheelbase(model):
    error = -0.07
    nominal = make_model(model, **MODELS[model].env_defaults)
    true = make_model(model, **{**MODELS[model].env_defaults, "wheelbase": 1.0 * (1 + error)})
    plant_env = PathFollowingEnv(
        model, "segments", plant={"parameter_errors": {"wheelbase": error}}
    )
    true_env = PathFollowingEnv(true, "segments")
    rng = np.random.default_rng(4)
    plant_env.reset(seed=1)
    true_env.reset(seed=1)
    for action in rng.uniform(-1, 1, (40, nominal.input_dim)).astype(np.float32):
        plant_env.step(action)
        true_env.step(action)
        np.testing.assert_array_equal(plant_env.unwrapped.core.state, true_env.core.state)


def test_a_steering_offset_turns_the_bicycle_as_if_its_wheel_were_misaligned():
    offset = 0.02
    env = PathFollowingEnv(
        "bicycle", ALONG_X, plant={"parameter_errors": {"steering_offset": offset}}
    )
    env.reset(seed=0, options={"start_pose": (0.0, 0.0, 0.0)})
    env.step(np.array([1.0, 0.0], dtype=np.float32))  # full speed, "straight" steering
    expected = Bicycle(**Bicycle.env_defaults).step([0, 0, 0], [1.0, offset], DT)
    np.testing.assert_allclose(env.pose, expected, rtol=0, atol=1e-15)


def test_slip_spreads_the_pose_as_eq_17_says_monte_carlo():
    """One straight step of 0.05 m at heading 0.3 for 20,000 robots: the pose's variances are
    eq. 17's Q (K_D |dD cos th|, K_D |dD sin th|, K_Dth |dD|) within 4.5 standard errors."""
    robots, heading = 20_000, 0.3
    k_d, k_dth, k_th = 0.01, 0.02, 0.005
    envs = PathFollowingVectorEnv(
        robots, "diff_drive", ALONG_X, plant={"slip": (k_d, k_dth, k_th)}, stall_time=None
    )
    envs.reset(seed=0, options={"start_pose": (0.0, 0.0, heading)})
    envs.step(np.tile(HALF_AHEAD, (robots, 1)))
    state = envs.core.state
    distance = 0.05
    expected = np.array(
        [k_d * abs(distance * math.cos(heading)), k_d * abs(distance * math.sin(heading)),
         k_dth * distance],
    )  # fmt: skip
    mean = np.array([distance * math.cos(heading), distance * math.sin(heading), heading])
    deviations = state[:, :3] - mean
    for axis in range(3):
        variance = np.mean(deviations[:, axis] ** 2)
        standard_error = expected[axis] * math.sqrt(2.0 / robots)  # of a Gaussian's variance
        assert abs(variance - expected[axis]) < 4.5 * standard_error, axis
        assert abs(np.mean(deviations[:, axis])) < 4.5 * math.sqrt(expected[axis] / robots)


ALL_IMPERFECTIONS = {
    "delay": 0.1,
    "time_constant": 0.15,
    "slip": CROWLEY_SLIP,
    "randomize": {
        "delay": (0.0, 0.3),
        "time_constant": (0.0, 0.3),
        "parameter_errors": 0.05,
        "steering_offset": 0.02,
        "slip": (0.0, 2.0),
    },
}


@pytest.mark.parametrize("model", sorted(MODELS))
@pytest.mark.parametrize("autoreset_mode", ["NextStep", "SameStep"])
def test_the_vector_env_equals_n_single_envs_with_every_imperfection(model, autoreset_mode):
    robots, steps = 4, 120
    settings = {"plant": ALL_IMPERFECTIONS, "step_limit": 30}
    vector = PathFollowingVectorEnv(
        robots, model, "segments", autoreset_mode=autoreset_mode, **settings
    )
    singles = [PathFollowingEnv(model, "segments", **settings) for _ in range(robots)]
    observations, infos = vector.reset(seed=list(range(robots)))
    for index, env in enumerate(singles):
        single_observation, info = env.reset(seed=index)
        np.testing.assert_array_equal(observations[index], single_observation)
        for key in ("plant_delay", "plant_time_constant", "plant_slip", "plant_parameter_errors"):
            np.testing.assert_array_equal(infos[key][index], info[key])
    rng = np.random.default_rng(0)
    pending = [False] * robots  # next-step autoreset: the robot restarts at the next step
    for _ in range(steps):
        actions = rng.uniform(-1, 1, (robots, vector.single_action_space.shape[0]))
        actions = actions.astype(np.float32)
        observations, rewards, _, _, infos = vector.step(actions)
        for index, env in enumerate(singles):
            if pending[index]:
                single_observation, info = env.reset()
                pending[index] = False
                np.testing.assert_array_equal(infos["plant_delay"][index], info["plant_delay"])
            else:
                single_observation, reward, ended, cut, _ = env.step(actions[index])
                assert rewards[index] == reward
                if (ended or cut) and autoreset_mode == "SameStep":
                    single_observation, _ = env.reset()
                pending[index] = (ended or cut) and autoreset_mode == "NextStep"
            np.testing.assert_array_equal(observations[index], single_observation)


def test_the_same_seed_gives_the_same_draws_and_bits():
    first = PathFollowingEnv("tricycle", "segments", plant=ALL_IMPERFECTIONS)
    second = PathFollowingEnv("tricycle", "segments", plant=ALL_IMPERFECTIONS)
    for env in (first, second):
        env.reset(seed=11)
    rng = np.random.default_rng(1)
    for action in rng.uniform(-1, 1, (50, 2)).astype(np.float32):
        a, b = first.step(action), second.step(action)
        np.testing.assert_array_equal(a[0], b[0])
        assert a[1] == b[1]


def test_randomized_draws_stay_in_their_ranges_and_whole_steps():
    envs = PathFollowingVectorEnv(500, "diff_drive", "segments", plant=ALL_IMPERFECTIONS)
    _, infos = envs.reset(seed=3)
    steps = infos["plant_delay"] / DT
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    assert set(np.round(steps).astype(int)) == {0, 1, 2, 3}
    assert (infos["plant_time_constant"] >= 0).all() and (infos["plant_time_constant"] <= 0.3).all()
    assert np.abs(infos["plant_parameter_errors"]).max() <= 0.05
    scales = infos["plant_slip"] / np.array(CROWLEY_SLIP)
    np.testing.assert_allclose(scales[:, 0], scales[:, 1])
    assert (scales >= 0).all() and (scales <= 2).all()


def test_a_range_ending_at_minus_zero_is_the_range_from_zero_to_zero():
    # Found by the plant's fuzz test: (0.0, -0.0) passed the checks, then numpy's uniform
    # refused it at reset ("high - low < 0").
    env = gym.make(
        "mobile_envs/Bicycle-Segments-v0", plant={"randomize": {"time_constant": (0.0, -0.0)}}
    )
    _, info = env.reset(seed=0)
    assert info["plant_time_constant"] == 0.0


def test_the_realistic_preset_is_what_the_manual_says():
    assert PRESETS["realistic"] == {
        "delay": 0.1,
        "time_constant": 0.1,
        "slip": CROWLEY_SLIP,
        "randomize": {"parameter_errors": 0.03, "steering_offset": 0.02},
    }
    env = gym.make("mobile_envs/Bicycle-Segments-v0", plant="realistic")
    _, info = env.reset(seed=0)
    assert info["plant_delay"] == pytest.approx(0.1)
    wheelbase_error, offset = info["plant_parameter_errors"]
    assert abs(wheelbase_error) <= 0.03 and abs(offset) <= 0.02


@pytest.mark.parametrize(
    ("plant", "named"),
    [
        ({"delay": 0.15}, "multiple of dt"),
        ({"delay": -0.1}, "delay"),
        ({"time_constant": math.inf}, "time_constant"),
        ({"time_constant": -1.0}, "time_constant"),
        ({"parameter_errors": {"wheelbase": 0.1}}, "wheelbase"),
        ({"parameter_errors": {"track_width": -1.0}}, "track_width"),
        ({"slip": (0.1, 0.1)}, "slip"),
        ({"slip": (0.1, -0.1, 0.0)}, "slip"),
        # 0-d and 2-d arrays are not a list of coefficients (hypothesis found the 0-d one)
        ({"slip": np.array(0.5)}, "slip"),
        ({"slip": np.zeros((3, 1))}, "slip"),
        ({"randomize": {"delay": np.array(0.1)}}, "randomize delay"),
        ({"wobble": 1.0}, "wobble"),
        ({"randomize": {"delay": (0.01, 0.05)}}, "no whole number of steps"),
        ({"randomize": {"time_constant": (0.3, 0.1)}}, "low <= high"),
        ({"randomize": {"gusts": 1}}, "gusts"),
        ("bumpy", "bumpy"),
        (3, "plant"),
    ],
)
def test_bad_plants_raise_naming_what_is_wrong(plant, named):
    with pytest.raises(ValueError, match=named):
        PathFollowingEnv("diff_drive", "segments", plant=plant)


def test_a_realistic_robot_tracks_worse_than_the_ideal_one_under_pure_pursuit():
    from agents import PurePursuit, evaluate

    ideal = evaluate(PurePursuit(), "mobile_envs/DiffDrive-Segments-v0", episodes=3).summary
    realistic = evaluate(
        PurePursuit(), "mobile_envs/DiffDrive-Segments-v0", episodes=3, plant="realistic"
    ).summary
    assert realistic["mean_abs_cte"] > ideal["mean_abs_cte"]


def test_differential_drive_nominal_parameters_are_untouched_by_a_plant():
    model = DifferentialDrive(**DifferentialDrive.env_defaults)
    env = PathFollowingEnv(model, "segments", plant="realistic")
    np.testing.assert_array_equal(env.model.kernel_parameters, [0.05, 1.0, 0.0, 0.0])


@pytest.mark.parametrize(
    "plant", [{"delay": 1e25}, {"delay": 61.0}, {"randomize": {"delay": (0.0, 1e25)}}]
)
def test_a_delay_beyond_the_commands_a_robot_can_keep_is_refused_naming_it(plant):
    # Found by the fuzz suite: a delay of 1e25 s asked numpy for an array too large to index.
    with pytest.raises(ValueError, match=r"plant (randomize )?delay .*at most 60 s"):
        PathFollowingEnv("bicycle", "segments", plant=plant)


@pytest.mark.parametrize(
    "plant",
    [{"slip": (1e39, 0.0, 0.0)}, {"slip": (0.0, 0.0, 1.5)}, {"randomize": {"slip": (0, 1e42)}}],
)
def test_slip_beyond_any_floor_is_refused_naming_it(plant):
    # Found by the fuzz suite: slip coefficients of 1e39 sent rewards past float32's range.
    with pytest.raises(ValueError, match=r"plant (randomize )?slip .*at most"):
        PathFollowingEnv("diff_drive", "segments", plant=plant)

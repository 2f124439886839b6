"""Sensors plug into the core: their observation slice, their buffers and their noise."""

import math

import gymnasium as gym
import numpy as np
import pytest

from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.sensing.sensors import RANGE_MAX, SENSORS, RangeSensor, Sensor, register_sensor
from mobile_envs.tracks import the_maze


class NoisyPosition(Sensor):
    """A test sensor: the robot's (x, y) plus Gaussian noise from each robot's generator, and
    how many times it has measured that robot (per-robot state)."""

    def __init__(self, sigma: float):
        self.sigma = sigma
        self.names = ("gps_x", "gps_y", "gps_count")
        self.scales = np.array([0.1, 0.1, 0.001])

    def allocate(self, num_robots):
        self.count = np.zeros(num_robots)

    def reset(self, world, indices, rngs, out):
        self.count[indices] = 0
        self.measure(world, indices, rngs, out)

    def measure(self, world, indices, rngs, out):
        for index in indices:
            noise = self.sigma * rngs[index].standard_normal(2)
            out[index, :2] = world.state[index, :2] + noise
            out[index, 2] = self.count[index]
        self.count[indices] += 1


def test_a_new_sensor_adds_its_names_and_readings_after_the_others():
    env = PathFollowingEnv("diff_drive", "segments", sensors=[RangeSensor(), NoisyPosition(0.0)])
    plain = PathFollowingEnv("diff_drive", "segments")
    assert env.observation_names == (*plain.observation_names, "gps_x", "gps_y", "gps_count")
    assert env.observation_space.shape == (plain.observation_space.shape[0] + 3,)
    observation, info = env.reset(seed=0)
    for step in range(1, 4):
        observation, *_, info = env.step(np.array([0.5, 0.4], np.float32))
        # Noise-free here: the reading is the pose, scaled by the sensor's own factors.
        np.testing.assert_allclose(observation[-3:-1], np.float32(0.1 * info["pose"][:2]))
        assert observation[-1] == np.float32(0.001 * step)  # one reading at reset, then each step


def test_without_sensors_the_range_block_is_gone():
    env = PathFollowingEnv("bicycle", "maze", sensors=[])
    plain = PathFollowingEnv("bicycle", "maze")
    assert env.observation_names == plain.observation_names[:-16]
    observation, _ = env.reset(seed=1)
    reference, _ = plain.reset(seed=1)
    np.testing.assert_array_equal(observation, reference[:-16])


def test_noise_comes_from_each_robots_generator_so_vector_equals_single_envs():
    settings = {"model": "diff_drive", "paths": "training", "start_noise": (0.2, 0.3)}
    vector = PathFollowingVectorEnv(5, **settings, sensors=[NoisyPosition(0.05)])
    singles = [PathFollowingEnv(**settings, sensors=[NoisyPosition(0.05)]) for _ in range(5)]
    observations, _ = vector.reset(seed=7)
    expected = [env.reset(seed=7 + index)[0] for index, env in enumerate(singles)]
    np.testing.assert_array_equal(observations, np.array(expected))
    rng = np.random.default_rng(0)
    done = np.zeros(5, dtype=bool)
    for _ in range(300):
        actions = rng.uniform(-1, 1, (5, 2)).astype(np.float32)
        observations, rewards, terminated, truncated, _ = vector.step(actions)
        for index, env in enumerate(singles):
            if done[index]:
                single = env.reset()[0]
            else:
                single, reward, *flags, _ = env.step(actions[index])
                assert reward == rewards[index] and flags == [terminated[index], truncated[index]]
            np.testing.assert_array_equal(observations[index], single)
        done = terminated | truncated


def test_noise_has_the_sensors_spread():
    """Monte Carlo: readings minus the true position have the sensor's standard deviation."""
    sigma, count = 0.05, 400
    vector = PathFollowingVectorEnv(count, "diff_drive", "segments", sensors=[NoisyPosition(sigma)])
    vector.reset(seed=0)
    errors = []
    for _ in range(5):
        _, _, _, _, info = vector.step(np.zeros((count, 2), np.float32))
        errors.append(vector.core.readings[:, :2] - info["pose"][:, :2])
    errors = np.concatenate(errors).ravel()
    # 4000 samples: the sample deviation is within 5% of sigma (about 4.5 standard errors).
    assert abs(errors.std() / sigma - 1.0) < 0.05
    assert abs(errors.mean()) < 4 * sigma / math.sqrt(errors.size)


def test_range_readings_equal_the_mazes_own_ray_casts():
    env = gym.make("mobile_envs/Tricycle-Maze-v0", start_noise=(0.2, 0.3))
    sensor = RangeSensor()
    maze = the_maze().maze
    observation, info = env.reset(seed=3)
    rng = np.random.default_rng(3)
    for _ in range(60):
        observation, *_, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        expected = maze.ranges(info["pose"], sensor.angles, RANGE_MAX) / RANGE_MAX
        np.testing.assert_array_equal(observation[-16:], expected.astype(np.float32))


class AlwaysMeasuringRange(RangeSensor):
    """The range sensor, claiming to measure everywhere: the core then steps every robot in
    two calls with the sensors between, as it does in mazes."""

    def measures(self, world):
        return True


@pytest.mark.parametrize("num_threads", [1, 2])
def test_a_step_without_a_measuring_sensor_is_the_two_call_step_bit_for_bit(num_threads):
    """Off mazes the range sensor measures nothing, so the core moves and scores every robot
    in one call; the trajectories, observations, rewards and flags are the two calls' bits."""
    settings = dict(model="diff_drive", paths="lines", start_noise=(0.2, 0.3))
    fused = PathFollowingVectorEnv(16, **settings, num_threads=num_threads)
    two_calls = PathFollowingVectorEnv(
        16, **settings, num_threads=num_threads, sensors=[AlwaysMeasuringRange()]
    )
    assert not fused.core.sensors[0].measures(fused.core)
    observations = [fused.reset(seed=5)[0], two_calls.reset(seed=5)[0]]
    assert fused.core._nothing_between and not two_calls.core._nothing_between
    np.testing.assert_array_equal(*observations)
    rng = np.random.default_rng(5)
    ended = 0
    for _ in range(300):
        actions = rng.uniform(-1, 1, (16, 2)).astype(np.float32)
        (*fused_result, fused_info), (*two_call_result, two_call_info) = (
            fused.step(actions),
            two_calls.step(actions),
        )
        for fused_part, two_call_part in zip(fused_result, two_call_result, strict=True):
            np.testing.assert_array_equal(fused_part, two_call_part)
        assert fused_info.keys() == two_call_info.keys()
        for key, value in fused_info.items():
            np.testing.assert_array_equal(value, two_call_info[key])
        np.testing.assert_array_equal(fused.core.state, two_calls.core.state)
        ended += int((fused_result[2] | fused_result[3]).sum())
    assert ended > 16  # restarts happened in both, and kept them equal


def test_the_range_sensor_measures_only_where_robots_drive_in_mazes():
    open_space = PathFollowingEnv("diff_drive", "segments")
    in_maze = PathFollowingEnv("diff_drive", "maze")
    open_space.reset(seed=0)
    in_maze.reset(seed=0)
    sensor = RangeSensor()
    assert not sensor.measures(open_space.core) and sensor.measures(in_maze.core)
    assert open_space.core._nothing_between and not in_maze.core._nothing_between


def test_off_mazes_the_ranges_read_the_maximum():
    env = PathFollowingEnv("diff_drive", "segments")
    observation, _ = env.reset(seed=0)
    assert (observation[-16:] == 1.0).all()


@pytest.mark.parametrize(
    ("arguments", "named"),
    [
        ({"rays": 0}, "rays"),
        ({"rays": 2.5}, "rays"),
        ({"max_range": math.inf}, "max_range"),
        # Issue 30: an OverflowError, a TypeError naming nothing, and ints beyond float64.
        ({"rays": math.inf}, "rays"),
        ({"rays": None}, "rays"),
        ({"rays": True}, "rays"),
        ({"rays": 10**400}, "rays"),
        ({"max_range": 10**400}, "max_range"),
        ({"max_range": "5"}, "max_range"),
    ],
)
def test_range_sensor_settings_are_validated(arguments, named):
    with pytest.raises(ValueError, match=f"^{named} must"):
        RangeSensor(**arguments)


def test_sensors_must_be_sensors_or_their_names():
    with pytest.raises(ValueError, match=r"sensors\[0\]: unknown sensor 'sonar'; known: .*'range'"):
        PathFollowingEnv(sensors=["sonar"])
    with pytest.raises(ValueError, match=r"sensors\[1\] must be one of Sensor objects"):
        PathFollowingEnv(sensors=["range", 3])
    with pytest.raises(ValueError, match="sensors must be a list"):
        PathFollowingEnv(sensors="range")
    with pytest.raises(ValueError, match="sensors must be a list"):
        PathFollowingEnv(sensors=np.array(0.5))  # a 0-d array holds no list


# ---------------------------------------------------------------- sensors by name


def test_a_sensor_by_name_is_the_sensor_with_its_defaults():
    by_name = PathFollowingEnv("bicycle", "maze", sensors=["range"])
    default = PathFollowingEnv("bicycle", "maze")
    assert by_name.observation_names == default.observation_names
    np.testing.assert_array_equal(by_name.reset(seed=4)[0], default.reset(seed=4)[0])
    for _ in range(20):
        action = np.array([0.6, 0.1], np.float32)
        np.testing.assert_array_equal(by_name.step(action)[0], default.step(action)[0])


def test_a_sensor_from_its_settings_as_a_yaml_or_the_command_line_gives_them():
    """``{"type": name, **settings}``, as hyperparameter YAML files and ``--env-kwargs`` JSON
    hold them, through ``gym.make``'s keyword arguments."""
    env = gym.make("mobile_envs/Tricycle-Maze-v0", sensors=[{"type": "range", "rays": 8}])
    names = env.unwrapped.observation_names
    assert [name for name in names if name.startswith("range_")] == [f"range_{k}" for k in range(8)]
    observation, info = env.reset(seed=3)
    maze = the_maze().maze
    angles = np.linspace(-math.pi, math.pi, 8, endpoint=False)
    expected = maze.ranges(info["pose"], angles, RANGE_MAX) / RANGE_MAX
    np.testing.assert_array_equal(observation[-8:], expected.astype(np.float32))


@pytest.mark.parametrize(
    ("sensors", "message"),
    [
        (
            [{"type": "range", "rayz": 8}],
            r"sensors\[0\]: settings \['rayz'\] are not settings of sensor 'range'; "
            r"its settings: \['rays', 'max_range'\]",
        ),
        ([{"rays": 8}], r"sensors\[0\] needs a 'type' naming the sensor"),
        (["range", {"type": "range", "rays": 0}], r"sensors\[1\]: rays must be a positive integer"),
        ([{"type": "range", "rays": None}], r"sensors\[0\]: "),
    ],
)
def test_named_sensors_name_what_is_wrong(sensors, message):
    with pytest.raises(ValueError, match=message):
        PathFollowingEnv(sensors=sensors)


def test_user_code_registers_a_sensor_by_name():
    def noisy_position(sigma: float = 0.0) -> Sensor:
        return NoisyPosition(sigma)

    register_sensor("test_noisy_position", noisy_position)
    assert "test_noisy_position" in SENSORS
    env = PathFollowingEnv("diff_drive", "segments", sensors=[{"type": "test_noisy_position"}])
    assert env.observation_names[-3:] == ("gps_x", "gps_y", "gps_count")
    with pytest.raises(ValueError, match="'test_noisy_position' is already registered"):
        register_sensor("test_noisy_position", noisy_position)

"""The GNSS-like sensor: fixes at their rate, their error's spread, what a held fix reads,
and vector == N single envs bit for bit."""

import math
from fractions import Fraction

import gymnasium as gym
import numpy as np
import pytest
from lockstep import drive_in_lockstep

from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.sensing.sensors import SENSORS
from mobile_envs.sensing.sensors.gnss import ERROR_BLOCK, GnssSensor


def relative(point, pose):
    """``point`` in the frame of ``pose`` (x, y, heading)."""
    dx, dy = point[0] - pose[0], point[1] - pose[1]
    cos_heading, sin_heading = math.cos(pose[2]), math.sin(pose[2])
    return np.array([cos_heading * dx + sin_heading * dy, -sin_heading * dx + cos_heading * dy])


def fix_steps_by_brute_force(dt: str, rate: str, steps: int) -> list[int]:
    """The steps k in 1..steps that reach a fix instant j / rate in ((k - 1) dt, k dt], in
    exact rational arithmetic."""
    step, period = Fraction(dt), 1 / Fraction(rate)
    fixes, instant = [], period
    for k in range(1, steps + 1):
        if instant <= k * step:
            fixes.append(k)
            while instant <= k * step:  # a rate above 1 / dt: one fix a step
                instant += period
    return fixes


def test_it_is_chosen_by_name_with_its_settings():
    assert SENSORS["gnss"] is GnssSensor
    env = gym.make(
        "mobile_envs/DiffDrive-Lines-v0",
        sensors=["range", {"type": "gnss", "rate": 2.0, "noise": 0.1}],
    )
    assert env.unwrapped.observation_names[-3:] == ("gnss_forward", "gnss_left", "gnss_age")
    sensor = env.unwrapped.core.sensors[1]
    assert (sensor.rate, sensor.noise, sensor.max_offset) == (2.0, 0.1, 1.0)


@pytest.mark.parametrize(
    ("settings", "named"),
    [
        ({"rate": 0.0}, "rate"),
        ({"rate": math.inf}, "rate"),
        ({"noise": -0.1}, "noise"),
        ({"noise": True}, "noise"),
        ({"max_offset": 0.0}, "max_offset"),
    ],
)
def test_bad_settings_are_named(settings, named):
    with pytest.raises(ValueError, match=rf"sensors\[0\]: {named}"):
        PathFollowingEnv(sensors=[{"type": "gnss", **settings}])


@pytest.mark.parametrize(
    ("dt", "rate"),
    [("0.1", "1"), ("0.1", "3"), ("0.1", "2.5"), ("0.05", "7"), ("0.1", "20"), ("0.1", "0.7")],
)
def test_fixes_come_at_their_rate(dt, rate):
    """A fix (age 0) at exactly the steps that reach an instant j / rate, by exact rational
    arithmetic (at 0.7 Hz, 0.1 * 0.7 is a hair below 0.07 in floats: the 7th fix is still at
    step 100); the age grows by dt between them and observes in [0, 1)."""
    steps = 120
    env = PathFollowingEnv(
        "diff_drive",
        "lines",
        dt=float(dt),
        sensors=[GnssSensor(rate=float(rate), noise=0.0)],
        step_limit=10_000,
    )
    observation, _ = env.reset(seed=0)
    assert env.core.readings[0, 2] == 0.0
    fixes, ages = [], []
    for k in range(1, steps + 1):
        observation, *_ = env.step(np.array([0.3, 0.3], np.float32))
        age = env.core.readings[0, 2]
        if age == 0.0:
            fixes.append(k)
        ages.append(age)
        assert 0.0 <= observation[-1] < 1.0
    assert fixes == fix_steps_by_brute_force(dt, rate, steps)
    last_fix = 0
    for k, age in enumerate(ages, start=1):
        last_fix = k if k in fixes else last_fix
        assert age == pytest.approx((k - last_fix) * float(dt), abs=1e-12)


def test_a_held_fix_reads_where_the_robot_was_seen_from_where_it_is():
    """Noise-free, exact localization: the reading is the position at the last fix, in the
    frame of the pose now (from the env's own infos)."""
    env = PathFollowingEnv("bicycle", "segments", sensors=[GnssSensor(rate=2.0, noise=0.0)])
    _, info = env.reset(seed=1)
    fixed_at = info["pose"][:2]
    rng = np.random.default_rng(1)
    for k in range(1, 60):
        *_, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        if k % 5 == 0:
            fixed_at = info["pose"][:2]
        np.testing.assert_allclose(
            env.core.readings[0, :2], relative(fixed_at, info["pose"]), atol=1e-12
        )


def test_with_odometry_a_fix_reads_the_estimates_drift():
    """A fresh noise-free fix is the true position seen from the estimated pose."""
    env = PathFollowingEnv(
        "diff_drive",
        "lines",
        sensors=[GnssSensor(rate=10.0, noise=0.0)],
        localization="odometry",
        localization_params={"k_distance": 0.01, "k_heading": 0.01},
    )
    env.reset(seed=2)
    drifts = []
    for _ in range(80):
        *_, info = env.step(np.array([0.8, 0.7], np.float32))
        expected = relative(info["pose"][:2], info["estimated_pose"])
        np.testing.assert_allclose(env.core.readings[0, :2], expected, atol=1e-12)
        drifts.append(np.hypot(*expected))
    assert max(drifts) > 0.01  # the estimate did drift, and the reading showed it


def test_the_fix_error_has_its_setting_as_spread():
    """Monte Carlo: fresh fixes of 4000 robots (exact localization) read their error turned
    into each robot's frame, N(0, noise^2) on each axis, independent; at every fix of an
    episode, not only the first."""
    noise, robots = 0.3, 4000
    envs = PathFollowingVectorEnv(
        robots,
        "diff_drive",
        "lines",
        start_noise=(0.5, math.pi),
        sensors=[GnssSensor(rate=5.0, noise=noise, max_offset=2.0)],
    )
    envs.reset(seed=0)
    errors = [envs.core.readings[:, :2].copy()]
    for step in range(1, 5):
        envs.step(np.full((robots, 2), 0.5, np.float32))
        if step % 2 == 0:  # 5 Hz at 0.1 s: a fix every other step
            assert (envs.core.readings[:, 2] == 0.0).all()
            errors.append(envs.core.readings[:, :2].copy())
    samples = np.concatenate(errors)  # 12 000 per axis
    count = len(samples)
    for axis in range(2):
        # The sample variance's standard error is noise^2 sqrt(2 / (n - 1)): within 4.5 of it.
        variance = samples[:, axis].var(ddof=1)
        assert abs(variance - noise**2) < 4.5 * noise**2 * math.sqrt(2 / (count - 1))
        assert abs(samples[:, axis].mean()) < 4.5 * noise / math.sqrt(count)
    correlation = np.corrcoef(samples.T)[0, 1]
    assert abs(correlation) < 4.5 / math.sqrt(count)


def fix_errors(env, steps):
    """The error of each fix over ``steps`` steps (a fix every step), from the readings and
    the true poses: the reading turned back into the world frame."""
    _, info = env.reset(seed=5)
    errors = []
    for _ in range(steps):
        pose = info["pose"]
        cos_heading, sin_heading = math.cos(pose[2]), math.sin(pose[2])
        forward, left = env.core.readings[0, :2]
        errors.append(
            (cos_heading * forward - sin_heading * left, sin_heading * forward + cos_heading * left)
        )
        *_, info = env.step(np.array([0.2, 0.2], np.float32))
    return np.array(errors)


def test_errors_are_drawn_in_blocks_afresh_at_each_reset():
    """Past a block of fixes a robot draws new errors (none repeats), and a reset with a seed
    fixes as it did the first time, whatever the episode before left of its block."""
    env = PathFollowingEnv(
        "diff_drive", "lines", sensors=[GnssSensor(rate=10.0, noise=0.1)], step_limit=10_000
    )
    first = fix_errors(env, 3 * ERROR_BLOCK)
    assert len(np.unique(first, axis=0)) == len(first)
    fix_errors(env, ERROR_BLOCK // 2)  # leaves half a block
    np.testing.assert_array_equal(fix_errors(env, 3 * ERROR_BLOCK), first)


def test_noise_comes_from_each_robots_generator_so_vector_equals_single_envs():
    settings = {
        "model": "tricycle",
        "paths": "training",
        "start_noise": (0.2, 0.3),
        "sensors": ["range", {"type": "gnss", "rate": 3.0, "noise": 0.2}],
        "localization": "odometry",
    }
    vector = PathFollowingVectorEnv(5, **settings)
    singles = [PathFollowingEnv(**settings) for _ in range(5)]

    def actions(rng):
        return rng.uniform(-1, 1, (5, 2)).astype(np.float32)

    ended = drive_in_lockstep(vector, singles, 7, 400, actions)
    assert ended > 5  # restarts happened, and kept every robot's fixes equal

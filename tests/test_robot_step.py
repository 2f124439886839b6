"""The compiled step: observations and rewards against hand geometry, action validation."""

import itertools
import math

import gymnasium as gym
import numpy as np
import pytest

from mobile_envs.envs.interface import validate_actions
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.sim.columns import FlagColumn, FloatColumn, IntColumn
from mobile_envs.world.paths import Path

# An L: 4 m east, then 3 m north.
CORNER = Path([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]])


def walk_along(points: np.ndarray, s: float) -> np.ndarray:
    """The point at arc length s on a polyline, clamped to its ends, by walking it."""
    for start, end in itertools.pairwise(points):
        length = float(np.hypot(*(end - start)))
        if s <= length:
            return start + max(s, 0.0) / length * (end - start)
        s -= length
    return points[-1]


def test_observation_matches_hand_geometry_element_by_element():
    env = PathFollowingEnv("diff_drive", CORNER)
    x, y, heading = 3.2, -0.3, 0.4
    observation, info = env.reset(options={"start_pose": (x, y, heading)})
    # Closest point (3.2, 0) on the first leg: s = 3.2, 0.3 m right of the path.
    assert info["cross_track_error"] == pytest.approx(-0.3)
    scale = 1.0 / (10 * 0.25 + 1.0)  # farthest preview point: 2.5 m ahead + 1 m off track
    cos, sin = math.cos(heading), math.sin(heading)
    for k in range(10):
        px, py = walk_along(CORNER.points, 3.2 + 0.25 * (k + 1))
        forward = cos * (px - x) + sin * (py - y)
        left = -sin * (px - x) + cos * (py - y)
        assert observation[2 * k] == pytest.approx(forward * scale, abs=1e-6)
        assert observation[2 * k + 1] == pytest.approx(left * scale, abs=1e-6)
    expected_tail = [
        -0.3,  # cross-track error over the 1 m off-track distance
        0.4 / math.pi,  # heading error over pi
        math.tanh(-0.3 / 0.05),
        math.tanh(0.4 / 0.1),
        0.0,  # speed
        0.0,  # yaw rate
        1.0 - 3.2 / 7.0,  # remaining fraction
        0.0,  # previous action, 2 elements
        0.0,
        *[1.0] * 16,  # range readings at the maximum range: no walls
    ]
    np.testing.assert_allclose(observation[20:], expected_tail, atol=1e-6)


def test_one_step_reward_follows_the_documented_formula():
    env = PathFollowingEnv("diff_drive", "horizontal_line")
    env.reset(options={"start_pose": (2.0, 6.1, 0.0)})
    # Both wheels at 10 rad/s: 0.5 m/s straight ahead, 0.05 m in a step of 0.1 s.
    observation, reward, terminated, truncated, info = env.step(np.array([0.5, 0.5], np.float32))
    progress, cte, dt = 0.05, 0.1, 0.1
    action_change = 0.5**2  # the mean over both wheels of (0.5 - 0)^2
    expected = progress - 0.01 - (8.0 + 20.0 * cte) * cte * dt - 0.02 * action_change
    assert reward == pytest.approx(expected, abs=1e-12)
    assert info["cross_track_error"] == pytest.approx(cte)
    assert observation[24] == pytest.approx(0.5, abs=1e-6)  # speed over the 1 m/s top speed
    assert observation[-18:-16].tolist() == [0.5, 0.5]  # the previous action
    assert not terminated and not truncated


def test_peak_term_charges_each_new_worst_excursion_from_the_start_pose_once():
    # 0.1 m left of the line, heading 0.3 rad further left: each forward step takes the robot
    # 0.05 sin(0.3) m further off. Then it turns in place to -0.3 rad (0.1 rad a step) and
    # drives back towards the line: no new worst excursion, nothing charged.
    weight = 7.0
    runs = {}
    for w in (0.0, weight):
        env = PathFollowingEnv(
            "diff_drive", "horizontal_line", reward_weights={"peak_cross_track": w}
        )
        _, info = env.reset(options={"start_pose": (2.0, 6.1, 0.3)})
        errors, rewards = [abs(info["cross_track_error"])], []
        for action in [[0.5, 0.5]] * 4 + [[-0.5, 0.5]] * 6 + [[0.5, 0.5]] * 4:
            _, reward, terminated, truncated, info = env.step(np.array(action, np.float32))
            errors.append(abs(info["cross_track_error"]))
            rewards.append(reward)
            assert not terminated and not truncated
        runs[w] = (np.array(errors), np.array(rewards))
    errors, plain = runs[0.0]
    assert np.array_equal(errors, runs[weight][0])  # the term changes the reward only
    assert errors[0] == pytest.approx(0.1)
    assert errors[4] == pytest.approx(0.1 + 4 * 0.05 * math.sin(0.3))
    # By brute force: each step's growth of the running max, the start pose's included.
    peaks = np.maximum.accumulate(errors)
    expected = plain - weight * np.diff(peaks)
    np.testing.assert_allclose(runs[weight][1], expected, rtol=0, atol=1e-12)
    charged = plain - runs[weight][1]
    assert charged[:4].min() > 0 and np.all(charged[4:] < 1e-12)  # turned back: free
    assert charged.sum() == pytest.approx(weight * (errors.max() - errors[0]), abs=1e-12)


def test_named_columns_are_views_of_the_packed_arrays():
    core = PathFollowingEnv().core
    for packed, names in ((core.floats, FloatColumn), (core.ints, IntColumn)):
        for column, name in enumerate(names):
            packed[0, column] = column + 1
            assert getattr(core, name.name.lower())[0] == column + 1
    for column, name in enumerate(FlagColumn):
        core.flags[0, column] = True
        assert getattr(core, name.name.lower())[0]


def test_validate_actions_clips_a_copy_and_keeps_the_caller_array():
    raw = np.array([3.0, -0.25])
    clipped = validate_actions(raw, (2,))
    assert clipped.shape == (1, 2) and clipped.dtype == np.float64
    assert clipped.tolist() == [[1.0, -0.25]]
    assert raw.tolist() == [3.0, -0.25]
    batch = validate_actions(np.array([[2, -5], [0, 1]]), (2, 2))  # integers are numbers
    assert batch.tolist() == [[1.0, -1.0], [0.0, 1.0]]


@pytest.mark.parametrize(
    "bad",
    [np.array(["a", "b"]), np.array([True, False]), np.array([1j, 0.0]), [np.nan, 0.0]],
)
def test_validate_actions_rejects_non_numbers_and_non_finite_values(bad):
    with pytest.raises(ValueError, match="action"):
        validate_actions(bad, (2,))


@pytest.mark.parametrize(
    "env_id, kwargs",
    [
        ("mobile_envs/DiffDrive-Segments-v0", {}),  # open space: move, score, observe
        ("mobile_envs/Bicycle-Maze-v0", {}),  # the walls and the range sensor's rays too
        ("mobile_envs/Tricycle-Maze-v0", {"sensors": []}),  # the walls alone
        ("mobile_envs/Mecanum-Segments-Realistic-v0", {}),  # a delayed, lagged, slipping plant
    ],
)
def test_a_whole_step_in_one_call_gives_the_bits_of_the_calls_it_replaces(env_id, kwargs):
    fused, parts = (gym.make(env_id, **kwargs).unwrapped for _ in range(2))
    rng = np.random.default_rng(5)
    for episode in range(3):
        for env in (fused, parts):
            env.reset(seed=episode)
        # The one-call step is taken, not the general one it falls back to.
        assert not fused.core._senses
        for _ in range(400):
            width = fused.core.model.input_dim
            actions = validate_actions(rng.uniform(-1.5, 1.5, width), (width,))
            observation = fused.core.step_and_observe(actions, [fused.np_random])
            parts.core.step(actions, [parts.np_random])
            expected = parts.core.observe()
            assert observation.tobytes() == expected.tobytes()
            for name in ("state", "inputs", "floats", "ints", "flags", "readings"):
                assert getattr(fused.core, name).tobytes() == getattr(parts.core, name).tobytes()
            if fused.core.terminated[0] or fused.core.truncated[0]:
                break

"""The batched harness against the one-episode-at-a-time loop it replaced: the same episodes,
the same metrics (bit for bit for classical agents, to float32 rounding for policies)."""

import dataclasses
import json
import math
import pathlib

import gymnasium as gym
import numpy as np
import pytest
from harness_reference import CASES, episode_values, evaluate_one_at_a_time

from agents.controllers.base import ClassicalAgent
from agents.controllers.guidance import TricycleGuidance
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from agents.harness import batch
from agents.harness.evaluate import evaluate, run_episode
from agents.harness.policies import recorded_observation_settings
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.sim.config import CoreConfig

REFERENCE = json.loads(
    (pathlib.Path(__file__).parent / "data" / "harness_reference.json").read_text()
)
MODELS = pathlib.Path(__file__).resolve().parent.parent / "models"
NOISE = {"start_noise": (0.2, 0.3)}


@pytest.mark.parametrize(("name", "agent", "env_id", "env_kwargs", "episodes", "seed"), CASES)
def test_classical_agents_give_the_recorded_episodes_bit_for_bit(
    name, agent, env_id, env_kwargs, episodes, seed
):
    # Recorded with the sequential loop and the pure-Python laws (tests/harness_reference.py).
    result = evaluate(agent, env_id, episodes, seed=seed, **env_kwargs)
    assert episode_values(result) == REFERENCE[name]


@pytest.mark.parametrize("robots", [1, 3])
def test_robots_that_finish_take_the_next_seeds_then_wait(monkeypatch, robots):
    # Fewer robots than episodes: each robot drives several episodes, one after another, and
    # the episodes are still those of seeds 0..6 in order, bit for bit.
    name, agent, env_id, env_kwargs, episodes, seed = CASES[4]  # random paths, varied lengths
    monkeypatch.setattr("agents.harness.evaluate.MAX_ROBOTS", robots)
    result = evaluate(agent, env_id, episodes, seed=seed, **env_kwargs)
    assert episode_values(result) == REFERENCE[name]


def test_the_episode_log_keeps_every_measured_episode_whole():
    # Robots start and end episodes at random steps; the log keeps, grows and shifts its rows
    # (capacity 4) and must hand back exactly what was appended since each start.
    rng = np.random.default_rng(0)
    count = 5
    log = batch.EpisodeLog(count, capacity=4)
    written = [[] for _ in range(count)]  # poses since each robot's start
    errors_written = [[] for _ in range(count)]
    starts = rng.normal(size=(count, 3))
    log.start(np.arange(count), starts)
    for robot in range(count):
        written[robot].append(starts[robot])
    for _ in range(200):
        poses, errors = rng.normal(size=(count, 3)), rng.normal(size=count)
        log.append(poses, errors, np.ones(count, dtype=bool))
        for robot in range(count):
            written[robot].append(poses[robot])
            errors_written[robot].append(errors[robot])
        for robot in np.flatnonzero(rng.random(count) < 0.1):
            trajectory, episode_errors = log.episode(robot)
            np.testing.assert_array_equal(trajectory, written[robot])
            np.testing.assert_array_equal(episode_errors, errors_written[robot])
            fresh = rng.normal(size=(count, 3))
            log.start(np.array([robot]), fresh)
            written[robot], errors_written[robot] = [fresh[robot]], []
    assert len(log.poses) < 200  # rows no episode needs were dropped


def test_the_vector_env_takes_every_setting_of_the_single_env():
    # Every setting away from its default: a setting the harness did not pass on would make
    # its robots differ from the single env.
    env = PathFollowingEnv(
        "bicycle",
        "sharp_segments",
        model_params={"wheelbase": 1.3},
        dt=0.05,
        integrator="euler",
        goal_radius=0.2,
        max_cross_track=2.0,
        step_limit=77,
        start_noise=(0.1, 0.2),
        robot_radius=0.3,
        stall_time=None,
        reward_weights={"time": 0.5},
        localization="odometry",
        num_threads=1,
    )
    envs = batch.vector_env_like(env, 3)
    for item in dataclasses.fields(CoreConfig):
        if not item.init:
            continue  # derived from the others
        assert getattr(envs.config, item.name) == getattr(env.config, item.name), item.name
    envs.close()


def test_an_env_under_another_wrapper_runs_one_episode_at_a_time():
    class Halved(gym.ActionWrapper):
        def action(self, action):
            return 0.5 * np.asarray(action)

    env = Halved(gym.make("mobile_envs/DiffDrive-Lines-v0", max_episode_steps=30))
    result = evaluate(PurePursuit(), env, episodes=2, seed=4)
    bound = PurePursuit().bind(env)
    expected = [run_episode(bound, env, 4 + index) for index in range(2)]
    for got, want in zip(result.episodes, expected, strict=True):
        np.testing.assert_array_equal(got.trajectory, want.trajectory)
    plain = evaluate(PurePursuit(), "mobile_envs/DiffDrive-Lines-v0", 2, 4, max_episode_steps=30)
    assert not np.array_equal(result.episodes[0].trajectory, plain.episodes[0].trajectory)


@pytest.mark.parametrize(
    "agent",
    [
        PurePursuit(mode="textbook"),
        RegulatedPurePursuit(speed=0.7),
        TricycleGuidance.from_roots(0.8, 1.5, 0.7, speed=-0.3, point="O"),
    ],
)
def test_classical_agents_equal_the_sequential_loop_on_more_settings(agent):
    env_id = "mobile_envs/Tricycle-Segments-Beacons-v0"
    expected = evaluate_one_at_a_time(agent, env_id, 5, seed=11, **NOISE)
    result = evaluate(agent, env_id, 5, seed=11, **NOISE)
    for got, want in zip(result.episodes, expected, strict=True):
        assert (got.steps, got.completed, got.mean_abs_cte) == (
            want["steps"],
            want["completed"],
            want["mean_abs_cte"],
        )
        np.testing.assert_array_equal(got.trajectory, want["trajectory"])


# ---------------------------------------------------------------- policies


def shipped_policy(name):
    pytest.importorskip("stable_baselines3", reason="policies need the train extra")
    from agents.harness.policies import load_policy

    return load_policy(MODELS / name)


#: Shipped policies on envs where their closed loops keep a float32 rounding difference of
#: the actions small; see the next test for one that does not.
STABLE_POLICY_RUNS = [
    ("constant_velocity_ppo.zip", "mobile_envs/ConstantVelocity-Lines-v0", 6),
    ("diffdrive_ppo.zip", "mobile_envs/DiffDrive-Maze-v0", 3),
    ("diffdrive_ppo.zip", "mobile_envs/DiffDrive-Random-v0", 12),
    ("tricycle_ppo.zip", "mobile_envs/Tricycle-Maze-v0", 3),
]


@pytest.mark.parametrize(("model", "env_id", "episodes"), STABLE_POLICY_RUNS)
def test_policies_give_the_sequential_metrics_within_1e_6(model, env_id, episodes):
    policy = shipped_policy(model)
    # The reference loop makes its env as told: with the sensors the policy was trained with
    # (the constant-velocity policy sees its last commands), which the harness adds itself.
    own_settings = recorded_observation_settings(policy)
    expected = evaluate_one_at_a_time(policy, env_id, episodes, seed=0, **NOISE, **own_settings)
    result = evaluate(policy, env_id, episodes, seed=0, **NOISE)
    for got, want in zip(result.episodes, expected, strict=True):
        assert (got.steps, got.completed, got.collision) == (
            want["steps"],
            want["completed"],
            want["collision"],
        )
        for key in ("mean_abs_cte", "max_abs_cte", "rms_cte"):
            assert getattr(got, key) == pytest.approx(want[key], abs=1e-6, rel=0)


def test_a_policy_predicts_for_all_robots_what_it_predicts_for_each():
    # One batch: every robot's action within float32 rounding of predicting it alone (the
    # batch adds the products in another order, so the bits may differ: by up to ~1e-6 after
    # three layers, measured).
    policy = shipped_policy("bicycle_ppo.zip")
    envs = gym.make_vec("mobile_envs/Bicycle-Random-v0", num_envs=20)
    observations, _ = envs.reset(seed=0)
    agent = batch.PolicyBatchAgent(policy, 20)
    robots = np.arange(20)
    for _ in range(30):
        actions = agent.act(robots, observations, envs.unwrapped.believed_states)
        alone = np.array([policy.predict(row, deterministic=True)[0] for row in observations])
        np.testing.assert_allclose(actions, alone, rtol=0, atol=1e-5)
        observations = envs.step(actions)[0]
    envs.close()


def test_a_policy_episode_does_not_depend_on_the_episodes_beside_it():
    # Every prediction has at least MIN_POLICY_BATCH rows, where torch gives each row the
    # same bits in any batch (one thread): 3 episodes are the first 3 of 10.
    torch = pytest.importorskip("torch", reason="policies need the train extra")
    policy = shipped_policy("bicycle_ppo.zip")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        few = evaluate(policy, "mobile_envs/Bicycle-SharpSegments-v0", 3, seed=0, **NOISE)
        many = evaluate(policy, "mobile_envs/Bicycle-SharpSegments-v0", 10, seed=0, **NOISE)
    finally:
        torch.set_num_threads(threads)
    for got, want in zip(few.episodes, many.episodes[:3], strict=True):
        np.testing.assert_array_equal(got.trajectory, want.trajectory)


def test_the_sb3_fast_path_is_predict():
    policy = shipped_policy("tricycle_ppo.zip")
    rng = np.random.default_rng(3)
    observations = rng.uniform(-1, 1, (40, *policy.observation_space.shape)).astype(np.float32)
    agent = batch.PolicyBatchAgent(policy, 40)
    robots = np.arange(40)
    expected, _ = policy.predict(observations, deterministic=True)
    np.testing.assert_array_equal(agent.act(robots, observations, np.zeros((40, 4))), expected)


def test_policy_episodes_are_reproducible():
    policy = shipped_policy("diffdrive_ppo.zip")
    first = evaluate(policy, "mobile_envs/DiffDrive-Random-v0", 5, seed=2)
    second = evaluate(policy, "mobile_envs/DiffDrive-Random-v0", 5, seed=2)
    for a, b in zip(first.episodes, second.episodes, strict=True):
        np.testing.assert_array_equal(a.trajectory, b.trajectory)
        assert math.isclose(a.mean_abs_cte, b.mean_abs_cte, rel_tol=0, abs_tol=0)


class HeadForTheGoal(ClassicalAgent):
    """A law written for one robot only (reset and inputs): turn towards the path's goal and
    drive at 0.5 m/s, slowing down as the heading error grows."""

    def reset(self, path):
        self.goal = path.goal.copy()
        self.steps = 0  # state between calls, as a law for one robot keeps it

    def inputs(self, state, model, dt):
        self.steps += 1
        bearing = math.atan2(self.goal[1] - state[1], self.goal[0] - state[0]) - state[2]
        bearing = math.atan2(math.sin(bearing), math.cos(bearing))
        v = 0.5 * max(math.cos(bearing), 0.0) * min(1.0, self.steps / 10)
        return model.inputs_for(state, v, 2.0 * bearing, dt)


def test_a_law_written_for_one_robot_runs_a_robot_at_a_time_in_the_harness():
    env_id = "mobile_envs/DiffDrive-Random-v0"
    expected = evaluate_one_at_a_time(HeadForTheGoal(), env_id, 6, seed=3)
    result = evaluate(HeadForTheGoal, env_id, 6, seed=3)
    for got, want in zip(result.episodes, expected, strict=True):
        np.testing.assert_array_equal(got.trajectory, want["trajectory"])
        assert got.mean_abs_cte == want["mean_abs_cte"]
    assert len({episode.steps for episode in result.episodes}) > 1  # episodes end apart


def test_a_law_must_be_written_for_many_robots_or_for_one():
    class Nothing(ClassicalAgent):
        pass

    with pytest.raises(TypeError, match="batch\\(\\), or reset\\(\\) and inputs\\(\\)"):
        evaluate(Nothing(), "mobile_envs/DiffDrive-Lines-v0", 1)


def test_a_bound_law_for_one_robot_shows_each_robots_copy():
    env = gym.make_vec("mobile_envs/DiffDrive-Lines-v0", num_envs=2)
    bound = HeadForTheGoal().bind(env)
    observations, _ = env.reset(seed=0)
    bound.predict(observations)
    assert [robot.steps for robot in bound.robots] == [1, 1]
    with pytest.raises(AttributeError, match="arrays"):
        _ = PurePursuit().bind(env).robots
    env.close()

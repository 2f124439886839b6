"""MPPI: its rollouts are the env's motion, its randomness is the episode's, its batches are
its robots, its critics and filters are what the docstring says."""

import math

import gymnasium as gym
import numpy as np
import pytest

import mobile_envs  # noqa: F401  (registers the ids)
from agents import MPPI
from agents.controllers import mppi_kernels as kernels
from agents.controllers.mppi import episode_stream, primitive_actions
from agents.harness.batch import run_episodes, vector_env_like
from agents.harness.compare import CLASSICAL_AGENTS
from agents.harness.evaluate import evaluate, run_episode
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.robots import INTEGRATORS, MODELS
from mobile_envs.tracks.sets import Track
from mobile_envs.world.maze import Maze
from mobile_envs.world.paths import Path, course_path

MODEL_NAMES = sorted(MODELS)
#: Small but real settings, so the tests compile and run quickly.
QUICK = {"samples": 48, "horizon": 10, "manoeuvres": 8}


def env_model(name):
    return MODELS[name](**MODELS[name].env_defaults)


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("name", MODEL_NAMES)
def test_the_rollout_is_the_envs_motion(name, integrator):
    """A sampled action sequence driven through the env and through MPPI's rollout passes
    through the same states (the env takes float32 actions: the rollout gets those)."""
    env = PathFollowingEnv(name, "random", integrator=integrator, max_cross_track=100.0)
    env.reset(seed=3)
    agent = MPPI(**QUICK)
    planner = agent.planner(env.model, env.dt, integrator=integrator)
    noise = np.empty((1, 40, env.model.input_dim))
    kernels.draw_noise(episode_stream(7, env.path, env.state), 0.5, noise)
    actions = np.clip(0.6 * noise[0], -1.0, 1.0).astype(np.float32)
    start = env.state
    predicted = planner.rollout(start, actions.astype(np.float64))
    visited = [start]
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        assert not (terminated or truncated)
        visited.append(env.state)
    np.testing.assert_allclose(predicted, np.array(visited), rtol=0.0, atol=1e-9)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_the_prediction_over_the_delay_and_the_lag_is_the_plants_motion(name):
    """With a plant of two steps' delay and a lag (no parameter errors, no slip), the env's
    true robot passes through the states MPPI predicts: first over the two commands in the
    delay line (zeros at the start, as the plant's), then under the actions, all through the
    lag."""
    plant = {"delay": 0.2, "time_constant": 0.15}
    env = PathFollowingEnv(name, "random", plant=plant, max_cross_track=100.0)
    env.reset(seed=4)
    planner = MPPI(**QUICK).bind(env).planner
    assert planner.delay_steps == 2 and 0.0 < planner.lag < 1.0
    noise = np.empty((1, 30, env.model.input_dim))
    kernels.draw_noise(episode_stream(2, env.path, env.state), 0.5, noise)
    actions = np.clip(0.7 * noise[0], -1.0, 1.0).astype(np.float32)
    predicted = planner.rollout(env.state, actions[:-2].astype(np.float64))
    visited = [env.state]
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        assert not (terminated or truncated)
        visited.append(env.state)
    np.testing.assert_allclose(predicted, np.array(visited), rtol=0.0, atol=1e-9)


def test_the_planner_plans_from_the_state_predicted_over_the_delay():
    """A step's costs under a delay are those of the same samples rolled out, without the
    delay, from the state the delayed commands lead to (with the lag state they leave)."""
    model = env_model("diff_drive")
    path = Path([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]])
    delayed = MPPI(**QUICK, delay=0.3, time_constant=0.1).planner(model, 0.1)
    immediate = MPPI(**QUICK, delay=0.0, time_constant=0.1).planner(model, 0.1)
    delayed.restart([0], [path])
    immediate.restart([0], [path])
    delayed.pending[0] = [[1.0, 2.0], [3.0, 3.5], [2.0, 1.0]]
    delayed.applied[0] = [0.5, 0.25]
    state = np.array([[0.1, -0.05, 0.2]])
    through = delayed.rollout(state[0], np.zeros((0, 2)), delayed.pending[0], delayed.applied[0])
    immediate.applied[0] = delayed.applied[0]
    for command in delayed.pending[0]:
        immediate.applied[0] += immediate.lag * (command - immediate.applied[0])
    samples = np.random.default_rng(0).uniform(-1, 1, (6, 10, 2))
    np.testing.assert_array_equal(
        delayed.score(0, state, samples), immediate.score(0, through[-1:], samples)
    )


def run_episode_actions(agent, env_id, seed, steps, **env_kwargs):
    env = gym.make(env_id, **env_kwargs)
    bound = agent.bind(env)
    observation, _ = env.reset(seed=seed)
    actions = []
    for _ in range(steps):
        action, _ = bound.predict(observation)
        actions.append(action)
        observation, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    env.close()
    return np.array(actions)


def test_the_same_seed_gives_the_same_trajectory_and_another_seed_another():
    first = evaluate(MPPI(**QUICK), "mobile_envs/Bicycle-Segments-v0", 2, seed=5)
    again = evaluate(MPPI(**QUICK), "mobile_envs/Bicycle-Segments-v0", 2, seed=5)
    for one, other in zip(first.episodes, again.episodes, strict=True):
        np.testing.assert_array_equal(one.trajectory, other.trajectory)
    reseeded = run_episode_actions(MPPI(**QUICK, seed=1), "mobile_envs/Bicycle-Segments-v0", 5, 30)
    original = run_episode_actions(MPPI(**QUICK), "mobile_envs/Bicycle-Segments-v0", 5, 30)
    assert not np.array_equal(reseeded, original)


def test_each_episode_draws_from_its_own_generator():
    """The noise depends on the agent's seed, the episode's path and its start, not on what
    ran before."""
    path, other = course_path("segments"), course_path("sharp_segments")
    start = np.array([0.0, 0.1, 0.2])
    first = episode_stream(0, path, start)
    np.testing.assert_array_equal(first, episode_stream(0, path, start.copy()))
    assert not np.array_equal(first, episode_stream(1, path, start))
    assert not np.array_equal(first, episode_stream(0, other, start))
    assert not np.array_equal(first, episode_stream(0, path, start + np.array([0.0, 0.0, 1e-12])))


@pytest.mark.parametrize(
    "env_id", ["mobile_envs/Tricycle-Random-v0", "mobile_envs/Mecanum-Random-v0"]
)
def test_a_batch_equals_its_robots_planned_alone(env_id):
    """A vector env of robots on different tracks (random paths and mazes), planned in one
    call, takes every robot's actions bit for bit as a single env planned alone does."""
    count, steps, seed = 5, 25, 11
    envs = gym.make_vec(env_id, num_envs=count)
    batched = MPPI(**QUICK).bind(envs)
    observations, _ = envs.reset(seed=seed)
    singles = [gym.make(env_id) for _ in range(count)]
    alone = [MPPI(**QUICK).bind(env) for env in singles]
    single_observations = [env.reset(seed=seed + i)[0] for i, env in enumerate(singles)]
    assert any(env.unwrapped.track.maze is not None for env in singles)
    for _ in range(steps):
        actions, _ = batched.predict(observations)
        for i, env in enumerate(singles):
            action, _ = alone[i].predict(single_observations[i])
            np.testing.assert_array_equal(actions[i], action)
            single_observations[i], *_ = env.step(action)
        observations, *_ = envs.step(actions)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_the_harness_batch_equals_its_episodes_run_one_at_a_time(name):
    """The batched harness (3 robots for 5 episodes: robots that finish take the next seed
    while the others drive on, and only the robots still driving are planned) gives every
    episode the trajectory it has run alone in a single env, bit for bit; with start noise
    and a plant with a delay, for every model."""
    env_id = f"mobile_envs/{MODELS[name].env_id}-Lines-v0"
    kwargs = {"start_noise": (0.2, 0.3), "plant": {"delay": 0.1, "time_constant": 0.1}}
    single = gym.make(env_id, **kwargs)
    envs = vector_env_like(single.unwrapped, 3)
    batched = run_episodes(MPPI(**QUICK), envs, 5, seed=7)
    for index, record in enumerate(batched):
        alone = run_episode(MPPI(**QUICK).bind(single), single, 7 + index)
        np.testing.assert_array_equal(record.trajectory, alone.trajectory)
    assert len({record.trajectory.shape[0] for record in batched}) > 1


def test_the_planner_reads_the_believed_state():
    """With a localization, the bound agent plans from the estimate, as a twin planner fed
    the env's believed states does, and not from the truth."""
    env = PathFollowingVectorEnv(2, "diff_drive", "segments", localization="odometry+beacons")
    bound = MPPI(**QUICK).bind(env)
    twin = MPPI(**QUICK).planner(env.model, env.dt, 2)
    truth = MPPI(**QUICK).planner(env.model, env.dt, 2)
    observations, _ = env.reset(seed=0)
    twin.restart([0, 1], env.tracks)
    truth.restart([0, 1], env.tracks)
    differed = False
    for _ in range(15):
        actions, _ = bound.predict(observations)
        expected = twin.act(env.believed_states)
        np.testing.assert_array_equal(actions, expected.astype(np.float32))
        differed |= not np.array_equal(truth.act(env.states), expected)
        observations, *_ = env.step(actions)
    assert not np.array_equal(env.believed_states, env.states)
    assert differed


def test_the_critics_score_a_straight_run_as_documented():
    """On a straight path, a robot driving along it at a constant speed pays nothing but
    the arc length it leaves: - progress_weight x distance / (top speed x T dt)."""
    model = env_model("constant_velocity")
    agent = MPPI(samples=8, horizon=10, smoothing=False, goal_distance=0.0)
    planner = agent.planner(model, 0.1)
    planner.restart([0], [Path([[0.0, 0.0], [20.0, 0.0]])])
    planner.histories[0, -1] = [0.5, 0.0, 0.0]
    state = np.array([[1.0, 0.0, 0.0]])
    speeds = np.array([0.5, 1.0, 0.0])
    actions = np.zeros((3, 10, 3))
    actions[:, :, 0] = speeds[:, np.newaxis]
    costs = planner.score(0, state, actions)
    distance = speeds * model.top_speed * 10 * 0.1
    expected = -agent.progress_weight * distance / (model.top_speed * 10 * 0.1)
    # The action change from the last applied one (0.5) counts once, at the first step.
    expected += agent.smoothness_weight * (speeds - 0.5) ** 2 / 10
    np.testing.assert_allclose(costs, expected, rtol=1e-12, atol=1e-12)


def test_a_rollout_that_hits_a_wall_pays_the_collision_cost():
    maze = Maze(rows=3, cols=3, cell_size=1.5, seed=1)
    track = Track(maze.route((0, 0), (2, 2)), maze)
    model = env_model("diff_drive")
    agent = MPPI(samples=8, horizon=10)
    planner = agent.planner(model, 0.1)
    planner.restart([0], [track])
    start = np.array([0.75, 0.75, -math.pi / 2])  # facing the maze's outer wall, 0.75 m off
    sequences = np.zeros((2, 10, 2))
    sequences[0] = 1.0  # full speed ahead; sequence 1 stands still
    costs = planner.score(0, start[np.newaxis], sequences)
    end = planner.rollout(start, sequences[0])[-1]
    assert maze.collides(end[:2], 0.25)
    assert costs[0] - costs[1] > 0.9 * agent.collision_cost


def brute_force_wall_distance(maze, x, y):
    walls = maze.walls
    best = math.inf
    for (x0, y0), (x1, y1) in walls:
        dx, dy = x1 - x0, y1 - y0
        fraction = min(max(((x - x0) * dx + (y - y0) * dy) / (dx * dx + dy * dy), 0.0), 1.0)
        best = min(best, math.hypot(x - x0 - fraction * dx, y - y0 - fraction * dy))
    return best


def test_the_wall_distance_is_the_distance_to_the_nearest_wall_segment():
    maze = Maze(rows=5, cols=6, cell_size=1.5, seed=4, origin=(-2.0, 1.0))
    rng = np.random.default_rng(2)
    reach = 0.6
    for x, y in rng.uniform([-2.0, 1.0], [7.0, 8.5], size=(400, 2)):
        got = kernels.wall_distance(
            x, y, reach, maze.vertical_walls, maze.horizontal_walls, maze.rows, maze.cols,
            -2.0, 1.0, 1.5,
        )  # fmt: skip
        assert got == pytest.approx(min(brute_force_wall_distance(maze, x, y), reach), abs=1e-12)
    outside = kernels.wall_distance(
        -2.5, 2.0, reach, maze.vertical_walls, maze.horizontal_walls, 5, 6, -2.0, 1.0, 1.5
    )
    assert outside == 0.0


def test_savitzky_golay_keeps_a_quadratic_and_reaches_into_the_history():
    """Quadratic 9-point Savitzky-Golay weights reproduce any quadratic exactly; at the
    start the window reads the applied history, at the end it repeats the last action."""
    t = np.arange(-4, 20, dtype=np.float64)
    quadratic = 0.001 * t**2 - 0.02 * t + 0.3
    history = quadratic[:4, np.newaxis].copy()
    sequence = quadratic[4:, np.newaxis].copy()
    smoothed = np.empty_like(sequence)
    kernels._savitzky_golay(sequence, history, smoothed)
    np.testing.assert_allclose(sequence[:-4, 0], quadratic[4:-4], atol=1e-12)
    padded = np.concatenate([quadratic, np.full(4, quadratic[-1])])
    expected_last = np.dot(kernels.SAVITZKY_GOLAY, padded[-9:])
    assert sequence[-1, 0] == pytest.approx(expected_last, abs=1e-12)


def test_the_noise_is_standard_normal_with_the_asked_correlation():
    noise = np.empty((400, 50, 2))
    kernels.draw_noise(episode_stream(3, course_path("segments"), np.zeros(3)), 0.8, noise)
    assert abs(noise.mean()) < 0.02
    assert noise.std() == pytest.approx(1.0, abs=0.02)
    lag_one = np.mean(noise[:, 1:] * noise[:, :-1])
    assert lag_one == pytest.approx(0.8, abs=0.02)


def test_the_primitives_are_the_corners_and_the_axes():
    primitives = primitive_actions(3)
    assert primitives.shape == (14, 3)
    assert {tuple(row) for row in primitives[:8]} == {
        (a, b, c) for a in (-1.0, 1.0) for b in (-1.0, 1.0) for c in (-1.0, 1.0)
    }
    np.testing.assert_array_equal(np.abs(primitives[8:]).sum(axis=1), 1.0)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_every_model_reaches_the_goal_of_a_course_line(name):
    env_id = f"mobile_envs/{MODELS[name].env_id}-Lines-v0"
    result = evaluate(MPPI(), env_id, 1, seed=0)
    assert result.summary["completion_rate"] == 1.0


def test_the_agent_steers_without_an_env():
    path = Path([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0]])
    model = env_model("diff_drive")
    agent = MPPI(**QUICK)
    with pytest.raises(RuntimeError, match="reset"):
        agent.inputs(np.zeros(3), model, 0.1)
    agent.reset(path)
    state = np.zeros(3)
    for _ in range(80):
        state = model.step(state, agent.inputs(state, model, 0.1), 0.1)
    assert math.dist(state[:2], (3.0, 3.0)) < 1.0


def test_mppi_is_a_compare_agent():
    assert isinstance(CLASSICAL_AGENTS["mppi"](), MPPI)


@pytest.mark.parametrize(
    ("arguments", "name"),
    [
        ({"samples": 1}, "samples"),
        ({"samples": 2.5}, "samples"),
        ({"horizon": 0}, "horizon"),
        ({"temperature": 0.0}, "temperature"),
        ({"temperature": math.nan}, "temperature"),
        ({"noise_std": 0.0}, "noise_std"),
        ({"noise_correlation": 1.0}, "noise_correlation"),
        ({"path_weight": -1.0}, "path_weight"),
        ({"progress_weight": math.inf}, "progress_weight"),
        ({"heading_weight": "1"}, "heading_weight"),
        ({"wall_margin": 0.0}, "wall_margin"),
        ({"collision_cost": 1e300}, "collision_cost"),
        ({"manoeuvres": -1}, "manoeuvres"),
        ({"manoeuvres": 1.5}, "manoeuvres"),
        ({"manoeuvres": False}, "manoeuvres"),
        ({"smoothing": 1}, "smoothing"),
        ({"primitives": "yes"}, "primitives"),
        ({"seed": -1}, "seed"),
        ({"seed": True}, "seed"),
        ({"delay": -0.1}, "delay"),
        ({"delay": "0.1"}, "delay"),
        ({"time_constant": math.inf}, "time_constant"),
    ],
)
def test_bad_parameters_are_refused_by_name(arguments, name):
    with pytest.raises(ValueError, match=name):
        MPPI(**arguments)


def test_a_planner_refuses_what_it_cannot_plan():
    agent = MPPI(**QUICK)
    with pytest.raises(ValueError, match="limits"):
        agent.planner(MODELS["diff_drive"](), 0.1)
    model = env_model("diff_drive")
    with pytest.raises(ValueError, match="integrator"):
        agent.planner(model, 0.1, integrator="verlet")
    with pytest.raises(ValueError, match="dt"):
        agent.planner(model, 0.0)
    planner = agent.planner(model, 0.1, 2)
    with pytest.raises(RuntimeError, match="restart"):
        planner.act(np.zeros((2, 3)))
    planner.restart([0, 1], [course_path("segments"), Track(course_path("horizontal_line"))])
    with pytest.raises(ValueError, match="robot indices"):
        planner.act(np.zeros((2, 3)), [2])
    with pytest.raises(ValueError, match="shape"):
        planner.act(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="NaN"):
        planner.act(np.full((2, 3), np.nan))
    with pytest.raises(ValueError, match="robot"):
        planner.restart([2], [course_path("segments")])
    with pytest.raises(ValueError, match="delay must be a multiple"):
        MPPI(**QUICK, delay=0.15).planner(model, 0.1)

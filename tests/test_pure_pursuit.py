"""PurePursuit against the course's MATLAB numbers, and RegulatedPurePursuit on every course."""

import inspect
import math

import numpy as np
import pytest

from agents.controllers.pure_pursuit import (
    ForwardProjection,
    PurePursuit,
    RegulatedPurePursuit,
)
from agents.harness.evaluate import evaluate
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.robots import Bicycle, DifferentialDrive, Tricycle
from mobile_envs.world.paths import LINE_NAMES, Path, course_path

# Steps to the goal of an independent re-implementation of MATLAB's controllerPurePursuit with
# the course's settings: unbounded wheel speeds, dt 0.1 s, start heading 0, 0.6 m/s, 2 rad/s,
# lookahead 0.3 m, goal radius 0.1 m, one step per controller call until within the radius.
MATLAB_STEPS = [
    ("segments", "euler", 285),
    ("segments", "exact", 282),
    ("sharp_segments", "euler", 527),
]
GOAL_RADIUS = 0.1


@pytest.mark.parametrize(("path_name", "integrator", "steps"), MATLAB_STEPS)
def test_core_reaches_the_goal_in_matlabs_number_of_steps(path_name, integrator, steps):
    path = course_path(path_name)
    controller = PurePursuit(lookahead=0.3, speed=0.6, max_angular_speed=2.0, mode="matlab")
    controller.reset(path)
    model = DifferentialDrive()
    pose = np.array(path.start_pose)
    count = 0
    while math.dist(pose[:2], path.goal) > GOAL_RADIUS and count < 2 * steps:
        v, omega = controller.twist(pose)
        pose = model.step(pose, model.inputs_for(pose, v, omega), 0.1, integrator)
        count += 1
    assert count == steps


@pytest.mark.parametrize(("path_name", "integrator", "steps"), MATLAB_STEPS)
def test_env_reaches_the_goal_in_matlabs_number_of_steps(path_name, integrator, steps):
    env = PathFollowingEnv(
        "diff_drive",
        path_name,
        model_params={"max_wheel_speed": 1000.0},
        integrator=integrator,
        max_cross_track=10.0,
    )
    agent = PurePursuit.for_env(env)
    observation, _ = env.reset(seed=0)
    terminated = truncated = False
    while not (terminated or truncated):
        action, _ = agent.predict(observation)
        observation, _, terminated, truncated, info = env.step(action)
    assert info["is_success"]
    assert env.elapsed_steps == steps


@pytest.mark.parametrize("model", ["constant_velocity", "diff_drive", "bicycle", "tricycle"])
@pytest.mark.parametrize("line", LINE_NAMES)
@pytest.mark.parametrize("mode", ["matlab", "textbook"])
def test_an_aligned_start_on_a_line_stays_on_it(model, line, mode):
    path = course_path(line)
    along = (*path.points[0], float(path.segment_headings[0]))
    env = PathFollowingEnv(model, line)
    agent = PurePursuit.for_env(env, mode=mode)
    observation, info = env.reset(seed=0, options={"start_pose": along})
    terminated = truncated = False
    while not (terminated or truncated):
        action, _ = agent.predict(observation)
        observation, _, terminated, truncated, info = env.step(action)
        assert abs(info["cross_track_error"]) < 1e-9
    assert info["is_success"]


def test_the_projection_never_moves_back_along_its_segment():
    projection = ForwardProjection(Path([[0, 0], [10, 0]]))
    assert projection.update((4.0, 1.0), search_distance=0.3) == (4.0, 0.0)
    assert projection.update((2.0, 1.0), search_distance=0.3) == (4.0, 0.0)


def test_the_first_call_searches_the_whole_path_later_calls_only_ahead():
    # Two parallel legs; the robot sits by the second one.
    path = Path([[0, 0], [10, 0], [10, 2], [0, 2]])
    projection = ForwardProjection(path)
    assert projection.update((3.0, 1.9), search_distance=0.3) == (3.0, 2.0)
    assert projection.segment == 2
    projection = ForwardProjection(path)
    projection.update((0.0, 0.0), search_distance=0.3)
    assert projection.update((3.0, 1.9), search_distance=0.3) == (3.0, 0.0)


def test_the_lookahead_point_walks_round_corners_and_stops_at_the_goal():
    projection = ForwardProjection(Path([[0, 0], [1, 0], [1, 1]]))
    projection.update((0.5, 0.0), search_distance=0.3)
    assert projection.point_ahead(0.3) == pytest.approx((0.8, 0.0))
    assert projection.point_ahead(0.7) == pytest.approx((1.0, 0.2))
    assert projection.point_ahead(5.0) == (1.0, 1.0)


def test_matlab_mode_turns_at_one_radian_per_second_when_the_path_lies_behind():
    path = Path([[0, 0], [-5, 0]])
    matlab, textbook = PurePursuit(mode="matlab"), PurePursuit(mode="textbook")
    matlab.reset(path)
    textbook.reset(path)
    assert matlab.twist((0.0, 0.0, 0.0)) == (0.6, 1.0)
    assert textbook.twist((0.0, 0.0, 0.0))[1] == pytest.approx(0.0, abs=1e-12)


def test_textbook_yaw_rate_is_the_matlab_one_times_the_speed():
    path = course_path("segments")
    matlab = PurePursuit(speed=0.4, max_angular_speed=100.0)
    textbook = PurePursuit(speed=0.4, max_angular_speed=100.0, mode="textbook")
    pose = (2.1, 1.2, 2.0)
    for controller in (matlab, textbook):
        controller.reset(path)
    v, omega = matlab.twist(pose)
    assert textbook.twist(pose) == (v, pytest.approx(0.4 * omega))


def test_yaw_rate_saturates_at_the_limit():
    controller = PurePursuit(max_angular_speed=2.0)
    controller.reset(Path([[0, 0], [0, 5]]))
    assert controller.twist((0.0, 0.0, 0.0)) == (0.6, 2.0)


@pytest.mark.parametrize("env_model", ["diff_drive", "bicycle"])
@pytest.mark.parametrize("paths", ["segments", "sharp_segments", "maze"])
def test_regulated_pure_pursuit_completes_the_courses_and_the_maze(env_model, paths):
    env = PathFollowingEnv(env_model, paths)
    summary = evaluate(RegulatedPurePursuit(), env, episodes=1).summary
    assert summary["completion_rate"] == 1.0
    assert summary["collision_rate"] == 0.0


def test_regulated_pure_pursuit_rotates_in_place_towards_a_path_behind():
    controller = RegulatedPurePursuit(max_angular_accel=100.0)
    controller.reset(Path([[0, 0], [-5, 0]]))
    v, omega = controller.twist((0.0, 0.0, 0.1), turns_in_place=True)
    assert (v, omega) == (0.0, controller.rotate_angular_speed)


def test_the_rotation_ramps_up_at_the_angular_acceleration_limit():
    controller = RegulatedPurePursuit(max_angular_accel=3.2)
    controller.reset(Path([[0, 0], [-5, 0]]))
    rates = [controller.twist((0.0, 0.0, 0.1), dt=0.1)[1] for _ in range(8)]
    assert rates[:5] == pytest.approx([0.32, 0.64, 0.96, 1.28, 1.6])
    assert rates[5:] == pytest.approx([1.8] * 3)


def test_regulated_pure_pursuit_reverses_a_car_towards_a_path_behind():
    controller = RegulatedPurePursuit()
    controller.reset(Path([[0, 0], [-5, 0]]))
    # Path behind on the left (bearing near +pi): back up turning the heading left.
    v, omega = controller.twist((0.0, 0.0, 0.1), turns_in_place=False)
    assert v == -controller.reverse_speed
    assert omega > 0.0
    assert Bicycle().twist(np.zeros(3), Bicycle().inputs_for(np.zeros(3), v, omega))[1] > 0.0


def test_speed_drops_on_tight_arcs_but_not_below_the_floor():
    controller = RegulatedPurePursuit(min_radius=0.9, min_regulated_speed=0.25, speed=0.9)
    controller.reset(Path([[0, 0], [20, 0]]))
    assert controller.twist((5.0, 0.0, 0.0))[0] == 0.9
    # Lookahead point 0.3 m ahead, 0.1 m aside: radius (0.09 + 0.01) / 0.2 = 0.5 m.
    controller.reset(Path([[0, 0.1], [20, 0.1]]))
    v, omega = controller.twist((5.0, 0.0, 0.0))
    assert v == pytest.approx(0.9 * 0.5 / 0.9)
    assert omega == pytest.approx(v / 0.5)
    strict = RegulatedPurePursuit(min_radius=2.0, min_regulated_speed=0.25, speed=0.9)
    strict.reset(Path([[0, 0.1], [20, 0.1]]))
    assert strict.twist((5.0, 0.0, 0.0))[0] == 0.25


def test_speed_drops_near_the_goal_but_not_below_the_approach_floor():
    controller = RegulatedPurePursuit(approach_distance=0.6, min_approach_speed=0.05)
    controller.reset(Path([[0, 0], [10, 0]]))
    assert controller.twist((9.7, 0.0, 0.0))[0] == pytest.approx(0.9 * 0.3 / 0.6)
    controller.reset(Path([[0, 0], [10, 0]]))
    assert controller.twist((9.99, 0.0, 0.0))[0] == 0.05


def test_only_robots_with_a_tight_turn_rotate_in_place():
    assert DifferentialDrive().min_turning_radius == 0.0
    assert Bicycle(max_steering=math.pi / 4).min_turning_radius == pytest.approx(1.0)
    assert Tricycle().min_turning_radius == pytest.approx(1.0 / math.tan(math.radians(85)))


@pytest.mark.parametrize("agent", [PurePursuit(), RegulatedPurePursuit()])
def test_a_vector_env_of_four_gets_the_actions_of_four_single_envs(agent):
    settings = {
        "model": "bicycle",
        "paths": "lines",
        "start_noise": (0.3, 0.5),
        "step_limit": 40,
    }
    vector = PathFollowingVectorEnv(4, **settings)
    singles = [PathFollowingEnv(**settings) for _ in range(4)]
    vector_agent = agent.bind(vector)
    single_agents = [agent.bind(env) for env in singles]
    observations, _ = vector.reset(seed=3)
    single_observations = [env.reset(seed=3 + index)[0] for index, env in enumerate(singles)]
    needs_reset = np.zeros(4, dtype=bool)
    compared = 0
    for _ in range(100):  # two and a half 40-step episodes: autoresets included
        actions, _ = vector_agent.predict(observations)
        assert actions.shape == (4, 2)
        for index, env in enumerate(singles):
            if needs_reset[index]:  # the vector env ignores this robot's action and resets it
                single_observations[index], _ = env.reset()
                continue
            action, _ = single_agents[index].predict(single_observations[index])
            np.testing.assert_array_equal(action, actions[index])
            single_observations[index] = env.step(action)[0]
            compared += 1
        observations, _, terminated, truncated, _ = vector.step(actions)
        needs_reset = terminated | truncated
    assert compared > 350


def test_episode_start_restarts_the_projection():
    env = PathFollowingEnv("diff_drive", "segments")
    agent = PurePursuit.for_env(env)
    observation, _ = env.reset(seed=0)
    first, _ = agent.predict(observation, episode_start=np.array([True]))
    for _ in range(30):
        observation = env.step(agent.predict(observation)[0])[0]
    observation, _ = env.reset(seed=0)
    again, _ = agent.predict(observation, episode_start=np.array([True]))
    np.testing.assert_array_equal(first, again)


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="mode"):
        PurePursuit(mode="matlib")
    with pytest.raises(ValueError, match="lookahead"):
        PurePursuit(lookahead=0.0)
    with pytest.raises(ValueError, match="min_lookahead"):
        RegulatedPurePursuit(min_lookahead=1.0, max_lookahead=0.5)
    with pytest.raises(RuntimeError, match="reset"):
        PurePursuit().twist((0.0, 0.0, 0.0))


# Paths that double back over themselves (issue 13): the agent's own projection stays on the
# leg being driven, and the env scores the whole path.

OUT_AND_BACK = [[0.0, 0.0], [5.0, 0.0], [0.0, 0.0]]
PARTIAL_REVERSAL = [[0.0, 0.0], [5.0, 0.0], [2.0, 0.0]]
STATION_AND_BACK = [[1.0, 1.0], [4.0, 1.0], [4.0, 3.0], [4.0, 1.0], [1.0, 1.0]]


def figure_eight(points=121):
    """A lemniscate from the top of its right lobe, crossing its centre (6, 6) twice."""
    t = np.linspace(np.pi / 2, 2.5 * np.pi - 0.5, points)
    return np.column_stack((6.0 + 4.0 * np.sin(t), 6.0 + 2.0 * np.sin(2.0 * t)))


def test_the_projection_stays_on_the_outward_leg_until_the_turn():
    # In any direction the return leg is as close as the outward one up to rounding; the
    # projection point is the robot's own position on the outward leg until the turn.
    rng = np.random.default_rng(0)
    for _ in range(100):
        start, turn = rng.uniform(0.0, 10.0, (2, 2))
        back_to = start + rng.uniform(0.2, 1.0) * (turn - start)
        projection = ForwardProjection(Path([start, turn, back_to]))
        for fraction in np.linspace(0.0, 0.99, 100):
            position = tuple(start + fraction * (turn - start))
            assert projection.update(position, search_distance=0.3) == pytest.approx(position)
            assert projection.segment == 0


DOUBLING_BACK = {
    "out_and_back": OUT_AND_BACK,
    "partial_reversal": PARTIAL_REVERSAL,
    "station_and_back": STATION_AND_BACK,
    "figure_eight": figure_eight(),
}


@pytest.mark.parametrize(
    ("agent", "path_name"),
    [
        *((PurePursuit(), name) for name in ("out_and_back", "partial_reversal", "figure_eight")),
        *((RegulatedPurePursuit(), name) for name in DOUBLING_BACK),
    ],
)
def test_pure_pursuit_completes_paths_that_double_back(agent, path_name):
    # Not PurePursuit on station_and_back: it meets the cusp almost head-on, where
    # 2 sin(alpha) / Ld is nearly 0 and the robot drives on past the station.
    env = PathFollowingEnv("diff_drive", Path(DOUBLING_BACK[path_name]))
    episode = evaluate(agent, env, episodes=1).summary
    assert episode["completion_rate"] == 1.0


@pytest.mark.parametrize(
    ("agent", "start_noise"),
    # PurePursuit from the exact start: from a noisy one it meets the cusp almost head-on.
    [(PurePursuit(), (0.0, 0.0)), (RegulatedPurePursuit(), (0.2, 0.3))],
)
def test_pure_pursuit_completes_an_out_and_back_path_in_a_vector_env(agent, start_noise):
    vector = PathFollowingVectorEnv(3, "diff_drive", Path(OUT_AND_BACK), start_noise=start_noise)
    bound = agent.bind(vector)
    observations, info = vector.reset(seed=0)
    outcome = [None] * 3
    while None in outcome:
        actions, _ = bound.predict(observations)
        observations, _, terminated, truncated, info = vector.step(actions)
        for index in np.flatnonzero(terminated | truncated):
            if outcome[index] is None:
                outcome[index] = (bool(info["is_success"][index]), info["progress"][index])
    for success, progress in outcome:
        assert success and progress > 0.98


BAD_NUMBERS = [math.nan, math.inf, -math.inf, -1.0, True, "0.5", None]


@pytest.mark.parametrize(
    ("parameters", "name"),
    [
        # The cases: each was accepted and failed later.
        ({"speed": 0}, "speed"),
        ({"speed": -0.6}, "speed"),
        ({"speed": math.nan}, "speed"),
        ({"lookahead": math.inf}, "lookahead"),
        *(
            ({name: value}, name)
            for name in ("lookahead", "speed", "max_angular_speed")
            for value in BAD_NUMBERS
        ),
    ],
)
def test_pure_pursuit_refuses_a_parameter_that_is_no_positive_finite_number(parameters, name):
    with pytest.raises(ValueError, match=f"^{name} must be"):
        PurePursuit(**parameters)


REGULATED_PARAMETERS = list(inspect.signature(RegulatedPurePursuit).parameters)
ANGLES = ("rotate_min_angle", "reverse_min_angle", "reverse_exit_angle")


@pytest.mark.parametrize(
    ("parameters", "name"),
    [
        ({"lookahead_time": math.nan}, "lookahead_time"),
        ({"max_angular_speed": -1}, "max_angular_speed"),
        *(({name: value}, name) for name in REGULATED_PARAMETERS for value in BAD_NUMBERS),
        *(({name: 3.5}, name) for name in ANGLES),  # beyond pi
        ({"reverse_exit_angle": 1.3, "reverse_min_angle": 1.2}, "reverse_exit_angle"),
    ],
)
def test_regulated_pure_pursuit_refuses_bad_parameters_naming_them(parameters, name):
    with pytest.raises(ValueError, match=f"^{name} must be"):
        RegulatedPurePursuit(**parameters)


def test_zero_is_a_valid_floor_distance_and_angle():
    floors = ("min_radius", "min_regulated_speed", "approach_distance", "min_approach_speed")
    controller = RegulatedPurePursuit(**dict.fromkeys((*floors, "in_place_radius", *ANGLES), 0))
    controller.reset(Path([[0, 0], [10, 0]]))
    assert controller.twist((5.0, 0.0, 0.0)) == (controller.speed, 0.0)


def test_numpy_scalars_are_valid_parameters_and_act_as_their_values():
    path = course_path("segments")
    pose = (2.1, 1.2, 2.0)
    for numpy_agent, plain_agent in (
        (
            PurePursuit(
                lookahead=np.float32(0.5), speed=np.int64(1), max_angular_speed=np.float16(3)
            ),
            PurePursuit(lookahead=float(np.float32(0.5)), speed=1.0, max_angular_speed=3.0),
        ),
        (
            RegulatedPurePursuit(speed=np.float32(0.75), lookahead_time=np.int32(2)),
            RegulatedPurePursuit(speed=0.75, lookahead_time=2.0),
        ),
    ):
        assert all(type(value) in (float, str) for value in numpy_agent.parameters().values())
        numpy_agent.reset(path)
        plain_agent.reset(path)
        assert numpy_agent.twist(pose) == plain_agent.twist(pose)


# The law for many robots: one compiled call, the bits of each robot commanded alone.


@pytest.mark.parametrize(
    ("agent", "model"),
    [
        (PurePursuit(), DifferentialDrive()),
        (PurePursuit(mode="textbook", speed=0.8), Bicycle()),
        (RegulatedPurePursuit(), DifferentialDrive()),
        (RegulatedPurePursuit(), Bicycle()),  # three-point turns: the reversing state
        (RegulatedPurePursuit(speed=0.5), Tricycle()),
    ],
)
def test_a_batch_of_robots_gets_the_commands_each_gets_alone(agent, model):
    # Five robots on different paths from random poses, driven by their own commands; robot
    # 2 starts a new path halfway. Each robot alone (its own agent) must get the same bits.
    rng = np.random.default_rng(5)
    paths = [course_path(name) for name in ("segments", "sharp_segments", "diagonal_line")]
    paths += [Path(DOUBLING_BACK["station_and_back"]), Path(figure_eight())]
    count = len(paths)
    states = np.zeros((count, model.state_dim))
    states[:, :3] = [(*path.points[0], 0.0) for path in paths]
    states[:, :2] += rng.uniform(-0.3, 0.3, (count, 2))
    states[:, 2] = rng.uniform(-math.pi, math.pi, count)
    laws = agent.batch(count)
    laws.reset(np.arange(count), paths)
    alone = [type(agent)(**agent.parameters()) for _ in range(count)]
    for single, path in zip(alone, paths, strict=True):
        single.reset(path)
    robots = np.arange(count)
    for step in range(120):
        if step == 60:
            laws.reset([2], [paths[0]])
            alone[2].reset(paths[0])
        inputs = laws.inputs(robots, states, model, 0.1)
        for index, single in enumerate(alone):
            np.testing.assert_array_equal(inputs[index], single.inputs(states[index], model, 0.1))
        states = model.step(states, inputs, 0.1)


def test_a_batch_commands_only_the_robots_asked_for():
    laws = PurePursuit().batch(3)
    path = course_path("segments")
    laws.reset([0, 1, 2], [path] * 3)
    states = np.array([[2.0, 1.0, 0.0], [2.5, 1.2, 0.3], [2.0, 0.8, -0.2]])
    both = laws.inputs(np.array([0, 2]), states, DifferentialDrive(), 0.1)
    fresh = PurePursuit().batch(3)
    fresh.reset([0, 1, 2], [path] * 3)
    everyone = fresh.inputs(np.arange(3), states, DifferentialDrive(), 0.1)
    np.testing.assert_array_equal(both, everyone[[0, 2]])


def test_a_batch_refuses_robots_without_a_path():
    laws = RegulatedPurePursuit().batch(4)
    laws.reset([1], [course_path("segments")])
    with pytest.raises(RuntimeError, match=r"reset.*\[0, 2, 3\]"):
        laws.inputs(np.arange(4), np.zeros((4, 3)), DifferentialDrive(), 0.1)

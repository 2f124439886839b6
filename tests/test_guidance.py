"""Seed 003's tricycle guidance law: its validation run, its pole placement, its limits."""

import math

import numpy as np
import pytest

from agents.controllers.guidance import TricycleGuidance
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.robots import Tricycle
from mobile_envs.world.paths import Path

# Seed 003's run, as the arc_straight path lays it out: an arc of radius 1.24 m from (1, 1)
# heading north, turning right by 90 degrees, then 3 m east.
RADIUS = 1.24
CENTRE = np.array([1.0 + RADIUS, 1.0])
STRAIGHT_Y = 1.0 + RADIUS
STRAIGHT_END_X = 1.0 + RADIUS + 3.0
SPEED = 0.2
OFFSET = 0.110
DT = 0.1
# The correction transient: twice the 2% settling time 4 / (zeta omega_n) = 1.5 s of eq. 23
# for the gains below, as the 2 rad/s steering-rate limit slows the first second. C has then
# covered 0.6 m of the 1.95 m arc: the bounds cover the rest of the arc, the junction with
# the straight and the straight.
NATURAL_FREQUENCY, DAMPING = 3.0, 0.9
TRANSIENT_STEPS = 30


def wheel_errors(state, wheelbase=1.0):
    """e_c and xi_r of the drive wheel C against the exact arc and straight (not the env's
    polyline), or None once C has passed the path's end."""
    x, y, psi, gamma = state
    wheel = np.array([x + wheelbase * math.cos(psi), y + wheelbase * math.sin(psi)])
    if wheel[0] > STRAIGHT_END_X:
        return None
    if wheel[0] < CENTRE[0] and wheel[1] >= CENTRE[1]:  # on the arc: left is outwards
        lateral = math.dist(wheel, CENTRE) - RADIUS
        angle = math.atan2(wheel[1] - CENTRE[1], wheel[0] - CENTRE[0])
        tangent = angle - math.pi / 2
    elif wheel[1] < CENTRE[1]:  # before the arc: the tangent line at its start, heading north
        lateral, tangent = 1.0 - wheel[0], math.pi / 2
    else:
        lateral, tangent = wheel[1] - STRAIGHT_Y, 0.0
    return lateral, math.remainder(psi + gamma - tangent, 2 * math.pi)


def run_seed_003(offset):
    """The validation run: C starts ``offset`` left of the arc's start, the wheel straight and
    the vehicle along the arc's tangent; returns e_c and xi_r at every step while C is on the
    path (the whole of it), starting with the initial ones."""
    # O trails C by 1 m, so it starts 1 m off the path and reaches the goal after the env's
    # default time limit (one traversal at 0.2 m/s): widen both.
    env = PathFollowingEnv("tricycle", "arc_straight", max_cross_track=3.0, step_limit=400)
    assert np.allclose(env.reset(seed=0)[1]["pose"], (1.0, 1.0, math.pi / 2))
    assert np.allclose(env.path.goal, (STRAIGHT_END_X, STRAIGHT_Y))
    agent = TricycleGuidance.from_poles(NATURAL_FREQUENCY, DAMPING, speed=SPEED).bind(env)
    start = (1.0 - offset, 0.0, math.pi / 2)
    observation, _ = env.reset(seed=0, options={"start_pose": start})
    errors = [wheel_errors(env.state)]
    errors += [current for current, _ in steps_while_c_is_on_the_path(env, agent, observation)]
    return np.array(errors)


def steps_while_c_is_on_the_path(env, agent, observation):
    """Step ``env`` under ``agent`` from ``observation`` while C is on the path, yielding C's
    (e_c, xi_r) and the step's info after each step; asserts that the episode does not end
    before C has run the whole path."""
    while True:
        action, _ = agent.predict(observation)
        observation, _, terminated, truncated, info = env.step(action)
        current = wheel_errors(env.state)
        if current is None:
            return
        assert not (terminated or truncated), "the episode ended before C ran the whole path"
        yield current, info


@pytest.mark.parametrize("offset", [OFFSET, -OFFSET])
def test_seed_003_run_corrects_the_offset_then_holds_its_error_bounds(offset):
    errors = run_seed_003(offset)
    lateral, orientation = errors[:, 0], errors[:, 1]
    assert lateral[0] == pytest.approx(offset)
    assert abs(lateral[TRANSIENT_STEPS]) < 0.005  # the offset is corrected
    assert np.abs(lateral[TRANSIENT_STEPS:]).max() <= 0.0165
    assert np.degrees(np.abs(orientation[TRANSIENT_STEPS:]).max()) <= 3.8


def wheel_lateral_error_from_x_axis(state, wheelbase=1.0):
    _, y, psi, _ = state
    return y + wheelbase * math.sin(psi)


def test_the_gains_place_the_roots_of_eq_23():
    """A small offset from a straight path decays as e'' + b e' + a v e = 0 predicts."""
    natural_frequency, damping, offset = 2.0, 0.7, 0.01
    guidance = TricycleGuidance.from_poles(natural_frequency, damping, speed=SPEED)
    assert guidance.a * SPEED == pytest.approx(natural_frequency**2)
    assert guidance.b == pytest.approx(2 * damping * natural_frequency)
    env = PathFollowingEnv("tricycle", Path([[0, 0], [20, 0]]))
    agent = guidance.bind(env)
    observation, _ = env.reset(options={"start_pose": (1.0, offset, 0.0)})
    lateral = []
    for _ in range(60):
        observation = env.step(agent.predict(observation)[0])[0]
        lateral.append(wheel_lateral_error_from_x_axis(env.state))
    t = DT * np.arange(1, 61)
    damped = natural_frequency * math.sqrt(1 - damping**2)
    expected = (
        offset
        * np.exp(-damping * natural_frequency * t)
        * (np.cos(damped * t) + damping * natural_frequency / damped * np.sin(damped * t))
    )
    # Sampling at 10 Hz with the steering rate held between samples costs a few percent.
    np.testing.assert_allclose(lateral, expected, atol=0.08 * offset)


def test_the_lateral_error_is_signed_positive_left_and_measured_at_the_wheel():
    guidance = TricycleGuidance(a=1.0, b=1.0)
    guidance.reset(Path([[0, 0], [10, 0]]))
    lateral, orientation, _ = guidance.errors((2.0, 0.0, math.pi / 6, -0.1), wheelbase=1.0)
    assert lateral == pytest.approx(0.5)
    assert orientation == pytest.approx(math.pi / 6 - 0.1)
    # eq. 20 with v / L = 0.2: -a e_c - b xi_r - (v / L) gamma.
    rate = guidance.steering_rate((2.0, 0.0, math.pi / 6, -0.1), wheelbase=1.0)
    assert rate == pytest.approx(-0.5 - (math.pi / 6 - 0.1) + 0.02)


def test_past_the_end_the_wheel_keeps_to_the_last_segments_line():
    guidance = TricycleGuidance(a=1.0, b=1.0)
    guidance.reset(Path([[0, 0], [10, 0]]))
    lateral, orientation, _ = guidance.errors((11.0, 0.2, 0.0, 0.0), wheelbase=1.0)
    assert (lateral, orientation) == pytest.approx((0.2, 0.0))


def test_only_the_tricycle_is_driven():
    with pytest.raises(ValueError, match="cannot drive"):
        TricycleGuidance.from_poles(2.0, 0.9).bind(PathFollowingEnv("diff_drive", "segments"))
    with pytest.raises(ValueError, match="positive"):
        TricycleGuidance(a=-1.0, b=1.0)


# ---------------------------------------------------------------- the general law (eqs. 11-19)


def eq_17_roots(guidance, wheelbase):
    """Roots of q''' + c q'' + (v / L) b q' + (v^2 / L) a q (seed 003 eq. 17)."""
    v, a, b, c = guidance.speed, guidance.a, guidance.b, guidance.c
    return np.sort_complex(np.roots([1.0, c, v * b / wheelbase, v * v * a / wheelbase]))


@pytest.mark.parametrize("speed", [0.2, 0.5, -0.3])
@pytest.mark.parametrize("wheelbase", [1.0, 1.6])
@pytest.mark.parametrize("point", ["O", "C"])
def test_from_roots_places_one_real_and_two_complex_roots_of_eq_17(speed, wheelbase, point):
    decay, natural_frequency, damping = 0.8, 1.5, 0.6
    guidance = TricycleGuidance.from_roots(
        decay, natural_frequency, damping, speed, wheelbase=wheelbase, point=point
    )
    damped = natural_frequency * math.sqrt(1 - damping**2)
    expected = np.sort_complex(
        [
            -decay,
            -damping * natural_frequency + 1j * damped,
            -damping * natural_frequency - 1j * damped,
        ]
    )
    np.testing.assert_allclose(eq_17_roots(guidance, wheelbase), expected, atol=1e-9)
    np.testing.assert_allclose(
        np.sort_complex(guidance.characteristic_roots(wheelbase)), expected, atol=1e-9
    )
    assert np.sign(guidance.b) == np.sign(speed)  # eq. 18 or eq. 19's sign of b


def test_routh_hurwitz_accepts_exactly_the_gains_whose_roots_are_stable():
    """Over random gains and speeds of both signs, the law is built exactly when every root
    of eq. 17 (found numerically) has a negative real part; otherwise a ValueError."""
    rng = np.random.default_rng(0)
    accepted = refused = 0
    for _ in range(3000):
        a, b, c = rng.uniform(-2, 10), rng.uniform(-10, 10), rng.uniform(-2, 10)
        speed = rng.choice([-1, 1]) * rng.uniform(0.05, 2.0)
        roots = np.roots([1.0, c, speed * b, speed * speed * a])  # L = 1
        margin = roots.real.max()
        if abs(margin) < 1e-6:
            continue  # marginal: neither side is meaningful
        try:
            TricycleGuidance(a, b, speed, c=c, point="O")
        except ValueError:
            assert margin > 0, (a, b, c, speed)
            refused += 1
        else:
            assert margin < 0, (a, b, c, speed)
            accepted += 1
    assert accepted > 200 and refused > 200


def test_reversing_needs_b_c_below_v_a_not_above():
    """Seed 003's eq. 19 as rendered reads b c > v a for v < 0 too; Routh-Hurwitz asks
    c (v b) > v^2 a, i.e. b c < v a when v < 0. Gains meeting the rendered form are unstable."""
    speed, a, b, c = -0.5, 1.0, -0.2, 1.0  # b c = -0.2 > v a = -0.5
    assert np.roots([1.0, c, speed * b, speed * speed * a]).real.max() > 0
    with pytest.raises(ValueError, match="b c < v a"):
        TricycleGuidance(a, b, speed, c=c, point="O")
    stable = TricycleGuidance(a, -2.0, speed, c=c, point="O")  # b c = -2 < v a
    assert stable.characteristic_roots(1.0).real.max() < 0


def test_the_simple_law_is_the_general_law_with_b_plus_a_l_and_c_b_plus_v_over_l():
    """Eq. 20 is eq. 13 with (a, b + a L, b + v / L): the same steering rate everywhere, and
    eq. 17's roots are eq. 23's and -v / L (eq. 24)."""
    a, b, speed, wheelbase = 4.0, 2.5, 0.3, 1.2
    simple = TricycleGuidance(a, b, speed)
    general = TricycleGuidance(a, b + a * wheelbase, speed, c=b + speed / wheelbase, point="C")
    path = Path([[0.0, 0.0], [4.0, 1.0], [8.0, -1.0]])
    simple.reset(path)
    general.reset(path)
    rng = np.random.default_rng(1)
    for _ in range(50):
        state = (rng.uniform(0, 7), rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1))
        assert simple.steering_rate(state, wheelbase) == pytest.approx(
            general.steering_rate(state, wheelbase), abs=1e-12
        )
    expected = np.sort_complex(np.r_[np.roots([1.0, b, a * speed]), -speed / wheelbase])
    np.testing.assert_allclose(
        np.sort_complex(simple.characteristic_roots(wheelbase)), expected, atol=1e-12
    )


def linear_prediction(guidance, wheelbase, initial, times):
    """The linearized closed loop of the general law on O, x = (e_o, xi, gamma):
    e_o' = v xi (eq. 15), xi' = (v / L) gamma (eq. 16), gamma' = -a e_o - b xi - c gamma
    (eq. 11), solved by its eigenvectors; returns e_o at ``times``."""
    v, a, b, c = guidance.speed, guidance.a, guidance.b, guidance.c
    matrix = np.array([[0.0, v, 0.0], [0.0, 0.0, v / wheelbase], [-a, -b, -c]])
    values, vectors = np.linalg.eig(matrix)
    weights = np.linalg.solve(vectors, initial)
    return np.array([(vectors @ (weights * np.exp(values * t))).real[0] for t in times])


def run_on_x_axis(guidance, start, steps, dt=0.02, wheelbase=1.0):
    """Drive the tricycle with the law along the x axis; returns the states after each step.
    Reversing (v < 0), the vehicle points against the path and O leads."""
    model = Tricycle(wheelbase=wheelbase)
    guidance.reset(Path([[0.0, 0.0], [30.0, 0.0]]))
    state, states = np.array(start, dtype=float), []
    for _ in range(steps):
        state = model.step(state, guidance.inputs(state, model, dt), dt)
        states.append(state)
    return np.array(states)


@pytest.mark.parametrize(("speed", "point"), [(0.3, "O"), (0.3, "C"), (-0.3, "O"), (-0.3, "C")])
def test_closed_loop_errors_follow_eq_17_forwards_and_reversing(speed, point):
    """A small offset from a straight path decays as the linearized loop predicts: the
    tricycle's own kinematics (sampled at 50 Hz) against the closed form, on O and on C,
    the drive wheel leading (v > 0) and the tricycle reversing O first (v < 0)."""
    guidance = TricycleGuidance.from_roots(1.0, 1.5, 0.7, speed, point=point)
    offset, heading_error = 0.02, 0.01
    reversing = speed < 0
    psi = (math.pi if reversing else 0.0) + heading_error
    # Left of the direction of travel is -y when the vehicle points along -x.
    y_of_o = -offset if reversing else offset
    states = run_on_x_axis(guidance, (2.0, y_of_o, psi, 0.0), steps=1000)
    lateral_of_o = -states[:, 1] if reversing else states[:, 1]
    times = 0.02 * np.arange(1, 1001)
    # On a straight path e_c = e_o + L sin(xi) and xi_r = xi + gamma exactly, so the C law
    # (eq. 13) is, linearized, the O law (eq. 11) with the same a, b, c: the loop in
    # (e_o, xi, gamma) is the same for both points.
    expected = linear_prediction(guidance, 1.0, np.array([offset, heading_error, 0.0]), times)
    np.testing.assert_allclose(lateral_of_o, expected, atol=0.03 * offset)
    assert np.abs(lateral_of_o[-100:]).max() < 1e-4  # settled after 20 s


def test_the_tricycle_reverses_onto_a_straight_path_on_point_o():
    """Seed 003's manoeuvre: O first, from 0.2 m off the path and 10 degrees askew, the wheel
    straight; the simple law refuses to reverse."""
    guidance = TricycleGuidance.from_roots(0.8, 1.2, 0.7, speed=-0.25, point="O")
    states = run_on_x_axis(guidance, (1.0, -0.2, math.pi + math.radians(10), 0.0), 2000)
    lateral, heading_error = -states[:, 1], np.remainder(states[:, 2], 2 * math.pi) - math.pi
    assert states[-1, 0] > 8.0  # it went backwards along +x, 10 m in 40 s
    assert abs(lateral[-1]) < 1e-3 and abs(heading_error[-1]) < 1e-3
    assert np.abs(lateral).max() < 0.25  # no wide swing on the way
    with pytest.raises(ValueError, match=r"^speed must be positive"):
        TricycleGuidance(a=1.0, b=1.0, speed=-0.25)


@pytest.mark.parametrize(
    ("build", "pattern"),
    [
        (lambda: TricycleGuidance.from_poles(2, 1, speed=0), r"^speed"),
        (lambda: TricycleGuidance.from_poles(2, 1, speed=math.nan), r"^speed"),
        (lambda: TricycleGuidance.from_poles(-2, 1), r"^natural_frequency"),
        (lambda: TricycleGuidance.from_poles(2, math.inf), r"^damping"),
        (lambda: TricycleGuidance(a=math.nan, b=1.0), r"^a must"),
        (lambda: TricycleGuidance(a=1.0, b=math.inf), r"^b must"),
        (lambda: TricycleGuidance(a=1.0, b=-1.0), r"^b must be positive"),
        (lambda: TricycleGuidance(a=1.0, b=1.0, speed=math.inf), r"^speed"),
        (lambda: TricycleGuidance(a=1.0, b=1.0, c=math.nan), r"^c must"),
        (lambda: TricycleGuidance(a=1.0, b=1.0, c=-1.0), r"^c must be positive"),
        (lambda: TricycleGuidance(a=-1.0, b=1.0, c=1.0), r"^a must be positive"),
        (lambda: TricycleGuidance(a=1.0, b=-1.0, c=1.0, speed=0.2), r"^b must be positive"),
        (lambda: TricycleGuidance(a=1.0, b=1.0, c=1.0, speed=-0.2), r"^b must be negative"),
        (lambda: TricycleGuidance(a=10.0, b=1.0, c=1.0, speed=0.2), "b c > v a"),
        (lambda: TricycleGuidance(a=1.0, b=1.0, c=1.0, speed=0.0), r"^speed"),
        (lambda: TricycleGuidance(a=1.0, b=1.0, point="O"), r"^point"),
        (lambda: TricycleGuidance(a=1.0, b=3.0, c=1.0, point="P"), r"^point"),
        (lambda: TricycleGuidance.from_roots(1.0, 1.0, 1.0, 0.2), r"^damping"),
        (lambda: TricycleGuidance.from_roots(0.0, 1.0, 0.5, 0.2), r"^decay_rate"),
        (lambda: TricycleGuidance.from_roots(1.0, 1.0, 0.5, 0.0), r"^speed"),
        (lambda: TricycleGuidance.from_roots(1.0, 1.0, 0.5, 0.2, wheelbase=-1), r"^wheelbase"),
        # Beyond float64 (issue 30: each raised OverflowError).
        (lambda: TricycleGuidance(a=10**400, b=1.0), r"^a must"),
        (lambda: TricycleGuidance(a=1.0, b=-(10**400)), r"^b must"),
        (lambda: TricycleGuidance(a=1.0, b=1.0, speed=10**400), r"^speed must"),
        (lambda: TricycleGuidance(a=1.0, b=1.0, c=10**400), r"^c must"),
        (lambda: TricycleGuidance(a=True, b=1.0), r"^a must"),
        (lambda: TricycleGuidance.from_poles(10**400, 1), r"^natural_frequency"),
    ],
)
def test_bad_gains_raise_value_errors_naming_the_parameter(build, pattern):
    with pytest.raises(ValueError, match=pattern):
        build()


@pytest.mark.parametrize(
    "guidance",
    [
        TricycleGuidance.for_comparison(),
        TricycleGuidance.from_roots(0.8, 1.5, 0.7, speed=0.4, point="C"),
        TricycleGuidance.from_roots(0.8, 1.2, 0.7, speed=-0.25, point="O"),
    ],
)
def test_a_batch_of_tricycles_gets_the_steering_rates_each_gets_alone(guidance):
    rng = np.random.default_rng(2)
    model = Tricycle()
    paths = [
        Path([[0, 0], [4, 1], [8, -1]]),
        Path([[0, 0], [5, 0], [5, 5]]),
        Path([[1, 1], [9, 1]]),
    ]
    count = len(paths)
    states = np.column_stack(
        (rng.uniform(0, 3, count), rng.uniform(-0.5, 0.5, count), rng.uniform(-0.3, 0.3, count),
         np.zeros(count))
    )  # fmt: skip
    if guidance.speed < 0:
        states[:, 2] += math.pi
    laws = guidance.batch(count)
    laws.reset(np.arange(count), paths)
    alone = [TricycleGuidance(**guidance.parameters()) for _ in range(count)]
    for single, path in zip(alone, paths, strict=True):
        single.reset(path)
    for _ in range(80):
        inputs = laws.inputs(np.arange(count), states, model, 0.1)
        for index, single in enumerate(alone):
            np.testing.assert_array_equal(inputs[index], single.inputs(states[index], model, 0.1))
        states = model.step(states, inputs, 0.1)

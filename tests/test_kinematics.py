"""The four kinematic models against closed forms, numerical orders and invariances."""

import math

import numpy as np
import pytest

from mobile_envs._kernels.angles import wrap_angle, wrap_scalar_angle
from mobile_envs._kernels.specialize import for_model, model, per_model
from mobile_envs.robots import (
    INTEGRATORS,
    Bicycle,
    ConstantVelocity,
    DifferentialDrive,
    Tricycle,
    make_model,
)
from mobile_envs.robots import MODELS as CATALOGUE

#: Every model of the catalogue, with the finite limits the envs build it with: a model added
#: as a module of its own is tested here too.
MODELS = [model_class(**model_class.env_defaults) for model_class in CATALOGUE.values()]
MODEL_IDS = [type(model).__name__ for model in MODELS]


def sample_inputs(model, rng, count):
    """Random inputs inside a model's limits (its env defaults' where it has none)."""
    bounded = type(model)(**type(model).env_defaults)
    high = np.where(np.isfinite(model.input_high), model.input_high, bounded.input_high)
    return rng.uniform(-high, high, (count, model.input_dim))


def body_twist_of(model, u):
    """A rigid-body model's body twist (v_x, v_y, omega): its pose rates at heading 0."""
    return model.derivative(np.zeros(model.state_dim), u)[:3]


def is_rigid_body(model):
    """Whether the model's inputs alone fix its body twist (its state is the pose alone)."""
    return model.state_dim == 3


def sample_states(model, rng, count):
    states = rng.uniform(-5, 5, (count, model.state_dim))
    states[:, 2] = rng.uniform(-math.pi, math.pi, count)
    if model.state_dim == 4:
        states[:, 3] = rng.uniform(-1.0, 1.0, count)
    return states


def circle_end(start, speed, omega, time):
    """Closed-form pose after driving an arc at constant forward speed and yaw rate."""
    x, y, heading = start
    if omega == 0.0:
        return np.array(
            [x + speed * time * math.cos(heading), y + speed * time * math.sin(heading), heading]
        )
    radius = speed / omega
    center = (x - radius * math.sin(heading), y + radius * math.cos(heading))
    end_heading = heading + omega * time
    return np.array(
        [
            center[0] + radius * math.sin(end_heading),
            center[1] - radius * math.cos(end_heading),
            end_heading,
        ]
    )


def pose_error(a, b):
    return max(abs(a[0] - b[0]), abs(a[1] - b[1]), abs(float(wrap_angle(a[2] - b[2]))))


# ---------------------------------------------------------------- closed forms


def test_equal_wheel_speeds_drive_a_straight_line_of_the_right_length():
    model = DifferentialDrive(wheel_radius=0.05, track_width=1.0)
    state = np.array([1.0, 2.0, 0.3])
    for integrator in INTEGRATORS:
        end = model.step(state, [10.0, 10.0], 2.0, integrator)
        assert end[2] == pytest.approx(0.3, abs=1e-15)
        assert np.hypot(end[0] - 1.0, end[1] - 2.0) == pytest.approx(0.05 * 10.0 * 2.0, rel=1e-12)
        assert math.atan2(end[1] - 2.0, end[0] - 1.0) == pytest.approx(0.3, abs=1e-12)


def test_opposite_wheel_speeds_spin_in_place():
    model = DifferentialDrive(wheel_radius=0.05, track_width=1.0)
    state = np.array([1.0, 2.0, 0.0])
    for integrator in INTEGRATORS:
        end = model.step(state, [4.0, -4.0], 0.5, integrator)
        np.testing.assert_allclose(end[:2], [1.0, 2.0], atol=1e-15)
        # omega = r (wR - wL) / L = 0.05 * 8 / 1 = 0.4 rad/s
        assert end[2] == pytest.approx(0.2, abs=1e-14)


def test_unequal_wheel_speeds_trace_the_circle_around_the_eq2_centre():
    model = DifferentialDrive(wheel_radius=0.05, track_width=1.0)
    wheels = np.array([12.0, 8.0])
    v_right, v_left = 0.05 * wheels
    expected_radius = 1.0 * (v_right + v_left) / (2.0 * (v_right - v_left))
    assert model.turning_radius(wheels) == pytest.approx(expected_radius, rel=1e-15)
    state = np.array([0.5, -1.0, 0.7])
    center = model.instantaneous_center(state, wheels)
    np.testing.assert_allclose(
        center, [0.5 - expected_radius * math.sin(0.7), -1.0 + expected_radius * math.cos(0.7)]
    )
    for _ in range(40):
        state = model.step(state, wheels, 0.37)
        assert np.hypot(*(state[:2] - center)) == pytest.approx(abs(expected_radius), rel=1e-12)


def test_straight_motion_has_infinite_radius_and_no_centre():
    model = DifferentialDrive()
    assert math.isinf(model.turning_radius([3.0, 3.0]))
    assert np.isinf(model.instantaneous_center([0, 0, 0], [3.0, 3.0])).all()
    assert model.turning_radius([3.0, -3.0]) == 0.0


@pytest.mark.parametrize("gamma", [0.2, -0.5, math.pi / 4])
def test_bicycle_at_constant_steering_traces_radius_wheelbase_over_tan_gamma(gamma):
    model = Bicycle(wheelbase=1.3, max_steering=math.pi / 3)
    radius = 1.3 / math.tan(gamma)
    state = np.array([0.0, 0.0, 0.0])
    center = np.array([0.0, radius])
    for _ in range(30):
        state = model.step(state, [0.8, gamma], 0.25)
        assert np.hypot(*(state[:2] - center)) == pytest.approx(abs(radius), rel=1e-12)


def test_tricycle_at_constant_steering_turns_at_v_sin_gamma_over_wheelbase():
    model = Tricycle(wheelbase=1.2)
    gamma, speed, dt = 0.6, 0.5, 0.3
    state = np.array([0.0, 0.0, 0.0, gamma])
    end = model.step(state, [speed, 0.0], dt)
    assert end[2] == pytest.approx(speed * math.sin(gamma) / 1.2 * dt, rel=1e-13)
    assert end[3] == gamma
    # O moves at v cos(gamma) on a circle of radius L / tan(gamma).
    expected = circle_end(
        (0.0, 0.0, 0.0), speed * math.cos(gamma), speed * math.sin(gamma) / 1.2, dt
    )
    np.testing.assert_allclose(end[:3], expected, atol=1e-12)


def test_constant_velocity_with_v_y_alone_moves_sideways_to_the_left():
    # The course's helper writes "- v_y dt cos th" in y, which would move the robot right.
    model = ConstantVelocity()
    for heading in (0.0, 0.4, -2.0):
        end = model.step([0.0, 0.0, heading], [0.0, 1.0, 0.0], 0.5, "euler")
        left = np.array([-math.sin(heading), math.cos(heading)])
        np.testing.assert_allclose(end[:2], 0.5 * left, atol=1e-15)


# ---------------------------------------------------------------- integrators


def exact_reference(model, state, u, dt):
    """Closed-form end pose for the rigid-body models (constant body twist)."""
    v_x, v_y, omega = body_twist_of(model, u)
    # The body's reference point moves on a circle; rotate a body-frame offset along.
    if omega == 0.0:
        c, s = math.cos(state[2]), math.sin(state[2])
        return state + np.array([(v_x * c - v_y * s) * dt, (v_x * s + v_y * c) * dt, 0.0])
    speed = math.hypot(v_x, v_y)
    slip = math.atan2(v_y, v_x)
    end = circle_end((state[0], state[1], state[2] + slip), speed, omega, dt)
    return end - np.array([0.0, 0.0, slip])


RIGID_BODIES = [model for model in MODELS if is_rigid_body(model)]


@pytest.mark.parametrize("model", RIGID_BODIES, ids=[type(m).__name__ for m in RIGID_BODIES])
@pytest.mark.parametrize("dt", [1e-3, 0.1, 1.0, 7.5])
def test_exact_matches_the_closed_form_for_any_dt(model, dt):
    rng = np.random.default_rng(1)
    for state, u in zip(sample_states(model, rng, 20), sample_inputs(model, rng, 20), strict=True):
        end = model.step(state, u, dt, "exact")
        assert pose_error(end, exact_reference(model, state, u, dt)) < 1e-9


def test_exact_is_smooth_as_omega_goes_to_zero():
    model = DifferentialDrive()
    ends = [model.step([0, 0, 0.3], [10.0 + eps, 10.0 - eps], 1.0) for eps in (0.0, 1e-12, 1e-8)]
    np.testing.assert_allclose(ends[0], ends[1], atol=1e-12)
    np.testing.assert_allclose(ends[0], ends[2], atol=1e-8)
    assert np.isfinite(ends).all()


def fine_rk4_reference(model, state, u, dt, steps=4000):
    """Fine RK4 (the tricycle's, with a steering rate that keeps gamma inside its limit)."""
    for _ in range(steps):
        state = model.step(state, u, dt / steps, "rk4")
    return state


def measured_order(errors, dts):
    return np.polyfit(np.log(dts), np.log(errors), 1)[0]


@pytest.mark.parametrize("model", MODELS, ids=MODEL_IDS)
def test_local_error_orders(model):
    """Per-step error: euler ~ dt^2, midpoint ~ dt^3, rk4 ~ dt^5 (exact to round-off)."""
    state = np.array([0.3, -0.2, 0.4, 0.1][: model.state_dim])
    u = model.input_high * np.array([0.7, 0.3, 0.5, 0.2])[: model.input_dim]
    dts = np.array([0.2, 0.1, 0.05, 0.025])
    expected_orders = {"euler": 2.0, "midpoint": 3.0, "rk4": 5.0}
    for integrator, order in expected_orders.items():
        errors = []
        for dt in dts:
            if is_rigid_body(model):
                truth = exact_reference(model, state, u, dt)
            else:
                truth = fine_rk4_reference(model, state, u, dt)
            errors.append(np.abs(model.step(state, u, dt, integrator)[:3] - truth[:3]).max())
        assert measured_order(errors, dts) == pytest.approx(order, abs=0.3), integrator


def test_tricycle_exact_integrator_is_accurate_while_the_wheel_turns():
    model = Tricycle()
    state, u, dt = np.array([0.0, 0.0, 0.2, -0.3]), np.array([0.8, 1.2]), 0.1
    truth = fine_rk4_reference(model, state, u, dt)
    assert np.abs(model.step(state, u, dt, "exact") - truth).max() < 1e-5


def test_tricycle_steering_stops_at_its_limit():
    model = Tricycle(max_steering=1.0)
    state = np.array([0.0, 0.0, 0.0, 0.9])
    for integrator in INTEGRATORS:
        end = model.step(state, [0.5, 5.0], 0.1, integrator)
        assert end[3] == pytest.approx(1.0)
    with pytest.raises(ValueError, match="gamma"):
        model.step([0.0, 0.0, 0.0, 1.2], [0.5, 0.0], 0.1)


# ---------------------------------------------------------------- batching and wrapping


@pytest.mark.parametrize("model", MODELS, ids=MODEL_IDS)
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_batched_call_equals_single_calls_exactly(model, integrator):
    rng = np.random.default_rng(7)
    states, inputs = sample_states(model, rng, 16), sample_inputs(model, rng, 16)
    batched = model.step(states, inputs, 0.1, integrator)
    singles = np.array(
        [model.step(s, u, 0.1, integrator) for s, u in zip(states, inputs, strict=True)]
    )
    np.testing.assert_array_equal(batched, singles)
    np.testing.assert_array_equal(
        model.derivative(states, inputs),
        [model.derivative(s, u) for s, u in zip(states, inputs, strict=True)],
    )


@pytest.mark.parametrize("model", MODELS, ids=MODEL_IDS)
def test_headings_stay_wrapped(model):
    rng = np.random.default_rng(3)
    states, inputs = sample_states(model, rng, 64), 5 * sample_inputs(model, rng, 64)
    for _ in range(200):
        states = model.step(states, inputs, 0.1)
    assert ((states[:, 2] > -math.pi) & (states[:, 2] <= math.pi)).all()


def test_wrap_angle_range():
    wrapped = wrap_angle([math.pi, -math.pi, 3 * math.pi, 0.5])
    np.testing.assert_allclose(wrapped, [math.pi, math.pi, math.pi, 0.5])


def test_heading_wrap_matches_wrap_angle_bit_for_bit():
    headings = np.array([math.pi, -math.pi, 3 * math.pi, -7.5, 12.0, 1e-17, -1e-17, 0.5, -0.0])
    np.testing.assert_array_equal([wrap_scalar_angle(a) for a in headings], wrap_angle(headings))
    states = np.stack([np.zeros_like(headings), np.zeros_like(headings), headings], axis=1)
    for integrator in INTEGRATORS:
        ends = DifferentialDrive().step(states, [0.0, 0.0], 0.1, integrator)
        np.testing.assert_array_equal(ends[:, 2], wrap_angle(headings))


# ---------------------------------------------------------------- compiled kernels


@pytest.mark.parametrize("model", MODELS, ids=MODEL_IDS)
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_advance_robot_in_place_equals_out_of_place_and_step(model, integrator):
    rng = np.random.default_rng(5)
    code = INTEGRATORS.index(integrator)
    for state, u in zip(sample_states(model, rng, 8), sample_inputs(model, rng, 8), strict=True):
        u = model.saturate(u)
        start = state.copy()
        out = np.empty_like(state)
        model.kernels.advance(model.kernel_parameters, state, u, 0.3, code, out)
        np.testing.assert_array_equal(state, start)
        model.kernels.advance(model.kernel_parameters, state, u, 0.3, code, state)
        np.testing.assert_array_equal(state, out)
        np.testing.assert_array_equal(out, model.step(start, u, 0.3, integrator))


@per_model()
def advance_in_place(parameters, states, inputs, dt, integrator_code):
    """How other compiled code drives a model: a template that calls ``model.advance``, one
    robot at a time, in place, compiled per model with ``for_model``."""
    for row in range(states.shape[0]):
        model.advance(parameters, states[row], inputs[row], dt, integrator_code, states[row])


@pytest.mark.parametrize("model", MODELS, ids=MODEL_IDS)
def test_advance_robot_called_from_compiled_code_equals_advance(model):
    rng = np.random.default_rng(9)
    states = sample_states(model, rng, 32)
    inputs = model.saturate(sample_inputs(model, rng, 32))
    for code, integrator in enumerate(INTEGRATORS):
        expected = model.advance(states, inputs, 0.1, integrator)
        got = states.copy()
        for_model(advance_in_place, model.compiled)(model.kernel_parameters, got, inputs, 0.1, code)
        np.testing.assert_array_equal(got, expected)


def twist_closed_form(model, state, u):
    if isinstance(model, ConstantVelocity):
        return u[0], u[2]
    if isinstance(model, DifferentialDrive):
        r, L = model.wheel_radius, model.track_width
        return r * (u[0] + u[1]) / 2, r * (u[0] - u[1]) / L
    if isinstance(model, Bicycle):
        return u[0], u[0] * math.tan(u[1]) / model.wheelbase
    return u[0] * math.cos(state[3]), u[0] * math.sin(state[3]) / model.wheelbase


@pytest.mark.parametrize(
    "model",
    [
        ConstantVelocity(),
        DifferentialDrive(wheel_radius=0.07, track_width=0.6),
        Bicycle(wheelbase=1.7),
        Tricycle(wheelbase=0.8),
    ],
    ids=lambda model: type(model).__name__,
)
def test_robot_twist_matches_the_closed_forms(model):
    rng = np.random.default_rng(13)
    for state, u in zip(sample_states(model, rng, 8), sample_inputs(model, rng, 8), strict=True):
        v, omega = model.kernels.twist(model.kernel_parameters, state, u)
        expected_v, expected_omega = twist_closed_form(model, state, u)
        assert v == pytest.approx(expected_v, rel=1e-14, abs=1e-15)
        assert omega == pytest.approx(expected_omega, rel=1e-14, abs=1e-15)
        assert (v, omega) == tuple(model.twist(state, u))


@pytest.mark.parametrize(
    ("model", "parameters"),
    [
        (ConstantVelocity(max_speed=2.0, max_angular_speed=3.0), [0, 0, 0, 0]),
        (DifferentialDrive(0.07, 0.6, 15.0), [0.07, 0.6, 0, 0]),
        (Bicycle(1.7, 0.5, 2.0), [1.7, 0, 0, 0]),
        (Tricycle(0.8, 1.2, 2.0, 3.0, substeps=6), [0.8, 1.2, 6, 0]),
    ],
    ids=lambda value: type(value).__name__,
)
def test_kernel_parameters_layout(model, parameters):
    assert model.kernel_parameters.dtype == np.float64
    assert model.kernel_parameters.flags.c_contiguous
    np.testing.assert_array_equal(model.kernel_parameters, parameters)


def test_integrator_codes_are_indices():
    assert INTEGRATORS == ("euler", "midpoint", "exact", "rk4")


# ---------------------------------------------------------------- twist bridge


@pytest.mark.parametrize("model", MODELS, ids=MODEL_IDS)
def test_inputs_for_reproduces_a_feasible_twist(model):
    model = type(model)()  # without limits: any twist is feasible
    rng = np.random.default_rng(11)
    states = sample_states(model, rng, 32)
    v = rng.uniform(0.1, 1.0, 32)
    omega = rng.uniform(-0.5, 0.5, 32) * v  # curvature <= 0.5: feasible for every model
    inputs = model.inputs_for(states, v, omega, dt=0.1)
    if isinstance(model, Tricycle):
        # The wheel reaches the wanted angle by the end of the step.
        states = model.step(states, inputs, 0.1)
        inputs = np.stack([inputs[:, 0], np.zeros(32)], axis=1)
    got_v, got_omega = model.twist(states, inputs)
    np.testing.assert_allclose(got_v, v, atol=1e-12)
    np.testing.assert_allclose(got_omega, omega, atol=1e-12)


def test_diff_drive_saturation_keeps_the_turning_radius():
    model = DifferentialDrive(max_wheel_speed=10.0)
    wheels = model.inputs_for([0, 0, 0], 1.0, 1.0)
    assert np.abs(wheels).max() == pytest.approx(10.0)
    v, omega = model.twist([0, 0, 0], wheels)
    assert v / omega == pytest.approx(1.0)


def test_bicycle_saturates_the_steering_angle():
    model = Bicycle(max_steering=math.pi / 6)
    v, gamma = model.inputs_for([0, 0, 0], 0.5, 5.0)
    assert (v, gamma) == (0.5, pytest.approx(math.pi / 6))
    assert model.inputs_for([0, 0, 0], 0.0, 1.0)[1] == pytest.approx(math.pi / 6)
    # Reversing: steering keeps the sign that turns the body the wanted way.
    reverse = model.inputs_for([0, 0, 0], -0.5, 0.2)
    assert model.twist([0, 0, 0], reverse)[1] == pytest.approx(0.2)


def test_inputs_are_saturated_to_the_limits():
    model = Bicycle(max_speed=1.0, max_steering=0.5)
    end = model.step([0, 0, 0], [3.0, 1.2], 1.0)
    np.testing.assert_allclose(end, model.step([0, 0, 0], [1.0, 0.5], 1.0))


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("factory", "parameter"),
    [
        (lambda: DifferentialDrive(wheel_radius=0.0), "wheel_radius"),
        (lambda: DifferentialDrive(track_width=-1.0), "track_width"),
        (lambda: DifferentialDrive(wheel_radius=math.nan), "wheel_radius"),
        (lambda: Bicycle(wheelbase=0.0), "wheelbase"),
        (lambda: Bicycle(max_steering=math.pi / 2), "max_steering"),
        (lambda: Bicycle(max_steering=0.0), "max_steering"),
        (lambda: Tricycle(max_steering=2.0), "max_steering"),
        (lambda: Tricycle(wheelbase=math.inf), "wheelbase"),
        (lambda: ConstantVelocity(max_speed=math.nan), "max_speed"),
        (lambda: make_model("hovercraft"), "hovercraft"),
    ],
)
def test_bad_parameters_raise_value_error_naming_them(factory, parameter):
    with pytest.raises(ValueError, match=parameter):
        factory()


@pytest.mark.parametrize("model", MODELS, ids=MODEL_IDS)
def test_nan_or_inf_in_state_or_input_raises(model):
    state = np.zeros(model.state_dim)
    u = np.zeros(model.input_dim)
    for bad in (math.nan, math.inf):
        bad_state, bad_u = state.copy(), u.copy()
        bad_state[0], bad_u[0] = bad, bad
        with pytest.raises(ValueError, match="state"):
            model.step(bad_state, u, 0.1)
        with pytest.raises(ValueError, match="u contains"):
            model.step(state, bad_u, 0.1)


@pytest.mark.parametrize("model", MODELS, ids=MODEL_IDS)
def test_wrong_shapes_raise_naming_the_expected_shape(model):
    k, m = model.state_dim, model.input_dim
    with pytest.raises(ValueError, match=rf"\({k},\) or \(N, {k}\)"):
        model.step(np.zeros(k + 1), np.zeros(m), 0.1)
    with pytest.raises(ValueError, match=rf"\({m},\) or \(N, {m}\)"):
        model.step(np.zeros(k), np.zeros((2, m + 1)), 0.1)
    with pytest.raises(ValueError, match="different numbers of robots"):
        model.step(np.zeros((3, k)), np.zeros((2, m)), 0.1)


def test_bad_dt_and_integrator_raise():
    model = DifferentialDrive()
    with pytest.raises(ValueError, match="dt"):
        model.step([0, 0, 0], [1, 1], 0.0)
    with pytest.raises(ValueError, match="integrator"):
        model.step([0, 0, 0], [1, 1], 0.1, "verlet")


# ---------------------------------------------------------------- models own their facts


def _input_corners(model):
    """Every corner of the model's input box, where its extremes of v and omega lie."""
    grids = np.meshgrid(*[[-high, 0.0, high] for high in model.input_high])
    return np.stack([grid.ravel() for grid in grids], axis=1)


@pytest.mark.parametrize("name", sorted(MODELS_BY_NAME := {m.name: m for m in MODELS}))
def test_top_speed_and_yaw_rate_are_the_extremes_of_the_twist_over_the_input_box(name):
    """Brute force over the input box's corners (with the env defaults' finite limits)."""
    model = make_model(name, **type(MODELS_BY_NAME[name]).env_defaults)
    corners = _input_corners(model)
    if isinstance(model, Tricycle):
        # The twist depends on the wheel angle (state), the inputs only steer it.
        gammas = np.linspace(-model.max_steering, model.max_steering, 341)
        states = np.zeros((len(gammas), 4))
        states[:, 3] = gammas
        v, omega = model.twist(states, np.tile([model.max_speed, 0.0], (len(gammas), 1)))
    else:
        v, omega = model.twist(np.zeros((len(corners), 3)), corners)
    assert np.max(np.abs(v)) == pytest.approx(model.top_speed, rel=1e-12)
    assert np.max(np.abs(omega)) == pytest.approx(model.top_yaw_rate, rel=1e-12)


@pytest.mark.parametrize("name", ["bicycle", "tricycle"])
def test_min_turning_radius_is_the_circle_at_full_lock(name):
    """Drive a full circle at the steering limit: its radius is the minimum."""
    model = make_model(name, **type(MODELS_BY_NAME[name]).env_defaults)
    state = np.zeros(model.state_dim)
    if isinstance(model, Tricycle):
        state[3] = model.max_steering
        inputs = np.array([0.5, 0.0])
    else:
        inputs = np.array([0.5, model.max_steering])
    points = [state[:2]]
    for _ in range(400):
        state = model.step(state, inputs, 0.05)
        points.append(state[:2])
    x, y = np.array(points).T
    # Least-squares circle x^2 + y^2 + D x + E y + F = 0 through the trajectory.
    D, E, F = np.linalg.lstsq(np.stack([x, y, np.ones_like(x)], 1), -(x**2 + y**2), rcond=None)[0]
    radius = math.sqrt(D**2 / 4 + E**2 / 4 - F)
    assert radius == pytest.approx(model.min_turning_radius, rel=1e-9)


def test_models_that_turn_on_the_spot_have_zero_turning_radius():
    assert ConstantVelocity().min_turning_radius == 0.0
    assert DifferentialDrive().min_turning_radius == 0.0


def test_every_model_names_its_env_id_and_observed_state():
    from mobile_envs.robots import FROM_INPUT, FROM_STATE

    assert {"bicycle", "constant_velocity", "diff_drive", "tricycle"} <= set(CATALOGUE)
    env_ids = [model.env_id for model in CATALOGUE.values()]
    assert len(set(env_ids)) == len(env_ids)
    assert {"ConstantVelocity", "DiffDrive", "Bicycle", "Tricycle"} <= set(env_ids)
    (wheel_angle,) = Tricycle(max_steering=1.0).observed_state
    assert (wheel_angle.name, wheel_angle.source, wheel_angle.column) == (
        "wheel_angle",
        FROM_STATE,
        Tricycle.state_names.index("gamma"),
    )
    assert wheel_angle.scale == 1.0
    (lateral,) = ConstantVelocity(max_speed=2.0).observed_state
    assert (lateral.source, ConstantVelocity.input_names[lateral.column]) == (FROM_INPUT, "v_y")
    assert lateral.scale == 0.5
    assert DifferentialDrive().observed_state == Bicycle().observed_state == ()


def test_a_model_whose_module_lacks_its_compiled_functions_is_refused_when_defined():
    from mobile_envs.robots import KinematicModel

    # This test module holds no advance, twist or rates: no model falls through to another's
    # physics, or to none.
    with pytest.raises(TypeError, match=r"lacks the compiled functions \['advance', 'twist'"):

        class Hovercraft(KinematicModel):
            name = "hovercraft"


def test_a_template_is_compiled_per_model_not_called_directly():
    from mobile_envs.robots.model import _advance_rows

    state, inputs = np.zeros((1, 3)), np.ones((1, 2))
    with pytest.raises(TypeError, match="for_model"):
        _advance_rows(np.zeros(4), state, inputs, 0.1, INTEGRATORS.index("exact"))

"""Wheel odometry (seed 000): encoders, dead reckoning and error growth against closed forms."""

import math

import numpy as np
import pytest

from mobile_envs._kernels.specialize import for_model
from mobile_envs.robots import (
    Bicycle,
    ConstantVelocity,
    DifferentialDrive,
    Tricycle,
)
from mobile_envs.robots.encoders import count_encoder
from mobile_envs.sensing.odometry import (
    DEAD_RECKONING_METHODS,
    OdometrySettings,
    WheelOdometry,
    _increments_rows,
    dead_reckoning,
    differential_increments,
    odometry_covariance,
)

DT = 0.1


def test_covariance_is_eq_17_element_by_element_and_broadcasts():
    covariance = odometry_covariance(0.5, -0.2, 2.0, 0.002, 0.004, 0.01)
    expected = np.diag(
        [0.002 * abs(0.5 * math.cos(2.0)), 0.002 * abs(0.5 * math.sin(2.0)), 0.004 * 0.5 + 0.002]
    )
    np.testing.assert_allclose(covariance, expected, rtol=1e-15)
    # The defaults are Crowley's coefficients; negative increments count by magnitude.
    np.testing.assert_allclose(
        odometry_covariance(-1.0, 0.0, 0.0), np.diag([0.001, 0.0, 0.003]), atol=1e-18
    )
    batch = odometry_covariance(np.ones((4, 1)), np.zeros(5), np.linspace(0, 1, 5))
    assert batch.shape == (4, 5, 3, 3)
    np.testing.assert_allclose(batch[2, 3], odometry_covariance(1.0, 0.0, 0.75), rtol=1e-15)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"k_distance": -0.1}, "k_distance"),
        ({"k_distance_heading": math.nan}, "k_distance_heading"),
        ({"k_heading": math.inf}, "k_heading"),
        ({"delta_distance": [1.0, math.nan]}, "delta_distance"),
        ({"heading": math.inf}, "heading"),
        ({"delta_heading": [1.0, 2.0, 3.0]}, "broadcast"),
    ],
)
def test_covariance_rejects_bad_input_by_name(kwargs, name):
    arguments = {"delta_distance": [1.0, 2.0], "delta_heading": 0.1, "heading": 0.0} | kwargs
    with pytest.raises(ValueError, match=name):
        odometry_covariance(**arguments)


def test_eq_16_turns_wheel_distances_into_distance_and_turn():
    distance, turn = differential_increments([0.3, 1.0], [0.1, 1.0], track_width=0.5)
    np.testing.assert_allclose(distance, [0.2, 1.0])
    np.testing.assert_allclose(turn, [0.4, 0.0])
    with pytest.raises(ValueError, match="track_width"):
        differential_increments(1.0, 1.0, track_width=0.0)


def geometric_sum_endpoint(start, distance, turn, steps, method):
    """Closed form of n equal steps of ``method`` (seed 000 eqs. 20, 26, 25) as a geometric
    series: Euler moves by d e^{i(theta0 + k beta)}, so n steps sum to
    d e^{i theta0} (e^{i n beta} - 1) / (e^{i beta} - 1); the midpoint steps are those turned
    by beta/2, the exact steps the midpoint ones shortened by sinc(beta/2)."""
    x0, y0, theta0 = start
    euler = (
        distance * np.exp(1j * theta0) * (np.exp(1j * steps * turn) - 1) / (np.exp(1j * turn) - 1)
    )
    midpoint = euler * np.exp(0.5j * turn)
    exact = midpoint * math.sin(turn / 2) / (turn / 2)
    moved = {"euler": euler, "midpoint": midpoint, "exact": exact}[method]
    return np.array([x0 + moved.real, y0 + moved.imag, theta0 + steps * turn])


@pytest.mark.parametrize("method", DEAD_RECKONING_METHODS)
@pytest.mark.parametrize("turn", [0.3, -0.05, 1.2])
def test_each_discretization_against_its_closed_form_on_an_arc(method, turn):
    start, distance, steps = (1.0, -2.0, 0.7), 0.4, 25
    poses = dead_reckoning(start, np.full(steps, distance), np.full(steps, turn), method)
    np.testing.assert_allclose(
        poses[-1], geometric_sum_endpoint(start, distance, turn, steps, method), atol=1e-12
    )


def test_exact_dead_reckoning_stays_on_the_circle_and_the_others_leave_it():
    """Eq. 25 lands on the arc of radius R = dD / dtheta itself; eq. 26 spirals out of it
    (its chords are too long by 1/sinc) and eq. 20 lags behind the turn."""
    distance, turn, steps = 0.5, 0.25, 40
    radius = distance / turn
    centre = np.array([0.0, radius])  # start at the origin heading east, turning left
    for method in DEAD_RECKONING_METHODS:
        poses = dead_reckoning((0, 0, 0), np.full(steps, distance), np.full(steps, turn), method)
        drift = np.abs(np.hypot(*(poses[:, :2] - centre).T) - radius).max()
        if method == "exact":
            assert drift < 1e-12
        else:
            assert drift > 1e-3


def test_exact_odometry_of_a_differential_drive_replays_the_kinematics():
    """Constant wheel speeds over a step drive an exact arc: the wheels roll (R +- L/2) dtheta
    (eqs. 21, 22) and eq. 25 reproduces the model's exact step to rounding."""
    model = DifferentialDrive(wheel_radius=0.05, track_width=0.4)
    odometry = WheelOdometry(model, k_distance=0, k_distance_heading=0, k_heading=0)
    rng = np.random.default_rng(3)
    state = np.array([2.0, 1.0, 0.3])
    estimate = state.copy()
    for _ in range(200):
        inputs = rng.uniform(-20.0, 20.0, 2)
        after = model.step(state, inputs, DT)
        distance, turn, _ = odometry.increments(state, after, inputs, DT)
        true_turn = math.remainder(after[2] - state[2], 2 * math.pi)
        assert turn == pytest.approx(true_turn, abs=1e-12)
        radius = float(model.turning_radius(inputs))
        if math.isfinite(radius):
            right = inputs[0] * model.wheel_radius * DT
            assert right == pytest.approx((radius + model.track_width / 2) * true_turn)
            assert distance == pytest.approx(radius * true_turn)
        estimate = odometry.step(estimate, state, after, inputs, DT)[0]
        state = after
    np.testing.assert_allclose(estimate[:2], state[:2], atol=1e-10)
    assert math.remainder(estimate[2] - state[2], 2 * math.pi) == pytest.approx(0, abs=1e-10)


def test_bicycle_odometry_reads_traction_and_steering():
    model = Bicycle(wheelbase=1.2)
    odometry = WheelOdometry(model, k_distance=0, k_distance_heading=0, k_heading=0)
    state, inputs = np.array([0.0, 0.0, 0.5]), np.array([0.8, 0.3])
    after = model.step(state, inputs, DT)
    distance, turn, _ = odometry.increments(state, after, inputs, DT)
    assert distance == pytest.approx(0.08)
    assert turn == pytest.approx(0.08 * math.tan(0.3) / 1.2)
    estimate = odometry.step(state, state, after, inputs, DT)[0]
    np.testing.assert_allclose(estimate, after, atol=1e-14)


def test_tricycle_odometry_follows_the_drive_wheel_and_the_steering():
    """With gamma held, O rolls v cos(gamma) dt on an exact arc; while gamma turns, the
    odometry's linear-gamma means track the model's sub-stepped arcs closely."""
    model = Tricycle(wheelbase=1.0)
    odometry = WheelOdometry(model, k_distance=0, k_distance_heading=0, k_heading=0)
    state, inputs = np.array([0.0, 0.0, 0.0, 0.4]), np.array([0.5, 0.0])
    after = model.step(state, inputs, DT)
    distance, turn, _ = odometry.increments(state, after, inputs, DT)
    assert distance == pytest.approx(0.05 * math.cos(0.4), rel=1e-14)
    assert turn == pytest.approx(after[2] - state[2], rel=1e-13)
    np.testing.assert_allclose(odometry.step(state[:3], state, after, inputs, DT)[0], after[:3])

    estimate = state[:3].copy()
    for k in range(300):
        inputs = np.array([0.5, 0.6 * math.cos(0.05 * k)])
        after = model.step(state, inputs, DT)
        estimate = odometry.step(estimate, state, after, inputs, DT)[0]
        state = after
    # 15 m driven with the wheel always turning: within a millimetre.
    np.testing.assert_allclose(estimate[:2], state[:2], atol=1e-3)


def test_encoders_count_whole_counts_and_carry_the_rest():
    """Every reading is a whole number of counts and the counted total trails the true one by
    the carried residual, always within [0, one count): nothing is lost to rounding."""
    counts = 100
    one_count = 2 * math.pi / counts
    rng = np.random.default_rng(7)
    residual, true_total, counted_total = 0.0, 0.0, 0.0
    for _ in range(2000):
        rotation = rng.uniform(-0.2, 0.3)
        measured, residual = count_encoder(rotation, residual, counts)
        assert abs(measured / one_count - round(measured / one_count)) < 1e-9
        true_total += rotation
        counted_total += measured
        assert 0.0 <= residual < one_count
        assert true_total - counted_total == pytest.approx(residual, abs=1e-9)
    assert count_encoder(0.123, 0.0, 0) == (0.123, 0.0)  # 0 counts: an ideal encoder


def test_quantized_wheels_reach_the_distance_rolled_within_a_count():
    model = DifferentialDrive(wheel_radius=0.05, track_width=0.4)
    odometry = WheelOdometry(
        model, k_distance=0, k_distance_heading=0, k_heading=0, encoder_counts=500
    )
    state, residuals, travelled = np.zeros(3), np.zeros((1, 2)), 0.0
    for _ in range(100):
        inputs = np.array([7.3, 7.3])
        after = model.step(state, inputs, DT)
        distance, _, residuals = odometry.increments(state, after, inputs, DT, residuals)
        travelled += float(distance)
        state = after
    one_count = 2 * math.pi / 500 * 0.05
    assert 0.0 <= state[0] - travelled < one_count
    assert travelled != pytest.approx(state[0], abs=1e-12)  # it did quantize


def test_a_wheel_radius_mismatch_curves_a_straight_run():
    """Right wheel assumed r (1 + e/2), left r (1 - e/2): on a straight run the odometry
    turns (dD_R - dD_L)/L' = e d / L' a step, so it draws an arc of curvature e / L' with
    L' = L (1 + e_L), as Borenstein's E_d predicts."""
    radius_error, wheelbase_error = 0.01, 0.05
    model = DifferentialDrive(wheel_radius=0.05, track_width=0.4)
    odometry = WheelOdometry(
        model,
        k_distance=0,
        k_distance_heading=0,
        k_heading=0,
        wheel_radius_error=radius_error,
        wheelbase_error=wheelbase_error,
    )
    state = estimate = np.zeros(3)
    inputs = np.array([10.0, 10.0])
    for _ in range(100):
        after = model.step(state, inputs, DT)
        estimate = odometry.step(estimate, state, after, inputs, DT)[0]
        state = after
    curvature = radius_error / (0.4 * (1 + wheelbase_error))
    length = state[0]  # 5 m
    expected = (
        np.array([math.sin(curvature * length), 1 - math.cos(curvature * length)]) / curvature
    )
    np.testing.assert_allclose(estimate[:2], expected, atol=1e-10)
    assert estimate[2] == pytest.approx(curvature * length)


def test_a_wheelbase_error_scales_a_turn_on_the_spot():
    model = DifferentialDrive(wheel_radius=0.05, track_width=0.4)
    odometry = WheelOdometry(
        model, k_distance=0, k_distance_heading=0, k_heading=0, wheelbase_error=-0.1
    )
    inputs, state = np.array([3.0, -3.0]), np.zeros(3)
    after = model.step(state, inputs, DT)
    _, turn, _ = odometry.increments(state, after, inputs, DT)
    assert turn == pytest.approx(after[2] / 0.9)


def expected_abs_sin(variance):
    """E|sin theta| for theta ~ N(0, variance), from the Fourier series of |sin|:
    |sin t| = 2/pi - (4/pi) sum_m cos(2 m t) / (4 m^2 - 1), and E cos(2 m t) = e^{-2 m^2 var}."""
    m = np.arange(1, 200_001)
    return 2 / math.pi * (1 - 2 * np.sum(np.exp(-2 * m**2 * variance) / (4 * m**2 - 1)))


def straight_run_moments(distance, steps, k_distance, k_distance_heading):
    """Closed-form variances of the odometry error after ``steps`` straight steps of length d.

    The heading estimate is a random walk, theta_k = w_0 + ... + w_{k-1}, w ~ N(0, q) with
    q = K_Dtheta d (Q33; dtheta = 0), so Var theta_n = n q = sum of Q33. With Euler (and the
    other two, dtheta being 0) x_n = sum_k (d cos theta_k + v_k), y_n = sum_k (d sin theta_k
    + u_k), v_k and u_k ~ N(0, K_D d |cos theta_k|), N(0, K_D d |sin theta_k|) independent of
    the rest. For Gaussian a, b: E cos a = e^{-Var a/2}, E sin a sin b =
    (e^{-Var(a-b)/2} - e^{-Var(a+b)/2}) / 2, E cos a cos b = (e^{-Var(a-b)/2} +
    e^{-Var(a+b)/2}) / 2, and for j <= k Var(theta_k - theta_j) = (k - j) q,
    Var(theta_k + theta_j) = (k + 3 j) q. |cos theta_k| = cos theta_k here: theta stays within
    9 standard deviations of pi/2.
    """
    q = k_distance_heading * distance
    j, k = np.meshgrid(np.arange(steps), np.arange(steps), indexing="ij")
    low, high = np.minimum(j, k), np.maximum(j, k)
    minus, plus = np.exp(-(high - low) * q / 2), np.exp(-(high + 3 * low) * q / 2)
    mean_cos = np.exp(-np.arange(steps) * q / 2)
    cos_covariance = (minus + plus) / 2 - np.outer(mean_cos, mean_cos)
    x_variance = k_distance * distance * mean_cos.sum() + distance**2 * cos_covariance.sum()
    abs_sin = np.array([expected_abs_sin(index * q) for index in range(steps)])
    y_variance = distance**2 * ((minus - plus) / 2).sum() + k_distance * distance * abs_sin.sum()
    return x_variance, y_variance, steps * q


@pytest.mark.parametrize("steps", [20, 100])
def test_monte_carlo_error_growth_on_a_straight_line_matches_eq_17(steps):
    """20 000 robots drive the same line, 2 m or 10 m; the spread of their odometry against
    the truth is the closed form of :func:`straight_run_moments` within sampling error (4.5
    standard errors of each sample variance, estimated from its own fourth moment).

    The heading's variance is the plain sum of Q33. Over 2 m the heading stays close enough
    to 0 that x's is the sum of Q11 (0.4 % above it, under the 1 % sampling error); over 10 m
    the cos fluctuations of the drifting heading add 71 %. y's is almost all heading error
    propagated: sum_jk d^2 E[sin theta_j sin theta_k], about d^2 q n^3 / 3.
    """
    robots, distance = 20_000, 0.1
    model = DifferentialDrive(wheel_radius=0.05, track_width=0.4)
    odometry = WheelOdometry(model)  # Crowley's K_D, K_Dtheta, K_theta
    inputs = np.full((robots, 2), distance / DT / model.wheel_radius)
    state = np.zeros((robots, 3))
    estimates, residuals = state.copy(), None
    rng = np.random.default_rng(2024)
    for _ in range(steps):
        after = model.step(state, inputs, DT)
        estimates, residuals = odometry.step(estimates, state, after, inputs, DT, residuals, rng)
        state = after
    errors = estimates - state
    x_var, y_var, heading_var = straight_run_moments(distance, steps, 0.001, 0.003)
    sum_q11, sum_q33 = steps * 0.001 * distance, steps * 0.003 * distance
    assert heading_var == pytest.approx(sum_q33)
    if steps == 20:
        assert x_var == pytest.approx(sum_q11, rel=0.005)
    else:
        assert x_var == pytest.approx(1.71 * sum_q11, rel=0.01)
    # Linearized, y_n = d sum_k theta_k = d sum_i (n - 1 - i) w_i: d^2 q sum_m m^2.
    linear_y_var = distance**2 * (sum_q33 / steps) * (steps - 1) * steps * (2 * steps - 1) / 6
    assert y_var == pytest.approx(linear_y_var, rel=0.05)
    # x falls short on average: E cos theta_k = e^{-k q / 2} < 1. y and the heading are
    # symmetric about 0.
    x_mean = -distance * np.sum(1 - np.exp(-np.arange(steps) * (sum_q33 / steps) / 2))
    assert_error_moments(errors, (x_mean, 0.0, 0.0), (x_var, y_var, heading_var))


def assert_error_moments(errors, expected_means, expected_variances):
    """Each column of ``errors`` (one row a robot) has its expected mean and variance, each
    within 4.5 standard errors of its sample estimate."""
    robots = len(errors)
    moments = zip(expected_means, expected_variances, strict=True)
    for column, (expected_mean, expected_var) in enumerate(moments):
        deviations = errors[:, column] - errors[:, column].mean()
        standard_error = math.sqrt((deviations**2).var() / robots)
        assert abs((deviations**2).mean() - expected_var) < 4.5 * standard_error, column
        mean_error = errors[:, column].mean() - expected_mean
        assert abs(mean_error) < 4.5 * math.sqrt(expected_var / robots), column


def test_noise_comes_from_the_callers_generator_bit_for_bit():
    model = DifferentialDrive()
    odometry = WheelOdometry(model, method="midpoint")
    states = np.zeros((3, 3))
    inputs = np.array([[5.0, 4.0], [1.0, -1.0], [0.0, 3.0]])
    after = model.step(states, inputs, DT)
    batch = odometry.step(states, states, after, inputs, DT, rng=np.random.default_rng(5))[0]
    rng = np.random.default_rng(5)
    normals = rng.standard_normal((3, 3))
    for robot in range(3):
        replay = _Replay(normals[robot])
        one = odometry.step(
            states[robot], states[robot], after[robot], inputs[robot], DT, rng=replay
        )[0]
        assert np.array_equal(one, batch[robot])


class _Replay:
    """A stand-in generator that hands back given normals."""

    def __init__(self, normals):
        self.normals = normals

    def standard_normal(self, shape):
        return self.normals.reshape(shape)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"method": "rk4"}, "method"),
        ({"k_distance": -1.0}, "k_distance"),
        ({"k_heading": "lots"}, "k_heading"),
        ({"wheel_radius_error": 1.0}, "wheel_radius_error"),
        ({"wheelbase_error": math.nan}, "wheelbase_error"),
        ({"encoder_counts": 0}, "encoder_counts"),
        ({"encoder_counts": 2.5}, "encoder_counts"),
        ({"encoder_counts": True}, "encoder_counts"),
        ({"steering_counts": -4}, "steering_counts"),
        ({"encoder_counts": 1024}, "traction_wheel_radius"),
        ({"encoder_counts": 1024, "traction_wheel_radius": -0.1}, "traction_wheel_radius"),
    ],
)
def test_bad_settings_raise_value_errors_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        WheelOdometry(Tricycle(), **kwargs)


def test_bad_calls_raise_value_errors_naming_the_argument():
    with pytest.raises(ValueError, match="model"):
        WheelOdometry(ConstantVelocity())
    odometry = WheelOdometry(DifferentialDrive())
    good = np.zeros(3), np.zeros(3), np.zeros(2), DT
    with pytest.raises(ValueError, match="states_after"):
        odometry.increments(good[0], np.zeros(4), good[2], DT)
    with pytest.raises(ValueError, match="inputs"):
        odometry.increments(good[0], good[1], [math.nan, 0.0], DT)
    with pytest.raises(ValueError, match="dt"):
        odometry.increments(*good[:3], 0.0)
    with pytest.raises(ValueError, match="residuals"):
        odometry.increments(*good, residuals=np.zeros(2))
    with pytest.raises(ValueError, match="estimates"):
        odometry.step(np.zeros((2, 3)), *good)
    with pytest.raises(ValueError, match="method"):
        dead_reckoning((0, 0, 0), [1.0], [0.0], method="rk4")
    with pytest.raises(ValueError, match="delta_heading"):
        dead_reckoning((0, 0, 0), [1.0, 2.0], [0.0])


def test_the_encoder_kernel_refuses_a_model_it_has_no_encoders_for():
    """No model falls through to another's physics: compiled for the constant-velocity
    model, which has no wheels, the encoder kernel raises instead of counting anything."""
    model = ConstantVelocity()
    state = np.zeros((1, 3))
    settings = OdometrySettings().encoder_settings
    increments = for_model(_increments_rows, model.compiled)
    with pytest.raises(ValueError, match="no encoders"):
        increments(
            model.kernel_parameters, settings, state, state, np.array([[0.5, 0.1, 0.0]]), DT,
            np.zeros((1, 2)),
        )  # fmt: skip


def test_the_settings_are_checked_without_a_model_and_the_steering_read_to_its_count():
    with pytest.raises(ValueError, match="wheelbase_error"):
        OdometrySettings(wheelbase_error=-1.0)
    with pytest.raises(ValueError, match="traction_wheel_radius"):
        OdometrySettings(traction_wheel_radius=0.0)
    one_count = 2 * math.pi / 1000
    odometry = WheelOdometry(Tricycle(), steering_counts=1000)
    gammas = np.array([0.0, 0.4 * one_count, 0.6 * one_count, -2.3 * one_count, 0.5])
    read = odometry.read_steering(gammas)
    np.testing.assert_allclose(read / one_count, np.round(gammas / one_count), atol=1e-12)
    assert np.abs(read - gammas).max() <= one_count / 2
    np.testing.assert_array_equal(WheelOdometry(Tricycle()).read_steering(gammas), gammas)

"""The mecanum robot against its wheel equations, and driven as any other model.

The generic properties (integrator orders, exact arcs against the closed form, batching,
wrapping, the twist bridge, its top speed and yaw rate) run on it in test_kinematics.py,
which reads the catalogue of models.
"""

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import mobile_envs  # noqa: F401  (registers the ids)
from agents import PurePursuit, RegulatedPurePursuit, evaluate
from mobile_envs.envs.registration import path_set_ids
from mobile_envs.robots import MODELS, make_model

R, LX, LY = 0.05, 0.2, 0.2


def twist_of_wheels(wheels, r=R, lx=LX, ly=LY):
    """The issue's body twist, written out wheel by wheel (FL, FR, RL, RR)."""
    fl, fr, rl, rr = wheels
    return (
        r / 4 * (fl + fr + rl + rr),
        r / 4 * (-fl + fr + rl - rr),
        r / (4 * (lx + ly)) * (-fl + fr - rl + rr),
    )


def test_it_is_in_the_catalogue_with_its_facts():
    model = make_model("mecanum", **MODELS["mecanum"].env_defaults)
    assert (model.wheel_radius, model.half_wheelbase, model.half_track) == (R, LX, LY)
    assert model.top_speed == pytest.approx(1.0)
    assert model.top_yaw_rate == pytest.approx(R * 20.0 / (LX + LY))
    assert model.min_turning_radius == 0.0
    assert model.input_names == ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
    np.testing.assert_array_equal(model.input_high, [20.0] * 4)


@pytest.mark.parametrize(
    ("wheels", "direction"),
    [
        ((10, 10, 10, 10), "forward"),
        ((-10, 10, 10, -10), "left"),
        ((-10, 10, -10, 10), "turn"),
    ],
)
def test_the_wheel_patterns_move_forward_sideways_and_turn_on_the_spot(wheels, direction):
    model = make_model("mecanum")
    start = np.array([1.0, 2.0, 0.3])
    end = model.step(start, wheels, 0.5)
    v_x, v_y, omega = twist_of_wheels(wheels)
    if direction == "forward":
        assert (v_y, omega) == (0.0, 0.0)
        expected = start + np.array([v_x * 0.5 * math.cos(0.3), v_x * 0.5 * math.sin(0.3), 0.0])
    elif direction == "left":
        assert (v_x, omega) == (0.0, 0.0)
        expected = start + np.array([-v_y * 0.5 * math.sin(0.3), v_y * 0.5 * math.cos(0.3), 0.0])
    else:
        assert (v_x, v_y) == (0.0, 0.0)
        expected = start + np.array([0.0, 0.0, omega * 0.5])
    np.testing.assert_allclose(end, expected, rtol=0, atol=1e-15)


def test_the_body_twist_is_the_wheel_equations_for_random_wheels():
    model = make_model("mecanum", wheel_radius=0.07, half_wheelbase=0.3, half_track=0.15)
    rng = np.random.default_rng(0)
    for wheels in rng.uniform(-20, 20, (50, 4)):
        expected = twist_of_wheels(wheels, 0.07, 0.3, 0.15)
        rates = model.derivative([0.0, 0.0, 0.0], wheels)  # at heading 0: the body frame
        np.testing.assert_allclose(rates, expected, rtol=1e-14, atol=1e-15)
        v, omega = model.twist([0.0, 0.0, 0.0], wheels)
        assert (float(v), float(omega)) == pytest.approx((expected[0], expected[2]), rel=1e-14)


def test_the_inverse_kinematics_inverts_the_wheel_equations():
    model = make_model("mecanum")
    rng = np.random.default_rng(1)
    v_x, v_y, omega = rng.uniform(-1, 1, (3, 40))
    wheels = model.wheel_speeds(v_x, v_y, omega)
    for row, twist in zip(wheels, np.stack([v_x, v_y, omega], axis=1), strict=True):
        np.testing.assert_allclose(twist_of_wheels(row), twist, rtol=0, atol=1e-14)


def test_the_twist_bridge_saturates_all_wheels_by_one_factor():
    model = make_model("mecanum", max_wheel_speed=10.0)
    wheels = model.inputs_for([0, 0, 0], 1.0, 2.0)  # asks for 20 + 8 rad/s on some wheels
    assert np.abs(wheels).max() == pytest.approx(10.0)
    v_x, v_y, omega = twist_of_wheels(wheels)
    assert v_y == pytest.approx(0.0, abs=1e-15)
    assert omega / v_x == pytest.approx(2.0)  # the same curvature, slower


def test_ids_exist_for_every_path_set_and_pass_the_env_checker():
    ids = [env_id for env_id in gym.registry if env_id.startswith("mobile_envs/Mecanum-")]
    for set_id in path_set_ids():
        assert f"mobile_envs/Mecanum-{set_id}-v0" in ids
    env = gym.make("mobile_envs/Mecanum-Maze-v0")
    check_env(env.unwrapped)
    assert env.action_space.shape == (4,)


@pytest.mark.parametrize("agent", [PurePursuit, RegulatedPurePursuit])
@pytest.mark.parametrize("paths", ["Lines", "Segments", "SharpSegments", "Maze"])
def test_pure_pursuit_and_rpp_drive_it_through_the_twist_bridge(agent, paths):
    result = evaluate(agent(), f"mobile_envs/Mecanum-{paths}-v0", episodes=3)
    assert result.summary["completion_rate"] == 1.0
    assert result.summary["mean_abs_cte"] < 0.1

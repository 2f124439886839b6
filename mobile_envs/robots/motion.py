"""Compiled motion shared by the models: arcs, the rigid-body step and Runge-Kutta sums.

A model whose native inputs fix its body twist (v_x, v_y, omega) over a step (the constant
velocity robot, the differential drive, the bicycle, the mecanum robot) moves along an arc:
:func:`rigid_body_step` advances it by any integrator from that twist alone, so those
models' modules only say how their inputs make the twist. No fast-math: the same inputs
give the same bits.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from mobile_envs._kernels import exact_math

#: Integrator names; a kernel's integrator code is the name's index here.
INTEGRATORS = ("euler", "midpoint", "exact", "rk4")
EULER, MIDPOINT, EXACT, RK4 = range(len(INTEGRATORS))


@njit(cache=True)
def clip(value: float, limit: float) -> float:
    """``value`` clipped to [-limit, limit], as ``np.clip`` does."""
    return min(max(value, -limit), limit)


@njit(cache=True)
def sinc(half_turn: float) -> float:
    """sin(h) / h, and 1 at h = 0: an arc's chord over its length (Bermúdez 2003, eq. 25)."""
    if half_turn == 0.0:
        return 1.0
    return math.sin(half_turn) / half_turn


@njit(cache=True)
def arc_displacement(heading, v_x, v_y, omega, dt, integrator_code):
    """World-frame displacement over ``dt`` of a body moving at a constant body twist.

    The body velocity (v_x, v_y) rotates with the heading; integrating exactly gives the
    displacement along the mid-step heading times sinc(omega dt / 2) (Bermúdez 2003, eq. 25).
    Euler takes the heading at the step's start, midpoint the mid-step heading unshortened.
    """
    direction, shrink = heading, 1.0
    if integrator_code != EULER:
        half_turn = 0.5 * omega * dt
        direction = heading + half_turn
        if integrator_code == EXACT:
            shrink = sinc(half_turn)
    cos_d, sin_d = math.cos(direction), math.sin(direction)
    dx = (v_x * cos_d - v_y * sin_d) * dt * shrink
    dy = (v_x * sin_d + v_y * cos_d) * dt * shrink
    return dx, dy


@njit(cache=True)
def rk4_increment(dt, k1, k2, k3, k4):
    """The classical Runge-Kutta sum dt / 6 (k1 + 2 k2 + 2 k3 + k4)."""
    return dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


@njit(cache=True, inline="always")
def body_rates(heading, v_x, v_y, omega):
    """The pose's time derivative (x', y', heading') under the body twist (v_x, v_y, omega)."""
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    return v_x * cos_h - v_y * sin_h, v_x * sin_h + v_y * cos_h, omega


@njit(cache=True, inline="always")
def rigid_body_step(x, y, heading, v_x, v_y, omega, dt, integrator_code):
    """One step of a body holding the twist (v_x, v_y, omega): the new (x, y, heading), the
    heading not wrapped. Euler, midpoint and exact follow :func:`arc_displacement`; RK4
    samples :func:`body_rates` at the step's start, middle (twice) and end."""
    if integrator_code == RK4:
        half = 0.5 * dt
        k1 = body_rates(heading, v_x, v_y, omega)
        k2 = body_rates(heading + half * k1[2], v_x, v_y, omega)
        k3 = body_rates(heading + half * k2[2], v_x, v_y, omega)
        k4 = body_rates(heading + dt * k3[2], v_x, v_y, omega)
        return (
            x + rk4_increment(dt, k1[0], k2[0], k3[0], k4[0]),
            y + rk4_increment(dt, k1[1], k2[1], k3[1], k4[1]),
            heading + rk4_increment(dt, k1[2], k2[2], k3[2], k4[2]),
        )
    dx, dy = arc_displacement(heading, v_x, v_y, omega, dt, integrator_code)
    return x + dx, y + dy, heading + omega * dt


def steering_for(
    wheelbase: float, v: NDArray[np.float64], omega: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The steering angle gamma with tan(gamma) = L omega / v of a car-like robot (numpy);
    +-pi/2 is asked for when v = 0."""
    forward = np.where(v < 0.0, -1.0, 1.0)
    return exact_math.arctan2(wheelbase * omega * forward, np.abs(v))


def scale_into_limit(inputs: NDArray[np.float64], limit: float) -> NDArray[np.float64]:
    """Each row of ``inputs`` scaled by one factor so that its largest magnitude is at most
    ``limit``: wheel speeds that keep the direction (and turning radius) they ask for."""
    peak = np.abs(inputs).max(axis=1, keepdims=True)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        scale = np.where(peak > limit, limit / peak, 1.0)
    return inputs * scale


def rim_speeds_into_limit(
    rim: NDArray[np.float64], radius: float, max_wheel_speed: float
) -> NDArray[np.float64]:
    """Wheel speeds (rad/s) for the wheels' rim speeds ``rim`` (N, W) (m/s), each row scaled
    by one factor into ``max_wheel_speed`` (:func:`scale_into_limit`). A row whose division
    by ``radius`` overflows (speeds near float64's maximum) is scaled before it is divided,
    so that it saturates instead of turning into inf and NaN."""
    with np.errstate(over="ignore", invalid="ignore"):  # found and redone below
        wheels = scale_into_limit(rim / radius, max_wheel_speed)
    overflowed = ~np.isfinite(wheels).all(axis=1)
    if overflowed.any():
        wheels[overflowed] = scale_into_limit(rim[overflowed], max_wheel_speed * radius) / radius
    return wheels


def apply_steering_error(
    rows: NDArray[np.float64],
    name: str,
    error: NDArray[np.float64],
    wheelbase_column: int,
    offset_column: int,
) -> None:
    """A car-like robot's true parameters: its wheelbase times (1 + error) for
    ``"wheelbase"``, its steering misaligned by ``error`` radians for ``"steering_offset"``."""
    if name == "wheelbase":
        rows[:, wheelbase_column] *= 1.0 + error
    else:
        rows[:, offset_column] = error

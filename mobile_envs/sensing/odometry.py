"""Wheel odometry and its error model (seed 000, Bermúdez 2003, eqs. 14-26).

A robot's odometry integrates what its encoders measure, one step at a time:

    X(k+1) = f(X(k), U(k)) + v(k),    U(k) = [dD(k), dtheta(k)]          (eqs. 14, 15)

- **Encoders.** The differential drive counts each wheel's turn: dD = (dD_R + dD_L) / 2 and
  dtheta = (dD_R - dD_L) / L (eq. 16, :func:`differential_increments`). The bicycle and the
  tricycle have a traction encoder (the distance of the bicycle's reference point, of the
  tricycle's drive wheel C) and a steering encoder (gamma), as seed 003's robot does.
  Incremental encoders count whole counts: a step's fraction of a count is kept (the
  *residual*) and counted in a later step, so no distance is lost to rounding.
- **f**, the dead-reckoning step (:func:`dead_reckoning`): ``"euler"`` (eq. 20, along the
  heading at the step's start), ``"midpoint"`` (eq. 26, along the mid-step heading) or
  ``"exact"`` (eq. 25, the chord of the arc: the mid-step heading, the length shortened by
  sin(dtheta/2) / (dtheta/2)).
- **v(k) ~ N(0, Q(k))** (eq. 17, :func:`odometry_covariance`), after Crowley & Chenavier
  (1992): Q = diag(K_D |dD cos theta|, K_D |dD sin theta|, K_Dtheta |dD| + K_theta |dtheta|)
  with theta the estimated heading at the step's start.
- **Systematic errors** (Borenstein & Feng 1995): the radii and the track width (wheelbase)
  the odometry assumes differ from the robot's by given fractions.

The per-robot work is in numba kernels (:func:`measure_increments`,
:func:`dead_reckoning_step`, :func:`advance_odometry`) taking plain floats and arrays, so
compiled code can run a robot's odometry without a Python call. They draw nothing: the noise
comes in as three standard normals per step, drawn by the caller from the robot's own
generator. :class:`WheelOdometry` holds validated settings and runs the kernels on batches.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from mobile_envs._kernels import exact_math
from mobile_envs._kernels.angles import wrap_scalar_angle
from mobile_envs._kernels.specialize import for_model, model, per_model
from mobile_envs.robots import INTEGRATORS, KinematicModel
from mobile_envs.robots.encoders import EncoderSetting, count_encoder
from mobile_envs.validation import (
    as_choice,
    as_finite_array,
    as_in_open_interval,
    as_non_negative,
    as_optional_count,
    as_positive,
    as_rows,
)

__all__ = [
    "DEAD_RECKONING_METHODS",
    "DEFAULT_K_DISTANCE",
    "DEFAULT_K_DISTANCE_HEADING",
    "DEFAULT_K_HEADING",
    "OdometrySettings",
    "WheelOdometry",
    "advance_odometry",
    "count_encoder",
    "dead_reckoning",
    "dead_reckoning_step",
    "differential_increments",
    "measure_increments",
    "noisy_dead_reckoning",
    "odometry_covariance",
    "odometry_motion",
    "odometry_variances",
]

#: Discretizations of the odometry step; a kernel's method code is the name's index here,
#: the same code as :data:`mobile_envs.robots.model.INTEGRATORS` gives the name.
DEAD_RECKONING_METHODS = INTEGRATORS[:3]
_EULER, _MIDPOINT, _EXACT = range(3)

#: Crowley & Chenavier's typical coefficients, as seed 000 quotes them.
DEFAULT_K_DISTANCE = 0.001  # m^2/m
DEFAULT_K_DISTANCE_HEADING = 0.003  # rad^2/m
DEFAULT_K_HEADING = 0.001  # rad^2/rad

# Layout of WheelOdometry.kernel_parameters, a float64 array of _PARAMETER_COUNT (what the
# encoders count and what the odometry assumes of the robot is its encoder_settings, laid
# out as mobile_envs.robots.encoders.EncoderSetting says):
_K_DISTANCE = 0  # K_D (m^2/m)
_K_DISTANCE_HEADING = 1  # K_Dtheta (rad^2/m)
_K_HEADING = 2  # K_theta (rad^2/rad)
_METHOD = 3  # DEAD_RECKONING_METHODS index
_PARAMETER_COUNT = 4

Array = NDArray[np.float64]


# ---------------------------------------------------------------- compiled kernels
# No fastmath: the same inputs give the same bits, whatever the batch.


@njit(cache=True)
def odometry_variances(
    delta_distance: float,
    delta_heading: float,
    heading: float,
    k_distance: float,
    k_distance_heading: float,
    k_heading: float,
) -> tuple[float, float, float]:
    """The diagonal (Q11, Q22, Q33) of eq. 17's Q(k), for compiled code.

    :param delta_distance: dD(k) (m)
    :param delta_heading: dtheta(k) (rad)
    :param heading: theta(k), the heading at the step's start (rad)
    """
    return (
        k_distance * abs(delta_distance * math.cos(heading)),
        k_distance * abs(delta_distance * math.sin(heading)),
        k_distance_heading * abs(delta_distance) + k_heading * abs(delta_heading),
    )


@njit(cache=True)
def dead_reckoning_step(
    x: float, y: float, heading: float, delta_distance: float, delta_heading: float, method: int
) -> tuple[float, float, float]:
    """One noise-free odometry step f(X(k), U(k)): eq. 20, 26 or 25 by ``method``.

    :param method: ``DEAD_RECKONING_METHODS.index(name)``
    :return: (x, y, heading) after the step, the heading not wrapped
    """
    direction, length = heading, delta_distance
    if method != _EULER:
        half_turn = 0.5 * delta_heading
        direction = heading + half_turn
        if method == _EXACT and half_turn != 0.0:
            length = delta_distance * math.sin(half_turn) / half_turn
    return (
        x + length * math.cos(direction),
        y + length * math.sin(direction),
        heading + delta_heading,
    )


@per_model(inline="always")
def measure_increments(
    model_parameters: Array,
    encoder_settings: Array,
    state_before: Array,
    state_after: Array,
    inputs: Array,
    dt: float,
    residuals: Array,
) -> tuple[float, float]:
    """U(k) = (dD, dtheta): what one robot's encoders make of its step, as its model's
    ``encoder_increments`` reads them (eq. 16 for the differential drive; the traction and
    steering encoders of the car-like robots). A template compiled per model
    (:func:`~mobile_envs._kernels.specialize.for_model`); a model without encoders has none.

    :param model_parameters: the model's ``kernel_parameters``
    :param encoder_settings: :attr:`WheelOdometry.encoder_settings`
    :param state_before: the robot's true state at the step's start
    :param state_after: its true state at the step's end (the tricycle's gamma is read there)
    :param inputs: the saturated native inputs held over the step
    :param dt: the step (s)
    :param residuals: (2,) the encoders' carried fractions of a count, updated in place:
        right and left wheel, or traction wheel and unused
    """
    return model.encoder_increments(
        model_parameters, encoder_settings, state_before, state_after, inputs, dt, residuals
    )


@njit(cache=True, inline="always")
def noisy_dead_reckoning(
    odometry_parameters: Array,
    estimate: Array,
    delta_distance: float,
    delta_heading: float,
    normals: Array,
) -> None:
    """X(k+1) = f(X(k), U(k)) + v(k) (eq. 14) on one robot's estimate, in place.

    v(k) = sqrt(Q(k)) ``normals``, Q(k) of eq. 17 at the estimate's heading; the heading is
    wrapped to (-pi, pi].

    :param estimate: (3,) the estimated (x, y, heading), updated in place
    :param normals: (3,) standard normal draws for the noise of x, y and heading
    """
    q11, q22, q33 = odometry_variances(
        delta_distance,
        delta_heading,
        estimate[2],
        odometry_parameters[_K_DISTANCE],
        odometry_parameters[_K_DISTANCE_HEADING],
        odometry_parameters[_K_HEADING],
    )
    x, y, heading = dead_reckoning_step(
        estimate[0],
        estimate[1],
        estimate[2],
        delta_distance,
        delta_heading,
        int(odometry_parameters[_METHOD]),
    )
    estimate[0] = x + math.sqrt(q11) * normals[0]
    estimate[1] = y + math.sqrt(q22) * normals[1]
    estimate[2] = wrap_scalar_angle(heading + math.sqrt(q33) * normals[2])


@njit(cache=True)
def odometry_motion(
    odometry_parameters: Array, delta_distance: float, delta_heading: float
) -> tuple[float, float, float]:
    """The motion the odometry reads from U(k) = (dD, dtheta) without its noise: f's step
    (eq. 20, 26 or 25, by the settings' method) from the origin, in the frame of the pose at
    the step's start."""
    return dead_reckoning_step(
        0.0, 0.0, 0.0, delta_distance, delta_heading, int(odometry_parameters[_METHOD])
    )


@per_model(inline="always")
def advance_odometry(
    model_parameters: Array,
    encoder_settings: Array,
    odometry_parameters: Array,
    state_before: Array,
    state_after: Array,
    inputs: Array,
    dt: float,
    residuals: Array,
    normals: Array,
    estimate: Array,
) -> None:
    """One robot's odometry over one step: :func:`measure_increments`, then
    :func:`noisy_dead_reckoning` on ``estimate`` (both in place, as they document). A
    template compiled per model, as :func:`measure_increments`."""
    delta_distance, delta_heading = measure_increments(
        model_parameters, encoder_settings, state_before, state_after, inputs, dt, residuals
    )
    noisy_dead_reckoning(odometry_parameters, estimate, delta_distance, delta_heading, normals)


@njit(cache=True)
def _dead_reckoning_rows(starts, delta_distance, delta_heading, method):
    robots, steps = delta_distance.shape
    poses = np.empty((robots, steps + 1, 3))
    for robot in range(robots):
        x, y, heading = starts[robot, 0], starts[robot, 1], starts[robot, 2]
        poses[robot, 0, 0], poses[robot, 0, 1], poses[robot, 0, 2] = x, y, heading
        for k in range(steps):
            x, y, heading = dead_reckoning_step(
                x, y, heading, delta_distance[robot, k], delta_heading[robot, k], method
            )
            poses[robot, k + 1, 0], poses[robot, k + 1, 1] = x, y
            poses[robot, k + 1, 2] = heading
    return poses


@per_model()
def _advance_odometry_rows(
    model_parameters,
    encoder_settings,
    odometry_parameters,
    states_before,
    states_after,
    inputs,
    dt,
    residuals,
    normals,
    estimates,
):
    for robot in range(estimates.shape[0]):
        advance_odometry(
            model_parameters,
            encoder_settings,
            odometry_parameters,
            states_before[robot],
            states_after[robot],
            inputs[robot],
            dt,
            residuals[robot],
            normals[robot],
            estimates[robot],
        )


@per_model()
def _increments_rows(
    model_parameters, encoder_settings, states_before, states_after, inputs, dt, residuals
):
    increments = np.empty((states_before.shape[0], 2))
    for robot in range(states_before.shape[0]):
        increments[robot, 0], increments[robot, 1] = measure_increments(
            model_parameters,
            encoder_settings,
            states_before[robot],
            states_after[robot],
            inputs[robot],
            dt,
            residuals[robot],
        )
    return increments


# ---------------------------------------------------------------- validation


def _as_fraction(name: str, value: object) -> float:
    """A relative error: a float in (-1, 1)."""
    return as_in_open_interval(name, value, -1.0, 1.0, "(-1, 1), a fraction")


def _method_code(method: str) -> int:
    return DEAD_RECKONING_METHODS.index(as_choice("method", method, DEAD_RECKONING_METHODS))


# ---------------------------------------------------------------- public numpy functions


def odometry_covariance(
    delta_distance: ArrayLike,
    delta_heading: ArrayLike,
    heading: ArrayLike,
    k_distance: float = DEFAULT_K_DISTANCE,
    k_distance_heading: float = DEFAULT_K_DISTANCE_HEADING,
    k_heading: float = DEFAULT_K_HEADING,
) -> Array:
    """Q(k) of seed 000 eq. 17, the covariance of one odometry step's noise v(k).

    Q = diag(K_D |dD cos theta|, K_D |dD sin theta|, K_Dtheta |dD| + K_theta |dtheta|).
    The three arrays broadcast against each other.

    :param delta_distance: dD(k), the distance travelled in the step (m)
    :param delta_heading: dtheta(k), the heading change in the step (rad)
    :param heading: theta(k), the heading at the step's start (rad)
    :param k_distance: K_D (m^2/m), >= 0
    :param k_distance_heading: K_Dtheta (rad^2/m), >= 0
    :param k_heading: K_theta (rad^2/rad), >= 0
    :return: shape (..., 3, 3), the broadcast shape of the three inputs then (3, 3)
    """
    k_d = as_non_negative("k_distance", k_distance)
    k_dth = as_non_negative("k_distance_heading", k_distance_heading)
    k_th = as_non_negative("k_heading", k_heading)
    distance = as_finite_array("delta_distance", delta_distance)
    turn = as_finite_array("delta_heading", delta_heading)
    theta = as_finite_array("heading", heading)
    try:
        distance, turn, theta = np.broadcast_arrays(distance, turn, theta)
    except ValueError:
        raise ValueError(
            "delta_distance, delta_heading and heading must broadcast together, got shapes "
            f"{np.shape(delta_distance)}, {np.shape(delta_heading)} and {np.shape(heading)}"
        ) from None
    covariance = np.zeros((*distance.shape, 3, 3))
    covariance[..., 0, 0] = k_d * np.abs(distance * exact_math.cos(theta))
    covariance[..., 1, 1] = k_d * np.abs(distance * exact_math.sin(theta))
    covariance[..., 2, 2] = k_dth * np.abs(distance) + k_th * np.abs(turn)
    return covariance


def differential_increments(
    delta_right: ArrayLike, delta_left: ArrayLike, track_width: float
) -> tuple[Array, Array]:
    """Seed 000 eq. 16: dD = (dD_R + dD_L) / 2, dtheta = (dD_R - dD_L) / L.

    :param delta_right: distance rolled by the right wheel (m), any shape
    :param delta_left: distance rolled by the left wheel (m), broadcasting with it
    :param track_width: L, the distance between the wheels (m), positive
    :return: (dD, dtheta), arrays of the broadcast shape
    """
    track_width = as_positive("track_width", track_width)
    right = as_finite_array("delta_right", delta_right)
    left = as_finite_array("delta_left", delta_left)
    return 0.5 * (right + left), (right - left) / track_width


def dead_reckoning(
    start_pose: ArrayLike,
    delta_distance: ArrayLike,
    delta_heading: ArrayLike,
    method: str = "exact",
) -> Array:
    """The poses that odometry without noise reaches from ``start_pose`` (eq. 20, 25 or 26).

    :param start_pose: (x, y, heading), shape (3,) or (N, 3)
    :param delta_distance: dD(k) per step (m), shape (K,) or (N, K)
    :param delta_heading: dtheta(k) per step (rad), the same shape
    :param method: ``"euler"`` (eq. 20), ``"midpoint"`` (eq. 26) or ``"exact"`` (eq. 25)
    :return: the K + 1 poses, start included, shape (K + 1, 3) or (N, K + 1, 3); headings
        are accumulated, not wrapped
    """
    code = _method_code(method)
    starts, starts_batched = as_rows("start_pose", start_pose, 3)
    distance = as_finite_array("delta_distance", delta_distance)
    turn = as_finite_array("delta_heading", delta_heading)
    if distance.shape != turn.shape or distance.ndim not in (1, 2):
        raise ValueError(
            "delta_distance and delta_heading must have one shape, (K,) or (N, K), got "
            f"{distance.shape} and {turn.shape}"
        )
    steps_batched = distance.ndim == 2
    distance, turn = np.atleast_2d(distance), np.atleast_2d(turn)
    count = max(len(starts), len(distance))
    if starts_batched and steps_batched and len(starts) != len(distance):
        raise ValueError(
            f"start_pose and the increments hold different numbers of robots: "
            f"{len(starts)} and {len(distance)}"
        )
    starts = np.broadcast_to(starts, (count, 3)).copy()
    distance = np.broadcast_to(distance, (count, distance.shape[1])).copy()
    turn = np.broadcast_to(turn, (count, turn.shape[1])).copy()
    poses = _dead_reckoning_rows(starts, distance, turn, code)
    return poses if starts_batched or steps_batched else poses[0]


@dataclass(frozen=True)
class OdometrySettings:
    """Wheel odometry's settings, validated when made: the dead-reckoning step, eq. 17's
    coefficients, the encoders, and what the odometry assumes of the robot.

    Whatever needs the model (the constant-velocity model has no wheels; a car-like robot's
    quantized traction encoder needs ``traction_wheel_radius``) is checked by
    :class:`WheelOdometry`.

    :param method: dead-reckoning step, ``"euler"`` (eq. 20), ``"midpoint"`` (eq. 26) or
        ``"exact"`` (eq. 25)
    :param k_distance: K_D of eq. 17 (m^2/m), >= 0
    :param k_distance_heading: K_Dtheta (rad^2/m), >= 0
    :param k_heading: K_theta (rad^2/rad), >= 0
    :param wheel_radius_error: relative error e of the wheel radii the odometry assumes, in
        (-1, 1): the differential drive's right wheel is taken as r (1 + e/2) and its left as
        r (1 - e/2), a mismatch (Borenstein's E_d = (2 + e) / (2 - e)); the car-like robots'
        traction wheel as r (1 + e), a scale error
    :param wheelbase_error: relative error of the track width (differential drive,
        Borenstein's E_b = 1 + e) or wheelbase L (bicycle, tricycle) it assumes, in (-1, 1)
    :param encoder_counts: counts per revolution of the traction encoders; None for ideal ones
    :param steering_counts: counts per revolution of the steering encoder (bicycle,
        tricycle); None for an ideal one
    :param traction_wheel_radius: the bicycle's or tricycle's traction wheel radius (m),
        needed (only) to count its turns when ``encoder_counts`` is set; the differential
        drive's comes from the model
    :raises ValueError: naming the first bad setting
    """

    method: str = "exact"
    k_distance: float = DEFAULT_K_DISTANCE
    k_distance_heading: float = DEFAULT_K_DISTANCE_HEADING
    k_heading: float = DEFAULT_K_HEADING
    wheel_radius_error: float = 0.0
    wheelbase_error: float = 0.0
    encoder_counts: int | None = None
    steering_counts: int | None = None
    traction_wheel_radius: float | None = None

    def __post_init__(self) -> None:
        _method_code(self.method)
        checked = {
            "k_distance": as_non_negative("k_distance", self.k_distance),
            "k_distance_heading": as_non_negative("k_distance_heading", self.k_distance_heading),
            "k_heading": as_non_negative("k_heading", self.k_heading),
            "wheel_radius_error": _as_fraction("wheel_radius_error", self.wheel_radius_error),
            "wheelbase_error": _as_fraction("wheelbase_error", self.wheelbase_error),
            "encoder_counts": as_optional_count("encoder_counts", self.encoder_counts),
            "steering_counts": as_optional_count("steering_counts", self.steering_counts),
            "traction_wheel_radius": None
            if self.traction_wheel_radius is None
            else as_positive("traction_wheel_radius", self.traction_wheel_radius),
        }
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    @property
    def kernel_parameters(self) -> Array:
        """The dead reckoning's settings as the kernels read them (:func:`noisy_dead_reckoning`)."""
        parameters = np.zeros(_PARAMETER_COUNT)
        parameters[_K_DISTANCE] = self.k_distance
        parameters[_K_DISTANCE_HEADING] = self.k_distance_heading
        parameters[_K_HEADING] = self.k_heading
        parameters[_METHOD] = _method_code(self.method)
        return parameters

    @property
    def encoder_settings(self) -> Array:
        """The encoders' settings as a model's ``encoder_increments`` reads them
        (:class:`~mobile_envs.robots.encoders.EncoderSetting`)."""
        settings = np.zeros(len(EncoderSetting))
        settings[EncoderSetting.RADIUS_ERROR] = self.wheel_radius_error
        settings[EncoderSetting.WHEELBASE_ERROR] = self.wheelbase_error
        settings[EncoderSetting.COUNTS] = self.encoder_counts or 0
        settings[EncoderSetting.STEERING_COUNTS] = self.steering_counts or 0
        settings[EncoderSetting.TRACTION_RADIUS] = self.traction_wheel_radius or 0.0
        return settings


class WheelOdometry:
    """Wheel odometry of one kinematic model: settings, error model and batched runs.

    :param model: the robot's :class:`~mobile_envs.robots.model.KinematicModel`, one with
        encoders (:attr:`~mobile_envs.robots.model.KinematicModel.has_encoders`: not the
        constant-velocity model)
    :param settings: the :class:`OdometrySettings`; or give its fields as keywords
    """

    def __init__(
        self, model: KinematicModel, settings: OdometrySettings | None = None, **fields: Any
    ):
        if not model.has_encoders:
            raise ValueError(
                f"model must be a robot with wheel encoders, got {model!r}: "
                "the constant-velocity model has no wheels to count"
            )
        if settings is None:
            settings = OdometrySettings(**fields)
        elif fields:
            raise ValueError(f"give the settings or their fields, not both; got {sorted(fields)}")
        self.model = model
        self.settings = settings
        #: The dead reckoning's settings for the kernels (:func:`advance_odometry`).
        self.kernel_parameters = settings.kernel_parameters
        #: The encoders' settings for the model's ``encoder_increments``.
        self.encoder_settings = settings.encoder_settings
        needs_radius = model.traction_radius_unknown and settings.encoder_counts is not None
        if needs_radius and settings.traction_wheel_radius is None:
            raise ValueError(
                "traction_wheel_radius is needed to count the traction wheel's turns when "
                f"encoder_counts is set, got {settings.traction_wheel_radius!r}"
            )

    def read_steering(self, gamma: ArrayLike) -> Array:
        """What the steering encoder reads of wheel angles ``gamma`` (rad): the nearest count
        with ``steering_counts``, gamma itself with an ideal encoder."""
        angles = as_finite_array("gamma", gamma)
        counts = self.encoder_settings[EncoderSetting.STEERING_COUNTS]
        if not counts:
            return angles.copy()
        count = 2.0 * math.pi / counts
        return np.round(angles / count) * count

    def _check_step(
        self, states_before: ArrayLike, states_after: ArrayLike, inputs: ArrayLike, dt: float
    ) -> tuple[Array, Array, Array, float, bool]:
        model = self.model
        before, batched = as_rows("states_before", states_before, model.state_dim)
        after, _ = as_rows("states_after", states_after, model.state_dim)
        commands, _ = as_rows("inputs", inputs, model.input_dim)
        if not len(before) == len(after) == len(commands):
            raise ValueError(
                "states_before, states_after and inputs must hold one row per robot, got "
                f"{len(before)}, {len(after)} and {len(commands)}"
            )
        dt = as_positive("dt", dt)
        return before, after, np.ascontiguousarray(model.saturate(commands)), dt, batched

    def _check_residuals(self, residuals: ArrayLike | None, count: int) -> Array:
        if residuals is None:
            return np.zeros((count, 2))
        array = as_finite_array("residuals", residuals)
        if array.shape != (count, 2):
            raise ValueError(f"residuals must have shape ({count}, 2), got {array.shape}")
        return array.copy()

    def increments(
        self,
        states_before: ArrayLike,
        states_after: ArrayLike,
        inputs: ArrayLike,
        dt: float,
        residuals: ArrayLike | None = None,
    ) -> tuple[Array, Array, Array]:
        """U(k) = (dD, dtheta) the encoders measure over one step (see
        :func:`measure_increments`).

        :param states_before: true states at the step's start, (k,) or (N, k)
        :param states_after: true states at its end, the same shape
        :param inputs: the native inputs held over the step, (m,) or (N, m); saturated here
        :param dt: the step (s), positive
        :param residuals: (N, 2) the encoders' carried fractions of a count; None for zeros
        :return: (dD, dtheta, residuals after the step): scalars (0-d) for one robot, (N,)
            and (N, 2) for a batch
        """
        before, after, commands, dt, batched = self._check_step(
            states_before, states_after, inputs, dt
        )
        carried = self._check_residuals(residuals, len(before))
        increments = for_model(_increments_rows, self.model.compiled)(
            self.model.kernel_parameters,
            self.encoder_settings,
            before,
            after,
            commands,
            dt,
            carried,
        )
        if batched:
            return increments[:, 0], increments[:, 1], carried
        return increments[0, 0], increments[0, 1], carried

    def step(
        self,
        estimates: ArrayLike,
        states_before: ArrayLike,
        states_after: ArrayLike,
        inputs: ArrayLike,
        dt: float,
        residuals: ArrayLike | None = None,
        rng: np.random.Generator | None = None,
    ) -> tuple[Array, Array]:
        """Advance the estimated poses over one step of the robots (eq. 14).

        :param estimates: estimated (x, y, heading), (3,) or (N, 3)
        :param states_before: true states at the step's start, (k,) or (N, k)
        :param states_after: true states at its end
        :param inputs: the native inputs held over the step; saturated here
        :param dt: the step (s), positive
        :param residuals: (N, 2) the encoders' carried fractions of a count; None for zeros
        :param rng: draws v(k) (three standard normals a robot, in robot order); None for
            odometry without noise (the systematic errors and quantization still apply)
        :return: (new estimates, shaped as ``estimates``; residuals after the step, (N, 2))
        """
        before, after, commands, dt, batched = self._check_step(
            states_before, states_after, inputs, dt
        )
        poses, poses_batched = as_rows("estimates", estimates, 3)
        if len(poses) != len(before):
            raise ValueError(f"estimates hold {len(poses)} robots and states_before {len(before)}")
        carried = self._check_residuals(residuals, len(before))
        normals = np.zeros((len(poses), 3)) if rng is None else rng.standard_normal((len(poses), 3))
        for_model(_advance_odometry_rows, self.model.compiled)(
            self.model.kernel_parameters,
            self.encoder_settings,
            self.kernel_parameters,
            before,
            after,
            commands,
            dt,
            carried,
            normals,
            poses,
        )
        return (poses if poses_batched or batched else poses[0]), carried

    def __repr__(self) -> str:
        return f"WheelOdometry({self.model!r}, {self.settings!r})"

"""``mobile_envs.odometry``, kept for the code and documents that import it.

Wheel odometry; it lives in :mod:`mobile_envs.sensing.odometry`.
"""

from mobile_envs.sensing.odometry import (
    DEAD_RECKONING_METHODS,
    DEFAULT_K_DISTANCE,
    DEFAULT_K_DISTANCE_HEADING,
    DEFAULT_K_HEADING,
    OdometrySettings,
    WheelOdometry,
    advance_odometry,
    count_encoder,
    dead_reckoning,
    dead_reckoning_step,
    differential_increments,
    measure_increments,
    noisy_dead_reckoning,
    odometry_covariance,
    odometry_motion,
    odometry_variances,
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

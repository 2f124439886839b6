"""The tricycle guidance law of seed 003 (Font & Batlle 2006), eq. 20, for v > 0.

The tricycle (:class:`~mobile_envs.kinematics.Tricycle`) steers and drives with one wheel C,
a distance L ahead of O, the midpoint of the rear wheels. The law steers C onto the path:

    gamma' = -a e_c - b xi_r - (v / L) gamma            (seed 003 eq. 20)

- ``e_c``: signed lateral error of C, C = O + L (cos psi, sin psi), positive left of the path;
- ``xi_r = xi + gamma``: the orientation error of the wheel, psi + gamma minus the path
  heading at C's projection, wrapped to (-pi, pi];
- ``v``: the drive wheel's speed, held constant; ``a, b > 0``.

With e_c' = v xi_r (eq. 14) and psi' = (v / L) sin gamma ~ (v / L) gamma (eq. 16), the errors
obey ``e_c'' + b e_c' + a v e_c = 0`` (eq. 23) on a straight path: the gains place the roots
of ``s^2 + b s + a v`` (:meth:`TricycleGuidance.from_poles`). The wheel angle gamma itself
settles more slowly, at the rate v / L (eq. 24), while C already tracks the path.

On a circular arc of curvature kappa the law balances at e_c = -(v / (a L)) gamma_ss with
sin(gamma_ss) = L kappa, a steady lateral error of v^2 gamma_ss / (omega_n^2 L) that the gains
keep small: seed 003 refers circular paths to a separate law [13], but on its own run (a
1.24 m arc at 0.2 m/s) omega_n = 3 rad/s leaves about 4 mm, well inside the 16.5 mm it
measured, so this module keeps the pure eq. 20.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agents.base import ClassicalAgent
from mobile_envs.kinematics import KinematicModel, Tricycle
from mobile_envs.paths import Path


class TricycleGuidance(ClassicalAgent):
    """Seed 003's simple guidance law (eq. 20) for the tricycle, drive wheel leading (v > 0).

    It puts the drive wheel C on the path, as seed 003 does; the envs measure the
    cross-track error of O, which trails C by L and runs inside curves (on an arc of radius
    R, by R - sqrt(R^2 - L^2)) and cuts corners.

    :param a: gain on the lateral error of C (1/(m s)), positive
    :param b: gain on the wheel orientation error (1/s), positive
    :param speed: drive wheel speed v (m/s), positive; seed 003 ran at 0.2 m/s
    """

    def __init__(self, a: float, b: float, speed: float = 0.2):
        if not (a > 0.0 and b > 0.0 and speed > 0.0):
            raise ValueError(f"a, b and speed must be positive, got {a}, {b} and {speed}")
        self.a = float(a)
        self.b = float(b)
        self.speed = float(speed)
        self.path: Path | None = None
        self.segment: int | None = None

    @classmethod
    def from_poles(
        cls, natural_frequency: float, damping: float, speed: float = 0.2
    ) -> TricycleGuidance:
        """Gains that give eq. 23, s^2 + b s + a v, the roots of s^2 + 2 zeta omega_n s +
        omega_n^2: ``b = 2 zeta omega_n``, ``a = omega_n^2 / v``.

        :param natural_frequency: omega_n (rad/s)
        :param damping: zeta (1 is critical damping)
        :param speed: v (m/s); the gain a holds the roots only at this speed
        """
        return cls(natural_frequency**2 / speed, 2.0 * damping * natural_frequency, speed)

    @classmethod
    def for_comparison(cls) -> TricycleGuidance:
        """The settings :mod:`agents.compare` uses: omega_n = 2 rad/s, zeta = 0.9 at 0.5 m/s,
        fast enough to reach the goal within the envs' time limits."""
        return cls.from_poles(natural_frequency=2.0, damping=0.9, speed=0.5)

    def supports(self, model: KinematicModel) -> bool:
        return isinstance(model, Tricycle)

    def reset(self, path: Path) -> None:
        self.path = path
        self.segment = None

    def errors(self, state: ArrayLike, wheelbase: float) -> tuple[float, float, int]:
        """The lateral error e_c (m) of C, the wheel's orientation error xi_r (rad), and the
        path segment C projects onto.

        e_c is measured to the line of that segment, so it stays a lateral error when C runs
        past the path's end.

        :param state: (x, y, psi, gamma) of the tricycle
        :param wheelbase: L (m)
        """
        if self.path is None:
            raise RuntimeError("call reset(path) before asking for a command")
        x, y, psi, gamma = (float(value) for value in np.asarray(state)[:4])
        wheel = (x + wheelbase * math.cos(psi), y + wheelbase * math.sin(psi))
        _, _, self.segment = self.path.project(wheel, hint=self.segment)
        start = self.path.points[self.segment]
        heading = float(self.path.segment_headings[self.segment])
        offset_x, offset_y = wheel[0] - start[0], wheel[1] - start[1]
        lateral_error = math.cos(heading) * offset_y - math.sin(heading) * offset_x
        orientation_error = math.remainder(psi + gamma - heading, 2.0 * math.pi)
        return lateral_error, orientation_error, self.segment

    def steering_rate(self, state: ArrayLike, wheelbase: float) -> float:
        """gamma' of eq. 20 for the tricycle in ``state`` (x, y, psi, gamma)."""
        lateral_error, orientation_error, _ = self.errors(state, wheelbase)
        gamma = float(np.asarray(state)[3])
        return -self.a * lateral_error - self.b * orientation_error - self.speed / wheelbase * gamma

    def inputs(self, state: NDArray[np.float64], model: KinematicModel, dt: float) -> ArrayLike:
        return np.array([self.speed, self.steering_rate(state, model.wheelbase)])

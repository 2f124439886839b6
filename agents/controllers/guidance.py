"""The tricycle guidance laws of seed 003 (Font & Batlle 2006): the general three-parameter law
(eqs. 11-19) and the simple law for v > 0 (eq. 20).

The tricycle (:class:`~mobile_envs.robots.model.Tricycle`) steers and drives with one wheel C,
a distance L ahead of O, the midpoint of the rear wheels, and is guided by its steering rate.
The errors, measured against the path's tangent at the guided point's projection:

- ``e_o``, ``e_c``: the signed lateral errors of O and of C, C = O + L (cos psi, sin psi),
  positive to the left of the direction of travel;
- ``xi``: the vehicle's orientation error, psi minus the heading it should have;
  ``xi_r = xi + gamma`` (eq. 9) that of the drive wheel;
- ``v``: the drive wheel's speed, held constant, negative when reversing.

**The general law** (``c`` given) steers

    gamma' = -a e_o - b xi - c gamma                       (eq. 11, point O: manoeuvres)
    gamma' = -a e_c - (b - a L) xi_r - (c - b + a L) gamma  (eq. 13, point C: cruise)

(eq. 12 is eq. 13 written with xi; the three are one law, as e_c ~ e_o + L xi). With
e_o' ~ v xi, e_c' ~ v xi_r and xi' ~ (v / L) gamma (eqs. 14-16), every error q of a straight
path obeys

    q''' + c q'' + (v / L) b q' + (v^2 / L) a q = 0          (eq. 17)

whose roots Routh-Hurwitz keeps in the left half-plane iff a > 0, c > 0, v b > 0 and
c (v b) > v^2 a: for v > 0, b > 0 and b c > v a (eq. 18); for v < 0, b < 0 and
b c < v a, i.e. |b| c > |v| a. (Seed 003's eq. 19, as our copy of the text renders it, reads
"b c > v a" for v < 0 too; with b < 0 and v < 0 that is the unstable side, so this module
checks the condition Routh-Hurwitz gives.) :meth:`TricycleGuidance.from_roots` places one
real root and a complex-conjugate pair, as seed 003 does. Reversing is manoeuvring: a path
followed with v < 0 is driven O first, the vehicle pointing against the direction of travel.

**The simple law** (``c`` None), for the drive wheel leading (v > 0):

    gamma' = -a e_c - b xi_r - (v / L) gamma               (eq. 20)

the general law with b -> b + a L and c = b + v / L: eq. 17 factors into
(s + v / L)(s^2 + b s + a v), so ``e_c'' + b e_c' + a v e_c = 0`` (eq. 23): the gains place
the roots of ``s^2 + b s + a v`` (:meth:`TricycleGuidance.from_poles`). The wheel angle gamma
itself settles more slowly, at the rate v / L (eq. 24), while C already tracks the path. For
v < 0 it would leave e_o, xi and gamma unstable (seed 003 section 3.3), so it refuses v <= 0.

On a circular arc of curvature kappa the simple law balances at e_c = -(v / (a L)) gamma_ss
with sin(gamma_ss) = L kappa, a steady lateral error of v^2 gamma_ss / (omega_n^2 L) that the
gains keep small: seed 003 refers circular paths to a separate law [13], but on its own run (a
1.24 m arc at 0.2 m/s) omega_n = 3 rad/s leaves about 4 mm, well inside the 16.5 mm it
measured, so this module keeps the pure eq. 20. The general law, too, is seed 003's law for
straight paths.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from agents.controllers.base import ClassicalAgent
from agents.controllers.batch import ONE_ROBOT, Indices, LawBatch, PathArrays
from agents.controllers.cpython_math import ieee_remainder
from mobile_envs.robots import KinematicModel, Tricycle

#: The points the general law can guide: O (manoeuvres, eq. 11) and C (cruise, eq. 13).
GUIDED_POINTS = ("O", "C")


def _finite(name: str, value: float) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return number


def _positive(name: str, value: float) -> float:
    number = _finite(name, value)
    if number <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return number


def _check_routh_hurwitz(a: float, b: float, c: float, speed: float) -> None:
    """Raise ValueError unless eq. 17's roots all lie in the left half-plane (eqs. 18, 19)."""
    case = "v > 0, eq. 18" if speed > 0.0 else "v < 0, eq. 19"
    if a <= 0.0:
        raise ValueError(f"a must be positive for a stable law ({case}), got {a}")
    if c <= 0.0:
        raise ValueError(f"c must be positive for a stable law ({case}), got {c}")
    if speed * b <= 0.0:
        sign = "positive" if speed > 0.0 else "negative"
        raise ValueError(f"b must be {sign} for a stable law ({case}), got {b}")
    if c * speed * b <= speed * speed * a:
        relation = "b c > v a" if speed > 0.0 else "b c < v a (|b| c > |v| a)"
        raise ValueError(
            f"a, b, c and speed must satisfy {relation} for a stable law ({case}), got "
            f"b c = {b * c} and v a = {speed * a}"
        )


class TricycleGuidance(ClassicalAgent):
    """Seed 003's guidance law for the tricycle: the simple law (eq. 20, ``c=None``) or the
    general three-parameter law (eqs. 11-13, ``c`` given) on the point O or C.

    The simple law puts the drive wheel C on the path, as seed 003's run does; the envs
    measure the cross-track error of O, which trails C by L and runs inside curves (on an arc
    of radius R, by R - sqrt(R^2 - L^2)) and cuts corners.

    :param a: gain on the lateral error (1/(m s)), positive
    :param b: gain on the orientation error (1/s): for the simple law positive; for the
        general law of the sign of ``speed``, with b c > v a (v > 0) or |b| c > |v| a (v < 0)
    :param speed: drive wheel speed v (m/s); seed 003 ran at 0.2 m/s. The simple law needs
        v > 0; the general law takes either sign, v < 0 reversing along the path
    :param c: the general law's gain on the wheel angle gamma (1/s), positive; None for the
        simple law
    :param point: the point the general law puts on the path, ``"O"`` (eq. 11) or ``"C"``
        (eq. 13); the simple law always guides C
    :raises ValueError: naming the parameter, for non-finite gains or speed, or gains that
        break eq. 18 / 19 (the general law) or a, b, v > 0 (the simple law)
    """

    def __init__(
        self,
        a: float,
        b: float,
        speed: float = 0.2,
        c: float | None = None,
        point: str = "C",
    ):
        self.a = _finite("a", a)
        self.b = _finite("b", b)
        self.speed = _finite("speed", speed)
        if point not in GUIDED_POINTS:
            raise ValueError(f"point must be one of {GUIDED_POINTS}, got {point!r}")
        self.point = point
        if c is None:
            for name, value in (("a", self.a), ("b", self.b), ("speed", self.speed)):
                if value <= 0.0:
                    raise ValueError(
                        f"{name} must be positive for the simple law (eq. 20), got {value}; "
                        "reversing needs the general law (give c)"
                    )
            if point != "C":
                raise ValueError(f"point must be 'C' for the simple law (eq. 20), got {point!r}")
            self.c: float | None = None
        else:
            self.c = _finite("c", c)
            if self.speed == 0.0:
                raise ValueError("speed must be non-zero: the law steers a moving tricycle")
            _check_routh_hurwitz(self.a, self.b, self.c, self.speed)

    @classmethod
    def from_poles(
        cls, natural_frequency: float, damping: float, speed: float = 0.2
    ) -> TricycleGuidance:
        """The simple law with the roots of eq. 23, s^2 + b s + a v, at those of
        s^2 + 2 zeta omega_n s + omega_n^2: ``b = 2 zeta omega_n``, ``a = omega_n^2 / v``.

        :param natural_frequency: omega_n (rad/s), positive
        :param damping: zeta (1 is critical damping), positive
        :param speed: v (m/s), positive; the gain a holds the roots only at this speed
        """
        omega = _positive("natural_frequency", natural_frequency)
        zeta = _positive("damping", damping)
        v = _positive("speed", speed)
        return cls(omega**2 / v, 2.0 * zeta * omega, v)

    @classmethod
    def from_roots(
        cls,
        decay_rate: float,
        natural_frequency: float,
        damping: float,
        speed: float,
        wheelbase: float = 1.0,
        point: str = "O",
    ) -> TricycleGuidance:
        """The general law with eq. 17's roots at -p and -zeta omega_n +- i omega_n
        sqrt(1 - zeta^2), one real and two complex-conjugate roots as seed 003 places them.

        (s + p)(s^2 + 2 zeta omega_n s + omega_n^2) = s^3 + c s^2 + (v / L) b s + (v^2 / L) a
        gives c = p + 2 zeta omega_n, b = L (omega_n^2 + 2 zeta omega_n p) / v and
        a = L p omega_n^2 / v^2; b takes the sign of v, so the same roots serve reversing.

        :param decay_rate: p (1/s), the real root being -p; positive
        :param natural_frequency: omega_n of the complex pair (rad/s), positive
        :param damping: zeta of the complex pair, in (0, 1)
        :param speed: v (m/s), non-zero; negative to reverse along the path
        :param wheelbase: L (m) of the tricycle the roots are placed for, positive
        :param point: ``"O"`` (eq. 11) or ``"C"`` (eq. 13)
        """
        p = _positive("decay_rate", decay_rate)
        omega = _positive("natural_frequency", natural_frequency)
        zeta = _positive("damping", damping)
        if zeta >= 1.0:
            raise ValueError(
                f"damping must lie in (0, 1) for a complex-conjugate pair, got {damping!r}"
            )
        v = _finite("speed", speed)
        if v == 0.0:
            raise ValueError("speed must be non-zero: the gains scale with 1 / v")
        length = _positive("wheelbase", wheelbase)
        a = length * p * omega**2 / v**2
        b = length * (omega**2 + 2.0 * zeta * omega * p) / v
        return cls(a, b, v, c=p + 2.0 * zeta * omega, point=point)

    @classmethod
    def for_comparison(cls) -> TricycleGuidance:
        """The settings :mod:`agents.harness.compare` uses: omega_n = 2 rad/s, zeta = 0.9 at 0.5
        m/s, fast enough to reach the goal within the envs' time limits."""
        return cls.from_poles(natural_frequency=2.0, damping=0.9, speed=0.5)

    def characteristic_roots(self, wheelbase: float) -> NDArray[np.complex128]:
        """The roots of the closed loop's error dynamics for a tricycle of this wheelbase:
        eq. 17's for the general law, eq. 23's and -v/L (eq. 24) for the simple one."""
        length = _positive("wheelbase", wheelbase)
        v = self.speed
        if self.c is None:
            b, c = self.b + self.a * length, self.b + v / length
        else:
            b, c = self.b, self.c
        return np.roots([1.0, c, v * b / length, v * v * self.a / length]).astype(np.complex128)

    def supports(self, model: KinematicModel) -> bool:
        return isinstance(model, Tricycle)

    def batch(self, num_robots: int) -> TricycleGuidanceBatch:
        return TricycleGuidanceBatch(self, num_robots)

    def errors(self, state: ArrayLike, wheelbase: float) -> tuple[float, float, int]:
        """The lateral error e_c (m) of C, the wheel's orientation error xi_r (rad), and the
        path segment C projects onto, for travel along the path (v > 0).

        e_c is measured to the line of that segment, so it stays a lateral error when C runs
        past the path's end.

        :param state: (x, y, psi, gamma) of the tricycle
        :param wheelbase: L (m)
        """
        return self._robot_batch().robot_errors(state, wheelbase, guided=False)

    def guided_errors(self, state: ArrayLike, wheelbase: float) -> tuple[float, float, int]:
        """The general law's errors: the lateral error (m) of the guided point (O or C), the
        vehicle's orientation error xi (rad) and the segment the point projects onto, both
        taken in the direction of travel (against the vehicle's heading when reversing).

        :param state: (x, y, psi, gamma) of the tricycle
        :param wheelbase: L (m)
        """
        return self._robot_batch().robot_errors(state, wheelbase, guided=True)

    def steering_rate(self, state: ArrayLike, wheelbase: float) -> float:
        """gamma' of eq. 20 (simple law) or eq. 11 / 13 (general law) for the tricycle in
        ``state`` (x, y, psi, gamma)."""
        states = np.asarray(state, dtype=np.float64).reshape(1, -1)
        return float(self._robot_batch().steering_rates(ONE_ROBOT, states, float(wheelbase))[0])

    def _robot_batch(self) -> TricycleGuidanceBatch:
        robot = self.robot()
        assert isinstance(robot, TricycleGuidanceBatch)
        return robot


@njit(cache=True)
def guided_points(robots, states, wheelbase, at_wheel, wheel_angle, points_out, angles_out):
    """The point each robot of ``robots`` puts on its path, C (``at_wheel``) or O, and the
    angle whose error the law weighs: the wheel's psi + gamma (``wheel_angle``) or psi."""
    for j in range(robots.shape[0]):
        x, y, psi, gamma = states[robots[j], 0], states[robots[j], 1], states[robots[j], 2], 0.0
        if wheel_angle:
            gamma = states[robots[j], 3]
        if at_wheel:
            x, y = x + wheelbase * math.cos(psi), y + wheelbase * math.sin(psi)
        points_out[j, 0], points_out[j, 1] = x, y
        angles_out[j] = psi + gamma if wheel_angle else psi


@njit(cache=True)
def path_errors(
    paths, robots, points, angles, segments, travel_sign, lateral_out, orientation_out
):  # fmt: skip
    """The lateral error of each robot's point (left of the direction of travel) and the
    orientation error of its angle, against the tangent of the segment the point projects
    onto (``segments``).

    Reversing (``travel_sign`` -1), the vehicle should point against the path: its nominal
    heading is the path's plus pi, and left is taken of that heading, so the errors obey
    eqs. 14-16 with v < 0.
    """
    for j in range(robots.shape[0]):
        column = paths.spans[robots[j], 0] + segments[j]
        heading = paths.segment_headings[column]
        if travel_sign < 0.0:
            heading += math.pi
        offset_x = points[j, 0] - paths.starts_x[column]
        offset_y = points[j, 1] - paths.starts_y[column]
        lateral_out[j] = math.cos(heading) * offset_y - math.sin(heading) * offset_x
        orientation_out[j] = ieee_remainder(angles[j] - heading, 2.0 * math.pi)


@njit(cache=True)
def steering_rates(
    robots, states, lateral_errors, orientation_errors, a, b, c, simple, point_c, speed,
    wheelbase, rates_out,
):  # fmt: skip
    """gamma' of eq. 20 (``simple``: the errors are e_c and xi_r) or of eq. 11 / 13 (on C
    when ``point_c``; the errors are the guided point's and xi) for ``robots``."""
    for j in range(robots.shape[0]):
        gamma = states[robots[j], 3]
        lateral_error, orientation_error = lateral_errors[j], orientation_errors[j]
        if simple:
            rates_out[j] = -a * lateral_error - b * orientation_error - speed / wheelbase * gamma
        elif not point_c:
            rates_out[j] = -a * lateral_error - b * orientation_error - c * gamma
        else:
            a_l = a * wheelbase
            rates_out[j] = (
                -a * lateral_error - (b - a_l) * (orientation_error + gamma) - (c - b + a_l) * gamma
            )


class TricycleGuidanceBatch(LawBatch):
    """:class:`TricycleGuidance` for N tricycles: the segment each one's guided point
    projects onto, steered for all of them at once.

    :param law: the gains
    :param num_robots: N
    """

    def __init__(self, law: TricycleGuidance, num_robots: int):
        super().__init__(num_robots)
        self.law = law
        #: (N,) the segment each guided point last projected onto; -1 before the first.
        self.segments = np.full(num_robots, -1, dtype=np.int64)

    def restart(self, robots: Indices) -> None:
        self.segments[robots] = -1

    def errors(
        self, robots: Indices, states: NDArray[np.float64], wheelbase: float, guided: bool
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
        """The errors of robots ``robots`` of (N, 4) ``states``: with ``guided`` those of the
        general law (:meth:`TricycleGuidance.guided_errors`), else e_c and xi_r
        (:meth:`TricycleGuidance.errors`); each projection follows the robot's progress.

        :return: (lateral errors, orientation errors, segments), each (len(robots),)
        """
        paths: PathArrays = self.paths.arrays(robots)
        law = self.law
        count = len(robots)
        points, angles = np.empty((count, 2)), np.empty(count)
        at_wheel = not guided or law.point == "C"
        guided_points(robots, states, float(wheelbase), at_wheel, not guided, points, angles)
        segments = self.paths.project(robots, points, self.segments[robots])
        self.segments[robots] = segments
        travel_sign = math.copysign(1.0, law.speed) if guided else 1.0
        lateral, orientation = np.empty(count), np.empty(count)
        path_errors(paths, robots, points, angles, segments, travel_sign, lateral, orientation)
        return lateral, orientation, segments

    def steering_rates(
        self, robots: Indices, states: NDArray[np.float64], wheelbase: float
    ) -> NDArray[np.float64]:
        """gamma' for robots ``robots`` of (N, 4) ``states`` on tricycles of wheelbase L."""
        law = self.law
        simple = law.c is None
        lateral, orientation, _ = self.errors(robots, states, wheelbase, guided=not simple)
        rates = np.empty(len(robots))
        steering_rates(
            robots, states, lateral, orientation, law.a, law.b, math.nan if simple else law.c,
            simple, law.point == "C", law.speed, float(wheelbase), rates,
        )  # fmt: skip
        return rates

    def robot_errors(
        self, state: ArrayLike, wheelbase: float, guided: bool
    ) -> tuple[float, float, int]:
        """Robot 0's errors (see :meth:`errors`)."""
        states = np.asarray(state, dtype=np.float64).reshape(1, -1)
        lateral, orientation, segments = self.errors(ONE_ROBOT, states, wheelbase, guided)
        return float(lateral[0]), float(orientation[0]), int(segments[0])

    def inputs(
        self, robots: Indices, states: NDArray[np.float64], model: KinematicModel, dt: float
    ) -> NDArray[np.float64]:
        if not isinstance(model, Tricycle):
            raise ValueError(f"TricycleGuidance drives a Tricycle, got {model!r}")
        inputs = np.empty((len(robots), 2))
        inputs[:, 0] = self.law.speed
        inputs[:, 1] = self.steering_rates(robots, states, model.wheelbase)
        return inputs

"""A satellite position fix (GNSS-like): a noisy absolute position at a set rate, held
between fixes."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from mobile_envs.sensing.sensors.sensor import Array, Generators, Indices, Sensor, SensorWorld
from mobile_envs.validation import as_positive, as_real

#: A fix instant this close to a step, in fix periods, counts as reached at that step: so
#: ``rate * dt`` products that float arithmetic leaves a hair short of an integer (10 steps
#: of 0.1 s at 1 Hz) still fix on the step they are meant to.
_INSTANT_TOLERANCE = 1e-9
#: Fixes whose errors a robot draws from its generator at once: a fix then costs no call to
#: the generator (a call per robot and fix made the sensor cost three times the step), and
#: the step is one compiled call.
ERROR_BLOCK = 64


class GnssSensor(Sensor):
    """A satellite position fix at a set rate: ``sensors=["gnss"]`` (or ``{"type": "gnss",
    "rate": 10.0, "noise": 0.02}``).

    Fixes come at ``rate`` Hz from each episode's start, at t = j / rate (j = 0, 1, ...), each
    taken at the first step that reaches its instant, so at most one a step (a rate above
    1 / dt fixes every step). A fix is the robot's true position plus an error of ``noise``
    metres standard deviation on each axis, held until the next. The errors are standard
    normals from the robot's own generator, drawn :data:`ERROR_BLOCK` fixes at a time
    (``standard_normal((ERROR_BLOCK, 2))``: x then y of each fix) at every reset and when a
    block is used up; none when ``noise`` is 0.

    It reads, every step, the last fix as seen from the pose the robot believes it has (its
    localization's estimate; its true pose with ``localization="exact"``), in that pose's
    frame, and the fix's age:

    | element        | reading                                        | observation      |
    |----------------|------------------------------------------------|------------------|
    | ``gnss_forward`` | the fix ahead of the believed pose (m)       | / ``max_offset`` |
    | ``gnss_left``    | the fix to the left of it (m)                | / ``max_offset`` |
    | ``gnss_age``     | time since the fix (s)                       | x ``rate``       |

    With exact localization a fresh fix reads its error, turned into the robot's frame; as the
    robot moves on the held fix falls behind it. With odometry a fresh fix reads the drift of
    the estimate plus the error: what a policy needs to correct its belief. The age observes
    in [0, 1) (fixes are never more than a period apart); offsets beyond ``max_offset`` clip.

    :param rate: fixes per second (Hz)
    :param noise: standard deviation of each axis of a fix's error (m), >= 0
    :param max_offset: the offset (m) that observes as 1
    :raises ValueError: naming a setting that is not a positive (``noise``: non-negative)
        finite number
    """

    name = "gnss"

    def __init__(self, rate: float = 5.0, noise: float = 0.05, max_offset: float = 1.0):
        self.rate = as_positive("rate", rate)
        self.noise = as_real("noise", noise)
        if self.noise < 0.0:
            raise ValueError(f"noise must be a non-negative number (m), got {noise!r}")
        self.max_offset = as_positive("max_offset", max_offset)
        self.names = ("gnss_forward", "gnss_left", "gnss_age")
        self.scales = np.array([1.0 / self.max_offset, 1.0 / self.max_offset, self.rate])
        self.allocate(0)

    def allocate(self, num_robots: int) -> None:
        #: (N, 2) each robot's last fix (m).
        self.fixes = np.zeros((num_robots, 2))
        #: Steps since each robot's reset, and the step of its last fix.
        self.steps = np.zeros(num_robots, dtype=np.int64)
        self.fix_steps = np.zeros(num_robots, dtype=np.int64)
        #: Each robot's drawn errors, and how many of them it has used.
        self.errors = np.zeros((num_robots, ERROR_BLOCK, 2))
        self.used = np.full(num_robots, ERROR_BLOCK, dtype=np.int64)

    def reset(self, world: SensorWorld, indices: Indices, rngs: Generators, out: Array) -> None:
        self._draw_errors(indices, rngs)  # a new episode draws its own errors
        self._fix_and_read(world, indices, rngs, out, True)

    def measure(self, world: SensorWorld, indices: Indices, rngs: Generators, out: Array) -> None:
        self._fix_and_read(world, indices, rngs, out, False)

    def _fix_and_read(
        self,
        world: SensorWorld,
        indices: Indices,
        rngs: Generators,
        out: Array,
        restart: bool,
    ) -> None:
        """Fix robots ``indices`` that are due (all of them at a restart), read them all, and
        draw new errors for those that used their last."""
        used_up = _fix_and_read_robots(
            indices, restart, world.dt * self.rate, self.noise, world.state, world.estimate,
            world.dt, self.steps, self.fix_steps, self.fixes, self.errors, self.used, out,
        )  # fmt: skip
        if used_up:
            self._draw_errors(indices[self.used[indices] == ERROR_BLOCK], rngs)

    def _draw_errors(self, indices: Indices, rngs: Generators) -> None:
        """A new block of errors for each robot of ``indices``, from its own generator."""
        if self.noise > 0.0:
            for index in indices.tolist():
                self.errors[index] = rngs[index].standard_normal((ERROR_BLOCK, 2))
        self.used[indices] = 0

    def __repr__(self) -> str:
        return f"GnssSensor(rate={self.rate}, noise={self.noise}, max_offset={self.max_offset})"


@njit(cache=True)
def _fix_and_read_robots(
    indices: NDArray[np.int64],
    restart: bool,
    fixes_per_step: float,
    noise: float,
    state: NDArray[np.float64],
    estimate: NDArray[np.float64],
    dt: float,
    steps: NDArray[np.int64],
    fix_steps: NDArray[np.int64],
    fixes: NDArray[np.float64],
    errors: NDArray[np.float64],
    used: NDArray[np.int64],
    out: NDArray[np.float64],
) -> bool:
    """Robot by robot (the same bits for a robot whatever the others): count the step (from
    0 at a restart), fix the robot if the step reaches a fix instant (always at a restart):
    its true position plus ``noise`` times its next error; then read the last fix in the
    frame of its believed pose, and the fix's age.

    :return: whether a robot used its last error
    """
    used_up = False
    for index in indices:
        if restart:
            steps[index] = 0
            due = True
        else:
            steps[index] += 1
            fixes_by_now = math.floor(steps[index] * fixes_per_step + _INSTANT_TOLERANCE)
            fixes_before = math.floor((steps[index] - 1) * fixes_per_step + _INSTANT_TOLERANCE)
            due = fixes_by_now > fixes_before
        if due:
            error = used[index]
            fixes[index, 0] = state[index, 0] + noise * errors[index, error, 0]
            fixes[index, 1] = state[index, 1] + noise * errors[index, error, 1]
            fix_steps[index] = steps[index]
            used[index] = error + 1
            used_up |= error + 1 == ERROR_BLOCK
        heading = estimate[index, 2]
        cos_heading, sin_heading = math.cos(heading), math.sin(heading)
        dx = fixes[index, 0] - estimate[index, 0]
        dy = fixes[index, 1] - estimate[index, 1]
        out[index, 0] = cos_heading * dx + sin_heading * dy
        out[index, 1] = -sin_heading * dx + cos_heading * dy
        out[index, 2] = (steps[index] - fix_steps[index]) * dt
    return used_up

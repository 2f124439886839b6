"""Sensors: per-robot measurements that the environment's observation carries.

A :class:`Sensor` owns everything about one measurement: the names of its observation
elements and the factors that scale them to [-1, 1], its per-robot buffers, how it reads a
freshly reset robot and how it measures every robot after a move. The core
(:class:`mobile_envs.sim.core.PathFollowingCore`) composes its sensors without knowing which
they are: each gets its own columns of the core's ``readings`` array (in raw units, metres
for ranges) and the observation holds ``clip(readings * scales, -1, 1)``.

A stochastic sensor draws its noise from each robot's own generator (``rngs[i]`` for robot
i), robot by robot in the order of ``indices``, and only for the robots it is asked to read:
so a vector env of N robots equals N single envs bit for bit and the same seed gives the
same bits.

Adding a sensor is one class here (or in its own module) plus its tests; pass it to the
environments with ``sensors=[...]``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from mobile_envs.robots import KinematicModel
from mobile_envs.world.maze import Maze

Array = NDArray[np.float64]
Indices = NDArray[np.int64]


class SensorWorld(Protocol):
    """What a sensor may read of the simulation: the robots' true states and their mazes."""

    num_robots: int
    #: (N, k) model states; columns 0-2 are the pose (x, y, heading).
    state: Array
    #: The maze of each maze slot, None for a free slot (empty when no robot was in a maze).
    mazes: list[Maze | None]
    #: (N, m) each robot's action of the step before the one being measured.
    previous_action: Array

    def robots_by_maze(self, indices: Indices | None = None) -> list[tuple[Maze, Indices | None]]:
        """The mazes robots ``indices`` (all by default) are in, each with its robots among
        them (None: all N robots, in order, so results can be written in place)."""
        ...

    def sense_mazes(
        self,
        indices: Indices | None,
        radius: float,
        angles: Array,
        max_range: float,
        collision_out: NDArray[np.bool_],
        ranges_out: Array,
    ) -> None:
        """:meth:`Maze.sense` of robots ``indices`` (all by default), each in its own maze,
        into their rows of the outputs; robots in open space are left as they are."""
        ...


class Sensor(ABC):
    """Base of the sensors.

    Subclasses set :attr:`names` and :attr:`scales` and implement :meth:`reset` and
    :meth:`measure`; those with per-robot state allocate it in :meth:`allocate`, and those
    that read nothing in some worlds (the range sensor off mazes) say so in :meth:`measures`.
    """

    #: The sensor's observation elements, in order.
    names: tuple[str, ...]
    #: (len(names),) factors that bring each reading to [-1, 1].
    scales: Array

    @property
    def width(self) -> int:
        """How many observation elements (and readings columns) the sensor has."""
        return len(self.names)

    def bind(self, model: KinematicModel) -> None:  # noqa: B027 (most sensors need no model)
        """Fit the sensor to the robot it rides on, before its names and scales are read (a
        sensor of the robot's commands needs its number of inputs)."""

    def allocate(self, num_robots: int) -> None:  # noqa: B027 (most sensors hold no state)
        """Make the per-robot buffers for ``num_robots`` robots."""

    @abstractmethod
    def reset(
        self,
        world: SensorWorld,
        indices: Indices,
        rngs: Sequence[np.random.Generator],
        out: Array,
    ) -> None:
        """Read robots ``indices`` right after their reset into rows ``indices`` of ``out``.

        :param rngs: every robot's generator, by robot index
        :param out: (N, width), the sensor's columns of the core's readings
        """

    @abstractmethod
    def measure(
        self,
        world: SensorWorld,
        indices: Indices,
        rngs: Sequence[np.random.Generator],
        out: Array,
    ) -> None:
        """Read robots ``indices`` after a move into rows ``indices`` of ``out`` (N, width).

        ``indices`` are the robots that go on: a robot that restarts this step is read by
        :meth:`reset` instead and must draw nothing here. A noise-free sensor may read every
        robot; rows outside ``indices`` are overwritten by the restart.

        :param rngs: every robot's generator, by robot index
        """

    def measures(self, world: SensorWorld) -> bool:
        """Whether :meth:`measure` would change a reading or draw a number in ``world``, asked
        after every reset and holding until the next: steps where no sensor measures skip the
        sensors and step each robot in one compiled call. True unless a sensor knows better
        (the default suits every sensor)."""
        return True


_NO_COLLISIONS = np.empty(0, dtype=bool)

#: Range sensor defaults: rays evenly spread around the robot, and their reach.
RANGE_RAYS = 16
RANGE_MAX = 3.0


class RangeSensor(Sensor):
    """A ring of range finders: the distance to the first maze wall along each ray.

    Rays are evenly spread counter-clockwise from straight behind the robot (``-pi``);
    readings are at most ``max_range`` and exactly ``max_range`` off mazes, so the
    observation reads 1 there. Noise-free.

    :param rays: number of rays
    :param max_range: reach in metres
    """

    def __init__(self, rays: int = RANGE_RAYS, max_range: float = RANGE_MAX):
        if isinstance(rays, bool) or int(rays) != rays or rays < 1:
            raise ValueError(f"rays must be a positive integer, got {rays!r}")
        if not (math.isfinite(max_range) and max_range > 0):
            raise ValueError(f"max_range must be a positive finite number, got {max_range!r}")
        self.rays = int(rays)
        self.max_range = float(max_range)
        self.angles = np.linspace(-math.pi, math.pi, self.rays, endpoint=False)
        self.names = tuple(f"range_{k}" for k in range(self.rays))
        self.scales = np.full(self.rays, 1.0 / self.max_range)

    def reset(
        self,
        world: SensorWorld,
        indices: Indices,
        rngs: Sequence[np.random.Generator],
        out: Array,
    ) -> None:
        out[indices] = self.max_range
        self._cast(world, out, indices)

    def measure(
        self,
        world: SensorWorld,
        indices: Indices,
        rngs: Sequence[np.random.Generator],
        out: Array,
    ) -> None:
        # Noise-free: every robot at once, which keeps the in-place path for a shared maze.
        if self.measures(world):
            self._cast(world, out)

    def measures(self, world: SensorWorld) -> bool:
        # In open space every ray reads max_range, written at reset.
        return bool(world.mazes)

    def _cast(self, world: SensorWorld, out: Array, indices: Indices | None = None) -> None:
        """Cast the rays of the robots among ``indices`` (all by default) in a maze, all mazes
        in one call (an empty collision array asks for the ranges alone)."""
        world.sense_mazes(indices, 0.0, self.angles, self.max_range, _NO_COLLISIONS, out)

    def __repr__(self) -> str:
        return f"RangeSensor(rays={self.rays}, max_range={self.max_range})"

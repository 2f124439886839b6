"""The range sensor: a ring of range finders that read the distance to the maze walls."""

from __future__ import annotations

import math

import numpy as np

from mobile_envs.sensing.sensors.sensor import Array, Generators, Indices, Sensor, SensorWorld
from mobile_envs.validation import as_count, as_positive

_NO_COLLISIONS = np.empty(0, dtype=bool)

#: Range sensor defaults: rays evenly spread around the robot, and their reach.
RANGE_RAYS = 16
RANGE_MAX = 3.0


class RangeSensor(Sensor):
    """A ring of range finders: the distance to the first maze wall along each ray
    (``sensors=["range"]``, the default sensor).

    Rays are evenly spread counter-clockwise from straight behind the robot (``-pi``);
    readings are at most ``max_range`` and exactly ``max_range`` off mazes, so the
    observation reads 1 there. Noise-free.

    :param rays: number of rays
    :param max_range: reach in metres
    """

    name = "range"

    def __init__(self, rays: int = RANGE_RAYS, max_range: float = RANGE_MAX):
        self.rays = as_count("rays", rays)
        self.max_range = as_positive("max_range", max_range)
        self.angles = np.linspace(-math.pi, math.pi, self.rays, endpoint=False)
        self.names = tuple(f"range_{k}" for k in range(self.rays))
        self.scales = np.full(self.rays, 1.0 / self.max_range)

    def reset(self, world: SensorWorld, indices: Indices, rngs: Generators, out: Array) -> None:
        out[indices] = self.max_range
        self._cast(world, out, indices)

    def measure(self, world: SensorWorld, indices: Indices, rngs: Generators, out: Array) -> None:
        # Noise-free: every robot at once, which keeps the in-place path for a shared maze.
        if self.measures(world):
            self._cast(world, out)

    def measures(self, world: SensorWorld) -> bool:
        # In open space every ray reads max_range, written at reset.
        return bool(world.mazes)

    def maze_rays(self) -> tuple[Array, float]:
        return self.angles, self.max_range

    def _cast(self, world: SensorWorld, out: Array, indices: Indices | None = None) -> None:
        """Cast the rays of the robots among ``indices`` (all by default) in a maze, all mazes
        in one call (an empty collision array asks for the ranges alone)."""
        world.sense_mazes(indices, 0.0, self.angles, self.max_range, _NO_COLLISIONS, out)

    def __repr__(self) -> str:
        return f"RangeSensor(rays={self.rays}, max_range={self.max_range})"

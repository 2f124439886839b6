"""The sensor interface: what a sensor owns, what it may read of the simulation, and the
catalogue environments choose sensors from by name.

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

Adding a sensor is one module in :mod:`mobile_envs.sensing.sensors` (a :class:`Sensor`
subclass with a ``name``, which registers it) plus its tests. Environments take sensors as
objects, names or settings (``sensors=[RangeSensor(), "gnss", {"type": "range", "rays":
8}]``: :func:`make_sensors`), so ``train.py``, a hyperparameters YAML and ``--env-kwargs``
choose them; user code adds its own with :func:`register_sensor` or a named subclass.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar, Protocol

import numpy as np
from numpy.typing import NDArray

from mobile_envs.catalogue import Catalogue
from mobile_envs.robots import KinematicModel
from mobile_envs.validation import is_list
from mobile_envs.world.maze import Maze

Array = NDArray[np.float64]
Indices = NDArray[np.int64]
#: Every robot's generator, by robot index.
Generators = Sequence[np.random.Generator]


class SensorWorld(Protocol):
    """What a sensor may read of the simulation: the step, the robots' true states, what they
    believe their poses are, and their mazes."""

    num_robots: int
    #: (N, k) model states; columns 0-2 are the pose (x, y, heading).
    state: Array
    #: (N, 3) the pose (x, y, heading) each robot believes it has: its localization's
    #: estimate, the true pose without one (``localization="exact"``); updated before the
    #: sensors read.
    estimate: Array
    #: The maze of each maze slot, None for a free slot (empty when no robot was in a maze).
    mazes: list[Maze | None]
    #: (N, m) each robot's action of the step before the one being measured.
    previous_action: Array

    @property
    def dt(self) -> float:
        """The step (s)."""
        ...

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


#: The sensors environments build by name (``sensors=["range"]``); a :class:`Sensor`
#: subclass with a ``name`` registers itself.
SENSORS: Catalogue[Callable[..., Sensor]] = Catalogue("sensor")


class Sensor(ABC):
    """Base of the sensors.

    Subclasses set :attr:`names` and :attr:`scales` and implement :meth:`reset` and
    :meth:`measure`; those with per-robot state allocate it in :meth:`allocate`, and those
    that read nothing in some worlds (the range sensor off mazes) say so in :meth:`measures`.
    A subclass that sets :attr:`name` is registered under it in :data:`SENSORS`, its
    ``__init__``'s arguments its settings.
    """

    #: The name environments take for it (``sensors=["range"]``), if it has one.
    name: ClassVar[str]
    #: The sensor's observation elements, in order.
    names: tuple[str, ...]
    #: (len(names),) factors that bring each reading to [-1, 1].
    scales: Array

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in vars(cls):
            register_sensor(cls.name, cls)

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
    def reset(self, world: SensorWorld, indices: Indices, rngs: Generators, out: Array) -> None:
        """Read robots ``indices`` right after their reset into rows ``indices`` of ``out``.

        :param rngs: every robot's generator, by robot index
        :param out: (N, width), the sensor's columns of the core's readings
        """

    @abstractmethod
    def measure(self, world: SensorWorld, indices: Indices, rngs: Generators, out: Array) -> None:
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

    def maze_rays(self) -> tuple[Array, float] | None:
        """The rays this sensor casts, (angles from the heading in rad, reach in m), when what
        it measures is exactly the maze's ranges along them, unbounded by noise or state;
        else None (the default). A step whose only measuring sensor casts maze rays casts
        them with the collision test, in the step's own compiled call: the same bits."""
        return None


def register_sensor(name: str, factory: Callable[..., Sensor], *, replace: bool = False) -> None:
    """Let environments build ``factory(**settings)`` from ``name`` (``sensors=[name]`` or
    ``sensors=[{"type": name, **settings}]``).

    :param factory: a :class:`Sensor` subclass or a function that returns a sensor; its
        keyword arguments are the sensor's settings
    :param replace: replace a sensor already registered under ``name``
    :raises ValueError: for a name already registered (unless ``replace``)
    """
    SENSORS.register(name, factory, replace=replace)


#: What environments take for a sensor: an object, a name, or ``{"type": name, **settings}``.
SensorSpec = Sensor | str | Mapping[str, Any]
#: The forms :func:`make_sensors` takes, for its messages.
_SENSOR_FORMS = 'Sensor objects, sensor names or {"type": name, **settings} mappings'


def make_sensor(sensor: Sensor | str | Mapping[str, Any], label: str = "sensor") -> Sensor:
    """A sensor from an object (as it is), a registered name (with its default settings), or a
    mapping ``{"type": name, **settings}``.

    :param label: what messages call it (``"sensors[1]"``)
    :raises ValueError: naming ``label`` and what is wrong: an unknown name (listing the known
        ones), a mapping without a ``"type"``, settings the sensor does not take (listing those
        it takes) or bad setting values
    """
    if isinstance(sensor, Sensor):
        return sensor
    if isinstance(sensor, str):
        name, settings = sensor, {}
    elif isinstance(sensor, Mapping):
        settings = dict(sensor)
        name = settings.pop("type", None)
        if not isinstance(name, str):
            raise ValueError(
                f"{label} needs a 'type' naming the sensor, one of {list(SENSORS.names())}; "
                f"got {sensor!r}"
            )
    else:
        raise ValueError(f"{label} must be one of {_SENSOR_FORMS}, got {sensor!r}")
    try:
        built = SENSORS.make(name, settings)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{label}: {error}") from None
    if not isinstance(built, Sensor):
        raise ValueError(f"{label}: sensor {name!r} built {built!r}, not a Sensor")
    return built


def make_sensors(sensors: Any) -> tuple[Sensor, ...]:
    """Sensors from a list of the forms :func:`make_sensor` takes, in order.

    :raises ValueError: naming ``sensors`` (or ``sensors[k]``) and what is wrong
    """
    if not is_list(sensors):
        raise ValueError(f"sensors must be a list of {_SENSOR_FORMS}, got {sensors!r}")
    return tuple(make_sensor(sensor, f"sensors[{k}]") for k, sensor in enumerate(sensors))

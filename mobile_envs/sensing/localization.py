"""Localization: what each robot believes its pose is, as opposed to what it is.

With a :class:`Localization` the environment's robots *observe* from their estimated pose
(preview points, tracking errors, progress) and are *scored* on their true pose (reward,
termination, episode metrics), as a real robot follows its path on what its localization
tells it. Without one (``localization="exact"``, the default) the robot knows its pose.

A localization owns the estimates' evolution: :meth:`Localization.reset` sets the estimates
of freshly reset robots, :meth:`Localization.update` advances them after each move, drawing
any noise from each robot's own generator (``rngs[i]`` for robot i, robot by robot in the
order of ``indices``), so a vector env of N robots equals N single envs bit for bit.

Environments take a localization by name from :data:`LOCALIZATIONS` (``localization=
"odometry"``, its settings in ``localization_params``); a subclass with a ``name`` registers
itself, and :func:`register_localization` registers any factory.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from typing import Any, ClassVar, Protocol

import numpy as np
from numpy.typing import NDArray

from mobile_envs.catalogue import Catalogue
from mobile_envs.robots import KinematicModel
from mobile_envs.tracks.sets import PathSet, Track
from mobile_envs.world.maze import Maze

Array = NDArray[np.float64]
Indices = NDArray[np.int64]
Generators = Sequence[np.random.Generator]


class LocalizationWorld(Protocol):
    """What a localization may read of the simulation."""

    num_robots: int
    model: KinematicModel
    #: (N, k) true states after the move, and at its start (the encoders' view of the step).
    state: Array
    previous_state: Array
    #: (N, m) the saturated native inputs held over the step.
    inputs: Array
    #: Each robot's track (its path and maze), None before its first reset.
    tracks: list[Track | None]

    @property
    def dt(self) -> float: ...

    def robots_by_maze(self, indices: Indices | None = None) -> list[tuple[Maze, Indices | None]]:
        """The mazes robots ``indices`` are in, each with its robots among them."""
        ...


#: The localizations environments build by name; a subclass with a ``name`` registers itself.
LOCALIZATIONS: Catalogue[Callable[..., Localization]] = Catalogue("localization")


class Localization(ABC):
    """Base of the localizations: how each robot's pose estimate evolves.

    The estimate is (x, y, heading) of the robot's reference point; the environment keeps it
    in an (N, 3) array and hands rows of it to :meth:`reset` and :meth:`update`. Each
    environment works on its own copy of the localization it is given.
    """

    #: The name environments take for it (``localization="..."``).
    name: str
    #: The part of the environment ids it gives, ``mobile_envs/<Model>-<PathSet>-<env_id>-v0``
    #: (on the path sets with localized ids: :class:`~mobile_envs.tracks.catalogue.
    #: PathSetEntry`); None for none.
    env_id: ClassVar[str | None] = None
    #: Whether it reads wheel (or steering) encoders, so only models with encoders have its ids.
    needs_encoders: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in vars(cls):
            register_localization(cls.name, cls)

    def allocate(  # noqa: B027 (a localization without per-robot state needs nothing)
        self, num_robots: int, model: KinematicModel, path_set: PathSet
    ) -> None:
        """Make the per-robot buffers for ``num_robots`` robots of ``model`` on ``path_set``
        (a localization may check there that it can work for them: ``ValueError`` if not)."""

    @abstractmethod
    def reset(
        self, world: LocalizationWorld, indices: Indices, rngs: Generators, estimate: Array
    ) -> None:
        """Set the estimates of robots ``indices`` right after their reset.

        :param rngs: every robot's generator, by robot index
        :param estimate: (N, 3), write rows ``indices``
        """

    @abstractmethod
    def update(
        self, world: LocalizationWorld, indices: Indices, rngs: Generators, estimate: Array
    ) -> None:
        """Advance the estimates of robots ``indices`` over the step just taken (robots that
        restart this step are left to :meth:`reset` and must draw nothing here).

        :param rngs: every robot's generator, by robot index
        :param estimate: (N, 3), update rows ``indices``
        """

    # Optional: what a localization shows beyond the estimate (the defaults show nothing).

    def read_model_state(self, states: Array) -> Array:
        """The model's state columns beyond the pose, ``states`` (..., k - 3), as the robot's
        own encoders read them (the tricycle's wheel angle from its steering encoder); by
        default exactly."""
        return np.array(states, dtype=np.float64)

    @property
    def landmarks(self) -> Array | None:
        """(R, 2) positions of the landmarks it measures (the reflectors), None if none."""
        return None

    def sightings(self, index: int) -> Array:
        """(L, 2, 2) segments to draw for robot ``index``'s last measurement (the laser lines
        of its last fix); none by default."""
        return np.zeros((0, 2, 2))


def believed_states(localization: Localization | None, estimate: Array, states: Array) -> Array:
    """What robots believe their states are: the estimated pose (x, y, heading) followed by
    the model's other state columns as :meth:`Localization.read_model_state` reads them; a
    copy of ``states`` without a localization.

    :param estimate: (n, 3) estimated poses
    :param states: (n, k) true states of the same robots
    """
    believed = np.array(states, dtype=np.float64)
    if localization is not None:
        believed[:, :3] = estimate
        believed[:, 3:] = localization.read_model_state(believed[:, 3:])
    return believed


def register_localization(
    name: str, factory: Callable[..., Localization], *, replace: bool = False
) -> None:
    """Let environments build ``factory(**localization_params)`` from
    ``localization=name``.

    :param factory: a :class:`Localization` subclass or a function that returns one; its
        keyword arguments are the localization's settings
    :param replace: replace a localization already registered under ``name``
    :raises ValueError: for ``"exact"`` (the robot knowing its pose) or a name already
        registered (unless ``replace``)
    """
    if name == "exact":
        raise ValueError('"exact" is the robot knowing its pose, not a localization to register')
    LOCALIZATIONS.register(name, factory, replace=replace)


def make_localization(
    localization: str | Localization | None, parameters: dict[str, Any] | None = None
) -> Localization | None:
    """A localization from a name (``"exact"`` gives None: the robot knows its pose) and its
    settings, or an instance as it is.

    :raises ValueError: for an unknown name (listing the known ones), settings with an
        instance or with ``"exact"``, or settings the localization does not take (naming
        them and those it takes)
    """
    if localization is None or isinstance(localization, Localization):
        if parameters:
            raise ValueError("localization_params can only be given with a localization name")
        return localization
    if localization == "exact":
        if parameters:
            raise ValueError('localization="exact" takes no localization_params')
        return None
    if not isinstance(localization, str) or localization not in LOCALIZATIONS:
        known = ["exact", *LOCALIZATIONS.names()]
        raise ValueError(f"unknown localization {localization!r}; known: {known}")
    built = LOCALIZATIONS.make(localization, parameters, label="localization_params")
    if not isinstance(built, Localization):
        raise ValueError(f"localization {localization!r} built {built!r}, not a Localization")
    return built

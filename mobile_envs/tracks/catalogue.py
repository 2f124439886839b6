"""The path-set catalogue: the sets environments take by name (``paths="segments"``), and the
facts their environment ids are made of.

A set is registered with :func:`register_path_set`: its name, a function that builds it (run
once, on first use, so importing the package builds nothing) and, for a set with ids of its
own, the part of the id it gives (``mobile_envs/<Model>-<env_id>-v0``), the settings those ids
pass and which models and localizations have them. :func:`mobile_envs.register_envs`
registers the ids of sets added after ``import mobile_envs``::

    from mobile_envs.tracks import FixedPathSet, Track, register_path_set
    from mobile_envs.world.paths import Path

    def square() -> FixedPathSet:
        corners = [[1, 1], [5, 1], [5, 5], [1, 5], [1, 1.5]]
        return FixedPathSet("square", [Track(Path(corners))], reflectors=[[0, 0], [6, 0], [0, 6]])

    register_path_set("square", square, env_id="Square")
    mobile_envs.register_envs()  # mobile_envs/DiffDrive-Square-v0, ...-Square-Beacons-v0, ...
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import Any

from mobile_envs.catalogue import Catalogue
from mobile_envs.tracks.sets import PathSet


@dataclass(frozen=True, eq=False)
class PathSetEntry:
    """A registered path set: how to build it and the facts of its environment ids.

    Calling the entry builds the set (a fresh one at each call; :func:`path_set` keeps the
    one environments share).

    :param build: makes the set, named as it is registered; a module-level function, so the
        catalogue's sets pickle
    :param env_id: the part of the ids it gives, ``mobile_envs/<Model>-<env_id>-v0``
        (CamelCase letters and digits); None for a set without ids
    :param env_kwargs: the environment settings its ids pass beyond the model and the set
        (``{"start_noise": 0.0}``)
    :param env_models: the model names that have its ids; None for every model
    :param env_localizations: the localization names that have localized ids on it
        (``mobile_envs/<Model>-<env_id>-<Localization>-v0``, for the localizations with an
        id of their own); None for every such localization, ``()`` for none
    :param compared: whether ``train.py compare`` runs its ids by default
    """

    build: Callable[[], PathSet]
    env_id: str | None = None
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    env_models: tuple[str, ...] | None = None
    env_localizations: tuple[str, ...] | None = None
    compared: bool = False

    def __call__(self) -> PathSet:
        return self.build()


#: Every path set environments take by name.
PATH_SETS: Catalogue[PathSetEntry] = Catalogue("path set")


def register_path_set(
    name: str,
    build: Callable[[], PathSet],
    *,
    env_id: str | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    env_models: tuple[str, ...] | None = None,
    env_localizations: tuple[str, ...] | None = None,
    compared: bool = False,
    replace: bool = False,
) -> None:
    """Register a path set under ``name``, for environments to take by name; the other
    arguments are :class:`PathSetEntry`'s.

    :param replace: replace a set already registered under ``name``
    :raises ValueError: for a duplicate name (unless ``replace``) or an ``env_id`` that is
        not CamelCase letters and digits
    """
    if env_id is not None and not (
        isinstance(env_id, str) and env_id.isascii() and env_id.isalnum() and env_id[0].isupper()
    ):
        raise ValueError(
            f"path set {name!r}: env_id must be CamelCase letters and digits (it is one part "
            f"of mobile_envs/<Model>-<env_id>-v0), got {env_id!r}"
        )
    entry = PathSetEntry(
        build,
        env_id,
        dict(env_kwargs or {}),
        None if env_models is None else tuple(env_models),
        None if env_localizations is None else tuple(env_localizations),
        bool(compared),
    )
    PATH_SETS.register(name, entry, replace=replace)


def path_set_names() -> tuple[str, ...]:
    """Names of the registered path sets."""
    return PATH_SETS.names()


def path_set(name: str) -> PathSet:
    """The registered path set of this name, built on first use (the same object after).

    :param name: one of :func:`path_set_names`.
    :raises ValueError: for an unknown name; the message lists the known ones.
    """
    if not isinstance(name, str) or name not in PATH_SETS:
        known = ", ".join(path_set_names())
        raise ValueError(f"unknown path set {name!r}; known path sets: {known}")
    built = _built(PATH_SETS[name])
    if built.name != name:
        raise ValueError(f"path set {name!r} is built with another name, {built.name!r}")
    return built


@cache
def _built(entry: PathSetEntry) -> PathSet:
    """The set ``entry`` builds, once per entry (a replaced name builds its new entry)."""
    return entry()

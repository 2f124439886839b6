"""Catalogues: the things environments take by name, which user code extends without editing
the package.

A :class:`Catalogue` maps names to factories: the path sets
(:data:`mobile_envs.tracks.catalogue.PATH_SETS`), the sensors
(:data:`mobile_envs.sensing.sensors.SENSORS`) and the localizations
(:data:`mobile_envs.sensing.localization.LOCALIZATIONS`). ``make(name, settings)`` builds one
from its settings, as ``train.py``, a hyperparameter YAML or ``--env-kwargs`` give them, and
names what is wrong (an unknown name, a setting the factory does not take)::

    >>> from mobile_envs.catalogue import Catalogue
    >>> shapes = Catalogue("shape")
    >>> shapes.register("square", lambda side=1.0: side * side)
    >>> shapes.make("square", {"side": 2.0})
    4.0
    >>> shapes.make("square", {"radius": 1.0})
    Traceback (most recent call last):
    ...
    ValueError: settings ['radius'] are not settings of shape 'square'; its settings: ['side']

A package whose modules each register what they define (one module per sensor, per path
set) imports them all with :func:`import_package_modules`, so adding one is adding a module.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any, TypeVar

Factory = TypeVar("Factory", bound=Callable[..., Any])

_NAMED = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)


class Catalogue(Mapping[str, Factory]):
    """A read-only mapping from names to factories, to which :meth:`register` adds.

    ``sorted(catalogue)``, ``name in catalogue`` and ``catalogue[name]`` read it as a mapping;
    it iterates in name order, whatever the order of registration.

    :param kind: what it holds, as messages name it (``"sensor"``, ``"path set"``)
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._factories: dict[str, Factory] = {}

    def register(self, name: str, factory: Factory, *, replace: bool = False) -> None:
        """Make ``factory`` the one ``name`` builds.

        :param replace: replace a factory already registered under ``name``
        :raises ValueError: for a name that is not a non-empty string, a factory that is not
            callable, or a name already registered (unless ``replace``)
        """
        if not isinstance(name, str) or not name:
            raise ValueError(f"a {self.kind} name must be a non-empty string, got {name!r}")
        if not callable(factory):
            raise ValueError(f"{self.kind} {name!r}: the factory must be callable, got {factory!r}")
        if name in self._factories and not replace:
            raise ValueError(
                f"{self.kind} {name!r} is already registered ({self._factories[name]!r}); "
                "pass replace=True to replace it"
            )
        self._factories[name] = factory

    def __getitem__(self, name: str) -> Factory:
        return self._factories[name]

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._factories))

    def __len__(self) -> int:
        return len(self._factories)

    def names(self) -> tuple[str, ...]:
        """The registered names, in order."""
        return tuple(self)

    def factory(self, name: Any) -> Factory:
        """The factory of ``name``.

        :raises ValueError: for an unknown name, listing the known ones
        """
        if not isinstance(name, str) or name not in self._factories:
            raise ValueError(f"unknown {self.kind} {name!r}; known: {list(self.names())}")
        return self._factories[name]

    def settings_of(self, name: str) -> tuple[str, ...]:
        """The settings (keyword arguments) the factory of ``name`` takes, in order."""
        parameters = inspect.signature(self.factory(name)).parameters.values()
        return tuple(parameter.name for parameter in parameters if parameter.kind in _NAMED)

    def make(
        self, name: Any, settings: Mapping[str, Any] | None = None, label: str = "settings"
    ) -> Any:
        """Build ``name`` with ``settings``.

        :param settings: the factory's keyword arguments; None for none
        :param label: what the settings are called in messages (``"localization_params"``)
        :raises ValueError: for an unknown name, settings that are not a mapping or that
            the factory does not take (naming them and the ones it takes), and whatever the
            factory raises for bad values
        """
        factory = self.factory(name)
        if settings is None:
            settings = {}
        if not isinstance(settings, Mapping):
            raise ValueError(f"{label} of {self.kind} {name!r} must be a mapping, got {settings!r}")
        parameters = inspect.signature(factory).parameters.values()
        takes_any = any(parameter.kind == inspect.Parameter.VAR_KEYWORD for parameter in parameters)
        accepted = self.settings_of(name)
        unknown = sorted(set(settings) - set(accepted), key=str)
        if unknown and not takes_any:
            raise ValueError(
                f"{label} {unknown} are not settings of {self.kind} {name!r}; "
                f"its settings: {list(accepted)}"
            )
        return factory(**settings)

    def __repr__(self) -> str:
        return f"Catalogue({self.kind!r}, {list(self.names())})"


def import_package_modules(package: str, path: Iterable[str]) -> None:
    """Import every module of a package, in name order, so that each registers what it
    defines: a package's ``__init__`` calls ``import_package_modules(__name__, __path__)``.

    :param package: the package's name
    :param path: the package's ``__path__``
    """
    for module in sorted(pkgutil.iter_modules(path), key=lambda found: found.name):
        importlib.import_module(f"{package}.{module.name}")

"""Compiled code written once and specialized per robot model.

The kernels that move robots (the step, the odometry, the localization, a model's own batch
methods) are written once, as *templates*: plain functions that call the model's compiled
functions through the placeholder :data:`model` (``model.advance(...)``,
``model.twist(...)``). :func:`for_model` compiles a template for one model, with ``model``
bound to the module that holds that model's compiled functions (``robots/diff_drive.py``
for the differential drive). So no compiled code outside a model's module names a model,
and a new model needs no edit anywhere else.

A template may call other templates; they are specialized for the same model first. Each
specialization is an ordinary numba function: it inlines the model's functions (which are
``inline="always"``), runs as fast as code written for that model alone, and is cached on
disk like any kernel, under its template's file and a name that carries the model module's
name and a hash of its source (so an edited model outside this package is recompiled; the
package's own edits are followed by :mod:`mobile_envs._kernels.kernel_cache`). Numba's
first-class functions would also pass a model's functions to a kernel, but a call then
costs microseconds of type checking and the disk cache misses in every new process.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import types
from collections.abc import Callable
from typing import Any

from numba import njit

__all__ = ["Template", "fallback", "for_model", "model", "model_namespace", "per_model"]

#: The placeholder a template calls a model's compiled functions through: ``model.advance``,
#: ``model.twist``, ... (see :class:`mobile_envs.robots.model.KinematicModel` for the list).
#: :func:`for_model` binds the name to a model's module instead.
model = types.ModuleType("model", "A robot model's compiled functions, bound per model.")


class Template:
    """A function compiled per model by :func:`for_model`; calling it directly is an error.

    :param function: the template's Python source, calling the placeholder :data:`model`
    :param options: numba's options for its specializations (``cache`` is set by
        :func:`for_model`)
    """

    def __init__(self, function: Callable[..., Any], options: dict[str, Any]) -> None:
        self.function = function
        self.options = options
        functools.update_wrapper(self, function)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        raise TypeError(
            f"{self.function.__qualname__} is compiled per model: call "
            f"for_model({self.function.__name__}, model_module) instead"
        )

    def __repr__(self) -> str:
        return f"<template {self.function.__module__}.{self.function.__qualname__}>"


def per_model(**options: Any) -> Callable[[Callable[..., Any]], Template]:
    """Decorator: make a function a :class:`Template` compiled with numba ``options``
    (``inline="always"``, ``parallel=True``, ...) for each model it is specialized for."""

    def decorate(function: Callable[..., Any]) -> Template:
        return Template(function, options)

    return decorate


_SPECIALIZED: dict[tuple[Template, types.ModuleType], Any] = {}
_NAMESPACES: dict[types.ModuleType, types.ModuleType] = {}
_FALLBACKS: dict[str, Any] = {}


def fallback(name: str, function: Any) -> None:
    """Give templates ``function`` as ``model.<name>`` for models whose module has no
    ``name``: numba compiles every branch of a template, also those a model never takes
    (the odometry's, for a robot without encoders), so such a call must still resolve.

    :param function: a compiled function, typically one that raises ``ValueError``
    """
    _FALLBACKS[name] = function


def for_model(template: Template, model_module: types.ModuleType) -> Any:
    """``template`` compiled for the model whose compiled functions ``model_module`` holds.

    The model module may hold templates itself (the rigid-body models take their
    ``advance``, ``twist`` and ``rates`` from :mod:`mobile_envs.robots.rigid_body`, which call
    the module's ``body_twist``): those are specialized for it too. Specializations are made
    once per (template, model) and kept: later calls return the same numba dispatcher.

    :param template: a function decorated with :func:`per_model`
    :param model_module: the module of a model's compiled functions
        (:attr:`mobile_envs.robots.model.KinematicModel.compiled`)
    :return: the numba dispatcher
    """
    key = (template, model_module)
    compiled = _SPECIALIZED.get(key)
    if compiled is None:
        compiled = _specialize(template, model_module)
        _SPECIALIZED[key] = compiled
    return compiled


def model_namespace(model_module: types.ModuleType) -> types.ModuleType:
    """What templates see as :data:`model` for ``model_module``: its attributes, with each
    template among them specialized for it (compiled on first use, as numba does)."""
    namespace = _NAMESPACES.get(model_module)
    if namespace is None:
        namespace = types.ModuleType(model_module.__name__, model_module.__doc__)
        _NAMESPACES[model_module] = namespace
        for name, function in _FALLBACKS.items():
            setattr(namespace, name, function)
        for name, value in vars(model_module).items():
            if not name.startswith("__"):
                compiled = for_model(value, model_module) if isinstance(value, Template) else value
                setattr(namespace, name, compiled)
    return namespace


def _specialize(template: Template, model_module: types.ModuleType) -> Any:
    source = template.function
    bindings: dict[str, Any] = {"model": model_namespace(model_module)}
    for name in source.__code__.co_names:
        called = source.__globals__.get(name)
        if isinstance(called, Template):
            bindings[name] = for_model(called, model_module)
    function = types.FunctionType(
        source.__code__,
        {**source.__globals__, **bindings},
        source.__name__,
        source.__defaults__,
        source.__closure__,
    )
    function.__kwdefaults__ = source.__kwdefaults__
    function.__module__ = source.__module__
    function.__doc__ = source.__doc__
    tag = _model_tag(model_module)
    # numba names a kernel's cache files after its qualname: one set of files per model.
    function.__qualname__ = f"{source.__qualname__}__{tag}"
    # A model typed in at an interactive prompt has no source to key a cache on.
    cache = not tag.endswith("_interactive")
    return njit(cache=cache, **template.options)(function)


@functools.cache
def _model_tag(model_module: types.ModuleType) -> str:
    """The model module's name and a hash of its source, for cache file names."""
    name = model_module.__name__.replace(".", "_")
    try:
        source_file = inspect.getsourcefile(model_module)
    except TypeError:  # a module without a file
        source_file = None
    if source_file is None:
        return f"{name}_interactive"
    with open(source_file, "rb") as source:
        digest = hashlib.sha256(source.read()).hexdigest()[:12]
    return f"{name}_{digest}"

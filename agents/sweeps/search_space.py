"""Search spaces for sweeps: YAML (``hyperparams/sweep.yml``) turned into Optuna suggestions.

The file holds one space per algorithm. A key names an argument of the algorithm, with dots
into nested mappings (``policy_kwargs.net_arch``), or, prefixed with ``env.``, an argument
of the environment (``env.reward_weights.cross_track``). A value says how to sample it::

    learning_rate: {type: float, low: 1.0e-5, high: 3.0e-3, log: true}
    n_epochs: {type: int, low: 3, high: 20}
    gamma: {type: categorical, choices: [0.98, 0.99, 0.995]}
    policy_kwargs.net_arch: {type: categorical, choices: {small: [64, 64], deep: [64, 64, 64]}}

Named choices carry values Optuna cannot store (lists, mappings): the trial records the name.
"""

from __future__ import annotations

import copy
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import yaml

ENV_PREFIX = "env."
_FIELDS = {
    "float": {"type", "low", "high", "log", "step"},
    "int": {"type", "low", "high", "log", "step"},
    "categorical": {"type", "choices"},
}


@dataclass(frozen=True)
class Parameter:
    """One sampled setting.

    :param key: where it goes (see the module docstring)
    :param kind: ``float``, ``int`` or ``categorical``
    :param low: the smallest value (float, int)
    :param high: the largest value (float, int)
    :param log: sample on a log scale (float, int)
    :param step: sample on a grid of this spacing (float, int)
    :param choices: the values (categorical); a mapping gives them names
    """

    key: str
    kind: str
    low: float | None = None
    high: float | None = None
    log: bool = False
    step: float | None = None
    choices: tuple[Any, ...] | Mapping[str, Any] | None = None

    def suggest(self, trial: Any) -> Any:
        """Ask ``trial`` (an ``optuna.Trial``) for this parameter; return the setting's value."""
        if self.kind == "categorical":
            assert self.choices is not None
            if isinstance(self.choices, Mapping):
                name = trial.suggest_categorical(self.key, list(self.choices))
                return copy.deepcopy(self.choices[name])
            return trial.suggest_categorical(self.key, list(self.choices))
        assert self.low is not None and self.high is not None
        if self.kind == "int":
            step = int(self.step) if self.step is not None else 1
            return trial.suggest_int(
                self.key, int(self.low), int(self.high), step=step, log=self.log
            )
        return trial.suggest_float(self.key, self.low, self.high, step=self.step, log=self.log)

    def value_of(self, stored: Any) -> Any:
        """The setting's value for the value a trial stored (a choice's name for named
        choices)."""
        if self.kind == "categorical" and isinstance(self.choices, Mapping):
            return copy.deepcopy(self.choices[stored])
        return stored


def parse_parameter(key: str, spec: Any) -> Parameter:
    """A :class:`Parameter` from one entry of the YAML.

    :raises ValueError: naming ``key`` for a malformed entry
    """
    if not isinstance(spec, Mapping) or spec.get("type") not in _FIELDS:
        raise ValueError(
            f"search space parameter {key!r}: expected a mapping with type float, int or "
            f"categorical, got {spec!r}"
        )
    kind = spec["type"]
    unknown = sorted(set(spec) - _FIELDS[kind])
    if unknown:
        raise ValueError(f"search space parameter {key!r}: unknown fields {unknown} for {kind}")
    if "" in key.removeprefix(ENV_PREFIX).split("."):
        raise ValueError(f"search space parameter {key!r}: an empty name between dots")
    if kind == "categorical":
        choices = spec.get("choices")
        if isinstance(choices, Mapping) and choices:
            return Parameter(
                key, kind, choices={str(name): value for name, value in choices.items()}
            )
        if isinstance(choices, list) and choices:
            for choice in choices:
                if choice is not None and not isinstance(choice, (bool, int, float, str)):
                    raise ValueError(
                        f"search space parameter {key!r}: choice {choice!r} is not a number, "
                        f"string or boolean; name it (choices: {{name: value}})"
                    )
            return Parameter(key, kind, choices=tuple(choices))
        raise ValueError(
            f"search space parameter {key!r}: choices must be a non-empty list or mapping"
        )
    low, high = spec.get("low"), spec.get("high")
    numbers = (int, float) if kind == "float" else (int,)
    article = "a float" if kind == "float" else "an int"
    for name, bound in (("low", low), ("high", high)):
        if isinstance(bound, bool) or not isinstance(bound, numbers):
            raise ValueError(
                f"search space parameter {key!r}: {name} must be {article}, got {bound!r}"
            )
    assert low is not None and high is not None
    if not low <= high:
        raise ValueError(f"search space parameter {key!r}: low {low} is above high {high}")
    log = bool(spec.get("log", False))
    if log and low <= 0:
        raise ValueError(f"search space parameter {key!r}: a log scale needs low > 0, got {low}")
    step = spec.get("step")
    if step is not None and (isinstance(step, bool) or not isinstance(step, numbers) or step <= 0):
        raise ValueError(f"search space parameter {key!r}: step must be a positive number")
    if step is not None and log:
        raise ValueError(f"search space parameter {key!r}: step and log cannot both be set")
    return Parameter(key, kind, float(low), float(high), log, step)


def load_search_space(path: pathlib.Path, algo: str) -> list[Parameter]:
    """The parameters of ``algo``'s space in the YAML file at ``path``.

    :raises ValueError: for a missing file or algorithm, or a malformed entry
    """
    if not path.is_file():
        raise ValueError(f"search space file not found: {path}")
    table = yaml.safe_load(path.read_text()) or {}
    if algo not in table:
        raise ValueError(f"{path} has no search space for algo {algo!r}; it has {sorted(table)}")
    space = table[algo]
    if not isinstance(space, Mapping) or not space:
        raise ValueError(f"{path}: the search space for {algo!r} must be a non-empty mapping")
    return [parse_parameter(str(key), spec) for key, spec in space.items()]


def set_dotted(target: dict[str, Any], dotted: str, value: Any) -> None:
    """Set ``target[a][b][c] = value`` for ``dotted = "a.b.c"``, making the mappings between.

    :raises ValueError: when a step on the way holds something other than a mapping
    """
    *parents, leaf = dotted.split(".")
    node = target
    for index, part in enumerate(parents):
        child = node.setdefault(part, {})
        if not isinstance(child, dict):
            where = ".".join(parents[: index + 1])
            raise ValueError(f"cannot set {dotted}: {where} is {child!r}, not a mapping")
        node = child
    node[leaf] = value


def apply_values(config: dict[str, Any], values: Mapping[str, Any]) -> dict[str, Any]:
    """A copy of a run config (:func:`agents.training.runs.run_config`) with sampled values set.

    :param values: setting values by parameter key (``env.`` keys go into ``env_kwargs``)
    """
    result = copy.deepcopy(config)
    algo = result.get("algo", "ppo")
    for key, value in values.items():
        if key.startswith(ENV_PREFIX):
            set_dotted(result.setdefault("env_kwargs", {}), key.removeprefix(ENV_PREFIX), value)
        else:
            set_dotted(result[algo], key, value)
    if algo == "ppo":
        # PPO splits each rollout of n_steps x n_envs steps into minibatches.
        rollout = result["ppo"].get("n_steps", 2048) * result["n_envs"]
        if result["ppo"].get("batch_size", 64) > rollout:
            result["ppo"]["batch_size"] = rollout
    return result


def suggest_config(trial: Any, config: dict[str, Any], space: list[Parameter]) -> dict[str, Any]:
    """The run config of ``trial``: ``config`` with every parameter of ``space`` sampled."""
    return apply_values(config, {parameter.key: parameter.suggest(trial) for parameter in space})

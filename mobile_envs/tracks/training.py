"""The training mix: random paths three times in four, random mazes the fourth, which the
``mobile_envs/<Model>-Random-v0`` ids train on with noisy starts; the same mix with paths
that may end soon after a corner (``training_short_ends``); and one with mazes half of the
draws (``training_half_mazes``)."""

from __future__ import annotations

from mobile_envs.tracks.catalogue import path_set, register_path_set
from mobile_envs.tracks.sets import MixedPathSet, PathSet

#: The share of random mazes in the default training mix.
_MAZE_WEIGHT = 0.25


def _with_random_mazes(random_paths: str, maze_weight: float, name: str) -> PathSet:
    """The path set ``random_paths`` (weight ``1 - maze_weight``) mixed with random mazes."""
    return MixedPathSet(
        [path_set(random_paths), path_set("random_maze")],
        [1.0 - maze_weight, maze_weight],
        name=name,
    )


def training_set() -> PathSet:
    """Random paths (weight 0.75) and random mazes (0.25), with both their reflectors: the
    open area's stand outside the mazes' outer walls, which hide them; on the random paths
    the maze posts stand in the open as poles."""
    return _with_random_mazes("random", _MAZE_WEIGHT, "training")


def training_short_ends_set() -> PathSet:
    """:func:`training_set` with ``random_short_ends`` for the random paths: the same draws,
    but polylines may end as soon as 0.5 m after their last corner, as the course's Segments
    does (0.79 m after a 96 degree corner)."""
    return _with_random_mazes("random_short_ends", _MAZE_WEIGHT, "training_short_ends")


register_path_set(
    "training",
    training_set,
    env_id="Random",
    env_kwargs={"start_noise": (0.2, 0.3)},
    env_localizations=(),
)
register_path_set("training_short_ends", training_short_ends_set)


def training_half_mazes_set() -> PathSet:
    """:func:`training_set` with random mazes half of the draws instead of a quarter: more
    of the tight corners the canonical maze tests (a variant of the bicycle's recipe,
    docs/training.md, "What did not work")."""
    return _with_random_mazes("random", 0.5, "training_half_mazes")


register_path_set("training_half_mazes", training_half_mazes_set)

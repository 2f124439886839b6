"""The training mix: random paths three times in four, random mazes the fourth, which the
``mobile_envs/<Model>-Random-v0`` ids train on with noisy starts."""

from __future__ import annotations

from mobile_envs.tracks.catalogue import path_set, register_path_set
from mobile_envs.tracks.sets import MixedPathSet, PathSet


def training_set() -> PathSet:
    """Random paths (weight 0.75) and random mazes (0.25), with both their reflectors: the
    open area's stand outside the mazes' outer walls, which hide them; on the random paths
    the maze posts stand in the open as poles."""
    return MixedPathSet(
        [path_set("random"), path_set("random_maze")], [0.75, 0.25], name="training"
    )


register_path_set(
    "training",
    training_set,
    env_id="Random",
    env_kwargs={"start_noise": (0.2, 0.3)},
    env_localizations=(),
)

"""Random paths in the course's area: lines and arcs drawn from each robot's generator
(:func:`mobile_envs.world.paths.random_path`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mobile_envs.tracks.catalogue import register_path_set
from mobile_envs.tracks.course import OPEN_AREA_REFLECTORS
from mobile_envs.tracks.sets import GeneratedPathSet, PathSet, Track
from mobile_envs.world.paths import random_path, random_paths_from_streams


def random_track(rng: np.random.Generator) -> Track:
    """A random path in open space (a module-level function, so the set pickles)."""
    return Track(random_path(rng))


def random_tracks_from_streams(streams: NDArray[np.uint64]) -> list[Track]:
    """:func:`random_track` of each generator whose stream is a row of ``streams``, the
    paths drawn in one call."""
    return [Track(path) for path in random_paths_from_streams(streams)]


def random_set() -> PathSet:
    """Random paths, drawn within the course's 0-13 m area and its reflectors."""
    return GeneratedPathSet(
        "random", random_track, random_tracks_from_streams, OPEN_AREA_REFLECTORS
    )


register_path_set("random", random_set)

"""Random paths in the course's area: lines and arcs drawn from each robot's generator
(:func:`mobile_envs.world.paths.random_path`), and the same with polylines that may end soon
after a corner (``random_short_ends``)."""

from __future__ import annotations

from functools import partial

import numpy as np
from numpy.typing import NDArray

from mobile_envs.tracks.catalogue import register_path_set
from mobile_envs.tracks.course import OPEN_AREA_REFLECTORS
from mobile_envs.tracks.sets import GeneratedPathSet, PathSet, Track
from mobile_envs.world.paths import SHORTEST_LAST_LEG, random_path, random_paths_from_streams

#: The shortest last leg of ``random_short_ends``'s polylines (m): the course's Segments ends
#: 0.79 m after a 96 degree corner, which no default random path does (their legs are 1 m or
#: more).
SHORT_END_LAST_LEG = 0.5


def random_track(rng: np.random.Generator, shortest_last_leg: float = SHORTEST_LAST_LEG) -> Track:
    """A random path in open space (a module-level function, so the set pickles)."""
    return Track(random_path(rng, shortest_last_leg))


def random_tracks_from_streams(
    streams: NDArray[np.uint64], shortest_last_leg: float = SHORTEST_LAST_LEG
) -> list[Track]:
    """:func:`random_track` of each generator whose stream is a row of ``streams``, the
    paths drawn in one call."""
    return [Track(path) for path in random_paths_from_streams(streams, shortest_last_leg)]


def random_set() -> PathSet:
    """Random paths, drawn within the course's 0-13 m area and its reflectors."""
    return GeneratedPathSet(
        "random", random_track, random_tracks_from_streams, OPEN_AREA_REFLECTORS
    )


def random_short_ends_set() -> PathSet:
    """Random paths whose polylines' last legs are cut to as little as
    :data:`SHORT_END_LAST_LEG`: the same draws as ``random``, so most paths are ``random``'s
    bit for bit; a polyline whose last leg ``random`` lengthens to 1 m (the walk ran out of
    length) ends shorter here."""
    return GeneratedPathSet(
        "random_short_ends",
        partial(random_track, shortest_last_leg=SHORT_END_LAST_LEG),
        partial(random_tracks_from_streams, shortest_last_leg=SHORT_END_LAST_LEG),
        OPEN_AREA_REFLECTORS,
    )


register_path_set("random", random_set)
register_path_set("random_short_ends", random_short_ends_set)

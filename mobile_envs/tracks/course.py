"""The course's path sets: its segments, its sharp segments, each of its three straight lines
and the three lines together, with the reflector layout of the course's area."""

from __future__ import annotations

from functools import partial

import numpy as np

from mobile_envs.tracks.catalogue import register_path_set
from mobile_envs.tracks.sets import FixedPathSet, PathSet, Track
from mobile_envs.world.paths import LINE_NAMES, course_path

#: The course's area (paths within 0-13 m on both axes): six reflectors on the walls of a
#: 16 m square room around it, placed by a search for the smallest worst first-order error.
#: From anywhere in the 13 m square the best triple fixes the position within 1.2 mm of
#: 65535-count quantization (0.8 mm in the median) and the heading within 1.6 counts.
#: (A square's four corners are concyclic: reflectors only there would leave a critical
#: circle through the whole area.)
OPEN_AREA_REFLECTORS = np.array(
    [[0.0, -1.5], [8.0, -1.5], [14.5, 0.0], [14.5, 14.5], [0.0, 14.5], [-1.5, 6.5]]
)
OPEN_AREA_REFLECTORS.flags.writeable = False


def course_set(name: str, path_names: tuple[str, ...]) -> PathSet:
    """The course's paths ``path_names`` as the set ``name``, in the course's area."""
    tracks = [Track(course_path(path_name)) for path_name in path_names]
    return FixedPathSet(name, tracks, OPEN_AREA_REFLECTORS)


def _register(name: str, path_names: tuple[str, ...], env_id: str | None = None) -> None:
    """Register the course set ``name``; one with an ``env_id`` is in the comparison."""
    register_path_set(
        name,
        partial(course_set, name, path_names),
        env_id=env_id,
        env_kwargs={"start_noise": 0.0},
        compared=env_id is not None,
    )


_register("segments", ("segments",), "Segments")
_register("sharp_segments", ("sharp_segments",), "SharpSegments")
for _line in LINE_NAMES:
    _register(_line, (_line,))
_register("lines", LINE_NAMES, "Lines")

"""Tracks and the path-set catalogue: what an environment draws a path (and a maze) from.

Each module here defines path sets and registers them (:func:`register_path_set`); importing
the package imports them all, so a new set is a new module.
"""

from mobile_envs.catalogue import import_package_modules
from mobile_envs.tracks.catalogue import (
    PATH_SETS,
    PathSetEntry,
    path_set,
    path_set_names,
    register_path_set,
)
from mobile_envs.tracks.mazes import (
    CANONICAL_MAZE_SEED,
    RANDOM_MAZE_CELL_SIZE,
    RANDOM_MAZE_SIZE,
    random_maze,
    random_mazes_from_streams,
    the_maze,
)
from mobile_envs.tracks.sets import FixedPathSet, GeneratedPathSet, MixedPathSet, PathSet, Track

import_package_modules(__name__, __path__)

__all__ = [
    "CANONICAL_MAZE_SEED",
    "PATH_SETS",
    "RANDOM_MAZE_CELL_SIZE",
    "RANDOM_MAZE_SIZE",
    "FixedPathSet",
    "GeneratedPathSet",
    "MixedPathSet",
    "PathSet",
    "PathSetEntry",
    "Track",
    "path_set",
    "path_set_names",
    "random_maze",
    "random_mazes_from_streams",
    "register_path_set",
    "the_maze",
]

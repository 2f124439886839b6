"""Tracks and the path-set catalogue: what an environment draws a path (and a maze) from."""

from mobile_envs.tracks.sets import (
    CANONICAL_MAZE_SEED,
    RANDOM_MAZE_CELL_SIZE,
    RANDOM_MAZE_SIZE,
    FixedPathSet,
    GeneratedPathSet,
    MixedPathSet,
    PathSet,
    Track,
    path_set,
    path_set_names,
    random_maze,
    random_mazes_from_streams,
    the_maze,
)

__all__ = [
    "CANONICAL_MAZE_SEED",
    "RANDOM_MAZE_CELL_SIZE",
    "RANDOM_MAZE_SIZE",
    "FixedPathSet",
    "GeneratedPathSet",
    "MixedPathSet",
    "PathSet",
    "Track",
    "path_set",
    "path_set_names",
    "random_maze",
    "random_mazes_from_streams",
    "the_maze",
]

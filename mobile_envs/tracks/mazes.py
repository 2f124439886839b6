"""Maze tracks: the canonical maze, random mazes, and a reflector on every post of their
grid."""

from __future__ import annotations

from functools import cache

import numpy as np
from numpy.typing import NDArray

from mobile_envs._kernels.pcg64 import store, stream_of
from mobile_envs.tracks.catalogue import register_path_set
from mobile_envs.tracks.sets import FixedPathSet, GeneratedPathSet, PathSet, Track
from mobile_envs.world.maze import Maze, draw_maze_route, draw_maze_routes

#: The seed the canonical maze (:func:`the_maze`) is carved with.
CANONICAL_MAZE_SEED = 0
#: Random mazes (:func:`random_maze`): cells per side, and the side of a cell (m).
RANDOM_MAZE_SIZE = 8
RANDOM_MAZE_CELL_SIZE = 1.5


@cache
def the_maze() -> Track:
    """The canonical maze track, the same at every call.

    An 8 x 8 maze of 1.5 m cells carved with seed :data:`CANONICAL_MAZE_SEED`, and its shortest
    route from cell (0, 0) to the opposite corner, cell (7, 7): 34 legs, 51 m.
    """
    maze = Maze(rows=8, cols=8, cell_size=1.5, seed=CANONICAL_MAZE_SEED)
    return Track(maze.route((0, 0), (maze.rows - 1, maze.cols - 1)), maze)


def random_maze(rng: np.random.Generator) -> Track:
    """A new 8 x 8 maze of 1.5 m cells and the route between two cells far apart in it.

    The maze's seed, the start cell and the goal cell come from ``rng``; the goal is drawn among
    the cells at least half as far from the start, along the maze, as the farthest cell. The
    maze is ``Maze(seed=seed)``; the draws run in compiled code
    (:func:`~mobile_envs.world.maze.draw_maze_route`).

    :param rng: the random generator; the same state gives the same track.
    """
    stream = stream_of(rng)
    seed, vertical, horizontal, cells = draw_maze_route(stream, RANDOM_MAZE_SIZE, RANDOM_MAZE_SIZE)
    store(rng, stream)
    maze = _random_maze_of(seed, vertical, horizontal)
    return Track(maze._path_through(cells, "random_maze"), maze)


def _random_maze_of(seed: int, vertical: NDArray[np.bool_], horizontal: NDArray[np.bool_]) -> Maze:
    """The random maze carved from ``seed`` into these walls (see :func:`random_maze`)."""
    return Maze._carved(
        RANDOM_MAZE_SIZE,
        RANDOM_MAZE_SIZE,
        RANDOM_MAZE_CELL_SIZE,
        np.zeros(2),
        seed,
        vertical,
        horizontal,
    )


def random_mazes_from_streams(streams: NDArray[np.uint64]) -> list[Track]:
    """:func:`random_maze` of each generator whose stream (:mod:`mobile_envs._kernels.pcg64`) is a
    row of ``streams`` (k, STREAM_WORDS), which advance in place (the caller stores them
    back): the mazes drawn in one compiled call and their routes' geometry in another, the
    same tracks bit for bit."""
    seeds, verticals, horizontals, cells, offsets = draw_maze_routes(
        streams, RANDOM_MAZE_SIZE, RANDOM_MAZE_SIZE
    )
    mazes = [
        _random_maze_of(seed, vertical, horizontal)
        for seed, vertical, horizontal in zip(seeds.tolist(), verticals, horizontals, strict=True)
    ]
    paths = Maze._paths_through(mazes, cells, offsets, "random_maze")
    return [Track(path, maze) for path, maze in zip(paths, mazes, strict=True)]


def maze_reflectors(maze: Maze) -> NDArray[np.float64]:
    """A reflector on every post of ``maze``: every corner of its grid of cells.

    From anywhere inside a cell its four corner posts are in sight (walls that end at a post
    do not hide it), and the posts of the cells open to it too, so no point of a maze lacks
    three reflectors; on the canonical maze's route at least 8 are in view. Any three corners
    of one cell lie on the cell's circumscribed circle, but the open cells' posts give
    triples whose circles lie elsewhere.

    :return: ((rows + 1) (cols + 1), 2) positions (m)
    """
    return grid_posts(maze.rows, maze.cols, maze.cell_size, maze.origin)


def grid_posts(
    rows: int, cols: int, cell_size: float, origin: tuple[float, float] | NDArray[np.float64]
) -> NDArray[np.float64]:
    """Every corner of a grid of ``rows`` x ``cols`` square cells of side ``cell_size`` (m)
    from ``origin``, the lower-left corner, column by column.

    :return: ((rows + 1) (cols + 1), 2) positions (m)
    """
    lines_x = origin[0] + cell_size * np.arange(cols + 1)
    lines_y = origin[1] + cell_size * np.arange(rows + 1)
    grid_x, grid_y = np.meshgrid(lines_x, lines_y, indexing="ij")
    return np.column_stack((grid_x.ravel(), grid_y.ravel()))


def maze_set() -> PathSet:
    """The canonical maze, with a reflector on each of its 81 posts."""
    track = the_maze()
    assert track.maze is not None, "the canonical track is a maze"
    return FixedPathSet("maze", [track], maze_reflectors(track.maze))


def random_maze_set() -> PathSet:
    """Random mazes, with a reflector on each post of the 8 x 8 grid of 1.5 m cells they
    share with the canonical maze."""
    return GeneratedPathSet(
        "random_maze",
        random_maze,
        random_mazes_from_streams,
        grid_posts(RANDOM_MAZE_SIZE, RANDOM_MAZE_SIZE, RANDOM_MAZE_CELL_SIZE, (0.0, 0.0)),
    )


register_path_set("maze", maze_set, env_id="Maze", env_kwargs={"start_noise": 0.0}, compared=True)
register_path_set("random_maze", random_maze_set)

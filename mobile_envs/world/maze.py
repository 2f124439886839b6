"""Perfect grid mazes: generation, shortest routes, walls, collisions and range sensing.

Seed 000's robot won a maze competition by planning shortest routes in a known maze. These mazes
set a path follower the same task: follow the shortest route through the cell centres without
touching the walls, optionally sensing the walls with range finders.

Cell (row, col) covers x in ``origin_x + [col, col + 1] * cell_size`` and y in
``origin_y + [row, row + 1] * cell_size``: rows grow along +y. Walls are zero-thickness segments
on the grid lines, kept in two boolean grids: ``vertical[row, line]`` is the wall on vertical grid
line ``line`` (0 to cols) beside row ``row``, ``horizontal[line, col]`` the wall on horizontal
grid line ``line`` (0 to rows) beside column ``col``. The outer boundary is all wall.

Collisions and ranges are computed robot by robot in numba-compiled kernels that read these
grids (``_disc_touches_wall``, ``_ray_distance``); :meth:`Maze.sense` runs both for a batch of
robots in one call, the environments' per-step hot path. The canonical maze and random mazes,
as tracks to follow, are in :mod:`mobile_envs.tracks.sets`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numba import njit, prange
from numpy.typing import ArrayLike, NDArray

from mobile_envs._kernels.array_copies import copy_rows
from mobile_envs._kernels.pcg64 import (
    Stream,
    draw_integer,
    draw_seed,
    seeded_stream,
    store,
    stream_of,
)
from mobile_envs.world.paths import DUPLICATE_TOLERANCE, MAX_COORDINATE, Path

Cell = tuple[int, int]


def _read_only(array: NDArray) -> NDArray:
    array.flags.writeable = False
    return array


class Maze:
    """A perfect maze on a grid of square cells.

    Every cell is reachable from every other by exactly one route. Immutable.

    :param rows: number of cells along y.
    :param cols: number of cells along x.
    :param cell_size: side of a cell (m).
    :param seed: an int seed, or a numpy Generator to carve with.
    :param origin: (x, y) of the maze's lower-left corner (m).
    :raises ValueError: for non-positive sizes, a negative or non-integer seed, a bad origin,
        or a maze reaching farther than :data:`~mobile_envs.world.paths.MAX_COORDINATE` from (0, 0).
    """

    def __init__(
        self,
        rows: int = 8,
        cols: int = 8,
        cell_size: float = 1.5,
        seed: int | np.random.Generator = 0,
        origin: ArrayLike = (0.0, 0.0),
    ) -> None:
        for label, value in (("rows", rows), ("cols", cols)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{label} must be a positive integer, got {value!r}")
        try:
            cell_size = float(cell_size)
        except (TypeError, ValueError):
            raise ValueError(f"cell_size must be a number, got {cell_size!r}") from None
        if not (math.isfinite(cell_size) and cell_size > 0):
            raise ValueError(f"cell_size must be finite and > 0, got {cell_size}")
        origin = np.array(origin, dtype=np.float64)
        if origin.shape != (2,) or not np.all(np.isfinite(origin)):
            raise ValueError(f"origin must be a finite (x, y) pair, got {origin.tolist()}")
        far_corner = origin + np.array([cols, rows]) * cell_size
        if np.abs(np.concatenate((origin, far_corner))).max() > MAX_COORDINATE:
            raise ValueError(
                f"origin and cell_size must keep the maze within {MAX_COORDINATE:g} m of (0, 0) "
                f"on each axis, got origin {origin.tolist()} and cell_size {cell_size:g}"
            )
        if isinstance(seed, np.random.Generator):
            stream: Stream = stream_of(seed)
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0:
            stream = seeded_stream(int(seed))
        else:
            raise ValueError(f"seed must be an int >= 0 or a numpy Generator, got {seed!r}")
        vertical, horizontal = carve_walls(int(rows), int(cols), stream)
        if isinstance(seed, np.random.Generator):
            store(seed, stream)
        self._set_up(
            int(rows),
            int(cols),
            cell_size,
            origin,
            None if isinstance(seed, np.random.Generator) else int(seed),
            vertical,
            horizontal,
        )

    def _set_up(
        self,
        rows: int,
        cols: int,
        cell_size: float,
        origin: NDArray[np.float64],
        seed: int | None,
        vertical: NDArray[np.bool_],
        horizontal: NDArray[np.bool_],
    ) -> None:
        self._rows, self._cols = rows, cols
        self._cell_size = cell_size
        self._origin = _read_only(origin)
        self._seed = seed
        self._vertical = _read_only(vertical)
        self._horizontal = _read_only(horizontal)
        # Python floats: the sensing kernels take them without a lookup per call.
        self._origin_x, self._origin_y = float(origin[0]), float(origin[1])
        # Built on first use: random mazes are made at every reset and rarely drawn.
        self._walls: NDArray[np.float64] | None = None

    @classmethod
    def _carved(
        cls,
        rows: int,
        cols: int,
        cell_size: float,
        origin: NDArray[np.float64],
        seed: int,
        vertical: NDArray[np.bool_],
        horizontal: NDArray[np.bool_],
    ) -> Maze:
        """A maze from walls :func:`carve_walls` made with ``seed``, its settings valid
        (those of a validated maze): what ``Maze(rows, cols, cell_size, seed, origin)`` makes,
        without checking again."""
        maze = cls.__new__(cls)
        maze._set_up(rows, cols, cell_size, origin, seed, vertical, horizontal)
        return maze

    def __setstate__(self, state: dict[str, Any]) -> None:
        # Pickled and deep-copied arrays come back writeable: a copy must stay immutable.
        self.__dict__.update(state)
        for array in (self._origin, self._vertical, self._horizontal, self._walls):
            if array is not None:
                _read_only(array)

    @property
    def rows(self) -> int:
        """Number of cells along y."""
        return self._rows

    @property
    def cols(self) -> int:
        """Number of cells along x."""
        return self._cols

    @property
    def cell_size(self) -> float:
        """Side of a cell (m)."""
        return self._cell_size

    @property
    def origin(self) -> NDArray[np.float64]:
        """(2,) the maze's lower-left corner (m)."""
        return self._origin

    @property
    def seed(self) -> int | None:
        """The int seed the maze was carved with; None when carved with a Generator."""
        return self._seed

    @property
    def vertical_walls(self) -> NDArray[np.bool_]:
        """(rows, cols + 1) whether each vertical grid line holds a wall beside each row."""
        return self._vertical

    @property
    def horizontal_walls(self) -> NDArray[np.bool_]:
        """(rows + 1, cols) whether each horizontal grid line holds a wall beside each col."""
        return self._horizontal

    @property
    def bounds(self) -> NDArray[np.float64]:
        """(2, 2) lower-left and upper-right corners of the maze (m)."""
        size = np.array([self._cols, self._rows]) * self._cell_size
        return _read_only(np.stack((self._origin, self._origin + size)))

    @property
    def walls(self) -> NDArray[np.float64]:
        """(W, 2, 2) wall segments (start and end points, m), the outer boundary included."""
        if self._walls is None:
            self._walls = _read_only(self._wall_segments())
        return self._walls

    def _wall_segments(self) -> NDArray[np.float64]:
        cell = self._cell_size
        origin_x, origin_y = self._origin
        rows, lines = np.nonzero(self._vertical)
        x = origin_x + lines * cell
        y = origin_y + rows * cell
        vertical = np.stack((np.column_stack((x, y)), np.column_stack((x, y + cell))), axis=1)
        lines, cols = np.nonzero(self._horizontal)
        x = origin_x + cols * cell
        y = origin_y + lines * cell
        horizontal = np.stack((np.column_stack((x, y)), np.column_stack((x + cell, y))), axis=1)
        return np.concatenate((vertical, horizontal))

    def cell_center(self, cell: Cell) -> NDArray[np.float64]:
        """(2,) centre (m) of cell (row, col)."""
        row, col = self._check_cell(cell)
        return self._origin + (np.array([col, row]) + 0.5) * self._cell_size

    def open_between(self, a: Cell, b: Cell) -> bool:
        """Whether a robot can pass directly between two cells.

        True when cells a and b are neighbours and the wall between them is open; False for
        cells that are not neighbours.
        """
        (row_a, col_a), (row_b, col_b) = self._check_cell(a), self._check_cell(b)
        if row_a == row_b and abs(col_a - col_b) == 1:
            return not self._vertical[row_a, max(col_a, col_b)]
        if col_a == col_b and abs(row_a - row_b) == 1:
            return not self._horizontal[max(row_a, row_b), col_a]
        return False

    def distances_from(self, cell: Cell) -> NDArray[np.int64]:
        """(rows, cols) number of cell-to-cell moves on the route from ``cell`` to each cell."""
        row, col = self._check_cell(cell)
        return breadth_first(self._vertical, self._horizontal, row, col)[0]

    def route(self, start_cell: Cell, goal_cell: Cell, name: str = "maze") -> Path:
        """The shortest route between two cells, through the centres of the cells it crosses.

        Found by breadth-first search; in a perfect maze it is the only route. The path starts
        heading along its first leg.

        :param start_cell: (row, col) where the route starts.
        :param goal_cell: (row, col) where it ends; must differ from the start.
        :param name: the path's name.
        """
        start, goal = self._check_cell(start_cell), self._check_cell(goal_cell)
        if start == goal:
            raise ValueError(f"start and goal cells must differ, both are {start}")
        return self._path_through(route_cells(self._vertical, self._horizontal, start, goal), name)

    def _path_through(self, cells: NDArray[np.int64], name: str) -> Path:
        """The path through the centres of (K, 2) cells (row, col), K >= 2, heading along its
        first leg."""
        centres = self._origin + (cells[:, ::-1] + 0.5) * self._cell_size
        start_heading = _first_leg_heading(centres)
        if self._cell_size < DUPLICATE_TOLERANCE:  # the path may drop centres, or be empty
            return Path(centres, name=name, start_heading=start_heading)
        # Centres of a validated maze, a cell apart: nothing for the constructor to check.
        return Path._generated(centres, name, start_heading)

    @classmethod
    def _paths_through(
        cls, mazes: Sequence[Maze], cells: NDArray[np.int64], offsets: NDArray[np.int64], name: str
    ) -> list[Path]:
        """:meth:`_path_through` of each maze ``mazes[k]`` and its cells
        ``cells[offsets[k]:offsets[k + 1]]``, the paths' geometry derived in one call; the
        mazes share one origin and one cell size of at least DUPLICATE_TOLERANCE."""
        first = mazes[0]
        centres = first._origin + (cells[:, ::-1] + 0.5) * first._cell_size
        headings = [_first_leg_heading(centres[start:]) for start in offsets[:-1].tolist()]
        return Path._generated_many(centres, offsets, name, headings)

    def collides(self, xy: ArrayLike, radius: float) -> NDArray[np.bool_] | bool:
        """Whether a robot disc of ``radius`` touches a wall, or its centre is outside the maze.

        Touching includes contact: a wall exactly ``radius`` away counts. Only the walls of the
        few cells the disc can reach are measured.

        :param xy: (N, 2) positions or (N, 3) poses (m); (2,) or (3,) for one robot.
        :param radius: disc radius (m), in [0, cell_size / 2).
        :return: (N,) booleans, or a bool for one robot.
        """
        if not 0 <= radius < self._cell_size / 2:
            raise ValueError(f"radius must lie in [0, {self._cell_size / 2}), got {radius}")
        xy = np.asarray(xy, dtype=np.float64)
        single = xy.ndim == 1
        positions = _check_rows_of(xy.reshape(1, -1) if single else xy, "xy", (2, 3))
        _check_finite_positions(positions)
        collides = np.empty(len(positions), dtype=bool)
        # With no rays the kernel reads neither a heading nor max_range.
        no_rays, no_ranges = np.empty(0), np.empty((len(positions), 0))
        self.sense(positions, radius, no_rays, 1.0, collides, no_ranges)
        return bool(collides[0]) if single else collides

    def ranges(self, pose: ArrayLike, angles: ArrayLike, max_range: float) -> NDArray[np.float64]:
        """Distance from each robot to the first wall along each ray, as range finders read it.

        Each ray walks the grid cell by cell (Amanatides & Woo's traversal) and stops at the first
        grid line it crosses on a wall. A robot exactly on a grid line belongs to the cell above
        or to the right of it: a ray leaving through that line reads 0 when the line holds a
        wall, a ray into the cell does not see it.

        :param pose: (N, 3) robot poses (x, y, heading), or (3,) for one robot.
        :param angles: (R,) ray directions relative to the heading (rad).
        :param max_range: the sensors' reach (m); a ray that meets no wall closer reads this.
        :return: (N, R) distances (m), or (R,) for one robot; 0 for a robot outside the maze.
        """
        if not (math.isfinite(max_range) and max_range > 0):
            raise ValueError(f"max_range must be finite and > 0, got {max_range}")
        pose = np.asarray(pose, dtype=np.float64)
        single = pose.ndim == 1
        poses = _check_rows_of(pose.reshape(1, -1) if single else pose, "pose", (3,))
        _check_finite_positions(poses)
        angles = np.asarray(angles, dtype=np.float64)
        if angles.ndim != 1 or not np.all(np.isfinite(angles)):
            raise ValueError(f"angles must be a 1-D array of finite angles, got {angles}")
        distances = np.empty((len(poses), len(angles)))
        self.sense(poses, 0.0, angles, max_range, np.empty(len(poses), dtype=bool), distances)
        return distances[0] if single else distances

    def sense(
        self,
        poses: NDArray[np.float64],
        radius: float,
        angles: NDArray[np.float64],
        max_range: float,
        collision_out: NDArray[np.bool_],
        ranges_out: NDArray[np.float64],
    ) -> None:
        """:meth:`collides` and :meth:`ranges` for N robots at once, into given arrays.

        The per-step hot path: one call into compiled code, no validation, no allocation. The
        results equal those of :meth:`collides` and :meth:`ranges` bit for bit; a robot whose
        x or y is not finite collides and reads 0.

        :param poses: (N, >= 2) float64 rows starting (x, y, heading); any strides, e.g. the
            first columns of a wider state array. The heading is read only when there are rays.
        :param radius: robot disc radius (m), >= 0.
        :param angles: (R,) float64 ray directions relative to the heading (rad).
        :param max_range: the sensors' reach (m), > 0.
        :param collision_out: (N,) bool, set to whether each robot touches a wall or is outside;
            empty (0,) when only the ranges are wanted.
        :param ranges_out: (N, R) float64, set to the distance along each ray to the first wall.
        """
        _sense(
            poses,
            float(radius),
            angles,
            float(max_range),
            self._vertical,
            self._horizontal,
            self._origin_x,
            self._origin_y,
            self._cell_size,
            collision_out,
            ranges_out,
        )

    def _check_cell(self, cell: Cell) -> Cell:
        try:
            row, col = cell
        except (TypeError, ValueError):
            raise ValueError(f"a cell is a (row, col) pair of ints, got {cell!r}") from None
        if not all(
            isinstance(index, (int, np.integer)) and not isinstance(index, bool)
            for index in (row, col)
        ):
            raise ValueError(f"a cell is a (row, col) pair of ints, got {cell!r}")
        if not (0 <= row < self._rows and 0 <= col < self._cols):
            raise ValueError(f"cell {cell!r} is outside the {self._rows} x {self._cols} maze")
        return int(row), int(col)

    def __repr__(self) -> str:
        return (
            f"Maze(rows={self._rows}, cols={self._cols}, cell_size={self._cell_size}, "
            f"seed={self._seed}, origin={tuple(self._origin.tolist())})"
        )


def _check_rows_of(array: NDArray[np.float64], label: str, widths: tuple[int, ...]) -> NDArray:
    if array.ndim != 2 or array.shape[1] not in widths:
        expected = " or ".join(f"(N, {width})" for width in widths)
        raise ValueError(f"{label} must have shape {expected}, got {array.shape}")
    return array


def _check_finite_positions(positions: NDArray[np.float64]) -> None:
    if not np.all(np.isfinite(positions[:, :2])):
        raise ValueError("positions must be finite")


# Compiled carving and search. Cells are (row, col); the moves, in the order the carving
# lists a cell's neighbours: +col, +row, -col, -row.
_ROW_STEPS = (0, 1, 0, -1)
_COL_STEPS = (1, 0, -1, 0)


@njit(cache=True)
def carve_walls(
    rows: int, cols: int, stream: Stream
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Wall grids of a perfect maze, carved by a randomized depth-first search.

    From cell (0, 0), the search moves to a neighbour it has not reached, drawn uniformly
    (``integers(count)``) among them in move order, knocking down the wall between; with no
    such neighbour it backs up. One wall falls per newly reached cell, so the open walls form
    a spanning tree of the grid: every cell is reachable by exactly one route. Depth-first
    carving makes long winding corridors.

    :param stream: the carving generator (:mod:`mobile_envs._kernels.pcg64`).
    :return: ``vertical`` (rows, cols + 1) and ``horizontal`` (rows + 1, cols).
    """
    vertical = np.ones((rows, cols + 1), dtype=np.bool_)
    horizontal = np.ones((rows + 1, cols), dtype=np.bool_)
    visited = np.zeros((rows, cols), dtype=np.bool_)
    stack = np.empty((rows * cols, 2), dtype=np.int64)
    candidates = np.empty((4, 2), dtype=np.int64)
    visited[0, 0] = True
    stack[0] = 0
    top = 0
    while top >= 0:
        row, col = stack[top, 0], stack[top, 1]
        count = 0
        for move in range(4):
            next_row, next_col = row + _ROW_STEPS[move], col + _COL_STEPS[move]
            if 0 <= next_row < rows and 0 <= next_col < cols and not visited[next_row, next_col]:
                candidates[count, 0], candidates[count, 1] = next_row, next_col
                count += 1
        if count == 0:
            top -= 1
            continue
        chosen = draw_integer(stream, count)
        next_row, next_col = candidates[chosen, 0], candidates[chosen, 1]
        if next_row == row:
            vertical[row, max(col, next_col)] = False
        else:
            horizontal[max(row, next_row), col] = False
        visited[next_row, next_col] = True
        top += 1
        stack[top, 0], stack[top, 1] = next_row, next_col
    return vertical, horizontal


@njit(cache=True)
def _open_towards(
    vertical: NDArray[np.bool_], horizontal: NDArray[np.bool_], row: int, col: int, move: int
) -> bool:
    """Whether the wall from cell (row, col) in direction ``move`` is open (the neighbour may
    lie outside: the boundary is all wall)."""
    if move == 0:
        return not vertical[row, col + 1]
    if move == 1:
        return not horizontal[row + 1, col]
    if move == 2:
        return not vertical[row, col]
    return not horizontal[row, col]


@njit(cache=True)
def breadth_first(
    vertical: NDArray[np.bool_], horizontal: NDArray[np.bool_], start_row: int, start_col: int
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Route lengths in cells from the start cell to every cell, and each cell's predecessor
    on its route (as ``row * cols + col``; -1 for the start and unreached cells)."""
    rows, cols = vertical.shape[0], horizontal.shape[1]
    distance = np.full((rows, cols), -1, dtype=np.int64)
    previous = np.full(rows * cols, -1, dtype=np.int64)
    queue = np.empty(rows * cols, dtype=np.int64)
    distance[start_row, start_col] = 0
    queue[0] = start_row * cols + start_col
    head, tail = 0, 1
    while head < tail:
        cell = queue[head]
        head += 1
        row, col = cell // cols, cell % cols
        for move in range(4):
            if not _open_towards(vertical, horizontal, row, col, move):
                continue
            next_row, next_col = row + _ROW_STEPS[move], col + _COL_STEPS[move]
            if distance[next_row, next_col] < 0:
                distance[next_row, next_col] = distance[row, col] + 1
                previous[next_row * cols + next_col] = cell
                queue[tail] = next_row * cols + next_col
                tail += 1
    return distance, previous


def _first_leg_heading(centres: NDArray[np.float64]) -> float:
    """The heading (rad) from the first centre to the second, by ``math.atan2``."""
    first_leg = centres[1] - centres[0]
    return math.atan2(first_leg[1], first_leg[0])


@njit(cache=True)
def _route_from(previous: NDArray[np.int64], cols: int, goal: int) -> NDArray[np.int64]:
    """(K, 2) the cells (row, col) from the start to cell ``goal`` (``row * cols + col``),
    read back along the predecessors."""
    count, cell = 1, goal
    while previous[cell] >= 0:
        cell = previous[cell]
        count += 1
    cells = np.empty((count, 2), dtype=np.int64)
    cell = goal
    for index in range(count - 1, -1, -1):
        cells[index, 0], cells[index, 1] = cell // cols, cell % cols
        cell = previous[cell]
    return cells


@njit(cache=True)
def route_cells(
    vertical: NDArray[np.bool_],
    horizontal: NDArray[np.bool_],
    start: tuple[int, int],
    goal: tuple[int, int],
) -> NDArray[np.int64]:
    """(K, 2) the cells (row, col) of the shortest route from ``start`` to ``goal``, both
    included, found by breadth-first search."""
    cols = horizontal.shape[1]
    _, previous = breadth_first(vertical, horizontal, start[0], start[1])
    return _route_from(previous, cols, goal[0] * cols + goal[1])


@njit(cache=True)
def draw_maze_route(
    stream: Stream, rows: int, cols: int
) -> tuple[int, NDArray[np.bool_], NDArray[np.bool_], NDArray[np.int64]]:
    """A maze drawn from ``stream`` and a route far across it (:func:`~mobile_envs.tracks.sets.
    random_maze`'s draws, in order): the maze's seed (``integers(2**63)``), carved as
    ``Maze(seed=seed)`` carves; the start row and column (``integers(rows)``,
    ``integers(cols)``); the goal among the cells at least half as far along the maze as the
    farthest, in row-major order (``integers(count)``).

    :return: the seed, the wall grids and (K, 2) the route's cells (row, col).
    """
    seed = draw_seed(stream)
    vertical, horizontal = carve_walls(rows, cols, seeded_stream(seed))
    start_row = draw_integer(stream, rows)
    start_col = draw_integer(stream, cols)
    distance, previous = breadth_first(vertical, horizontal, start_row, start_col)
    half_farthest = distance.max() / 2
    far_cells = np.flatnonzero(distance.ravel() >= half_farthest)
    goal = far_cells[draw_integer(stream, far_cells.size)]
    return seed, vertical, horizontal, _route_from(previous, cols, goal)


@njit(cache=True)
def draw_maze_routes(
    streams: NDArray[np.uint64], rows: int, cols: int
) -> tuple[
    NDArray[np.int64], NDArray[np.bool_], NDArray[np.bool_], NDArray[np.int64], NDArray[np.int64]
]:
    """:func:`draw_maze_route` from each row of ``streams`` (k, STREAM_WORDS), in one call.

    :return: the seeds (k,), the wall grids (k, rows, cols + 1) and (k, rows + 1, cols), the
        routes' cells end to end and where each route starts (k + 1 offsets).
    """
    count = streams.shape[0]
    seeds = np.empty(count, dtype=np.int64)
    verticals = np.empty((count, rows, cols + 1), dtype=np.bool_)
    horizontals = np.empty((count, rows + 1, cols), dtype=np.bool_)
    offsets = np.zeros(count + 1, dtype=np.int64)
    cells = np.empty((count * rows * cols, 2), dtype=np.int64)  # a route visits a cell once
    for k in range(count):
        seeds[k], vertical, horizontal, route = draw_maze_route(streams[k], rows, cols)
        copy_rows(vertical, verticals[k], 0)
        copy_rows(horizontal, horizontals[k], 0)
        copy_rows(route, cells, offsets[k])
        offsets[k + 1] = offsets[k] + route.shape[0]
    return seeds, verticals, horizontals, cells[: offsets[count]], offsets


# Compiled sensing kernels. Grid coordinates measure positions in cells from the maze's origin:
# cell (row, col) spans grid x in [col, col + 1] and grid y in [row, row + 1].


@njit(cache=True)
def _inside(grid_x: float, grid_y: float, rows: int, cols: int) -> bool:
    """Whether a point lies in the maze: the lower and left edges belong to it, the others not."""
    return 0.0 <= grid_x < cols and 0.0 <= grid_y < rows


@njit(cache=True)
def _gap(value: float, low: float, high: float) -> float:
    """Distance from ``value`` to the interval [low, high]; 0 within it."""
    return max(low - value, value - high, 0.0)


#: Grid cells the wall search of a collision reaches beyond the robot's radius, against the
#: rounding of grid coordinates (see :func:`_touches_walls_on_lines`).
_REACH_SLACK = 1e-9


@njit(cache=True)
def _touches_walls_on_lines(
    across: float,
    along: float,
    radius: float,
    reach: float,
    grid_across: float,
    grid_along: float,
    walls: NDArray[np.bool_],
    segments: int,
    lines: int,
    origin_across: float,
    origin_along: float,
    cell_size: float,
) -> bool:
    """Whether a disc touches one of the walls on a family of parallel grid lines.

    ``walls[segment, line]`` is the wall on grid line ``line``, the lines being crossed by the
    ``across`` axis, between grid points ``segment`` and ``segment + 1`` along them. The lines and
    segments searched are those within ``reach`` (the radius in cells) of the centre, and
    :data:`_REACH_SLACK` cells more against rounding; each wall's exact distance decides.
    ``segments`` and ``lines`` are the maze's share of ``walls`` (a padded grid may hold more).

    Only those walls can decide: ``hypot(gap_across, gap_along)`` is at least each of its
    arguments, so a wall on a line farther than the radius across, or on a segment ending
    farther than the radius along, is never within it. The grid coordinates and the gaps
    differ by rounding (about 1e-15 cells) far below the slack.
    """
    first_line = max(math.ceil(grid_across - reach - _REACH_SLACK), 0)
    last_line = min(math.floor(grid_across + reach + _REACH_SLACK), lines - 1)
    # Segment k spans [k, k + 1] along the lines: one starting a cell before the reach can
    # still end within it.
    first_segment = max(math.ceil(grid_along - reach - 1.0 - _REACH_SLACK), 0)
    last_segment = min(math.floor(grid_along + reach + _REACH_SLACK), segments - 1)
    for segment in range(first_segment, last_segment + 1):
        start = origin_along + segment * cell_size
        gap_along = _gap(along, start, start + cell_size)
        for line in range(first_line, last_line + 1):
            gap_across = across - (origin_across + line * cell_size)
            if walls[segment, line] and math.hypot(gap_across, gap_along) <= radius:
                return True
    return False


@njit(cache=True)
def _disc_touches_wall(
    x: float,
    y: float,
    radius: float,
    vertical: NDArray[np.bool_],
    horizontal: NDArray[np.bool_],
    rows: int,
    cols: int,
    origin_x: float,
    origin_y: float,
    cell_size: float,
) -> bool:
    """Whether the disc of ``radius`` around (x, y) touches a wall (at a distance <= radius), or
    its centre lies outside the maze of ``rows`` x ``cols`` cells."""
    grid_x = (x - origin_x) / cell_size
    grid_y = (y - origin_y) / cell_size
    if not _inside(grid_x, grid_y, rows, cols):
        return True
    reach = radius / cell_size
    # Horizontal walls are vertical ones with x and y swapped: transposed, the same search.
    return _touches_walls_on_lines(
        x, y, radius, reach, grid_x, grid_y, vertical, rows, cols + 1, origin_x, origin_y,
        cell_size,
    ) or _touches_walls_on_lines(
        y, x, radius, reach, grid_y, grid_x, horizontal.T, cols, rows + 1, origin_y, origin_x,
        cell_size,
    )  # fmt: skip


@njit(cache=True)
def _first_crossing(offset: float, direction: float, cell_size: float) -> float:
    """Ray length from a point ``offset`` into its cell to the cell's next grid line ahead, along
    one axis of the unit ``direction``; inf for a ray parallel to the lines."""
    if direction == 0.0:
        return math.inf
    if direction > 0.0:
        return abs(cell_size - offset) / abs(direction)
    return abs(offset) / abs(direction)


@njit(cache=True)
def _crossing_spacing(direction: float, cell_size: float) -> float:
    """Ray length between successive grid lines along one axis; inf for a parallel ray."""
    return math.inf if direction == 0.0 else cell_size / abs(direction)


@njit(cache=True)
def _locate(
    x: float,
    y: float,
    rows: int,
    cols: int,
    origin_x: float,
    origin_y: float,
    cell_size: float,
) -> tuple[bool, int, int, float, float]:
    """Whether (x, y) lies in the maze and, if so, its cell (row, col) and its offsets (m) from
    that cell's lower-left corner; zeros for a point outside."""
    grid_x = (x - origin_x) / cell_size
    grid_y = (y - origin_y) / cell_size
    if not _inside(grid_x, grid_y, rows, cols):
        return False, 0, 0, 0.0, 0.0
    col, row = math.floor(grid_x), math.floor(grid_y)
    return True, row, col, x - origin_x - col * cell_size, y - origin_y - row * cell_size


@njit(cache=True)
def _ray_distance(
    row: int,
    col: int,
    offset_x: float,
    offset_y: float,
    direction: float,
    max_range: float,
    vertical: NDArray[np.bool_],
    horizontal: NDArray[np.bool_],
    rows: int,
    cols: int,
    cell_size: float,
) -> float:
    """Distance from a point (``offset_x``, ``offset_y``) into cell (row, col), along the absolute
    ``direction`` (rad), to the first wall; ``max_range`` when no wall is that close.

    Amanatides & Woo's grid traversal: from the start cell, step across whichever of the next
    vertical and horizontal grid lines is nearer along the ray (the vertical one on a tie) and
    stop on the first line crossed on a wall. The boundary is all wall, so the ray never leaves
    the grid and crosses at most rows + cols lines.
    """
    direction_x, direction_y = math.cos(direction), math.sin(direction)
    # 1 when the ray runs towards +x (+y): the next line is then the cell's far side.
    ahead_x = 1 if direction_x > 0.0 else 0
    ahead_y = 1 if direction_y > 0.0 else 0
    next_x = _first_crossing(offset_x, direction_x, cell_size)
    next_y = _first_crossing(offset_y, direction_y, cell_size)
    spacing_x = _crossing_spacing(direction_x, cell_size)
    spacing_y = _crossing_spacing(direction_y, cell_size)
    for _ in range(rows + cols):
        crosses_x = next_x <= next_y
        distance = next_x if crosses_x else next_y
        if not distance <= max_range:  # also stops a ray whose direction is NaN
            return max_range
        if crosses_x:
            if vertical[row, col + ahead_x]:
                return distance
            col += 2 * ahead_x - 1
            next_x += spacing_x
        else:
            if horizontal[row + ahead_y, col]:
                return distance
            row += 2 * ahead_y - 1
            next_y += spacing_y
    return max_range


@njit(cache=True)
def _sense_robot(
    x: float,
    y: float,
    heading: float,
    radius: float,
    angles: NDArray[np.float64],
    max_range: float,
    vertical: NDArray[np.bool_],
    horizontal: NDArray[np.bool_],
    rows: int,
    cols: int,
    origin_x: float,
    origin_y: float,
    cell_size: float,
    collision_out: NDArray[np.bool_],
    ranges_out: NDArray[np.float64],
    robot: int,
) -> None:
    """Collision (when ``collision_out`` is not empty) and ranges of one robot in one maze,
    into row ``robot`` of the outputs; a robot outside the maze collides and reads 0."""
    if collision_out.shape[0] > 0:
        collision_out[robot] = _disc_touches_wall(
            x, y, radius, vertical, horizontal, rows, cols, origin_x, origin_y, cell_size
        )
    if angles.shape[0] == 0:
        return
    inside, row, col, offset_x, offset_y = _locate(x, y, rows, cols, origin_x, origin_y, cell_size)
    for ray in range(angles.shape[0]):
        if not inside:
            ranges_out[robot, ray] = 0.0
            continue
        ranges_out[robot, ray] = _ray_distance(
            row, col, offset_x, offset_y, heading + angles[ray], max_range, vertical, horizontal,
            rows, cols, cell_size,
        )  # fmt: skip


@njit(cache=True)
def _sense(
    poses: NDArray[np.float64],
    radius: float,
    angles: NDArray[np.float64],
    max_range: float,
    vertical: NDArray[np.bool_],
    horizontal: NDArray[np.bool_],
    origin_x: float,
    origin_y: float,
    cell_size: float,
    collision_out: NDArray[np.bool_],
    ranges_out: NDArray[np.float64],
) -> None:
    """Collision and ranges of each robot in ``poses``, written into the output arrays; a robot
    outside the maze collides and reads 0 on every ray. An empty ``collision_out`` asks for
    the ranges alone, an empty ``angles`` for the collisions alone (the heading is then not
    read)."""
    rows, cols = vertical.shape[0], horizontal.shape[1]
    rays = angles.shape[0]
    for robot in range(poses.shape[0]):
        _sense_robot(
            poses[robot, 0], poses[robot, 1], poses[robot, 2] if rays else 0.0, radius, angles,
            max_range, vertical, horizontal, rows, cols, origin_x, origin_y, cell_size,
            collision_out, ranges_out, robot,
        )  # fmt: skip


#: Many mazes' walls as :func:`sense_packed` reads them: (verticals, horizontals, sizes,
#: frames), slot by slot (see :class:`mobile_envs.world.maze_pack.MazePack`).
PackedWalls = tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.int64], NDArray[np.float64]]


@njit(cache=True)
def sense_packed(
    poses: NDArray[np.float64],
    robots: NDArray[np.int64],
    slots: NDArray[np.int64],
    radius: float,
    angles: NDArray[np.float64],
    max_range: float,
    walls: PackedWalls,
    collision_out: NDArray[np.bool_],
    ranges_out: NDArray[np.float64],
) -> None:
    """:meth:`Maze.sense` for robots in many mazes at once, each reading its own maze.

    Robot ``robots[k]`` is in the maze of slot ``slots[robots[k]]`` (skipped when -1); slot ``s`` of
    ``walls`` = (verticals, horizontals, sizes, frames) holds that maze's wall grids padded to a
    common size, ``verticals[s]`` and ``horizontals[s]``, its ``sizes[s]`` (rows, cols) and
    ``frames[s]`` (origin x, origin y, cell size). Results go to rows ``robots[k]`` of the outputs,
    equal bit for bit to :meth:`Maze.sense` in each robot's maze: the same kernel, on the unpadded
    part.
    """
    _sense_packed_range(
        0, robots.shape[0], poses, robots, slots, radius, angles, max_range, walls,
        collision_out, ranges_out,
    )  # fmt: skip


@njit(cache=True, parallel=True)
def sense_packed_parallel(
    chunks: int,
    poses: NDArray[np.float64],
    robots: NDArray[np.int64],
    slots: NDArray[np.int64],
    radius: float,
    angles: NDArray[np.float64],
    max_range: float,
    walls: PackedWalls,
    collision_out: NDArray[np.bool_],
    ranges_out: NDArray[np.float64],
) -> None:
    """:func:`sense_packed` with ``robots`` split into ``chunks`` contiguous chunks on numba's
    threads (run it through :func:`mobile_envs._kernels.threads.on_threads`); every robot's result
    is the serial one, bit for bit, since each writes only its own rows."""
    count = robots.shape[0]
    for chunk in prange(chunks):
        _sense_packed_range(
            chunk * count // chunks, (chunk + 1) * count // chunks, poses, robots, slots,
            radius, angles, max_range, walls, collision_out, ranges_out,
        )  # fmt: skip


@njit(cache=True)
def _sense_packed_range(
    first, stop, poses, robots, slots, radius, angles, max_range, walls, collision_out,
    ranges_out,
):  # fmt: skip
    """:func:`sense_packed` for robots ``robots[first:stop]``; a call of its own, since a
    ``prange`` body that inlined this loop's exits would run serially."""
    verticals, horizontals, sizes, frames = walls
    rays = angles.shape[0]
    for k in range(first, stop):
        robot = robots[k]
        slot = slots[robot]
        if slot < 0:
            continue
        _sense_robot(
            poses[robot, 0], poses[robot, 1], poses[robot, 2] if rays else 0.0, radius, angles,
            max_range, verticals[slot], horizontals[slot], sizes[slot, 0], sizes[slot, 1],
            frames[slot, 0], frames[slot, 1], frames[slot, 2], collision_out, ranges_out, robot,
        )  # fmt: skip

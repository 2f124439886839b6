"""Perfect grid mazes: generation, shortest routes, walls, collisions and range sensing.

Seed 000's robot won a maze competition by planning shortest routes in a known maze. These mazes
set a path follower the same task: follow the shortest route through the cell centres without
touching the walls, optionally sensing the walls with range finders.

Cell (row, col) covers x in ``origin_x + [col, col + 1] * cell_size`` and y in
``origin_y + [row, row + 1] * cell_size``: rows grow along +y. Walls are zero-thickness segments
on the grid lines, kept in two boolean grids: ``vertical[row, line]`` is the wall on vertical grid
line ``line`` (0 to cols) beside row ``row``, ``horizontal[line, col]`` the wall on horizontal
grid line ``line`` (0 to rows) beside column ``col``. The outer boundary is all wall.
"""

from __future__ import annotations

import math
from collections import deque
from functools import cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mobile_envs.paths import Path, Track

Cell = tuple[int, int]

CANONICAL_MAZE_SEED = 0
_MOVES = ((0, 1), (1, 0), (0, -1), (-1, 0))  # (row step, col step)


def _carve_walls(
    rows: int, cols: int, rng: np.random.Generator
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Wall grids of a perfect maze, carved by a randomized depth-first search.

    The search knocks down one wall per newly reached cell, so the open walls form a spanning
    tree of the grid: every cell is reachable by exactly one route. Depth-first carving makes
    long winding corridors.
    """
    vertical = np.ones((rows, cols + 1), dtype=bool)
    horizontal = np.ones((rows + 1, cols), dtype=bool)
    visited = {(0, 0)}
    stack = [(0, 0)]
    while stack:
        row, col = stack[-1]
        unvisited = [
            (row + row_step, col + col_step)
            for row_step, col_step in _MOVES
            if 0 <= row + row_step < rows
            and 0 <= col + col_step < cols
            and (row + row_step, col + col_step) not in visited
        ]
        if not unvisited:
            stack.pop()
            continue
        next_row, next_col = unvisited[rng.integers(len(unvisited))]
        if next_row == row:
            vertical[row, max(col, next_col)] = False
        else:
            horizontal[max(row, next_row), col] = False
        visited.add((next_row, next_col))
        stack.append((next_row, next_col))
    return vertical, horizontal


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
    :raises ValueError: for non-positive sizes, a negative or non-integer seed, or a bad origin.
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
        if isinstance(seed, np.random.Generator):
            rng = seed
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0:
            rng = np.random.default_rng(seed)
        else:
            raise ValueError(f"seed must be an int >= 0 or a numpy Generator, got {seed!r}")

        self._rows, self._cols = int(rows), int(cols)
        self._cell_size = float(cell_size)
        self._origin = _read_only(origin)
        self._seed = None if isinstance(seed, np.random.Generator) else int(seed)
        vertical, horizontal = _carve_walls(self._rows, self._cols, rng)
        self._vertical = _read_only(vertical)
        self._horizontal = _read_only(horizontal)
        # Copies with a wall-free border, so a lookup one cell off the grid finds no wall.
        self._vertical_padded = _read_only(np.pad(vertical, ((1, 1), (0, 0))))
        self._horizontal_padded = _read_only(np.pad(horizontal, ((0, 0), (1, 1))))
        self._walls = _read_only(self._wall_segments())

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
    def bounds(self) -> NDArray[np.float64]:
        """(2, 2) lower-left and upper-right corners of the maze (m)."""
        size = np.array([self._cols, self._rows]) * self._cell_size
        return _read_only(np.stack((self._origin, self._origin + size)))

    @property
    def walls(self) -> NDArray[np.float64]:
        """(W, 2, 2) wall segments (start and end points, m), the outer boundary included."""
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

    def _open_neighbours(self, cell: Cell) -> list[Cell]:
        row, col = cell
        return [
            (row + row_step, col + col_step)
            for row_step, col_step in _MOVES
            if 0 <= row + row_step < self._rows
            and 0 <= col + col_step < self._cols
            and self.open_between(cell, (row + row_step, col + col_step))
        ]

    def _breadth_first(self, start: Cell) -> tuple[NDArray[np.int64], dict[Cell, Cell]]:
        """Route lengths in cells from ``start`` to every cell, and each cell's predecessor."""
        distance = np.full((self._rows, self._cols), -1, dtype=np.int64)
        distance[start] = 0
        previous: dict[Cell, Cell] = {}
        queue = deque([start])
        while queue:
            cell = queue.popleft()
            for neighbour in self._open_neighbours(cell):
                if distance[neighbour] < 0:
                    distance[neighbour] = distance[cell] + 1
                    previous[neighbour] = cell
                    queue.append(neighbour)
        return distance, previous

    def distances_from(self, cell: Cell) -> NDArray[np.int64]:
        """(rows, cols) number of cell-to-cell moves on the route from ``cell`` to each cell."""
        return self._breadth_first(self._check_cell(cell))[0]

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
        _, previous = self._breadth_first(start)
        cells = [goal]
        while cells[-1] != start:
            cells.append(previous[cells[-1]])
        centres = np.array([self.cell_center(cell) for cell in reversed(cells)])
        first_leg = centres[1] - centres[0]
        return Path(centres, name=name, start_heading=math.atan2(first_leg[1], first_leg[0]))

    def collides(self, xy: ArrayLike, radius: float) -> NDArray[np.bool_] | bool:
        """Whether a robot disc of ``radius`` touches a wall, or its centre is outside the maze.

        O(1) per robot: a disc narrower than a cell reaches at most its own cell's walls and the
        two walls that leave the nearest cell corner outward.

        :param xy: (N, 2) positions or (N, 3) poses (m); (2,) or (3,) for one robot.
        :param radius: disc radius (m), in [0, cell_size / 2).
        :return: (N,) booleans, or a bool for one robot.
        """
        if not 0 <= radius < self._cell_size / 2:
            raise ValueError(f"radius must lie in [0, {self._cell_size / 2}), got {radius}")
        xy = np.asarray(xy, dtype=np.float64)
        single = xy.ndim == 1
        positions = _check_rows_of(xy.reshape(1, -1) if single else xy, "xy", (2, 3))
        cell = self._cell_size
        inside, row, col, local_x, local_y = self._locate(positions[:, 0], positions[:, 1])
        # Distances to the nearer vertical and horizontal grid lines of the cell, and their walls.
        east = (local_x > cell / 2).astype(np.intp)
        north = (local_y > cell / 2).astype(np.intp)
        gap_x = np.where(east, cell - local_x, local_x)
        gap_y = np.where(north, cell - local_y, local_y)
        side_wall_x = self._vertical[row, col + east]
        side_wall_y = self._horizontal[row + north, col]
        # Past the nearest corner: the vertical wall in the next row, the horizontal one in the
        # next column. The corner is the closest point of both to the disc's centre.
        corner_walls = (
            self._vertical_padded[row + 2 * north, col + east]
            | self._horizontal_padded[row + north, col + 2 * east]
        )
        touches = (
            ((gap_x <= radius) & side_wall_x)
            | ((gap_y <= radius) & side_wall_y)
            | ((np.hypot(gap_x, gap_y) <= radius) & corner_walls)
        )
        collides = touches | ~inside
        return bool(collides[0]) if single else collides

    def ranges(self, pose: ArrayLike, angles: ArrayLike, max_range: float) -> NDArray[np.float64]:
        """Distance from each robot to the first wall along each ray, as range finders read it.

        A grid traversal (Amanatides & Woo's DDA), vectorized over all rays: each step moves
        every unfinished ray across its next grid line and stops the rays whose line segment
        holds a wall. A ray crosses at most rows + cols lines before meeting the boundary, and
        at most 2 (max_range / cell_size + 1) lines within reach, so the steps are bounded.

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
        angles = np.asarray(angles, dtype=np.float64)
        if angles.ndim != 1 or not np.all(np.isfinite(angles)):
            raise ValueError(f"angles must be a 1-D array of finite angles, got {angles}")

        directions = (poses[:, 2:3] + angles).ravel()
        ray_x = np.repeat(poses[:, 0], len(angles))
        ray_y = np.repeat(poses[:, 1], len(angles))
        inside, row, col, local_x, local_y = self._locate(ray_x, ray_y)
        distances = np.where(inside, max_range, 0.0)
        ray = np.flatnonzero(inside)
        row, col, local_x, local_y = row[ray], col[ray], local_x[ray], local_y[ray]
        direction_x = np.cos(directions[ray])
        direction_y = np.sin(directions[ray])
        # 1 when the ray runs towards +x (+y): the next grid line is then the cell's far side.
        ahead_x = (direction_x > 0).astype(np.intp)
        ahead_y = (direction_y > 0).astype(np.intp)
        cell = self._cell_size
        # Ray length to the next vertical (x) and horizontal (y) grid line, and between lines.
        next_x = _divide_or_inf(np.abs(ahead_x * cell - local_x), np.abs(direction_x))
        next_y = _divide_or_inf(np.abs(ahead_y * cell - local_y), np.abs(direction_y))
        spacing_x = _divide_or_inf(np.full(len(ray), cell), np.abs(direction_x))
        spacing_y = _divide_or_inf(np.full(len(ray), cell), np.abs(direction_y))

        max_steps = min(self._rows + self._cols, 2 * (math.floor(max_range / cell) + 1))
        for _ in range(max_steps):
            if ray.size == 0:
                break
            crosses_x = next_x <= next_y
            distance = np.where(crosses_x, next_x, next_y)
            wall = np.where(
                crosses_x,
                self._vertical[row, col + ahead_x],
                self._horizontal[row + ahead_y, col],
            )
            within_reach = distance <= max_range
            hit = wall & within_reach
            distances[ray[hit]] = distance[hit]
            going = ~wall & within_reach
            crosses_x, crosses_y = crosses_x[going], ~crosses_x[going]
            ray, ahead_x, ahead_y = ray[going], ahead_x[going], ahead_y[going]
            col = col[going] + crosses_x * (2 * ahead_x - 1)
            row = row[going] + crosses_y * (2 * ahead_y - 1)
            spacing_x, spacing_y = spacing_x[going], spacing_y[going]
            next_x = next_x[going] + np.where(crosses_x, spacing_x, 0.0)
            next_y = next_y[going] + np.where(crosses_y, spacing_y, 0.0)

        distances = distances.reshape(len(poses), len(angles))
        return distances[0] if single else distances

    def _locate(
        self, x: NDArray[np.float64], y: NDArray[np.float64]
    ) -> tuple[NDArray[np.bool_], NDArray[np.intp], NDArray[np.intp], NDArray, NDArray]:
        """Where points lie in the grid.

        :return: whether each point lies inside the maze, its row and column (the nearest cell
            for a point outside), and its x and y offsets (m) from that cell's lower-left corner.
        """
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            raise ValueError("positions must be finite")
        cell = self._cell_size
        grid_x = (x - self._origin[0]) / cell
        grid_y = (y - self._origin[1]) / cell
        inside = (grid_x >= 0) & (grid_x < self._cols) & (grid_y >= 0) & (grid_y < self._rows)
        col = np.clip(np.floor(grid_x), 0, self._cols - 1).astype(np.intp)
        row = np.clip(np.floor(grid_y), 0, self._rows - 1).astype(np.intp)
        local_x = x - self._origin[0] - col * cell
        local_y = y - self._origin[1] - row * cell
        return inside, row, col, local_x, local_y

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


def _divide_or_inf(numerator: NDArray[np.float64], denominator: NDArray[np.float64]) -> NDArray:
    """numerator / denominator, inf where the denominator is 0 (a ray parallel to the lines)."""
    return np.divide(
        numerator, denominator, out=np.full(numerator.shape, np.inf), where=denominator != 0
    )


def _check_rows_of(array: NDArray[np.float64], label: str, widths: tuple[int, ...]) -> NDArray:
    if array.ndim != 2 or array.shape[1] not in widths:
        expected = " or ".join(f"(N, {width})" for width in widths)
        raise ValueError(f"{label} must have shape {expected}, got {array.shape}")
    return array


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
    the cells at least half as far from the start, along the maze, as the farthest cell.

    :param rng: the random generator; the same state gives the same track.
    """
    maze = Maze(seed=int(rng.integers(2**63)))
    start = (int(rng.integers(maze.rows)), int(rng.integers(maze.cols)))
    distance = maze.distances_from(start)
    far_cells = np.argwhere(distance >= distance.max() / 2)
    goal = far_cells[rng.integers(len(far_cells))]
    return Track(maze.route(start, (int(goal[0]), int(goal[1])), name="random_maze"), maze)

"""Tests of mobile_envs.world.maze against breadth-first search and brute-force geometry."""

import itertools
from collections import deque

import numpy as np
import pytest

from mobile_envs.tracks import random_maze, the_maze
from mobile_envs.world.maze import Maze

SIZES = [(8, 8, 0), (3, 5, 1), (1, 4, 2), (6, 2, 3)]


def neighbours(maze, cell):
    row, col = cell
    candidates = [(row + 1, col), (row - 1, col), (row, col + 1), (row, col - 1)]
    return [
        other for other in candidates if 0 <= other[0] < maze.rows and 0 <= other[1] < maze.cols
    ]


def bfs_distances(maze, start):
    """Moves from start to every cell through open walls, by the test's own search."""
    distance = {start: 0}
    queue = deque([start])
    while queue:
        cell = queue.popleft()
        for other in neighbours(maze, cell):
            if other not in distance and maze.open_between(cell, other):
                distance[other] = distance[cell] + 1
                queue.append(other)
    return distance


def cells(maze):
    return [(row, col) for row in range(maze.rows) for col in range(maze.cols)]


@pytest.mark.parametrize(("rows", "cols", "seed"), SIZES)
def test_maze_is_perfect(rows, cols, seed):
    maze = Maze(rows, cols, seed=seed)
    assert len(bfs_distances(maze, (0, 0))) == rows * cols
    open_walls = {
        frozenset((cell, other))
        for cell in cells(maze)
        for other in neighbours(maze, cell)
        if maze.open_between(cell, other)
    }
    assert len(open_walls) == rows * cols - 1


@pytest.mark.parametrize(("rows", "cols", "seed"), SIZES)
def test_walls_are_the_closed_grid_edges_and_the_boundary(rows, cols, seed):
    maze = Maze(rows, cols, cell_size=2.0, seed=seed, origin=(1.0, -3.0))
    edges = rows * (cols + 1) + (rows + 1) * cols
    assert maze.walls.shape == (edges - (rows * cols - 1), 2, 2)
    lengths = np.hypot(*(maze.walls[:, 1] - maze.walls[:, 0]).T)
    assert lengths == pytest.approx(2.0)
    midpoints = maze.walls.mean(axis=1)
    (x_min, y_min), (x_max, y_max) = maze.bounds
    on_boundary = (
        np.isclose(midpoints[:, 0], x_min)
        | np.isclose(midpoints[:, 0], x_max)
        | np.isclose(midpoints[:, 1], y_min)
        | np.isclose(midpoints[:, 1], y_max)
    )
    assert on_boundary.sum() == 2 * (rows + cols)
    # Every interior wall sits between two cells that are not open to each other.
    for midpoint in midpoints[~on_boundary]:
        grid = (midpoint - maze.origin) / 2.0
        if np.isclose(grid[0] % 1, 0):  # vertical wall between columns
            a = (int(grid[1]), round(grid[0]) - 1)
            b = (a[0], a[1] + 1)
        else:
            a = (round(grid[1]) - 1, int(grid[0]))
            b = (a[0] + 1, a[1])
        assert not maze.open_between(a, b)


def test_open_between_non_neighbours_is_false():
    maze = Maze(4, 4, seed=0)
    assert not maze.open_between((0, 0), (1, 1))
    assert not maze.open_between((0, 0), (0, 2))
    assert not maze.open_between((2, 2), (2, 2))


@pytest.mark.parametrize(("rows", "cols", "seed"), SIZES)
def test_route_is_the_shortest_through_open_walls(rows, cols, seed):
    maze = Maze(rows, cols, cell_size=1.5, seed=seed, origin=(0.5, 0.25))
    rng = np.random.default_rng(seed)
    for _ in range(10):
        start = (int(rng.integers(rows)), int(rng.integers(cols)))
        goal = (int(rng.integers(rows)), int(rng.integers(cols)))
        if start == goal:
            continue
        path = maze.route(start, goal)
        route_cells = [
            (int(row), int(col))
            for col, row in np.floor((path.points - maze.origin) / maze.cell_size)
        ]
        assert route_cells[0] == start and route_cells[-1] == goal
        for a, b in itertools.pairwise(route_cells):
            assert maze.open_between(a, b)
        assert path.length == pytest.approx(bfs_distances(maze, start)[goal] * 1.5)
        assert np.allclose(path.points - maze.origin, (np.array(route_cells)[:, ::-1] + 0.5) * 1.5)
        first_leg = path.points[1] - path.points[0]
        assert path.start_heading == pytest.approx(np.arctan2(first_leg[1], first_leg[0]))
        assert np.array_equal(maze.distances_from(start)[goal], bfs_distances(maze, start)[goal])


def point_segment_distances(points, walls):
    """(N, W) distance from each point to each wall segment."""
    start = walls[None, :, 0]
    direction = walls[None, :, 1] - start
    offset = points[:, None] - start
    along = np.clip(
        np.sum(offset * direction, axis=-1) / np.sum(direction * direction, axis=-1), 0, 1
    )
    return np.linalg.norm(offset - along[..., None] * direction, axis=-1)


@pytest.mark.parametrize("radius", [0.0, 0.2, 0.5, 0.74])
def test_collides_matches_brute_force_over_all_walls(radius):
    maze = Maze(8, 8, cell_size=1.5, seed=4, origin=(-1.0, 2.0))
    rng = np.random.default_rng(5)
    (x_min, y_min), (x_max, y_max) = maze.bounds
    points = rng.uniform((x_min - 0.5, y_min - 0.5), (x_max + 0.5, y_max + 0.5), size=(4000, 2))
    outside = (
        (points[:, 0] < x_min)
        | (points[:, 0] >= x_max)
        | (points[:, 1] < y_min)
        | (points[:, 1] >= y_max)
    )
    expected = outside | (point_segment_distances(points, maze.walls).min(axis=1) <= radius)
    assert np.array_equal(maze.collides(points, radius), expected)
    assert 0 < expected.sum() < len(points)
    assert maze.collides(np.column_stack((points, points[:, 0])), radius).tolist() == (
        expected.tolist()
    )
    assert maze.collides(points[0], radius) == expected[0]


def test_collides_with_a_wall_beyond_the_nearest_corner():
    # A disc in cell (1, 1) of a 2 x 2 maze near the corner (1, 1) reaches the walls that leave
    # that corner outward, between cells (0, 0) and (0, 1) or (0, 0) and (1, 0), only once its
    # radius exceeds the distance to the corner, hypot(0.1, 0.1).
    position = np.array([1.1, 1.1])
    outcomes = set()
    for seed in range(10):
        maze = Maze(2, 2, cell_size=1.0, seed=seed)
        own = not (maze.open_between((1, 1), (1, 0)) and maze.open_between((1, 1), (0, 1)))
        beyond = not (maze.open_between((0, 0), (0, 1)) and maze.open_between((0, 0), (1, 0)))
        assert maze.collides(position, 0.12) == own
        assert maze.collides(position, 0.15) == (own or beyond)
        outcomes.add((own, beyond))
    assert (False, True) in outcomes


def brute_force_ranges(poses, angles, walls, max_range):
    """(N, R) distance along each ray to the nearest wall segment it meets, by solving each
    ray-segment intersection."""
    directions = poses[:, 2:3] + angles
    ray = np.stack((np.cos(directions), np.sin(directions)), axis=-1)[:, :, None]  # (N, R, 1, 2)
    origin = poses[:, None, None, :2]
    start = walls[None, None, :, 0]
    edge = walls[None, None, :, 1] - start
    denominator = ray[..., 0] * edge[..., 1] - ray[..., 1] * edge[..., 0]
    to_start = start - origin
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (to_start[..., 0] * edge[..., 1] - to_start[..., 1] * edge[..., 0]) / denominator
        u = (to_start[..., 0] * ray[..., 1] - to_start[..., 1] * ray[..., 0]) / denominator
    hits = (denominator != 0) & (t >= 0) & (u >= 0) & (u <= 1) & (t <= max_range)
    return np.where(hits, t, max_range).min(axis=-1)


@pytest.mark.parametrize("max_range", [0.7, 3.0, 30.0])
def test_ranges_match_brute_force_over_all_walls(max_range):
    maze = Maze(8, 8, cell_size=1.5, seed=6, origin=(0.5, -0.5))
    rng = np.random.default_rng(7)
    (x_min, y_min), (x_max, y_max) = maze.bounds
    poses = np.column_stack(
        (
            rng.uniform(x_min, x_max, 300),
            rng.uniform(y_min, y_max, 300),
            rng.uniform(-np.pi, np.pi, 300),
        )
    )
    angles = np.linspace(-np.pi, np.pi, 16, endpoint=False)
    expected = brute_force_ranges(poses, angles, maze.walls, max_range)
    measured = maze.ranges(poses, angles, max_range)
    assert measured.shape == (300, 16)
    assert np.allclose(measured, expected, rtol=0, atol=1e-9)
    assert np.any(measured < max_range)
    assert np.allclose(maze.ranges(poses[3], angles, max_range), expected[3], rtol=0, atol=1e-9)


def test_ranges_along_the_axes_and_outside():
    maze = Maze(3, 3, cell_size=1.0, seed=0)
    # Rays along the axes have a direction component of exactly 0 (sin(0), sin(pi)).
    pose = np.array([[1.5, 1.25, 0.0], [0.25, 1.5, np.pi / 2], [5.0, 5.0, 0.0]])
    angles = np.array([0.0, np.pi / 2, np.pi, -np.pi / 2])
    expected = brute_force_ranges(pose[:2], angles, maze.walls, 10.0)
    measured = maze.ranges(pose, angles, 10.0)
    assert np.allclose(measured[:2], expected, rtol=0, atol=1e-9)
    assert np.array_equal(measured[2], np.zeros(4))


def random_poses(maze, count, rng, margin=0.5):
    """(count, 3) poses over the maze and a margin around it, so some robots are outside."""
    (x_min, y_min), (x_max, y_max) = maze.bounds
    return np.column_stack(
        (
            rng.uniform(x_min - margin, x_max + margin, count),
            rng.uniform(y_min - margin, y_max + margin, count),
            rng.uniform(-np.pi, np.pi, count),
        )
    )


@pytest.mark.parametrize("which", ["canonical", "random"])
def test_sense_equals_collides_and_ranges_for_a_strided_batch(which):
    rng = np.random.default_rng(8)
    maze = the_maze().maze if which == "canonical" else random_maze(rng).maze
    state = np.zeros((500, 4))  # a wider state array: the poses are a non-contiguous view
    state[:, :3] = random_poses(maze, 500, rng)
    poses = state[:, :3]
    assert not poses.flags.c_contiguous
    angles = np.linspace(-np.pi, np.pi, 16, endpoint=False)
    collision, ranges = np.empty(500, dtype=bool), np.empty((500, 16))
    maze.sense(poses, 0.3, angles, 3.0, collision, ranges)
    assert np.array_equal(collision, maze.collides(poses, 0.3))
    assert np.array_equal(ranges, maze.ranges(poses, angles, 3.0))
    assert 0 < collision.sum() < 500
    for robot in range(0, 500, 37):  # one robot at a time gives the same bits
        one_collision, one_ranges = np.empty(1, dtype=bool), np.empty((1, 16))
        maze.sense(poses[robot : robot + 1], 0.3, angles, 3.0, one_collision, one_ranges)
        assert one_collision[0] == collision[robot]
        assert np.array_equal(one_ranges[0], ranges[robot])


def test_sense_outside_or_at_a_non_finite_position_collides_and_reads_zero():
    maze = the_maze().maze
    poses = np.array([[-0.1, 1.0, 0.0], [12.0, 1.0, 0.0], [np.nan, 1.0, 0.0], [1.0, np.inf, 0.0]])
    collision, ranges = np.empty(4, dtype=bool), np.empty((4, 3))
    maze.sense(poses, 0.3, np.array([0.0, 1.0, 2.0]), 3.0, collision, ranges)
    assert collision.all()
    assert np.array_equal(ranges, np.zeros((4, 3)))


def quarter_cell_lattice(maze):
    """(P, 2) points every quarter cell over the maze: on grid lines, at corners and between,
    the upper and right boundaries (outside the maze) included."""
    quarter = maze.cell_size / 4
    x = maze.origin[0] + np.arange(4 * maze.cols + 1) * quarter
    y = maze.origin[1] + np.arange(4 * maze.rows + 1) * quarter
    return np.stack(np.meshgrid(x, y), axis=-1).reshape(-1, 2)


@pytest.mark.parametrize("radius", [0.0, 0.2, 0.375, 0.5, 0.74])
def test_collides_on_grid_lines_and_corners_matches_brute_force(radius):
    # Exact binary fractions: every distance to a wall is computed without rounding. A radius of
    # a quarter cell puts walls at exactly the radius (a touch counts), at the edge of the
    # lines and segments the search reaches.
    maze = Maze(5, 4, cell_size=1.5, seed=11, origin=(-1.0, 2.0))
    points = quarter_cell_lattice(maze)
    x_max, y_max = maze.bounds[1]
    outside = (points[:, 0] >= x_max) | (points[:, 1] >= y_max)
    expected = outside | (point_segment_distances(points, maze.walls).min(axis=1) <= radius)
    assert np.array_equal(maze.collides(points, radius), expected)


def test_ranges_on_grid_lines_and_corners_read_from_the_cell_above_and_right():
    # A robot on a grid line belongs to the cell above it or to its right: it reads what a robot
    # a hair inside that cell reads. A ray leaving a corner through the corner itself crosses the
    # vertical line first (the traversal's tie rule), as from a hair nearer the left side than
    # the bottom. Rays along the axes run exactly along grid lines; the others, from these
    # points, pass no other grid corner, where a hair would change which wall is met first.
    maze = Maze(5, 4, cell_size=1.5, seed=11, origin=(-1.0, 2.0))
    (x_min, y_min), (x_max, y_max) = maze.bounds
    points = quarter_cell_lattice(maze)
    outside = (points[:, 0] >= x_max) | (points[:, 1] >= y_max)
    poses = np.column_stack((points, np.zeros(len(points))))
    angles = np.concatenate(
        ([0.0, np.pi / 2, np.pi, -np.pi / 2], 0.3 + np.linspace(-np.pi, np.pi, 8, endpoint=False))
    )
    measured = maze.ranges(poses, angles, 30.0)
    assert np.array_equal(measured[outside], np.zeros((outside.sum(), len(angles))))
    hair = np.array([1e-12, 1e-9, 0.0])
    expected = brute_force_ranges(poses[~outside] + hair, angles, maze.walls, 30.0)
    assert np.allclose(measured[~outside], expected, rtol=0, atol=1e-7)
    # On the lower-left corner: towards the boundary 0, into the maze more.
    assert np.array_equal(maze.ranges((x_min, y_min, 0.0), [np.pi, -np.pi / 2], 30.0), [0, 0])
    assert np.all(maze.ranges((x_min, y_min, 0.0), [0.0, np.pi / 2], 30.0) > 0)
    collision, ranges = np.empty(len(poses), dtype=bool), np.empty((len(poses), len(angles)))
    maze.sense(poses, 0.5, angles, 30.0, collision, ranges)
    assert np.array_equal(ranges, measured)
    assert np.array_equal(collision, maze.collides(points, 0.5))


def test_the_canonical_maze():
    track = the_maze()
    maze = track.maze
    assert (maze.rows, maze.cols, maze.cell_size) == (8, 8, 1.5)
    assert np.array_equal(track.path.points[0], [0.75, 0.75])
    assert np.array_equal(track.path.goal, [11.25, 11.25])
    assert the_maze() is track
    assert np.array_equal(Maze(seed=maze.seed).walls, maze.walls)
    along_route = track.path.point_at(np.linspace(0, track.path.length, 500))
    assert not maze.collides(along_route, 0.3).any()


def test_random_maze_is_reproducible_and_its_ends_are_far_apart():
    first = random_maze(np.random.default_rng(3))
    second = random_maze(np.random.default_rng(3))
    assert np.array_equal(first.maze.walls, second.maze.walls)
    assert np.array_equal(first.path.points, second.path.points)
    rng = np.random.default_rng(4)
    for _ in range(20):
        track = random_maze(rng)
        start = tuple(
            int(index) for index in np.floor(track.path.points[0] / track.maze.cell_size)[::-1]
        )
        farthest = max(bfs_distances(track.maze, start).values())
        assert track.path.length >= farthest / 2 * track.maze.cell_size


def test_generator_seed_carves_reproducibly():
    first = Maze(seed=np.random.default_rng(9))
    second = Maze(seed=np.random.default_rng(9))
    assert np.array_equal(first.walls, second.walls)
    assert first.seed is None


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"rows": 0}, "rows"),
        ({"cols": 2.5}, "cols"),
        ({"cell_size": -1.0}, "cell_size"),
        ({"cell_size": float("nan")}, "cell_size"),
        ({"seed": -1}, "seed"),
        ({"seed": "x"}, "seed"),
        ({"origin": (0.0, 1.0, 2.0)}, "origin"),
        # Finite, but the walls and the route would reach past 1e9 m (1e300 m: infinity).
        ({"cell_size": 1e300}, "cell_size 1e\\+300"),
        ({"origin": (-1e9 - 1.0, 0.0)}, r"origin \[-1000000001.0, 0.0\]"),
        ({"origin": (1e9 - 1.0, 0.0)}, "within 1e\\+09 m"),
    ],
)
def test_bad_maze_arguments_raise(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Maze(**kwargs)


def test_a_maze_may_reach_the_coordinate_limit():
    maze = Maze(2, 2, cell_size=0.5, origin=(1e9 - 1.0, -1e9))
    assert maze.bounds.tolist() == [[1e9 - 1.0, -1e9], [1e9, -1e9 + 1.0]]
    assert maze.route((0, 0), (1, 1)).length == pytest.approx(1.0)


def test_bad_queries_raise():
    maze = Maze(4, 4, seed=0)
    with pytest.raises(ValueError, match="radius"):
        maze.collides((1.0, 1.0), 0.75)
    with pytest.raises(ValueError, match="outside"):
        maze.route((0, 0), (4, 0))
    with pytest.raises(ValueError, match="differ"):
        maze.route((1, 1), (1, 1))
    with pytest.raises(ValueError, match="max_range"):
        maze.ranges((1.0, 1.0, 0.0), [0.0], 0.0)
    with pytest.raises(ValueError, match="pose"):
        maze.ranges((1.0, 1.0), [0.0], 1.0)
    with pytest.raises(ValueError, match="finite"):
        maze.collides((np.nan, 1.0), 0.1)

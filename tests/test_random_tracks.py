"""Tests of the compiled track generators and of many mazes sensed in one call.

The generators are checked against their documented properties by the test's own brute force
(breadth-first search over ``open_between``, geometry of the points); that they draw today's
numbers bit for bit is what ``benchmarks/fingerprint.py`` pins. The packed sensing is checked
against :meth:`Maze.sense` in each robot's own maze, bit for bit.
"""

import itertools
import math
from collections import deque

import numpy as np
import pytest

from mobile_envs.tracks import path_set, random_maze
from mobile_envs.tracks.random_paths import SHORT_END_LAST_LEG
from mobile_envs.world.maze import Maze
from mobile_envs.world.maze_pack import MazePack
from mobile_envs.world.paths import (
    RANDOM_AREA,
    RANDOM_LENGTH_RANGE,
    RANDOM_MAX_TURN,
    SHORTEST_LAST_LEG,
    random_path,
)


def distances_by_search(maze, start):
    """Steps from ``start`` to every cell it reaches, by the test's own breadth-first search."""
    distance = {start: 0}
    queue = deque([start])
    while queue:
        row, col = queue.popleft()
        for other in ((row + 1, col), (row - 1, col), (row, col + 1), (row, col - 1)):
            inside = 0 <= other[0] < maze.rows and 0 <= other[1] < maze.cols
            if inside and other not in distance and maze.open_between((row, col), other):
                distance[other] = distance[(row, col)] + 1
                queue.append(other)
    return distance


def reachable_and_open_walls(maze):
    """Cells reached from (0, 0) by the test's own search, and the number of open walls."""
    open_walls = (~maze.vertical_walls[:, 1:-1]).sum() + (~maze.horizontal_walls[1:-1]).sum()
    return distances_by_search(maze, (0, 0)), int(open_walls)


def test_random_mazes_are_perfect_and_their_routes_are_the_shortest_far_ones():
    rng = np.random.default_rng(21)
    for _ in range(60):
        track = random_maze(rng)
        maze = track.maze
        reached, open_walls = reachable_and_open_walls(maze)
        assert len(reached) == maze.rows * maze.cols
        assert open_walls == maze.rows * maze.cols - 1  # a spanning tree
        cells = [
            (int(row), int(col))
            for col, row in np.floor(track.path.points / maze.cell_size).astype(int)
        ]
        distance = distances_by_search(maze, cells[0])
        assert len(cells) - 1 == distance[cells[-1]]  # no shorter route exists
        assert all(maze.open_between(a, b) for a, b in itertools.pairwise(cells))
        assert distance[cells[-1]] >= max(distance.values()) / 2
        assert np.array_equal(Maze(seed=maze.seed).walls, maze.walls)


@pytest.mark.parametrize(("rows", "cols"), [(1, 1), (1, 7), (9, 2), (13, 11)])
def test_a_maze_carved_from_a_generator_is_the_maze_of_its_seed(rows, cols):
    # An int seed is carved from default_rng(seed)'s state, built in compiled code; a
    # Generator is carved from its own state: both paths must make the same maze.
    for seed in (0, 3, 2**40 + 1):
        rng = np.random.default_rng(seed)
        from_generator = Maze(rows, cols, seed=rng)
        from_seed = Maze(rows, cols, seed=seed)
        assert np.array_equal(from_generator.walls, from_seed.walls)
        reached, open_walls = reachable_and_open_walls(from_seed)
        assert len(reached) == rows * cols and open_walls == rows * cols - 1
        # A corridor offers one way on at every step: integers(1) draws nothing.
        untouched = rng.bit_generator.state == np.random.default_rng(seed).bit_generator.state
        assert untouched == (rows == 1 or cols == 1)


def test_a_maze_carves_from_any_bit_generator():
    first = Maze(6, 5, seed=np.random.Generator(np.random.Philox(4)))
    second = Maze(6, 5, seed=np.random.Generator(np.random.Philox(4)))
    assert np.array_equal(first.walls, second.walls)
    reached, open_walls = reachable_and_open_walls(first)
    assert len(reached) == 30 and open_walls == 29


def test_random_paths_keep_their_documented_limits():
    rng = np.random.default_rng(5)
    low, high = RANDOM_AREA
    for _ in range(300):
        path = random_path(rng)
        assert np.all(path.points >= low - 1e-9) and np.all(path.points <= high + 1e-9)
        # A polyline's last leg is at least 1 m, so it may run up to 1 m past the length.
        assert RANDOM_LENGTH_RANGE[0] - 1e-9 <= path.length <= RANDOM_LENGTH_RANGE[1] + 1.0
        assert np.all(np.abs(path.turn_angles) <= RANDOM_MAX_TURN + 1e-9)
        assert math.isfinite(path.start_heading)


def test_short_ends_cut_only_the_last_leg_of_polylines_that_default_paths_clamp():
    # The draws are the default's; only a last leg that the default lengthens to 1 m (the
    # walk ran out of length) is cut shorter, down to SHORT_END_LAST_LEG. Where that happens
    # to a walk that does not fit the area (drawn again), the draws part; every other path,
    # arcs included, is the default's bit for bit.
    short_ends = path_set("random_short_ends")
    same = cut = soon_after_a_corner = 0
    for seed in range(400):
        default = random_path(np.random.default_rng(seed))
        short = short_ends.sample(np.random.default_rng(seed)).path
        if np.array_equal(short.points, default.points):
            assert short.start_heading == default.start_heading
            same += 1
            continue
        if abs(default.segment_lengths[-1] - SHORTEST_LAST_LEG) > 1e-9:
            continue  # an earlier walk that did not fit was cut otherwise: other draws
        cut += 1
        last = short.segment_lengths[-1]
        assert SHORT_END_LAST_LEG - 1e-9 <= last < SHORTEST_LAST_LEG
        # the legs before the last keep the default's lengths and corners
        assert np.allclose(short.segment_lengths[:-1], default.segment_lengths[:-1])
        assert np.allclose(short.turn_angles, default.turn_angles)
        assert short.length < default.length <= RANDOM_LENGTH_RANGE[1] + SHORTEST_LAST_LEG
        if last < 0.85 and abs(short.turn_angles[-2]) > math.radians(69):  # last corner
            soon_after_a_corner += 1
    assert same >= 300  # arcs, and polylines whose last leg was not cut
    assert same + cut >= 390  # walks drawn again are rare
    assert cut >= 40  # about half the polylines (a quarter of the paths) end cut
    assert soon_after_a_corner >= 5  # what the set is for: Segments-like endings


@pytest.mark.parametrize("bad", [0.0, -0.5, math.nan, math.inf, "0.5", True, None])
def test_a_bad_shortest_last_leg_is_refused(bad):
    with pytest.raises(ValueError, match="shortest_last_leg must be a positive number"):
        random_path(np.random.default_rng(0), bad)


@pytest.mark.parametrize(
    ("name", "maze_weight"), [("training", 0.25), ("training_half_mazes", 0.5)]
)
def test_path_set_draws_match_numpys_choice_of_member(name, maze_weight):
    # The training mixes draw their member with one double, as rng.choice(2, p=...) does.
    rng, reference = np.random.default_rng(8), np.random.default_rng(8)
    training = path_set(name)
    for _ in range(200):
        member = int(reference.choice(2, p=[1.0 - maze_weight, maze_weight]))
        track = training.sample(rng)
        expected = (random_path if member == 0 else random_maze)(reference)
        expected_path = expected if member == 0 else expected.path
        assert (track.maze is not None) == (member == 1)
        assert np.array_equal(track.path.points, expected_path.points)
        assert track.path.start_heading == expected_path.start_heading
    assert rng.bit_generator.state == reference.bit_generator.state


def random_poses(rng, count, extent):
    return np.column_stack(
        (
            rng.uniform(-1.0, extent + 1.0, count),
            rng.uniform(-1.0, extent + 1.0, count),
            rng.uniform(-np.pi, np.pi, count),
        )
    )


def test_packed_sensing_equals_each_robots_own_maze_bit_for_bit():
    rng = np.random.default_rng(9)
    sizes = [(8, 8, 1.5), (3, 5, 1.0), (12, 4, 0.75), (1, 1, 2.0), (8, 8, 1.5)]
    mazes = [
        Maze(rows, cols, cell_size, seed=index, origin=(0.3 * index, -0.2 * index))
        for index, (rows, cols, cell_size) in enumerate(sizes)
    ]
    count = 600
    pack = MazePack(count)
    robot_slots = np.full(count, -1, dtype=np.int64)
    owners = rng.integers(-1, len(mazes), count)  # -1: open space
    for robot, owner in enumerate(owners):
        if owner >= 0:
            robot_slots[robot] = pack.acquire(mazes[owner])
    assert len(pack) == len(mazes)
    state = np.zeros((count, 5))  # wider than a pose: the kernels read strided rows
    state[:, :3] = random_poses(rng, count, 12.0)
    angles = np.linspace(-np.pi, np.pi, 16, endpoint=False)
    collision = np.zeros(count, dtype=bool)
    ranges = np.full((count, 16), -7.0)
    robots = np.arange(count)
    pack.sense(state, robots, robot_slots, 0.3, angles, 3.0, collision, ranges)
    for index, maze in enumerate(mazes):
        mine = np.flatnonzero(owners == index)
        expected_collision = np.empty(len(mine), dtype=bool)
        expected_ranges = np.empty((len(mine), 16))
        maze.sense(state[mine], 0.3, angles, 3.0, expected_collision, expected_ranges)
        assert np.array_equal(collision[mine], expected_collision)
        assert np.array_equal(ranges[mine], expected_ranges)
    outside = owners < 0
    assert not collision[outside].any() and np.all(ranges[outside] == -7.0)
    assert 0 < collision.sum() < count


def test_packed_sensing_of_some_robots_and_of_collisions_alone():
    rng = np.random.default_rng(10)
    mazes = [random_maze(rng).maze for _ in range(30)]
    count = 200
    pack = MazePack(count)
    slots = np.array([pack.acquire(mazes[robot % 30]) for robot in range(count)])
    poses = random_poses(rng, count, 12.0)
    chosen = np.sort(rng.choice(count, 50, replace=False))
    collision = np.zeros(count, dtype=bool)
    pack.sense(poses, chosen, slots, 0.4, np.empty(0), 1.0, collision, np.empty((count, 0)))
    for robot in range(count):
        expected = mazes[robot % 30].collides(poses[robot], 0.4) if robot in chosen else False
        assert collision[robot] == expected


def test_maze_slots_are_shared_counted_and_reused():
    rng = np.random.default_rng(11)
    first, second, third = (random_maze(rng).maze for _ in range(3))
    pack = MazePack(2)
    slot = pack.acquire(first)
    assert pack.acquire(first) == slot and pack.users(slot) == 2
    other = pack.acquire(second)
    assert other != slot and len(pack) == 2
    pack.release(slot)
    assert pack.mazes[slot] is first
    pack.release(slot)
    assert pack.mazes[slot] is None and len(pack) == 1
    assert pack.acquire(third) == slot  # the freed slot, not a third one
    assert np.array_equal(pack.verticals[slot, :8, :9], third.vertical_walls)
    big = Maze(10, 12, seed=1)
    pack.release(other)
    big_slot = pack.acquire(big)  # wider than the packed grids: they grow, keeping the rest
    assert np.array_equal(pack.horizontals[big_slot, :11, :12], big.horizontal_walls)
    assert np.array_equal(pack.horizontals[slot, :9, :8], third.horizontal_walls)

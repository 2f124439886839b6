"""Tests of mobile_envs.world.paths against brute-force geometry and hand-computed values."""

import ast
import copy
import gc
import json
import math
import pickle
import weakref
from pathlib import Path as FilePath

import gymnasium as gym
import numpy as np
import pytest

import mobile_envs  # also registers the env ids
from mobile_envs._kernels.pcg64 import streams_of
from mobile_envs.tracks import (
    FixedPathSet,
    GeneratedPathSet,
    MixedPathSet,
    path_set,
    path_set_names,
    the_maze,
)
from mobile_envs.world.paths import (
    ARC_STRAIGHT_RADIUS,
    RANDOM_AREA,
    RANDOM_MAX_TURN,
    RANDOM_MISALIGNED_START_PROBABILITY,
    Path,
    PathTable,
    arc_straight_path,
    course_path,
    course_path_names,
    random_path,
    random_paths,
)

REFERENCE_FILE = FilePath(__file__).parents[2] / "shared/reference/course_paths.json"
PACKAGED_FILE = FilePath(__file__).parents[1] / "mobile_envs/data/course_paths.json"


def test_cross_track_error_is_positive_left_of_the_path():
    east = Path([[0.0, 0.0], [10.0, 0.0]])
    west = Path([[10.0, 0.0], [0.0, 0.0]])
    xy = np.array([[3.0, 0.5], [3.0, -0.5]])
    assert east.project(xy)[1] == pytest.approx([0.5, -0.5])
    assert west.project(xy)[1] == pytest.approx([-0.5, 0.5])
    s, error, segment = east.project((3.0, 0.5, 1.0))
    assert (s, error, segment) == (pytest.approx(3.0), pytest.approx(0.5), 0)
    assert isinstance(s, float) and isinstance(segment, int)


def walk_along(path, offset, step=0.05):
    """Positions a robot passes moving forward along the path at a fixed lateral offset."""
    s = np.arange(0.0, path.length, step)
    heading = path.heading_at(s)
    normal = np.column_stack((-np.sin(heading), np.cos(heading)))
    return path.point_at(s) + offset * normal


@pytest.mark.parametrize("offset", [-0.01, 0.0, 0.01])
@pytest.mark.parametrize("path", [course_path("segments"), arc_straight_path(), the_maze().path])
def test_hinted_projection_agrees_with_global_search_when_moving_forward(path, offset):
    # Close to the path and away from very sharp corners (where, inside the corner, a point
    # can lie nearer the segment the hint has already left), the two searches agree.
    positions = walk_along(path, offset)
    hint = 0
    for xy in positions:
        hinted = path.project(xy, hint=hint)
        assert hinted == path.project(xy)
        hint = hinted[2]
    assert hint == path.num_segments - 1


def test_hint_keeps_a_follower_on_its_own_part_of_a_self_crossing_path():
    # The last segment runs down x = 2 and crosses the first segment at (2, 0).
    loop = Path([[0.0, 0.0], [4.0, 0.0], [4.0, 2.0], [2.0, 2.0], [2.0, -2.0]])
    first_part = np.column_stack((np.linspace(0.5, 3.5, 61), np.full(61, 0.01)))
    last_part = np.column_stack((np.full(61, 2.01), np.linspace(1.5, -1.5, 61)))
    for positions, own_segment, s_of in (
        (first_part, 0, lambda xy: xy[0]),
        (last_part, 3, lambda xy: 10.0 - xy[1]),
    ):
        hint = loop.project(positions[0])[2]
        assert hint == own_segment
        for xy in positions:
            s, _, hint = loop.project(xy, hint=hint)
            assert hint == own_segment
            assert s == pytest.approx(s_of(xy))
    # Near the crossing the global search jumps to the other part.
    assert loop.project((2.001, 0.01))[2] == 3
    assert loop.project((2.01, 0.001))[2] == 0


def test_hint_search_is_bounded_by_the_search_distance():
    # Twenty 0.1 m segments: from hint 0 the search covers segments starting up to 1.05 m,
    # segments 0 to 10.
    path = Path(np.column_stack((np.linspace(0.0, 2.0, 21), np.zeros(21))))
    table = PathTable([path], search_distance=0.95)
    far = np.array([[1.75, 0.0]])
    s, _, segment = table.project([0], far, hint=[0])
    assert segment[0] == 10
    assert s[0] == pytest.approx(1.1)
    assert table.project([0], far)[2][0] == 17


def seeded_random_paths(count, seed):
    rng = np.random.default_rng(seed)
    return [Path(rng.uniform(0, 10, size=(rng.integers(2, 12), 2))) for _ in range(count)]


def test_path_table_equals_per_path_queries_exactly():
    paths = [*seeded_random_paths(5, 0), course_path("segments"), arc_straight_path()]
    table = PathTable(paths)
    rng = np.random.default_rng(1)
    rows = rng.integers(len(paths), size=300)
    xy = rng.uniform(-1, 11, size=(300, 2))
    s = rng.uniform(-1, 20, size=300)
    hint = rng.integers(0, 12, size=300)
    offsets = np.array([-0.5, 0.0, 0.3, 1.0, 30.0])
    pose = np.column_stack((xy, rng.uniform(-np.pi, np.pi, size=300)))

    batched = table.project(rows, xy)
    hinted = table.project(rows, xy, hint=hint)
    points = table.point_at(rows, s)
    headings = table.heading_at(rows, s)
    preview = table.preview(rows, pose, s, offsets)
    for i, row in enumerate(rows):
        path = paths[row]
        assert (batched[0][i], batched[1][i], batched[2][i]) == path.project(xy[i])
        clipped_hint = min(hint[i], path.num_segments - 1)
        assert (hinted[0][i], hinted[1][i], hinted[2][i]) == path.project(xy[i], clipped_hint)
        assert np.array_equal(points[i], path.point_at(s[i]))
        assert headings[i] == path.heading_at(s[i])
        assert np.array_equal(preview[i], path.preview(pose[i], s[i], offsets))
    assert np.array_equal(table.lengths, [path.length for path in paths])
    assert np.array_equal(table.goals, [path.goal for path in paths])


def test_set_path_replaces_a_row_with_a_longer_or_shorter_path():
    short, other = seeded_random_paths(2, 2)
    table = PathTable([short, short])
    long_path = arc_straight_path()
    table.set_path(1, long_path)
    assert table.paths[1] is long_path
    table.set_path(0, other)
    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 6, size=(50, 2))
    s = rng.uniform(0, 6, size=50)
    for row, path in enumerate((other, long_path)):
        rows = np.full(50, row)
        projected = table.project(rows, xy)
        for i in range(50):
            assert (projected[0][i], projected[1][i], projected[2][i]) == path.project(xy[i])
        assert np.array_equal(table.point_at(rows, s), path.point_at(s))
    table.set_path(0, Path([[0.0, 0.0], [100.0, 0.0]]))
    assert np.array_equal(table.point_at([0, 0], [50.0, 120.0]), [[50.0, 0.0], [100.0, 0.0]])


def test_rows_replaced_many_times_answer_as_their_own_paths_in_little_room():
    # Rows move to new slots, are rewritten in place and are laid out again as paths of
    # 1 to 200 segments come and go; every query must still be each path's own, and the
    # columns must hold about the live segments, not rows x the longest path.
    rng = np.random.default_rng(7)

    def a_path():
        count = int(rng.choice([2, 3, 5, 20, 201]))
        return Path(np.cumsum(rng.uniform(0.1, 1.0, size=(count, 2)), axis=0))

    table = PathTable([a_path() for _ in range(16)])
    most_live = 0
    for _ in range(40):
        for row in rng.choice(16, size=5, replace=False):
            table.set_path(int(row), a_path())
            live = sum(path.num_segments for path in table.paths)
            most_live = max(most_live, live)
            assert table.columns.shape[1] <= 1.5 * most_live + 1
        rows = rng.integers(16, size=40)
        xy = rng.uniform(0, 60, size=(40, 2))
        s = rng.uniform(-1, 120, size=40)
        hint = rng.integers(0, 250, size=40)
        projected = table.project(rows, xy, hint)
        points = table.point_at(rows, s)
        for i, row in enumerate(rows):
            path = table.paths[row]
            expected = path._table.project([0], xy[i : i + 1], hint[i : i + 1])
            assert [value[i] for value in projected] == [value[0] for value in expected]
            assert np.array_equal(points[i], path.point_at(s[i]))
    longest = max(path.num_segments for path in table.paths)
    assert table.columns.shape[1] < 16 * longest or longest < 50


def test_point_at_and_heading_at_by_hand():
    path = Path([[0.0, 0.0], [3.0, 0.0], [3.0, 4.0]])
    assert np.array_equal(path.point_at(1.5), [1.5, 0.0])
    assert np.array_equal(path.point_at(5.0), [3.0, 2.0])
    assert np.array_equal(path.point_at([-1.0, 100.0]), [[0.0, 0.0], [3.0, 4.0]])
    assert path.point_at(np.zeros((2, 3))).shape == (2, 3, 2)
    assert path.heading_at(1.0) == 0.0
    assert path.heading_at(4.0) == pytest.approx(np.pi / 2)
    assert path.heading_at(3.0) == pytest.approx(np.pi / 2)  # a vertex: the next segment
    assert np.array_equal(path.cumulative_length, [0.0, 3.0, 7.0])
    assert path.length == 7.0
    assert path.segment_headings == pytest.approx([0.0, np.pi / 2])


def test_preview_in_the_robot_frame_by_hand():
    path = Path([[0.0, 0.0], [10.0, 0.0]])
    # Heading +y, the robot's forward axis is +y and its left is -x.
    pose = (1.0, 1.0, np.pi / 2)
    expected = [[-1.0, 0.0], [-1.0, -1.0], [-1.0, -2.0]]
    assert path.preview(pose, 1.0, [0.0, 1.0, 2.0]) == pytest.approx(np.array(expected))
    clamped = path.preview((9.5, 0.0, 0.0), 9.5, [0.0, 1.0, 5.0])
    assert clamped == pytest.approx(np.array([[0.0, 0.0], [0.5, 0.0], [0.5, 0.0]]))
    batched = path.preview(np.array([pose, (9.5, 0.0, 0.0)]), [1.0, 9.5], [0.0, 1.0, 5.0])
    assert batched.shape == (2, 3, 2)
    assert batched[1] == pytest.approx(clamped)


def test_turn_angles_of_a_square():
    square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0]]
    half_pi = np.pi / 2
    assert Path(square).turn_angles == pytest.approx([0, half_pi, half_pi, half_pi, 0])
    clockwise = Path(square[::-1])
    assert clockwise.turn_angles == pytest.approx([0, -half_pi, -half_pi, -half_pi, 0])


def test_path_is_immutable_and_drops_consecutive_duplicates():
    path = Path([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 2.0]], name="p")
    assert np.array_equal(path.points, [[0.0, 0.0], [1.0, 0.0], [1.0, 2.0]])
    assert path.num_segments == 2
    assert np.array_equal(path.start_pose, [0.0, 0.0, 0.0])
    assert np.array_equal(path.goal, [1.0, 2.0])
    for array in (path.points, path.cumulative_length, path.turn_angles, path.segment_headings):
        with pytest.raises(ValueError):
            array[0] = 1.0
    with pytest.raises(AttributeError):
        path.name = "q"


@pytest.mark.parametrize(
    ("points", "message"),
    [
        ([[0.0, 0.0]], "at least two points"),
        ([[0.0, 0.0], [1.0, np.nan]], "finite"),
        ([[0.0, 0.0], [np.inf, 1.0]], "finite"),
        ([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]], "shape"),
        ([0.0, 1.0, 2.0], "shape"),
        ([[1.0, 1.0], [1.0, 1.0], [1.0, 1.0]], "zero length"),
        ([[1.0, 1.0], [1.0, 1.0 + 1e-12]], "zero length"),
        ([[0.0, 0.0], [1.0]], "array of numbers"),
        ([["a", "b"], [1.0, 2.0]], "array of numbers"),
        # Finite, but the length would be infinite (the reproducer).
        ([[-1e308, 0.0], [1e308, 0.0]], r"within 1e\+09 m .* point 0"),
        ([[0.0, 0.0], [0.0, -1.5e9]], r"within 1e\+09 m .* point 1"),
    ],
)
def test_bad_points_raise(points, message):
    with pytest.raises(ValueError, match=message):
        Path(points)


def test_a_path_as_large_as_allowed_has_finite_geometry():
    path = Path([[-1e9, -1e9], [1e9, 1e9], [1e9, -1e9]])
    assert path.length == pytest.approx(2 * math.sqrt(2) * 1e9 + 2e9)
    s, error, _ = path.project((0.0, 1e9))
    # Closest: (0.5e9, 0.5e9) on the diagonal, 1.5e9 sqrt(2) along it, left of it.
    assert (s, error) == (pytest.approx(1.5e9 * math.sqrt(2)), pytest.approx(math.sqrt(0.5) * 1e9))


@pytest.mark.parametrize("heading", [True, "north", None, np.nan])
def test_a_start_heading_that_is_no_finite_number_is_refused(heading):
    with pytest.raises(ValueError, match="start_heading"):
        Path([[0.0, 0.0], [1.0, 0.0]], start_heading=heading)


def test_numpy_scalars_are_valid_start_headings():
    assert Path([[0, 0], [1, 0]], start_heading=np.float32(0.5)).start_heading == 0.5


def test_bad_queries_raise():
    table = PathTable([course_path("segments")])
    with pytest.raises(ValueError, match="rows"):
        table.project([1], [[0.0, 0.0]])
    with pytest.raises(ValueError, match="xy"):
        table.project([0], [[0.0, 0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="hint"):
        table.project([0, 0], [[0.0, 0.0], [1.0, 1.0]], hint=[0])
    with pytest.raises(ValueError, match="search_distance"):
        PathTable([course_path("segments")], search_distance=-1.0)
    with pytest.raises(ValueError, match="at least one path"):
        PathTable([])


def test_from_file_reads_csv_with_header_and_blank_lines(tmp_path):
    file = tmp_path / "route.csv"
    file.write_text("x,y\n0,0\n\n 1.5 , 0\n1.5,2\n")
    path = Path.from_file(file)
    assert np.array_equal(path.points, [[0.0, 0.0], [1.5, 0.0], [1.5, 2.0]])
    assert path.name == "route"


def test_from_file_reads_json(tmp_path):
    file = tmp_path / "route.json"
    file.write_text(json.dumps([[0, 0], [1.5, 0], [1.5, 2]]))
    assert np.array_equal(Path.from_file(file).points, [[0.0, 0.0], [1.5, 0.0], [1.5, 2.0]])


def assert_rejected_naming_the_file(file, message):
    """``Path.from_file(file)`` raises a ValueError that matches ``message`` and names the
    file."""
    with pytest.raises(ValueError, match=message) as error:
        Path.from_file(file)
    assert str(file) in str(error.value)


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("bad.csv", "x,y\n0,0\n1,1\nabc,2\n", "line 4"),
        ("bad.csv", "0,0\n1,1,1\n", "line 2"),
        ("bad.csv", "0,0\n1,nan\n", "line 2"),
        ("bad.csv", "x,y\n0,0\n", "at least two points"),
        ("bad.csv", "", "at least two points"),
        ("bad.json", "[[0, 0], [1, 1]", "line 1, column"),
        ("bad.json", '[[0, 0], [1, 1], [2, "a"]]', "item 2"),
        ("bad.json", '{"x": 1}', "JSON list"),
        ("bad.json", "[[0, 0]]", "at least two points"),
        ("bad.json", "[[0, 0], [0, 0]]", "zero length"),
        ("bad.txt", "0,0\n1,1\n", "unknown path file type"),
    ],
)
def test_from_file_rejects_bad_files_naming_file_and_place(tmp_path, name, content, message):
    file = tmp_path / name
    file.write_text(content)
    assert_rejected_naming_the_file(file, message)


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("big.json", b"[[0, 0], [" + b"9" * 400 + b", 0]]", "item 1 .* too large"),
        ("bigger.json", b"[[0, 0], [" + b"9" * 5000 + b", 0]]", "invalid JSON"),
        ("huge.json", b"[[0, 0], [1e400, 0]]", "finite"),
        ("far.json", b"[[0, 0], [1e300, 0]]", "within"),
        ("deep.json", b"[" * 100_000 + b"]" * 100_000, "nested too deeply"),
        ("latin1.csv", "x,y\n0,0\n1,2\u00e9\n".encode("latin-1"), "not UTF-8 .* byte 11"),
        ("latin1.json", "[[0, 0], [1, 2]] \u00e9".encode("latin-1"), "not UTF-8"),
        ("far.csv", b"0,0\n1e300,0\n", "within"),
        ("nested.json", b"[[0, 0], [[[[[[[[1]]]]]]], 2]]", "item 1"),
    ],
)
def test_from_file_names_the_file_for_extreme_content(tmp_path, name, content, message):
    file = tmp_path / name
    file.write_bytes(content)
    assert_rejected_naming_the_file(file, message)


@pytest.mark.parametrize(
    ("name", "content"),
    [
        ("bom.csv", b"\xef\xbb\xbf0,0\n1.5,0\n1.5,2\n"),
        ("bom_header.csv", b"\xef\xbb\xbfx,y\r\n0,0\r\n1.5,0\r\n1.5,2\r\n"),
        ("bom.json", b"\xef\xbb\xbf[[0, 0], [1.5, 0], [1.5, 2]]"),
    ],
)
def test_from_file_accepts_a_utf8_byte_order_mark(tmp_path, name, content):
    file = tmp_path / name
    file.write_bytes(content)
    assert np.array_equal(Path.from_file(file).points, [[0.0, 0.0], [1.5, 0.0], [1.5, 2.0]])


def test_from_file_names_a_file_it_cannot_read(tmp_path):
    for file in (tmp_path / "missing.csv", tmp_path):
        target = file if file.suffix else file / "folder.json"
        if not file.suffix:
            target.mkdir()
        with pytest.raises(ValueError, match="cannot read") as error:
            Path.from_file(target)
        assert str(target) in str(error.value)


def test_course_waypoints_match_the_reference_file():
    packaged = json.loads(PACKAGED_FILE.read_text())
    for name in course_path_names():
        assert course_path(name).points.tolist() == packaged["paths"][name]
        assert np.array_equal(course_path(name).start_pose[2], 0.0)
    if not REFERENCE_FILE.exists():
        pytest.skip(f"reference file {REFERENCE_FILE} is not present")
    assert json.loads(REFERENCE_FILE.read_text()) == packaged


def test_lines_set_holds_the_three_lines():
    names = [track.path.name for track in path_set("lines").tracks]
    assert names == ["horizontal_line", "vertical_line", "diagonal_line"]


def test_arc_straight_geometry():
    path = arc_straight_path()
    heading = path.start_heading
    turn = np.sign(path.turn_angles[1])
    assert np.all(np.sign(path.turn_angles[1:-1]) == turn)
    centre = path.points[0] + turn * ARC_STRAIGHT_RADIUS * np.array(
        [-np.sin(heading), np.cos(heading)]
    )
    arc = path.points[:-1]
    assert np.hypot(*(arc - centre).T) == pytest.approx(ARC_STRAIGHT_RADIUS, abs=1e-12)
    assert path.segment_lengths[-1] == pytest.approx(3.0, abs=1e-12)
    assert path.segment_lengths[:-1].max() <= 0.05
    chords = path.num_segments - 1
    chord_length = 2 * ARC_STRAIGHT_RADIUS * np.sin(np.pi / 4 / chords)
    assert path.length == pytest.approx(chords * chord_length + 3.0, abs=1e-12)
    assert path.length == pytest.approx(ARC_STRAIGHT_RADIUS * np.pi / 2 + 3.0, abs=1e-3)
    # The start pose follows the arc's tangent, not the first chord.
    assert heading == pytest.approx(np.pi / 2)
    assert path.segment_headings[0] != pytest.approx(heading, abs=1e-3)


def test_random_paths_are_reproducible_bounded_and_varied():
    first = random_path(np.random.default_rng(7))
    assert np.array_equal(first.points, random_path(np.random.default_rng(7)).points)
    assert not np.array_equal(first.points, random_path(np.random.default_rng(8)).points)
    rng = np.random.default_rng(0)
    paths = [random_path(rng) for _ in range(300)]
    low, high = RANDOM_AREA
    largest_turns, aligned = [], 0
    for path in paths:
        assert low <= path.points.min() and path.points.max() <= high
        assert 8.0 <= path.length <= 26.0
        assert -np.pi <= path.start_heading <= np.pi
        aligned += path.start_heading == path.segment_headings[0]
        largest_turns.append(np.abs(path.turn_angles).max())
    # Most start along the first segment; RANDOM_MISALIGNED_START_PROBABILITY of them, like
    # the course's heading-0 starts, at any heading.
    expected_aligned = 300 * (1 - RANDOM_MISALIGNED_START_PROBABILITY)
    assert abs(aligned - expected_aligned) < 4 * np.sqrt(300 * 0.3 * 0.7)
    assert max(largest_turns) <= RANDOM_MAX_TURN + 1e-9
    assert sum(turn > np.radians(120) for turn in largest_turns) >= 10
    assert sum(turn < np.radians(20) for turn in largest_turns) >= 10  # smooth ones too


PATH_ARRAYS = ("points", "segment_lengths", "cumulative_length", "segment_headings", "turn_angles")


def assert_same_path(drawn, expected):
    for name in PATH_ARRAYS:
        assert np.array_equal(getattr(drawn, name), getattr(expected, name)), name
        assert not getattr(drawn, name).flags.writeable
    assert drawn.start_heading == expected.start_heading
    assert drawn.name == expected.name


def test_random_paths_of_many_generators_are_each_ones_random_path_bit_for_bit():
    seeds = range(200)
    alone = [np.random.default_rng(seed) for seed in seeds]
    together = [np.random.default_rng(seed) for seed in seeds]
    for _ in range(3):  # from advanced states too
        expected = [random_path(rng) for rng in alone]
        drawn = random_paths(together)
        for path, reference in zip(drawn, expected, strict=True):
            assert_same_path(path, reference)
        assert [rng.bit_generator.state for rng in together] == [
            rng.bit_generator.state for rng in alone
        ]
    # Generators numpy builds on another bit generator take the one-by-one draws.
    other = np.random.Generator(np.random.MT19937(5))
    reference = random_path(np.random.Generator(np.random.MT19937(5)))
    assert_same_path(random_paths([other, np.random.default_rng(1)])[0], reference)
    assert random_paths([]) == []


def test_a_batch_of_paths_has_the_geometry_of_its_points():
    # Brute force from each path's own points: numpy's differences, lengths and headings.
    for path in random_paths([np.random.default_rng(seed) for seed in range(50)]):
        delta = np.diff(path.points, axis=0)
        lengths = np.hypot(delta[:, 0], delta[:, 1])
        np.testing.assert_allclose(path.segment_lengths, lengths, rtol=1e-15)
        np.testing.assert_allclose(path.cumulative_length, np.r_[0, np.cumsum(lengths)], rtol=1e-12)
        # The C library's atan2 (numpy's arctan2 has other last bits on AVX-512 CPUs).
        headings = [math.atan2(dy, dx) for dx, dy in delta.tolist()]
        assert np.array_equal(
            path.segment_headings.view(np.int64), np.array(headings).view(np.int64)
        )
        turns = np.angle(np.exp(1j * np.diff(path.segment_headings)))
        np.testing.assert_allclose(path.turn_angles[1:-1], turns, atol=1e-12)
        assert path.turn_angles[0] == path.turn_angles[-1] == 0.0
        assert_same_path(path, Path(path.points, "random", path.start_heading))


def test_set_paths_equals_set_path_row_by_row_across_lay_outs():
    rng = np.random.default_rng(4)
    start = random_paths([np.random.default_rng(seed) for seed in range(8)])
    by_batch, one_by_one = PathTable(start), PathTable(start)
    for round_ in range(30):
        rows = [int(row) for row in rng.choice(8, size=int(rng.integers(1, 8)), replace=False)]
        generators = [np.random.default_rng(1000 * round_ + row) for row in rows]
        paths = random_paths(generators)
        if round_ % 3 == 0:  # a path of its own among the batch's
            paths[0] = Path(np.cumsum(rng.uniform(0.1, 1.0, size=(40, 2)), axis=0))
        by_batch.set_paths(rows, paths)
        for row, path in zip(rows, paths, strict=True):
            one_by_one.set_path(row, path)
        for table in (by_batch, one_by_one):
            for row, path in enumerate(table.paths):
                first, last = table.spans[row]
                expected = PathTable([path])
                assert np.array_equal(
                    table.columns[:, first : first + last + 1], expected.columns
                ), (round_, row)
    assert by_batch.columns.shape == one_by_one.columns.shape
    with pytest.raises(ValueError, match="2 rows and 1 paths"):
        by_batch.set_paths([0, 1], start[:1])
    with pytest.raises(ValueError, match="row must lie"):
        by_batch.set_paths([8], start[:1])


def test_paths_made_together_keep_no_memory_of_each_other_once_written():
    # Each path owns its arrays, and the batch's shared arrays go once a table has written
    # the paths: an env's restarts would otherwise keep every batch a live path came from.
    def owner(array):
        while array.base is not None:
            array = array.base
        return array

    paths = random_paths([np.random.default_rng(seed) for seed in range(6)])
    for path in paths:
        for name in PATH_ARRAYS:  # a buffer of the path's own numbers, 6 per point
            assert owner(getattr(path, name)).size == 6 * len(path.points) - 2
    batch = weakref.ref(paths[0]._geometry)
    table = PathTable(paths)
    table.set_paths(list(range(6)), paths)
    gc.collect()
    assert batch() is None
    assert all(
        np.array_equal(table.point_at([k], [0.0])[0], path.points[0])
        for k, path in enumerate(paths)
    )


@pytest.mark.parametrize("name", ["training", "random", "random_maze", "lines", "maze"])
def test_sample_many_draws_what_sample_draws_from_each_generator(name):
    alone = [np.random.default_rng(seed) for seed in range(40)]
    together = [np.random.default_rng(seed) for seed in range(40)]
    expected = [path_set(name).sample(rng) for rng in alone]
    drawn = path_set(name).sample_many(together)
    for track, reference in zip(drawn, expected, strict=True):
        assert_same_path(track.path, reference.path)
        assert (track.maze is None) == (reference.maze is None)
        if track.maze is not None:
            assert np.array_equal(track.maze.walls, reference.maze.walls)
    assert [rng.bit_generator.state for rng in together] == [
        rng.bit_generator.state for rng in alone
    ]
    if name == "training":
        assert 0 < sum(track.maze is not None for track in drawn) < len(drawn)


@pytest.mark.parametrize("name", ["training", "random", "random_maze", "lines", "maze"])
def test_sample_streams_draws_from_the_streams_and_leaves_the_generators_alone(name):
    together = [np.random.default_rng(seed) for seed in range(30)]
    untouched = [rng.bit_generator.state for rng in together]
    path_set(name).sample_streams(together, streams_of(together))
    assert [rng.bit_generator.state for rng in together] == untouched
    drawn, expected = _sampled_both_ways(path_set(name), range(30))
    for track, reference in zip(drawn, expected, strict=True):
        assert_same_path(track.path, reference.path)
        assert (track.maze is None) == (reference.maze is None)


def _sampled_both_ways(drawing_set, seeds):
    """The tracks ``drawing_set`` draws for generators seeded ``seeds`` through
    ``sample_streams``, and through ``sample`` one by one; the streams must end where
    ``sample`` leaves the generators."""
    alone = [np.random.default_rng(seed) for seed in seeds]
    together = [np.random.default_rng(seed) for seed in seeds]
    expected = [drawing_set.sample(rng) for rng in alone]
    streams = streams_of(together)
    drawn = drawing_set.sample_streams(together, streams)
    assert np.array_equal(streams, streams_of(alone))
    return drawn, expected


def test_a_mixture_samples_streams_for_one_robot_or_one_member_as_sample_does():
    """A restart of one robot (and one of robots that all drew the same member) hands the
    streams to that member as they are: the tracks and the streams are sample's."""
    members_drawn = set()
    for seed in range(40):
        (drawn,), (expected,) = _sampled_both_ways(path_set("training"), [seed])
        assert_same_path(drawn.path, expected.path)
        assert (drawn.maze is None) == (expected.maze is None)
        members_drawn.add(drawn.maze is None)
    assert members_drawn == {True, False}  # both members drew, each alone
    only_random = MixedPathSet([path_set("random"), path_set("random_maze")], [1.0, 0.0])
    for track, reference in zip(*_sampled_both_ways(only_random, range(6)), strict=True):
        assert_same_path(track.path, reference.path)


def test_a_mixture_with_a_member_drawing_in_python_samples_streams_as_one_by_one():
    mixture = MixedPathSet(
        [GeneratedPathSet("random_again", path_set("random").sample), path_set("lines")],
        [0.5, 0.5],
    )
    drawn, expected = _sampled_both_ways(mixture, range(20))
    names = {track.path.name for track in drawn}
    assert "random" in names and len(names) > 1  # both members drew
    for track, reference in zip(drawn, expected, strict=True):
        assert_same_path(track.path, reference.path)


@pytest.mark.parametrize(
    ("name", "draws"),
    [("segments", False), ("maze", False), ("lines", True), ("random", True), ("training", True)],
)
def test_a_set_says_whether_it_draws_from_the_generator(name, draws):
    rng = np.random.default_rng(0)
    before = rng.bit_generator.state
    path_set(name).sample(rng)
    assert path_set(name).draws is draws
    assert (rng.bit_generator.state != before) is draws


def test_a_generated_set_without_a_batch_function_samples_one_by_one():
    generated = GeneratedPathSet("random_again", path_set("random").sample)
    rngs = [np.random.default_rng(seed) for seed in range(5)]
    expected = [path_set("random").sample(np.random.default_rng(seed)) for seed in range(5)]
    for track, reference in zip(generated.sample_many(rngs), expected, strict=True):
        assert_same_path(track.path, reference.path)


def test_path_set_registry():
    names = path_set_names()
    for name in ["segments", "sharp_segments", "lines", "arc_straight", "random", "maze"]:
        assert name in names
    assert {"random_maze", "training", "horizontal_line"} <= set(names)
    with pytest.raises(ValueError, match=r"known path sets: .*segments"):
        path_set("nope")
    assert path_set("random").tracks == ()
    assert path_set("maze").tracks[0].maze is not None


@pytest.mark.parametrize("name", ["lines", "random", "random_maze", "training", "maze"])
def test_same_rng_state_draws_the_same_track(name):
    first = path_set(name).sample(np.random.default_rng(11))
    second = path_set(name).sample(np.random.default_rng(11))
    assert np.array_equal(first.path.points, second.path.points)
    assert (first.maze is None) == (second.maze is None)
    if first.maze is not None:
        assert np.array_equal(first.maze.walls, second.maze.walls)


def test_fixed_and_mixed_sets_draw_from_their_members():
    tracks = path_set("lines").tracks
    rng = np.random.default_rng(0)
    drawn = {path_set("lines").sample(rng).path.name for _ in range(50)}
    assert drawn == {track.path.name for track in tracks}
    training = [path_set("training").sample(rng) for _ in range(60)]
    in_maze = sum(track.maze is not None for track in training)
    assert 5 <= in_maze <= 30
    mix = MixedPathSet([path_set("segments"), path_set("lines")], [1.0, 0.0])
    assert {mix.sample(rng).path.name for _ in range(20)} == {"segments"}
    with pytest.raises(ValueError, match="weight"):
        MixedPathSet([path_set("segments")], [1.0, 2.0])
    with pytest.raises(ValueError, match="weights"):
        MixedPathSet([path_set("segments")], [-1.0])
    with pytest.raises(ValueError, match="at least one track"):
        FixedPathSet("empty", [])


def test_a_one_track_set_draws_what_numpy_integers_1_would_draw_nothing():
    # The one-track set skips rng.integers(1); numpy's integers(1) must indeed leave the
    # generator where it was, or every course env's start poses would shift.
    sampled, called = np.random.default_rng(5), np.random.default_rng(5)
    track = path_set("segments").sample(sampled)
    assert called.integers(1) == 0
    assert track is path_set("segments").tracks[0]
    assert sampled.bit_generator.state == called.bit_generator.state
    assert sampled.random() == called.random()


# ---------------------------------------------------------------------------------------------
# Paths that double back or cross themselves: the projection follows the robot's own progress

OUT_AND_BACK = [[0.0, 0.0], [5.0, 0.0], [0.0, 0.0]]
PARTIAL_REVERSAL = [[0.0, 0.0], [5.0, 0.0], [2.0, 0.0]]
THREE_OVERLAPPING_LEGS = [[0.0, 0.0], [4.0, 0.0], [1.0, 0.0], [4.0, 0.0]]
STATION_AND_BACK = [[1.0, 1.0], [4.0, 1.0], [4.0, 3.0], [4.0, 1.0], [1.0, 1.0]]


def figure_eight(points=121):
    """A lemniscate that starts at the top of its right lobe and crosses its centre (6, 6)
    twice, at t = pi and t = 2 pi."""
    t = np.linspace(np.pi / 2, 2.5 * np.pi - 0.5, points)
    return np.column_stack((6.0 + 4.0 * np.sin(t), 6.0 + 2.0 * np.sin(2.0 * t)))


DOUBLING_BACK = {
    "out_and_back": OUT_AND_BACK,
    "partial_reversal": PARTIAL_REVERSAL,
    "three_overlapping_legs": THREE_OVERLAPPING_LEGS,
    "station_and_back": STATION_AND_BACK,
    "figure_eight": figure_eight(),
}


def follow_with_hint(path, s_values):
    """Project poses walked exactly along the path, facing its direction, each from the
    previous step's segment: the projected arc lengths."""
    hint = 0
    projected = []
    for s in s_values:
        x, y = path.point_at(s)
        projected_s, error, hint = path.project((x, y, path.heading_at(s)), hint=hint)
        assert abs(error) < 1e-9
        projected.append(projected_s)
    return np.array(projected)


@pytest.mark.parametrize("points", DOUBLING_BACK.values(), ids=DOUBLING_BACK.keys())
def test_hinted_projection_follows_a_robot_along_legs_that_overlap_or_cross(points):
    # The truth is the arc length the robot walked: a leg it is not on, however close, never
    # takes the projection, not even where both legs lie in the search window.
    path = Path(points)
    s = np.arange(0.0, path.length, 0.02)
    np.testing.assert_allclose(follow_with_hint(path, s), s, rtol=0, atol=1e-9)


@pytest.mark.parametrize("points", DOUBLING_BACK.values(), ids=DOUBLING_BACK.keys())
def test_global_projection_takes_the_first_visit_of_a_point(points):
    # Brute force: of all the arc lengths at which the path passes through a point, the
    # smallest.
    path = Path(points)
    samples = np.linspace(0.0, path.length, 200_001)
    sample_points = path.point_at(samples)
    rng = np.random.default_rng(5)
    for s in rng.uniform(0.0, path.length, 60):
        xy = path.point_at(s)
        visits = samples[np.hypot(*(sample_points - xy).T) < 1e-4]
        projected_s, error, _ = path.project(xy)
        assert abs(error) < 1e-9
        assert projected_s == pytest.approx(visits.min(), abs=2e-4)


def test_a_point_on_a_return_leg_projects_onto_the_outward_leg_without_a_hint():
    # The reproducer: (2.5, 0) lies on both legs; it gave 7.5, the return leg.
    s, error, segment = Path(PARTIAL_REVERSAL).project((2.5, 0.0))
    assert (s, error, segment) == (pytest.approx(2.5), pytest.approx(0.0, abs=1e-12), 0)
    x = np.linspace(2.0, 5.0, 61)
    s, _, segment = Path(PARTIAL_REVERSAL).project(np.column_stack((x, np.zeros_like(x))))
    np.testing.assert_allclose(s, x, rtol=0, atol=1e-12)
    assert not segment.any()


def test_the_heading_chooses_the_leg_only_near_the_turn():
    path = Path(OUT_AND_BACK)  # the return leg starts 5 m along the path
    facing_back = (4.5, 0.0, math.pi)
    facing_out = (4.5, 0.0, 0.0)
    # From the outward leg, 0.5 m before the turn: both legs lie within the 1 m window.
    assert path.project(facing_out, hint=0)[0] == pytest.approx(4.5)
    assert path.project(facing_back, hint=0)[0] == pytest.approx(5.5)
    # 2 m before the turn the return leg is out of reach whatever the heading.
    assert path.project((3.0, 0.0, math.pi), hint=0)[0] == pytest.approx(3.0)
    # Without a heading, or without a hint, the earlier point.
    assert path.project((4.5, 0.0), hint=0)[0] == pytest.approx(4.5)
    assert path.project(facing_back)[0] == pytest.approx(4.5)
    # Once on the return leg, the outward leg lies behind the hint segment.
    assert path.project(facing_out, hint=1)[0] == pytest.approx(5.5)


# The environments score a robot on its own progress along a path that doubles back.

THERE_AND_BACK = Path([[0.0, 0.0], [3.0, 0.0], [0.0, 0.0]])  # 3 m out, 3 m back
FORWARD = np.array([0.6, 0.6], dtype=np.float32)  # 0.06 m a step straight ahead
ROTATE = np.array([-0.25, 0.25], dtype=np.float32)  # on the spot, 0.05 rad a step


class ThereAndBackDriver:
    """A differential-drive robot that drives out along x, turns on the spot where x reaches
    ``turn_at`` and drives back: the action for each pose."""

    def __init__(self, turn_at):
        self.turn_at = turn_at
        self.phase = "out"

    def action(self, pose):
        x, _, heading = pose
        if self.phase == "out" and x >= self.turn_at:
            self.phase = "turn"
        if self.phase == "turn" and abs(math.remainder(heading - math.pi, 2 * math.pi)) < 0.03:
            self.phase = "back"
        return ROTATE if self.phase == "turn" else FORWARD


def true_arc_length(pose, turn_at):
    """Where a robot on THERE_AND_BACK is along the path: on the way out until it faces back;
    then on the return leg, if it turned within the 1 m search window of the turn (else it is
    backing along the outward leg)."""
    x, _, heading = pose
    on_return_leg = math.cos(heading) < 0.0 and turn_at >= 3.0 - 1.0
    return min(max(6.0 - x, 3.0), 6.0) if on_return_leg else min(max(x, 0.0), 3.0)


TURN_POINTS = (1.2, 2.4, 3.0)  # far before the turn, within the window, at the turn


def drive_there_and_back(env, turn_at):
    """Drive one episode; the (pose, arc length, is_success) of every step."""
    _, info = env.reset(seed=0)
    driver = ThereAndBackDriver(turn_at)
    steps = []
    terminated = truncated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(driver.action(info["pose"]))
        steps.append((info["pose"], info["progress"] * THERE_AND_BACK.length, info["is_success"]))
    return steps


@pytest.mark.parametrize("turn_at", TURN_POINTS)
def test_the_env_scores_the_leg_the_robot_drives(turn_at):
    env = gym.make("mobile_envs/PathFollowing-v0", paths=THERE_AND_BACK)
    steps = drive_there_and_back(env, turn_at)
    for pose, s, _ in steps:
        assert s == pytest.approx(true_arc_length(pose, turn_at), abs=1e-6)
    successes = [success for _, _, success in steps]
    # Success needs the whole path: a robot that turned back early passes through the goal
    # (the start) without reaching it.
    assert successes[-1] == (turn_at > 2.0)
    assert not any(successes[:-1])


def test_the_vector_env_scores_each_robot_on_its_own_leg_as_single_envs_do():
    vector = gym.make_vec("mobile_envs/PathFollowing-v0", num_envs=3, paths=THERE_AND_BACK)
    single = gym.make("mobile_envs/PathFollowing-v0", paths=THERE_AND_BACK)
    expected = [drive_there_and_back(single, turn_at) for turn_at in TURN_POINTS]
    drivers = [ThereAndBackDriver(turn_at) for turn_at in TURN_POINTS]
    _, info = vector.reset(seed=0)
    done = np.zeros(3, dtype=bool)
    recorded = [[] for _ in TURN_POINTS]
    while not done.all():
        poses = info["pose"]
        actions = np.array(
            [driver.action(pose) for driver, pose in zip(drivers, poses, strict=True)]
        )
        _, _, terminated, truncated, info = vector.step(actions)
        for index in np.flatnonzero(~done):
            recorded[index].append(
                (info["progress"][index] * THERE_AND_BACK.length, info["is_success"][index])
            )
        done |= terminated | truncated
    for index, steps in enumerate(expected):
        assert recorded[index] == [(s, success) for _, s, success in steps]


def test_driving_straight_past_the_end_of_a_partial_reversal_is_no_success():
    # The reproducer: 34 steps at 0.06 m end at x = 2.04, by the goal (2, 0) but with
    # 6 of the 8 m never driven.
    for env in (
        gym.make("mobile_envs/PathFollowing-v0", paths=Path(PARTIAL_REVERSAL)),
        gym.make_vec("mobile_envs/PathFollowing-v0", num_envs=1, paths=Path(PARTIAL_REVERSAL)),
    ):
        _, info = env.reset(seed=0)
        for _ in range(34):
            action = FORWARD if not hasattr(env, "num_envs") else FORWARD[None]
            _, _, terminated, _, info = env.step(action)
            x = np.ravel(info["pose"])[0]
            assert np.ravel(info["progress"])[0] * 8.0 == pytest.approx(x, abs=1e-6)
            assert not np.any(terminated)
        assert x == pytest.approx(2.04, abs=1e-6)


# Copies: Ray, multiprocessing with spawn or forkserver and SB3's SubprocVecEnv pickle envs,
# and with them their path sets.

COPIES = {
    "pickle": lambda thing: pickle.loads(pickle.dumps(thing)),
    "deepcopy": copy.deepcopy,
}


def assert_same_track(first, second):
    assert np.array_equal(first.path.points, second.path.points)
    assert (first.path.name, first.path.start_heading) == (
        second.path.name,
        second.path.start_heading,
    )
    assert (first.maze is None) == (second.maze is None)
    if first.maze is not None:
        assert np.array_equal(first.maze.walls, second.maze.walls)


@pytest.mark.parametrize("make_copy", COPIES.values(), ids=COPIES.keys())
@pytest.mark.parametrize("name", path_set_names())
def test_every_path_set_survives_pickle_and_deepcopy(name, make_copy):
    original = path_set(name)
    duplicate = make_copy(original)
    assert type(duplicate) is type(original) and duplicate.name == original.name
    assert len(duplicate.tracks) == len(original.tracks)
    for mine, theirs in zip(original.tracks, duplicate.tracks, strict=True):
        assert_same_track(mine, theirs)
    for seed in range(4):  # the copy draws what the original draws
        assert_same_track(
            original.sample(np.random.default_rng(seed)),
            duplicate.sample(np.random.default_rng(seed)),
        )


@pytest.mark.parametrize("make_copy", COPIES.values(), ids=COPIES.keys())
def test_copies_of_paths_and_mazes_stay_immutable_and_answer_alike(make_copy):
    track = path_set("random_maze").sample(np.random.default_rng(2))
    path, maze = make_copy(track.path), make_copy(track.maze)
    for array in (path.points, path.cumulative_length, path.segment_lengths, path.turn_angles):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 1.0
    for array in (maze.walls, maze.origin):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 1.0
    xy = np.random.default_rng(0).uniform(0.0, 12.0, (50, 2))
    for mine, theirs in zip(track.path.project(xy), path.project(xy), strict=True):
        assert np.array_equal(mine, theirs)
    assert np.array_equal(track.maze.collides(xy, 0.25), maze.collides(xy, 0.25))


def test_paths_maze_and_tracks_import_one_way():
    # Data flows paths -> maze -> tracks: neither paths nor maze imports what builds on it,
    # and the geometry imports no physics.
    # ("_kernels": ``from mobile_envs._kernels import exact_math``, the C library's atan2.)
    allowed = {
        "_kernels/angles": set(),
        "_kernels/exact_math": set(),
        "world/geometry": set(),
        "_kernels/pcg64": set(),
        "_kernels/array_copies": set(),
        "world/paths": {
            "_kernels.angles",
            "_kernels",
            "world.geometry",
            "_kernels.pcg64",
            "_kernels.array_copies",
        },
        "world/maze": {"world.paths", "_kernels.pcg64", "_kernels.array_copies"},
        "tracks/sets": {"world.maze", "world.paths", "_kernels.pcg64"},
    }
    package = FilePath(mobile_envs.__file__).parent
    for module, imports in allowed.items():
        tree = ast.parse((package / f"{module}.py").read_text())
        imported = {
            node.module.removeprefix("mobile_envs.")
            for node in ast.walk(tree)
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("mobile_envs")
        }
        assert imported == imports, module

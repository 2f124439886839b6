"""Path geometry for path following: polylines, batched queries and the path catalogue.

A :class:`Path` is an immutable polyline with the queries a path follower needs: the projection
of a robot onto the path (arc length and signed cross-track error), the point and heading at an
arc length, and preview points in the robot frame. :class:`PathTable` packs many paths into
padded arrays so that N robots, each on its own path, are answered by one set of numpy calls.
A :class:`Path` answers its own queries through a one-row table: there is one copy of the
geometry.

The catalogue holds the course's paths (exact waypoints from ``data/course_paths.json``), seed
003's arc-and-straight validation path, random training paths and the mazes of
:mod:`mobile_envs.maze`, grouped into named :class:`PathSet` objects (see :func:`path_set`).
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import weakref
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache, partial
from importlib import resources
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mobile_envs.kinematics import wrap_angle

if TYPE_CHECKING:
    from mobile_envs.maze import Maze

DEFAULT_SEARCH_DISTANCE = 1.0
DUPLICATE_TOLERANCE = 1e-9  # m: consecutive points closer than this count as one

# Rows of the packed segment table, which holds one column per segment. A projection reads the
# first five for every segment it searches.
(
    _START_X,
    _START_Y,
    _DELTA_X,
    _DELTA_Y,
    _INV_LENGTH_SQ,
    _START_S,
    _LENGTH,
    _INV_LENGTH,
    _HEADING,
) = range(9)
_NUM_COLUMNS = 9

Projection = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]


def _read_only(array: NDArray) -> NDArray:
    array.flags.writeable = False
    return array


class Path:
    """An immutable polyline that a robot follows from its first point to its last.

    :param points: (M, 2) waypoints (m), M >= 2; consecutive duplicate points (closer than
        :data:`DUPLICATE_TOLERANCE`) are dropped.
    :param name: a label for logs and plots.
    :param start_heading: heading (rad) of :attr:`start_pose`; the course starts at heading 0.
    :raises ValueError: when the points are not an (M, 2) array of finite numbers with M >= 2,
        or all points coincide.
    """

    def __init__(
        self, points: ArrayLike, name: str | None = None, start_heading: float = 0.0
    ) -> None:
        try:
            points = np.array(points, dtype=np.float64)
        except (TypeError, ValueError) as error:
            raise ValueError(f"points must be an (M, 2) array of numbers: {error}") from None
        if points.ndim != 2 or points.shape[1] != 2:
            raise ValueError(f"points must have shape (M, 2), got {points.shape}")
        if len(points) < 2:
            raise ValueError(f"a path needs at least two points, got {len(points)}")
        not_finite = np.flatnonzero(~np.isfinite(points).all(axis=1))
        if not_finite.size:
            index = not_finite[0]
            raise ValueError(f"points must be finite; point {index} is {points[index].tolist()}")
        if not math.isfinite(start_heading):
            raise ValueError(f"start_heading must be finite, got {start_heading}")

        points, delta, segment_lengths = _drop_duplicates(points)
        if len(points) < 2:
            raise ValueError("the path has zero length: all its points are identical")

        segment_headings = np.arctan2(delta[:, 1], delta[:, 0])
        turn_angles = np.zeros(len(points))
        turn_angles[1:-1] = wrap_angle(np.diff(segment_headings))

        self._points = _read_only(points)
        self._segment_lengths = _read_only(segment_lengths)
        self._cumulative_length = _read_only(np.concatenate(([0.0], np.cumsum(segment_lengths))))
        self._segment_headings = _read_only(segment_headings)
        self._turn_angles = _read_only(turn_angles)
        self._name = name
        self._start_heading = float(start_heading)
        self._table = PathTable([self])

    @classmethod
    def from_file(cls, filename: str | os.PathLike[str], name: str | None = None) -> Path:
        """Read waypoints from a CSV or JSON file, chosen by the file's extension.

        CSV: ``x,y`` on each line; blank lines are ignored and the first line may be a header.
        JSON: a list of ``[x, y]`` pairs.

        :param filename: a ``.csv`` or ``.json`` file.
        :param name: the path's name; the file name without extension when None.
        :raises ValueError: for an unknown extension, malformed content (the message names the
            file and the line, or the item or JSON error position) or points that make no path.
        """
        file = pathlib.Path(filename)
        readers = {".csv": _read_csv_points, ".json": _read_json_points}
        reader = readers.get(file.suffix.lower())
        if reader is None:
            raise ValueError(f"{file}: unknown path file type {file.suffix!r}; use .csv or .json")
        points = reader(file)
        try:
            return cls(points, name=file.stem if name is None else name)
        except ValueError as error:
            raise ValueError(f"{file}: {error}") from None

    @property
    def points(self) -> NDArray[np.float64]:
        """(M, 2) vertices (m), read-only."""
        return self._points

    @property
    def num_segments(self) -> int:
        """Number of segments, M - 1."""
        return len(self._segment_lengths)

    @property
    def length(self) -> float:
        """Total arc length (m)."""
        return float(self._cumulative_length[-1])

    @property
    def cumulative_length(self) -> NDArray[np.float64]:
        """(M,) arc length (m) at each vertex, starting at 0."""
        return self._cumulative_length

    @property
    def segment_lengths(self) -> NDArray[np.float64]:
        """(M - 1,) length (m) of each segment."""
        return self._segment_lengths

    @property
    def segment_headings(self) -> NDArray[np.float64]:
        """(M - 1,) heading (rad) of each segment, in [-pi, pi]."""
        return self._segment_headings

    @property
    def turn_angles(self) -> NDArray[np.float64]:
        """(M,) signed turn (rad, positive to the left) at each vertex; 0 at the two ends.

        A curvature proxy: a sharp corner turns by nearly pi, a densified arc by a little at
        each vertex.
        """
        return self._turn_angles

    @property
    def name(self) -> str | None:
        """The label given at construction."""
        return self._name

    @property
    def start_heading(self) -> float:
        """Heading (rad) of the start pose."""
        return self._start_heading

    @property
    def start_pose(self) -> NDArray[np.float64]:
        """(3,) start pose (x, y, heading): the first point, heading :attr:`start_heading`."""
        return _read_only(np.array([*self._points[0], self._start_heading]))

    @property
    def goal(self) -> NDArray[np.float64]:
        """(2,) the last point (m)."""
        return self._points[-1]

    def project(
        self, xy: ArrayLike, hint: ArrayLike | int | None = None
    ) -> Projection | tuple[float, float, int]:
        """Project robots onto the path: see :meth:`PathTable.project`.

        :param xy: (N, 2) positions or (N, 3) poses; (2,) or (3,) for one robot.
        :param hint: segment index per robot from the previous step (an int for one robot),
            or None for a global search.
        :return: (s, cross_track_error, segment_index): arrays of shape (N,), or a float, a
            float and an int for one robot.
        """
        xy = np.asarray(xy, dtype=np.float64)
        single = xy.ndim == 1
        positions = xy.reshape(1, -1) if single else xy
        if single and hint is not None:
            hint = [hint]
        rows = np.zeros(len(positions), dtype=np.intp)
        s, cross_track_error, segment = self._table.project(rows, positions, hint)
        if single:
            return float(s[0]), float(cross_track_error[0]), int(segment[0])
        return s, cross_track_error, segment

    def point_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Points at arc lengths s (any shape), clamped to [0, length]: shape s.shape + (2,)."""
        s = np.asarray(s, dtype=np.float64)
        flat_s = s.reshape(-1)
        points = self._table._point_at(np.zeros(flat_s.shape, dtype=np.intp), flat_s)
        return points.reshape((*s.shape, 2))

    def heading_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Path headings (rad) at arc lengths s (any shape), clamped to [0, length].

        At a vertex the heading is that of the segment starting there.
        """
        s = np.asarray(s, dtype=np.float64)
        flat_s = s.reshape(-1)
        headings = self._table._heading_at(np.zeros(flat_s.shape, dtype=np.intp), flat_s)
        return headings.reshape(s.shape)

    def preview(self, pose: ArrayLike, s: ArrayLike, offsets: ArrayLike) -> NDArray[np.float64]:
        """Path points ahead of robots, in each robot's frame: see :meth:`PathTable.preview`.

        :param pose: (N, 3) poses, or (3,) for one robot.
        :param s: (N,) arc lengths (a scalar for one robot) the offsets count from.
        :param offsets: (K,) arc length offsets (m).
        :return: (N, K, 2), or (K, 2) for one robot: (forward, left) coordinates (m).
        """
        pose = np.asarray(pose, dtype=np.float64)
        if pose.ndim == 1:
            return self.preview(pose[None], np.reshape(s, 1), offsets)[0]
        rows = np.zeros(len(pose), dtype=np.intp)
        return self._table.preview(rows, pose, s, offsets)

    def __repr__(self) -> str:
        return f"Path(name={self._name!r}, points={len(self._points)}, length={self.length:.3f})"


def _drop_duplicates(
    points: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Drop each point closer than DUPLICATE_TOLERANCE to the one before it.

    Such a segment has no direction, and the inverse of its length could overflow. Dropping
    points can bring other points closer together, so this repeats until no short segment is
    left (one pass for any sensible path).

    :return: the remaining points, their differences and the segment lengths.
    """
    while True:
        delta = np.diff(points, axis=0)
        segment_lengths = np.hypot(delta[:, 0], delta[:, 1])
        short = segment_lengths < DUPLICATE_TOLERANCE
        if not short.any():
            return points, delta, segment_lengths
        points = points[np.concatenate(([True], ~short))]


def _parse_number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _read_csv_points(file: pathlib.Path) -> NDArray[np.float64]:
    points = []
    first_line = True
    for number, line in enumerate(file.read_text().splitlines(), start=1):
        if not line.strip():
            continue
        values = [_parse_number(field) for field in line.split(",")]
        if first_line and all(value is None for value in values):
            first_line = False
            continue  # a header such as "x,y"
        first_line = False
        if len(values) != 2 or None in values or not all(map(math.isfinite, values)):
            raise ValueError(
                f"{file}, line {number}: expected 'x,y' with two finite numbers, "
                f"got {line.strip()!r}"
            )
        points.append(values)
    return np.array(points, dtype=np.float64).reshape(-1, 2)


def _read_json_points(file: pathlib.Path) -> NDArray[np.float64]:
    try:
        data = json.loads(file.read_text())
    except json.JSONDecodeError as error:
        raise ValueError(
            f"{file}: invalid JSON at line {error.lineno}, column {error.colno}: {error.msg}"
        ) from None
    if not isinstance(data, list):
        raise ValueError(
            f"{file}: expected a JSON list of [x, y] points, got {type(data).__name__}"
        )
    for index, item in enumerate(data):
        is_pair = isinstance(item, list) and len(item) == 2
        if not is_pair or not all(
            isinstance(value, (int, float)) and not isinstance(value, bool) for value in item
        ):
            raise ValueError(f"{file}: item {index} is not an [x, y] pair of numbers: {item!r}")
    return np.array(data, dtype=np.float64).reshape(-1, 2)


def _packed_segments(path: Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The packed segment columns of one path, (columns, M - 1), and its padding column.

    Padding repeats the last vertex: zero-length segments at the goal that start at the path's
    full arc length, so an arc-length lookup past the end lands on the goal. Their inverse
    lengths are 0, which guards the divisions. Paths are immutable, so this is computed once
    per path: resets that reuse a path (every course set) only copy it.
    """
    cached = _PACKED_SEGMENTS.get(path)
    if cached is not None:
        return cached
    points = path.points
    columns = np.empty((_NUM_COLUMNS, path.num_segments))
    columns[_START_X] = points[:-1, 0]
    columns[_START_Y] = points[:-1, 1]
    columns[_DELTA_X] = np.diff(points[:, 0])
    columns[_DELTA_Y] = np.diff(points[:, 1])
    columns[_INV_LENGTH] = 1.0 / path.segment_lengths
    columns[_INV_LENGTH_SQ] = columns[_INV_LENGTH] ** 2
    columns[_START_S] = path.cumulative_length[:-1]
    columns[_LENGTH] = path.segment_lengths
    columns[_HEADING] = path.segment_headings
    padding = np.zeros(_NUM_COLUMNS)
    padding[_START_X], padding[_START_Y] = path.goal
    padding[_START_S] = path.length
    padding[_HEADING] = path.segment_headings[-1]
    _PACKED_SEGMENTS[path] = columns, padding
    return columns, padding


_PACKED_SEGMENTS: weakref.WeakKeyDictionary[Path, tuple[NDArray, NDArray]] = (
    weakref.WeakKeyDictionary()
)
#: Hinted-search window width of each path, per search distance.
_WINDOW_WIDTHS: weakref.WeakKeyDictionary[Path, dict[float, int]] = weakref.WeakKeyDictionary()


def _window_width(cumulative_length: NDArray[np.float64], search_distance: float) -> int:
    """Number of segments a hinted projection must search on this path, from its hint on.

    From hint segment k the search covers k, k + 1, and every later segment that starts at most
    ``search_distance`` beyond the end of k; the widest such window over all k.
    """
    num_segments = len(cumulative_length) - 1
    segment_ends = cumulative_length[1:]
    last_vertex = np.searchsorted(cumulative_length, segment_ends + search_distance, "right") - 1
    last_segment = np.minimum(last_vertex, num_segments - 1)
    return max(2, int(np.max(last_segment - np.arange(num_segments))) + 1)


class PathTable:
    """P paths packed into padded arrays, queried for N robots at once.

    Robot i follows path ``rows[i]``, and many robots may share a row. Every query is a fixed
    number of numpy calls whatever N and P are; no Python loop runs over robots or segments.
    The segment data lives in one (columns, P, width) array, padded to the widest path by
    repeating each path's last vertex (see :func:`_packed_segments`).

    :param paths: the paths, one per row.
    :param search_distance: how far (m of arc length) beyond the end of its hint segment a
        hinted projection looks for the closest segment.
    """

    def __init__(
        self, paths: Sequence[Path], search_distance: float = DEFAULT_SEARCH_DISTANCE
    ) -> None:
        paths = tuple(paths)
        if not paths:
            raise ValueError("a PathTable needs at least one path")
        for index, path in enumerate(paths):
            _check_path(path, f"paths[{index}]")
        if not (math.isfinite(search_distance) and search_distance >= 0):
            raise ValueError(f"search_distance must be finite and >= 0, got {search_distance}")
        self._search_distance = float(search_distance)
        self._paths = list(paths)
        self._pack(max(path.num_segments for path in paths))

    def _pack(self, width: int) -> None:
        num_rows = len(self._paths)
        self._width = width
        self._columns = np.empty((_NUM_COLUMNS, num_rows, width))
        # Flat views: robot i's segment j lives at column rows[i] * width + j.
        self._flat_columns = self._columns.reshape(_NUM_COLUMNS, num_rows * width)
        self._lengths = np.empty(num_rows)
        self._goals = np.empty((num_rows, 2))
        self._last_segment = np.empty(num_rows, dtype=np.intp)
        self._windows = np.empty(num_rows, dtype=np.intp)
        for row, path in enumerate(self._paths):
            self._write_row(row, path)
        self._window = int(self._windows.max())
        self._index_arc_lengths()

    def _write_row(self, row: int, path: Path) -> None:
        segments, padding = _packed_segments(path)
        self._columns[:, row, : path.num_segments] = segments
        self._columns[:, row, path.num_segments :] = padding[:, None]
        self._lengths[row] = path.length
        self._goals[row] = path.goal
        self._last_segment[row] = path.num_segments - 1
        windows = _WINDOW_WIDTHS.setdefault(path, {})
        if self._search_distance not in windows:
            windows[self._search_distance] = _window_width(
                path.cumulative_length, self._search_distance
            )
        self._windows[row] = windows[self._search_distance]

    def _index_arc_lengths(self, row: int | None = None) -> None:
        """Offset each row's segment start arc lengths so one searchsorted serves all rows.

        Row r's keys are its start arc lengths plus r * spacing, with an integer spacing longer
        than any path: the keys of all rows form one sorted array, and the offsets are exact.
        Adding an offset rounds monotonically, so a lookup within a rounding error (1e-10 m for
        10,000 rows of 25 m paths) before a vertex may find the next segment, where the
        fraction clamps to 0: the point found is the vertex.
        """
        starts = self._columns[_START_S]
        if row is None or self._lengths[row] >= self._key_spacing:
            self._key_spacing = math.ceil(self._lengths.max()) + 1.0
            offsets = np.arange(len(self._paths))[:, None] * self._key_spacing
            self._keys = (starts + offsets).ravel()
        else:
            self._keys.reshape(starts.shape)[row] = starts[row] + row * self._key_spacing

    def set_path(self, row: int, path: Path) -> None:
        """Replace the path of one row, widening the padding when the new path is longer.

        :param row: the row to replace, in [0, P).
        :param path: the new path.
        """
        if not 0 <= row < len(self._paths):
            raise ValueError(f"row must lie in [0, {len(self._paths)}), got {row}")
        _check_path(path, "path")
        self._paths[row] = path
        if path.num_segments > self._width:
            self._pack(path.num_segments)
        else:
            self._write_row(row, path)
            # A window wider than a row needs finds the same segment (see _project), so the
            # width only grows here instead of a max over every row on each reset.
            self._window = max(self._window, int(self._windows[row]))
            self._index_arc_lengths(row)

    @property
    def paths(self) -> tuple[Path, ...]:
        """The path of each row."""
        return tuple(self._paths)

    @property
    def search_distance(self) -> float:
        """Arc length (m) a hinted projection searches beyond the end of its hint segment."""
        return self._search_distance

    @property
    def window_width(self) -> int:
        """Segments a hinted projection examines per robot, the widest window of any row."""
        return self._window

    @property
    def lengths(self) -> NDArray[np.float64]:
        """(P,) length (m) of each row's path, read-only."""
        return _read_only(self._lengths.view())

    @property
    def goals(self) -> NDArray[np.float64]:
        """(P, 2) last point (m) of each row's path, read-only."""
        return _read_only(self._goals.view())

    def __len__(self) -> int:
        return len(self._paths)

    def project(self, rows: ArrayLike, xy: ArrayLike, hint: ArrayLike | None = None) -> Projection:
        """Project robots onto their paths: the closest point of each robot's path.

        Without a hint every segment is searched. With a hint (each robot's segment index from
        the previous step) the search walks forward from the hint segment, as MATLAB's
        controllerPurePursuit does: it covers the hint segment, the next one, and the later
        segments that start within :attr:`search_distance` beyond the end of the hint segment.
        That costs :attr:`window_width` segments per robot, however long the path, and keeps
        a robot on its own part of a path that crosses itself. Ties go to the earliest segment.

        :param rows: (N,) the row (path) of each robot.
        :param xy: (N, 2) positions or (N, 3) poses (m); only x and y are used.
        :param hint: (N,) segment indices (clipped to each path's segments), or None for a
            global search.
        :return: (s, cross_track_error, segment_index), each (N,): the arc length (m) of the
            closest point; the distance (m) to it, positive when the robot is left of the
            path's direction (the side is that of the closest segment's line); the closest
            segment (int64).
        """
        rows = self._check_rows(rows)
        xy = _check_points(xy, len(rows), "xy", widths=(2, 3))
        if hint is None:
            first = np.zeros(len(rows), dtype=np.intp)
            return self._project(rows, xy[:, 0], xy[:, 1], first, self._width, windowed=False)
        hint = np.asarray(hint)
        if hint.shape != rows.shape or not np.issubdtype(hint.dtype, np.integer):
            raise ValueError(
                f"hint must be an integer array of shape {rows.shape}, "
                f"got shape {hint.shape} and dtype {hint.dtype}"
            )
        first = np.clip(hint, 0, self._last_segment[rows])
        return self._project(rows, xy[:, 0], xy[:, 1], first, self._window, windowed=True)

    def _project(
        self,
        rows: NDArray[np.intp],
        x: NDArray[np.float64],
        y: NDArray[np.float64],
        first: NDArray[np.intp],
        width: int,
        windowed: bool,
    ) -> Projection:
        """Closest point among ``width`` segments per robot, from segment ``first`` on."""
        # Segments past a path's end repeat its last segment: argmin keeps the first copy.
        segment = first[:, None] + np.arange(width)
        np.minimum(segment, self._last_segment[rows][:, None], out=segment)
        flat = segment + (rows * self._width)[:, None]
        columns = self._flat_columns
        delta_x = np.take(columns[_DELTA_X], flat)
        delta_y = np.take(columns[_DELTA_Y], flat)
        offset_x = x[:, None] - np.take(columns[_START_X], flat)
        offset_y = y[:, None] - np.take(columns[_START_Y], flat)
        fraction = offset_x * delta_x
        fraction += offset_y * delta_y
        fraction *= np.take(columns[_INV_LENGTH_SQ], flat)
        _clip_to_unit(fraction)
        gap_x = offset_x - fraction * delta_x
        gap_y = offset_y - fraction * delta_y
        distance_sq = gap_x * gap_x
        distance_sq += gap_y * gap_y
        if windowed and width > 2:
            # Columns 0 and 1 (the hint segment and the next) always count; a later segment
            # counts if it starts within search_distance beyond the hint segment's end.
            start_s = np.take(columns[_START_S], flat)
            limit = start_s[:, 1:2] + self._search_distance
            np.putmask(distance_sq, start_s > limit, np.inf)

        pick = np.arange(len(rows)) * width + np.argmin(distance_sq, axis=1)
        chosen = flat.ravel()[pick]
        s = columns[_START_S][chosen] + fraction.ravel()[pick] * columns[_LENGTH][chosen]
        side = delta_x.ravel()[pick] * offset_y.ravel()[pick]
        side -= delta_y.ravel()[pick] * offset_x.ravel()[pick]
        cross_track_error = np.copysign(np.sqrt(distance_sq.ravel()[pick]), side)
        return s, cross_track_error, segment.ravel()[pick].astype(np.int64, copy=False)

    def point_at(self, rows: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
        """Points of each robot's path at arc lengths s, clamped to [0, length].

        :param rows: (N,) the row of each robot.
        :param s: (N,) or (N, K) arc lengths (m).
        :return: s.shape + (2,) points (m).
        """
        rows, s = self._check_arc_lengths(rows, s)
        return self._point_at(rows, s)

    def heading_at(self, rows: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
        """Path headings (rad) at arc lengths s, like :meth:`point_at`; s.shape."""
        rows, s = self._check_arc_lengths(rows, s)
        return self._heading_at(rows, s)

    def preview(
        self, rows: ArrayLike, pose: ArrayLike, s: ArrayLike, offsets: ArrayLike
    ) -> NDArray[np.float64]:
        """Path points ahead of each robot, in the robot's frame.

        :param rows: (N,) the row of each robot.
        :param pose: (N, 3) poses (x, y, heading).
        :param s: (N,) arc lengths (m) the offsets count from, usually the projection's s.
        :param offsets: (K,) arc length offsets (m); points past the path's end are its goal.
        :return: (N, K, 2) coordinates (m): x forward, y to the left of the robot.
        """
        rows = self._check_rows(rows)
        pose = _check_points(pose, len(rows), "pose", widths=(3,))
        s = np.asarray(s, dtype=np.float64)
        offsets = np.asarray(offsets, dtype=np.float64)
        if s.shape != rows.shape or offsets.ndim != 1:
            raise ValueError(
                f"s must have shape {rows.shape} and offsets shape (K,), "
                f"got {s.shape} and {offsets.shape}"
            )
        x, y = self._point_xy(rows[:, None], s[:, None] + offsets)
        to_x = x - pose[:, 0:1]
        to_y = y - pose[:, 1:2]
        cos = np.cos(pose[:, 2:3])
        sin = np.sin(pose[:, 2:3])
        return _pair(cos * to_x + sin * to_y, cos * to_y - sin * to_x)

    def _locate(
        self, rows: NDArray[np.intp], s: NDArray[np.float64]
    ) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """Flat segment index and fraction along it of arc length s on path ``rows``.

        ``rows`` broadcasts against ``s``. One searchsorted over the offset keys of all rows
        (see :meth:`_index_arc_lengths`); s on a vertex finds the segment that starts there.
        """
        s = np.minimum(np.maximum(s, 0.0), self._lengths[rows])
        flat = np.searchsorted(self._keys, s + rows * self._key_spacing, side="right") - 1
        # The path's end lands on a padding segment: step back to the last real one.
        np.minimum(flat, rows * self._width + self._last_segment[rows], out=flat)
        columns = self._flat_columns
        fraction = (s - columns[_START_S][flat]) * columns[_INV_LENGTH][flat]
        return flat, _clip_to_unit(fraction)

    def _point_at(self, rows: NDArray[np.intp], s: NDArray[np.float64]) -> NDArray[np.float64]:
        return _pair(*self._point_xy(rows, s))

    def _point_xy(
        self, rows: NDArray[np.intp], s: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        flat, fraction = self._locate(rows, s)
        columns = self._flat_columns
        x = columns[_DELTA_X][flat]
        x *= fraction
        x += columns[_START_X][flat]
        y = columns[_DELTA_Y][flat]
        y *= fraction
        y += columns[_START_Y][flat]
        return x, y

    def _heading_at(self, rows: NDArray[np.intp], s: NDArray[np.float64]) -> NDArray[np.float64]:
        flat, _ = self._locate(rows, s)
        return self._flat_columns[_HEADING][flat]

    def _check_rows(self, rows: ArrayLike) -> NDArray[np.intp]:
        rows = np.asarray(rows)
        if rows.ndim != 1 or not np.issubdtype(rows.dtype, np.integer):
            raise ValueError(
                f"rows must be a 1-D integer array, got shape {rows.shape} and dtype {rows.dtype}"
            )
        if rows.size and (rows.min() < 0 or rows.max() >= len(self._paths)):
            raise ValueError(
                f"rows must lie in [0, {len(self._paths)}), "
                f"got values from {rows.min()} to {rows.max()}"
            )
        return rows.astype(np.intp, copy=False)

    def _check_arc_lengths(
        self, rows: ArrayLike, s: ArrayLike
    ) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """Rows shaped to broadcast against s, which must be (N,) or (N, K)."""
        rows = self._check_rows(rows)
        s = np.asarray(s, dtype=np.float64)
        if s.ndim not in (1, 2) or len(s) != len(rows):
            raise ValueError(f"s must have shape ({len(rows)},) or ({len(rows)}, K), got {s.shape}")
        return rows.reshape((-1,) + (1,) * (s.ndim - 1)), s


# np.clip and np.stack cost microseconds of Python each; these run on every step.
def _clip_to_unit(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Clip to [0, 1] in place."""
    np.maximum(values, 0.0, out=values)
    return np.minimum(values, 1.0, out=values)


def _pair(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Stack two equally shaped arrays along a new last axis."""
    pairs = np.empty((*x.shape, 2))
    pairs[..., 0] = x
    pairs[..., 1] = y
    return pairs


def _check_path(path: object, label: str) -> None:
    if not isinstance(path, Path):
        raise ValueError(f"{label} must be a Path, got {type(path).__name__}")


def _check_points(
    array: ArrayLike, count: int, label: str, widths: tuple[int, ...]
) -> NDArray[np.float64]:
    array = np.asarray(array, dtype=np.float64)
    if array.ndim != 2 or len(array) != count or array.shape[1] not in widths:
        shapes = " or ".join(f"({count}, {width})" for width in widths)
        raise ValueError(f"{label} must have shape {shapes}, got {array.shape}")
    return array


# ---------------------------------------------------------------------------------------------
# The course's paths and seed 003's validation path

LINE_NAMES = ("horizontal_line", "vertical_line", "diagonal_line")


@cache
def _course_data() -> dict:
    data_file = resources.files("mobile_envs").joinpath("data/course_paths.json")
    return json.loads(data_file.read_text(encoding="utf-8"))


def course_path_names() -> tuple[str, ...]:
    """Names of the course's paths: segments, sharp_segments and the three lines."""
    return tuple(_course_data()["paths"])


def course_path(name: str) -> Path:
    """One of the course's paths, with its exact waypoints; it starts at heading 0.

    :param name: one of :func:`course_path_names`.
    """
    waypoints = _course_data()["paths"]
    if name not in waypoints:
        raise ValueError(f"unknown course path {name!r}; known: {', '.join(waypoints)}")
    return Path(waypoints[name], name=name)


ARC_STRAIGHT_RADIUS = 1.24
ARC_STRAIGHT_SWEEP = -math.pi / 2
ARC_STRAIGHT_STRAIGHT_LENGTH = 3.0
# 5 cm chords leave a sagitta of chord^2 / (8 radius) = 0.25 mm between chord and arc, far below
# the 16.5 mm lateral errors seed 003 reports.
ARC_STRAIGHT_CHORD = 0.05
ARC_STRAIGHT_START = (1.0, 1.0)
ARC_STRAIGHT_START_HEADING = math.pi / 2


def _arc_points(
    start: NDArray[np.float64], heading: float, radius: float, sweep: float, max_chord: float
) -> NDArray[np.float64]:
    """Points after ``start`` along a circular arc, at equal chords of at most ``max_chord``.

    :param start: (2,) where the arc starts, heading ``heading`` (rad).
    :param sweep: signed turn (rad); positive turns left.
    """
    turn = math.copysign(1.0, sweep)
    centre = start + turn * radius * np.array([-math.sin(heading), math.cos(heading)])
    count = math.ceil(radius * abs(sweep) / max_chord)
    angles = heading + np.linspace(0.0, sweep, count + 1)[1:]
    return centre + turn * radius * np.column_stack((np.sin(angles), -np.cos(angles)))


def arc_straight_path() -> Path:
    """Seed 003's validation run: a circular arc of radius 1.24 m, then a 3 m straight.

    The arc starts at (1, 1) heading north (+y) and turns right by 90 degrees, so the straight
    runs east to (5.24, 2.24). The arc is densified into equal chords of at most 5 cm (a
    sagitta of 0.25 mm); the straight is one segment. The start pose heads along the arc's
    tangent, pi/2, rather than along the first chord.
    """
    start = np.array(ARC_STRAIGHT_START)
    heading = ARC_STRAIGHT_START_HEADING
    arc = _arc_points(start, heading, ARC_STRAIGHT_RADIUS, ARC_STRAIGHT_SWEEP, ARC_STRAIGHT_CHORD)
    end_heading = heading + ARC_STRAIGHT_SWEEP
    straight_end = arc[-1] + ARC_STRAIGHT_STRAIGHT_LENGTH * np.array(
        [math.cos(end_heading), math.sin(end_heading)]
    )
    return Path(np.vstack((start, arc, straight_end)), name="arc_straight", start_heading=heading)


# ---------------------------------------------------------------------------------------------
# Random training paths

RANDOM_AREA = (0.5, 12.5)  # both axes (m): the course's 0-13 m plot limits less a margin
RANDOM_LENGTH_RANGE = (8.0, 25.0)
RANDOM_MAX_TURN = math.radians(150)
RANDOM_MISALIGNED_START_PROBABILITY = 0.3
_GENTLE_TURN_MAX = math.radians(90)
_SHARP_TURN_PROBABILITY = 0.3
_LEG_LENGTH_RANGE = (1.0, 4.0)
_ARC_RADIUS_RANGE = (1.0, 4.0)
_ARC_SWEEP_RANGE = (math.radians(30), math.radians(180))
_STRAIGHT_PROBABILITY = 0.3
_STRAIGHT_LENGTH_RANGE = (0.5, 3.0)
# Chords of 10 cm on radii of 1 m or more deviate from the arc by at most 1.25 mm.
RANDOM_ARC_CHORD = 0.1


def _random_sign(rng: np.random.Generator) -> float:
    return 1.0 if rng.random() < 0.5 else -1.0


def _polyline_walk(rng: np.random.Generator, target_length: float) -> NDArray[np.float64]:
    """Straight legs joined by corners; some corners are sharp (90 to 150 degrees).

    The last leg is cut to end at the target length, but kept at least as long as the
    shortest leg.
    """
    heading = rng.uniform(-math.pi, math.pi)
    points = [np.zeros(2)]
    length = 0.0
    while length < target_length:
        if len(points) > 1:
            sharp = rng.random() < _SHARP_TURN_PROBABILITY
            low, high = (_GENTLE_TURN_MAX, RANDOM_MAX_TURN) if sharp else (0.0, _GENTLE_TURN_MAX)
            heading += _random_sign(rng) * rng.uniform(low, high)
        leg = rng.uniform(*_LEG_LENGTH_RANGE)
        leg = max(min(leg, target_length - length), _LEG_LENGTH_RANGE[0])
        points.append(points[-1] + leg * np.array([math.cos(heading), math.sin(heading)]))
        length += leg
    return np.array(points)


def _arc_walk(rng: np.random.Generator, target_length: float) -> NDArray[np.float64]:
    """A smooth path: circular arcs and straights joined tangentially, the arcs densified.

    The last piece is cut to end at the target length.
    """
    heading = rng.uniform(-math.pi, math.pi)
    pieces = [np.zeros((1, 2))]
    length = 0.0
    while length < target_length:
        start = pieces[-1][-1]
        remaining = target_length - length
        if rng.random() < _STRAIGHT_PROBABILITY:
            straight = min(rng.uniform(*_STRAIGHT_LENGTH_RANGE), remaining)
            pieces.append(start + straight * np.array([[math.cos(heading), math.sin(heading)]]))
            length += straight
        else:
            radius = rng.uniform(*_ARC_RADIUS_RANGE)
            sweep = min(rng.uniform(*_ARC_SWEEP_RANGE), remaining / radius)
            sweep *= _random_sign(rng)
            pieces.append(_arc_points(start, heading, radius, sweep, RANDOM_ARC_CHORD))
            heading += sweep
            length += radius * abs(sweep)
    return np.vstack(pieces)


def random_path(rng: np.random.Generator) -> Path:
    """A random training path inside the square :data:`RANDOM_AREA`.

    The rng picks a style (a polyline with some sharp corners, or smooth arcs and straights)
    and a length of 8 to 25 m (a polyline's last leg may run up to 1 m past it); every turn is
    at most 150 degrees and every polyline leg 1 to 4 m long.
    A walk whose extent does not fit the area is drawn again; one that fits is placed at a
    random spot inside. The start heading is the first segment's heading, or, with probability
    :data:`RANDOM_MISALIGNED_START_PROBABILITY`, any heading: the course starts every path at
    heading 0 whatever its direction, so a policy must learn to turn towards the path. The
    same rng state gives the same path, bit for bit.

    :param rng: the random generator to draw from.
    """
    target_length = rng.uniform(*RANDOM_LENGTH_RANGE)
    walk = _polyline_walk if rng.random() < 0.5 else _arc_walk
    area_low, area_high = RANDOM_AREA
    while True:
        points = walk(rng, target_length)
        low = points.min(axis=0)
        slack = (area_high - area_low) - (points.max(axis=0) - low)
        if np.all(slack >= 0):
            break
    points += area_low - low + rng.uniform(0.0, slack)
    if rng.random() < RANDOM_MISALIGNED_START_PROBABILITY:
        start_heading = float(rng.uniform(-math.pi, math.pi))
    else:
        first_leg = points[1] - points[0]
        start_heading = float(np.arctan2(first_leg[1], first_leg[0]))
    return Path(points, name="random", start_heading=start_heading)


# ---------------------------------------------------------------------------------------------
# Path sets


@dataclass(frozen=True)
class Track:
    """A path to follow and, on maze tracks, the maze whose walls the robot must avoid.

    :param path: the path.
    :param maze: the maze (walls for collisions and range readings), or None in open space.
    """

    path: Path
    maze: Maze | None = None


class PathSet(ABC):
    """A named source of tracks, from which an environment draws one at every reset.

    :param name: the set's name.
    """

    def __init__(self, name: str) -> None:
        self.name = name

    @property
    def tracks(self) -> tuple[Track, ...]:
        """The set's fixed tracks, for evaluators to enumerate; empty for generated sets."""
        return ()

    @abstractmethod
    def sample(self, rng: np.random.Generator) -> Track:
        """Draw a track.

        :param rng: the random generator; the same state gives the same track.
        """

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class FixedPathSet(PathSet):
    """A fixed tuple of tracks, drawn uniformly.

    :param name: the set's name.
    :param tracks: the tracks, at least one.
    """

    def __init__(self, name: str, tracks: Sequence[Track]) -> None:
        super().__init__(name)
        if not tracks:
            raise ValueError(f"path set {name!r} needs at least one track")
        self._tracks = tuple(tracks)

    @property
    def tracks(self) -> tuple[Track, ...]:
        return self._tracks

    def sample(self, rng: np.random.Generator) -> Track:
        return self._tracks[rng.integers(len(self._tracks))]


class GeneratedPathSet(PathSet):
    """Tracks made on demand by a generator function.

    :param name: the set's name.
    :param generate: makes a track from an rng, deterministically.
    """

    def __init__(self, name: str, generate: Callable[[np.random.Generator], Track]) -> None:
        super().__init__(name)
        self._generate = generate

    def sample(self, rng: np.random.Generator) -> Track:
        return self._generate(rng)


class MixedPathSet(PathSet):
    """A mixture: each draw picks a member set with the given weights, then draws from it.

    :param sets: the member sets.
    :param weights: non-negative weights, one per set, normalized to probabilities.
    :param name: the set's name; by default built from the members' names and weights.
    """

    def __init__(
        self, sets: Sequence[PathSet], weights: Sequence[float], name: str | None = None
    ) -> None:
        weights = np.asarray(weights, dtype=np.float64)
        if not sets or weights.shape != (len(sets),):
            raise ValueError(
                f"need one weight per set and at least one set, got {len(sets)} sets "
                f"and weights of shape {weights.shape}"
            )
        if not np.all(np.isfinite(weights)) or np.any(weights < 0) or weights.sum() <= 0:
            raise ValueError(f"weights must be finite, >= 0 and not all 0, got {weights}")
        if name is None:
            name = "+".join(
                f"{member.name}:{weight:g}" for member, weight in zip(sets, weights, strict=True)
            )
        super().__init__(name)
        self._sets = tuple(sets)
        self._probabilities = weights / weights.sum()

    def sample(self, rng: np.random.Generator) -> Track:
        member = self._sets[rng.choice(len(self._sets), p=self._probabilities)]
        return member.sample(rng)


def _course_set(name: str, path_names: Sequence[str]) -> PathSet:
    return FixedPathSet(name, [Track(course_path(path_name)) for path_name in path_names])


# The maze module imports Path and Track from this one, so the maze sets import it when built.
def _maze_set() -> PathSet:
    from mobile_envs.maze import the_maze

    return FixedPathSet("maze", [the_maze()])


def _random_maze_set() -> PathSet:
    from mobile_envs.maze import random_maze

    return GeneratedPathSet("random_maze", random_maze)


_PATH_SET_BUILDERS: dict[str, Callable[[], PathSet]] = {
    **{name: partial(_course_set, name, [name]) for name in ("segments", "sharp_segments")},
    **{name: partial(_course_set, name, [name]) for name in LINE_NAMES},
    "lines": partial(_course_set, "lines", LINE_NAMES),
    "arc_straight": lambda: FixedPathSet("arc_straight", [Track(arc_straight_path())]),
    "random": lambda: GeneratedPathSet("random", lambda rng: Track(random_path(rng))),
    "maze": _maze_set,
    "random_maze": _random_maze_set,
    "training": lambda: MixedPathSet(
        [path_set("random"), path_set("random_maze")], [0.75, 0.25], name="training"
    ),
}


def path_set_names() -> tuple[str, ...]:
    """Names of the registered path sets."""
    return tuple(_PATH_SET_BUILDERS)


@cache
def path_set(name: str) -> PathSet:
    """The registered path set of this name, built on first use.

    :param name: one of :func:`path_set_names`.
    :raises ValueError: for an unknown name; the message lists the known ones.
    """
    builder = _PATH_SET_BUILDERS.get(name)
    if builder is None:
        known = ", ".join(path_set_names())
        raise ValueError(f"unknown path set {name!r}; known path sets: {known}")
    return builder()

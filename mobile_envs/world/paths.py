"""Path geometry for path following: polylines, batched queries and the paths themselves.

A :class:`Path` is an immutable polyline with the queries a path follower needs: the projection
of a robot onto the path (arc length and signed cross-track error), the point and heading at an
arc length, and preview points in the robot frame. :class:`PathTable` packs many paths into
one array, each path in a slot of its own, so that N robots, each on its own path, are
answered by one compiled call (:mod:`mobile_envs.world.geometry`).
A :class:`Path` answers its own queries through a one-row table: there is one copy of the
geometry.

Paths come from files (:meth:`Path.from_file`), from the course (exact waypoints from
``data/course_paths.json``, :func:`course_path`), from seed 003's arc-and-straight validation
run (:func:`arc_straight_path`) and from the random generator of training paths
(:func:`random_path`). :mod:`mobile_envs.tracks.sets` groups them, with the mazes, into the named
path sets an environment draws from.
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import reprlib
from collections.abc import Sequence
from functools import cache, partial
from importlib import resources
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from mobile_envs._kernels import exact_math
from mobile_envs._kernels.angles import wrap_scalar_angle
from mobile_envs._kernels.array_copies import copy_rows
from mobile_envs._kernels.pcg64 import (
    Stream,
    draw_double,
    draw_uniform,
    store,
    stream_of,
    through_streams,
)
from mobile_envs.world.geometry import (
    DELTA_X,
    DELTA_Y,
    HEADING,
    INV_LENGTH,
    INV_LENGTH_SQ,
    LENGTH,
    NUM_COLUMNS,
    START_S,
    START_X,
    START_Y,
    headings_at,
    points_at,
    previews,
    project_robots,
)

__all__ = [
    "ARC_STRAIGHT_CHORD",
    "ARC_STRAIGHT_RADIUS",
    "ARC_STRAIGHT_START",
    "ARC_STRAIGHT_START_HEADING",
    "ARC_STRAIGHT_STRAIGHT_LENGTH",
    "ARC_STRAIGHT_SWEEP",
    "DEFAULT_SEARCH_DISTANCE",
    "DUPLICATE_TOLERANCE",
    "LINE_NAMES",
    "MAX_COORDINATE",
    "RANDOM_ARC_CHORD",
    "RANDOM_AREA",
    "RANDOM_LENGTH_RANGE",
    "RANDOM_MAX_TURN",
    "RANDOM_MISALIGNED_START_PROBABILITY",
    "SHORTEST_LAST_LEG",
    "Path",
    "PathGeometry",
    "PathTable",
    "Projection",
    "arc_straight_path",
    "course_path",
    "course_path_names",
    "draw_random_walk",
    "random_path",
    "random_paths",
    "random_paths_from_streams",
]

DEFAULT_SEARCH_DISTANCE = 1.0
DUPLICATE_TOLERANCE = 1e-9  # m: consecutive points closer than this count as one
# m: no coordinate may lie farther from the origin. A million kilometres covers any map
# projection, and keeps every length, squared distance and time limit in steps far from
# overflow, which coordinates near 1e308 reach (an infinite length, NaN observations).
MAX_COORDINATE = 1e9

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
    :raises ValueError: when the points are not an (M, 2) array of finite numbers within
        :data:`MAX_COORDINATE` of the origin with M >= 2, or all points coincide.
    """

    def __init__(
        self, points: ArrayLike, name: str | None = None, start_heading: float = 0.0
    ) -> None:
        try:
            vertices = np.array(points, dtype=np.float64)
        except (TypeError, ValueError) as error:
            raise ValueError(f"points must be an (M, 2) array of numbers: {error}") from None
        if vertices.ndim != 2 or vertices.shape[1] != 2:
            raise ValueError(f"points must have shape (M, 2), got {vertices.shape}")
        if len(vertices) < 2:
            raise ValueError(f"a path needs at least two points, got {len(vertices)}")
        not_finite = np.flatnonzero(~np.isfinite(vertices).all(axis=1))
        if not_finite.size:
            index = not_finite[0]
            raise ValueError(f"points must be finite; point {index} is {vertices[index].tolist()}")
        too_far = np.flatnonzero((np.abs(vertices) > MAX_COORDINATE).any(axis=1))
        if too_far.size:
            index = too_far[0]
            raise ValueError(
                f"points must lie within {MAX_COORDINATE:g} m of the origin on each axis, so "
                f"that lengths stay finite; point {index} is {vertices[index].tolist()}"
            )
        number_types = (int, float, np.integer, np.floating)
        if isinstance(start_heading, bool) or not isinstance(start_heading, number_types):
            raise ValueError(f"start_heading must be a number, got {start_heading!r}")
        if not math.isfinite(start_heading):
            raise ValueError(f"start_heading must be finite, got {start_heading}")

        geometry = PathGeometry(vertices, np.array([0, len(vertices)], dtype=np.int64))
        if _run_points(geometry.runs[1]) < 2:
            raise ValueError("the path has zero length: all its points are identical")
        self._set_up(geometry, 0, name, float(start_heading))

    def _set_up(
        self, geometry: PathGeometry, index: int, name: str | None, start_heading: float
    ) -> None:
        """Make this path path ``index`` of ``geometry``, its arrays read-only views of one
        copy of its own (views of the geometry would keep every path made with it alive)."""
        first, stop = geometry.runs[index], geometry.runs[index + 1]
        size = _run_points(stop - first)
        own = _read_only(geometry.packed[first:stop].copy())
        self._points = own[: 2 * size].reshape(size, 2)
        self._cumulative_length = own[2 * size : 3 * size]
        self._turn_angles = own[3 * size : 4 * size]
        self._segment_lengths = own[4 * size : 5 * size - 1]
        self._segment_headings = own[5 * size - 1 :]
        self._name = name
        self._start_heading = start_heading
        #: Where the path was made with others, for a table to write them in one call; the
        #: table drops it once written (and copies and lone paths never have it), so the
        #: geometry's arrays are freed with the last path no table has written.
        self._geometry: PathGeometry | None = geometry if len(geometry.runs) > 2 else None
        self._geometry_index = index
        # Built on first query: random paths are made at every reset and queried through the
        # environment's table instead.
        self._own_table: PathTable | None = None

    @classmethod
    def _generated(cls, points: NDArray[np.float64], name: str, start_heading: float) -> Path:
        """A path from points a generator made: finite, within :data:`MAX_COORDINATE`, at
        least two distinct ones (what the constructor checks), and a finite float heading.
        The same path as ``Path(points, name, start_heading)``, without checking again."""
        return cls._generated_many(
            points, np.array([0, len(points)], dtype=np.int64), name, [start_heading]
        )[0]

    @classmethod
    def _generated_many(
        cls,
        points: NDArray[np.float64],
        offsets: NDArray[np.int64],
        name: str,
        start_headings: Sequence[float],
    ) -> list[Path]:
        """:meth:`_generated` of many generators' paths given end to end (path j's points are
        ``points[offsets[j]:offsets[j + 1]]``), their geometry derived in one call."""
        return cls._of_geometry(PathGeometry(points, offsets), name, start_headings)

    @classmethod
    def _of_geometry(
        cls, geometry: PathGeometry, name: str, start_headings: Sequence[float]
    ) -> list[Path]:
        """The paths of ``geometry``, path j starting at heading ``start_headings[j]``."""
        paths = []
        for index, start_heading in enumerate(start_headings):
            path = cls.__new__(cls)
            path._set_up(geometry, index, name, start_heading)
            paths.append(path)
        return paths

    @property
    def _table(self) -> PathTable:
        """A one-row table of this path, which answers the path's own queries."""
        if self._own_table is None:
            self._own_table = PathTable([self])
        return self._own_table

    @classmethod
    def from_file(cls, filename: str | os.PathLike[str], name: str | None = None) -> Path:
        """Read waypoints from a CSV or JSON file, chosen by the file's extension.

        Both are UTF-8 text, with or without a byte order mark.
        CSV: ``x,y`` on each line; blank lines are ignored and the first line may be a header.
        JSON: a list of ``[x, y]`` pairs.

        :param filename: a ``.csv`` or ``.json`` file.
        :param name: the path's name; the file name without extension when None.
        :raises ValueError: for an unknown extension, a file that cannot be read or is not
            UTF-8, malformed content (the message names the file and the line, or the item or
            JSON error position) or points that make no path; every message names the file.
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
        hints = None if hint is None else np.asarray([hint] if single else hint)
        rows = np.zeros(len(positions), dtype=np.int64)
        s, cross_track_error, segment = self._table.project(rows, positions, hints)
        if single:
            return float(s[0]), float(cross_track_error[0]), int(segment[0])
        return s, cross_track_error, segment

    def point_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Points at arc lengths s (any shape), clamped to [0, length]: shape s.shape + (2,)."""
        s = np.asarray(s, dtype=np.float64)
        return self._table.point_at(np.zeros(s.size, dtype=np.int64), s.reshape(-1)).reshape(
            (*s.shape, 2)
        )

    def heading_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Path headings (rad) at arc lengths s (any shape), clamped to [0, length].

        At a vertex the heading is that of the segment starting there.
        """
        s = np.asarray(s, dtype=np.float64)
        headings = self._table.heading_at(np.zeros(s.size, dtype=np.int64), s.reshape(-1))
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
        rows = np.zeros(len(pose), dtype=np.int64)
        return self._table.preview(rows, pose, s, offsets)

    def __getstate__(self) -> dict[str, Any]:
        # The arrays pickle as the path's own; the geometry they view would bring the other
        # paths made with it.
        state = self.__dict__.copy()
        state["_geometry"] = None
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        # Pickled and deep-copied arrays come back writeable: a copy must stay immutable.
        self.__dict__.update(state)
        # A path pickled before its table was built on first query held it as ``_table``.
        self.__dict__.pop("_table", None)
        self.__dict__.setdefault("_own_table", None)
        self.__dict__.setdefault("_geometry", None)
        self.__dict__.setdefault("_geometry_index", 0)
        for array in (
            self._points,
            self._segment_lengths,
            self._cumulative_length,
            self._segment_headings,
            self._turn_angles,
        ):
            _read_only(array)

    def __repr__(self) -> str:
        return f"Path(name={self._name!r}, points={len(self._points)}, length={self.length:.3f})"


class PathGeometry:
    """The read-only geometry of paths given end to end, derived in two compiled calls, from
    which :class:`Path` objects take copies of their own and tables write many paths at once.

    Path j lies in ``packed[packed_offsets[j]:packed_offsets[j + 1]]``, a run of 6 M - 2
    numbers for its M points: the points (x, y for each), the cumulative lengths, the turn
    angles, the segment lengths and the segment headings.

    :param points: (P, 2) every path's points, path j's ``points[offsets[j]:offsets[j + 1]]``
        (checked by the caller), consecutive duplicates dropped here.
    :param offsets: (k + 1,) where each path's points start, and the end.
    """

    def __init__(self, points: NDArray[np.float64], offsets: NDArray[np.int64]) -> None:
        packed, self.packed_offsets, delta = _pack_geometry(points, offsets)
        # The C library's atan2 of each segment (exact_math: numpy's arctan2 has other last
        # bits on AVX-512 CPUs), over all segments at once, the same bits whatever the array.
        _pack_headings(packed, self.packed_offsets, exact_math.arctan2(delta[:, 1], delta[:, 0]))
        self.packed = _read_only(packed)
        #: :attr:`packed_offsets` as Python ints.
        self.runs: list[int] = self.packed_offsets.tolist()


@njit(cache=True)
def _first_segment_headings(
    packed: NDArray[np.float64], packed_offsets: NDArray[np.int64]
) -> NDArray[np.float64]:
    """The heading (rad) of each path's first segment, read from the runs of a
    :class:`PathGeometry` (its ``packed`` and ``packed_offsets``)."""
    headings = np.empty(packed_offsets.shape[0] - 1)
    for path in range(headings.shape[0]):
        at = packed_offsets[path]
        headings[path] = packed[at + 5 * _run_points(packed_offsets[path + 1] - at) - 1]
    return headings


@njit(cache=True)
def _run_length(points: int) -> int:
    """How many numbers the run of a path of ``points`` points holds (see
    :class:`PathGeometry`): 2 M for the points, M each for the cumulative lengths and the
    turns, M - 1 each for the segment lengths and headings."""
    return 6 * points - 2


@njit(cache=True)
def _run_points(length: int) -> int:
    """The points of a path whose run holds ``length`` numbers: the inverse of
    :func:`_run_length`."""
    return (length + 2) // 6


@njit(cache=True)
def _pack_geometry(
    points: NDArray[np.float64], offsets: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """Each path's points without consecutive duplicates, cumulative lengths and segment
    lengths in its run of a :class:`PathGeometry` (the headings and turns left to
    :func:`_pack_headings`); the runs' offsets, and every path's segment differences end to
    end."""
    count = offsets.shape[0] - 1
    packed = np.empty(6 * offsets[count])  # at most 6 numbers a point
    packed_offsets = np.zeros(count + 1, dtype=np.int64)
    deltas = np.empty((offsets[count], 2))
    # Typed int64 from the start: numba types the loop's calls before it sees the sum grow,
    # and would compile _pack_distinct once more for a literal 0.
    segments = np.int64(0)
    for path in range(count):
        at = packed_offsets[path]
        if _pack_distinct(points, offsets[path], offsets[path + 1], packed, at, deltas, segments):
            size = offsets[path + 1] - offsets[path]
        else:  # a point to drop (rare): the general case
            vertices, delta, segment_lengths = _drop_duplicates(
                points[offsets[path] : offsets[path + 1]]
            )
            cumulative = _cumulative_lengths(segment_lengths)
            size = vertices.shape[0]
            for point in range(size):
                packed[at + 2 * point] = vertices[point, 0]
                packed[at + 2 * point + 1] = vertices[point, 1]
                packed[at + 2 * size + point] = cumulative[point]
            for segment in range(size - 1):
                packed[at + 4 * size + segment] = segment_lengths[segment]
            copy_rows(delta, deltas, segments)
        segments += size - 1
        packed_offsets[path + 1] = at + _run_length(size)
    return packed[: packed_offsets[count]], packed_offsets, deltas[:segments]


@njit(cache=True)
def _pack_distinct(
    points: NDArray[np.float64],
    first: int,
    stop: int,
    packed: NDArray[np.float64],
    at: int,
    deltas: NDArray[np.float64],
    segments: int,
) -> bool:
    """Write the run of points ``points[first:stop]`` at ``packed[at]`` and their segment
    differences at ``deltas[segments]``, as :func:`_pack_geometry` does with the values
    :func:`_drop_duplicates` and :func:`_cumulative_lengths` compute, in one pass without
    allocating; False (the run half written) if a segment is shorter than
    DUPLICATE_TOLERANCE, which the general case drops."""
    size = stop - first
    cumulative = 0.0
    packed[at] = points[first, 0]
    packed[at + 1] = points[first, 1]
    packed[at + 2 * size] = 0.0
    for point in range(1, size):
        delta_x = points[first + point, 0] - points[first + point - 1, 0]
        delta_y = points[first + point, 1] - points[first + point - 1, 1]
        length = math.hypot(delta_x, delta_y)
        if length < DUPLICATE_TOLERANCE:
            return False
        cumulative += length
        packed[at + 2 * point] = points[first + point, 0]
        packed[at + 2 * point + 1] = points[first + point, 1]
        packed[at + 2 * size + point] = cumulative
        packed[at + 4 * size + point - 1] = length
        deltas[segments + point - 1, 0] = delta_x
        deltas[segments + point - 1, 1] = delta_y
    return True


@njit(cache=True)
def _pack_headings(
    packed: NDArray[np.float64], packed_offsets: NDArray[np.int64], headings: NDArray[np.float64]
) -> None:
    """Write every path's segment headings (given end to end) and its turn angles (the
    wrapped change of heading at each vertex, 0 at the two ends) into its run of a
    :class:`PathGeometry`."""
    segments = 0
    for path in range(packed_offsets.shape[0] - 1):
        at = packed_offsets[path]
        size = _run_points(packed_offsets[path + 1] - at)
        turns, segment_headings = at + 3 * size, at + 5 * size - 1
        packed[turns] = packed[turns + size - 1] = 0.0
        for segment in range(size - 1):
            packed[segment_headings + segment] = headings[segments + segment]
            if segment > 0:
                packed[turns + segment] = wrap_scalar_angle(
                    headings[segments + segment] - headings[segments + segment - 1]
                )
        segments += size - 1


@njit(cache=True)
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
        delta = points[1:] - points[:-1]
        segment_lengths = np.empty(len(delta))
        for segment in range(len(delta)):
            segment_lengths[segment] = math.hypot(delta[segment, 0], delta[segment, 1])
        short = segment_lengths < DUPLICATE_TOLERANCE
        if not short.any():
            return points, delta, segment_lengths
        keep = np.ones(len(points), dtype=np.bool_)
        for segment in range(len(short)):
            keep[segment + 1] = not short[segment]
        points = points[keep]


@njit(cache=True)
def _cumulative_lengths(segment_lengths: NDArray[np.float64]) -> NDArray[np.float64]:
    """(M,) arc length at each vertex: 0, then the running sum of the segment lengths."""
    cumulative = np.empty(len(segment_lengths) + 1)
    cumulative[0] = 0.0
    for segment in range(len(segment_lengths)):
        cumulative[segment + 1] = cumulative[segment] + segment_lengths[segment]
    return cumulative


def _parse_number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _read_text(file: pathlib.Path) -> str:
    """The file's text, decoded as UTF-8 without its byte order mark if it has one."""
    try:
        return file.read_bytes().decode("utf-8-sig")
    except OSError as error:
        raise ValueError(f"{file}: cannot read the file: {error.strerror or error}") from None
    except UnicodeDecodeError as error:
        bad_byte = error.object[error.start : error.start + 1]
        raise ValueError(f"{file}: not UTF-8 text: byte {error.start} is {bad_byte!r}") from None


def _read_csv_points(file: pathlib.Path) -> NDArray[np.float64]:
    points = []
    first_line = True
    for number, line in enumerate(_read_text(file).splitlines(), start=1):
        if not line.strip():
            continue
        values = [_parse_number(field) for field in line.split(",")]
        if first_line and all(value is None for value in values):
            first_line = False
            continue  # a header such as "x,y"
        first_line = False
        x, y = values if len(values) == 2 else (None, None)
        if x is None or y is None or not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(
                f"{file}, line {number}: expected 'x,y' with two finite numbers, "
                f"got {reprlib.repr(line.strip())}"
            )
        points.append((x, y))
    return np.array(points, dtype=np.float64).reshape(-1, 2)


def _read_json_points(file: pathlib.Path) -> NDArray[np.float64]:
    text = _read_text(file)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(
            f"{file}: invalid JSON at line {error.lineno}, column {error.colno}: {error.msg}"
        ) from None
    except ValueError as error:  # an integer with more digits than Python converts
        raise ValueError(f"{file}: invalid JSON: {error}") from None
    except RecursionError:
        raise ValueError(f"{file}: invalid JSON: nested too deeply to read") from None
    if not isinstance(data, list):
        raise ValueError(
            f"{file}: expected a JSON list of [x, y] points, got {type(data).__name__}"
        )
    points = np.empty((len(data), 2))
    for index, item in enumerate(data):
        is_pair = isinstance(item, list) and len(item) == 2
        if not is_pair or not all(
            isinstance(value, (int, float)) and not isinstance(value, bool) for value in item
        ):
            raise ValueError(
                f"{file}: item {index} is not an [x, y] pair of numbers: {reprlib.repr(item)}"
            )
        try:
            points[index] = float(item[0]), float(item[1])
        except OverflowError:
            raise ValueError(
                f"{file}: item {index} holds an integer too large for a float: {reprlib.repr(item)}"
            ) from None
    return points


@njit(cache=True)
def _write_packed_segments(
    columns: NDArray[np.float64],
    first: int,
    points: NDArray[np.float64],
    segment_lengths: NDArray[np.float64],
    cumulative_length: NDArray[np.float64],
    segment_headings: NDArray[np.float64],
) -> None:
    """Write one path's segments into ``columns``, from column ``first`` on."""
    for segment in range(segment_lengths.shape[0]):
        column = first + segment
        inverse_length = 1.0 / segment_lengths[segment]
        columns[START_X, column] = points[segment, 0]
        columns[START_Y, column] = points[segment, 1]
        columns[DELTA_X, column] = points[segment + 1, 0] - points[segment, 0]
        columns[DELTA_Y, column] = points[segment + 1, 1] - points[segment, 1]
        columns[INV_LENGTH, column] = inverse_length
        columns[INV_LENGTH_SQ, column] = inverse_length * inverse_length
        columns[START_S, column] = cumulative_length[segment]
        columns[LENGTH, column] = segment_lengths[segment]
        columns[HEADING, column] = segment_headings[segment]


@njit(cache=True)
def _write_packed_paths(
    columns: NDArray[np.float64],
    spans: NDArray[np.int64],
    lengths: NDArray[np.float64],
    goals: NDArray[np.float64],
    rows: NDArray[np.int64],
    paths: NDArray[np.int64],
    packed: NDArray[np.float64],
    packed_offsets: NDArray[np.int64],
) -> None:
    """Write path ``paths[k]`` of a :class:`PathGeometry` (its ``packed`` runs) into table row
    ``rows[k]``, already placed: its segments (:func:`_write_packed_segments`) from column
    ``spans[rows[k], 0]`` on, and the length and goal ``Path.length`` and ``Path.goal`` give."""
    for k in range(paths.shape[0]):
        row = rows[k]
        at = packed_offsets[paths[k]]
        size = _run_points(packed_offsets[paths[k] + 1] - at)
        points = packed[at : at + 2 * size].reshape((size, 2))
        cumulative_length = packed[at + 2 * size : at + 3 * size]
        _write_packed_segments(
            columns, spans[row, 0], points, packed[at + 4 * size : at + 5 * size - 1],
            cumulative_length, packed[at + 5 * size - 1 : packed_offsets[paths[k] + 1]],
        )  # fmt: skip
        lengths[row] = cumulative_length[size - 1]
        goals[row, 0], goals[row, 1] = points[size - 1, 0], points[size - 1, 1]


@njit(cache=True)
def _move_slots(
    source: NDArray[np.float64],
    source_firsts: NDArray[np.int64],
    target: NDArray[np.float64],
    target_firsts: NDArray[np.int64],
    counts: NDArray[np.int64],
) -> None:
    """Copy each row's ``counts[row]`` segment columns from ``source_firsts[row]`` of
    ``source`` to ``target_firsts[row]`` of ``target``, every value exactly, row after row
    and segment after segment (so ``target`` may be ``source`` where no row moves right)."""
    for row in range(counts.shape[0]):
        for column in range(NUM_COLUMNS):
            for segment in range(counts[row]):
                target[column, target_firsts[row] + segment] = source[
                    column, source_firsts[row] + segment
                ]


@njit(cache=True)
def _place_rows(
    spans: NDArray[np.int64],
    slots: NDArray[np.int64],
    end: int,
    capacity: int,
    rows: NDArray[np.int64],
    needed: NDArray[np.int64],
    start: int,
) -> tuple[int, int]:
    """Give row ``rows[k]`` room for ``needed[k]`` segments, for k from ``start`` on (see
    :meth:`PathTable.set_path`): its own slot when they fit there and fill at least half of
    it, else a new slot from column ``end`` on. Stops at the first row that fits in neither
    before ``capacity``, unplaced, for the table to lay its rows out again.

    :return: the new end, and the index k of that row (``len(rows)`` once all are placed).
    """
    for k in range(start, rows.shape[0]):
        row, count = rows[k], needed[k]
        if count > slots[row] or 2 * count < slots[row]:
            if end + count > capacity:
                return end, k
            spans[row, 0], slots[row] = end, count
            end += count
        spans[row, 1] = count - 1
    return end, rows.shape[0]


#: Room the table keeps beyond its paths' segments when it lays them out again: the columns
#: fill up after half the live segments' worth of new paths, so lay-outs stay rare.
_SPARE_ROOM = 1.5


class PathTable:
    """P paths packed into one array, queried for N robots at once.

    Robot i follows path ``rows[i]``, and many robots may share a row. The segments of every
    path lie side by side in one (columns, capacity) array, each path in a slot of its own
    (no padding to the longest path: random paths differ in length tenfold), and
    ``spans[row]`` says where: (first column, last segment). The compiled kernels of
    :mod:`mobile_envs.world.geometry` answer every query in one call, whatever N and P are.

    :param paths: the paths, one per row.
    :param search_distance: how far (m of arc length) beyond a robot's projection on its hint
        segment a hinted projection looks for the closest segment.
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
        num_rows = len(paths)
        self._lengths = np.empty(num_rows)
        self._goals = np.empty((num_rows, 2))
        #: (P, 2) each row's first column in :attr:`columns` and its last segment's index.
        self.spans = np.empty((num_rows, 2), dtype=np.int64)
        self._slots = np.empty(num_rows, dtype=np.int64)  # the columns each row may fill
        for row, path in enumerate(paths):
            self.spans[row, 1] = path.num_segments - 1
        #: (NUM_COLUMNS, capacity) the segment data, each row's path in its slot.
        self.columns = np.empty((NUM_COLUMNS, 0))
        self._lay_out(sum(path.num_segments for path in paths), move=False)
        for row, path in enumerate(paths):
            self._write_path(row, path)

    def _lay_out(
        self, capacity: int, new_row: int = -1, new_count: int = 0, move: bool = True
    ) -> None:
        """Move every row's segments side by side from column 0 into new columns of
        ``capacity`` (at least the segments of all rows), leaving room for ``new_count``
        segments, unwritten, in row ``new_row`` (-1: none), whose old ones are dropped.
        Without ``move`` the slots are only allotted (a new table, written after).

        At the same capacity the rows move within the columns they are in, in the order they
        lie there (``new_row`` last): each moves left of its old place, over no row still to
        move, and no fresh memory is touched (the page faults of 9 x capacity new numbers
        cost more than the copy)."""
        sizes = self.spans[:, 1] + 1
        moved = sizes.copy()
        if new_row >= 0:
            sizes[new_row], moved[new_row] = new_count, 0
        in_place = move and capacity == self.columns.shape[1]
        order = np.arange(len(sizes))
        if in_place:
            order = np.argsort(self.spans[:, 0], kind="stable")
            if new_row >= 0:
                order = np.concatenate((order[order != new_row], [new_row]))
        firsts = np.empty(len(sizes), dtype=np.int64)
        firsts[order] = np.concatenate(([0], np.cumsum(sizes[order][:-1])))
        if in_place:
            _move_slots(
                self.columns, self.spans[order, 0], self.columns, firsts[order], moved[order]
            )
            columns = self.columns
        else:
            columns = np.empty((NUM_COLUMNS, capacity))
            if move:
                _move_slots(
                    self.columns, np.ascontiguousarray(self.spans[:, 0]), columns, firsts, moved
                )
        self.columns = columns
        self.spans[:, 0] = firsts
        self._slots[:] = sizes
        self._end = int(sizes.sum())
        #: (columns, spans, lengths, goals): the writable arrays the kernels of
        #: :mod:`mobile_envs.world.geometry` read. A new path that does not fit lays the table
        #: out again (see :meth:`set_path`), replacing them: read them again after it.
        self.kernel_arrays = (self.columns, self.spans, self._lengths, self._goals)

    def _write_path(self, row: int, path: Path) -> None:
        """Write ``path`` into row ``row``, already placed: its segments, length and goal."""
        _write_packed_segments(
            self.columns,
            int(self.spans[row, 0]),
            path.points,
            path.segment_lengths,
            path.cumulative_length,
            path.segment_headings,
        )
        self._lengths[row] = path.length
        self._goals[row] = path.goal

    def set_path(self, row: int, path: Path) -> None:
        """Replace the path of one row.

        It goes into the row's slot when it fits there and fills at least half of it, else
        into a new slot after the others; when the columns are full, every row is laid out
        again (with :data:`_SPARE_ROOM` times their segments' room) and the kernel arrays
        are replaced.

        :param row: the row to replace, in [0, P).
        :param path: the new path.
        """
        self.set_paths([row], [path])

    def set_paths(self, rows: Sequence[int], paths: Sequence[Path]) -> None:
        """Replace the paths of rows ``rows`` (distinct), as :meth:`set_path` of each in
        turn does; paths made together (a generator's batch) are written in one call.

        :param rows: the rows to replace, each in [0, P).
        :param paths: the new path of each.
        """
        if len(rows) != len(paths):
            raise ValueError(f"got {len(rows)} rows and {len(paths)} paths")
        for index, (row, path) in enumerate(zip(rows, paths, strict=True)):
            if not 0 <= row < len(self._paths):
                raise ValueError(f"row must lie in [0, {len(self._paths)}), got {row}")
            _check_path(path, f"paths[{index}]")
        if not paths:
            return
        # One pass over the paths; those made together (a generator's batch, whose
        # PathGeometry they still hold) are grouped, to be written in one call each.
        needed_list: list[int] = []
        batches: dict[int, tuple[PathGeometry, list[int], list[int]]] = {}
        lone: list[tuple[int, Path]] = []
        for row, path in zip(rows, paths, strict=True):
            self._paths[row] = path
            needed_list.append(len(path._segment_lengths))
            geometry = path._geometry
            if geometry is None:
                lone.append((row, path))
                continue
            batch = batches.get(id(geometry))
            if batch is None:
                batch = batches[id(geometry)] = (geometry, [], [])
            batch[1].append(row)
            batch[2].append(path._geometry_index)
            path._geometry = None  # written below: the path no longer keeps its batch's arrays
        row_array = np.array(rows, dtype=np.int64)
        needed = np.array(needed_list, dtype=np.int64)
        placed = 0
        while True:
            # Each row into its slot or after the others, in order, until the columns fill.
            self._end, placed = _place_rows(
                self.spans, self._slots, self._end, self.columns.shape[1], row_array, needed,
                placed,
            )  # fmt: skip
            if placed == len(rows):
                break
            row, count = int(row_array[placed]), int(needed[placed])
            live = int((self.spans[:, 1] + 1).sum()) - (self.spans[row, 1] + 1) + count
            capacity = max(self.columns.shape[1], math.ceil(_SPARE_ROOM * live))
            self._lay_out(capacity, row, count)
            self.spans[row, 1] = count - 1
            placed += 1
        # Written once every row has its place: a lay-out moves the rows placed before it.
        for row, path in lone:
            self._write_path(row, path)
        for geometry, batch_rows, members in batches.values():
            _write_packed_paths(
                self.columns, self.spans, self._lengths, self._goals,
                np.array(batch_rows, dtype=np.int64), np.array(members, dtype=np.int64),
                geometry.packed, geometry.packed_offsets,
            )  # fmt: skip

    @property
    def paths(self) -> tuple[Path, ...]:
        """The path of each row."""
        return tuple(self._paths)

    @property
    def search_distance(self) -> float:
        """Arc length (m) a hinted projection searches beyond the robot's projection on its hint
        segment."""
        return self._search_distance

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

        Without a hint every segment is searched: there is no history, so where two distinct
        points of a path are equally close (legs that overlap, a path that crosses itself),
        the earlier one (the smaller arc length) wins.

        With a hint (each robot's segment index from the previous step) the search follows
        the robot's own progress, walking forward from the hint segment as MATLAB's
        controllerPurePursuit does: it covers the hint segment and the later segments that
        start within :attr:`search_distance` beyond the robot's projection on the hint
        segment. That bounds the work per robot, however long the path, and keeps a robot on
        its own part of a path that crosses itself or doubles back: a return leg starts far
        ahead of a robot on the outward leg. Near the turn, where both legs lie in the window,
        an exact tie between distinct points goes to the leg pointing closer to the robot's
        heading when ``xy`` holds poses (a robot that has turned round follows the return
        leg), else to the earlier point.

        :param rows: (N,) the row (path) of each robot.
        :param xy: (N, 2) positions or (N, 3) poses (m, m, rad); the heading only breaks
            hinted ties.
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
            first = np.zeros(len(rows), dtype=np.int64)
        else:
            hint = np.asarray(hint)
            if hint.shape != rows.shape or not np.issubdtype(hint.dtype, np.integer):
                raise ValueError(
                    f"hint must be an integer array of shape {rows.shape}, "
                    f"got shape {hint.shape} and dtype {hint.dtype}"
                )
            first = np.clip(hint, 0, self.spans[rows, 1]).astype(np.int64)
        headings = xy[:, 2].copy() if xy.shape[1] == 3 else np.full(len(rows), np.nan)
        return project_robots(
            self.columns,
            self.spans,
            rows,
            np.ascontiguousarray(xy[:, :2]),
            headings,
            first,
            hint is not None,
            self._search_distance,
        )

    def point_at(self, rows: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
        """Points of each robot's path at arc lengths s, clamped to [0, length].

        :param rows: (N,) the row of each robot.
        :param s: (N,) or (N, K) arc lengths (m).
        :return: s.shape + (2,) points (m).
        """
        flat_rows, flat_s = self._check_arc_lengths(rows, s)
        points = points_at(self.columns, self.spans, self._lengths, flat_rows, flat_s)
        return points.reshape((*np.shape(s), 2))

    def heading_at(self, rows: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
        """Path headings (rad) at arc lengths s, like :meth:`point_at`; s.shape.

        At a vertex the heading is that of the segment starting there.
        """
        flat_rows, flat_s = self._check_arc_lengths(rows, s)
        headings = headings_at(self.columns, self.spans, self._lengths, flat_rows, flat_s)
        return headings.reshape(np.shape(s))

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
        return previews(self.columns, self.spans, self._lengths, rows, pose, s, offsets)

    def _check_rows(self, rows: ArrayLike) -> NDArray[np.int64]:
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
        return rows.astype(np.int64, copy=False)

    def _check_arc_lengths(
        self, rows: ArrayLike, s: ArrayLike
    ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Rows and arc lengths flattened to (n,) each; s must be (N,) or (N, K)."""
        rows = self._check_rows(rows)
        s = np.asarray(s, dtype=np.float64)
        if s.ndim not in (1, 2) or len(s) != len(rows):
            raise ValueError(f"s must have shape ({len(rows)},) or ({len(rows)}, K), got {s.shape}")
        flat_rows = np.broadcast_to(rows.reshape((-1,) + (1,) * (s.ndim - 1)), s.shape)
        return flat_rows.ravel(), s.ravel()


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
    if not np.isfinite(array).all():
        raise ValueError(f"{label} contains NaN or inf")
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


@njit(cache=True, inline="always")
def _grown_rows(points: NDArray[np.float64], rows: int, kept: int) -> NDArray[np.float64]:
    """A new (rows, 2) buffer holding the first ``kept`` rows of ``points``."""
    grown = np.empty((rows, 2))
    copy_rows(points[:kept], grown, 0)
    return grown


@njit(cache=True, inline="always")
def _append_point(
    points: NDArray[np.float64], count: int, x: float, y: float
) -> NDArray[np.float64]:
    """Set point ``count`` of a growing buffer, doubling the buffer when it is full."""
    if count == len(points):
        points = _grown_rows(points, 2 * len(points), count)
    points[count, 0], points[count, 1] = x, y
    return points


@njit(cache=True, inline="always")
def _append_arc(
    points: NDArray[np.float64],
    count: int,
    heading: float,
    radius: float,
    sweep: float,
    max_chord: float,
) -> tuple[NDArray[np.float64], int]:
    """Append the points after point ``count - 1`` along a circular arc, at equal chords of at
    most ``max_chord``; the arc starts there heading ``heading`` (rad) and turns by the signed
    ``sweep`` (rad, positive to the left). The angles are numpy's ``linspace(0, sweep,
    chords + 1)`` past the first, added to the heading.

    :return: the buffer (grown if need be) and the new point count.
    """
    start_x, start_y = points[count - 1, 0], points[count - 1, 1]
    reach = math.copysign(1.0, sweep) * radius
    centre_x = start_x + reach * -math.sin(heading)
    centre_y = start_y + reach * math.cos(heading)
    chords = math.ceil(radius * abs(sweep) / max_chord)
    step = sweep / chords
    for chord in range(1, chords + 1):
        if chord == chords:
            angle = heading + sweep
        elif step == 0.0:  # linspace's way round a step that underflows
            angle = heading + chord / chords * sweep
        else:
            angle = heading + chord * step
        points = _append_point(
            points, count, centre_x + reach * math.sin(angle), centre_y + reach * -math.cos(angle)
        )
        count += 1
    return points, count


def _arc_points(
    start: NDArray[np.float64], heading: float, radius: float, sweep: float, max_chord: float
) -> NDArray[np.float64]:
    """Points after ``start`` along a circular arc, at equal chords of at most ``max_chord``.

    :param start: (2,) where the arc starts, heading ``heading`` (rad).
    :param sweep: signed turn (rad); positive turns left.
    """
    points = np.empty((1, 2))
    points[0] = start
    points, count = _append_arc(points, 1, heading, radius, sweep, max_chord)
    return points[1:count]


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
#: The shortest a polyline's last leg is cut to by default: the shortest leg.
SHORTEST_LAST_LEG = _LEG_LENGTH_RANGE[0]
_ARC_RADIUS_RANGE = (1.0, 4.0)
_ARC_SWEEP_RANGE = (math.radians(30), math.radians(180))
_STRAIGHT_PROBABILITY = 0.3
_STRAIGHT_LENGTH_RANGE = (0.5, 3.0)
# Chords of 10 cm on radii of 1 m or more deviate from the arc by at most 1.25 mm.
RANDOM_ARC_CHORD = 0.1


@njit(cache=True, inline="always")
def _random_sign(stream: Stream) -> float:
    return 1.0 if draw_double(stream) < 0.5 else -1.0


@njit(cache=True, inline="always")
def _polyline_walk(
    stream: Stream, target_length: float, shortest_last_leg: float
) -> NDArray[np.float64]:
    """Straight legs joined by corners; some corners are sharp (90 to 150 degrees).

    The last leg is cut to end at the target length, but kept at least
    ``shortest_last_leg`` long.
    """
    heading = draw_uniform(stream, -math.pi, math.pi)
    points = np.zeros((32, 2))
    count, length = 1, 0.0
    shortest, longest = _LEG_LENGTH_RANGE
    while length < target_length:
        if count > 1:
            sharp = draw_double(stream) < _SHARP_TURN_PROBABILITY
            low, high = (_GENTLE_TURN_MAX, RANDOM_MAX_TURN) if sharp else (0.0, _GENTLE_TURN_MAX)
            sign = _random_sign(stream)
            heading += sign * draw_uniform(stream, low, high)
        leg = draw_uniform(stream, shortest, longest)
        # A leg longer than what remains is the last: cut to end the walk at its length.
        leg = max(min(leg, target_length - length), shortest_last_leg)
        x, y = points[count - 1, 0], points[count - 1, 1]
        points = _append_point(
            points, count, x + leg * math.cos(heading), y + leg * math.sin(heading)
        )
        count += 1
        length += leg
    return points[:count]


@njit(cache=True, inline="always")
def _arc_walk(stream: Stream, target_length: float) -> NDArray[np.float64]:
    """A smooth path: circular arcs and straights joined tangentially, the arcs densified.

    The last piece is cut to end at the target length.
    """
    heading = draw_uniform(stream, -math.pi, math.pi)
    points = np.zeros((256, 2))
    count, length = 1, 0.0
    while length < target_length:
        remaining = target_length - length
        if draw_double(stream) < _STRAIGHT_PROBABILITY:
            straight = min(draw_uniform(stream, *_STRAIGHT_LENGTH_RANGE), remaining)
            x, y = points[count - 1, 0], points[count - 1, 1]
            points = _append_point(
                points, count, x + straight * math.cos(heading), y + straight * math.sin(heading)
            )
            count += 1
            length += straight
        else:
            radius = draw_uniform(stream, *_ARC_RADIUS_RANGE)
            sweep = min(draw_uniform(stream, *_ARC_SWEEP_RANGE), remaining / radius)
            sweep *= _random_sign(stream)
            points, count = _append_arc(points, count, heading, radius, sweep, RANDOM_ARC_CHORD)
            heading += sweep
            length += radius * abs(sweep)
    return points[:count]


@njit(cache=True, inline="always")
def _extent(points: NDArray[np.float64]) -> tuple[float, float, float, float]:
    """The smallest and largest x and y of the (M, 2) ``points``: low x, low y, high x, high y."""
    low_x = high_x = points[0, 0]
    low_y = high_y = points[0, 1]
    for point in range(1, points.shape[0]):
        low_x, high_x = min(low_x, points[point, 0]), max(high_x, points[point, 0])
        low_y, high_y = min(low_y, points[point, 1]), max(high_y, points[point, 1])
    return low_x, low_y, high_x, high_y


@njit(cache=True)
def draw_random_walk(
    stream: Stream, shortest_last_leg: float = SHORTEST_LAST_LEG
) -> tuple[NDArray[np.float64], bool, float]:
    """:func:`random_path`'s draws, in order: the length, the style, walks until one fits the
    area, its place in the area, and whether the start heading is drawn (and that heading).

    :return: the (M, 2) points in place, whether the start is misaligned, and its heading (0
        when it follows the first segment, which the caller computes).
    """
    target_length = draw_uniform(stream, *RANDOM_LENGTH_RANGE)
    polyline = draw_double(stream) < 0.5
    area_low, area_high = RANDOM_AREA
    while True:
        points = (
            _polyline_walk(stream, target_length, shortest_last_leg)
            if polyline
            else _arc_walk(stream, target_length)
        )
        low_x, low_y, high_x, high_y = _extent(points)
        slack_x = (area_high - area_low) - (high_x - low_x)
        slack_y = (area_high - area_low) - (high_y - low_y)
        if slack_x >= 0 and slack_y >= 0:
            break
    offset_x = area_low - low_x + draw_uniform(stream, 0.0, slack_x)
    offset_y = area_low - low_y + draw_uniform(stream, 0.0, slack_y)
    for point in range(points.shape[0]):
        points[point, 0] += offset_x
        points[point, 1] += offset_y
    if draw_double(stream) < RANDOM_MISALIGNED_START_PROBABILITY:
        return points, True, draw_uniform(stream, -math.pi, math.pi)
    return points, False, 0.0


@njit(cache=True)
def _draw_random_walks(
    streams: NDArray[np.uint64], shortest_last_leg: float
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.bool_], NDArray[np.float64]]:
    """:func:`draw_random_walk` from each row of ``streams`` (k, STREAM_WORDS): the walks'
    points end to end, where each starts (k + 1 offsets), whether each start is misaligned
    and its drawn heading."""
    count = streams.shape[0]
    offsets = np.zeros(count + 1, dtype=np.int64)
    misaligned = np.zeros(count, dtype=np.bool_)
    headings = np.zeros(count)
    points = np.empty((64 * count, 2))
    for walk in range(count):
        drawn, misaligned[walk], headings[walk] = draw_random_walk(streams[walk], shortest_last_leg)
        first, end = offsets[walk], offsets[walk] + drawn.shape[0]
        if end > points.shape[0]:
            points = _grown_rows(points, max(2 * points.shape[0], end), first)
        copy_rows(drawn, points, first)
        offsets[walk + 1] = end
    return points[: offsets[count]], offsets, misaligned, headings


def random_paths(
    rngs: Sequence[np.random.Generator], shortest_last_leg: float = SHORTEST_LAST_LEG
) -> list[Path]:
    """:func:`random_path` from each generator, in one compiled call for all of them: the
    same paths, bit for bit, and each generator left where ``random_path`` leaves it."""
    return through_streams(
        rngs,
        partial(random_paths_from_streams, shortest_last_leg=shortest_last_leg),
        lambda: [random_path(rng, shortest_last_leg) for rng in rngs],
    )


def random_paths_from_streams(
    streams: NDArray[np.uint64], shortest_last_leg: float = SHORTEST_LAST_LEG
) -> list[Path]:
    """:func:`random_paths` of the generators whose streams (:mod:`mobile_envs._kernels.pcg64`) are
    the rows of ``streams`` (k, STREAM_WORDS), which advance in place: the caller stores
    them back."""
    points, offsets, misaligned, drawn_headings = _draw_random_walks(
        streams, _checked_last_leg(shortest_last_leg)
    )
    geometry = PathGeometry(points, offsets)
    # An aligned start takes the first segment's heading: the C library's atan2 of the first
    # leg, as in random_path (a walk's first leg, 5 cm or more, is never dropped as a
    # duplicate).
    first_headings = _first_segment_headings(geometry.packed, geometry.packed_offsets)
    headings = np.where(misaligned, drawn_headings, first_headings)
    return Path._of_geometry(geometry, "random", headings.tolist())


def _checked_last_leg(shortest_last_leg: float) -> float:
    """``shortest_last_leg`` as a float; a ValueError unless it is a positive number."""
    if (
        isinstance(shortest_last_leg, bool)
        or not isinstance(shortest_last_leg, (int, float, np.integer, np.floating))
        or not math.isfinite(shortest_last_leg)
        or shortest_last_leg <= 0
    ):
        raise ValueError(
            f"shortest_last_leg must be a positive number of metres, got {shortest_last_leg!r}"
        )
    return float(shortest_last_leg)


def random_path(rng: np.random.Generator, shortest_last_leg: float = SHORTEST_LAST_LEG) -> Path:
    """A random training path inside the square :data:`RANDOM_AREA`.

    The rng picks a style (a polyline with some sharp corners, or smooth arcs and straights)
    and a length of 8 to 25 m (a polyline's last leg may run up to ``shortest_last_leg`` past
    it); every turn is at most 150 degrees and every polyline leg 1 to 4 m long but the last,
    which ends the walk at its length and is cut no shorter than ``shortest_last_leg``.
    A walk whose extent does not fit the area is drawn again; one that fits is placed at a
    random spot inside. The start heading is the first segment's heading, or, with probability
    :data:`RANDOM_MISALIGNED_START_PROBABILITY`, any heading: the course starts every path at
    heading 0 whatever its direction, so a policy must learn to turn towards the path. The
    same rng state gives the same path, bit for bit. The draws run in compiled code
    (:func:`draw_random_walk`, through :mod:`mobile_envs._kernels.pcg64`).

    :param rng: the random generator to draw from.
    :param shortest_last_leg: the shortest a polyline's last leg is cut to (m); by default
        :data:`SHORTEST_LAST_LEG`, the shortest leg. Shorter, more paths end soon after a
        corner (the course's Segments ends 0.79 m after one).
    :raises ValueError: for a ``shortest_last_leg`` that is not a positive number
    """
    last_leg = _checked_last_leg(shortest_last_leg)
    stream = stream_of(rng)
    points, misaligned, start_heading = draw_random_walk(stream, last_leg)
    store(rng, stream)
    if not misaligned:
        # The C library's atan2, as for the segment headings (PathGeometry), the same bits.
        first_leg = points[1] - points[0]
        start_heading = float(exact_math.arctan2(first_leg[1], first_leg[0]))
    return Path._generated(points, "random", start_heading)

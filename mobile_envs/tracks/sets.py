"""Tracks and the path-set catalogue: what an environment draws a path (and a maze) from.

A :class:`Track` is a path to follow and, in a maze, the maze whose walls the robot must
avoid. A :class:`PathSet` is a named source of tracks: a fixed tuple (:class:`FixedPathSet`),
a generator (:class:`GeneratedPathSet`) or a weighted mixture (:class:`MixedPathSet`). The
catalogue (:func:`path_set`, :func:`path_set_names`) names the course's paths, seed 003's
arc-and-straight path, random paths, the canonical maze and random mazes, and the training
mix of random paths and mazes.

It composes :mod:`mobile_envs.world.paths` and :mod:`mobile_envs.world.maze` (a maze's routes are
paths) and neither imports it: data flows from paths to mazes to tracks to the environments.
"""

from __future__ import annotations

import bisect
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache, partial

import numpy as np
from numpy.typing import NDArray

from mobile_envs._kernels.pcg64 import (
    store,
    store_streams,
    stream_doubles,
    stream_integers,
    stream_of,
    streams_of,
    through_streams,
)
from mobile_envs.world.maze import Maze, draw_maze_route, draw_maze_routes
from mobile_envs.world.paths import (
    LINE_NAMES,
    Path,
    arc_straight_path,
    course_path,
    random_path,
    random_paths_from_streams,
)

#: The seed the canonical maze (:func:`the_maze`) is carved with.
CANONICAL_MAZE_SEED = 0
#: Random mazes (:func:`random_maze`): cells per side, and the side of a cell (m).
RANDOM_MAZE_SIZE = 8
RANDOM_MAZE_CELL_SIZE = 1.5


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

    @property
    def draws(self) -> bool:
        """Whether a sample draws from its generator (a fixed set of one track does not)."""
        return True

    @abstractmethod
    def sample(self, rng: np.random.Generator) -> Track:
        """Draw a track.

        :param rng: the random generator; the same state gives the same track.
        """

    def sample_many(self, rngs: Sequence[np.random.Generator]) -> list[Track]:
        """Draw a track from each generator: ``[self.sample(rng) for rng in rngs]``, which
        sets that draw in compiled code compute in one call where every generator is a
        PCG64 (through :meth:`sample_streams`).

        :param rngs: distinct generators, one per track.
        """

        def one_by_one() -> list[Track]:
            return [self.sample(rng) for rng in rngs]

        if not self._draws_from_streams:
            return one_by_one()
        return through_streams(rngs, partial(self.sample_streams, rngs), one_by_one)

    def sample_streams(
        self, rngs: Sequence[np.random.Generator], streams: NDArray[np.uint64]
    ) -> list[Track]:
        """:meth:`sample_many` drawn from the generators' streams
        (:mod:`mobile_envs._kernels.pcg64`):
        row k of ``streams`` is generator ``rngs[k]``'s state, and the draws advance the rows
        in place, not the generators, for the caller to store back
        (:func:`~mobile_envs._kernels.pcg64.store_streams`) once it has drawn all it draws from them
        (the environments' restarts draw each robot's track, then its start pose).

        Sets that draw in Python (the default) store the rows, draw from the generators and
        read the rows again.

        :param rngs: distinct PCG64 generators, one per track.
        :param streams: (k, STREAM_WORDS) their streams.
        """
        store_streams(rngs, streams)
        tracks = [self.sample(rng) for rng in rngs]
        advanced = streams_of(rngs)
        assert advanced is not None  # PCG64s, as the streams were
        streams[:] = advanced
        return tracks

    @property
    def _draws_from_streams(self) -> bool:
        """Whether :meth:`sample_streams` draws from the streams themselves, in compiled
        code (then :meth:`sample_many` goes through it)."""
        return False

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
        if not self.draws:
            # rng.integers(1) draws nothing from the generator (its range is empty), so
            # skipping it leaves the same state, at a microsecond less a reset.
            return self._tracks[0]
        return self._tracks[rng.integers(len(self._tracks))]

    @property
    def draws(self) -> bool:
        return len(self._tracks) > 1

    def sample_streams(
        self, rngs: Sequence[np.random.Generator], streams: NDArray[np.uint64]
    ) -> list[Track]:
        if not self.draws:
            return [self._tracks[0]] * len(rngs)
        return [self._tracks[index] for index in stream_integers(streams, len(self._tracks))]

    @property
    def _draws_from_streams(self) -> bool:
        return self.draws  # one track: nothing to draw, nor streams to read


class GeneratedPathSet(PathSet):
    """Tracks made on demand by a generator function.

    :param name: the set's name.
    :param generate: makes a track from an rng, deterministically; a module-level function
        (not a lambda or a local function), for the set to pickle with the standard module.
    :param generate_from_streams: optionally, makes the tracks of many PCG64 generators at
        once from their streams (:mod:`mobile_envs._kernels.pcg64`), rows of a (k, STREAM_WORDS)
        array it advances in place: each the track ``generate`` makes from the generator
        (the same bits, each stream left where the generator would be); a module-level
        function too.
    """

    def __init__(
        self,
        name: str,
        generate: Callable[[np.random.Generator], Track],
        generate_from_streams: Callable[[NDArray[np.uint64]], list[Track]] | None = None,
    ) -> None:
        super().__init__(name)
        self._generate = generate
        self._generate_from_streams = generate_from_streams

    def sample(self, rng: np.random.Generator) -> Track:
        return self._generate(rng)

    def sample_streams(
        self, rngs: Sequence[np.random.Generator], streams: NDArray[np.uint64]
    ) -> list[Track]:
        if self._generate_from_streams is None:
            return super().sample_streams(rngs, streams)
        return self._generate_from_streams(streams)

    @property
    def _draws_from_streams(self) -> bool:
        return self._generate_from_streams is not None


class MixedPathSet(PathSet):
    """A mixture: each draw picks a member set with the given weights, then draws from it.

    :param sets: the member sets.
    :param weights: non-negative weights, one per set, normalized to probabilities.
    :param name: the set's name; by default built from the members' names and weights.
    """

    def __init__(
        self, sets: Sequence[PathSet], weights: Sequence[float], name: str | None = None
    ) -> None:
        array = np.asarray(weights, dtype=np.float64)
        if not sets or array.shape != (len(sets),):
            raise ValueError(
                f"need one weight per set and at least one set, got {len(sets)} sets "
                f"and weights of shape {array.shape}"
            )
        if not np.all(np.isfinite(array)) or np.any(array < 0) or array.sum() <= 0:
            raise ValueError(f"weights must be finite, >= 0 and not all 0, got {array}")
        if name is None:
            name = "+".join(
                f"{member.name}:{weight:g}" for member, weight in zip(sets, array, strict=True)
            )
        super().__init__(name)
        self._sets = tuple(sets)
        self._probabilities = array / array.sum()
        # rng.choice(len(sets), p=probabilities) draws one double and finds it in this
        # normalized cumulative sum; bisecting a list of floats does the same for a tenth
        # of the cost, a cost paid at every reset.
        cumulative = self._probabilities.cumsum()
        cumulative /= cumulative[-1]
        self._cumulative = cumulative.tolist()

    def sample(self, rng: np.random.Generator) -> Track:
        member = bisect.bisect_right(self._cumulative, rng.random())
        return self._sets[member].sample(rng)

    def sample_streams(
        self, rngs: Sequence[np.random.Generator], streams: NDArray[np.uint64]
    ) -> list[Track]:
        # Each generator draws its member, then its track from that member, as in sample:
        # the generators are distinct, so drawing every member first changes no draw. The
        # handful of robots a restart draws for are grouped in Python, where numpy's calls
        # would cost more than the grouping; when they all drew one member (a restart of
        # one robot always), that member draws from the streams as they are.
        cumulative = self._cumulative
        members = [
            bisect.bisect_right(cumulative, double)
            for double in stream_doubles(streams, 1)[:, 0].tolist()
        ]
        if len(set(members)) == 1:
            return self._sets[members[0]].sample_streams(rngs, streams)
        tracks: list[Track | None] = [None] * len(rngs)
        for member, member_set in enumerate(self._sets):
            drawers = [k for k, drawn in enumerate(members) if drawn == member]
            if drawers:
                member_streams = streams[drawers]
                drawn_tracks = member_set.sample_streams([rngs[k] for k in drawers], member_streams)
                streams[drawers] = member_streams
                for k, track in zip(drawers, drawn_tracks, strict=True):
                    tracks[k] = track
        return tracks  # type: ignore[return-value]  # every slot is filled

    @property
    def _draws_from_streams(self) -> bool:
        return True


# ---------------------------------------------------------------------------------------------
# Maze tracks


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


# ---------------------------------------------------------------------------------------------
# The catalogue


def _random_track(rng: np.random.Generator) -> Track:
    """A random path in open space (a module-level function, so the set pickles)."""
    return Track(random_path(rng))


def _random_tracks_from_streams(streams: NDArray[np.uint64]) -> list[Track]:
    """:func:`_random_track` of each generator whose stream is a row of ``streams``, the
    paths drawn in one call."""
    return [Track(path) for path in random_paths_from_streams(streams)]


def _course_set(name: str, path_names: Sequence[str]) -> PathSet:
    return FixedPathSet(name, [Track(course_path(path_name)) for path_name in path_names])


def _maze_set() -> PathSet:
    return FixedPathSet("maze", [the_maze()])


def _random_maze_set() -> PathSet:
    return GeneratedPathSet("random_maze", random_maze, random_mazes_from_streams)


def _training_set() -> PathSet:
    return MixedPathSet(
        [path_set("random"), path_set("random_maze")], [0.75, 0.25], name="training"
    )


_PATH_SET_BUILDERS: dict[str, Callable[[], PathSet]] = {
    **{name: partial(_course_set, name, [name]) for name in ("segments", "sharp_segments")},
    **{name: partial(_course_set, name, [name]) for name in LINE_NAMES},
    "lines": partial(_course_set, "lines", LINE_NAMES),
    "arc_straight": lambda: FixedPathSet("arc_straight", [Track(arc_straight_path())]),
    "random": lambda: GeneratedPathSet("random", _random_track, _random_tracks_from_streams),
    "maze": _maze_set,
    "random_maze": _random_maze_set,
    "training": _training_set,
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

"""Tracks and path sets: what an environment draws a path (and a maze) from.

A :class:`Track` is a path to follow and, in a maze, the maze whose walls the robot must
avoid. A :class:`PathSet` is a named source of tracks: a fixed tuple (:class:`FixedPathSet`),
a generator (:class:`GeneratedPathSet`) or a weighted mixture (:class:`MixedPathSet`). A set
carries what depends on it: the reflector layout beacon localization reads there
(:attr:`PathSet.reflectors`). The named sets are in the catalogue
(:mod:`mobile_envs.tracks.catalogue`), each defined in a module of its own.

It composes :mod:`mobile_envs.world.paths` and :mod:`mobile_envs.world.maze` (a maze's routes are
paths) and neither imports it: data flows from paths to mazes to tracks to the environments.
"""

from __future__ import annotations

import bisect
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mobile_envs._kernels.pcg64 import (
    store_streams,
    stream_doubles,
    stream_integers,
    streams_of,
    through_streams,
)
from mobile_envs.world.maze import Maze
from mobile_envs.world.paths import Path


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
    :param reflectors: (R, 2) positions (m) of the reflectors that beacon localization reads
        on the set's tracks (:mod:`mobile_envs.sensing.beacons`); None if it has no layout
        (beacon localization then needs them given).
    :raises ValueError: for reflectors that are not a finite (R, 2) array
    """

    def __init__(self, name: str, reflectors: ArrayLike | None = None) -> None:
        self.name = name
        self._reflectors = None if reflectors is None else _layout(name, reflectors)

    @property
    def reflectors(self) -> NDArray[np.float64] | None:
        """(R, 2) positions (m) of the set's reflector layout, read-only; None if it has
        none."""
        return self._reflectors

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
    :param reflectors: its reflector layout (see :class:`PathSet`).
    """

    def __init__(
        self, name: str, tracks: Sequence[Track], reflectors: ArrayLike | None = None
    ) -> None:
        super().__init__(name, reflectors)
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
    :param reflectors: its reflector layout (see :class:`PathSet`).
    """

    def __init__(
        self,
        name: str,
        generate: Callable[[np.random.Generator], Track],
        generate_from_streams: Callable[[NDArray[np.uint64]], list[Track]] | None = None,
        reflectors: ArrayLike | None = None,
    ) -> None:
        super().__init__(name, reflectors)
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
    :param reflectors: its reflector layout (see :class:`PathSet`); by default the members'
        layouts together, each distinct one once, in the members' order (None if a member
        has none).
    """

    def __init__(
        self,
        sets: Sequence[PathSet],
        weights: Sequence[float],
        name: str | None = None,
        reflectors: ArrayLike | None = None,
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
        if reflectors is None:
            reflectors = _joint_layout(sets)
        super().__init__(name, reflectors)
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


def _layout(name: str, reflectors: ArrayLike) -> NDArray[np.float64]:
    """Path set ``name``'s reflector positions as a read-only (R, 2) float64 array."""
    try:
        positions = np.array(reflectors, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(
            f"path set {name!r}: reflectors must be an (R, 2) array: {error}"
        ) from None
    if positions.ndim != 2 or positions.shape[1] != 2 or not np.isfinite(positions).all():
        raise ValueError(
            f"path set {name!r}: reflectors must be a finite (R, 2) array, got {reflectors!r}"
        )
    positions.flags.writeable = False
    return positions


def _joint_layout(sets: Sequence[PathSet]) -> NDArray[np.float64] | None:
    """The members' reflector layouts stacked, each distinct one once, in order; None if a
    member has none."""
    layouts: list[NDArray[np.float64]] = []
    for member in sets:
        layout = member.reflectors
        if layout is None:
            return None
        if not any(np.array_equal(layout, seen) for seen in layouts):
            layouts.append(layout)
    return np.vstack(layouts) if layouts else None

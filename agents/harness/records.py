"""What the harness records of an episode, and its summary over many, with 95% intervals."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from agents.harness.intervals import CONFIDENCE, t_interval, wilson_interval
from mobile_envs.tracks.sets import Track
from mobile_envs.world.maze import Maze
from mobile_envs.world.paths import Path


@dataclass
class EpisodeRecord:
    """What one episode did.

    :param completed: whether the robot reached the goal
    :param mean_abs_cte: mean |cross-track error| over the episode's steps (m)
    :param max_abs_cte: largest |cross-track error| (m)
    :param rms_cte: root mean square cross-track error (m)
    :param time: the episode's duration (s)
    :param time_to_goal: the time to reach the goal (s), NaN if it was not reached
    :param collision: whether it ended on a maze wall
    :param off_track: whether it ended beyond the env's ``max_cross_track``
    :param steps: the number of env steps
    :param trajectory: (T + 1, 3) poses (x, y, heading), from the start pose to the last one
    :param path: the episode's path
    :param maze: the maze whose walls the robot drove between, None in open space
    """

    completed: bool
    mean_abs_cte: float
    max_abs_cte: float
    rms_cte: float
    time: float
    time_to_goal: float
    collision: bool
    off_track: bool
    steps: int
    trajectory: NDArray[np.float64] = field(repr=False)
    path: Path = field(repr=False)
    maze: Maze | None = field(default=None, repr=False)

    @classmethod
    def measured(
        cls,
        cross_track_errors: NDArray[np.float64],
        trajectory: NDArray[np.float64],
        last_info: dict[str, bool],
        dt: float,
        track: Track,
    ) -> EpisodeRecord:
        """The record of an episode from its per-step cross-track errors, as the env computes
        its own end-of-episode metrics.

        :param cross_track_errors: (T,) the cross-track error after every step
        :param trajectory: (T + 1, 3) the poses from the start pose on
        :param last_info: the last step's ``is_success``, ``collision`` and ``off_track``
        :param dt: the env's step (s)
        :param track: the episode's track
        """
        errors = np.abs(cross_track_errors)
        completed = bool(last_info["is_success"])
        time = len(errors) * dt
        return cls(
            completed=completed,
            mean_abs_cte=float(np.mean(errors)),
            max_abs_cte=float(np.max(errors)),
            rms_cte=float(np.sqrt(np.mean(errors**2))),
            time=time,
            time_to_goal=time if completed else math.nan,
            collision=bool(last_info["collision"]),
            off_track=bool(last_info["off_track"]),
            steps=len(errors),
            trajectory=trajectory,
            path=track.path,
            maze=track.maze,
        )


@dataclass
class EvaluationResult:
    """The episodes of one agent on one env, and their summary.

    :param episodes: one record per episode, in seed order
    """

    episodes: list[EpisodeRecord]

    @property
    def summary(self) -> dict[str, float]:
        """Aggregates over the episodes, each episode weighted equally.

        - ``completion_rate``, ``collision_rate``, ``off_track_rate``: fractions of episodes
        - ``mean_abs_cte``: mean of the episodes' mean |cte| (m)
        - ``max_abs_cte``: largest |cte| of any episode (m)
        - ``rms_cte``: sqrt of the mean of the episodes' mean squared cte (m)
        - ``mean_time``: mean time to goal (s) over the completed episodes; NaN if none was
        - ``episodes``: the number of episodes
        """
        records = self.episodes
        if not records:
            raise ValueError("no episodes to summarize")
        times = [record.time_to_goal for record in records if record.completed]
        return {
            "completion_rate": float(np.mean([record.completed for record in records])),
            "mean_abs_cte": float(np.mean([record.mean_abs_cte for record in records])),
            "max_abs_cte": float(np.max([record.max_abs_cte for record in records])),
            "rms_cte": float(np.sqrt(np.mean([record.rms_cte**2 for record in records]))),
            "mean_time": float(np.mean(times)) if times else math.nan,
            "collision_rate": float(np.mean([record.collision for record in records])),
            "off_track_rate": float(np.mean([record.off_track for record in records])),
            "episodes": len(records),
        }

    def intervals(self, confidence: float = CONFIDENCE) -> dict[str, tuple[float, float]]:
        """Confidence intervals of the :attr:`summary`'s aggregates, (low, high) by its keys:

        - ``completion_rate``, ``collision_rate``, ``off_track_rate``: Wilson score intervals;
        - ``mean_abs_cte``, ``mean_time`` (over the completed episodes): Student t intervals
          of the mean, cut at 0 (neither can be negative);
        - ``rms_cte``: the square roots of the t interval of the mean squared cte, cut at 0.

        An aggregate over fewer than two episodes has (NaN, NaN) for a t interval;
        ``max_abs_cte``, an extreme, has none.

        :param confidence: the level, 0.95 by default
        """
        records = self.episodes
        count = len(records)
        if not count:
            raise ValueError("no episodes to summarize")
        low_square, high_square = _positive_t_interval(
            [record.rms_cte**2 for record in records], confidence
        )
        return {
            "completion_rate": wilson_interval(
                sum(record.completed for record in records), count, confidence
            ),
            "mean_abs_cte": _positive_t_interval(
                [record.mean_abs_cte for record in records], confidence
            ),
            "rms_cte": (math.sqrt(low_square), math.sqrt(high_square)),
            "mean_time": _positive_t_interval(
                [record.time_to_goal for record in records if record.completed], confidence
            ),
            "collision_rate": wilson_interval(
                sum(record.collision for record in records), count, confidence
            ),
            "off_track_rate": wilson_interval(
                sum(record.off_track for record in records), count, confidence
            ),
        }


def _positive_t_interval(values: list[float], confidence: float) -> tuple[float, float]:
    """The t interval of the mean of non-negative ``values``, its lower end cut at 0."""
    low, high = t_interval(values, confidence)
    return (low if math.isnan(low) else max(low, 0.0)), high

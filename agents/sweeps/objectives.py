"""What a sweep optimizes: harness metrics turned into Optuna objective values.

A sweep trial is scored on the evaluation harness's summary (:mod:`agents.harness.evaluate`) on
held-out paths, never on training reward. An :class:`Objective` names metrics in order:

- one metric: its value, in its own direction (``completion_rate`` up, the rest down);
- several metrics, ranked lexicographically (the default, completion rate then mean |cte|):
  one value that orders trials exactly as comparing the metrics in turn would;
- several metrics with ``pareto=True``: one Optuna objective each, and a Pareto front.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

#: Summary metrics a sweep can optimize, and the direction that is better.
DIRECTIONS = {
    "completion_rate": "maximize",
    "mean_abs_cte": "minimize",
    "max_abs_cte": "minimize",
    "rms_cte": "minimize",
    "mean_time": "minimize",
    "collision_rate": "minimize",
    "off_track_rate": "minimize",
}
#: Metrics that are fractions of episodes: multiples of 1 / episodes.
RATES = ("completion_rate", "collision_rate", "off_track_rate")
DEFAULT_METRICS = ("completion_rate", "mean_abs_cte")


def metric_value(summary: Mapping[str, float], metric: str) -> float:
    """One metric of a harness summary; ``mean_time`` is infinite when no episode finished
    (the summary's NaN), so it ranks behind every policy that reaches a goal."""
    value = float(summary[metric])
    if metric == "mean_time" and math.isnan(value):
        return math.inf
    return value


@dataclass(frozen=True)
class Objective:
    """The metrics a sweep optimizes and how they combine.

    :param metrics: names from :data:`DIRECTIONS`, most important first
    :param pareto: optimize each metric as its own objective (a Pareto front) instead of
        ranking them lexicographically. Optuna cannot prune multi-objective trials, so a
        Pareto sweep trains every trial to the end.
    :raises ValueError: for an unknown or repeated metric, or a lexicographic ranking in
        which a metric other than the last is not a rate (only rates, multiples of
        1 / episodes, leave room for the next metric between two of their values)
    """

    metrics: tuple[str, ...] = DEFAULT_METRICS
    pareto: bool = False

    def __post_init__(self) -> None:
        if not self.metrics:
            raise ValueError("objective needs at least one metric")
        unknown = [metric for metric in self.metrics if metric not in DIRECTIONS]
        if unknown:
            raise ValueError(f"unknown objective metrics {unknown}; known: {list(DIRECTIONS)}")
        if len(set(self.metrics)) != len(self.metrics):
            raise ValueError(f"objective metrics repeat: {list(self.metrics)}")
        if not self.pareto:
            for metric in self.metrics[:-1]:
                if metric not in RATES:
                    raise ValueError(
                        f"objective metric {metric!r} is not a rate ({', '.join(RATES)}), so "
                        f"no metric can rank after it; put it last or use pareto"
                    )

    @property
    def directions(self) -> list[str]:
        """Optuna's ``directions`` for the study."""
        if self.pareto:
            return [DIRECTIONS[metric] for metric in self.metrics]
        if len(self.metrics) == 1:
            return [DIRECTIONS[self.metrics[0]]]
        return ["maximize"]

    @property
    def label(self) -> str:
        """A short description, such as ``completion_rate > mean_abs_cte``."""
        return (" | " if self.pareto else " > ").join(self.metrics)

    def values(self, summary: Mapping[str, float]) -> list[float]:
        """The objective values of a harness summary, one per Optuna objective.

        The lexicographic value reads as ``g_1 (E+1)^(k-1) + ... + g_k`` in base E + 1
        (E episodes), where ``g`` counts the episodes on the good side of each rate; a last
        metric that is not a rate adds ``0.5 / (1 + x)`` for its value x >= 0, which lies in
        (0, 0.5] and so never outweighs one episode of the rates before it. Values of that
        last metric closer than the float resolution tie (about 1e-11 m for mean |cte| with
        20 episodes and two metrics).

        :param summary: :attr:`agents.harness.evaluate.EvaluationResult.summary`
        """
        if self.pareto or len(self.metrics) == 1:
            return [metric_value(summary, metric) for metric in self.metrics]
        episodes = int(summary["episodes"])
        value = 0.0
        for metric in self.metrics:
            x = metric_value(summary, metric)
            if metric in RATES:
                count = round(x * episodes)
                good = count if DIRECTIONS[metric] == "maximize" else episodes - count
                value = value * (episodes + 1) + good
            else:
                value += 0.5 / (1.0 + x)
        return [value]

    def to_attrs(self) -> dict[str, object]:
        """The objective as a study stores it, so every worker checks it optimizes the same."""
        return {"metrics": list(self.metrics), "pareto": self.pareto}

    @classmethod
    def from_attrs(cls, attrs: Mapping[str, object]) -> Objective:
        """The objective :meth:`to_attrs` stored."""
        metrics = attrs["metrics"]
        assert isinstance(metrics, Sequence)
        return cls(tuple(str(metric) for metric in metrics), bool(attrs["pareto"]))

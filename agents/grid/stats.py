"""Statistics over training seeds: mean with a Student-t interval, and rliable's interquartile
mean (IQM) with stratified bootstrap intervals (Agarwal et al., "Deep Reinforcement Learning
at the Edge of the Statistical Precipice", NeurIPS 2021).

The IQM is the mean of the middle 50% of the scores (scipy's ``trim_mean`` with 25% cut from
each end, as rliable computes it). Its interval comes from a percentile bootstrap that
resamples runs within each task (stratified), so every task keeps its number of runs.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats


def finite(values: ArrayLike) -> NDArray[np.float64]:
    """The finite values of ``values`` as a flat float array (NaN: nothing to measure)."""
    array = np.asarray(values, dtype=np.float64).ravel()
    return array[np.isfinite(array)]


def mean_interval(values: ArrayLike, confidence: float = 0.95) -> tuple[float, float]:
    """The mean of ``values`` and the half-width of its Student-t confidence interval.

    :param values: one score per run; NaN and infinite entries are left out
    :param confidence: the interval's coverage, in (0, 1)
    :return: (mean, half-width); the half-width is NaN with fewer than two values, and both
        are NaN with none
    """
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    scores = finite(values)
    if scores.size == 0:
        return math.nan, math.nan
    mean = float(np.mean(scores))
    if scores.size < 2:
        return mean, math.nan
    t = stats.t.ppf(0.5 + confidence / 2, df=scores.size - 1)
    return mean, float(t * np.std(scores, ddof=1) / math.sqrt(scores.size))


def interquartile_mean(values: ArrayLike) -> float:
    """The mean of the middle 50% of ``values`` (NaN and infinite entries left out)."""
    scores = finite(values)
    if scores.size == 0:
        return math.nan
    return float(stats.trim_mean(scores, proportiontocut=0.25))


def interquartile_means(samples: NDArray[np.float64]) -> NDArray[np.float64]:
    """The IQM of each row of ``samples``."""
    return np.asarray(stats.trim_mean(samples, proportiontocut=0.25, axis=1), dtype=np.float64)


def stratified_bootstrap_interval(
    tasks: Sequence[ArrayLike],
    statistic: Callable[[NDArray[np.float64]], NDArray[np.float64]] = interquartile_means,
    confidence: float = 0.95,
    repetitions: int = 2000,
    seed: int = 0,
) -> tuple[float, float]:
    """A percentile bootstrap interval of ``statistic`` over the runs of several tasks.

    Each repetition draws, for every task, as many runs as it has, with replacement, and
    applies ``statistic`` to all drawn scores together.

    :param tasks: the scores of each task's runs (NaN and infinite entries left out)
    :param statistic: maps an array of resamples, one per row, to one number per row
        (default: :func:`interquartile_means`)
    :param confidence: the interval's coverage, in (0, 1)
    :param repetitions: bootstrap resamples
    :param seed: seeds the resampling, so the same scores give the same interval
    :return: (low, high); NaN, NaN when there are no scores
    """
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    if repetitions < 1:
        raise ValueError(f"repetitions must be at least 1, got {repetitions}")
    groups = [scores for scores in (finite(task) for task in tasks) if scores.size]
    if not groups:
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    drawn = [group[rng.integers(0, group.size, (repetitions, group.size))] for group in groups]
    estimates = statistic(np.concatenate(drawn, axis=1))
    tail = (1 - confidence) / 2
    low, high = np.quantile(estimates, [tail, 1 - tail])
    return float(low), float(high)

"""agents.grid.stats against reference numbers, brute force and Monte Carlo coverage."""

import math

import numpy as np
import pytest

pytest.importorskip("scipy", reason="the grid's statistics need the sweep extra")

from agents.grid.stats import interquartile_mean, mean_interval, stratified_bootstrap_interval


def test_the_t_interval_of_ten_scores_uses_t_0975_with_9_degrees_of_freedom():
    scores = np.arange(10.0)  # mean 4.5, sample sd sqrt(55/6)
    mean, half_width = mean_interval(scores)
    assert mean == 4.5
    # t_{0.975, 9} = 2.262157 (statistical tables)
    assert half_width == pytest.approx(2.262157 * math.sqrt(55 / 6) / math.sqrt(10), rel=1e-6)


def test_the_95_percent_interval_covers_the_true_mean_95_percent_of_the_time():
    rng = np.random.default_rng(0)
    samples = rng.normal(3.0, 2.0, size=(4000, 10))
    covered = 0
    for sample in samples:
        mean, half_width = mean_interval(sample)
        covered += abs(mean - 3.0) <= half_width
    # 4000 trials: the coverage's standard error is 0.0034
    assert covered / len(samples) == pytest.approx(0.95, abs=0.012)


def test_one_score_has_no_interval_and_nan_scores_are_left_out():
    assert mean_interval([0.7]) == (0.7, pytest.approx(math.nan, nan_ok=True))
    mean, half_width = mean_interval([1.0, math.nan, 3.0, math.inf])
    assert mean == 2.0 and math.isfinite(half_width)
    assert all(math.isnan(value) for value in mean_interval([math.nan]))


def test_the_iqm_is_the_mean_of_the_middle_half():
    rng = np.random.default_rng(1)
    for size in (4, 8, 40):
        scores = rng.normal(size=size)
        ordered = np.sort(scores)
        quarter = size // 4
        assert interquartile_mean(scores) == pytest.approx(np.mean(ordered[quarter:-quarter]))
    assert interquartile_mean([0, 0, 0, 100, 1, 1, 1, -100]) == pytest.approx(0.5)


def row_means(samples):
    return np.mean(samples, axis=1)


def test_the_bootstrap_keeps_every_task_s_number_of_runs():
    # Task A's three runs all score 0, task B's one run 1: a stratified resample always holds
    # three zeros and one one, so its mean is 0.25 every time. Pooled resampling would vary.
    low, high = stratified_bootstrap_interval([[0, 0, 0], [1]], statistic=row_means)
    assert low == high == 0.25


def test_the_bootstrap_of_a_single_task_matches_resampling_it_one_draw_at_a_time():
    # Independent truth: the same draws, taken one resample at a time in a plain loop.
    scores = np.array([0.1, 0.4, 0.35, 0.8, 0.5, 0.05, 0.9, 0.6])
    rng = np.random.default_rng(7)
    draws = rng.integers(0, scores.size, (500, scores.size))
    loop = [interquartile_mean(scores[row]) for row in draws]
    expected = tuple(np.quantile(loop, [0.025, 0.975]))
    assert stratified_bootstrap_interval([scores], repetitions=500, seed=7) == pytest.approx(
        expected
    )


def test_the_bootstrap_interval_of_the_iqm_covers_it_and_is_reproducible():
    rng = np.random.default_rng(2)
    tasks = [rng.normal(0.5, 0.1, 10), rng.normal(0.7, 0.1, 10)]
    low, high = stratified_bootstrap_interval(tasks)
    iqm = interquartile_mean(np.concatenate(tasks))
    assert low < iqm < high
    assert high - low < 0.2
    assert stratified_bootstrap_interval(tasks) == (low, high)


def test_bad_settings_raise_naming_them():
    with pytest.raises(ValueError, match="confidence"):
        mean_interval([1, 2], confidence=1.5)
    with pytest.raises(ValueError, match="repetitions"):
        stratified_bootstrap_interval([[1, 2]], repetitions=0)

"""The harness's confidence intervals against closed forms, scipy and their coverage."""

import math

import numpy as np
import pytest

from agents.harness.intervals import (
    LARGE_DF,
    central_t_probability,
    t_interval,
    t_quantile,
    wilson_interval,
)


def test_the_t_quantile_has_its_closed_forms():
    # df 1 (Cauchy): tan(pi p / 2); df 2: t = 2 p / sqrt(2 (1 - p^2)) for P(|T| <= t) = p.
    for confidence in (0.5, 0.9, 0.95, 0.99):
        assert t_quantile(confidence, 1) == pytest.approx(math.tan(math.pi * confidence / 2))
        assert t_quantile(confidence, 2) == pytest.approx(
            confidence * math.sqrt(2.0 / (1.0 - confidence**2))
        )


def test_the_t_quantile_matches_the_tables():
    # Student's t table, 95% two-sided.
    for df, value in [(3, 3.182), (10, 2.228), (30, 2.042), (120, 1.980)]:
        assert t_quantile(0.95, df) == pytest.approx(value, abs=5e-4)


@pytest.mark.parametrize("df", [1, 2, 5, 9, 10, 49, 999, LARGE_DF, LARGE_DF + 1, 10**6])
@pytest.mark.parametrize("confidence", [0.8, 0.95, 0.999])
def test_the_t_quantile_matches_scipy(df, confidence):
    stats = pytest.importorskip("scipy.stats", reason="scipy is the independent reference")
    expected = stats.t.ppf(0.5 + confidence / 2, df)
    assert t_quantile(confidence, df) == pytest.approx(expected, rel=1e-11)


def test_the_central_probability_is_the_distribution_function():
    stats = pytest.importorskip("scipy.stats", reason="scipy is the independent reference")
    for df in (1, 2, 3, 4, 7, 8, 40):
        for t in (0.1, 1.0, 2.5, 10.0):
            expected = stats.t.cdf(t, df) - stats.t.cdf(-t, df)
            assert central_t_probability(t, df) == pytest.approx(expected, rel=1e-12)


def test_the_wilson_interval_matches_its_formula_and_stays_in_0_1():
    # 0 of 10, 10 of 10 and 7 of 10 at 95%, by the textbook formula with z = 1.959964.
    z = 1.959963984540054
    for successes in (0, 7, 10):
        n, p = 10, successes / 10
        centre = (p + z * z / 20) / (1 + z * z / 10)
        half = z / (1 + z * z / 10) * math.sqrt(p * (1 - p) / 10 + z * z / 400)
        low, high = wilson_interval(successes, n)
        assert (low, high) == pytest.approx((max(centre - half, 0), min(centre + half, 1)))
    assert wilson_interval(0, 10)[0] == 0.0
    assert wilson_interval(10, 10)[1] == 1.0
    assert wilson_interval(10, 10)[0] == pytest.approx(0.7225, abs=1e-4)


@pytest.mark.parametrize("episodes", [40, 100])
def test_the_wilson_interval_covers_the_rate_95_times_in_100(episodes):
    # Exact coverage: the binomial probability of the counts whose interval holds the rate.
    # Brown, Cai & DasGupta (2001): Wilson's coverage averages the nominal level over the
    # rates, dipping a few points below it only near the ends.
    coverages = []
    for rate in np.linspace(0.05, 0.95, 91):
        coverage = 0.0
        for successes in range(episodes + 1):
            low, high = wilson_interval(successes, episodes)
            if low <= rate <= high:
                coverage += (
                    math.comb(episodes, successes)
                    * rate**successes
                    * (1 - rate) ** (episodes - successes)
                )
        coverages.append(coverage)
    assert np.mean(coverages) == pytest.approx(0.95, abs=0.005)
    assert min(coverages) > 0.92


def test_the_t_interval_covers_the_mean_95_times_in_100():
    # Exact for normal samples: Monte Carlo, 4000 intervals of 5 values each (the estimate's
    # standard deviation is 0.0034).
    rng = np.random.default_rng(0)
    samples = rng.normal(0.05, 0.01, (4000, 5))
    covered = [low <= 0.05 <= high for low, high in map(t_interval, samples.tolist())]
    assert np.mean(covered) == pytest.approx(0.95, abs=0.015)


def test_misuse_is_refused():
    with pytest.raises(ValueError, match="confidence"):
        t_quantile(1.0, 3)
    with pytest.raises(ValueError, match="df"):
        t_quantile(0.95, 0)
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(3, 2)
    assert all(math.isnan(value) for value in t_interval([1.0]))

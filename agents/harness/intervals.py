"""Confidence intervals for the harness's summaries: Wilson score intervals for rates and
Student t intervals for means.

The Wilson interval (Wilson 1927) keeps its coverage near the nominal level for rates near 0
or 1 and for few episodes, where the normal approximation p +- z sqrt(p (1 - p) / n)
collapses to a point (a completion rate of 1.00 over 10 episodes is not certain). The t
interval assumes the episodes' values are independent draws, which the harness's episodes
are (each from its own seed); for n >= 30 or so it is also good for skewed values.

The t quantile needs no scipy: for integer degrees of freedom the distribution function has
a closed form (Abramowitz & Stegun 26.7.3-4), inverted by bisection; beyond
:data:`LARGE_DF` degrees of freedom the Cornish-Fisher expansion (A&S 26.7.5) is exact to
double precision.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from statistics import NormalDist

#: The confidence level the harness's tables print.
CONFIDENCE = 0.95
#: Degrees of freedom from which the t quantile comes from its asymptotic expansion.
LARGE_DF = 2000


def _check_confidence(confidence: float) -> float:
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence!r}")
    return float(confidence)


def normal_quantile(confidence: float) -> float:
    """z with P(|Z| <= z) = ``confidence`` for a standard normal Z (1.96 at 0.95)."""
    return NormalDist().inv_cdf(0.5 + 0.5 * _check_confidence(confidence))


def wilson_interval(
    successes: int, trials: int, confidence: float = CONFIDENCE
) -> tuple[float, float]:
    """The Wilson score interval of a rate: ``successes`` of ``trials``.

    :raises ValueError: unless 0 <= successes <= trials and trials >= 1
    """
    if trials < 1 or not 0 <= successes <= trials:
        raise ValueError(f"need 0 <= successes <= trials, trials >= 1; got {successes}/{trials}")
    z = normal_quantile(confidence)
    rate = successes / trials
    shrink = 1.0 + z * z / trials
    centre = (rate + z * z / (2.0 * trials)) / shrink
    half_width = z * math.sqrt(rate * (1.0 - rate) / trials + z * z / (4.0 * trials**2)) / shrink
    # At 0 and at 1 the ends are exactly 0 and 1; rounding would leave 1e-17 of them.
    low = 0.0 if successes == 0 else max(centre - half_width, 0.0)
    high = 1.0 if successes == trials else min(centre + half_width, 1.0)
    return low, high


def central_t_probability(t: float, df: int) -> float:
    """P(|T| <= t) for Student's T with ``df`` (a positive integer) degrees of freedom:
    A&S 26.7.3 (odd df) and 26.7.4 (even df), with theta = atan(t / sqrt(df))."""
    theta = math.atan(t / math.sqrt(df))
    cos_sq = math.cos(theta) ** 2
    total = term = 1.0
    if df % 2:
        if df == 1:
            return 2.0 * theta / math.pi
        for k in range(1, (df - 1) // 2):
            term *= 2.0 * k / (2.0 * k + 1.0) * cos_sq
            total += term
        return 2.0 / math.pi * (theta + math.sin(theta) * math.cos(theta) * total)
    for k in range(1, df // 2):
        term *= (2.0 * k - 1.0) / (2.0 * k) * cos_sq
        total += term
    return math.sin(theta) * total


def t_quantile(confidence: float, df: int) -> float:
    """t with P(|T| <= t) = ``confidence`` for Student's T with ``df`` degrees of freedom
    (12.706 for df 1, 1.984 for df 100 at 0.95).

    :raises ValueError: for a confidence outside (0, 1) or df below 1
    """
    confidence = _check_confidence(confidence)
    if df < 1:
        raise ValueError(f"df must be a positive integer, got {df!r}")
    if df > LARGE_DF:
        x = normal_quantile(confidence)
        return (
            x
            + (x**3 + x) / (4.0 * df)
            + (5 * x**5 + 16 * x**3 + 3 * x) / (96.0 * df**2)
            + (3 * x**7 + 19 * x**5 + 17 * x**3 - 15 * x) / (384.0 * df**3)
            + (79 * x**9 + 776 * x**7 + 1482 * x**5 - 1920 * x**3 - 945 * x) / (92160.0 * df**4)
        )
    low, high = 0.0, 1.0
    while central_t_probability(high, df) < confidence:
        low, high = high, 2.0 * high
    while high - low > 1e-13 * high:
        middle = 0.5 * (low + high)
        if central_t_probability(middle, df) < confidence:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


def t_interval(values: Sequence[float], confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The Student t interval of the mean of ``values``: mean +- t s / sqrt(n), s the sample
    standard deviation; (NaN, NaN) for fewer than two values."""
    count = len(values)
    if count < 2:
        return math.nan, math.nan
    mean = math.fsum(values) / count
    variance = math.fsum((value - mean) ** 2 for value in values) / (count - 1)
    half_width = t_quantile(confidence, count - 1) * math.sqrt(variance / count)
    return mean - half_width, mean + half_width

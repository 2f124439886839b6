"""The robustness study: its intervals against reference values, its plants, and one tiny
study written end to end."""

import json
import math

import numpy as np
import pytest

from agents.harness import robustness
from mobile_envs.sim.plant import CROWLEY_SLIP


@pytest.mark.parametrize(("successes", "trials"), [(0, 10), (5, 10), (49, 50), (50, 50), (3, 7)])
def test_wilson_intervals_are_the_roots_of_the_score_equation(successes, trials):
    """Wilson's interval holds the p with (p_hat - p)^2 = z^2 p (1 - p) / n: the roots of
    (1 + z^2/n) p^2 - (2 p_hat + z^2/n) p + p_hat^2 = 0."""
    z2 = 1.959963984540054**2
    rate = successes / trials
    roots = np.sort(np.roots([1 + z2 / trials, -(2 * rate + z2 / trials), rate * rate]).real)
    low, high = robustness.wilson_interval(successes, trials)
    assert low == pytest.approx(max(roots[0], 0.0), abs=1e-12)
    assert high == pytest.approx(min(roots[1], 1.0), abs=1e-12)
    # The textbook case: 5 of 10 gives about [0.237, 0.763].
    if (successes, trials) == (5, 10):
        assert (round(low, 3), round(high, 3)) == (0.237, 0.763)


@pytest.mark.parametrize(
    ("degrees", "tolerance"), [(5, 1e-3), (10, 2e-5), (29, 2e-6), (49, 1e-6), (999, 1e-9)]
)
def test_the_t_quantile_matches_scipy(degrees, tolerance):
    stats = pytest.importorskip("scipy.stats", reason="the reference quantiles need scipy")
    expected = stats.t.ppf(0.975, degrees)
    assert robustness.student_t_95(degrees) == pytest.approx(expected, rel=0, abs=tolerance)


def test_the_mean_interval_is_the_t_interval():
    values = [0.1, 0.2, 0.3, 0.4]
    mean, half = robustness.mean_interval(values)
    sd = math.sqrt(sum((v - 0.25) ** 2 for v in values) / 3)
    assert mean == pytest.approx(0.25)
    assert half == pytest.approx(robustness.student_t_95(3) * sd / 2)
    assert math.isnan(robustness.mean_interval([0.1])[1])


def test_each_plant_holds_one_imperfection_at_its_size():
    assert robustness.plant_of("delay", 0.0) is None
    assert robustness.plant_of("delay", 0.3) == {"delay": 0.3}
    assert robustness.plant_of("time_constant", 0.2) == {"time_constant": 0.2}
    assert robustness.plant_of("slip", 2.0) == {"slip": tuple(2 * k for k in CROWLEY_SLIP)}
    randomized = robustness.plant_of("parameter_errors", 0.06)["randomize"]
    assert randomized == {"parameter_errors": 0.06, "steering_offset": pytest.approx(0.04)}


def test_a_tiny_study_writes_its_table_plot_and_numbers(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib", reason="the plots need the render extra")
    monkeypatch.setitem(robustness.SIZES, "delay", (0.0, 0.3))
    output = tmp_path / "study"
    arguments = [
        "--models", "DiffDrive", "--paths", "Segments", "--imperfections", "delay",
        "--episodes", "2", "--no-policy", "--output", str(output),
    ]  # fmt: skip
    assert robustness.main(arguments) == 0
    table = (output / "DiffDrive.md").read_text()
    assert "delay-compensated pure pursuit" in table and "| delay | 0.3 s |" in table
    assert (output / "DiffDrive.png").stat().st_size > 10_000
    points = json.loads((output / "robustness.json").read_text())["DiffDrive"]
    assert len(points) == 3 * 2  # three classical agents, two sizes
    by_agent = {(p["agent"], p["size"]): p for p in points}
    # The compensated tracker is pure pursuit on the ideal robot, and better on the delayed.
    ideal = by_agent["pure pursuit", 0.0]
    assert by_agent["delay-compensated pure pursuit", 0.0]["mean_abs_cte"] == ideal["mean_abs_cte"]
    delayed = by_agent["pure pursuit", 0.3]["mean_abs_cte"]
    assert by_agent["delay-compensated pure pursuit", 0.3]["mean_abs_cte"] < delayed
    # An existing study is never overwritten unasked.
    assert robustness.main(arguments) == 2

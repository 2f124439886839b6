"""The robustness study: its intervals against reference values, its plants, and one tiny
study written end to end."""

import json
import math

import pytest

from agents.harness import robustness
from mobile_envs.sim.plant import CROWLEY_SLIP


def test_the_mean_interval_is_the_t_interval():
    values = [0.1, 0.2, 0.3, 0.4]
    mean, half = robustness.mean_interval(values)
    sd = math.sqrt(sum((v - 0.25) ** 2 for v in values) / 3)
    assert mean == pytest.approx(0.25)
    assert half == pytest.approx(3.182446305284263 * sd / 2)  # t(0.975, 3 degrees)
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

"""agents.sweeps.objectives: the lexicographic value orders trials exactly as comparing the metrics
in turn does; single and Pareto objectives pass the metrics through; bad specs are refused."""

import math

import pytest

pytest.importorskip("hypothesis", reason="the order properties need hypothesis (the dev extra)")

from hypothesis import given
from hypothesis import strategies as st

from agents.sweeps.objectives import DIRECTIONS, Objective

EPISODES = 20


def summary(completed: int, collided: int, mean_abs_cte: float, mean_time: float = 30.0):
    return {
        "completion_rate": completed / EPISODES,
        "collision_rate": collided / EPISODES,
        "off_track_rate": 0.0,
        "mean_abs_cte": mean_abs_cte,
        "max_abs_cte": 2 * mean_abs_cte,
        "rms_cte": 1.5 * mean_abs_cte,
        "mean_time": mean_time,
        "episodes": EPISODES,
    }


# Distances on a micrometre grid: far coarser than the value's float resolution (about
# 1e-11 m here), far finer than anything a tracker's accuracy could tell apart.
outcomes = st.tuples(
    st.integers(0, EPISODES),
    st.integers(0, EPISODES),
    st.integers(0, 5_000_000).map(lambda micrometres: micrometres * 1e-6),
)


@given(outcomes, outcomes)
def test_the_default_value_ranks_completion_first_then_mean_cte(first, second):
    objective = Objective()  # completion_rate, then mean_abs_cte
    (value_a,), (value_b,) = objective.values(summary(*first)), objective.values(summary(*second))
    # Independent truth: Python's tuple order on (more completions, less cross-track error).
    key_a, key_b = (first[0], -first[2]), (second[0], -second[2])
    if key_a > key_b:
        assert value_a > value_b
    elif key_a < key_b:
        assert value_a < value_b
    else:
        assert value_a == value_b


@given(outcomes, outcomes)
def test_two_rates_and_a_distance_rank_in_the_order_given(first, second):
    objective = Objective(("collision_rate", "completion_rate", "mean_abs_cte"))
    (value_a,), (value_b,) = objective.values(summary(*first)), objective.values(summary(*second))
    key_a = (-first[1], first[0], -first[2])  # fewer collisions, more completions, less cte
    key_b = (-second[1], second[0], -second[2])
    assert (value_a > value_b) == (key_a > key_b)
    assert (value_a == value_b) == (key_a == key_b)


def test_one_metric_is_its_own_value_and_direction():
    objective = Objective(("max_abs_cte",))
    assert objective.directions == ["minimize"]
    assert objective.values(summary(3, 0, 0.25)) == [0.5]
    assert Objective(("completion_rate",)).directions == ["maximize"]


def test_pareto_gives_one_value_per_metric_and_an_unfinished_sweep_time_of_infinity():
    objective = Objective(("completion_rate", "mean_abs_cte", "mean_time"), pareto=True)
    assert objective.directions == ["maximize", "minimize", "minimize"]
    assert objective.values(summary(5, 0, 0.1, 42.0)) == [0.25, 0.1, 42.0]
    assert objective.values(summary(0, 0, 0.1, math.nan))[2] == math.inf


def test_objectives_survive_the_round_trip_through_study_attributes():
    for objective in (Objective(), Objective(("mean_time", "rms_cte"), pareto=True)):
        assert Objective.from_attrs(objective.to_attrs()) == objective


@pytest.mark.parametrize(
    ("metrics", "pareto", "message"),
    [
        ((), False, "at least one metric"),
        (("speed",), False, "unknown objective metrics"),
        (("mean_abs_cte", "mean_abs_cte"), True, "repeat"),
        (("mean_abs_cte", "completion_rate"), False, "'mean_abs_cte' is not a rate"),
    ],
)
def test_bad_objectives_raise_naming_the_problem(metrics, pareto, message):
    with pytest.raises(ValueError, match=message):
        Objective(metrics, pareto)


def test_every_metric_has_a_direction():
    assert set(DIRECTIONS.values()) == {"maximize", "minimize"}

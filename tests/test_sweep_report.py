"""agents.sweeps.report on studies of known trials: the Pareto front against brute force, the
best trial's settings as a hyperparameter entry, the ranking, failed trials' errors, plots."""

import pytest

pytest.importorskip("yaml", reason="the report writes YAML (the train extra)")

import yaml

pytest.importorskip("optuna", reason="sweeps need the sweep extra")
pytest.importorskip("matplotlib", reason="the report's plots need matplotlib")

from optuna.distributions import FloatDistribution
from optuna.trial import TrialState, create_trial

from agents.sweeps.objectives import Objective
from agents.sweeps.report import ranked_trials, write_report
from agents.sweeps.storage import open_study

ENV_ID = "mobile_envs/DiffDrive-Random-v0"
#: (completion rate, mean |cte|) of the trials; the front is (0.9, 0.05), (0.7, 0.02), (0.5, 0.01).
OUTCOMES = [(0.9, 0.05), (0.7, 0.02), (0.5, 0.01), (0.7, 0.06), (0.4, 0.03), (0.9, 0.08)]
PNG = b"\x89PNG\r\n\x1a\n"


def study_of(tmp_path, objective):
    settings = {
        "base_config": {"env": ENV_ID},
        "objective": objective.to_attrs(),
        "eval_env": ENV_ID,
        "eval_episodes": 10,
        "eval_seed": 1_000_000,
    }
    study = open_study(str(tmp_path / "study.journal"), "report", settings)
    for index, (completion, cte) in enumerate(OUTCOMES):
        if objective.pareto:
            values = [completion, cte]
        else:
            summary = {"completion_rate": completion, "mean_abs_cte": cte, "episodes": 10}
            values = objective.values(summary)
        study.add_trial(
            create_trial(
                values=values,
                params={"learning_rate": 1e-4 * (index + 1)},
                distributions={"learning_rate": FloatDistribution(1e-5, 1e-2, log=True)},
                user_attrs={
                    "completion_rate": completion,
                    "mean_abs_cte": cte,
                    "settings": {"n_timesteps": 1000, "learning_rate": 1e-4 * (index + 1)},
                },
            )
        )
    study.add_trial(
        create_trial(state=TrialState.FAIL, user_attrs={"error": "ValueError: dt must be positive"})
    )
    return study


def dominates(a, b):
    """Completion up, |cte| down: a is no worse on both and better on one."""
    return a[0] >= b[0] and a[1] <= b[1] and a != b


def test_a_pareto_report_puts_the_brute_force_front_first(tmp_path):
    study = study_of(tmp_path, Objective(pareto=True))
    front = {
        index
        for index, outcome in enumerate(OUTCOMES)
        if not any(dominates(other, outcome) for other in OUTCOMES)
    }
    assert front == {0, 1, 2}
    ranked = [trial.number for trial in ranked_trials(study)]
    assert set(ranked[: len(front)]) == front
    # On the front, ranked on completion first, then |cte|: (0.9, 0.05) leads.
    assert ranked[0] == 0

    written = write_report(study, tmp_path / "report")
    names = {path.name for path in written}
    assert names == {
        "best_hyperparams.yml",
        "top_trials.md",
        "history.png",
        "importances.png",
        "pareto.png",
    }
    for path in written:
        if path.suffix == ".png":
            assert path.read_bytes()[:8] == PNG, path.name
    entry = yaml.safe_load((tmp_path / "report" / "best_hyperparams.yml").read_text())
    assert entry == {ENV_ID: {"n_timesteps": 1000, "learning_rate": 1e-4}}
    table = (tmp_path / "report" / "top_trials.md").read_text()
    assert "6 complete, 1 fail" in table
    assert "trial 6 failed: ValueError: dt must be positive" in table


def test_a_lexicographic_report_ranks_by_value_and_a_minimized_one_upwards(tmp_path):
    study = study_of(tmp_path / "lexicographic", Objective())
    ranked = [trial.number for trial in ranked_trials(study)]
    expected = sorted(range(len(OUTCOMES)), key=lambda i: (-OUTCOMES[i][0], OUTCOMES[i][1]))
    assert ranked == expected
    minimized = study_of(tmp_path / "minimized", Objective(("mean_abs_cte",)))
    assert [trial.number for trial in ranked_trials(minimized)] == sorted(
        range(len(OUTCOMES)), key=lambda i: OUTCOMES[i][1]
    )
    assert not (tmp_path / "report").exists()
    written = write_report(study, tmp_path / "report")
    assert "pareto.png" not in {path.name for path in written}


def test_a_report_needs_a_complete_trial_and_an_existing_study(tmp_path):
    study = open_study(
        str(tmp_path / "study.journal"),
        "empty",
        {"base_config": {"env": ENV_ID}, "objective": Objective().to_attrs()},
    )
    with pytest.raises(ValueError, match="no complete trial"):
        write_report(study, tmp_path / "report")
    with pytest.raises(ValueError, match="no sweep at"):
        open_study(str(tmp_path / "missing.journal"), "empty", None)
    with pytest.raises(ValueError, match="no study named 'other'"):
        open_study(str(tmp_path / "study.journal"), "other", None)

"""The results of a sweep (:mod:`agents.sweeps.sweep`): the best settings, the top trials, plots.

:func:`write_report` writes into a folder:

- ``best_hyperparams.yml``: the best trial's settings as an entry of ``hyperparams/ALGO.yml``
  (the env id as its key), ready to paste;
- ``top_trials.md``: the best complete trials with their harness metrics and parameters,
  and how many trials ended in each state;
- ``history.png``: the objective of every complete trial by trial number, and the best so far;
- ``importances.png``: each parameter's importance for the objective (PED-ANOVA), once two
  trials are complete;
- ``pareto.png`` (multi-objective studies): the complete trials on the first two metrics,
  the Pareto front marked.

The best trial is the one with the best value; in a multi-objective study, the trial of the
Pareto front that ranks first on the metrics taken in order.
"""

from __future__ import annotations

import math
import pathlib
import warnings
from typing import Any

import optuna
import yaml
from matplotlib.figure import Figure
from optuna.trial import FrozenTrial, TrialState

from agents.sweeps.objectives import DIRECTIONS, Objective
from agents.sweeps.storage import study_settings

TABLE_METRICS = (
    ("completion", "completion_rate", "{:.2f}"),
    ("mean abs cte (m)", "mean_abs_cte", "{:.4f}"),
    ("max abs cte (m)", "max_abs_cte", "{:.3f}"),
    ("mean time (s)", "mean_time", "{:.1f}"),
)


def objective_of(study: optuna.Study) -> Objective:
    """The objective the study was created with."""
    return Objective.from_attrs(study_settings(study)["objective"])


def metric_key(trial: FrozenTrial, objective: Objective) -> tuple[float, ...]:
    """A sort key, smaller is better, ranking trials on the objective's metrics in order."""
    key = []
    for index, metric in enumerate(objective.metrics):
        value = trial.values[index] if objective.pareto else trial.user_attrs[metric]
        if metric == "mean_time" and math.isnan(value):
            value = math.inf
        key.append(-value if DIRECTIONS[metric] == "maximize" else value)
    return tuple(key)


def ranked_trials(study: optuna.Study) -> list[FrozenTrial]:
    """The complete trials, best first (the Pareto front first in a multi-objective study)."""
    complete = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
    objective = objective_of(study)
    if not objective.pareto:
        maximize = study.direction == optuna.study.StudyDirection.MAXIMIZE
        return sorted(complete, key=lambda trial: -trial.values[0] if maximize else trial.values[0])
    front = {trial.number for trial in study.best_trials}
    return sorted(
        complete,
        key=lambda trial: (trial.number not in front, metric_key(trial, objective)),
    )


def hyperparams_entry(study: optuna.Study, trial: FrozenTrial) -> str:
    """``trial``'s settings as a hyperparameter YAML entry with a comment saying where they
    come from."""
    settings = study_settings(study)
    objective = objective_of(study)
    measured = "\n".join(
        f"#   {metric}: {trial.user_attrs[metric]:.4g}"
        for metric in DIRECTIONS
        if metric in trial.user_attrs
    )
    header = (
        f"# Best trial {trial.number} of study {study.study_name!r} (objective "
        f"{objective.label}),\n# measured on {settings['eval_episodes']} episodes of "
        f"{settings['eval_env']} from seed {settings['eval_seed']}:\n{measured}\n"
    )
    entry = {settings["base_config"]["env"]: trial.user_attrs["settings"]}
    return header + yaml.safe_dump(entry, sort_keys=False)


def format_cell(value: Any, style: str) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return style.format(value)


def top_table(study: optuna.Study, count: int = 10) -> str:
    """A markdown table of the ``count`` best complete trials, then the trial states."""
    objective = objective_of(study)
    value_titles = list(objective.metrics) if objective.pareto else [f"value ({objective.label})"]
    header = [
        "rank",
        "trial",
        *value_titles,
        *(title for title, _, _ in TABLE_METRICS),
        "parameters",
    ]
    lines = [
        f"Study {study.study_name!r}: objective {objective.label}.",
        "",
        "| " + " | ".join(header) + " |",
        "|" + "---|" * len(header),
    ]
    for rank, trial in enumerate(ranked_trials(study)[:count], start=1):
        values = [format_cell(value, "{:.6g}") for value in trial.values]
        metrics = [format_cell(trial.user_attrs.get(key), style) for _, key, style in TABLE_METRICS]
        parameters = ", ".join(
            f"{key}={value:.4g}" if isinstance(value, float) else f"{key}={value}"
            for key, value in trial.params.items()
        )
        lines.append(
            "| " + " | ".join([str(rank), str(trial.number), *values, *metrics, parameters]) + " |"
        )
    counts = {state.name: 0 for state in TrialState}
    for trial in study.get_trials(deepcopy=False):
        counts[trial.state.name] += 1
    lines += [
        "",
        "Trials: "
        + ", ".join(f"{count} {name.lower()}" for name, count in counts.items() if count),
    ]
    failed = [
        trial
        for trial in study.get_trials(deepcopy=False, states=(TrialState.FAIL,))
        if trial.user_attrs.get("error")
    ]
    for trial in failed:
        lines.append(f"- trial {trial.number} failed: {trial.user_attrs['error']}")
    return "\n".join(lines) + "\n"


def plot_history(study: optuna.Study, path: pathlib.Path) -> None:
    """Each complete trial's (first) objective value by trial number, and the best so far."""
    objective = objective_of(study)
    trials = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
    numbers = [trial.number for trial in trials]
    values = [trial.values[0] for trial in trials]
    maximize = objective.directions[0] == "maximize"
    best, running = [], -math.inf if maximize else math.inf
    for value in values:
        running = max(running, value) if maximize else min(running, value)
        best.append(running)
    figure = Figure(figsize=(7, 4))
    axes = figure.add_subplot()
    axes.plot(numbers, values, "o", label="trial")
    axes.step(numbers, best, where="post", color="C3", label="best so far")
    axes.set_xlabel("trial")
    name = (
        objective.metrics[0] if objective.pareto or len(objective.metrics) == 1 else objective.label
    )
    axes.set_ylabel(name)
    axes.set_title(f"{study.study_name}: optimization history")
    axes.legend(loc="best")
    figure.savefig(path, dpi=110, bbox_inches="tight")


def plot_importances(study: optuna.Study, path: pathlib.Path) -> bool:
    """A bar chart of the parameters' importances (PED-ANOVA) for the (first) objective; False
    when fewer than two trials are complete."""
    if len(study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))) < 2:
        return False
    maximize = objective_of(study).directions[0] == "maximize"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        warnings.filterwarnings("ignore", "PedAnovaImportanceEvaluator computes", UserWarning)
        importances = optuna.importance.get_param_importances(
            study,
            # PED-ANOVA ranks parameters by how they lead to low values.
            target=lambda trial: -trial.values[0] if maximize else trial.values[0],
            evaluator=optuna.importance.PedAnovaImportanceEvaluator(),
        )
    names = list(importances)[::-1]
    figure = Figure(figsize=(7, 0.6 + 0.35 * len(names)))
    axes = figure.add_subplot()
    axes.barh(names, [importances[name] for name in names])
    axes.set_xlabel("importance for the objective (PED-ANOVA)")
    axes.set_title(f"{study.study_name}: parameter importances")
    figure.savefig(path, dpi=110, bbox_inches="tight")
    return True


def plot_pareto(study: optuna.Study, path: pathlib.Path) -> None:
    """The complete trials on the first two metrics of a multi-objective study; the front
    marked."""
    objective = objective_of(study)
    front = {trial.number for trial in study.best_trials}
    figure = Figure(figsize=(6, 5))
    axes = figure.add_subplot()
    for on_front, style, label in ((False, "o", "trial"), (True, "*", "Pareto front")):
        trials = [
            trial
            for trial in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
            if (trial.number in front) == on_front
            and all(math.isfinite(value) for value in trial.values[:2])
        ]
        axes.plot(
            [trial.values[0] for trial in trials],
            [trial.values[1] for trial in trials],
            style,
            markersize=10 if on_front else 6,
            label=label,
        )
    axes.set_xlabel(f"{objective.metrics[0]} ({objective.directions[0]})")
    axes.set_ylabel(f"{objective.metrics[1]} ({objective.directions[1]})")
    axes.set_title(f"{study.study_name}: Pareto front")
    axes.legend(loc="best")
    figure.savefig(path, dpi=110, bbox_inches="tight")


def write_report(study: optuna.Study, folder: pathlib.Path) -> list[pathlib.Path]:
    """Write the report files into ``folder``; return their paths.

    :raises ValueError: when no trial of the study is complete yet
    """
    ranked = ranked_trials(study)
    if not ranked:
        raise ValueError(f"study {study.study_name!r} has no complete trial to report yet")
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    entry = folder / "best_hyperparams.yml"
    entry.write_text(hyperparams_entry(study, ranked[0]))
    table = folder / "top_trials.md"
    table.write_text(top_table(study))
    history = folder / "history.png"
    plot_history(study, history)
    written += [entry, table, history]
    importances = folder / "importances.png"
    if plot_importances(study, importances):
        written.append(importances)
    if objective_of(study).pareto and len(objective_of(study).metrics) >= 2:
        pareto = folder / "pareto.png"
        plot_pareto(study, pareto)
        written.append(pareto)
    return written

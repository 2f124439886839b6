"""The grid's results as one table: statistics across seeds per (model, path set, agent).

:func:`aggregate` groups the runs' harness summaries (:mod:`agents.grid.grid`) by the robot, the
path set and the agent (the algorithm, and its training env when that is not random
paths); :func:`write_results` writes ``grid.md`` (mean ± 95% Student-t interval, and the IQM
with its 95% stratified bootstrap interval; :mod:`agents.grid.stats`), ``grid.json`` (every
run and row) and ``iqm.png``. Rows with path set ``all`` pool every path set of a
(model, agent).
"""

from __future__ import annotations

import json
import math
import pathlib
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from agents.grid.stats import interquartile_mean, mean_interval, stratified_bootstrap_interval

#: (title, summary key, format) of the table's metrics.
METRICS = (
    ("completion", "completion_rate", "{:.2f}"),
    ("mean abs cte (m)", "mean_abs_cte", "{:.4f}"),
    ("max abs cte (m)", "max_abs_cte", "{:.3f}"),
    ("time to goal (s)", "mean_time", "{:.1f}"),
)
IQM_METRICS = ("completion_rate", "mean_abs_cte")


def split_env_id(env_id: str) -> tuple[str, str]:
    """``("DiffDrive", "Random")`` for ``mobile_envs/DiffDrive-Random-v0``.

    :raises ValueError: for an id not of the form ``mobile_envs/MODEL-PATHS-v0``
    """
    import mobile_envs

    name = env_id.removeprefix("mobile_envs/").removesuffix("-v0")
    model, _, paths = name.partition("-")
    if not env_id.startswith("mobile_envs/") or model not in mobile_envs.MODEL_IDS or not paths:
        raise ValueError(f"expected an env id mobile_envs/MODEL-PATHS-v0, got {env_id!r}")
    return model, paths


def agent_label(spec: dict[str, Any]) -> str:
    """The agent of a run: its algorithm, and its training env when not random paths; or the
    classical agent's name (:mod:`agents.grid.baselines`)."""
    if "agent" in spec:
        return str(spec["agent"])
    _, paths = split_env_id(spec["env"])
    return spec["algo"] if paths == "Random" else f"{spec['algo']} ({paths})"


def aggregate(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (model, path set, agent), and one per (model, agent) over all path sets
    (``path set`` ``all``), with the runs' scores per metric and their statistics."""
    cells: dict[tuple[str, str, str], dict[str, list[float]]] = {}
    for record in sorted(records, key=lambda record: record["run"]):
        agent = agent_label(record["spec"])
        for env_id, summary in record["results"].items():
            model, paths = split_env_id(env_id)
            scores = cells.setdefault((model, paths, agent), {})
            for _, key, _ in METRICS:
                scores.setdefault(key, []).append(float(summary[key]))
    rows = []
    groups: dict[tuple[str, str], list[tuple[str, dict[str, list[float]]]]] = {}
    for (model, paths, agent), scores in cells.items():
        groups.setdefault((model, agent), []).append((paths, scores))
        rows.append(row(model, paths, agent, [scores]))
    for (model, agent), members in groups.items():
        if len(members) > 1:
            rows.append(row(model, "all", agent, [scores for _, scores in members]))
    return rows


def row(
    model: str, paths: str, agent: str, tasks: Sequence[dict[str, list[float]]]
) -> dict[str, Any]:
    """The statistics of one row over the runs of one or more tasks (path sets).

    Over several tasks, the mean and its interval are those of each run's mean over the
    tasks (the runs are the independent samples), and the IQM is rliable's: of all the
    scores, with the bootstrap resampling runs within each task.
    """
    result: dict[str, Any] = {"model": model, "path set": paths, "agent": agent}
    result["runs"] = len(tasks[0]["completion_rate"])
    for _, key, _ in METRICS:
        every = [score for task in tasks for score in task[key]]
        per_run = np.array([task[key] for task in tasks], dtype=np.float64)  # tasks x runs
        per_run[~np.isfinite(per_run)] = np.nan
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # no finite score: NaN
            run_means = np.nanmean(per_run, axis=0)
        mean, half_width = mean_interval(run_means)
        result[key] = {"scores": every, "mean": mean, "ci95": half_width}
        if key in IQM_METRICS:
            result[key]["iqm"] = interquartile_mean(every)
            result[key]["iqm_ci95"] = list(
                stratified_bootstrap_interval([task[key] for task in tasks])
            )
    return result


def format_mean(statistics: dict[str, Any], style: str) -> str:
    mean, half_width = statistics["mean"], statistics["ci95"]
    if math.isnan(mean):
        return "-"
    if math.isnan(half_width):
        return style.format(mean)
    return f"{style.format(mean)} ± {style.format(half_width)}"


def format_iqm(statistics: dict[str, Any], style: str) -> str:
    if math.isnan(statistics["iqm"]):
        return "-"
    low, high = statistics["iqm_ci95"]
    return f"{style.format(statistics['iqm'])} [{style.format(low)}, {style.format(high)}]"


def markdown_table(rows: Sequence[dict[str, Any]]) -> str:
    """The grid's table: mean ± 95% CI per metric, IQM [95% bootstrap CI] for some."""
    header = ["model", "path set", "agent", "runs"]
    for title, key, _ in METRICS:
        header.append(f"{title} mean ± 95% CI")
        if key in IQM_METRICS:
            header.append(f"{title} IQM [95% CI]")
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for entry in rows:
        cells = [entry["model"], entry["path set"], entry["agent"], str(entry["runs"])]
        for _, key, style in METRICS:
            cells.append(format_mean(entry[key], style))
            if key in IQM_METRICS:
                cells.append(format_iqm(entry[key], style))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def plot_iqm(rows: Sequence[dict[str, Any]], path: pathlib.Path) -> None:
    """rliable-style interval estimates: each row's IQM and its 95% bootstrap CI per metric."""
    from matplotlib.figure import Figure

    labels = [f"{entry['model']} {entry['path set']} {entry['agent']}" for entry in rows]
    figure = Figure(figsize=(10, 0.8 + 0.35 * len(rows)))
    for index, key in enumerate(IQM_METRICS):
        axes = figure.add_subplot(1, len(IQM_METRICS), index + 1)
        for position, entry in enumerate(rows):
            low, high = entry[key]["iqm_ci95"]
            axes.plot([low, high], [position, position], color="C0", linewidth=6, alpha=0.5)
            axes.plot([entry[key]["iqm"]], [position], "|", color="black", markersize=12)
        axes.set_yticks(range(len(rows)))
        axes.set_yticklabels(labels if index == 0 else [])
        axes.set_xlabel(f"{key} (IQM, 95% CI)")
        axes.invert_yaxis()
    figure.savefig(path, dpi=110, bbox_inches="tight")


def write_results(records: Sequence[dict[str, Any]], output: pathlib.Path) -> str:
    """Write ``grid.json``, ``grid.md`` and ``iqm.png``; return the table."""
    rows = aggregate(records)
    table = markdown_table(rows)
    (output / "grid.md").write_text(table)
    runs = sorted(records, key=lambda record: record["run"])
    (output / "grid.json").write_text(json.dumps({"runs": runs, "rows": rows}, indent=1))
    plot_iqm(rows, output / "iqm.png")
    return table

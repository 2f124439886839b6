"""The robustness study: learned and classical trackers on robots that do not do exactly what
they are told.

``python -m agents.harness.robustness`` sweeps one imperfection of the plant
(:mod:`mobile_envs.sim.plant`) at a time, every agent meeting the same episodes at every
size (episode i resets with seed ``seed + i``):

============================  ====================================================
imperfection                  sizes
============================  ====================================================
delay                         0 to 0.4 s
time constant (lag)           0 to 0.5 s
parameter errors              0 to 10 % (each drawn per episode in +-size; the
                              steering offset in +-2/3 size rad, as the realistic
                              preset's 3 % and 0.02 rad)
slip                          0 to 4 x Crowley's eq. 17 coefficients
============================  ====================================================

It writes ``OUTPUT/robustness.md``, a page with a section per model: where the policy
falls behind (:func:`verdict`), the plot ``OUTPUT/<Model>.png`` (completion and mean
|cross-track error| against each imperfection's size, one line per agent) and the table
(completion with its 95% Wilson interval, mean |cte| with its 95% Student-t interval, per
agent and size, over the path sets); and the numbers, ``OUTPUT/robustness.json``.
``docs/robustness/`` is this command's output with its defaults. The agents:
pure pursuit, delay-compensated pure pursuit (told the plant's delay and lag), regulated
pure pursuit, and the model's shipped PPO policy (``models/<model>_ppo.zip``) when there is
one. Needs the ``render`` extra (matplotlib) for the plots and ``train`` for the policies.
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

import mobile_envs
from agents.controllers.delay_compensation import DelayCompensated
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from agents.harness.evaluate import evaluate
from agents.harness.intervals import t_interval, wilson_interval
from mobile_envs.envs.registration import path_set_ids
from mobile_envs.sim.plant import CROWLEY_SLIP

PROG = "python -m agents.harness.robustness"
MODELS_DIR = pathlib.Path(__file__).resolve().parents[2] / "models"
#: The shipped policy of each model, by its id prefix.
SHIPPED_POLICIES = {
    "ConstantVelocity": "constant_velocity_ppo.zip",
    "DiffDrive": "diffdrive_ppo.zip",
    "Bicycle": "bicycle_ppo.zip",
    "Tricycle": "tricycle_ppo.zip",
    "Mecanum": "mecanum_ppo.zip",
}
#: Each imperfection's sizes, and the plant of a size.
SIZES = {
    "delay": (0.0, 0.1, 0.2, 0.3, 0.4),
    "time_constant": (0.0, 0.1, 0.2, 0.3, 0.4, 0.5),
    "parameter_errors": (0.0, 0.025, 0.05, 0.075, 0.1),
    "slip": (0.0, 1.0, 2.0, 3.0, 4.0),
}
UNITS = {"delay": "s", "time_constant": "s", "parameter_errors": "", "slip": "x Crowley"}


def plant_of(imperfection: str, size: float) -> dict[str, Any] | None:
    """The plant with ``imperfection`` at ``size`` and nothing else (None: the ideal robot)."""
    if size == 0.0:
        return None
    if imperfection == "parameter_errors":
        return {"randomize": {"parameter_errors": size, "steering_offset": 2.0 / 3.0 * size}}
    if imperfection == "slip":
        return {"slip": tuple(size * coefficient for coefficient in CROWLEY_SLIP)}
    return {imperfection: size}


def mean_interval(values: Sequence[float]) -> tuple[float, float]:
    """The mean and the half-width of its 95% Student-t interval (NaN below two values)."""
    if not values:
        return math.nan, math.nan
    low, high = t_interval(values)
    return math.fsum(values) / len(values), 0.5 * (high - low)


@dataclass(frozen=True)
class Point:
    """One agent at one size of one imperfection, over the path sets' episodes."""

    agent: str
    imperfection: str
    size: float
    completed: int
    episodes: int
    mean_abs_cte: float
    mean_abs_cte_half_width: float

    @property
    def completion(self) -> float:
        return self.completed / self.episodes

    @property
    def completion_interval(self) -> tuple[float, float]:
        return wilson_interval(self.completed, self.episodes)


def make_agents(model_id: str, with_policy: bool) -> dict[str, Any]:
    """The study's agents for a model: classical ones, and its shipped policy if any."""
    agents: dict[str, Any] = {
        "pure pursuit": PurePursuit(),
        "delay-compensated pure pursuit": DelayCompensated(PurePursuit()),
        "regulated pure pursuit": RegulatedPurePursuit(),
    }
    policy = MODELS_DIR / SHIPPED_POLICIES.get(model_id, "")
    if with_policy and policy.is_file():
        from agents.harness.policies import load_policy

        agents["shipped PPO"] = load_policy(policy)
    return agents


def measure(
    model_id: str,
    path_sets: Sequence[str],
    episodes: int,
    seed: int,
    imperfections: Sequence[str],
    with_policy: bool = True,
) -> list[Point]:
    """Every agent at every size of every imperfection, on ``episodes`` episodes of each path
    set (start noise 0.2 m, 0.3 rad, as the learned-tracker targets)."""
    points: list[Point] = []
    for name, agent in make_agents(model_id, with_policy).items():
        for imperfection in imperfections:
            for size in SIZES[imperfection]:
                completed, means = 0, []
                for paths in path_sets:
                    result = evaluate(
                        agent,
                        f"mobile_envs/{model_id}-{paths}-v0",
                        episodes,
                        seed=seed,
                        start_noise=(0.2, 0.3),
                        plant=plant_of(imperfection, size),
                    )
                    completed += sum(record.completed for record in result.episodes)
                    means += [record.mean_abs_cte for record in result.episodes]
                mean, half = mean_interval(means)
                points.append(Point(name, imperfection, size, completed, len(means), mean, half))
                print(
                    f"{model_id} {name} {imperfection}={size:g}: completion "
                    f"{completed / len(means):.2f}, mean |cte| {mean:.3f} m",
                    flush=True,
                )
    return points


#: The learned agent, whose standing the verdict states.
POLICY = "shipped PPO"
#: A classical agent beats the policy at a size when it completes this much more, or as much
#: (within it) with a mean |cte| whose interval lies wholly below the policy's.
COMPLETION_MARGIN = 0.02


def beats(rival: Point, policy: Point) -> bool:
    """Whether ``rival`` does better than ``policy`` beyond noise (:data:`COMPLETION_MARGIN`,
    the mean |cte|'s intervals apart)."""
    if rival.completion >= policy.completion + COMPLETION_MARGIN:
        return True
    upper = rival.mean_abs_cte + rival.mean_abs_cte_half_width
    lower = policy.mean_abs_cte - policy.mean_abs_cte_half_width
    return rival.completion >= policy.completion - COMPLETION_MARGIN and upper < lower


def verdict(points: Sequence[Point]) -> list[str]:
    """One line per imperfection: the smallest size at which a classical agent beats the
    policy (:func:`beats`), and by how much; or that none does. Empty without a policy."""
    if not any(point.agent == POLICY for point in points):
        return []
    lines = []
    for imperfection in dict.fromkeys(point.imperfection for point in points):
        mine = [point for point in points if point.imperfection == imperfection]
        unit = f" {UNITS[imperfection]}" if UNITS[imperfection] else ""
        for size in dict.fromkeys(point.size for point in mine):
            at_size = [point for point in mine if point.size == size]
            policy = next(point for point in at_size if point.agent == POLICY)
            rivals = [p for p in at_size if p.agent != POLICY and beats(p, policy)]
            if rivals:
                better = "; ".join(
                    f"{p.agent} {p.completion:.2f}, {p.mean_abs_cte:.3f} m" for p in rivals
                )
                lines.append(
                    f"{imperfection}: the policy falls behind at {size:g}{unit} (completion "
                    f"{policy.completion:.2f}, mean |cte| {policy.mean_abs_cte:.3f} m; {better})"
                )
                break
        else:
            largest = mine[-1].size
            lines.append(f"{imperfection}: the policy leads or ties up to {largest:g}{unit}")
    return lines


def section(model_id: str, points: Sequence[Point]) -> str:
    """A model's part of the page: the verdict, the plot and the table."""
    lines = [f"## {model_id}", ""]
    lines += [f"- {line}" for line in verdict(points)] or ["No shipped policy: classical only."]
    lines += ["", f"![{model_id}]({model_id}.png)", "", table(model_id, points)]
    return "\n".join(lines)


def table(model_id: str, points: Sequence[Point]) -> str:
    """The points as a markdown table, one row per (imperfection, size), a column per agent."""
    agents = list(dict.fromkeys(point.agent for point in points))
    lines = [
        f"{model_id}: completion [95% Wilson interval]; mean |cte| (m) +- its 95% Student-t "
        "half-width",
        "",
        "| imperfection | size | " + " | ".join(agents) + " |",
        "|---|---|" + "---|" * len(agents),
    ]
    keys = list(dict.fromkeys((point.imperfection, point.size) for point in points))
    for imperfection, size in keys:
        cells = []
        for agent in agents:
            point = next(
                p
                for p in points
                if (p.agent, p.imperfection, p.size) == (agent, imperfection, size)
            )
            low, high = point.completion_interval
            cells.append(
                f"{point.completion:.2f} [{low:.2f}, {high:.2f}]; "
                f"{point.mean_abs_cte:.3f} +- {point.mean_abs_cte_half_width:.3f}"
            )
        unit = UNITS[imperfection]
        lines.append(f"| {imperfection} | {size:g} {unit} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def plot(model_id: str, points: Sequence[Point], output: pathlib.Path) -> None:
    """Completion and mean |cte| against each imperfection's size, a line per agent, with
    their intervals as bands."""
    from matplotlib.figure import Figure

    imperfections = list(dict.fromkeys(point.imperfection for point in points))
    agents = list(dict.fromkeys(point.agent for point in points))
    figure = Figure(figsize=(4 * len(imperfections), 6.5), layout="constrained")
    axes = figure.subplots(2, len(imperfections), squeeze=False)
    for column, imperfection in enumerate(imperfections):
        for agent in agents:
            mine = [p for p in points if p.agent == agent and p.imperfection == imperfection]
            sizes = [p.size for p in mine]
            intervals = np.array([p.completion_interval for p in mine])
            (line,) = axes[0, column].plot(sizes, [p.completion for p in mine], "o-", label=agent)
            axes[0, column].fill_between(
                sizes, intervals[:, 0], intervals[:, 1], color=line.get_color(), alpha=0.15
            )
            means = np.array([p.mean_abs_cte for p in mine])
            halves = np.nan_to_num(np.array([p.mean_abs_cte_half_width for p in mine]))
            axes[1, column].plot(sizes, means, "o-", color=line.get_color())
            axes[1, column].fill_between(
                sizes, means - halves, means + halves, color=line.get_color(), alpha=0.15
            )
        unit = UNITS[imperfection]
        axes[1, column].set_xlabel(f"{imperfection} ({unit})" if unit else imperfection)
        axes[0, column].set_ylim(-0.02, 1.02)
        axes[1, column].set_yscale("log")
    axes[0, 0].set_ylabel("completion")
    axes[1, 0].set_ylabel("mean |cross-track error| (m)")
    axes[0, 0].legend(fontsize="small")
    figure.suptitle(f"{model_id}: one imperfection at a time")
    figure.savefig(output, dpi=110)


def page(args: argparse.Namespace, sections: Sequence[str]) -> str:
    """The study's page: what was measured, with the command, then each model's section."""
    command = f"{PROG} --episodes {args.episodes} --seed {args.seed}"
    header = [
        "# Robustness: learned and classical trackers on an imperfect robot",
        "",
        "One imperfection of the plant at a time ([the plant](../manual.md)), every agent on",
        f"the same {args.episodes} episodes per path set and size ({', '.join(args.paths)};",
        "start noise 0.2 m, 0.3 rad). Pure pursuit, delay-compensated pure pursuit (it replays",
        "the commands still in the delay through the lag it is told of: with no delay it is pure",
        "pursuit) and regulated pure pursuit steer with the nominal model, as real controllers",
        "do. The shipped PPO policies were trained on a robot drawn anew each episode (their",
        "entries in hyperparams/ppo.yml).",
        "Regenerate this page and its plots with",
        "",
        "```bash",
        f"{command} --output docs/robustness --overwrite",
        "```",
        "",
    ]
    return "\n".join(header) + "\n" + "\n".join(sections)


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    models = list(mobile_envs.MODEL_IDS)
    parser.add_argument("--models", nargs="+", choices=models, default=models)
    parser.add_argument(
        "--paths", nargs="+", default=["Lines", "Segments", "SharpSegments", "Maze"]
    )
    parser.add_argument("--imperfections", nargs="+", choices=list(SIZES), default=list(SIZES))
    parser.add_argument("--episodes", type=int, default=50, help="per path set and size")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--output", type=pathlib.Path, default=pathlib.Path("robustness"))
    parser.add_argument("--no-policy", action="store_true", help="classical agents only")
    parser.add_argument(
        "--overwrite", action="store_true", help="write into an --output that holds files"
    )
    args = parser.parse_args(argv)
    if args.episodes < 2:
        parser.error(f"--episodes must be at least 2, got {args.episodes}")
    if args.seed < 0:
        parser.error(f"--seed must be >= 0, got {args.seed}")
    known = set(path_set_ids())
    for paths in args.paths:
        if paths not in known:
            parser.error(f"--paths: unknown path set {paths!r}; known: {sorted(known)}")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.output.is_dir() and any(args.output.iterdir()) and not args.overwrite:
        print(
            f"{PROG}: error: --output {args.output} holds files; choose another folder or "
            "pass --overwrite",
            file=sys.stderr,
        )
        return 2
    args.output.mkdir(parents=True, exist_ok=True)
    results: dict[str, list[dict[str, Any]]] = {}
    sections = []
    for model_id in args.models:
        points = measure(
            model_id, args.paths, args.episodes, args.seed, args.imperfections, not args.no_policy
        )
        plot(model_id, points, args.output / f"{model_id}.png")
        sections.append(section(model_id, points))
        results[model_id] = [{**point.__dict__, "completion": point.completion} for point in points]
        print(f"{model_id}: wrote {args.output / model_id}.png", flush=True)
    (args.output / "robustness.md").write_text(page(args, sections))
    (args.output / "robustness.json").write_text(json.dumps(results, indent=1))
    print(f"wrote {args.output.resolve()}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

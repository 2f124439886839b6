"""Learned trackers against the classical ones on paths they never trained on: the targets.

    python benchmarks/bench_ppo_targets.py [--episodes 50] [--models diff_drive bicycle ...]
        [--localization odometry+beacons] [--policy runs/X/final_model.zip] [--ideal-only]

Each shipped policy in ``models/`` (trained on random paths and random mazes only, never on
the course paths or the canonical maze) meets the classical trackers on Segments,
SharpSegments, Lines and the canonical Maze, every agent on the same episodes (episode i
resets with seed i): PurePursuit (MATLAB mode, the course's controller) and
RegulatedPurePursuit on the ideal robot, once with start-pose noise (0.2 m, 0.3 rad) and once
without; and, with the start noise, pure pursuit, DelayCompensated pure pursuit and regulated
pure pursuit on the realistic plant (``plant="realistic"``: delay, lag, parameter errors and
slip, :mod:`mobile_envs.sim.plant`). Targets, per model:

- ideal robot, per noise setting: completion >= 98% on every path set; mean |cross-track
  error| below both pure pursuit's and regulated pure pursuit's; max |cross-track error| on
  SharpSegments at most regulated pure pursuit's; time to goal at most 1.1 times regulated
  pure pursuit's;
- on 200 random training-style tracks (paths and mazes) from the held-out seeds
  :data:`HELD_OUT_SEED` on, which no training run draws (train.py seeds its robots 0 to
  n_envs - 1), completion >= 98%;
- realistic plant: completion >= 98% on every path set and mean |cross-track error| below
  pure pursuit's, delay-compensated pure pursuit's and regulated pure pursuit's;
- steering on a localization's estimate (scored on the truth), with start noise, on the ideal
  robot and on the realistic plant: completion >= 95%. The localization is
  ``--localization`` (``odometry+beacons`` by default) for the models with wheel or steering
  encoders and ``beacons`` for the others (constant velocity, mecanum), which odometry cannot
  count.

MPPI (:class:`agents.controllers.mppi.MPPI`, the model-predictive baseline) drives the ideal
robot's episodes too; the targets against it (completion >= MPPI's, mean |cte| below
MPPI's, time to goal <= 1.1 x MPPI's on every path set) are reported beside the others, not
yet required (``--no-mppi`` leaves it out). ``--ideal-only`` leaves out the realistic plant's
settings: the 31 targets of the
learned-tracker table (two noise settings, the held-out tracks, one localization). Prints a
markdown table per model and setting and one line per target; the tables give each
completion rate and mean |cte| with its 95% interval (Wilson score; Student t), so
``--episodes 1000`` (seconds per agent and env: the harness runs every episode at once)
tells a margin from noise. ``--policy ZIP`` measures a candidate (one model's) in place of
the shipped one, on the same episodes.
"""

from __future__ import annotations

import argparse
import math
import pathlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import mobile_envs  # noqa: F401  (registers the ids)
from agents.controllers.delay_compensation import DelayCompensated
from agents.controllers.mppi import MPPI
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from agents.harness.evaluate import evaluate
from agents.harness.policies import load_policy
from mobile_envs.robots import MODELS as KINEMATIC_MODELS

ROOT = pathlib.Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Model:
    """A kinematic model's ids and its shipped policy.

    :param prefix: the model's part of the env ids (``mobile_envs/<prefix>-<PathSet>-v0``)
    :param policy: the shipped policy
    :param kinematic: the model's name in :data:`mobile_envs.robots.MODELS`
    """

    prefix: str
    policy: pathlib.Path
    kinematic: str

    def localization(self, wanted: str) -> str:
        """``wanted``, or beacons for a robot without encoders for odometry to count."""
        if "odometry" in wanted and not KINEMATIC_MODELS[self.kinematic].has_encoders:
            return "beacons"
        return wanted


MODELS = {
    "constant_velocity": Model(
        "ConstantVelocity", ROOT / "models" / "constant_velocity_ppo.zip", "constant_velocity"
    ),
    "diff_drive": Model("DiffDrive", ROOT / "models" / "diffdrive_ppo.zip", "diff_drive"),
    "bicycle": Model("Bicycle", ROOT / "models" / "bicycle_ppo.zip", "bicycle"),
    "tricycle": Model("Tricycle", ROOT / "models" / "tricycle_ppo.zip", "tricycle"),
    "mecanum": Model("Mecanum", ROOT / "models" / "mecanum_ppo.zip", "mecanum"),
}
#: (id prefix, shipped policy) per model, as other benchmarks read them.
POLICIES = {name: (model.prefix, model.policy) for name, model in MODELS.items()}
PATH_SETS = ("Segments", "SharpSegments", "Lines", "Maze")
START_NOISE = (0.2, 0.3)
#: The first seed of the held-out random tracks; training draws from seeds 0 to n_envs - 1.
HELD_OUT_SEED = 1_000_000
HELD_OUT_EPISODES = 200
#: The classical agents, by the names the tables give them.
CLASSICAL: dict[str, Callable[[], Any]] = {
    "pure_pursuit": PurePursuit,
    "delay_compensated_pure_pursuit": lambda: DelayCompensated(PurePursuit()),
    "regulated_pure_pursuit": RegulatedPurePursuit,
    "mppi": MPPI,
}
#: The baselines the realistic plant's targets name.
REALISTIC_BASELINES = ("pure_pursuit", "delay_compensated_pure_pursuit", "regulated_pure_pursuit")

Summary = dict[str, float]
Interval = dict[str, tuple[float, float]]
#: (path set, agent) -> (summary, its 95% intervals)
Results = dict[tuple[str, str], tuple[Summary, Interval]]
Check = tuple[str, bool, str]


@dataclass(frozen=True)
class Setting:
    """Episodes every agent meets, and what the policy must do on them.

    :param title: the table's title
    :param env_kwargs: keyword arguments of every env (beside the policy's own)
    :param baselines: the classical agents measured beside the policy (keys of
        :data:`CLASSICAL`)
    :param checks: the targets: (policy's results, the baselines' results) -> checks
    :param reported: targets reported beside them, not required (against MPPI)
    """

    title: str
    env_kwargs: dict[str, Any]
    baselines: tuple[str, ...]
    checks: Callable[[Results], Iterator[Check]] = field(repr=False)
    reported: Callable[[Results], Iterator[Check]] | None = field(default=None, repr=False)


def ideal_checks(results: Results) -> Iterator[Check]:
    """Completion, mean |cte| against both pure pursuits, time against regulated pure
    pursuit's, and SharpSegments' max |cte|."""
    for path_set in PATH_SETS:
        ppo = results[path_set, "ppo"][0]
        pure = results[path_set, "pure_pursuit"][0]
        regulated = results[path_set, "regulated_pure_pursuit"][0]
        yield completion_check(path_set, ppo, 0.98)
        yield cte_check(path_set, ppo, (pure, regulated), "both pure pursuits'")
        yield (
            f"{path_set}: time <= 1.1 x regulated pure pursuit's",
            ppo["mean_time"] <= 1.1 * regulated["mean_time"]
            or (math.isnan(regulated["mean_time"]) and not math.isnan(ppo["mean_time"])),
            f"{ppo['mean_time']:.1f} vs {regulated['mean_time']:.1f} s",
        )
    ppo = results["SharpSegments", "ppo"][0]
    regulated = results["SharpSegments", "regulated_pure_pursuit"][0]
    yield (
        "SharpSegments: max |cte| <= regulated pure pursuit's",
        ppo["max_abs_cte"] <= regulated["max_abs_cte"],
        f"{ppo['max_abs_cte']:.3f} vs {regulated['max_abs_cte']:.3f} m",
    )


def realistic_checks(results: Results) -> Iterator[Check]:
    """Completion, and mean |cte| against the three pure pursuits."""
    for path_set in PATH_SETS:
        ppo = results[path_set, "ppo"][0]
        yield completion_check(path_set, ppo, 0.98)
        others = tuple(results[path_set, name][0] for name in REALISTIC_BASELINES)
        yield cte_check(path_set, ppo, others, "PP's, delay-compensated PP's and RPP's")


def mppi_checks(results: Results) -> Iterator[Check]:
    """Completion, mean |cte| and time against MPPI's on every path set."""
    for path_set in PATH_SETS:
        ppo, mppi = results[path_set, "ppo"][0], results[path_set, "mppi"][0]
        yield (
            f"{path_set}: completion >= MPPI's",
            ppo["completion_rate"] >= mppi["completion_rate"],
            f"{ppo['completion_rate']:.2f} vs {mppi['completion_rate']:.2f}",
        )
        yield cte_check(path_set, ppo, (mppi,), "MPPI's")
        yield (
            f"{path_set}: time <= 1.1 x MPPI's",
            ppo["mean_time"] <= 1.1 * mppi["mean_time"]
            or (math.isnan(mppi["mean_time"]) and not math.isnan(ppo["mean_time"])),
            f"{ppo['mean_time']:.1f} vs {mppi['mean_time']:.1f} s",
        )


def localized_checks(results: Results) -> Iterator[Check]:
    """Completion >= 95% on every path set."""
    for path_set in PATH_SETS:
        yield completion_check(path_set, results[path_set, "ppo"][0], 0.95)


def completion_check(path_set: str, ppo: Summary, minimum: float) -> Check:
    rate = ppo["completion_rate"]
    return f"{path_set}: completion >= {minimum}", rate >= minimum, f"{rate:.2f}"


def cte_check(path_set: str, ppo: Summary, others: tuple[Summary, ...], whose: str) -> Check:
    best = min(other["mean_abs_cte"] for other in others)
    measured = " / ".join(f"{other['mean_abs_cte']:.3f}" for other in others)
    return (
        f"{path_set}: mean |cte| below {whose}",
        ppo["mean_abs_cte"] < best,
        f"{ppo['mean_abs_cte']:.3f} vs {measured} m",
    )


def settings_for(
    model: Model, localization: str, realistic: bool = True, mppi: bool = False
) -> list[Setting]:
    """The settings of ``model``'s targets, those that fail most often first.

    :param realistic: with the realistic plant's settings (issue 27's targets); without
        them, the ideal robot's targets only (the learned-tracker table's)
    :param mppi: MPPI drives the ideal robot's episodes too, and the targets against it are
        reported
    """
    located = model.localization(localization)
    noisy = {"start_noise": START_NOISE}
    plant = {**noisy, "plant": "realistic"}
    ideal_baselines = ("pure_pursuit", "regulated_pure_pursuit")
    compared = (*ideal_baselines, "mppi") if mppi else ideal_baselines
    reported = mppi_checks if mppi else None
    noiseless = {"start_noise": (0.0, 0.0)}
    ideal = [
        Setting("with start noise", noisy, compared, ideal_checks, reported),
        Setting("without start noise", noiseless, compared, ideal_checks, reported),
        Setting(
            f"localization {located}, with start noise",
            {**noisy, "localization": located},
            ideal_baselines,
            localized_checks,
        ),
    ]
    if not realistic:
        return ideal
    return [
        ideal[0],
        Setting("realistic plant, with start noise", plant, REALISTIC_BASELINES, realistic_checks),
        *ideal[1:],
        Setting(
            f"realistic plant, localization {located}, with start noise",
            {**plant, "localization": located},
            REALISTIC_BASELINES,
            localized_checks,
        ),
    ]


def measure(
    name: str,
    prefix: str,
    agent: Any,
    path_set: str,
    episodes: int,
    env_kwargs: dict[str, Any],
) -> tuple[Summary, Interval]:
    """``agent``'s summary and intervals on ``episodes`` episodes of a path set, printed."""
    env_id = f"mobile_envs/{prefix}-{path_set}-v0"
    result = evaluate(agent, env_id, episodes, seed=0, **env_kwargs)
    summary = result.summary
    print(
        f"  {env_id:<36} {name:<31} completion {summary['completion_rate']:.2f} "
        f"mean|cte| {summary['mean_abs_cte']:.3f} max|cte| {summary['max_abs_cte']:.3f} "
        f"time {summary['mean_time']:.1f}",
        flush=True,
    )
    return summary, result.intervals()


class Targets:
    """One model's targets for any number of policies: the classical agents' results are
    measured once, when a setting first needs them.

    :param model: a key of :data:`MODELS`
    :param episodes: episodes per path set and setting
    :param localization: the localization of the localized settings (see
        :meth:`Model.localization`)
    :param realistic: measure the realistic plant's targets too (see :func:`settings_for`)
    :param mppi: measure MPPI on the ideal robot and report the targets against it
    """

    def __init__(
        self,
        model: str,
        episodes: int = 50,
        localization: str = "odometry+beacons",
        realistic: bool = True,
        mppi: bool = False,
    ):
        self.model = MODELS[model]
        self.episodes = episodes
        self.settings = settings_for(self.model, localization, realistic, mppi)
        self._baselines: dict[str, Results] = {}
        #: The last :meth:`run`'s reported targets (against MPPI), not required.
        self.reported: list[Check] = []

    def baselines(self, setting: Setting) -> Results:
        """The classical agents' results of ``setting`` (measured on the first call)."""
        if setting.title not in self._baselines:
            self._baselines[setting.title] = {
                (path_set, name): measure(
                    name,
                    self.model.prefix,
                    CLASSICAL[name](),
                    path_set,
                    self.episodes,
                    setting.env_kwargs,
                )
                for path_set in PATH_SETS
                for name in setting.baselines
            }
        return self._baselines[setting.title]

    def run(
        self, policy_path: pathlib.Path, stop_at_first_miss: bool = False
    ) -> tuple[list[tuple[str, Results]], list[Check]]:
        """Measure the policy at ``policy_path`` on every target.

        :param stop_at_first_miss: stop after the first setting with a missed target (the
            checks so far say which)
        :return: the tables (title, results of every agent) and the checks, in order
        """
        policy = load_policy(policy_path)
        tables, checks = [], []
        self.reported = []
        for setting in self.settings:
            print(f"{self.model.prefix}, {setting.title}: {self.episodes} episodes per set")
            results = dict(self.baselines(setting))
            for path_set in PATH_SETS:
                results[path_set, "ppo"] = measure(
                    "ppo", self.model.prefix, policy, path_set, self.episodes, setting.env_kwargs
                )
            tables.append((setting.title, results))
            checks += [(f"{setting.title}: {target}", met, text)
                       for target, met, text in setting.checks(results)]  # fmt: skip
            if setting.reported is not None:
                self.reported += [(f"{setting.title}: {target}", met, text)
                                  for target, met, text in setting.reported(results)]  # fmt: skip
            if stop_at_first_miss and not all(met for _, met, _ in checks):
                return tables, checks
            if setting is self.settings[0]:
                checks.append(self.held_out(policy))
                if stop_at_first_miss and not checks[-1][1]:
                    return tables, checks
        return tables, checks

    def held_out(self, policy: Any) -> Check:
        """The policy's completion on the held-out random tracks, checked."""
        env_id = f"mobile_envs/{self.model.prefix}-Random-v0"
        summary = evaluate(policy, env_id, HELD_OUT_EPISODES, seed=HELD_OUT_SEED)
        completion = summary.summary["completion_rate"]
        print(f"  {env_id:<36} {'ppo':<31} completion {completion:.3f}", flush=True)
        return (
            f"{HELD_OUT_EPISODES} held-out random tracks (seeds {HELD_OUT_SEED:,} on): "
            "completion >= 0.98",
            completion >= 0.98,
            f"{completion:.3f}",
        )


def with_interval(value: float, interval: tuple[float, float], style: str) -> str:
    """``value [low, high]`` in ``style``; the value alone where the interval is undefined."""
    text = style.format(value)
    if not math.isnan(interval[0]):
        text += f" [{style.format(interval[0])}, {style.format(interval[1])}]"
    return text


def print_table(title: str, results: Results) -> None:
    print(f"\n#### {title}\n")
    print(
        "| path set | agent | completion [95% Wilson] | mean \\|cte\\| (m) [95% t] "
        "| max \\|cte\\| (m) | time to goal (s) |"
    )
    print("|---|---|---|---|---|---|")
    for path_set in PATH_SETS:
        for agent in ("ppo", *CLASSICAL):
            if (path_set, agent) not in results:
                continue
            summary, bounds = results[path_set, agent]
            completion = with_interval(
                summary["completion_rate"], bounds["completion_rate"], "{:.2f}"
            )
            cte = with_interval(summary["mean_abs_cte"], bounds["mean_abs_cte"], "{:.3f}")
            print(
                f"| {path_set} | {agent.replace('_', ' ')} | {completion} | {cte} | "
                f"{summary['max_abs_cte']:.3f} | {summary['mean_time']:.1f} |"
            )


def add_localization_argument(parser: argparse.ArgumentParser) -> None:
    """``--localization``: the localized settings' mode (see :meth:`Model.localization`)."""
    parser.add_argument(
        "--localization",
        choices=("odometry", "beacons", "odometry+beacons"),
        default="odometry+beacons",
        help="the localized settings' mode (beacons for the models without encoders)",
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument(
        "--models",
        nargs="+",
        default=[name for name, model in MODELS.items() if model.policy.is_file()],
        choices=list(MODELS),
        help="the models to measure (default: every model with a shipped policy)",
    )
    add_localization_argument(parser)
    parser.add_argument(
        "--policy",
        type=pathlib.Path,
        help="a policy zip to measure instead of the shipped one (with a single --models)",
    )
    parser.add_argument(
        "--ideal-only",
        action="store_true",
        help="the ideal robot's targets only (the learned-tracker table's 31)",
    )
    parser.add_argument(
        "--no-mppi", action="store_true", help="leave MPPI and the targets against it out"
    )
    args = parser.parse_args()
    if args.episodes < 1:
        parser.error(f"--episodes must be at least 1, got {args.episodes}")
    if args.policy is not None and len(args.models) != 1:
        parser.error("--policy needs exactly one model in --models")
    policies = {
        model: MODELS[model].policy if args.policy is None else args.policy for model in args.models
    }
    for model, path in policies.items():
        if not path.is_file():
            parser.error(f"no policy file at {path} (for {model})")
    reports = []
    for model, path in policies.items():
        targets = Targets(
            model, args.episodes, args.localization, not args.ideal_only, not args.no_mppi
        )
        tables, checks = targets.run(path)
        reports.append((model, tables, checks, targets.reported))
    for model, tables, checks, reported in reports:
        met = sum(met for _, met, _ in checks)
        print(f"\n### {model}\n\n{met} of {len(checks)} targets met.")
        for title, results in tables:
            print_table(title, results)
        print()
        for target, met, measured in checks:
            print(f"- [{'x' if met else ' '}] {target}: {measured}")
        if reported:
            print("\nAgainst MPPI (reported, not yet required):\n")
            for target, met, measured in reported:
                print(f"- [{'x' if met else ' '}] {target}: {measured}")


if __name__ == "__main__":
    main()

"""Compare path-tracking agents on the same episodes: a markdown table and one plot per env.

Run ``python -m agents.harness.compare --help``. Every agent meets the same episodes on an env
(episode i resets with seed ``seed + i``; see :func:`agents.harness.evaluate.evaluate`). The output
folder receives ``comparison.md`` (env, agent, completion rate, mean/max/RMS |cross-track
error|, mean time to goal, "-" where no episode reached it, collision rate, each but the max
with its 95% interval in brackets: Wilson score intervals for the rates, Student t intervals
for the means, see :meth:`agents.harness.records.EvaluationResult.intervals`) and
``<env>.png`` per env: each agent's first episode drawn over the path and the maze walls, from
its start (a triangle pointing along the start heading) to the goal (a star in the goal
circle). All episodes of an agent run at once (:func:`agents.harness.evaluate.evaluate`), so
``--episodes 1000`` takes seconds per agent and env. The command prints the folder it writes
to. It never mixes two comparisons: a folder that holds files is refused unless
``--overwrite`` is given, which removes the comparison there before writing the new one (its
``comparison.md`` and its ``<env>.png`` plots, files named after an env id; anything else
stays).

Errors are one line on stderr, ``python -m agents.harness.compare: error: ...``, and no traceback:
exit status 2 for bad input (an unknown agent or env id, a missing, truncated or unfitting
policy file, env kwargs the env refuses), 1 when the system fails the command (the output
folder is not writable, the disk is full), 130 on Ctrl-C.
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle

import mobile_envs
from agents.controllers.base import ClassicalAgent
from agents.controllers.delay_compensation import DelayCompensated
from agents.controllers.guidance import TricycleGuidance
from agents.controllers.mppi import MPPI
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from agents.harness.evaluate import EvaluationResult, evaluate
from agents.harness.policies import ALGORITHMS
from agents.interrupts import StopRequests, interruption_in, signum_of
from mobile_envs.envs.registration import path_set_ids

PROG = "python -m agents.harness.compare"
#: Exit statuses: bad input (arguments or the files they name), and a failure of the system.
EXIT_USAGE = 2
EXIT_FAILURE = 1

CLASSICAL_AGENTS: dict[str, Callable[[], ClassicalAgent]] = {
    "pure_pursuit": PurePursuit,
    "pure_pursuit_textbook": lambda: PurePursuit(mode="textbook"),
    "regulated_pure_pursuit": RegulatedPurePursuit,
    "tricycle_guidance": TricycleGuidance.for_comparison,
    "mppi": MPPI,
    # Pure pursuit from the pose predicted over the env's plant delay (none: pure pursuit).
    "delay_compensated_pure_pursuit": lambda: DelayCompensated(PurePursuit()),
}
DEFAULT_AGENTS = tuple(CLASSICAL_AGENTS)
#: How a saved policy is named as an agent: ``ppo:PATH.zip``, ``sac:PATH.zip``, ...
POLICY_AGENTS = ", ".join(f"{algo}:PATH.zip" for algo in ALGORITHMS)
DEFAULT_PATH_SETS = tuple(path_set_ids(compared=True))
DEFAULT_ENVS = tuple(
    f"mobile_envs/{model}-{paths}-v0"
    for model in mobile_envs.MODEL_IDS
    for paths in DEFAULT_PATH_SETS
)
TABLE_COLUMNS = (
    ("completion [95% Wilson]", "completion_rate", "{:.2f}"),
    ("mean abs cte (m) [95% t]", "mean_abs_cte", "{:.3f}"),
    ("max abs cte (m)", "max_abs_cte", "{:.3f}"),
    ("rms cte (m) [95% t]", "rms_cte", "{:.3f}"),
    ("mean time (s) [95% t]", "mean_time", "{:.1f}"),
    ("collision [95% Wilson]", "collision_rate", "{:.2f}"),
)


def policy_spec(name: str) -> tuple[str, str] | None:
    """``(algo, path)`` for an agent name ``ALGO:PATH`` with ALGO in
    :data:`agents.harness.policies.ALGORITHMS`, else None."""
    algo, separator, path = name.partition(":")
    return (algo, path) if separator and algo in ALGORITHMS else None


def make_agent(name: str, env: gym.Env) -> Any | None:
    """The agent called ``name`` for ``env``, or None when it does not apply to the env's model.

    :param name: a key of :data:`CLASSICAL_AGENTS`, or ``ALGO:PATH.zip`` for a policy that
        ALGO (``ppo``, ``sac``, ``td3``, ``tqc``) saved; a zip of another algorithm is an error
    """
    spec = policy_spec(name)
    if spec is not None:
        # torch loads only when a policy is asked for
        from agents.harness.policies import check_spaces, drives_same_model, load_policy

        algo, path = spec
        policy = load_policy(path, algo=algo)
        if not drives_same_model(policy, env):
            return None
        check_spaces(policy, env, path)
        return policy
    if name not in CLASSICAL_AGENTS:
        known = ", ".join([*CLASSICAL_AGENTS, POLICY_AGENTS])
        raise ValueError(f"unknown agent {name!r}; known agents: {known}")
    agent = CLASSICAL_AGENTS[name]()
    unwrapped: Any = env.unwrapped  # a PathFollowingEnv, whose ``model`` is documented
    return agent if agent.supports(unwrapped.model) else None


def check_env_ids(env_ids: Sequence[str], flag: str) -> None:
    """Raise ValueError naming ``flag`` and the id unless every id is a registered env.

    :param env_ids: the ids asked for
    :param flag: the command-line flag they came from, for the message
    """
    for env_id in env_ids:
        try:
            gym.spec(env_id)
        except gym.error.Error as error:
            raise ValueError(f"{flag}: unknown env id {env_id!r}: {error}") from None


def make_env(env_id: str, env_kwargs: dict[str, Any], flag: str = "--env-kwargs") -> gym.Env:
    """``gym.make(env_id, **env_kwargs)`` for kwargs a user typed: a ValueError naming ``flag``
    when the env refuses them (an unknown name is a TypeError from the env's constructor).

    :param env_id: a registered id (see :func:`check_env_ids`)
    :param env_kwargs: keyword arguments for the env
    :param flag: the command-line flag the kwargs came from, for the message
    """
    try:
        return gym.make(env_id, **env_kwargs)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{env_id} refuses {flag} {json.dumps(env_kwargs)}: {error}") from error


def markdown_table(
    rows: Sequence[tuple[str, str, dict[str, float], dict[str, tuple[float, float]]]],
) -> str:
    """A markdown table with one row per (env, agent, summary, intervals); a value with an
    interval reads ``0.95 [0.90, 0.98]``."""
    header = ["env", "agent", *(title for title, _, _ in TABLE_COLUMNS)]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for env_id, agent_name, summary, intervals in rows:
        cells = [env_id.removeprefix("mobile_envs/"), agent_name]
        for _, key, style in TABLE_COLUMNS:
            value = summary[key]
            cell = "-" if math.isnan(value) else style.format(value)
            low, high = intervals.get(key, (math.nan, math.nan))
            if not (math.isnan(value) or math.isnan(low)):
                cell += f" [{style.format(low)}, {style.format(high)}]"
            cells.append(cell)
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


#: The file a comparison writes its table to.
TABLE_FILE = "comparison.md"


def plot_name(env_id: str) -> str:
    """The plot of ``env_id``'s first episodes: ``<Model>-<Set>-v0.png``."""
    return f"{env_id.split('/')[-1]}.png"


def comparison_files(folder: pathlib.Path) -> list[pathlib.Path]:
    """The files of a comparison in ``folder``: its table and the plots named after a
    registered env id."""
    plots = {plot_name(env_id) for env_id in gym.registry}
    return [
        path
        for path in sorted(folder.iterdir())
        if path.name == TABLE_FILE or (path.name in plots and path.is_file())
    ]


def prepare_output(output: pathlib.Path, overwrite: bool) -> None:
    """Make sure ``output`` can take a new comparison: a new or empty folder, or, with
    ``overwrite``, one whose previous comparison (:func:`comparison_files`) is removed.

    :raises ValueError: naming ``--output`` for a file, or a folder holding files without
        ``overwrite``
    """
    if output.exists() and not output.is_dir():
        raise ValueError(f"--output: {output} is a file, not a folder")
    if not output.is_dir() or not any(output.iterdir()):
        return
    if not overwrite:
        previous = [path.name for path in comparison_files(output)]
        what = f"a comparison ({', '.join(previous[:3])}{', ...' * (len(previous) > 3)})"
        raise ValueError(
            f"--output: {output} already holds {what if previous else 'files'}; give another "
            "--output, or "
            "--overwrite to replace the comparison in it"
        )
    for path in comparison_files(output):
        path.unlink()


def plot_first_episodes(
    env_id: str,
    results: dict[str, EvaluationResult],
    filename: pathlib.Path,
    goal_radius: float = 0.1,
) -> None:
    """Draw each agent's first episode over its path and the maze walls, with the start pose
    and the goal (its circle of ``goal_radius`` m); save a PNG."""
    figure = Figure(figsize=(7, 7))
    axes = figure.add_subplot()
    first = next(iter(results.values())).episodes[0]
    if first.maze is not None:
        walls = LineCollection(
            list(first.maze.walls), colors="black", linewidths=1.5, label="walls"
        )
        axes.add_collection(walls)
    axes.plot(*first.path.points.T, color="0.6", linewidth=3, label="path", zorder=1)
    for agent_name, result in results.items():
        episode = result.episodes[0]
        outcome = "goal" if episode.completed else "failed"
        axes.plot(*episode.trajectory[:, :2].T, linewidth=1.2, label=f"{agent_name} ({outcome})")
    # Every agent's first episode starts from the same pose (the same seed).
    x, y, heading = first.trajectory[0]
    axes.plot(
        x, y, marker=(3, 0, math.degrees(heading) - 90), markersize=11, color="tab:green",
        markeredgecolor="black", linestyle="none", label="start", zorder=3,
    )  # fmt: skip
    goal = first.path.points[-1]
    axes.add_patch(Circle(goal, goal_radius, fill=False, color="tab:red", zorder=2))
    axes.plot(
        *goal, marker="*", markersize=14, color="tab:red", markeredgecolor="black",
        linestyle="none", label="goal", zorder=3,
    )  # fmt: skip
    axes.set_aspect("equal")
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.set_title(f"{env_id.removeprefix('mobile_envs/')}: first episode")
    axes.legend(loc="best", fontsize="small")
    figure.savefig(filename, dpi=120, bbox_inches="tight")


def compare(
    agent_names: Sequence[str],
    env_ids: Sequence[str],
    episodes: int,
    seed: int,
    env_kwargs: dict[str, Any],
    output: pathlib.Path,
    check_stop: Callable[[], None] | None = None,
    overwrite: bool = False,
) -> str:
    """Evaluate every agent on every env, write the table and the plots; return the table.

    ``check_stop`` is called before every step; it raises to stop the comparison.
    ``output`` must be new or empty, or hold a comparison to replace with ``overwrite``
    (:func:`prepare_output`).
    """
    prepare_output(output, overwrite)
    output.mkdir(parents=True, exist_ok=True)
    print(f"writing the comparison to {output}/", flush=True)
    rows = []
    for env_id in env_ids:
        env = make_env(env_id, env_kwargs)
        results = {}
        for agent_name in agent_names:
            agent = make_agent(agent_name, env)
            if agent is None:
                unwrapped: Any = env.unwrapped
                model_name = unwrapped.model.name
                print(f"{env_id}: skipping {agent_name}, which cannot drive the {model_name} model")
                continue
            result = evaluate(agent, env, episodes, seed=seed, check_stop=check_stop)
            summary = result.summary
            results[agent_name] = result
            rows.append((env_id, agent_name, summary, result.intervals()))
            print(
                f"{env_id} {agent_name}: completion {summary['completion_rate']:.2f}, "
                f"mean |cte| {summary['mean_abs_cte']:.3f} m, "
                f"max |cte| {summary['max_abs_cte']:.3f} m, "
                f"mean time {summary['mean_time']:.1f} s, "
                f"collisions {summary['collision_rate']:.2f}",
                flush=True,
            )
        goal_radius = float(env.unwrapped.config.goal_radius)  # type: ignore[attr-defined]
        env.close()
        if results:
            plot_first_episodes(env_id, results, output / plot_name(env_id), goal_radius)
    table = markdown_table(rows)
    (output / TABLE_FILE).write_text(table)
    plots = len(comparison_files(output)) - 1
    print(f"wrote {output / TABLE_FILE} and {plots} plot{'s' * (plots != 1)} in {output}/")
    return table


def json_object(text: str) -> dict[str, Any]:
    """An ``--env-kwargs`` value: a JSON object."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as error:
        raise argparse.ArgumentTypeError(f"not valid JSON ({error}): {text}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(
            f"expected a JSON object such as '{{\"dt\": 0.1}}': {text}"
        )
    return value


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description=(
            "Run path-tracking agents on the same episodes of each env and write a markdown "
            "table (comparison.md) and one plot per env of every agent's first episode."
        ),
    )
    parser.add_argument(
        "--agents",
        nargs="+",
        default=list(DEFAULT_AGENTS),
        metavar="NAME",
        help=(
            f"agents: {', '.join(CLASSICAL_AGENTS)} (tricycle envs only), or a saved policy: "
            f"{POLICY_AGENTS} (default: {' '.join(DEFAULT_AGENTS)})"
        ),
    )
    parser.add_argument(
        "--envs",
        nargs="+",
        default=list(DEFAULT_ENVS),
        metavar="ID",
        help="env ids (default: every model on Lines, Segments, SharpSegments and Maze)",
    )
    parser.add_argument(
        "--episodes", type=int, default=10, help="episodes per agent and env (default: 10)"
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="seed of the first episode (default: 0)"
    )
    parser.add_argument(
        "--env-kwargs",
        type=json_object,
        default={},
        metavar="JSON",
        help="keyword arguments for gym.make, e.g. '{\"start_noise\": [0.2, 0.3]}'",
    )
    parser.add_argument(
        "--output",
        type=pathlib.Path,
        default=pathlib.Path("comparison"),
        help="folder for comparison.md and the plots, new or empty (default: comparison/)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the comparison in --output (its comparison.md and <env>.png plots)",
    )
    return parser.parse_args(argv)


def check_args(args: argparse.Namespace) -> None:
    """Raise ValueError naming the flag for values argparse cannot check by itself."""
    for name in args.agents:
        spec = policy_spec(name)
        if spec is not None:
            if not pathlib.Path(spec[1]).is_file():
                raise ValueError(f"--agents: no policy file at {spec[1]}")
        elif name not in CLASSICAL_AGENTS:
            raise ValueError(
                f"--agents: unknown agent {name!r}; known: "
                f"{', '.join(CLASSICAL_AGENTS)}, {POLICY_AGENTS}"
            )
    if args.episodes < 1:
        raise ValueError(f"--episodes must be at least 1, got {args.episodes}")
    if args.seed < 0:
        raise ValueError(f"--seed must be at least 0, got {args.seed}")
    check_env_ids(args.envs, "--envs")


def main(argv: Sequence[str] | None = None, check_stop: Callable[[], None] | None = None) -> str:
    """Run the comparison; return the markdown table. Errors raise (see :func:`cli`).

    :param argv: the arguments, ``sys.argv[1:]`` when None
    :param check_stop: called before every step; raises to stop
    :raises ValueError: for bad input, naming the flag or the file
    :raises OSError: when the output folder cannot be written
    """
    args = parse_args(argv)
    check_args(args)
    return compare(
        args.agents,
        args.envs,
        args.episodes,
        args.seed,
        args.env_kwargs,
        args.output,
        check_stop,
        args.overwrite,
    )


def cli(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    """Command-line entry point: :func:`main` with its errors as one line on stderr.

    :param argv: the arguments, ``sys.argv[1:]`` when None
    :param prog: the command's name in error messages
    :return: the exit status: 0, :data:`EXIT_USAGE`, :data:`EXIT_FAILURE`, or 130 (Ctrl-C) and
        143 (SIGTERM), 128 + the signal, which stops it at the next step
        (:class:`agents.interrupts.StopRequests`)
    """
    with StopRequests().installed() as requests:
        try:
            main(argv, requests.raise_if_requested)
        except ValueError as error:
            return report_error(prog, str(error), EXIT_USAGE)
        except OSError as error:
            return report_error(prog, describe_os_error(error), EXIT_FAILURE)
        except BaseException as error:
            interruption = interruption_in(error)  # a second signal may come wrapped
            if interruption is None:
                raise
            print(f"\n{prog}: interrupted", file=sys.stderr)
            return 128 + signum_of(interruption)
    return 0


def report_error(prog: str, message: str, status: int) -> int:
    """Print ``prog: error: message`` as one line on stderr, as argparse does; return ``status``."""
    one_line = " ".join(line.strip() for line in message.splitlines() if line.strip())
    print(f"{prog}: error: {one_line}", file=sys.stderr)
    return status


def describe_os_error(error: OSError) -> str:
    """``strerror: file`` (``Permission denied: runs/x/config.yml``) when the error names one."""
    if error.strerror and error.filename is not None:
        return f"{error.strerror}: {error.filename}"
    return str(error)


if __name__ == "__main__":
    sys.exit(cli())

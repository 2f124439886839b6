"""The grid's classical rows: each ``--baselines`` agent (pure pursuit, regulated pure pursuit,
MPPI, ...) measured by the harness on the same evaluation episodes as the trained policies.

A classical agent has nothing to train and no training seed, so it is one evaluation per
(robot, agent): one "run" in the table, whose interval columns show its mean alone. It is
recorded like a training run, ``OUTPUT/runs/MODEL_AGENT/evaluation.json``, and read back when
the same command runs again.
"""

from __future__ import annotations

import pathlib
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

from agents.grid.run import evaluation_envs, finished_record, record_evaluation
from agents.grid.table import split_env_id


@dataclass(frozen=True)
class BaselineSpec:
    """One classical agent's evaluation in the grid.

    :param agent: a name of :data:`agents.harness.compare.CLASSICAL_AGENTS`
    :param model: the robot, a key of :data:`mobile_envs.MODEL_IDS` (``DiffDrive``)
    :param eval_envs: the env ids it drives, the trained policies' evaluation envs
    :param episodes: episodes per evaluation env
    :param eval_seed: seed of the first episode
    :param eval_env_kwargs: keyword arguments for the evaluation envs
    """

    agent: str
    model: str
    eval_envs: tuple[str, ...]
    episodes: int
    eval_seed: int
    eval_env_kwargs: dict[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        return f"{self.model}_{self.agent}"

    def to_json(self) -> dict[str, Any]:
        record = asdict(self)
        record["eval_envs"] = list(self.eval_envs)
        return record


def baseline_specs(
    agents: Sequence[str],
    env_ids: Sequence[str],
    path_sets: Sequence[str],
    episodes: int,
    eval_seed: int,
    eval_env_kwargs: dict[str, Any],
) -> list[BaselineSpec]:
    """The evaluations of ``agents`` on the robots of ``env_ids``, one per (robot, agent) the
    agent can drive (``tricycle_guidance`` only drives the tricycle).

    :raises ValueError: for an unknown agent, or one that drives none of the robots
    """
    import gymnasium as gym

    import mobile_envs  # noqa: F401  (registers the ids)
    from agents.harness.compare import CLASSICAL_AGENTS, make_agent

    robots: dict[str, tuple[str, ...]] = {}  # each robot's evaluation envs, in --envs order
    for env_id in env_ids:
        model = split_env_id(env_id)[0]
        if model not in robots:
            robots[model] = evaluation_envs(env_id, path_sets)
    specs = []
    for agent in dict.fromkeys(agents):
        if agent not in CLASSICAL_AGENTS:
            raise ValueError(
                f"--baselines: unknown agent {agent!r}; known: {', '.join(CLASSICAL_AGENTS)}"
            )
        driven = []
        for model, eval_envs in robots.items():
            with gym.make(eval_envs[0]) as robot:
                if make_agent(agent, robot) is not None:
                    driven.append(
                        BaselineSpec(agent, model, eval_envs, episodes, eval_seed, eval_env_kwargs)
                    )
        if not driven:
            raise ValueError(f"--baselines: {agent} drives none of {', '.join(robots)}")
        specs += driven
    return specs


def evaluate_baseline(
    spec: BaselineSpec, output: pathlib.Path, check_stop: Callable[[], None] | None = None
) -> dict[str, Any]:
    """Evaluate (or read back) ``spec``; return its record, also written to its
    ``evaluation.json``.

    :raises ValueError: when its folder holds an evaluation of other settings
    """
    from agents.harness.compare import CLASSICAL_AGENTS

    finished = finished_record(spec, output)
    if finished is not None:
        return finished
    return record_evaluation(spec, CLASSICAL_AGENTS[spec.agent], output, check_stop)

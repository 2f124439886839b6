"""Minari datasets of any agent driving any env: offline-RL data recorded on the batched env.

Run ``python -m agents.harness.datasets --help`` (or ``python train.py dataset``)::

    python train.py dataset --agent regulated_pure_pursuit --env mobile_envs/DiffDrive-Random-v0 \\
        --episodes 1000 --robots 64

An agent is named as ``train.py compare`` names it (:func:`agents.harness.compare.make_agent`):
a classical agent (``pure_pursuit``, ``regulated_pure_pursuit``, ...) or a saved policy
(``ppo:models/diffdrive_ppo.zip``); any agent the harness can make records. The episodes are
the harness's: episode i resets with seed ``seed + i``
(:func:`agents.harness.evaluate.evaluate`), driven deterministically, so a dataset holds what
``compare`` measures. They are recorded on the batched vector env (``--robots`` robots step in
one call; a robot whose episode ends restarts with the next episode's seed), which Minari's
own ``DataCollector`` cannot do, and written with ``minari.create_dataset_from_buffers``.

Each step's ``infos`` holds the env's step keys and its episode metrics, NaN (``completed``:
False) until the episode's last step (:class:`mobile_envs.envs.recording.UniformInfo`'s
structure), so Minari's one-structure-per-episode rule holds. ``dataset.recover_environment()``
gives the env with the same keyword arguments. Datasets go where Minari keeps them
(``MINARI_DATASETS_PATH``, else ``~/.minari/datasets``); an existing id is never overwritten.

Errors are one line on stderr and exit 2 for bad input (an unknown agent or env, a malformed
or taken dataset id), 1 when the system fails (a folder that is not writable), 130 or 143 on
Ctrl-C or SIGTERM, with nothing written. Requires the ``minari`` extra (and ``train`` for a
saved policy).
"""

from __future__ import annotations

import argparse
import pathlib
import re
import sys
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

import mobile_envs  # noqa: F401  (registers the env ids)
from agents.harness.compare import (
    EXIT_FAILURE,
    EXIT_USAGE,
    check_env_ids,
    describe_os_error,
    json_object,
    make_agent,
    policy_spec,
    report_error,
)
from agents.harness.evaluate import bind_agent
from agents.interrupts import StopRequests, interruption_in, signum_of
from mobile_envs.envs.interface import (
    EPISODE_INFO_KEYS,
    LOCALIZATION_EPISODE_KEYS,
    episode_info_placeholders,
)

PROG = "python -m agents.harness.datasets"


@dataclass
class _Episode:
    """One robot's episode as it is recorded: a row per step, the reset's first."""

    seed: int
    observations: list[NDArray[np.float32]] = field(default_factory=list)
    actions: list[NDArray[np.float32]] = field(default_factory=list)
    rewards: list[float] = field(default_factory=list)
    terminations: list[bool] = field(default_factory=list)
    truncations: list[bool] = field(default_factory=list)
    infos: list[dict[str, Any]] = field(default_factory=list)

    def buffer(self, index: int) -> Any:
        """The episode as Minari's ``EpisodeBuffer``, its infos stacked key by key."""
        from minari.data_collector.episode_buffer import EpisodeBuffer

        infos = {key: np.stack([info[key] for info in self.infos]) for key in self.infos[0]}
        return EpisodeBuffer(
            id=index,
            seed=self.seed,
            observations=np.stack(self.observations),
            actions=np.stack(self.actions),
            rewards=list(self.rewards),
            terminations=list(self.terminations),
            truncations=list(self.truncations),
            infos=infos,
        )


def default_dataset_id(agent: str, env_id: str) -> str:
    """``mobile_envs/<Model>-<Set>/<agent>-v0``: Minari's ``namespace/env/name-vN`` form,
    the agent's name in hyphens (a saved policy's as ``ppo-<file stem>``)."""
    spec = policy_spec(agent)
    name = f"{spec[0]}-{pathlib.Path(spec[1]).stem}" if spec else agent
    env_name = re.sub(r"-v\d+$", "", env_id.split("/")[-1])
    return f"mobile_envs/{env_name}/{re.sub(r'[^A-Za-z0-9]+', '-', name).strip('-')}-v0"


def check_dataset_id(dataset_id: str) -> pathlib.Path:
    """The folder a new dataset ``dataset_id`` would take; ValueError when the id is malformed
    or a dataset already has it (Minari never overwrites one)."""
    from minari.dataset.minari_dataset import parse_dataset_id
    from minari.storage.datasets_root_dir import get_dataset_path

    parse_dataset_id(dataset_id)  # ValueError: "Malformed dataset ID ..."
    path = get_dataset_path(dataset_id)
    if path.exists():
        raise ValueError(
            f"a Minari dataset {dataset_id} already exists at {path}; give another id (or "
            "version), or delete it yourself (minari delete ID)"
        )
    return path


def record_dataset(
    agent: str | Any,
    env_id: str,
    dataset_id: str,
    *,
    episodes: int,
    robots: int = 16,
    seed: int = 0,
    env_kwargs: dict[str, Any] | None = None,
    algorithm_name: str | None = None,
    author: str | None = None,
    description: str | None = None,
    check_stop: Callable[[], None] | None = None,
    progress: bool = False,
) -> Any:
    """Record ``episodes`` episodes of ``agent`` on ``env_id`` as the Minari dataset
    ``dataset_id`` and return it (a ``minari.MinariDataset``).

    :param agent: an agent name for :func:`agents.harness.compare.make_agent`, or an agent
        object :func:`agents.harness.evaluate.bind_agent` takes (a classical agent, an SB3
        model, or anything with ``bind(env)`` or ``predict``)
    :param env_id: a registered env id
    :param dataset_id: Minari's ``(namespace/)name-vN``; a new one
    :param episodes: how many episodes; episode i resets with seed ``seed + i``
    :param robots: robots stepped at once (at most ``episodes`` are made)
    :param env_kwargs: keyword arguments of the env, recorded in the dataset's env spec
    :param algorithm_name: the dataset's ``algorithm_name`` (default: the agent's name)
    :param author: the dataset's author
    :param description: the dataset's description (default: what was recorded and how)
    :param check_stop: called before every step; raises to stop (nothing is written)
    :param progress: show a progress bar of the episodes (on stderr)
    :raises ValueError: for an agent that cannot drive the env, counts below 1, or a dataset
        id that is malformed or taken
    """
    for name, value in (("episodes", episodes), ("robots", robots)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"{name} must be a positive integer, got {value!r}")
    check_env_ids([env_id], "--env")
    check_dataset_id(dataset_id)
    env_kwargs = dict(env_kwargs or {})
    count = min(robots, episodes)
    envs = gym.make_vec(env_id, num_envs=count, autoreset_mode="Disabled", **env_kwargs)
    try:
        bound = _bound_agent(agent, envs, env_id)
        recorded = _record(bound, envs, episodes, seed, check_stop, progress)
    finally:
        envs.close()
    name = algorithm_name or (agent if isinstance(agent, str) else type(agent).__name__)
    spec = gym.spec(env_id)
    spec = replace(spec, kwargs={**spec.kwargs, **env_kwargs})
    import minari

    with warnings.catch_warnings():
        # Minari warns for each metadata field left empty (permalink, e-mail, ...).
        warnings.filterwarnings("ignore", message=r".*is set to None", category=UserWarning)
        return minari.create_dataset_from_buffers(
            dataset_id,
            [episode.buffer(index) for index, episode in enumerate(recorded)],
            env=spec,
            algorithm_name=name,
            author=author,
            description=description
            or (
                f"{name} on {env_id} (env kwargs {env_kwargs}): {episodes} episodes, episode i "
                f"reset with seed {seed} + i, deterministic actions; recorded by "
                "agents.harness.datasets on the batched vector env"
            ),
        )


def _bound_agent(agent: str | Any, envs: Any, env_id: str) -> Any:
    """``agent`` made (by name) and bound to the vector env."""
    if isinstance(agent, str):
        made = make_agent(agent, envs)
        if made is None:
            raise ValueError(f"--agent {agent} cannot drive {env_id}'s {envs.model.name} model")
        agent = made
    return bind_agent(agent, envs)


def _record(
    agent: Any,
    envs: Any,
    episodes: int,
    seed: int,
    check_stop: Callable[[], None] | None,
    progress: bool,
) -> list[_Episode]:
    """Run the episodes on the robots of ``envs`` (autoreset disabled): robot r starts
    episode r; a robot whose episode ends restarts with the next episode's seed, or, once
    every episode has a robot, with none and is no longer recorded."""
    from tqdm import tqdm

    count = envs.num_envs
    observations, infos = envs.reset(seed=[seed + robot for robot in range(count)])
    placeholders = episode_info_placeholders(localized="localization_error" in infos)
    metric_keys = (*EPISODE_INFO_KEYS, *LOCALIZATION_EPISODE_KEYS)
    ending = [key for key in metric_keys if key in placeholders]
    running: list[_Episode | None] = [_Episode(seed + robot) for robot in range(count)]
    for robot, episode in enumerate(running):
        assert episode is not None
        episode.observations.append(observations[robot])
        episode.infos.append(_robot_info(infos, robot, placeholders, ()))
    finished: dict[int, _Episode] = {}
    starts = np.ones(count, dtype=bool)
    next_episode = count
    with tqdm(total=episodes, unit="episode", disable=not progress, leave=False) as bar:
        while len(finished) < episodes:
            if check_stop is not None:
                check_stop()
            actions, _ = agent.predict(observations, episode_start=starts, deterministic=True)
            actions = np.asarray(actions, dtype=np.float32)
            observations, rewards, terminated, truncated, infos = envs.step(actions)
            ended = terminated | truncated
            for robot, episode in enumerate(running):
                if episode is None:
                    continue
                episode.observations.append(observations[robot])
                episode.actions.append(actions[robot])
                episode.rewards.append(float(rewards[robot]))
                episode.terminations.append(bool(terminated[robot]))
                episode.truncations.append(bool(truncated[robot]))
                final = ending if ended[robot] else ()
                episode.infos.append(_robot_info(infos, robot, placeholders, final))
            starts = ended.copy()
            if not ended.any():
                continue
            seeds: list[int | None] = [None] * count
            for robot in np.flatnonzero(ended).tolist():
                episode = running[robot]
                if episode is not None:
                    finished[episode.seed - seed] = episode
                    bar.update()
                if next_episode < episodes:
                    seeds[robot] = seed + next_episode
                    running[robot] = _Episode(seed + next_episode)
                    next_episode += 1
                else:
                    running[robot] = None
            observations, infos = envs.reset(seed=seeds, options={"reset_mask": ended})
            for robot in np.flatnonzero(ended).tolist():
                episode = running[robot]
                if episode is not None:
                    episode.observations[:] = [observations[robot]]
                    episode.infos[:] = [_robot_info(infos, robot, placeholders, ())]
    return [finished[index] for index in range(episodes)]


def _robot_info(
    infos: dict[str, Any], robot: int, placeholders: dict[str, Any], final: Sequence[str]
) -> dict[str, Any]:
    """Robot ``robot``'s info of a vector step: its step keys, and its episode metrics on
    the step that ends its episode (``final``), the placeholders before."""
    info = {
        key: value[robot]
        for key, value in infos.items()
        if not key.startswith("_") and key not in placeholders
    }
    info.update(placeholders)
    info.update({key: infos[key][robot] for key in final})
    return info


def parse_args(argv: Sequence[str] | None, prog: str = PROG) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog=prog,
        description=(
            "Record a Minari dataset of an agent driving an env: the harness's episodes "
            "(episode i resets with seed SEED + i), on the batched vector env."
        ),
    )
    parser.add_argument(
        "--agent",
        required=True,
        metavar="NAME",
        help="an agent as compare names it: pure_pursuit, regulated_pure_pursuit, "
        "tricycle_guidance, ... or a saved policy, ppo:PATH.zip",
    )
    parser.add_argument("--env", required=True, metavar="ID", help="a registered env id")
    parser.add_argument("--episodes", type=int, default=100, help="episodes (default: 100)")
    parser.add_argument("--robots", type=int, default=16, help="robots at once (default: 16)")
    parser.add_argument("--seed", type=int, default=0, help="the first episode's seed")
    parser.add_argument(
        "--env-kwargs", type=json_object, default={}, metavar="JSON", help="JSON env kwargs"
    )
    parser.add_argument(
        "--dataset-id",
        help="Minari's (namespace/)name-vN (default: mobile_envs/<Model>-<Set>/<agent>-v0)",
    )
    parser.add_argument("--author", help="the dataset's author")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    return parser.parse_args(argv)


def main(
    argv: Sequence[str] | None = None,
    check_stop: Callable[[], None] | None = None,
    prog: str = PROG,
) -> Any:
    """Record the dataset the arguments ask for and say where it went; return it.

    :raises ValueError: for bad input, naming the flag
    :raises OSError: when the dataset cannot be written
    """
    args = parse_args(argv, prog)
    for flag, value in (("--episodes", args.episodes), ("--robots", args.robots)):
        if value < 1:
            raise ValueError(f"{flag} must be at least 1, got {value}")
    if args.seed < 0:
        raise ValueError(f"--seed must be a non-negative integer, got {args.seed}")
    spec = policy_spec(args.agent)
    if spec is not None and not pathlib.Path(spec[1]).is_file():
        raise ValueError(f"--agent: no policy file at {spec[1]}")
    try:
        import minari  # noqa: F401
    except ImportError:
        raise ValueError('datasets need Minari: pip install -e ".[minari]"') from None
    dataset_id = args.dataset_id or default_dataset_id(args.agent, args.env)
    check_env_ids([args.env], "--env")
    try:
        path = check_dataset_id(dataset_id)
    except ValueError as error:
        raise ValueError(f"--dataset-id: {error}") from None
    print(
        f"recording {args.episodes} episodes of {args.agent} on {args.env} "
        f"({min(args.robots, args.episodes)} robots at once, seeds {args.seed}..."
        f"{args.seed + args.episodes - 1})",
        flush=True,
    )
    dataset = record_dataset(
        args.agent,
        args.env,
        dataset_id,
        episodes=args.episodes,
        robots=args.robots,
        seed=args.seed,
        env_kwargs=args.env_kwargs,
        author=args.author,
        check_stop=check_stop,
        progress=not args.no_progress,
    )
    print(
        f"wrote Minari dataset {dataset_id} ({dataset.total_episodes} episodes, "
        f"{dataset.total_steps} steps) to {path}; load it with minari.load_dataset({dataset_id!r})"
    )
    return dataset


def cli(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    """Command-line entry point: :func:`main` with its errors as one line on stderr.

    :return: the exit status: 0, 2 for bad input, 1 for a failed system, 128 + the signal on
        Ctrl-C or SIGTERM (stopped at the next step, nothing written)
    """
    with StopRequests().installed() as requests:
        try:
            main(argv, requests.raise_if_requested, prog)
        except ValueError as error:
            return report_error(prog, str(error), EXIT_USAGE)
        except OSError as error:
            return report_error(prog, describe_os_error(error), EXIT_FAILURE)
        except BaseException as error:
            interruption = interruption_in(error)
            if interruption is None:
                raise
            print(f"\n{prog}: interrupted; no dataset was written", file=sys.stderr)
            return 128 + signum_of(interruption)
    return 0


if __name__ == "__main__":
    sys.exit(cli())

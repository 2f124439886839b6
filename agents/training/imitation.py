"""Warm starts by behaviour cloning: a policy that drives like a classical agent before RL.

PPO from scratch on a car-like robot rarely learns to reach the goal of a sharp path in a
few minutes: a corner taken too fast is failed many steps after the decision that caused it.
A classical agent (regulated pure pursuit by default) already completes those paths, so its
episodes make a starting point:

1. :func:`record_demonstrations` runs the agent on N robots of the training env (the same
   batched env PPO trains on, same-step autoreset) and keeps the episodes it completed:
   observations, its normalized actions and the discounted returns of the env's reward;
2. :func:`clone` fits the policy's mean action to the agent's actions and its value
   function to those returns (mean squared errors, Adam), so PPO's first advantages come
   from a critic that already knows what the actor does;
3. DAgger rounds (Ross et al. 2011; ``dagger_rounds`` of :func:`warm_start`, none by
   default): the clone drives, the teacher says at every state it reaches what it would
   command there, those labels join the demonstrations and the policy is cloned again. A
   clone drifts into states its teacher never visited (a corner entered a little wide);
   DAgger shows it the way back from its own mistakes. A teacher with a memory (regulated
   pure pursuit limits its angular acceleration against its previous command) remembers
   its own labels, not the commands the policy applied;
4. RL then improves on the agent (:func:`warm_start` does steps 1 to 3 for ``train.py``;
   :class:`WarmStartCallback` does them for rl-baselines3-zoo, whose ``callback:`` entry in
   ``hyperparams/ppo.yml`` train.py reads too).

The teacher can be tuned (``teacher_kwargs``: its constructor's parameters): regulated pure
pursuit with a shorter lookahead tracks random paths more tightly than its defaults, and a
policy that starts from a better clone needs fewer RL steps. ``teacher: mppi`` clones the
model-predictive tracker (:class:`agents.controllers.mppi.MPPI`), which tracks tighter than
either pure pursuit, at about a tenth of their speed.

A warm start is minutes of work under load, so it keeps a checkpoint like training does
(``checkpoint`` of :func:`warm_start`): when its ``check_stop`` raises (a stop signal), the
recording (the env, the agent and the episodes so far) or the cloning (the weights, Adam's
state and the minibatch order) is saved, and the next call with the same checkpoint goes on
from there to the same weights, bit for bit, as a warm start that was never stopped.

Everything is seeded from the run's seed: the same command gives the same weights.
Requires the ``train`` extra.
"""

from __future__ import annotations

import pathlib
import pickle
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TextIO

import gymnasium as gym
import numpy as np
import torch
from numpy.typing import NDArray
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.policies import ActorCriticPolicy
from tqdm import tqdm

import mobile_envs  # noqa: F401  (registers the env ids)
from agents.controllers.base import ClassicalAgent
from agents.controllers.mppi import MPPI
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from agents.training.files import write_atomically

#: The agents a warm start can imitate, by name.
TEACHERS: dict[str, type[ClassicalAgent]] = {
    "pure_pursuit": PurePursuit,
    "regulated_pure_pursuit": RegulatedPurePursuit,
    "mppi": MPPI,
}
#: The version of the checkpoint's layout; a file of another version is refused.
CHECKPOINT_VERSION = 2
#: Seeds between two rounds' recordings: each round's robots draw new tracks.
ROUND_SEED_STRIDE = 1000


@dataclass
class Demonstrations:
    """The completed episodes of a teacher, flattened over robots and steps.

    :param observations: (n, D) what the robot observed
    :param actions: (n, m) the teacher's normalized actions
    :param returns: (n,) the discounted return from each step to the episode's end
    :param episodes: how many episodes ended, completed or not
    :param completed: how many of them reached the goal (only those are kept)
    """

    observations: NDArray[np.float32]
    actions: NDArray[np.float32]
    returns: NDArray[np.float32]
    episodes: int
    completed: int

    def joined(self, other: Demonstrations) -> Demonstrations:
        """These samples and ``other``'s, in that order; the episodes counted together."""
        return Demonstrations(
            np.concatenate([self.observations, other.observations]),
            np.concatenate([self.actions, other.actions]),
            np.concatenate([self.returns, other.returns]),
            self.episodes + other.episodes,
            self.completed + other.completed,
        )


def _discounted(rewards: list[float], gamma: float) -> list[float]:
    """Returns from each step to the end of an episode that terminated (nothing after it)."""
    total, returns = 0.0, []
    for reward in reversed(rewards):
        total = reward + gamma * total
        returns.append(total)
    return returns[::-1]


def _check_count(name: str, value: object) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"warm_start {name} must be a positive integer, got {value!r}")


#: Seconds between two lines of a bar written to a file or a pipe (``train.py > run.log``):
#: a terminal redraws it ten times a second, a log would get ten lines a second.
LOG_REDRAW_INTERVAL = 10.0

#: A bar's line in a log: no bar to draw, so nothing cut to a width.
LOG_LINE = (
    "{desc}{percentage:3.0f}% {n_fmt}/{total_fmt} [{elapsed}<{remaining}, {rate_fmt}{postfix}]"
)


class _LogLines:
    """tqdm's output where stderr is a file or a pipe: each redraw of a bar is a line of its
    own. tqdm starts a redraw with a carriage return, which a log keeps as one endless line
    and which bars of two runs writing to one log (the grid's) would overwrite."""

    def __init__(self, stream: TextIO):
        self.stream = stream

    def write(self, text: str) -> None:
        line = text.replace("\r", "").rstrip()
        if line:
            self.stream.write(line + "\n")

    def flush(self) -> None:
        self.stream.flush()


@dataclass(frozen=True)
class Display:
    """What a warm start shows: nothing, or each stage as a line on stdout and a progress bar
    on stderr (redrawn in place on a terminal; a line every :data:`LOG_REDRAW_INTERVAL`
    seconds on a file or a pipe).

    :param shown: show anything at all
    :param label: put before every line and bar (several runs writing to one output, as the
        grid's do); none by default
    """

    shown: bool = False
    label: str = ""

    @property
    def prefix(self) -> str:
        return f"{self.label}: " if self.label else ""

    def say(self, text: str) -> None:
        """Print a stage's line on stdout."""
        if self.shown:
            print(f"{self.prefix}{text}", flush=True)

    def bar(self, total: int, done: int, unit: str) -> tqdm:
        """A bar starting at ``done`` of ``total``."""
        logged = not sys.stderr.isatty()
        return tqdm(
            total=total,
            initial=done,
            unit=unit,
            desc=self.prefix or None,
            disable=not self.shown,
            file=_LogLines(sys.stderr) if logged else sys.stderr,
            dynamic_ncols=not logged,
            bar_format=LOG_LINE if logged else None,  # a log line's width is not a screen's
            leave=logged,
            mininterval=LOG_REDRAW_INTERVAL if logged else 0.1,
        )


#: What drives a DAgger round: observations -> actions (the policy's mean action).
Driver = Callable[[NDArray[np.float32]], NDArray[np.float32]]


@dataclass
class _Recording:
    """A recording in progress: the env and the teacher as they are after ``step`` steps,
    and what was kept so far. Picklable (envs and agents copy bit for bit), so a stopped
    recording goes on where it stopped.

    The teacher drives, and only its completed episodes are kept; or, in a DAgger round,
    a ``driver`` drives (given to :meth:`run`), the teacher's command at every state it
    reaches is the label, and every episode that ended is kept (the states of a failed one
    are where the labels matter most)."""

    teacher: str
    env_id: str
    gamma: float
    steps: int
    envs: Any
    agent: Any
    observations: NDArray[np.float32]
    labels_only: bool = False
    step: int = 0
    episodes: int = 0
    completed: int = 0
    running: list[list[tuple[NDArray[np.float32], NDArray[np.float32], float]]] = field(
        default_factory=list
    )
    kept_observations: list[NDArray[np.float32]] = field(default_factory=list)
    kept_actions: list[NDArray[np.float32]] = field(default_factory=list)
    kept_returns: list[float] = field(default_factory=list)

    @classmethod
    def start(
        cls,
        teacher: str,
        env_id: str,
        *,
        robots: int,
        steps: int,
        gamma: float,
        seed: int,
        env_kwargs: dict[str, Any] | None,
        teacher_kwargs: dict[str, Any] | None = None,
        labels_only: bool = False,
    ) -> _Recording:
        envs = gym.make_vec(
            env_id, num_envs=robots, autoreset_mode="SameStep", **(env_kwargs or {})
        )
        agent = make_teacher(teacher, teacher_kwargs).bind(envs)
        observations, _ = envs.reset(seed=seed)
        running: list[list[Any]] = [[] for _ in range(robots)]
        return cls(
            teacher,
            env_id,
            gamma,
            steps,
            envs,
            agent,
            observations,
            labels_only=labels_only,
            running=running,
        )

    def run(
        self, check_stop: Callable[[], None], display: Display, driver: Driver | None = None
    ) -> None:
        """Step until ``steps``; ``check_stop`` is called before every step.

        :param driver: what drives a DAgger round (the recording was started with
            ``labels_only``); None: the teacher drives
        """
        if self.labels_only != (driver is not None):
            raise ValueError("a DAgger round needs a driver, a teacher's recording none")
        with display.bar(self.steps, self.step, "step") as bar:
            while self.step < self.steps:
                check_stop()
                self._step(driver)
                bar.update()
        self.envs.close()

    def _step(self, driver: Driver | None) -> None:
        labels, _ = self.agent.predict(self.observations)
        labels = labels.astype(np.float32)
        actions = labels if driver is None else driver(self.observations)
        next_observations, rewards, terminated, truncated, infos = self.envs.step(actions)
        ended = terminated | truncated
        for robot, episode in enumerate(self.running):
            episode.append((self.observations[robot], labels[robot], float(rewards[robot])))
            if not ended[robot]:
                continue
            self.episodes += 1
            success = bool(infos["final_info"]["is_success"][robot])
            self.completed += success
            if success or self.labels_only:
                self.kept_observations.extend(step[0] for step in episode)
                self.kept_actions.extend(step[1] for step in episode)
                self.kept_returns.extend(_discounted([step[2] for step in episode], self.gamma))
            self.running[robot] = []
        self.observations = next_observations
        self.step += 1

    def demonstrations(self) -> Demonstrations:
        """The episodes kept (ValueError when there are none)."""
        if not self.kept_observations:
            driver = "the policy" if self.labels_only else self.teacher
            raise ValueError(
                f"{driver} ended none of its episodes on {self.env_id} in {self.steps} steps"
                if self.labels_only
                else f"{self.teacher} completed none of {self.episodes} episodes on "
                f"{self.env_id} in {self.steps} steps: nothing to imitate"
            )
        return Demonstrations(
            np.array(self.kept_observations, dtype=np.float32),
            np.array(self.kept_actions, dtype=np.float32),
            np.array(self.kept_returns, dtype=np.float32),
            self.episodes,
            self.completed,
        )


def make_teacher(teacher: str, teacher_kwargs: dict[str, Any] | None = None) -> ClassicalAgent:
    """The teacher named ``teacher``, built with ``teacher_kwargs``.

    :raises ValueError: for an unknown teacher or parameters it does not take (or refuses)
    """
    if teacher not in TEACHERS:
        raise ValueError(f"unknown teacher {teacher!r}; known: {', '.join(TEACHERS)}")
    if not isinstance(teacher_kwargs, (dict, type(None))):
        raise ValueError(f"warm_start teacher_kwargs must be a mapping, got {teacher_kwargs!r}")
    try:
        return TEACHERS[teacher](**(teacher_kwargs or {}))
    except TypeError as error:
        raise ValueError(f"warm_start teacher_kwargs for {teacher}: {error}") from None


def record_demonstrations(
    teacher: str,
    env_id: str,
    *,
    robots: int,
    steps: int,
    gamma: float,
    seed: int = 0,
    env_kwargs: dict[str, Any] | None = None,
    teacher_kwargs: dict[str, Any] | None = None,
    driver: Driver | None = None,
    check_stop: Callable[[], None] | None = None,
) -> Demonstrations:
    """Run ``teacher`` on ``robots`` robots of ``env_id`` for ``steps`` vector steps.

    Only the episodes the teacher completed are kept: imitating its failures would teach
    them. Episodes still running at the end are dropped too (their returns are unknown).
    With a ``driver`` (a DAgger round), the driver steers, the teacher's commands at the
    states it reaches are the actions recorded, and every episode that ended is kept.

    :param teacher: a key of :data:`TEACHERS`
    :param gamma: the discount of the returns (the RL algorithm's)
    :param seed: the vector env's reset seed
    :param teacher_kwargs: the teacher's parameters
    :param driver: observations -> actions, or None: the teacher drives
    :param check_stop: called before every step; raises to stop recording
    :raises ValueError: for an unknown teacher or its bad parameters, counts below 1, or no
        episode to keep
    """
    _check_count("robots", robots)
    _check_count("steps", steps)
    recording = _Recording.start(
        teacher,
        env_id,
        robots=robots,
        steps=steps,
        gamma=gamma,
        seed=seed,
        env_kwargs=env_kwargs,
        teacher_kwargs=teacher_kwargs,
        labels_only=driver is not None,
    )
    recording.run(check_stop or _never_stop, Display(), driver=driver)
    return recording.demonstrations()


def _never_stop() -> None:
    """A ``check_stop`` that never stops."""


@dataclass
class _Cloning:
    """A cloning in progress: the optimizer, the minibatch generator and where in which epoch
    it is. Its :meth:`state` and :meth:`restore` carry it through a checkpoint."""

    policy: ActorCriticPolicy
    demonstrations: Demonstrations
    epochs: int
    batch_size: int
    optimizer: torch.optim.Optimizer
    generator: torch.Generator
    epoch: int = 0
    start: int = 0
    order: torch.Tensor | None = None
    action_total: float = 0.0
    value_total: float = 0.0
    losses: dict[str, float] = field(
        default_factory=lambda: {"action_mse": float("nan"), "value_mse": float("nan")}
    )

    @classmethod
    def begin(
        cls,
        policy: ActorCriticPolicy,
        demonstrations: Demonstrations,
        epochs: int,
        batch_size: int,
        learning_rate: float,
        seed: int,
    ) -> _Cloning:
        """A cloning at its first minibatch: Adam on every weight but ``log_std``, the
        minibatch order drawn from a generator seeded with ``seed``."""
        parameters = [p for name, p in policy.named_parameters() if name != "log_std"]
        optimizer = torch.optim.Adam(parameters, lr=learning_rate)
        generator = torch.Generator().manual_seed(seed)
        return cls(policy, demonstrations, epochs, batch_size, optimizer, generator)

    def state(self) -> dict[str, Any]:
        """Everything :meth:`restore` needs, the policy's weights included."""
        return {
            "policy": self.policy.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "generator": self.generator.get_state(),
            "epoch": self.epoch,
            "start": self.start,
            "order": self.order,
            "action_total": self.action_total,
            "value_total": self.value_total,
            "losses": dict(self.losses),
        }

    def restore(self, state: dict[str, Any]) -> None:
        """Go back to a :meth:`state`: the weights, Adam's moments, the generator and the
        place in the epoch."""
        self.policy.load_state_dict(state["policy"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.generator.set_state(state["generator"])
        self.epoch, self.start, self.order = state["epoch"], state["start"], state["order"]
        self.action_total, self.value_total = state["action_total"], state["value_total"]
        self.losses = dict(state["losses"])

    def run(self, check_stop: Callable[[], None], display: Display) -> dict[str, float]:
        """Train to the last epoch; ``check_stop`` is called before every minibatch."""
        device = self.policy.device
        observations = torch.as_tensor(self.demonstrations.observations, device=device)
        actions = torch.as_tensor(self.demonstrations.actions, device=device)
        returns = torch.as_tensor(self.demonstrations.returns, device=device)
        self.policy.set_training_mode(True)
        with display.bar(self.epochs, self.epoch, "epoch") as bar:
            while self.epoch < self.epochs:
                if self.order is None:
                    self.order = torch.randperm(len(observations), generator=self.generator)
                # The epoch's samples in its order, so that each minibatch is a slice of them.
                shuffled_observations = observations[self.order]
                shuffled_actions, shuffled_returns = actions[self.order], returns[self.order]
                while self.start < len(self.order):
                    check_stop()
                    rows = slice(self.start, self.start + self.batch_size)
                    mean, values = _mean_and_value(self.policy, shuffled_observations[rows])
                    action_loss = torch.nn.functional.mse_loss(mean, shuffled_actions[rows])
                    value_loss = torch.nn.functional.mse_loss(values, shuffled_returns[rows])
                    self.optimizer.zero_grad()
                    (action_loss + value_loss).backward()
                    self.optimizer.step()
                    self.action_total += action_loss.item() * len(mean)
                    self.value_total += value_loss.item() * len(mean)
                    self.start += self.batch_size
                self.losses = {
                    "action_mse": self.action_total / len(self.order),
                    "value_mse": self.value_total / len(self.order),
                }
                self.epoch += 1
                self.start, self.order = 0, None
                self.action_total = self.value_total = 0.0
                bar.set_postfix(self.losses, refresh=False)
                bar.update()
        self.policy.set_training_mode(False)
        return self.losses


def _mean_and_value(
    policy: ActorCriticPolicy, observations: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """The policy's mean action and value for a batch, with the features computed once.

    The same operations, in the same order, as ``policy.get_distribution(observations)``'s
    mean and ``policy.predict_values(observations)`` (so the same bits), without building an
    action distribution (its argument checks) or extracting the features twice: a
    minibatch of 512 clones in about 15% less time."""
    features = policy.extract_features(observations)
    if policy.share_features_extractor:
        latent_pi, latent_vf = policy.mlp_extractor(features)
    else:
        pi_features, vf_features = features
        latent_pi = policy.mlp_extractor.forward_actor(pi_features)
        latent_vf = policy.mlp_extractor.forward_critic(vf_features)
    return policy.action_net(latent_pi), policy.value_net(latent_vf).flatten()


def clone(
    policy: ActorCriticPolicy,
    demonstrations: Demonstrations,
    *,
    epochs: int,
    batch_size: int,
    learning_rate: float,
    seed: int = 0,
    check_stop: Callable[[], None] | None = None,
) -> dict[str, float]:
    """Fit ``policy``'s mean action to the teacher's actions and its value to the returns.

    The action noise (``log_std``) is left as the policy was built: PPO still explores
    around the cloned mean.

    :param check_stop: called before every minibatch; raises to stop cloning
    :return: the last epoch's ``action_mse`` and ``value_mse``
    """
    cloning = _Cloning.begin(policy, demonstrations, epochs, batch_size, learning_rate, seed)
    return cloning.run(check_stop or _never_stop, Display())


class _Checkpoint:
    """The warm start's checkpoint file: its settings, then the recording in progress, or
    the demonstrations and the cloning's state, or (once done) the cloned weights.

    :param path: the file (None: no checkpoint is kept)
    :param settings: what the warm start was asked; a checkpoint of other settings is refused
    """

    def __init__(self, path: pathlib.Path | None, settings: dict[str, Any]):
        self.path = path
        self.settings = settings

    def load(self) -> dict[str, Any] | None:
        """The saved progress, or None without a file.

        :raises ValueError: naming the file when it is unreadable or was saved for other
            settings
        """
        if self.path is None or not self.path.is_file():
            return None
        try:
            with self.path.open("rb") as file:
                saved = pickle.load(file)
        except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError) as error:
            raise ValueError(
                f"{self.path} is not a readable warm-start checkpoint: {type(error).__name__}"
            ) from None
        if not isinstance(saved, dict) or saved.get("version") != CHECKPOINT_VERSION:
            raise ValueError(f"{self.path} is not a warm-start checkpoint of this version")
        if saved["settings"] != self.settings:
            raise ValueError(
                f"{self.path} holds a warm start of other settings ({saved['settings']}), "
                f"not {self.settings}"
            )
        return saved

    def save(self, stage: str, **progress: Any) -> None:
        """Write the progress of ``stage`` (``recording``, ``cloning``, ``done``) atomically."""
        if self.path is None:
            return
        saved = {"version": CHECKPOINT_VERSION, "settings": self.settings, "stage": stage}
        saved.update(progress)
        write_atomically(self.path, lambda file: pickle.dump(saved, file, pickle.HIGHEST_PROTOCOL))


def warm_start(
    model: BaseAlgorithm,
    env_id: str,
    *,
    seed: int = 0,
    env_kwargs: dict[str, Any] | None = None,
    teacher: str = "regulated_pure_pursuit",
    teacher_kwargs: dict[str, Any] | None = None,
    robots: int = 64,
    steps: int = 2000,
    epochs: int = 20,
    batch_size: int = 1024,
    learning_rate: float = 1e-3,
    dagger_rounds: int = 0,
    dagger_steps: int | None = None,
    dagger_epochs: int | None = None,
    check_stop: Callable[[], None] | None = None,
    checkpoint: pathlib.Path | None = None,
    progress: bool = False,
    label: str = "",
) -> dict[str, float]:
    """Clone ``teacher``'s completed episodes on ``env_id`` into ``model``'s policy, in place,
    then run ``dagger_rounds`` DAgger rounds: the policy drives for ``dagger_steps`` steps,
    the teacher labels every state it reaches, and the policy is cloned again on all the
    samples so far for ``dagger_epochs`` epochs.

    :param model: a PPO (or any actor-critic with a Gaussian policy) model, not yet trained
    :param seed: seeds the demonstrations' env (round r's with ``seed + 1000 r``) and the
        cloning's minibatch order (``seed + r``)
    :param teacher_kwargs: the teacher's parameters (its constructor's keyword arguments)
    :param robots: robots driven at once while recording
    :param steps: vector steps the teacher's recording takes (``robots * steps`` samples
        before filtering)
    :param epochs: passes over the teacher's demonstrations
    :param dagger_rounds: DAgger rounds after the first cloning (0: none)
    :param dagger_steps: vector steps of each DAgger round's recording (default: ``steps``)
    :param dagger_epochs: passes over all the samples after each DAgger round (default:
        ``epochs``)
    :param check_stop: called between the recording's steps and the cloning's minibatches;
        raises to stop the warm start (a stop signal:
        :meth:`agents.interrupts.StopRequests.raise_if_requested`)
    :param checkpoint: a file for the warm start's progress (None: none is kept). When
        ``check_stop`` raises, the progress is saved there before the exception goes on; the
        cloned weights are saved there at the end. A call that finds the file goes on from
        it, to the weights an uninterrupted warm start gives, bit for bit
    :param progress: print each stage and show a progress bar (on stderr)
    :param label: put before each of those lines and bars (:class:`Display`)
    :return: how many samples and episodes were kept, and the final losses
    :raises ValueError: for a model whose policy is not an actor-critic, bad settings, or a
        checkpoint that is unreadable or holds other settings
    """
    policy = model.policy
    if not isinstance(policy, ActorCriticPolicy):
        raise ValueError(
            f"warm_start needs an actor-critic policy (PPO, A2C), got {type(policy).__name__}"
        )
    dagger_steps = steps if dagger_steps is None else dagger_steps
    dagger_epochs = epochs if dagger_epochs is None else dagger_epochs
    counts = (
        ("robots", robots),
        ("steps", steps),
        ("epochs", epochs),
        ("batch_size", batch_size),
        ("dagger_steps", dagger_steps),
        ("dagger_epochs", dagger_epochs),
    )
    for name, value in counts:
        _check_count(name, value)
    if isinstance(dagger_rounds, bool) or not isinstance(dagger_rounds, int) or dagger_rounds < 0:
        raise ValueError(f"warm_start dagger_rounds must be an integer >= 0, got {dagger_rounds!r}")
    if not learning_rate > 0:
        raise ValueError(f"warm_start learning_rate must be > 0, got {learning_rate!r}")
    make_teacher(teacher, teacher_kwargs)  # refuses a bad teacher before any work
    gamma = float(getattr(model, "gamma", 0.99))
    settings = {
        "env_id": env_id,
        "env_kwargs": env_kwargs or {},
        "seed": seed,
        "teacher": teacher,
        "teacher_kwargs": teacher_kwargs or {},
        "robots": robots,
        "steps": steps,
        "epochs": epochs,
        "batch_size": batch_size,
        "learning_rate": learning_rate,
        "dagger_rounds": dagger_rounds,
        "dagger_steps": dagger_steps,
        "dagger_epochs": dagger_epochs,
        "gamma": gamma,
    }
    saves = _Checkpoint(checkpoint, settings)
    saved = saves.load()
    display = Display(progress, label)
    say = display.say
    if saved is not None and saved["stage"] == "done":
        policy.load_state_dict(saved["policy"])
        say(f"warm start: done before, its weights read from {checkpoint}")
        return dict(saved["report"])
    first_round, stage = 0, "recording"
    demonstrations: Demonstrations | None = None
    recording: _Recording | None = None
    cloning_state: dict[str, Any] | None = None
    if saved is not None:
        say(f"warm start: going on from {checkpoint} ({saved['stage']}, round {saved['round']})")
        first_round, stage = saved["round"], saved["stage"]
        demonstrations, recording = saved["demonstrations"], saved.get("recording")
        cloning_state = saved.get("cloning")
        if saved.get("policy") is not None:
            policy.load_state_dict(saved["policy"])

    losses: dict[str, float] = {}
    for round_ in range(first_round, dagger_rounds + 1):
        dagger = round_ > 0
        if stage == "recording":
            round_steps = dagger_steps if dagger else steps
            going_on = f" (from step {recording.step})" if recording is not None else ""
            # Said before the env is made: making it may compile kernels for seconds.
            say(
                f"warm start: DAgger round {round_} of {dagger_rounds}: the policy drives "
                f"{robots} robots of {env_id} for {round_steps} steps, {teacher} labels "
                f"every state{going_on}"
                if dagger
                else f"warm start: {teacher} drives {robots} robots of {env_id} for "
                f"{round_steps} steps{going_on}"
            )
            if recording is None:
                recording = _Recording.start(
                    teacher,
                    env_id,
                    robots=robots,
                    steps=round_steps,
                    gamma=gamma,
                    seed=seed + ROUND_SEED_STRIDE * round_,
                    env_kwargs=env_kwargs,
                    teacher_kwargs=teacher_kwargs,
                    labels_only=dagger,
                )
            stop = _saving_on_stop(
                check_stop,
                saves,
                "recording",
                round=round_,
                recording=recording,
                demonstrations=demonstrations,
                policy=policy.state_dict() if dagger else None,
            )
            recording.run(stop, display, _policy_driver(policy) if dagger else None)
            recorded = recording.demonstrations()
            demonstrations = recorded if demonstrations is None else demonstrations.joined(recorded)
            recording, stage = None, "cloning"
        assert demonstrations is not None
        round_epochs = dagger_epochs if dagger else epochs
        cloning = _Cloning.begin(
            policy, demonstrations, round_epochs, batch_size, learning_rate, seed + round_
        )
        going_on = ""
        if cloning_state is not None:
            cloning.restore(cloning_state)
            going_on, cloning_state = f" (from epoch {cloning.epoch})", None
        say(
            f"warm start: cloning {len(demonstrations.actions)} samples of "
            f"{demonstrations.episodes} episodes ({demonstrations.completed} completed) into "
            f"the policy and its critic, {round_epochs} epochs{going_on}"
        )
        losses = cloning.run(
            _saving_on_stop(
                check_stop,
                saves,
                "cloning",
                round=round_,
                demonstrations=demonstrations,
                cloning=cloning,
            ),
            display,
        )
        stage = "recording"
    assert demonstrations is not None
    report = {
        "samples": float(len(demonstrations.actions)),
        "episodes": float(demonstrations.episodes),
        "completed": float(demonstrations.completed),
        **losses,
    }
    saves.save("done", policy=policy.state_dict(), report=report)
    say(
        f"warm start: done, action mse {losses['action_mse']:.4g}, "
        f"value mse {losses['value_mse']:.4g}"
    )
    return report


def _policy_driver(policy: ActorCriticPolicy) -> Driver:
    """The policy's deterministic (mean) action, clipped to the action space."""

    def drive(observations: NDArray[np.float32]) -> NDArray[np.float32]:
        actions, _ = policy.predict(observations, deterministic=True)
        return np.asarray(actions, dtype=np.float32)

    return drive


def _saving_on_stop(
    check_stop: Callable[[], None] | None, saves: _Checkpoint, stage: str, **progress: Any
) -> Callable[[], None]:
    """``check_stop`` that saves the progress of ``stage`` before its exception goes on.

    It is only called between two steps (or minibatches), where the progress is whole. A
    second signal during the save abandons it and keeps the previous file
    (:func:`agents.training.files.write_atomically`).
    """

    def poll() -> None:
        if check_stop is None:
            return
        try:
            check_stop()
        except BaseException:
            saves.save(
                stage,
                **{
                    name: value.state() if isinstance(value, _Cloning) else value
                    for name, value in progress.items()
                },
            )
            raise

    return poll


class WarmStartCallback(BaseCallback):
    """A warm start as rl-baselines3-zoo's ``callback:`` entry: before the first rollout it
    runs :func:`warm_start` on the model, on the env id and keyword arguments the training
    env was made with (read from its first env's ``spec``), seeded with the model's seed.

    In ``hyperparams/ppo.yml``, which ``python -m rl_zoo3.train --conf-file`` and
    ``train.py`` both read (train.py turns the entry into its run's ``warm_start``)::

        callback:
          - agents.training.imitation.WarmStartCallback:
              teacher: regulated_pure_pursuit
              robots: 64
              steps: 3000

    :param settings: :func:`warm_start`'s keyword arguments (``teacher``,
        ``teacher_kwargs``, ``robots``, ``steps``, ``epochs``, ``batch_size``,
        ``learning_rate``, ``dagger_rounds``, ``dagger_steps``, ``dagger_epochs``;
        ``progress``, True unless given)
    """

    def __init__(self, verbose: int = 0, **settings: Any):
        super().__init__(verbose)
        self.settings = {"progress": True, **settings}
        self.report: dict[str, float] | None = None

    def _on_training_start(self) -> None:
        spec = self.training_env.get_attr("spec", [0])[0]
        if spec is None:
            raise ValueError("WarmStartCallback needs an env made by gym.make (it has no spec)")
        registered = gym.spec(spec.id).kwargs
        env_kwargs = {
            key: value for key, value in spec.kwargs.items() if registered.get(key) != value
        }
        env_kwargs.pop("render_mode", None)
        self.report = warm_start(
            self.model,
            spec.id,
            seed=self.model.seed or 0,
            env_kwargs=env_kwargs,
            **self.settings,
        )

    def _on_step(self) -> bool:
        return True

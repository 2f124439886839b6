"""What every classical agent shares: a control law, for one robot and for many, and its
binding to an env.

A classical agent is a control law usable without any environment, as MATLAB's
``controllerPurePursuit`` object is: ``agent.reset(path)`` once per path, then one command per
control step. The law itself is written once, for N robots: :meth:`ClassicalAgent.batch`
returns its :class:`~agents.controllers.batch.LawBatch`, whose state lives in arrays and whose
commands come from one compiled call for all robots; the single-robot methods are its batch
of one. :meth:`ClassicalAgent.bind` (or ``Agent.for_env(env, **params)``) ties it to a
:class:`~mobile_envs.envs.path_following.PathFollowingEnv` or a
:class:`~mobile_envs.envs.vector.PathFollowingVectorEnv` and returns a :class:`BoundAgent`, which
has Stable-Baselines3's ``predict`` interface; :meth:`ClassicalAgent.batch_agent` returns the
:class:`~agents.controllers.batch.BatchAgent` the evaluation harness drives.

Bound agents read only the env's documented attributes: ``paths``/``path``,
``believed_states``/``believed_state``, ``elapsed_steps``, ``model``, ``dt`` and
``action_from_inputs``. They steer on what the robot believes, never on the truth: with
``localization="odometry"``, ``"beacons"`` or ``"odometry+beacons"`` the control law sees the
estimated pose (and the model's other state as the robot's encoders read it), exactly as a
controller on the robot reads its localization; with ``"exact"`` that is the true state.
"""

from __future__ import annotations

import inspect
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agents.controllers.batch import (
    ONE_ROBOT,
    BatchAgent,
    ClassicalBatchAgent,
    LawBatch,
    PerRobotLaws,
    TwistLawBatch,
)
from mobile_envs.robots import KinematicModel
from mobile_envs.world.paths import Path


class ClassicalAgent:
    """A control law following a :class:`~mobile_envs.world.paths.Path`: for one robot
    (:meth:`reset`, :meth:`inputs`) and for many (:meth:`batch`).

    A subclass implements either :meth:`batch`, the law for N robots (the single-robot
    methods then run its batch of one, whose state between calls lives on the instance), or
    :meth:`reset` and :meth:`inputs` for one robot, which :meth:`batch` then runs a robot at a
    time (:class:`~agents.controllers.batch.PerRobotLaws`).
    """

    _robot: LawBatch | None = None

    def batch(self, num_robots: int) -> LawBatch:
        """This law for ``num_robots`` robots, each with its own state, commanded together.

        :param num_robots: N, at least 1
        :raises TypeError: for a subclass that implements neither this nor :meth:`reset` and
            :meth:`inputs`
        """
        agent_type = type(self)
        if agent_type.reset is ClassicalAgent.reset or agent_type.inputs is ClassicalAgent.inputs:
            raise TypeError(
                f"{agent_type.__name__} must implement batch(), or reset() and inputs()"
            )
        return PerRobotLaws(self, num_robots)

    def reset(self, path: Path) -> None:
        """Start following ``path``: forget everything about the previous one.

        :param path: the path to follow
        """
        if self._robot is None:
            self._robot = self.batch(1)
        self._robot.reset(ONE_ROBOT, [path])

    def inputs(self, state: ArrayLike, model: KinematicModel, dt: float) -> NDArray[np.float64]:
        """The native inputs of ``model`` for one robot in ``state``, held for ``dt`` seconds.

        :param state: the model's state, shape (k,)
        :param model: the robot's kinematic model
        :param dt: the control period (s)
        :return: shape (m,)
        """
        states = np.asarray(state, dtype=np.float64).reshape(1, -1)
        return self.robot().inputs(ONE_ROBOT, states, model, dt)[0]

    def robot(self) -> LawBatch:
        """The batch of one that :meth:`reset` started.

        :raises RuntimeError: before the first :meth:`reset`
        """
        if self._robot is None:
            raise RuntimeError("call reset(path) before asking for a command")
        return self._robot

    def supports(self, model: KinematicModel) -> bool:
        """Whether this law can drive ``model`` (every model unless a subclass says not)."""
        return True

    def bind(self, env: Any) -> BoundAgent:
        """This agent's law bound to ``env``, with ``predict`` (see :class:`BoundAgent`).

        :param env: a PathFollowingEnv or PathFollowingVectorEnv, possibly wrapped
        :raises ValueError: when the env's model is not one this agent can drive
        """
        return BoundAgent(self, env)

    def batch_agent(self, env: Any) -> BatchAgent:
        """This agent's law driving the robots of the vector env ``env`` (a
        :class:`~agents.controllers.batch.BatchAgent`, as the evaluation harness drives it).

        :param env: a PathFollowingVectorEnv, possibly wrapped
        :raises ValueError: when the env's model is not one this agent can drive
        """
        return ClassicalBatchAgent(self.bind(env).laws, env)

    @classmethod
    def for_env(cls, env: Any, **params: Any) -> BoundAgent:
        """Build the agent with ``params`` and bind it to ``env``: ``cls(**params).bind(env)``."""
        return cls(**params).bind(env)

    def __repr__(self) -> str:
        params = ", ".join(f"{key}={value!r}" for key, value in self.parameters().items())
        return f"{type(self).__name__}({params})"

    def parameters(self) -> dict[str, Any]:
        """The constructor arguments that rebuild this agent (each kept as an attribute)."""
        names = list(inspect.signature(type(self)).parameters)
        return {name: getattr(self, name) for name in names}

    def _check_supports(self, model: KinematicModel) -> None:
        if not self.supports(model):
            raise ValueError(f"{type(self).__name__} cannot drive {model!r}")


class TwistAgent(ClassicalAgent):
    """A law that commands a twist (v, omega); every model follows it through
    :meth:`~mobile_envs.robots.model.KinematicModel.inputs_for`, as MATLAB's
    ``VehicleSpeedHeadingRate`` mode does."""

    def twist(
        self, pose: ArrayLike, dt: float = 0.1, turns_in_place: bool = True
    ) -> tuple[float, float]:
        """The commanded forward speed v (m/s) and yaw rate omega (rad/s).

        :param pose: (x, y, heading) of the robot's reference point
        :param dt: the control period (s), for laws that limit a rate of change
        :param turns_in_place: whether the robot rotates on the spot, for laws that ask
        """
        robot = self.robot()
        assert isinstance(robot, TwistLawBatch)
        poses = np.asarray(pose, dtype=np.float64).reshape(1, -1)
        v, omega = robot.twists(ONE_ROBOT, poses, dt, turns_in_place)
        return float(v[0]), float(omega[0])


def restarting_robots(
    known: list[Any],
    current: Sequence[Any],
    steps: Sequence[int] | NDArray[np.int64],
    episode_start: ArrayLike | None,
) -> list[int]:
    """The robots whose episodes start now, as a bound agent decides from what it was given:
    robot i when ``episode_start[i]`` is true or, when ``episode_start`` is None, when it has
    taken no step yet (``steps[i] == 0``) or its path or track is another object than the one
    it knew (``known[i]``, as after the vector env's autoreset). ``known`` is updated.

    :param known: each robot's path (or track) when last asked; None before the first
    :param current: each robot's path (or track) now
    :param steps: each robot's steps in its episode
    :param episode_start: per robot, whether its episode just started; None to detect it
    """
    starts = None if episode_start is None else np.atleast_1d(episode_start)
    restarting = []
    for index, now in enumerate(current):
        if starts is None:
            restart = steps[index] == 0 or now is not known[index]
        else:
            restart = bool(starts[index]) or known[index] is None
        if restart:
            restarting.append(index)
            known[index] = now
    return restarting


class BoundController(ABC):
    """A controller driving every robot of one env, with SB3's ``predict`` interface: what
    :class:`BoundAgent` and :class:`~agents.controllers.mppi.BoundMPPI` share.

    ``predict`` reads the env's documented state: ``believed_states`` / ``believed_state``
    (the estimate when the env localizes, the true state otherwise), what each robot follows
    (:meth:`followed`: its path or its track) and ``elapsed_steps``. A robot restarts
    (:meth:`restart`) as :func:`restarting_robots` decides, then every robot is commanded
    (:meth:`actions`).

    :param agent: the controller's parameters; never modified
    :param env: a PathFollowingEnv or PathFollowingVectorEnv, possibly wrapped
    """

    def __init__(self, agent: Any, env: Any):
        base = env.unwrapped
        self.agent = agent
        self.env = base
        self.batched = hasattr(base, "num_envs")
        #: The robots driven: the vector env's ``num_envs``, 1 for a single env.
        self.count: int = base.num_envs if self.batched else 1
        self._followed: list[Any] = [None] * self.count

    def predict(
        self,
        observation: NDArray[np.float32],
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], Any]:
        """The env's normalized actions for the robots' current states.

        The controller reads the env's believed state (``believed_states`` /
        ``believed_state``: the estimate when the env localizes, the true state otherwise),
        not ``observation``, as a classical controller reads its localization.

        :param observation: the env's observation, (D,) or (N, D) (unused)
        :param state: passed through unchanged (classical agents keep no recurrent state)
        :param episode_start: per robot, whether its episode just started; None to detect it
        :param deterministic: ignored: classical agents are deterministic (MPPI's noise is
            its episode generator's)
        :return: ``(actions, state)``: actions (m,) for a single env, (N, m) for a vector env
        """
        env = self.env
        states = env.believed_states if self.batched else env.believed_state[np.newaxis]
        followed = self.followed()
        steps = env.elapsed_steps if self.batched else [env.elapsed_steps]
        restarting = restarting_robots(self._followed, followed, steps, episode_start)
        if restarting:
            self.restart(restarting, [followed[index] for index in restarting])
        actions = self.actions(states)
        return (actions if self.batched else actions[0]), state

    @abstractmethod
    def followed(self) -> Sequence[Any]:
        """What each robot follows now (its path or its track): another object restarts it."""

    @abstractmethod
    def restart(self, robots: list[int], followed: list[Any]) -> None:
        """Robots ``robots`` start new episodes, ``robots[j]`` following ``followed[j]``."""

    @abstractmethod
    def actions(self, states: NDArray[np.float64]) -> NDArray[np.float32]:
        """Every robot's normalized action, shape (count, m), from its believed state."""

    def __repr__(self) -> str:
        return f"{self.agent!r}.bind({type(self.env).__name__})"


class BoundAgent(BoundController):
    """A classical agent driving every robot of one env, with SB3's ``predict`` interface.

    Each robot has its own state of the control law (its :meth:`ClassicalAgent.batch`). A
    robot's state restarts on its path when ``episode_start[i]`` is true or, when
    ``episode_start`` is None, when the robot has taken no step yet in its episode or its path
    object changed (as after the vector env's autoreset).

    :param agent: the control law; it is never modified
    :param env: a PathFollowingEnv or PathFollowingVectorEnv, possibly wrapped
    :raises ValueError: when ``agent`` cannot drive the env's model
    """

    agent: ClassicalAgent

    def __init__(self, agent: ClassicalAgent, env: Any):
        agent._check_supports(env.unwrapped.model)
        super().__init__(agent, env)
        self.laws = agent.batch(self.count)
        self._robots = np.arange(self.count, dtype=np.int64)

    def bind(self, env: Any) -> BoundAgent:
        """The same control law bound to another env."""
        return self.agent.bind(env)

    @property
    def robots(self) -> list[Any]:
        """Each robot's own copy of a law written for one robot
        (:class:`~agents.controllers.batch.PerRobotLaws`).

        :raises AttributeError: for a law with a batch of its own, whose state is in arrays
        """
        if not isinstance(self.laws, PerRobotLaws):
            raise AttributeError(
                f"{type(self.agent).__name__} keeps its robots' states in arrays, not in copies"
            )
        return self.laws.robots

    def followed(self) -> Sequence[Path]:
        """Each robot's path now."""
        return self.env.paths if self.batched else [self.env.path]

    def restart(self, robots: list[int], followed: list[Any]) -> None:
        """Robots ``robots`` start on their paths ``followed``."""
        self.laws.reset(robots, followed)

    def actions(self, states: NDArray[np.float64]) -> NDArray[np.float32]:
        """The control law's inputs for every robot, as the env's normalized actions."""
        env = self.env
        inputs = self.laws.inputs(self._robots, states, env.model, env.dt)
        return env.action_from_inputs(inputs)

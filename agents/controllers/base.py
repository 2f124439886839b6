"""What every classical agent shares: a single-robot control law and its binding to an env.

A classical agent is a control law for one robot, usable without any environment, as
MATLAB's ``controllerPurePursuit`` object is: ``agent.reset(path)`` once per path, then one
command per control step. :meth:`ClassicalAgent.bind` (or ``Agent.for_env(env, **params)``)
ties it to a :class:`~mobile_envs.envs.path_following.PathFollowingEnv` or a
:class:`~mobile_envs.envs.vector.PathFollowingVectorEnv` and returns a :class:`BoundAgent`, which
has Stable-Baselines3's ``predict`` interface, so the evaluation harness drives PPO models and
classical agents alike.

The bound agent keeps one copy of the control law per robot (each with its own projection
state) and reads only the env's documented attributes: ``paths``/``path``,
``believed_states``/``believed_state``, ``elapsed_steps``, ``model``, ``dt`` and
``action_from_inputs``. It steers on what the robot believes, never on the truth: with
``localization="odometry"``, ``"beacons"`` or ``"odometry+beacons"`` the control law sees the
estimated pose (and the model's other state as the robot's encoders read it), exactly as a
controller on the robot reads its localization; with ``"exact"`` that is the true state.
"""

from __future__ import annotations

import copy
import inspect
from abc import ABC, abstractmethod
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mobile_envs.robots import KinematicModel
from mobile_envs.world.paths import Path


class ClassicalAgent(ABC):
    """A control law for one robot following a :class:`~mobile_envs.world.paths.Path`.

    Subclasses implement :meth:`reset` and :meth:`inputs`; the law's state between calls
    (a projection, a previous command) lives on the instance.
    """

    @abstractmethod
    def reset(self, path: Path) -> None:
        """Start following ``path``: forget everything about the previous one.

        :param path: the path to follow
        """

    @abstractmethod
    def inputs(self, state: NDArray[np.float64], model: KinematicModel, dt: float) -> ArrayLike:
        """The native inputs of ``model`` for one robot in ``state``, held for ``dt`` seconds.

        :param state: the model's state, shape (k,)
        :param model: the robot's kinematic model
        :param dt: the control period (s)
        :return: shape (m,)
        """

    def supports(self, model: KinematicModel) -> bool:
        """Whether this law can drive ``model`` (every model unless a subclass says not)."""
        return True

    def bind(self, env: Any) -> BoundAgent:
        """A copy of this agent bound to ``env``, with ``predict`` (see :class:`BoundAgent`).

        :param env: a PathFollowingEnv or PathFollowingVectorEnv, possibly wrapped
        :raises ValueError: when the env's model is not one this agent can drive
        """
        return BoundAgent(self, env)

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


class TwistAgent(ClassicalAgent):
    """A law that commands a twist (v, omega); every model follows it through
    :meth:`~mobile_envs.robots.model.KinematicModel.inputs_for`, as MATLAB's
    ``VehicleSpeedHeadingRate`` mode does."""

    @abstractmethod
    def twist(self, pose: ArrayLike) -> tuple[float, float]:
        """The commanded forward speed v (m/s) and yaw rate omega (rad/s).

        :param pose: (x, y, heading) of the robot's reference point
        """

    def inputs(self, state: NDArray[np.float64], model: KinematicModel, dt: float) -> ArrayLike:
        v, omega = self.twist(state[:3])
        return model.inputs_for(state, v, omega, dt)


class BoundAgent:
    """A classical agent driving every robot of one env, with SB3's ``predict`` interface.

    Each robot gets its own copy of the control law. A robot's copy restarts on its path when
    ``episode_start[i]`` is true or, when ``episode_start`` is None, when the robot has taken no
    step yet in its episode or its path object changed (as after the vector env's autoreset).

    :param agent: the control law; it is copied, never modified
    :param env: a PathFollowingEnv or PathFollowingVectorEnv, possibly wrapped
    :raises ValueError: when ``agent`` cannot drive the env's model
    """

    def __init__(self, agent: ClassicalAgent, env: Any):
        base = env.unwrapped
        if not agent.supports(base.model):
            raise ValueError(f"{type(agent).__name__} cannot drive {base.model!r}")
        self.agent = agent
        self.env = base
        self.batched = hasattr(base, "num_envs")
        count = base.num_envs if self.batched else 1
        self.robots = [copy.deepcopy(agent) for _ in range(count)]
        self._paths: list[Path | None] = [None] * count

    def bind(self, env: Any) -> BoundAgent:
        """The same control law bound to another env."""
        return self.agent.bind(env)

    def predict(
        self,
        observation: NDArray[np.float32],
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], Any]:
        """The env's normalized actions for the robots' current states.

        The control law reads the env's believed state (``believed_states`` /
        ``believed_state``: the estimate when the env localizes, the true state otherwise),
        not ``observation``, as a classical controller reads its localization.

        :param observation: the env's observation, (D,) or (N, D) (unused)
        :param state: passed through unchanged (classical agents keep no recurrent state)
        :param episode_start: per robot, whether its episode just started; None to detect it
        :param deterministic: ignored: classical agents are deterministic
        :return: ``(actions, state)``: actions (m,) for a single env, (N, m) for a vector env
        """
        env = self.env
        if self.batched:
            states, paths, steps = env.believed_states, env.paths, env.elapsed_steps
        else:
            states = env.believed_state[np.newaxis]
            paths, steps = [env.path], [env.elapsed_steps]
        starts = None if episode_start is None else np.atleast_1d(episode_start)
        inputs = []
        for index, robot in enumerate(self.robots):
            if starts is None:
                restart = steps[index] == 0 or paths[index] is not self._paths[index]
            else:
                restart = bool(starts[index]) or self._paths[index] is None
            if restart:
                robot.reset(paths[index])
                self._paths[index] = paths[index]
            inputs.append(robot.inputs(states[index], env.model, env.dt))
        actions = env.action_from_inputs(np.array(inputs, dtype=np.float64))
        return (actions if self.batched else actions[0]), state

    def __repr__(self) -> str:
        return f"{self.agent!r}.bind({type(self.env).__name__})"

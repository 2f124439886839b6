"""Delay compensation: steer from where the robot will be when the command arrives.

The standard fix for an actuator delay (a Smith-predictor-like prediction): the robot still
has to carry out the commands already sent, so the controller predicts its pose over the
delay with them, through its nominal model and the lag it knows of, and steers from the
predicted pose. Wrapped around pure pursuit this is the classical side's best shot on a
robot with a plant (:mod:`mobile_envs.sim.plant`); it knows the plant's nominal delay and
time constant, never the true robot's parameter errors or slip.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agents.controllers.base import BoundAgent, ClassicalAgent
from mobile_envs.robots import KinematicModel
from mobile_envs.validation import as_real
from mobile_envs.world.paths import Path


def _non_negative(name: str, value: Any) -> float:
    number = as_real(name, value)
    if number < 0.0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return number


class DelayCompensated(ClassicalAgent):
    """``agent``, steering from the pose the robot will have when its command takes effect.

    Each control step the commands already sent (``delay / dt`` of them, the oldest first)
    are replayed through the nominal model from the current (believed) state, through the
    first-order lag of ``time_constant`` as the robot's actuators apply it, and ``agent``
    computes its command for the predicted state.

    :param agent: the control law to compensate (pure pursuit, regulated pure pursuit, ...)
    :param delay: the actuators' delay (s), a whole number of control steps; None: the
        delay of the env's plant (its configured one, not an episode's draw) when bound
    :param time_constant: the actuators' lag (s), 0 for none; None: the env's plant's
    """

    def __init__(
        self,
        agent: ClassicalAgent,
        delay: float | None = None,
        time_constant: float | None = None,
    ):
        if not isinstance(agent, ClassicalAgent):
            raise ValueError(f"agent must be a ClassicalAgent, got {agent!r}")
        self.agent = agent
        self.delay = None if delay is None else _non_negative("delay", delay)
        self.time_constant = (
            None if time_constant is None else _non_negative("time_constant", time_constant)
        )
        self._sent: deque[NDArray[np.float64]] = deque()
        self._applied: NDArray[np.float64] | None = None

    def supports(self, model: KinematicModel) -> bool:
        return self.agent.supports(model)

    def bind(self, env: Any) -> BoundAgent:
        """Bound to ``env``; a delay or time constant left None is the env's plant's."""
        plant = env.unwrapped.config.plant
        delay = self.delay if self.delay is not None else (0.0 if plant is None else plant.delay)
        time_constant = self.time_constant
        if time_constant is None:
            time_constant = 0.0 if plant is None else plant.time_constant
        return BoundAgent(DelayCompensated(self.agent, delay, time_constant), env)

    def reset(self, path: Path) -> None:
        self.agent.reset(path)
        self._sent.clear()
        self._applied = None

    def inputs(self, state: ArrayLike, model: KinematicModel, dt: float) -> NDArray[np.float64]:
        if self.delay is None or self.time_constant is None:
            raise ValueError("bind the agent to an env, or give its delay and time_constant")
        steps = round(self.delay / dt)
        if abs(steps * dt - self.delay) > 1e-9:
            raise ValueError(f"delay must be a multiple of dt = {dt} s, got {self.delay} s")
        lag = 1.0 if self.time_constant == 0.0 else -math.expm1(-dt / self.time_constant)
        applied = np.zeros(model.input_dim) if self._applied is None else self._applied
        pending = [np.zeros(model.input_dim)] * (steps - len(self._sent)) + list(self._sent)
        # This step the robot applies the oldest pending command (zeros before any arrived).
        predicted, realized = np.array(state, dtype=np.float64), applied
        for command in pending:
            realized = realized + lag * (command - realized) if lag < 1.0 else command
            predicted = model.step(predicted, realized, dt)
        command = np.asarray(self.agent.inputs(predicted, model, dt), dtype=np.float64)
        self._sent.append(command)
        arrived = pending[0] if steps else command
        self._applied = applied + lag * (arrived - applied) if lag < 1.0 else arrived
        while len(self._sent) > steps:
            self._sent.popleft()
        return command

    def parameters(self) -> dict[str, Any]:
        return {"agent": self.agent, "delay": self.delay, "time_constant": self.time_constant}

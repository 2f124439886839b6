"""The robot's recent commands, as an observation block: what a policy needs to compensate a
delay or a lag it cannot see (:mod:`mobile_envs.sim.plant`).

Opt-in: pass it with the other sensors, by name (``sensors=["range", {"type":
"command_history", "steps": 3}]``) or as an object (``CommandHistory(3)``). The
observation's ``previous_action`` block holds the action just applied; this one the ``steps``
before it, newest first, so together they hold the last ``steps + 1`` actions.
"""

from __future__ import annotations

import numpy as np

from mobile_envs.robots import KinematicModel
from mobile_envs.sensing.sensors.sensor import Array, Generators, Indices, Sensor, SensorWorld
from mobile_envs.validation import as_count


class CommandHistory(Sensor):
    """The actions (in [-1, 1]) of the ``steps`` steps before the last, newest first; zeros
    before the episode had them. Noise-free.

    :param steps: how many past actions, at least 1
    """

    name = "command_history"

    def __init__(self, steps: int = 3):
        self.steps = as_count("steps", steps, 1000)
        self.names: tuple[str, ...] = ()
        self.scales = np.ones(0)

    def bind(self, model: KinematicModel) -> None:
        self.names = tuple(
            f"command_{age}_{name}"
            for age in range(1, self.steps + 1)
            for name in model.input_names
        )
        self.scales = np.ones(len(self.names))

    def reset(self, world: SensorWorld, indices: Indices, rngs: Generators, out: Array) -> None:
        out[indices] = 0.0

    def measure(self, world: SensorWorld, indices: Indices, rngs: Generators, out: Array) -> None:
        # Measured after the move and before the score: previous_action still holds the
        # action of the step before this one, which enters the history.
        width = world.previous_action.shape[1]
        out[indices, width:] = out[indices, :-width]
        out[indices, :width] = world.previous_action[indices]

    def __repr__(self) -> str:
        return f"CommandHistory(steps={self.steps})"

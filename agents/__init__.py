"""Classical path-tracking agents and the evaluation harness for mobile_envs.

Every agent, classical or Stable-Baselines3, acts through ``predict(observation, state,
episode_start, deterministic) -> (action, state)`` and is measured by :func:`evaluate`::

    from agents import PurePursuit, evaluate

    print(evaluate(PurePursuit(), "mobile_envs/DiffDrive-Segments-v0", episodes=5).summary)
"""

from agents.controllers.guidance import TricycleGuidance
from agents.controllers.mppi import MPPI
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from agents.harness.evaluate import EvaluationResult, evaluate

__all__ = [
    "EvaluationResult",
    "MPPI",
    "PurePursuit",
    "RegulatedPurePursuit",
    "TricycleGuidance",
    "evaluate",
]

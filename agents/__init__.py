"""Classical path-tracking agents and the evaluation harness for mobile_envs.

Every agent, classical or Stable-Baselines3, is measured by :func:`evaluate`, which runs all
its episodes at once in one vector env (a classical law commands every robot in one compiled
call, a policy predicts for every robot in one batch; any other controller plugs in as a
:class:`BatchAgent`)::

    from agents import PurePursuit, evaluate

    result = evaluate(PurePursuit(), "mobile_envs/DiffDrive-Random-v0", episodes=1000)
    print(result.summary, result.intervals())

Bound to an env, every agent also acts through SB3's ``predict(observation, state,
episode_start, deterministic) -> (action, state)``.
"""

from agents.controllers.batch import BatchAgent
from agents.controllers.guidance import TricycleGuidance
from agents.controllers.mppi import MPPI
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from agents.harness.evaluate import EvaluationResult, evaluate

__all__ = [
    "MPPI",
    "BatchAgent",
    "EvaluationResult",
    "PurePursuit",
    "RegulatedPurePursuit",
    "TricycleGuidance",
    "evaluate",
]

"""``train.py sweep`` and ``train.py grid``: the commands that train many runs.

train.py hands them their arguments here, so a missing optional extra is one clear line
instead of a traceback: the sweep needs ``optuna`` (the ``sweep`` extra), the grid needs
``scipy`` (also in ``sweep``), and ``grid --backend ray`` needs the ``ray`` extra.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence

COMMANDS = {
    "sweep": "an Optuna study over hyperparameters and reward weights",
    "grid": "many seeds x envs x algos, one table of mean ± CI and IQM",
}
#: The module that runs each command (its ``main(argv)``).
_MODULES = {"sweep": "agents.sweeps.sweep", "grid": "agents.grid.grid"}


def main(command: str, argv: Sequence[str]) -> int:
    """Run ``command`` (a key of :data:`COMMANDS`) with ``argv``; return its exit code."""
    if command not in COMMANDS:
        raise ValueError(f"unknown command {command!r}; known: {', '.join(COMMANDS)}")
    try:
        module = importlib.import_module(_MODULES[command])
    except ModuleNotFoundError as error:
        print(
            f"train.py {command}: error: {error.name} is not installed; "
            f"pip install -e '.[train,sweep]'",
            file=sys.stderr,
        )
        return 2
    code: int = module.main(list(argv))
    return code

"""Training progress as a line every few seconds, for output that is not a terminal.

SB3's progress bar (rich) redraws itself in a terminal; written to a file or a pipe (``train.py
... > run.log``, a Slurm or Ray job) it shows nothing until the run ends, minutes later. There
``train.py`` prints these lines instead, and so does each run of ``train.py grid``, named.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

from stable_baselines3.common.callbacks import BaseCallback


class ProgressLines(BaseCallback):
    """Print ``step N of TOTAL (P%), R steps/s`` at most every ``interval`` seconds of
    training, and once when training ends.

    The rate counts the steps of this run only (a resumed run starts its count where it
    resumed).

    :param total: the step count the run ends at
    :param interval: seconds between two lines, > 0
    :param stream: where the lines go (standard output by default)
    :param clock: monotonic seconds (``time.monotonic``)
    :param label: put before each line as ``LABEL: step ...`` (several runs printing to one
        output, as the grid's do); none by default
    """

    def __init__(
        self,
        total: int,
        interval: float = 10.0,
        stream: TextIO | None = None,
        clock: Callable[[], float] = time.monotonic,
        label: str = "",
    ):
        super().__init__()
        if total < 1:
            raise ValueError(f"total must be at least 1 step, got {total}")
        if not interval > 0:
            raise ValueError(f"interval must be positive, got {interval}")
        self.total = total
        self.interval = interval
        self.stream = stream
        self.clock = clock
        self.prefix = f"{label}: " if label else ""
        self._started = self._printed = 0.0
        self._steps_at_start = 0

    def _on_training_start(self) -> None:
        self._started = self._printed = self.clock()
        self._steps_at_start = self.num_timesteps

    def _on_step(self) -> bool:
        now = self.clock()
        if now - self._printed >= self.interval:
            self._printed = now
            self._print(now)
        return True

    def _on_training_end(self) -> None:
        self._print(self.clock())

    def _print(self, now: float) -> None:
        steps = self.num_timesteps
        elapsed = now - self._started
        rate = (steps - self._steps_at_start) / elapsed if elapsed > 0 else 0.0
        print(
            f"{self.prefix}step {steps:,} of {self.total:,} ({100 * steps / self.total:.0f}%), "
            f"{rate:,.0f} steps/s",
            file=self.stream if self.stream is not None else sys.stdout,
            flush=True,
        )

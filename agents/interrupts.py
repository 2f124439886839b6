"""Ctrl-C and SIGTERM as a request to stop, honoured where stopping is safe.

A Python signal handler runs between any two bytecodes of the main thread, also inside the
callbacks that compiled code makes into Python: numba's dispatcher calls
``_numba_unpickle`` on every call of a kernel that returns arrays. An exception raised
there does not come out as itself. Numba reports it as a ``SystemError`` whose cause is the
interruption, or, boxing a kernel's result arrays, crashes the process with a segmentation
fault. So a run that stops by raising from the handler may fail with the wrong error, or
lose everything since its last checkpoint.

:class:`StopRequests` therefore only records the first stop signal. The loops that take time
poll it between their steps and stop there, where the model is whole: training through
:class:`agents.training.checkpoints.StopOnRequest`, the warm start and
:func:`agents.harness.evaluate.evaluate`
through their ``check_stop`` argument (train.py, ``compare``, the sweep and grid workers). A
second signal raises :class:`Interrupted` at once, as an escape hatch (and for the save after
the first one, which the second abandons). :func:`interruption_in` finds an interruption
inside whatever exception carried it out.

Usage::

    requests = StopRequests()
    with requests.installed():
        try:
            model.learn(steps, callback=StopOnRequest(requests, callbacks))
            requests.raise_if_requested()
        except BaseException as error:
            interruption = interruption_in(error)
            if interruption is None:
                raise
            ...  # save, then exit with 128 + signum_of(interruption)
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType

#: The signals that ask a run to stop: Ctrl-C, and what Slurm, Kubernetes and Ray send.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A stop signal arrived; the exit status is ``128 + signum``.

    :param signum: the signal's number
    """

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class StopRequests:
    """The stop signals this process has received: the first is recorded, for a poller to
    honour; any after it raises :class:`Interrupted`.

    :ivar signum: the first stop signal received within :meth:`installed`, or None
    :ivar forced: whether a second signal came and raised at once: what it interrupted did not
        save
    """

    def __init__(self) -> None:
        self.signum: int | None = None
        self.forced = False
        self._asked: int | None = None

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.signum is None:
            self.signum = signum  # honoured at the next poll
            return
        self.forced = True
        raise Interrupted(signum)

    def request(self, signum: int = signal.SIGTERM) -> None:
        """Ask to stop as the first ``signum`` would, from another thread (a grid worker's
        parent asks this way). It is not a signal: the first real one after it is still only
        recorded, so a worker that its parent and the system both stop saves all the same."""
        self._asked = signum

    @contextlib.contextmanager
    def installed(self) -> Iterator[StopRequests]:
        """Within the block, SIGINT and SIGTERM go to this object; the previous handlers come
        back after it."""
        previous = {signum: signal.signal(signum, self._handle) for signum in STOP_SIGNALS}
        try:
            yield self
        finally:
            for signum, handler in previous.items():
                signal.signal(signum, handler)

    @property
    def requested(self) -> bool:
        """Whether a stop signal has arrived, or a :meth:`request`."""
        return self.signum is not None or self._asked is not None

    def raise_if_requested(self) -> None:
        """Raise :class:`Interrupted` for a recorded stop signal or :meth:`request`; do
        nothing otherwise. The poll for loops that cannot return early."""
        signum = self._asked if self.signum is None else self.signum
        if signum is not None:
            raise Interrupted(signum)


@contextlib.contextmanager
def stop_requests_on_main_thread() -> Iterator[StopRequests | None]:
    """:class:`StopRequests` installed for the block on the main thread; None on any other
    thread, where Python lets no handler be set (a thread pool's task keeps the process's)."""
    if threading.current_thread() is not threading.main_thread():
        yield None
        return
    with StopRequests().installed() as requests:
        yield requests


def signum_of(interruption: KeyboardInterrupt) -> int:
    """The signal behind ``interruption``: its own for an :class:`Interrupted`, SIGINT for
    Ctrl-C's plain ``KeyboardInterrupt``."""
    return getattr(interruption, "signum", signal.SIGINT)


def interruption_in(error: BaseException) -> KeyboardInterrupt | None:
    """The interruption (an :class:`Interrupted` or Ctrl-C's plain ``KeyboardInterrupt``) that
    ``error`` is or that caused it; None when ``error`` has nothing to do with a signal.

    Follows ``__cause__``, which is how CPython chains an exception that a C function let
    through (``SystemError: ... returned a result with an exception set``). ``__context__`` is
    not followed: an error raised while handling an interruption (a full disk during the save)
    is an error of its own.

    >>> try:
    ...     try:
    ...         raise Interrupted(signal.SIGTERM)
    ...     except Interrupted as inner:
    ...         raise SystemError("returned a result with an exception set") from inner
    ... except SystemError as outer:
    ...     interruption_in(outer).signum == signal.SIGTERM
    True
    """
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        if isinstance(current, KeyboardInterrupt):
            return current
        seen.add(id(current))
        current = current.__cause__
    return None

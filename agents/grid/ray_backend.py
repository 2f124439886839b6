"""The grid's Ray backend: each run of :mod:`agents.grid.grid` as a Ray task on a cluster.

Start a cluster with ``ray start --head --port 6379`` on one machine and
``ray start --address HEAD:6379`` on the others (each with this package installed, and
``--output`` on a filesystem they share, so a retry finds its run folder), then run
``python train.py grid --backend ray --address HEAD:6379 ...`` anywhere in it.

A task takes one CPU (training uses one torch thread). When the worker process or node
running a task dies, Ray runs the task again, up to ``retries`` times: the run continues
from what its folder holds (:func:`agents.grid.run.run_one`). An exception raised by the run
itself is not retried, since a run is deterministic and would raise again; it is reported
with the run's name.

No cluster at the address is one line after at most ``timeout`` seconds (Ray itself would
retry for minutes): a closed port at once, anything else that does not answer as a cluster
when the time is up. A stop request (Ctrl-C or SIGTERM to the grid) cancels the tasks, which
Ray interrupts as Ctrl-C would: each running run stops at its next step and saves its
checkpoint. Requires the ``ray`` extra.
"""

from __future__ import annotations

import logging
import os
import pathlib
import signal
import socket
import subprocess
import sys
import tempfile
import threading
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from agents.grid.run import RunSpec, run_one

if TYPE_CHECKING:
    from agents.interrupts import StopRequests


#: What the connection probe runs: ``ray.init`` on the address in its first argument.
_PROBE = (
    "import logging, sys, ray; "
    "ray.init(address=sys.argv[1], logging_level=logging.ERROR, log_to_driver=False); "
    "ray.shutdown()"
)


def connect(address: str, timeout: float) -> None:
    """``ray.init`` on the cluster at ``address``, given up after ``timeout`` seconds.

    Ray's own connection retries for minutes, logging on stderr, and lingers at exit: a
    closed port is found at once, then a probe process connects first and is killed when the
    time is up. The connection itself is made on a helper thread, which keeps Ray from
    replacing this process's SIGTERM handler.

    :raises ValueError: naming the address when nothing answers there as a Ray cluster
    """
    import ray

    host, colon, port = address.rpartition(":")
    if "://" not in address and colon and port.isdigit():
        try:
            socket.create_connection((host or "127.0.0.1", int(port)), timeout=timeout).close()
        except OSError as error:
            raise ValueError(f"--address {address}: no Ray cluster there: {error}") from None
    with tempfile.TemporaryFile("w+") as log:
        # Its own session, so that killing it takes what it started; a file, not a pipe, for
        # its messages, so that nothing it leaves holds this process up.
        probe = subprocess.Popen(
            [sys.executable, "-c", _PROBE, address],
            stdout=subprocess.DEVNULL,
            stderr=log,
            start_new_session=True,
        )
        try:
            status = probe.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(probe.pid, signal.SIGKILL)
            probe.wait()
            raise ValueError(
                f"--address {address}: no Ray cluster answered within {timeout:g} s (--ray-timeout)"
            ) from None
        log.seek(0)
        lines = [line for line in log.read().splitlines() if line.strip()]
    if status != 0:
        reason = lines[-1] if lines else f"exit status {status}"
        raise ValueError(f"--address {address}: no Ray cluster there: {reason}")
    outcome: dict[str, BaseException] = {}
    connected = threading.Event()

    def initialize() -> None:
        try:
            ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False)
        except BaseException as error:  # reported by the waiting thread
            outcome["error"] = error
        finally:
            connected.set()

    threading.Thread(target=initialize, daemon=True, name="ray-connect").start()
    connected.wait()
    if "error" in outcome:
        refusal = outcome["error"]
        raise ValueError(f"--address {address}: no Ray cluster there: {refusal}") from None


def run_on_ray(
    specs: Sequence[RunSpec],
    output: pathlib.Path,
    address: str | None,
    retries: int,
    timeout: float = 60.0,
    requests: StopRequests | None = None,
) -> tuple[list[dict[str, Any]], dict[str, str]]:
    """Run ``specs`` as Ray tasks; return the records and the errors by run name.

    :param specs: the runs
    :param output: the grid folder, which every node must reach at the same path
    :param address: the cluster's ``HOST:PORT``; None reads ``RAY_ADDRESS``
    :param retries: how many times a task whose worker died runs again
    :param timeout: seconds to wait for the cluster to answer
    :param requests: stop requests: one cancels the tasks, waits for them, and raises
        :class:`~agents.interrupts.Interrupted`
    :raises ValueError: when there is no address, or no cluster answers at it in time
    """
    try:
        import ray
    except ModuleNotFoundError:
        raise ValueError("--backend ray needs the ray extra: pip install -e '.[ray]'") from None
    from agents.interrupts import Interrupted

    address = address or os.environ.get("RAY_ADDRESS")
    if not address:
        raise ValueError("--backend ray needs --address HOST:PORT (or RAY_ADDRESS)")
    connect(address, timeout)
    try:
        task = ray.remote(num_cpus=1, max_retries=retries, retry_exceptions=False)(run_one)
        folder = str(output.resolve())
        pending = {task.remote(spec, folder): spec for spec in specs}
        records, errors = [], {}
        cancelled = False
        while pending:
            if requests is not None and requests.requested and not cancelled:
                for reference in pending:
                    ray.cancel(reference)
                cancelled = True
            done, _ = ray.wait(list(pending), num_returns=1, timeout=0.5)
            if not done:
                continue
            spec = pending.pop(done[0])
            try:
                records.append(ray.get(done[0]))
                print(f"done: {spec.name}", flush=True)
            except (ray.exceptions.TaskCancelledError, ray.exceptions.RayTaskError) as error:
                if cancelled:
                    print(f"stopped: {spec.name}", flush=True)
                    continue
                cause = getattr(error, "cause", error)
                errors[spec.name] = f"{type(cause).__name__}: {cause}"
                print(f"failed: {spec.name}: {errors[spec.name]}", flush=True)
            except ray.exceptions.RayError as error:  # worker or node lost beyond retries
                errors[spec.name] = f"{type(error).__name__}: {error}"
                print(f"failed: {spec.name}: {errors[spec.name]}", flush=True)
        if requests is not None and requests.signum is not None:
            raise Interrupted(requests.signum)
        return records, errors
    finally:
        ray.shutdown()

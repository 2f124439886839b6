"""The grid's Ray backend: each run of :mod:`agents.grid.grid` as a Ray task on a cluster.

Start a cluster with ``ray start --head --port 6379`` on one machine and
``ray start --address HEAD:6379`` on the others (each with this package installed, and
``--output`` on a filesystem they share, so a retry finds its run folder), then run
``python train.py grid --backend ray --address HEAD:6379 ...`` anywhere in it.

A task takes one CPU (training uses one torch thread). When the worker process or node
running a task dies, Ray runs the task again, up to ``retries`` times: the run continues
from what its folder holds (:func:`agents.grid.grid.run_one`). An exception raised by the run
itself is not retried, since a run is deterministic and would raise again; it is reported
with the run's name. Requires the ``ray`` extra.
"""

from __future__ import annotations

import logging
import os
import pathlib
from collections.abc import Sequence
from typing import Any

from agents.grid.run import RunSpec, run_one


def run_on_ray(
    specs: Sequence[RunSpec], output: pathlib.Path, address: str | None, retries: int
) -> tuple[list[dict[str, Any]], dict[str, str]]:
    """Run ``specs`` as Ray tasks; return the records and the errors by run name.

    :param specs: the runs
    :param output: the grid folder, which every node must reach at the same path
    :param address: the cluster's ``HOST:PORT``; None reads ``RAY_ADDRESS``
    :param retries: how many times a task whose worker died runs again
    :raises ValueError: when there is no address, or no cluster answers at it
    """
    try:
        import ray
    except ModuleNotFoundError:
        raise ValueError("--backend ray needs the ray extra: pip install -e '.[ray]'") from None

    address = address or os.environ.get("RAY_ADDRESS")
    if not address:
        raise ValueError("--backend ray needs --address HOST:PORT (or RAY_ADDRESS)")
    try:
        ray.init(address=address, logging_level=logging.WARNING, log_to_driver=False)
    except (ConnectionError, RuntimeError) as error:
        raise ValueError(f"no Ray cluster at {address}: {error}") from None
    try:
        task = ray.remote(num_cpus=1, max_retries=retries, retry_exceptions=False)(run_one)
        folder = str(output.resolve())
        pending = {task.remote(spec, folder): spec for spec in specs}
        records, errors = [], {}
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            spec = pending.pop(done[0])
            try:
                records.append(ray.get(done[0]))
                print(f"done: {spec.name}", flush=True)
            except ray.exceptions.RayTaskError as error:
                cause = error.cause
                errors[spec.name] = f"{type(cause).__name__}: {cause}"
                print(f"failed: {spec.name}: {errors[spec.name]}", flush=True)
            except ray.exceptions.RayError as error:  # worker or node lost beyond retries
                errors[spec.name] = f"{type(error).__name__}: {error}"
                print(f"failed: {spec.name}: {errors[spec.name]}", flush=True)
        return records, errors
    finally:
        ray.shutdown()

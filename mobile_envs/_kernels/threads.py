"""The threads the parallel kernels run on: numba's threading layer and thread count.

One thread (the default) calls the serial kernels and starts no numba threads at all. More
than one runs the ``*_parallel`` kernels (:mod:`mobile_envs.sim.step`,
:func:`mobile_envs.world.maze.sense_packed_parallel`) through :func:`on_threads`, on the layer
:func:`start_kernel_threads` picks.
"""

from __future__ import annotations

import ctypes
import pathlib
import sys
from typing import Any

import numba
from numba import get_num_threads, set_num_threads


def on_threads(parallel: Any, threads: int, *arguments: Any) -> None:
    """``parallel(threads, *arguments)``: a parallel kernel in ``threads`` chunks, with
    numba's thread count (which each calling thread sets for itself) at ``threads`` while it
    runs and the caller's after."""
    caller_threads = get_num_threads()
    if caller_threads == threads:
        parallel(threads, *arguments)
        return
    set_num_threads(threads)
    try:
        parallel(threads, *arguments)
    finally:
        set_num_threads(caller_threads)


def start_kernel_threads() -> None:
    """Have numba run the parallel kernels on TBB's threads when TBB is installed (the
    ``parallel`` extra), else on its own workqueue threads, unless the user chose a threading
    layer (``NUMBA_THREADING_LAYER``).

    numba prefers OpenMP, which loads the system's libgomp beside torch's own: torch in the
    same process then trained 80 times slower here. Neither TBB nor the workqueue has that
    conflict, and TBB starts a parallel kernel in microseconds where the workqueue takes about
    a hundred, as much as the kernel itself at N = 1024. The choice holds for the process once
    numba starts its threads (at the first parallel kernel).
    """
    if numba.config.THREADING_LAYER == "default":  # type: ignore[attr-defined]
        layer = "tbb" if _load_tbb() else "workqueue"
        numba.config.THREADING_LAYER = layer  # type: ignore[attr-defined]


def _load_tbb() -> bool:
    """Whether numba's TBB layer can load. pip's ``tbb`` puts ``libtbb.so.12`` in the
    environment's ``lib`` folder, where the loader does not look, so it is loaded from there
    first; a system TBB needs nothing."""
    library = {"linux": "libtbb.so.12", "darwin": "libtbb.12.dylib"}.get(sys.platform)
    candidate = pathlib.Path(sys.prefix, "lib", library) if library else None
    if candidate is not None and candidate.is_file():
        try:
            ctypes.CDLL(str(candidate), mode=ctypes.RTLD_GLOBAL)
        except OSError:
            return False
    try:
        from numba.np.ufunc import tbbpool  # type: ignore[attr-defined]  # noqa: F401
    except ImportError:
        return False
    return True

"""What a run was trained on: the machine, the libraries and the settings that change bits.

Same seed, same command, same machine gives the same weights bit for bit; on another machine
torch may pick other CPU kernels (``torch.backends.cpu.get_cpu_capability()``: ``AVX512``,
``AVX2``, ``DEFAULT``, set by the ``ATEN_CPU_CAPABILITY`` variable), other thread counts split
sums in another order, and another library version computes differently. A run folder's
``machine.yml`` records all of these, one entry per training session (a new run, then each
``--resume``), so two runs that differ can be told apart by what they ran on.

Each entry (:func:`machine_info`) holds:

- ``started_at_step``, ``time``: the step the session began at, and when (UTC, ISO 8601)
- ``python``, ``platform``, ``libraries``: the versions of python, numpy, numba, torch,
  gymnasium, stable-baselines3 and sb3-contrib (None where one is not installed)
- ``cpu``: the model name, the instruction-set flags torch's kernels dispatch on (avx, avx2,
  fma, avx512*, amx*), the logical cores and the cores this process may use
- ``torch``: ``num_threads``, ``num_interop_threads``, ``cpu_capability``, whether MKL and
  oneDNN (mkldnn) are built in, and ``parallel_info`` (OpenMP/MKL threading, one line each)
- ``environment``: the variables that set threads or kernels: ``ATEN_CPU_CAPABILITY``,
  ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``, ``MKL_CBWR`` (MKL's own per-CPU code path:
  it changed SAC's weights here where ``ATEN_CPU_CAPABILITY`` avx2/avx512 did not),
  ``ONEDNN_MAX_CPU_ISA``, ``PYTHONHASHSEED`` and every
  ``NUMBA_*``
"""

from __future__ import annotations

import datetime
import importlib.metadata
import os
import pathlib
import platform
import sys
from typing import Any

import yaml

#: The file in a run folder.
MACHINE_FILE = "machine.yml"
#: Distribution names whose versions are recorded, by the key they are recorded under.
LIBRARIES = {
    "numpy": "numpy",
    "numba": "numba",
    "torch": "torch",
    "gymnasium": "gymnasium",
    "stable_baselines3": "stable_baselines3",
    "sb3_contrib": "sb3_contrib",
}
#: Environment variables that change which kernels run or how many threads split the work.
ENVIRONMENT_VARIABLES = (
    "ATEN_CPU_CAPABILITY",
    "OMP_NUM_THREADS",
    "MKL_NUM_THREADS",
    "MKL_CBWR",
    "ONEDNN_MAX_CPU_ISA",
    "PYTHONHASHSEED",
)
#: CPU flag prefixes that decide torch's kernels (its CPU capability) and their arithmetic.
KERNEL_FLAG_PREFIXES = ("avx", "fma", "amx", "f16c")


def cpu_info(cpuinfo: pathlib.Path = pathlib.Path("/proc/cpuinfo")) -> dict[str, Any]:
    """The CPU: model name, the flags torch's kernels depend on, and core counts.

    :param cpuinfo: the Linux CPU description; elsewhere the model is ``platform.processor()``
        and no flags are listed
    """
    fields: dict[str, str] = {}
    if cpuinfo.is_file():
        for line in cpuinfo.read_text(errors="replace").splitlines():
            key, _, value = line.partition(":")
            fields.setdefault(key.strip(), value.strip())  # the first processor's
    model = fields.get("model name") or platform.processor() or platform.machine()
    flags = sorted(
        flag for flag in fields.get("flags", "").split() if flag.startswith(KERNEL_FLAG_PREFIXES)
    )
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        "model": model,
        "kernel_flags": flags,
        "logical_cores": os.cpu_count(),
        "usable_cores": usable,
    }


def library_versions() -> dict[str, str | None]:
    """The installed version of each of :data:`LIBRARIES`, None where one is missing."""
    versions: dict[str, str | None] = {}
    for key, distribution in LIBRARIES.items():
        try:
            versions[key] = importlib.metadata.version(distribution)
        except importlib.metadata.PackageNotFoundError:
            versions[key] = None
    return versions


def torch_info() -> dict[str, Any]:
    """Torch's thread settings and CPU kernels as this process runs them."""
    import torch

    parallel = [line.strip() for line in torch.__config__.parallel_info().splitlines()]
    return {
        "num_threads": torch.get_num_threads(),
        "num_interop_threads": torch.get_num_interop_threads(),
        "cpu_capability": torch.backends.cpu.get_cpu_capability(),
        "mkl": torch.backends.mkl.is_available(),
        "mkldnn": torch.backends.mkldnn.is_available(),
        "parallel_info": [line for line in parallel if line and not line.startswith("---")],
    }


def environment_settings() -> dict[str, str]:
    """The set environment variables among :data:`ENVIRONMENT_VARIABLES` and ``NUMBA_*``."""
    names = [*ENVIRONMENT_VARIABLES, *sorted(n for n in os.environ if n.startswith("NUMBA_"))]
    return {name: os.environ[name] for name in names if name in os.environ}


def machine_info(step: int = 0) -> dict[str, Any]:
    """One ``machine.yml`` entry: this machine, its libraries and settings, now.

    :param step: the step the training session starts at (0 for a new run)
    """
    return {
        "started_at_step": int(step),
        "time": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "python": platform.python_version(),
        "implementation": sys.implementation.name,
        "platform": platform.platform(),
        "libraries": library_versions(),
        "cpu": cpu_info(),
        "torch": torch_info(),
        "environment": environment_settings(),
    }


def read_machine_file(folder: pathlib.Path) -> list[dict[str, Any]]:
    """The entries of ``folder/machine.yml``, oldest first; none for a folder without one.

    :raises ValueError: naming the file when it is not a YAML list of entries
    """
    path = folder / MACHINE_FILE
    if not path.is_file():
        return []
    try:
        entries = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as error:
        raise ValueError(f"{path} is not a YAML file: {type(error).__name__}") from None
    if not isinstance(entries, list) or not all(isinstance(entry, dict) for entry in entries):
        raise ValueError(f"{path} is not a list of machine entries")
    return entries


def record_machine(folder: pathlib.Path, step: int = 0) -> dict[str, Any]:
    """Append this machine's entry (:func:`machine_info`) to ``folder/machine.yml``,
    atomically; return the entry.

    :param folder: the run folder
    :param step: the step the training session starts at
    :raises OSError: naming the file when it cannot be written
    """
    from agents.training.files import write_atomically

    entry = machine_info(step)
    entries = [*read_machine_file(folder), entry]
    text = yaml.safe_dump(entries, sort_keys=False)
    write_atomically(folder / MACHINE_FILE, lambda file: file.write(text.encode()))
    return entry

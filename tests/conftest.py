"""Test-session setup: keep numba's on-disk kernel cache honest while the sources change.

numba keys a cached kernel on its own source file only. The step kernels of
``mobile_envs/robot_step.py`` compile the physics of ``kinematics.py`` and the geometry of
``path_geometry.py`` into themselves, so after an edit to either, their cache would still
hold the old physics and the tests would run stale code. Installed packages do not change
under their cache; a working tree does, so the cache is dropped here when it is older than
those sources.
"""

import importlib.util
import pathlib

_INLINED_SOURCES = ("kinematics.py", "path_geometry.py")


def _drop_stale_step_kernel_cache() -> None:
    package = pathlib.Path(importlib.util.find_spec("mobile_envs").submodule_search_locations[0])
    newest_source = max((package / name).stat().st_mtime for name in _INLINED_SOURCES)
    for cached in (package / "__pycache__").glob("robot_step.*.nb[ci]"):
        if cached.stat().st_mtime < newest_source:
            cached.unlink(missing_ok=True)


_drop_stale_step_kernel_cache()

"""Compiled kernels follow their sources: an edit to any module drops the stale caches on import.

The end-to-end tests run a copy of the package in fresh processes, as a user does between
edits, and check the env's step against the exact-arc odometry step of seed 000 (eq. 25).
The rest check the invalidation itself, and its cache directory against numba's own choice.
"""

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from numba.core import config as numba_config
from numba.core.caching import FunctionCache

import mobile_envs
from mobile_envs._kernels.kernel_cache import (
    STAMP_NAME,
    invalidate_stale_kernel_caches,
    kernel_cache_dir,
    sources_digest,
)

PACKAGE = Path(mobile_envs.__file__).parent
WHEEL_RADIUS, TRACK_WIDTH, MAX_WHEEL_SPEED, DT = 0.05, 1.0, 20.0, 0.1
START = (1.0, 2.0, 0.3)
# Actions 0.5 and 0.25 of the wheel-speed limit: exact in float32, so the env applies these.
WHEEL_SPEEDS = (10.0, 5.0)
# The diff-drive forward speed, v = r (w_R + w_L) / 2, in the model's kernel, and where it is.
DIFF_DRIVE_SPEED = "wheel_radius * (right + left)"
DIFF_DRIVE_SOURCE = Path("robots", "diff_drive.py")
# Where numba caches the step kernels, which inline that speed: the step module's directory
# (named as numba names it, ``<directory>_<hash>``) and the kernels' file prefix.
STEP_CACHE_GLOB, STEP_KERNELS = "sim_*", "step."

STEP_SCRIPT = f"""
import json

import numpy as np

import mobile_envs
from mobile_envs.envs.path_following import PathFollowingEnv

env = PathFollowingEnv(
    "diff_drive",
    "segments",
    model_params={{
        "wheel_radius": {WHEEL_RADIUS}, "track_width": {TRACK_WIDTH},
        "max_wheel_speed": {MAX_WHEEL_SPEED},
    }},
    dt={DT},
    integrator="exact",
)
env.reset(seed=0, options={{"start_pose": {START}}})
start_pose = env.pose
inputs = np.array({WHEEL_SPEEDS})
env.step(env.action_from_inputs(inputs))
model_pose = env.model.step(start_pose, inputs, {DT}, "exact")
result = {{
    "package": mobile_envs.__file__,
    "model": type(env.model).__name__,
    "start_pose": start_pose.tolist(),
    "env_pose": env.pose.tolist(),
    "model_pose": model_pose.tolist(),
}}
print("RESULT", json.dumps(result))
"""


def exact_arc_pose(start: list[float], speed_factor: float = 1.0) -> tuple[float, float, float]:
    """Seed 000 eq. 25: one step from ``start``, the forward speed scaled by ``speed_factor``."""
    right, left = WHEEL_SPEEDS
    v = speed_factor * WHEEL_RADIUS * (right + left) / 2.0
    omega = WHEEL_RADIUS * (right - left) / TRACK_WIDTH
    distance, turn = v * DT, omega * DT
    x, y, heading = start
    sinc = math.sin(turn / 2.0) / (turn / 2.0)
    return (
        x + distance * sinc * math.cos(heading + turn / 2.0),
        y + distance * sinc * math.sin(heading + turn / 2.0),
        heading + turn,
    )


def copy_package(destination: Path) -> Path:
    """A copy of the package's sources under ``destination``, without any compiled cache."""
    copy = destination / "mobile_envs"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    return copy


def double_diff_drive_speed(package: Path) -> None:
    model_source = package / DIFF_DRIVE_SOURCE
    source = model_source.read_text()
    assert source.count(DIFF_DRIVE_SPEED) == 1, (
        f"the test edits the diff-drive speed {DIFF_DRIVE_SPEED!r}, found "
        f"{source.count(DIFF_DRIVE_SPEED)} times in {DIFF_DRIVE_SOURCE}: update DIFF_DRIVE_SPEED"
    )
    model_source.write_text(source.replace(DIFF_DRIVE_SPEED, f"{DIFF_DRIVE_SPEED} * 2.0"))


def step_in_fresh_process(package: Path, **environment: str) -> tuple[dict, list[str]]:
    """Run STEP_SCRIPT on ``package``; its result and numba's cache log lines."""
    root = package.parent
    script = root / "step_once.py"
    script.write_text(STEP_SCRIPT)
    env = {**os.environ, "PYTHONPATH": str(root), "NUMBA_DEBUG_CACHE": "1", **environment}
    completed = subprocess.run(
        [sys.executable, str(script)],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert completed.returncode == 0, completed.stderr
    lines = completed.stdout.splitlines()
    result = json.loads(next(line for line in lines if line.startswith("RESULT "))[7:])
    assert result["package"] == str(package / "__init__.py"), "the copy was not the one run"
    assert result["model"] == "DifferentialDrive"
    return result, [line for line in lines if line.startswith("[cache]")]


def cache_files(directory: Path) -> dict[str, int]:
    return {path.name: path.stat().st_mtime_ns for path in directory.glob("*.nb[ic]")}


def test_env_follows_an_edit_to_the_physics_it_inlines(tmp_path):
    package = copy_package(tmp_path)
    cache_root = tmp_path / "numba_cache"
    first, _ = step_in_fresh_process(package, NUMBA_CACHE_DIR=str(cache_root))
    assert first["start_pose"] == pytest.approx(START)
    assert first["env_pose"] == pytest.approx(
        exact_arc_pose(first["start_pose"]), rel=1e-12, abs=1e-12
    )
    assert first["env_pose"] == first["model_pose"]

    (cache_dir,) = cache_root.glob(STEP_CACHE_GLOB)
    stamp = cache_dir / STAMP_NAME
    assert stamp.read_text() == sources_digest(str(package))
    kernels_after_compile = cache_files(cache_dir)
    assert any(name.startswith(STEP_KERNELS) for name in kernels_after_compile)
    stamp_written = stamp.stat().st_mtime_ns

    again, cache_log = step_in_fresh_process(package, NUMBA_CACHE_DIR=str(cache_root))
    assert again["env_pose"] == first["env_pose"]
    assert stamp.stat().st_mtime_ns == stamp_written
    assert cache_files(cache_dir) == kernels_after_compile, "unchanged sources lost kernels"
    assert any("data loaded" in line and STEP_KERNELS in line for line in cache_log)
    assert not any("data saved" in line for line in cache_log), "recompiled unchanged kernels"

    double_diff_drive_speed(package)
    edited, cache_log = step_in_fresh_process(package, NUMBA_CACHE_DIR=str(cache_root))
    assert edited["env_pose"] == edited["model_pose"]
    assert edited["env_pose"] == pytest.approx(
        exact_arc_pose(edited["start_pose"], 2.0), rel=1e-12, abs=1e-12
    )
    for axis in (0, 1):
        moved_before = first["env_pose"][axis] - first["start_pose"][axis]
        moved_now = edited["env_pose"][axis] - edited["start_pose"][axis]
        assert moved_now == pytest.approx(2.0 * moved_before, rel=1e-9)
    assert any("data saved" in line and STEP_KERNELS in line for line in cache_log)
    assert stamp.read_text() == sources_digest(str(package))


def test_read_only_install_uses_numbas_user_cache_and_still_follows_edits(tmp_path):
    package = copy_package(tmp_path)
    # A file where a directory should be blocks writing there for every user, root included.
    for source_dir in {source.parent for source in package.rglob("*.py")}:
        (source_dir / "__pycache__").write_text("")
    blocker = tmp_path / "not_a_directory"
    blocker.write_text("")
    home = tmp_path / "home"
    environment = {
        "NUMBA_CACHE_DIR": str(blocker / "numba_cache"),
        "XDG_CACHE_HOME": str(home / ".cache"),
        "HOME": str(home),
    }
    first, _ = step_in_fresh_process(package, **environment)
    assert first["env_pose"] == pytest.approx(
        exact_arc_pose(first["start_pose"]), rel=1e-12, abs=1e-12
    )
    (user_cache_dir,) = (home / ".cache" / "numba").glob(STEP_CACHE_GLOB)
    assert (user_cache_dir / STAMP_NAME).read_text() == sources_digest(str(package))
    assert any(name.startswith(STEP_KERNELS) for name in cache_files(user_cache_dir))

    double_diff_drive_speed(package)
    edited, _ = step_in_fresh_process(package, **environment)
    assert edited["env_pose"] == edited["model_pose"]
    assert edited["env_pose"] == pytest.approx(
        exact_arc_pose(edited["start_pose"], 2.0), rel=1e-12, abs=1e-12
    )


# ---------------------------------------------------------------- the invalidation itself


def fake_package(root: Path) -> Path:
    package = root / "pkg"
    (package / "sub").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "physics.py").write_text("SPEED = 1.0\n")
    (package / "sub" / "sensing.py").write_text("RANGE = 4.0\n")
    return package


def numba_cache_dir_for(source: Path) -> Path:
    """Where numba itself caches a function defined in ``source``."""
    namespace: dict = {}
    exec(compile("def kernel():\n    return 1\n", str(source), "exec"), namespace)
    return Path(FunctionCache(namespace["kernel"]).cache_path)


def test_cache_directory_is_the_one_numba_chooses(tmp_path, monkeypatch):
    package = fake_package(tmp_path)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    for source in (package / "physics.py", package / "sub" / "sensing.py"):
        monkeypatch.setattr(numba_config, "CACHE_DIR", "")
        assert kernel_cache_dir(str(source.parent)) == str(source.parent / "__pycache__")
        assert numba_cache_dir_for(source) == source.parent / "__pycache__"

        monkeypatch.setattr(numba_config, "CACHE_DIR", str(tmp_path / "numba_cache"))
        assert Path(kernel_cache_dir(str(source.parent))) == numba_cache_dir_for(source)
        assert numba_cache_dir_for(source).parent == tmp_path / "numba_cache"

        # Neither the configured directory nor __pycache__ usable: numba's per-user cache.
        monkeypatch.setattr(numba_config, "CACHE_DIR", str(package / "__init__.py" / "x"))
        shutil.rmtree(source.parent / "__pycache__")
        (source.parent / "__pycache__").write_text("")
        assert Path(kernel_cache_dir(str(source.parent))) == numba_cache_dir_for(source)
        assert numba_cache_dir_for(source).parent == tmp_path / "xdg" / "numba"


def test_digest_changes_with_every_source_edit_rename_and_addition(tmp_path):
    package = fake_package(tmp_path)
    seen = {sources_digest(str(package))}
    (package / "__pycache__").mkdir()
    (package / "__pycache__" / "physics.cpython-311.pyc").write_bytes(b"compiled")
    (package / "notes.txt").write_text("not a source")
    assert sources_digest(str(package)) in seen, "non-sources changed the digest"
    for change in (
        lambda: (package / "physics.py").write_text("SPEED = 2.0\n"),
        lambda: (package / "sub" / "sensing.py").write_text("RANGE = 5.0\n"),
        lambda: (package / "physics.py").rename(package / "dynamics.py"),
        lambda: (package / "sub" / "localization.py").write_text(""),
    ):
        change()
        digest = sources_digest(str(package))
        assert digest not in seen
        seen.add(digest)


def test_stale_kernels_are_deleted_once_and_current_ones_kept(tmp_path, monkeypatch):
    monkeypatch.setattr(numba_config, "CACHE_DIR", "")
    package = fake_package(tmp_path)
    cache_dir = package / "__pycache__"
    cache_dir.mkdir()
    kernels = ["physics.step-3.py311.nbi", "physics.step-3.py311.1.nbc"]
    # numba's half-written file of a process compiling right now, and a bytecode file.
    others = ["physics.step-3.py311.nbi.tmp.0123456789abcdef", "physics.cpython-311.pyc"]
    for name in kernels + others:
        (cache_dir / name).write_bytes(b"old")

    # Kernels without a stamp were built by an import that predates stamping: unknown sources.
    deleted = invalidate_stale_kernel_caches(str(package))
    assert sorted(Path(path).name for path in deleted) == sorted(kernels)
    assert sorted(path.name for path in cache_dir.iterdir()) == sorted([*others, STAMP_NAME])
    assert (cache_dir / STAMP_NAME).read_text() == sources_digest(str(package))
    assert (package / "sub" / "__pycache__" / STAMP_NAME).is_file()

    for name in kernels:
        (cache_dir / name).write_bytes(b"current")
    assert invalidate_stale_kernel_caches(str(package)) == []
    assert all((cache_dir / name).read_bytes() == b"current" for name in kernels)

    (package / "sub" / "sensing.py").write_text("RANGE = 5.0\n")
    assert len(invalidate_stale_kernel_caches(str(package))) == len(kernels)
    assert (cache_dir / STAMP_NAME).read_text() == sources_digest(str(package))


def test_a_kernel_that_cannot_be_deleted_keeps_the_old_stamp(tmp_path, monkeypatch):
    monkeypatch.setattr(numba_config, "CACHE_DIR", "")
    package = fake_package(tmp_path)
    invalidate_stale_kernel_caches(str(package))
    stamp = package / "__pycache__" / STAMP_NAME
    old_stamp = stamp.read_text()
    kernel = package / "__pycache__" / "physics.step-3.py311.nbi"
    kernel.write_bytes(b"old")
    (package / "physics.py").write_text("SPEED = 2.0\n")

    def locked(path):
        raise PermissionError(13, "in use by another process", path)

    with monkeypatch.context() as patch:
        patch.setattr(os, "remove", locked)
        assert invalidate_stale_kernel_caches(str(package)) == []
    assert stamp.read_text() == old_stamp, "stamped current while a stale kernel remained"
    assert invalidate_stale_kernel_caches(str(package)) == [str(kernel)]
    assert stamp.read_text() == sources_digest(str(package))


def test_concurrent_imports_agree_and_leave_no_temporary_files(tmp_path):
    package = copy_package(tmp_path)
    cache_dir = package / "__pycache__"
    cache_dir.mkdir()
    (cache_dir / "robot_step.step-9.py311.nbi").write_bytes(b"stale")
    environment = {**os.environ, "PYTHONPATH": str(tmp_path), "NUMBA_CACHE_DIR": ""}
    importers = [
        subprocess.Popen(
            [sys.executable, "-c", "import mobile_envs"],
            cwd=tmp_path,
            env=environment,
            stderr=subprocess.PIPE,
            text=True,
        )
        for _ in range(6)
    ]
    for importer in importers:
        _, errors = importer.communicate(timeout=120)
        assert importer.returncode == 0, errors
    assert not (cache_dir / "robot_step.step-9.py311.nbi").exists()
    assert [path.name for path in cache_dir.iterdir() if ".tmp." in path.name] == []
    assert (cache_dir / STAMP_NAME).read_text() == sources_digest(str(package))


def test_kernels_cached_says_whether_the_step_kernels_cache_holds_an_index(tmp_path, monkeypatch):
    import mobile_envs._kernels.kernel_cache as kernel_cache

    monkeypatch.setattr(kernel_cache, "_configured_numba_cache_dir", lambda: "")
    (tmp_path / "sim").mkdir()
    assert not kernel_cache.kernels_cached(str(tmp_path))  # no cache folder yet
    cache = tmp_path / "sim" / "__pycache__"
    (cache / STAMP_NAME).write_text("digest")
    assert not kernel_cache.kernels_cached(str(tmp_path))  # a stamp but no kernel
    (cache / "step.move_robots-176.py311.nbi").write_bytes(b"")
    assert kernel_cache.kernels_cached(str(tmp_path))

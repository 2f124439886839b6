"""The step kernels split over threads give every robot the bits of the serial path."""

import importlib.metadata
import os
import subprocess
import sys

import gymnasium as gym
import numba
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import mobile_envs  # noqa: F401  (registers the ids)
from mobile_envs.sim.config import available_threads, make_core_config
from mobile_envs.sim.step import _chunk

ENV_IDS = sorted(env_id for env_id in gym.registry if env_id.startswith("mobile_envs/"))
THREADS = available_threads()
needs_two_threads = pytest.mark.skipif(
    THREADS < 2, reason="numba has one thread here (NUMBA_NUM_THREADS), nothing runs in parallel"
)


def _as_bytes(value):
    """Exact bytes of an info value (so -0.0 and 0.0 differ), recursing into dicts."""
    if isinstance(value, dict):
        return {key: _as_bytes(item) for key, item in value.items()}
    array = np.asarray(value)
    if array.dtype == object:
        return [None if item is None else np.asarray(item).tobytes() for item in array]
    return (array.dtype.str, array.shape, array.tobytes())


def vector_run(env_id, num_threads, num_envs=7, steps=60, seed=11, **kwargs):
    """Every output of ``steps`` random steps of a vector env, as exact bytes."""
    envs = gym.make_vec(env_id, num_envs=num_envs, num_threads=num_threads, **kwargs)
    observations, infos = envs.reset(seed=seed)
    record = [observations.tobytes(), _as_bytes(infos)]
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        actions = rng.uniform(-1, 1, envs.action_space.shape).astype(np.float32)
        actions[:, 0] = np.abs(actions[:, 0])  # mostly forward, so episodes end by the goal too
        observations, rewards, terminated, truncated, infos = envs.step(actions)
        record += [observations.tobytes(), rewards.tobytes(), terminated.tobytes()]
        record += [truncated.tobytes(), _as_bytes(infos)]
    envs.close()
    return record


@needs_two_threads
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_parallel_vector_env_equals_the_serial_one_bit_for_bit(env_id):
    # 7 robots: the two chunks differ in size; step_limit=20 makes autoresets certain.
    serial = vector_run(env_id, 1, step_limit=20)
    assert vector_run(env_id, 2, step_limit=20) == serial


@needs_two_threads
@pytest.mark.parametrize("autoreset_mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_parallel_equals_serial_on_a_large_batch_in_every_autoreset_mode(autoreset_mode):
    # 512 robots (where two threads start to pay) in a maze: chunks of 256, many resets.
    env_id = "mobile_envs/Bicycle-Maze-v0"
    kwargs = {"num_envs": 512, "steps": 30, "autoreset_mode": autoreset_mode}
    assert vector_run(env_id, THREADS, **kwargs) == vector_run(env_id, 1, **kwargs)


@needs_two_threads
@pytest.mark.parametrize(
    "env_id", ["mobile_envs/DiffDrive-Segments-v0", "mobile_envs/Tricycle-Maze-v0"]
)
def test_single_env_with_threads_equals_the_serial_one(env_id):
    results = []
    for num_threads in (1, 2):
        env = gym.make(env_id, num_threads=num_threads)
        observation, _ = env.reset(seed=4)
        record = [observation.tobytes()]
        rng = np.random.default_rng(4)
        for _ in range(80):
            action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            observation, reward, terminated, truncated, info = env.step(action)
            record += [observation.tobytes(), reward, terminated, truncated, _as_bytes(info)]
            if terminated or truncated:
                observation, _ = env.reset()
                record.append(observation.tobytes())
        results.append(record)
    assert results[0] == results[1]


@needs_two_threads
def test_a_step_leaves_the_callers_numba_thread_count_as_it_was():
    envs = gym.make_vec("mobile_envs/DiffDrive-Segments-v0", num_envs=8, num_threads=2)
    envs.reset(seed=0)
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        envs.step(np.zeros((8, 2), np.float32))
        assert numba.get_num_threads() == 1
    finally:
        numba.set_num_threads(previous)


@pytest.mark.parametrize(("count", "chunks"), [(0, 2), (1, 2), (7, 2), (8, 3), (1024, 16)])
def test_chunks_cover_every_robot_once_in_order(count, chunks):
    covered = []
    for chunk in range(chunks):
        first, stop = _chunk(chunk, chunks, count)
        covered += range(first, stop)
    assert covered == list(range(count))


def test_one_thread_by_default_and_numpy_integers_are_accepted():
    assert make_core_config("diff_drive", "segments").num_threads == 1
    envs = gym.make_vec("mobile_envs/DiffDrive-Segments-v0", num_envs=2048)
    assert envs.core.num_threads == 1
    assert make_core_config(
        "diff_drive", "segments", num_threads=np.int64(THREADS)
    ).num_threads == (THREADS)


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "2", None, THREADS + 1])
def test_num_threads_is_validated_naming_it(bad):
    with pytest.raises(ValueError, match="num_threads"):
        gym.make("mobile_envs/DiffDrive-Segments-v0", num_threads=bad)
    with pytest.raises(ValueError, match="num_threads"):
        gym.make_vec("mobile_envs/DiffDrive-Segments-v0", num_envs=2, num_threads=bad)


_THREAD_START_SCRIPT = """
import gymnasium as gym, numba, numpy as np
import mobile_envs
from numba.np.ufunc import parallel
serial = gym.make_vec("mobile_envs/DiffDrive-Segments-v0", num_envs=600)
serial.reset(seed=0)
serial.step(np.zeros((600, 2), np.float32))
print(parallel._is_initialized)
threaded = gym.make_vec("mobile_envs/DiffDrive-Segments-v0", num_envs=8, num_threads=2)
threaded.reset(seed=0)
threaded.step(np.zeros((8, 2), np.float32))
print(numba.threading_layer())
"""


@needs_two_threads
@pytest.mark.skipif(
    "NUMBA_THREADING_LAYER" in os.environ, reason="the user's NUMBA_THREADING_LAYER wins"
)
def test_one_thread_starts_no_numba_threads_and_more_use_tbb_or_the_workqueue():
    # numba's OpenMP layer loads the system's libgomp beside torch's, which slowed torch in
    # the same process 80-fold: the serial path must start no threading layer at all, and
    # the parallel one must take TBB where the parallel extra installed it, else the
    # workqueue, never OpenMP. A fresh process: this one's numba has started.
    try:
        importlib.metadata.version("tbb")
        expected = "tbb"
    except importlib.metadata.PackageNotFoundError:
        expected = "workqueue"
    result = subprocess.run(
        [sys.executable, "-c", _THREAD_START_SCRIPT], capture_output=True, text=True, check=True
    )
    assert result.stdout.split() == ["False", expected]

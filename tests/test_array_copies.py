"""Array copies in compiled code, and what the first run compiles.

:func:`~mobile_envs._kernels.array_copies.copy_rows` is checked against numpy's slice
assignment. The kernels a training env calls before its first step are checked, compiled afresh
in a new process (an empty numba cache), to compile none of numba's slice-assignment error
formatting (string code that took seconds to compile) and no kernel twice, once for a
literal argument and once for its type (numba compiles a callee for a constant it sees
before the loop's int64, then again).
"""

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from mobile_envs._kernels.array_copies import copy_rows


@pytest.mark.parametrize("dtype", [np.float64, np.int64, np.bool_])
@pytest.mark.parametrize("first", [0, 3])
def test_copy_rows_equals_numpys_slice_assignment(dtype: type, first: int) -> None:
    rng = np.random.default_rng(first)
    source = (rng.normal(size=(5, 3)) * 10).astype(dtype)
    target = np.zeros((10, 3), dtype=dtype)
    expected = target.copy()
    expected[first : first + 5] = source
    copy_rows(source, target, first)
    np.testing.assert_array_equal(target, expected)


def test_copy_rows_writes_into_a_view_of_a_larger_array() -> None:
    grids = np.zeros((2, 3, 4), dtype=np.bool_)
    grid = np.arange(12).reshape(3, 4) % 3 == 0
    copy_rows(grid, grids[1], 0)
    np.testing.assert_array_equal(grids[1], grid)
    assert not grids[0].any()


FIRST_RUN_SCRIPT = """
import json

import gymnasium as gym
import numpy as np
from numba.core import event

import mobile_envs  # noqa: F401

compiled = []


class Listener(event.Listener):
    def on_start(self, ev):
        dispatcher = ev.data["dispatcher"]
        compiled.append(
            [dispatcher.py_func.__module__, dispatcher.py_func.__qualname__, str(ev.data["args"])]
        )

    def on_end(self, ev):
        pass


event.register("numba:compile", Listener())
envs = gym.make_vec("mobile_envs/DiffDrive-Random-v0", num_envs=16)
envs.reset(seed=0)
actions = np.random.default_rng(0).uniform(-1, 1, size=(3, *envs.action_space.shape))
for action in actions.astype(np.float32):
    envs.step(action)
print(json.dumps(compiled))
"""


def test_a_training_envs_first_steps_compile_no_error_formatting_and_no_literal_twins(
    tmp_path,
) -> None:
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    done = subprocess.run(
        [sys.executable, "-c", FIRST_RUN_SCRIPT],
        env=environment,
        capture_output=True,
        text=True,
        check=True,
    )
    compiled = json.loads(done.stdout.splitlines()[-1])
    ours = [entry for entry in compiled if entry[0].startswith("mobile_envs")]
    assert len(ours) > 20, "the env compiled fewer kernels than it calls: was the cache empty?"
    formatting = [entry for entry in compiled if "raise_with_shape_context" in entry[1]]
    assert formatting == [], "a kernel assigns an array slice from an array: use copy_rows"
    seen: dict[tuple[str, str, str], str] = {}
    for module, name, arguments in ours:
        key = (module, name, unliteral(arguments))
        assert key not in seen, f"{name} compiled for {arguments} and {seen[key]}"
        seen[key] = arguments


def unliteral(arguments: str) -> str:
    """numba's argument types with each literal constant replaced by its type."""
    arguments = re.sub(r"Literal\[int\]\(-?\d+\)", "int64", arguments)
    return re.sub(r"Literal\[bool\]\((True|False)\)", "bool", arguments)

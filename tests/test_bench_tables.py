"""The README's speed table as bench_vector.py prints it from its measurements."""

from __future__ import annotations

import importlib.util
import math
import pathlib
from types import ModuleType

import pytest

BENCHMARKS = pathlib.Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture(scope="module")
def bench_vector() -> ModuleType:
    spec = importlib.util.spec_from_file_location("bench_vector", BENCHMARKS / "bench_vector.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_markdown_table_has_a_line_per_env_and_count_with_the_faster_threads_ratios(
    bench_vector: ModuleType,
) -> None:
    course, maze = "mobile_envs/DiffDrive-Segments-v0", "mobile_envs/Bicycle-Maze-v0"
    rows = [
        (course, 1, 1, 61_000.0, 15_000.0, 3_000.0),
        (course, 1, 2, 25_000.0, 15_000.0, 3_000.0),
        (course, 1024, 1, 2_900_000.0, 50_000.0, 6_400_000.0),
        (course, 1024, 2, 3_200_000.0, 50_000.0, 6_400_000.0),
        (maze, 1024, 1, 1_000_000.0, math.nan, 6_400_000.0),
        (maze, 1024, 2, 1_600_000.0, math.nan, 6_400_000.0),
    ]
    lines = bench_vector.markdown_table(rows, 2, 0.75).splitlines()
    assert lines[0] == (
        "2 cores, load average 0.75 at the start; gymnax Pendulum-v1 (JAX CPU): "
        "3,000 at N = 1, 6,400,000 at N = 1024 steps/s."
    )
    assert lines[2] == "| env | N | 1 thread | 2 threads | x SyncVectorEnv | x gymnax |"
    assert lines[4:] == [
        "| DiffDrive-Segments-v0 | 1 | 61,000 | 25,000 | 4.1x | 20.33x |",  # one thread faster
        "| DiffDrive-Segments-v0 | 1024 | 2.90M | 3.20M | 64.0x | 0.50x |",
        "| Bicycle-Maze-v0 | 1024 | 1.00M | 1.60M | - | 0.25x |",  # no SyncVectorEnv run
    ]


def test_markdown_table_without_gymnax_says_so(bench_vector: ModuleType) -> None:
    rows = [("mobile_envs/DiffDrive-Random-v0", 64, 1, 500_000.0, 40_000.0, math.nan)]
    lines = bench_vector.markdown_table(rows, 16, 1.0).splitlines()
    assert lines[0] == "16 cores, load average 1.00 at the start; gymnax Pendulum-v1 not measured."
    assert lines[-1] == "| DiffDrive-Random-v0 | 64 | 500,000 | 12.5x | - |"

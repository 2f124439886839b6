"""The grid's Ray backend on a real two-node cluster: a run whose worker is killed mid-training
is retried, and the grid's numbers equal a local run of the same seeds bit for bit.

Needs a running cluster of at least two nodes: ``bash .ci/run`` starts one on 127.0.0.1
(``ray start --head`` and a second ``ray start --address``) and sets RAY_ADDRESS.
"""

import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

pytest.importorskip("yaml", reason="the grid reads YAML (the train extra)")

import yaml

pytest.importorskip("ray", reason="the Ray backend needs the ray extra")
pytest.importorskip("stable_baselines3", reason="training needs the train extra")

import ray
from tiny_runs import TINY_PPO, grid_flags, same_numbers

from agents.grid.grid import main

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def cluster():
    address = os.environ.get("RAY_ADDRESS")
    if not address:
        if os.environ.get("CI"):
            pytest.fail("RAY_ADDRESS is not set: .ci/run starts the cluster these tests need")
        pytest.skip("needs a Ray cluster of two nodes: set RAY_ADDRESS (bash .ci/run starts one)")
    ray.init(address=address, log_to_driver=False)
    alive = [node for node in ray.nodes() if node["Alive"]]
    ray.shutdown()
    assert len(alive) >= 2, f"the cluster at {address} has {len(alive)} node(s), not 2"
    return address


def test_a_grid_on_two_nodes_retries_a_killed_run_and_matches_a_local_grid(cluster, tmp_path):
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump(TINY_PPO))
    local = tmp_path / "local"
    assert main(grid_flags(local, hyperparams, "--workers", "2")) == 0

    on_ray = tmp_path / "ray"
    command = [
        sys.executable,
        "train.py",
        "grid",
        *grid_flags(on_ray, hyperparams, "--backend", "ray", "--address", cluster),
    ]
    grid = subprocess.Popen(
        command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    attempts = on_ray / "runs" / "DiffDrive-Random-v0_ppo_seed0" / "attempts.log"
    deadline = time.monotonic() + 180
    while not attempts.is_file() or not attempts.read_text().strip():
        assert grid.poll() is None, grid.stdout.read()
        assert time.monotonic() < deadline, "the run never started on the cluster"
        time.sleep(0.05)
    first_pid = int(attempts.read_text().split()[-1])
    os.kill(first_pid, signal.SIGKILL)  # the Ray worker process running the training

    log, _ = grid.communicate(timeout=300)
    assert grid.returncode == 0, log
    pids = [int(line.split()[-1]) for line in attempts.read_text().splitlines()]
    assert len(pids) == 2 and pids[0] == first_pid != pids[1], "retried once, in a new worker"

    local_runs = json.loads((local / "grid.json").read_text())["runs"]
    ray_runs = json.loads((on_ray / "grid.json").read_text())["runs"]
    assert [run["run"] for run in ray_runs] == [run["run"] for run in local_runs]
    for ray_run, local_run in zip(ray_runs, local_runs, strict=True):
        same_numbers(ray_run["results"], local_run["results"])
    assert (on_ray / "grid.md").read_text() == (local / "grid.md").read_text()


def grid_without_a_cluster(tmp_path, address, *extra):
    """``train.py grid --backend ray`` at ``address``: (its result, the seconds it took)."""
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump(TINY_PPO))
    flags = grid_flags(tmp_path / "out", hyperparams, "--backend", "ray", "--address", address)
    command = [sys.executable, "train.py", "grid", *flags, *extra]
    start = time.monotonic()
    result = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=300)
    return result, time.monotonic() - start


def assert_one_error_line(result, *named):
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    (line,) = result.stderr.strip().splitlines()
    for text in named:
        assert text in line, (text, line)


def test_no_cluster_at_a_closed_port_is_one_line_at_once(tmp_path):
    """Issue 30: --address 127.0.0.1:1 was still retrying after 300 s."""
    result, _ = grid_without_a_cluster(tmp_path, "127.0.0.1:1")
    assert_one_error_line(result, "--address 127.0.0.1:1", "no Ray cluster there")
    assert not (tmp_path / "out" / "runs").exists()


def test_a_port_that_does_not_answer_as_a_cluster_is_given_up_after_the_timeout(tmp_path):
    import socket

    with socket.socket() as listener:  # accepts connections, says nothing
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        address = f"127.0.0.1:{listener.getsockname()[1]}"
        result, seconds = grid_without_a_cluster(tmp_path, address, "--ray-timeout", "3")
    assert_one_error_line(result, f"--address {address}", "within 3 s", "--ray-timeout")
    assert seconds < 90  # the start-up and 3 s, not Ray's minutes of retries

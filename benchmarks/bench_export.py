"""Inference time per action, batch 1, one core: onnxruntime on the exported actor vs SB3.

    python benchmarks/bench_export.py [--model models/diffdrive_ppo.zip ...] [--calls 5000]

For each model: export its deterministic actor (agents.training.export), then time one action for
one observation, ``--calls`` times after a warm-up, with
- onnxruntime, ``intra_op_num_threads=1`` and ``inter_op_num_threads=1``;
- SB3 ``model.predict(observation, deterministic=True)`` with ``torch.set_num_threads(1)``;
- the same torch module the export traced (:class:`agents.training.export.DeterministicActor`) under
  ``torch.inference_mode``, which is what is left of SB3's cost without its numpy plumbing.
The observations are real ones: the env's, with the policy driving. Prints the median and the
90th percentile in microseconds, and the largest difference between the ONNX and SB3 actions.
"""

from __future__ import annotations

import argparse
import pathlib
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DEFAULT_MODELS = [ROOT / "models" / "diffdrive_ppo.zip", ROOT / "models" / "bicycle_ppo.zip"]


def observations_of(model: Any, count: int) -> np.ndarray:
    """``count`` observations of the env the policy was trained on, the policy driving."""
    from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv

    env = PathFollowingSB3VecEnv(trained_on(model), 8, seed=123)
    rows: list[Any] = [env.reset()]
    while len(rows) * 8 < count:
        actions, _ = model.predict(rows[-1], deterministic=True)
        rows.append(env.step(actions)[0])
    env.close()
    return np.concatenate(rows)[:count].astype(np.float32)


def trained_on(model: Any) -> str:
    """The env id the policy recorded (train.py records it), DiffDrive-Random otherwise."""
    return str(getattr(model, "trained_on", None) or "mobile_envs/DiffDrive-Random-v0")


def time_calls(act: Callable[[np.ndarray], object], observations: np.ndarray) -> list[float]:
    """Seconds of each call of ``act`` on one observation (batch 1), after 200 warm-up calls."""
    for row in observations[:200]:
        act(row)
    times = []
    for row in observations:
        start = time.perf_counter()
        act(row)
        times.append(time.perf_counter() - start)
    return times


def describe(name: str, times: list[float]) -> str:
    median = statistics.median(times) * 1e6
    p90 = statistics.quantiles(times, n=10)[-1] * 1e6
    return f"  {name:<28} median {median:8.1f} us   p90 {p90:8.1f} us"


def measure(path: pathlib.Path, calls: int) -> None:
    import onnxruntime
    import torch

    from agents.harness.policies import load_policy, model_algorithm
    from agents.training.export import INPUT_NAME, OUTPUT_NAME, DeterministicActor, export_onnx

    model = load_policy(path)
    observations = observations_of(model, calls)
    with tempfile.TemporaryDirectory() as folder:
        graph = export_onnx(model, pathlib.Path(folder) / "policy.onnx")
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        session = onnxruntime.InferenceSession(
            str(graph), options, providers=["CPUExecutionProvider"]
        )
    actor = DeterministicActor(model)

    def run_onnx(row: np.ndarray) -> object:
        return session.run([OUTPUT_NAME], {INPUT_NAME: row[None]})[0]

    def run_sb3(row: np.ndarray) -> object:
        return model.predict(row, deterministic=True)[0]

    def run_torch(row: np.ndarray) -> object:
        with torch.inference_mode():
            return actor(torch.from_numpy(row[None]))

    batch_onnx = session.run([OUTPUT_NAME], {INPUT_NAME: observations})[0]
    batch_sb3, _ = model.predict(observations, deterministic=True)
    print(
        f"{path.name} ({model_algorithm(path)}, trained on {trained_on(model)}): "
        f"{calls} calls, "
        f"batch 1; max |onnx - predict| {np.max(np.abs(batch_onnx - batch_sb3)):.2e}"
    )
    print(describe("onnxruntime, 1 thread", time_calls(run_onnx, observations)))
    print(describe("SB3 predict, 1 thread", time_calls(run_sb3, observations)))
    print(describe("torch actor, 1 thread", time_calls(run_torch, observations)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", nargs="+", type=pathlib.Path, default=DEFAULT_MODELS)
    parser.add_argument("--calls", type=int, default=5000, help="timed calls per runtime")
    args = parser.parse_args()
    import onnxruntime
    import torch

    torch.set_num_threads(1)
    print(f"torch {torch.__version__}, onnxruntime {onnxruntime.__version__}")
    for path in args.model:
        measure(path, args.calls)


if __name__ == "__main__":
    main()

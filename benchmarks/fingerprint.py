"""Behaviour fingerprint: hashes of trajectories, to show a refactor changes nothing.

    python benchmarks/fingerprint.py OUT.json [--reference benchmarks/fingerprint_reference.json]
                                              [--threads 2]

For every registered id: 400 steps of seeded random actions through ``gym.make`` (with
resets), and 300 steps of a vector env of 6 robots; for two ids, 400 steps of the SB3
adapter; 3-episode evaluations of the classical agents and of the shipped PPO policies.
Each entry is a hash of every observation, reward, flag and info value, bit for bit. With
``--reference``, every entry the reference holds must be identical (ids added since are
listed, not compared); the exit status says whether they are. ``--threads N`` makes every
env with ``num_threads=N``, so the step kernels split the robots over N threads: the
fingerprint must not change (compare it with a serial one as ``--reference``).

``benchmarks/fingerprint_reference.json`` holds every registered id's entries. The env
entries have been identical since the core's redesign; the ``ppo`` entries come from the
batched harness, whose policies predict for all robots in one batch (a batch sums each
layer's products in another order than a single row does, so the actions differ in the last
float32 bits; git's log of the reference file says when each entry last changed and why).
The ``ppo`` entries also depend on the CPU: torch's float32 kernels differ between an AMD
EPYC (where the reference was made) and an Intel Xeon with AVX-512 and AMX, where 4 of the
``ppo`` entries differ and every other entry is identical. Compare ``ppo`` entries only with
a reference made on the same kind of CPU.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import pathlib
import sys
from typing import Any

import gymnasium as gym
import numpy as np

import mobile_envs  # noqa: F401  (registers the ids)


def _add_info(digest: Any, info: dict[str, Any]) -> None:
    for key in sorted(info):
        value = info[key]
        digest.update(key.encode())
        as_array = 0 if isinstance(value, dict) else np.asarray(value, dtype=np.float64)
        digest.update(np.ascontiguousarray(as_array).tobytes())


def _digest_of_reset(env: Any, seed: int) -> Any:
    """A sha256 digest fed the observation and info of ``env.reset(seed=seed)`` (one env's
    or a vector env's)."""
    digest = hashlib.sha256()
    observation, info = env.reset(seed=seed)
    digest.update(observation.tobytes())
    _add_info(digest, info)
    return digest


def _random_actions(rng: np.random.Generator, space: Any) -> np.ndarray:
    """float32 actions uniform in [-1, 1] of the shape of ``space``, drawn from ``rng``."""
    return rng.uniform(-1, 1, space.shape).astype(np.float32)


def single_env_hash(env_id: str, rng: np.random.Generator, threads: int) -> str:
    env = gym.make(env_id, num_threads=threads)
    digest = _digest_of_reset(env, 3)
    for _ in range(400):
        action = _random_actions(rng, env.action_space)
        observation, reward, terminated, truncated, info = env.step(action)
        digest.update(observation.tobytes())
        digest.update(np.float64(reward).tobytes())
        digest.update(bytes([terminated, truncated]))
        _add_info(digest, info)
        if terminated or truncated:
            observation, info = env.reset()
            digest.update(observation.tobytes())
    return digest.hexdigest()[:16]


def vector_env_hash(env_id: str, rng: np.random.Generator, threads: int) -> str:
    envs = gym.make_vec(env_id, num_envs=6, num_threads=threads)
    digest = _digest_of_reset(envs, 5)
    for _ in range(300):
        actions = _random_actions(rng, envs.action_space)
        observations, rewards, terminated, truncated, infos = envs.step(actions)
        for array in (observations, rewards, terminated, truncated):
            digest.update(array.tobytes())
        _add_info(digest, infos)
    return digest.hexdigest()[:16]


def sb3_hash(env_id: str, threads: int) -> str:
    from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv

    adapter = PathFollowingSB3VecEnv(env_id, num_envs=5, seed=2, num_threads=threads)
    rng = np.random.default_rng(4)
    digest = hashlib.sha256()
    digest.update(np.asarray(adapter.reset()).tobytes())
    width = adapter.action_space.shape[0]  # type: ignore[index]
    for _ in range(400):
        actions = rng.uniform(-1, 1, (5, width)).astype(np.float32)
        observations, rewards, dones, infos = adapter.step(actions)
        for array in (observations, rewards, dones):
            digest.update(np.asarray(array).tobytes())
        for info in infos:
            _add_info(digest, info)
    return digest.hexdigest()[:16]


def agent_summaries(threads: int) -> dict[str, str]:
    from agents import PurePursuit, RegulatedPurePursuit, TricycleGuidance, evaluate
    from agents.harness.policies import load_policy

    noise = (0.2, 0.3)
    runs: list[tuple[str, Any, str]] = [
        ("PurePursuit", PurePursuit(), "DiffDrive-SharpSegments-v0"),
        ("RegulatedPurePursuit", RegulatedPurePursuit(), "Bicycle-Maze-v0"),
        ("TricycleGuidance", TricycleGuidance.for_comparison(), "Tricycle-ArcStraight-v0"),
        ("RegulatedPurePursuit", RegulatedPurePursuit(), "ConstantVelocity-Segments-v0"),
    ]
    summaries = {}
    for name, agent, env_name in runs:
        env_id = f"mobile_envs/{env_name}"
        result = evaluate(agent, env_id, episodes=3, start_noise=noise, num_threads=threads)
        summaries[f"agent {name} {env_id}"] = json.dumps(
            result.summary, sort_keys=True, default=float
        )
    models = pathlib.Path(__file__).resolve().parent.parent / "models"
    for model, env_id in [
        ("constant_velocity_ppo.zip", "mobile_envs/ConstantVelocity-Lines-v0"),
        ("diffdrive_ppo.zip", "mobile_envs/DiffDrive-Maze-v0"),
        ("bicycle_ppo.zip", "mobile_envs/Bicycle-SharpSegments-v0"),
        ("tricycle_ppo.zip", "mobile_envs/Tricycle-Segments-v0"),
    ]:
        policy = load_policy(models / model)
        result = evaluate(policy, env_id, episodes=3, start_noise=noise, num_threads=threads)
        summaries[f"ppo {env_id}"] = json.dumps(result.summary, sort_keys=True, default=float)
    return summaries


def fingerprint(threads: int = 1) -> dict[str, str]:
    """Every entry's hash, the envs made with ``num_threads=threads``."""
    ids = sorted(env_id for env_id in gym.registry if env_id.startswith("mobile_envs/"))
    entries = {}
    for env_id in ids:
        rng = np.random.default_rng(1)  # the vector run goes on drawing where the single stops
        entries[f"single {env_id}"] = single_env_hash(env_id, rng, threads)
        entries[f"vector {env_id}"] = vector_env_hash(env_id, rng, threads)
    for env_id in ("mobile_envs/DiffDrive-Random-v0", "mobile_envs/Tricycle-Maze-v0"):
        entries[f"sb3 {env_id}"] = sb3_hash(env_id, threads)
    entries.update(agent_summaries(threads))
    return entries


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", type=pathlib.Path, help="where to write the fingerprint")
    parser.add_argument("--reference", type=pathlib.Path, help="a fingerprint to compare with")
    parser.add_argument(
        "--threads", type=int, default=1, help="num_threads for every env (default 1)"
    )
    args = parser.parse_args()
    if args.threads < 1:
        parser.error(f"--threads must be a positive integer, got {args.threads}")
    entries = fingerprint(args.threads)
    args.output.write_text(json.dumps(entries, indent=1, sort_keys=True) + "\n")
    print(f"{len(entries)} entries written to {args.output}")
    if args.reference is None:
        return 0
    reference = json.loads(args.reference.read_text())
    changed = sorted(key for key in reference if entries.get(key) != reference[key])
    added = sorted(set(entries) - set(reference))
    print(f"{len(reference) - len(changed)} of {len(reference)} reference entries identical")
    for key in changed:
        print(f"  changed: {key}")
    print(f"{len(added)} entries the reference does not hold (ids added since)")
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main())

"""Vector env speed against gymnax's Pendulum-v1, PPO training speed and memory per robot.

    python benchmarks/bench_vector.py [--quick] [--threads 1,2] [--no-gymnax] [--no-ppo]
        [--markdown]

For each id of :data:`ENV_IDS` (the course envs and the ``*-Random-v0`` training envs) at
N = 1, 64, 1024 and 8192 robots, the native batched vector env (``gym.make_vec``, the ids'
vector_entry_point) runs with each ``num_threads`` of ``--threads``, best of 3 runs (these
machines are noisy), beside Gymnasium's SyncVectorEnv over N single envs where N is small
enough. Each step is the full step: kinematics, projection, observation, reward, infos and
autoreset, with random actions drawn in advance.

In the same run, gymnax's ``Pendulum-v1`` (the ``bench`` extra: gymnax and jax) runs on
JAX's CPU backend the way its users run it: ``jit`` of a ``lax.scan`` over steps of a
``vmap`` over N envs, random actions drawn inside the scan, autoreset included (gymnax's
``step``), at least 1000 steps a scan, compile time excluded, ``block_until_ready``, best
of 3. Every row prints its ratio to it at the same N. Without gymnax installed
(``pip install -e .[bench]``) that column is NaN and the rest still runs.

Then PPO (SB3, one torch thread) trains on ``DiffDrive-Random-v0`` with 16, 64 and 256
robots (``n_steps`` so that a rollout is 4096 steps), reporting steps/s and the share of the
time spent inside the env (``step_wait`` and ``reset``), and the memory each robot costs is
measured with tracemalloc. The load average is printed first: with two cores shared,
parallel figures depend on what else runs. With ``--markdown`` the vector-env figures are
printed again at the end as the markdown table the README's *Speed* section holds, headed
by the machine's core count and load.
"""

from __future__ import annotations

import argparse
import math
import os
import time
import tracemalloc
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

import mobile_envs  # noqa: F401  (registers the ids)

ENV_IDS = (
    "mobile_envs/DiffDrive-Segments-v0",
    "mobile_envs/DiffDrive-Random-v0",
    "mobile_envs/Bicycle-Maze-v0",
    "mobile_envs/Bicycle-Random-v0",
)
ROBOT_COUNTS = (1, 64, 1024, 8192)
#: PPO's robot counts; each rollout holds this many steps in all.
PPO_ROBOT_COUNTS = (16, 64, 256)
PPO_ROLLOUT = 4096


def robot_steps_per_second(envs: gym.vector.VectorEnv, robot_steps: int) -> float:
    """Time ``robot_steps`` robot-steps (at least 5 vector steps) of random actions, from a
    reset with seed 0."""
    count = envs.num_envs
    steps = min(20_000, max(5, robot_steps // count))  # N = 1 needs no million steps
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (16, count, *(envs.single_action_space.shape or ()))).astype(
        np.float32
    )
    envs.reset(seed=0)
    envs.step(actions[0])  # warm up
    start = time.perf_counter()
    for step in range(steps):
        envs.step(actions[step % 16])
    return steps * count / (time.perf_counter() - start)


def gymnax_pendulum(robot_steps: int) -> Callable[[int], float] | None:
    """A function of N giving gymnax Pendulum-v1's best-of-3 steps/s on JAX's CPU backend,
    or None when gymnax is not installed (``pip install -e .[bench]``)."""
    os.environ.setdefault("JAX_PLATFORMS", "cpu")
    try:
        import gymnax
        import jax
    except ImportError:
        return None
    env, params = gymnax.make("Pendulum-v1")

    def rate(count: int) -> float:
        # At least 1000 steps a scan: shorter ones measure the dispatch, not the env.
        steps = min(20_000, max(1_000, robot_steps // count))

        def rollout(key: Any) -> Any:
            reset_key, step_key = jax.random.split(key)
            reset_keys = jax.random.split(reset_key, count)
            _, state = jax.vmap(env.reset, in_axes=(0, None))(reset_keys, params)

            def one_step(carry: Any, _: Any) -> Any:
                state, key = carry
                key, action_key, env_key = jax.random.split(key, 3)
                actions = jax.random.uniform(action_key, (count, 1), minval=-2.0, maxval=2.0)
                env_keys = jax.random.split(env_key, count)
                step = jax.vmap(env.step, in_axes=(0, 0, 0, None))
                _, state, reward, *_ = step(env_keys, state, actions, params)
                return (state, key), reward.sum()

            _, rewards = jax.lax.scan(one_step, (state, step_key), None, length=steps)
            return rewards

        compiled = jax.jit(rollout)
        compiled(jax.random.PRNGKey(0)).block_until_ready()  # compile outside the timing
        best = 0.0
        for repeat in range(3):
            start = time.perf_counter()
            compiled(jax.random.PRNGKey(repeat + 1)).block_until_ready()
            best = max(best, steps * count / (time.perf_counter() - start))
        return best

    return rate


#: One measured vector env: (env id, N, num_threads, robot-steps/s, SyncVectorEnv's, gymnax's).
Row = tuple[str, int, int, float, float, float]


def measure_vector_envs(
    robot_steps: int, sync_limit: int, threads: list[int], jax: bool
) -> list[Row]:
    """Print and return every id's robot-steps/s at each N and thread count, beside
    SyncVectorEnv's and gymnax Pendulum-v1's at the same N (NaN where not measured)."""
    rows: list[Row] = []
    pendulum = gymnax_pendulum(robot_steps) if jax else None
    reference = {count: pendulum(count) if pendulum else float("nan") for count in ROBOT_COUNTS}
    if pendulum is None:
        print("gymnax Pendulum-v1: not measured (pip install -e .[bench] installs gymnax, jax)")
    header = f"{'env':<36} {'N':>6} {'threads':>7} {'native robot-steps/s':>21}"
    print(f"{header} {'sync':>12} {'x sync':>7} {'x gymnax':>9}")
    for count in ROBOT_COUNTS:
        print(f"{'gymnax Pendulum-v1 (jax cpu)':<36} {count:>6} {'':>7} {reference[count]:>21,.0f}")
    for env_id in ENV_IDS:
        for count in ROBOT_COUNTS:
            sync_rate = float("nan")
            if count <= sync_limit:
                sync = gym.make_vec(env_id, num_envs=count, vectorization_mode="sync")
                sync_rate = robot_steps_per_second(sync, min(robot_steps, 20 * count) // 4)
                sync.close()
            for num_threads in threads:
                native = gym.make_vec(env_id, num_envs=count, num_threads=num_threads)
                # Best of 3: runs of the same work vary by +-20% on these shared machines.
                rate = max(robot_steps_per_second(native, robot_steps) for _ in range(3))
                native.close()
                print(
                    f"{env_id:<36} {count:>6} {num_threads:>7} {rate:>21,.0f} {sync_rate:>12,.0f} "
                    f"{rate / sync_rate:>7.1f} {rate / reference[count]:>9.2f}"
                )
                rows.append((env_id, count, num_threads, rate, sync_rate, reference[count]))
    return rows


def markdown_table(rows: list[Row], cores: int | None, load: float) -> str:
    """The rows as the README's markdown table: one line per id and N, the thread counts side
    by side, and the faster one's ratios to SyncVectorEnv and to gymnax Pendulum-v1 ("-"
    where not measured)."""
    thread_counts = sorted({row[2] for row in rows})
    by_case: dict[tuple[str, int], dict[int, Row]] = {}
    for row in rows:
        by_case.setdefault((row[0], row[1]), {})[row[2]] = row
    gymnax = {count: reference for _, count, _, _, _, reference in rows}
    measured_gymnax = {count: rate for count, rate in gymnax.items() if math.isfinite(rate)}
    reference_line = (
        "gymnax Pendulum-v1 (JAX CPU): "
        + ", ".join(f"{rate:,.0f} at N = {count}" for count, rate in measured_gymnax.items())
        + " steps/s"
        if measured_gymnax
        else "gymnax Pendulum-v1 not measured"
    )
    lines = [
        f"{cores} cores, load average {load:.2f} at the start; {reference_line}.",
        "",
        "| env | N | "
        + " | ".join(f"{count} thread{'s' * (count > 1)}" for count in thread_counts)
        + " | x SyncVectorEnv | x gymnax |",
        "|---|---|" + "---|" * len(thread_counts) + "---|---|",
    ]
    for (env_id, count), measured in by_case.items():
        cells = " | ".join(
            _robot_steps(measured[threads][3]) if threads in measured else "-"
            for threads in thread_counts
        )
        _, _, _, rate, sync_rate, reference = max(measured.values(), key=lambda row: row[3])
        lines.append(
            f"| {env_id.removeprefix('mobile_envs/')} | {count} | {cells} | "
            f"{_ratio(rate, sync_rate, '.1f')} | {_ratio(rate, reference, '.2f')} |"
        )
    return "\n".join(lines)


def _robot_steps(rate: float) -> str:
    """Robot-steps/s, in millions from a million on."""
    return f"{rate / 1e6:.2f}M" if rate >= 1e6 else f"{rate:,.0f}"


def _ratio(rate: float, reference: float, spec: str) -> str:
    return f"{rate / reference:{spec}}x" if math.isfinite(reference) else "-"


def measure_ppo(rollouts: int, threads: int) -> None:
    """SB3 PPO's steps/s on DiffDrive-Random-v0 and the share of its time inside the env."""
    import torch
    from stable_baselines3 import PPO

    from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv

    class TimedAdapter(PathFollowingSB3VecEnv):
        """The adapter, adding up the time spent in the env's reset and step_wait."""

        env_seconds = 0.0

        def reset(self) -> Any:
            start = time.perf_counter()
            result = super().reset()
            self.env_seconds += time.perf_counter() - start
            return result

        def step_wait(self) -> Any:
            start = time.perf_counter()
            result = super().step_wait()
            self.env_seconds += time.perf_counter() - start
            return result

    torch.set_num_threads(1)
    env_id = "mobile_envs/DiffDrive-Random-v0"
    timesteps = rollouts * PPO_ROLLOUT
    print(
        f"\nPPO (SB3) on {env_id}, {timesteps} steps, rollouts of {PPO_ROLLOUT}, "
        f"1 torch thread, env num_threads={threads}"
    )
    print(f"  {'robots':>6} {'n_steps':>7} {'steps/s':>9} {'env share':>10}")
    warm_up = PathFollowingSB3VecEnv(env_id, 4, seed=0, num_threads=threads)
    warm_up.reset()
    for _ in range(300):  # compiles what the first timed run would otherwise compile
        warm_up.step(np.zeros((4, *(warm_up.action_space.shape or ())), np.float32))
    for count in PPO_ROBOT_COUNTS:
        env = TimedAdapter(env_id, count, seed=0, num_threads=threads)
        n_steps = PPO_ROLLOUT // count
        model = PPO("MlpPolicy", env, n_steps=n_steps, batch_size=1024, seed=0, device="cpu")
        env.env_seconds = 0.0
        start = time.perf_counter()
        model.learn(timesteps)
        elapsed = time.perf_counter() - start
        share = env.env_seconds / elapsed
        print(f"  {count:>6} {n_steps:>7} {timesteps / elapsed:>9,.0f} {share:>10.1%}")
        env.close()


def measure_memory(count: int = 8192, long_steps: int = 500) -> None:
    """Memory per robot after a reset and 10 steps standing still, and again after
    ``long_steps`` steps of driving (random actions around half speed forward), where
    episodes end and restart as in training, so memory that restarts leave behind shows."""
    print(
        f"\nmemory per robot (tracemalloc, N = {count}): after reset and 10 steps / after "
        f"{long_steps} steps of driving"
    )
    for env_id in ENV_IDS:
        tracemalloc.start()
        envs = gym.make_vec(env_id, num_envs=count)
        envs.reset(seed=0)
        shape = (count, *(envs.single_action_space.shape or ()))
        for _ in range(10):
            envs.step(np.zeros(shape, np.float32))
        early, _ = tracemalloc.get_traced_memory()
        rng = np.random.default_rng(0)
        for _ in range(long_steps - 10):
            envs.step((0.5 + 0.3 * rng.uniform(-1, 1, shape)).astype(np.float32))
        late, _ = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        print(f"  {env_id:<36} {early / count:>8,.0f} / {late / count:>8,.0f} bytes per robot")
        del envs


def positive_counts(flag: str, *, distinct: bool = False) -> Callable[[str], list[int]]:
    """An argparse ``type``: positive integers separated by commas (``distinct``: none of
    them twice), refused with a message that names ``flag``."""
    wanted = "distinct positive integers" if distinct else "positive integers"

    def parse(text: str) -> list[int]:
        try:
            counts = [int(item) for item in text.split(",")]
        except ValueError:
            counts = []
        if not counts or min(counts) < 1 or (distinct and len(set(counts)) != len(counts)):
            raise argparse.ArgumentTypeError(
                f"{flag} must be {wanted} separated by commas, got {text!r}"
            )
        return counts

    return parse


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps, no sync at 8192")
    parser.add_argument(
        "--threads",
        type=positive_counts("--threads"),
        default=[1, 2],
        help="comma-separated num_threads values for the vector envs (default 1,2)",
    )
    parser.add_argument("--no-gymnax", action="store_true", help="skip gymnax's Pendulum-v1")
    parser.add_argument("--no-ppo", action="store_true", help="skip the PPO measurement")
    parser.add_argument(
        "--markdown", action="store_true", help="end with the README's markdown table"
    )
    args = parser.parse_args()
    load = os.getloadavg()[0]
    print(f"{os.cpu_count()} cores, load average {load:.2f}")
    rows = measure_vector_envs(
        200_000 if args.quick else 1_000_000,
        1024 if args.quick else 8192,
        args.threads,
        not args.no_gymnax,
    )
    if not args.no_ppo:
        measure_ppo(3 if args.quick else 10, max(args.threads))
    measure_memory()
    if args.markdown:
        print("\n" + markdown_table(rows, os.cpu_count(), load))


if __name__ == "__main__":
    main()

"""The long fuzz profile: tests/test_fuzz.py's strategies and checks with many more examples.

    python benchmarks/fuzz_long.py [--examples 5000] [--seed 0]

Runs each fuzz target (constructor arguments; localization settings and the randomized
localization's variants; triangulation's input; actions for the single env, the vector env
and the SB3 adapter; reset options and seeds for both envs; the sweep's and the grid's
command lines, checked before anything trains) for ``--examples`` examples (the command
lines, which build a model each, for a tenth of them), then prints how many examples gave
each outcome. Any other outcome (a NaN, another exception type, an error that names the
wrong argument) stops the run with hypothesis's minimal failing example. CI runs the same
checks with tens to a few hundred examples each.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from hypothesis import HealthCheck, given, seed, settings

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import test_fuzz  # the strategies and checks, from the test suite


def targets() -> dict[str, tuple]:
    """Each fuzz target: its check and strategies, as tests/test_fuzz.py pairs them."""
    fuzz = test_fuzz
    sb3_env_id = "mobile_envs/DiffDrive-Random-v0"
    targets = {
        "constructor arguments": (fuzz.check_constructor, fuzz.constructor_arguments()),
        "localization settings and variants": (
            fuzz.check_constructor,
            fuzz.localization_arguments(),
        ),
        "triangulation input": (fuzz.check_triangulation, fuzz.triangulation_inputs()),
        "single env actions": (
            lambda action, robot_seed: fuzz.check_action(*fuzz._SINGLE, action, (2,), robot_seed),
            fuzz.actions_for((2,)),
            fuzz.st.integers(0, 3),
        ),
        "vector env actions": (
            lambda action, robot_seed: fuzz.check_action(*fuzz._VECTOR, action, (3, 2), robot_seed),
            fuzz.actions_for((3, 2)),
            fuzz.st.integers(0, 3),
        ),
        "single env reset options": (
            lambda options, reset_seed: fuzz.check_reset(fuzz._RESET_SINGLE, reset_seed, options),
            fuzz.reset_options(),
            fuzz.st.one_of(fuzz.st.none(), fuzz.st.integers(0, 2**40)),
        ),
        "vector env reset options and seeds": (
            lambda options, reset_seed: fuzz.check_reset(fuzz._RESET_VECTOR, reset_seed, options),
            fuzz.reset_options(num_envs=3),
            fuzz.seeds(3),
        ),
    }
    try:
        from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv
    except ImportError:
        print("SB3 adapter skipped: stable-baselines3 (the train extra) is not installed")
    else:
        adapters = tuple(PathFollowingSB3VecEnv(sb3_env_id, 8, seed=1) for _ in range(2))
        targets["SB3 adapter actions"] = (
            lambda action: fuzz.check_action(*adapters, action, (8, 2), 0),
            # None is a known defect of the adapter (tests/test_fuzz.py's strict xfail).
            fuzz.actions_for((8, 2)).filter(lambda action: action is not None),
        )
    for command, flags in (("sweep", fuzz.SWEEP_FLAGS), ("grid", fuzz.GRID_FLAGS)):
        targets[f"{command} command lines"] = (
            command_line_check(command),
            fuzz.command_lines(flags),
        )
    return targets


def command_line_check(command: str) -> Callable[[tuple[list[str], set[str]]], None]:
    """tests/test_fuzz.py's check of ``command``'s settings, each example in a new folder."""

    def check(line: tuple[list[str], set[str]]) -> None:
        folder = Path(tempfile.mkdtemp(prefix=f"fuzz_{command}_"))
        test_fuzz.check_command_line(command, *line, folder)

    return check


#: Targets that build a model or an env per example run a tenth of ``--examples``.
SLOW_TARGETS = ("sweep command lines", "grid command lines")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=5000, help="examples per target")
    parser.add_argument("--seed", type=int, default=0, help="hypothesis's random seed")
    args = parser.parse_args()
    profile = settings(
        max_examples=args.examples,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    for name, (check, *strategies) in targets().items():
        before = test_fuzz.OUTCOMES.copy()
        start = time.perf_counter()
        examples = max(1, args.examples // 10) if name in SLOW_TARGETS else args.examples
        target_profile = settings(profile, max_examples=examples)
        seed(args.seed)(target_profile(given(*strategies)(check)))()
        outcomes = test_fuzz.OUTCOMES - before
        print(f"{name}: {outcomes.total()} examples in {time.perf_counter() - start:.1f} s")
        for outcome, count in sorted(outcomes.items()):
            print(f"  {count:7d}  {outcome}")
    print(
        f"{test_fuzz.OUTCOMES.total()} examples in all, and no other outcome: no NaN or inf, "
        f"no other exception type, no error that names the wrong argument"
    )


if __name__ == "__main__":
    main()

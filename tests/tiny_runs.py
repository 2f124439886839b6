"""Settings for the tiny trainings the sweep, grid and Ray tests run (a few thousand steps on
4 robots: they check the machinery, not learning), and an exact comparison of their numbers."""

import math

#: A hyperparameter file's content: PPO small enough to train 1000 steps in about a second.
TINY_PPO = {
    "default": {
        "n_envs": 4,
        "policy": "MlpPolicy",
        "n_steps": 64,
        "batch_size": 64,
        "n_epochs": 2,
        "policy_kwargs": {"net_arch": [16, 16]},
    }
}


def grid_flags(output, hyperparams, *extra):
    """``train.py grid`` flags for 2 seeds of 512 steps, evaluated on 2 path sets."""
    return [
        "--seeds",
        "0-1",
        "--hyperparams",
        str(hyperparams),
        "--timesteps",
        "512",
        "--eval-paths",
        "Random",
        "Lines",
        "--episodes",
        "2",
        "--output",
        str(output),
        *extra,
    ]


def same_numbers(first, second):
    """Assert two (nested) dicts of numbers are equal bit for bit, NaN (no episode reached
    the goal) equal to NaN."""
    assert first.keys() == second.keys()
    for key in first:
        if isinstance(first[key], dict):
            same_numbers(first[key], second[key])
        elif not (math.isnan(first[key]) and math.isnan(second[key])):
            assert first[key] == second[key], key

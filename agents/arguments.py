"""argparse types the training commands share (``train.py``, its ``sweep`` and ``grid``): each
refuses a value with a message that argparse prefixes with the argument's name, and exit
status 2."""

from __future__ import annotations

import argparse
import pathlib
import re
from collections.abc import Callable

#: Seeds are below this: SB3 seeds numpy's legacy generator, which takes 32-bit seeds.
SEED_LIMIT = 2**32
#: The first evaluation seed of the sweep and the grid: the training envs are seeded from
#: --seed (0, ...), so these random paths and start poses are not among those a policy
#: trained on.
DEFAULT_EVAL_SEED = 1_000_000


def at_least(minimum: int, maximum: int | None = None) -> Callable[[str], int]:
    """An argparse ``type``: an integer no smaller than ``minimum`` (and no larger than
    ``maximum``), written in ASCII digits with an optional sign."""

    def parse(text: str) -> int:
        if not re.fullmatch(r"\s*[+-]?[0-9]+\s*", text):
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}")
        value = int(text)
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}, got {value}")
        if maximum is not None and value > maximum:
            raise argparse.ArgumentTypeError(f"must be at most {maximum}, got {value}")
        return value

    return parse


#: An argparse ``type`` for seeds: an integer in [0, 2**32).
seed = at_least(0, SEED_LIMIT - 1)


def add_count_argument(
    parser: argparse.ArgumentParser, flag: str, minimum: int, default: int, help: str
) -> None:
    """Add ``flag``, a whole number at least ``minimum`` that is ``default`` when not given,
    its help ``help`` followed by the default as the training commands show it
    (``"episodes per evaluation (default: 20)"``)."""
    parser.add_argument(
        flag, type=at_least(minimum), default=default, help=f"{help} (default: {default})"
    )


def add_n_envs_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--n-envs``, the robots collecting experience (by default the YAML's), as every
    training command takes it."""
    parser.add_argument(
        "--n-envs", type=at_least(1), help="robots collecting experience (default: YAML)"
    )


def add_hyperparams_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--hyperparams``, the YAML of settings per env id the runs train with (by default
    the algorithm's, ``hyperparams/ALGO.yml``), as every training command takes it."""
    parser.add_argument(
        "--hyperparams",
        type=pathlib.Path,
        help="settings per env id (default: hyperparams/ALGO.yml)",
    )


def add_eval_seed_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--eval-seed``, the seed of the first evaluation episode (default
    :data:`DEFAULT_EVAL_SEED`), as the sweep and the grid take it."""
    parser.add_argument(
        "--eval-seed",
        type=seed,
        default=DEFAULT_EVAL_SEED,
        help=f"seed of the first evaluation episode (default: {DEFAULT_EVAL_SEED})",
    )

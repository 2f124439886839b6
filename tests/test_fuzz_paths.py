"""Fuzzing path files: whatever a file holds, Path.from_file gives a valid Path or a ValueError
that names the file; never another exception, a NaN or a hang.

Bounded for CI (a few hundred examples per strategy, seconds in all); run with
``--hypothesis-show-statistics`` to see how many examples gave each outcome.
"""

import itertools
import json
import math

import numpy as np
import pytest

pytest.importorskip("hypothesis", reason="the path-file fuzz suite needs hypothesis (dev extra)")

from hypothesis import event, given, settings
from hypothesis import strategies as st

from mobile_envs.world.paths import DUPLICATE_TOLERANCE, MAX_COORDINATE, Path

EXAMPLES = settings(max_examples=200, deadline=None)
SUFFIXES = (".csv", ".json", ".CSV", ".JSON")
BOM = "\ufeff"
_file_numbers = itertools.count()


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("path_files")


def write(folder, suffix, content):
    """A new file in ``folder`` holding ``content`` (bytes, or text written as UTF-8)."""
    file = folder / f"fuzz_{next(_file_numbers)}{suffix}"
    file.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    return file


def read(file):
    """Path.from_file(file), checked: a valid path, or None after a ValueError naming the file.

    Any other exception fails the test.
    """
    try:
        path = Path.from_file(file)
    except ValueError as error:
        assert str(file) in str(error)
        event("ValueError naming the file")
        return None
    points = path.points
    assert points.ndim == 2 and points.shape[1] == 2 and len(points) >= 2
    assert np.isfinite(points).all() and np.abs(points).max() <= MAX_COORDINATE
    assert math.isfinite(path.length) and path.length > 0
    assert np.all(path.segment_lengths >= DUPLICATE_TOLERANCE)
    event("valid path")
    return path


# ---------------------------------------------------------------------------------------------
# Strategies

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-1e3, 1e3),
    st.integers(-(10**400), 10**400),
    st.integers(-100, 100),
)
number_text = st.one_of(
    numbers.map(repr),
    st.sampled_from(
        ["nan", "-inf", "Infinity", "1e400", "-1e-400", "1_0", "0x10", "", " ", "\u0661"]
    ),
)
csv_field = st.one_of(number_text, st.text(max_size=6))
csv_line = st.lists(csv_field, max_size=4).map(",".join)
line_break = st.sampled_from(["\n", "\r\n", "\r"])


@st.composite
def csv_text(draw):
    """CSV-ish text: lines of number-like and arbitrary fields, maybe a header and a BOM."""
    lines = draw(st.lists(csv_line, max_size=8))
    if draw(st.booleans()):
        lines.insert(0, draw(st.sampled_from(["x,y", "X, Y", "east,north", "x"])))
    text = draw(line_break).join(lines)
    return (BOM if draw(st.booleans()) else "") + text


json_values = st.recursive(
    st.one_of(st.none(), st.booleans(), numbers, st.text(max_size=4)),
    lambda children: st.one_of(
        st.lists(children, max_size=4), st.dictionaries(st.text(max_size=3), children, max_size=3)
    ),
    max_leaves=24,
)
json_pairs = st.lists(st.lists(numbers, min_size=2, max_size=2), max_size=8)


@st.composite
def json_text(draw):
    """JSON text, often a list of pairs, sometimes cut short or with a character inserted."""
    text = json.dumps(draw(st.one_of(json_pairs, json_values)))
    if draw(st.booleans()):
        cut = draw(st.integers(0, len(text)))
        text = text[:cut] + draw(st.text(max_size=2)) + text[cut + draw(st.integers(0, 2)) :]
    return (BOM if draw(st.booleans()) else "") + text


@st.composite
def deep_nesting(draw):
    depth = draw(st.integers(1, 120_000))
    closing = depth - draw(st.integers(0, 2))
    return "[" * depth + draw(st.sampled_from(["", "0", "0, 0"])) + "]" * max(closing, 0)


# ---------------------------------------------------------------------------------------------
# Properties


@EXAMPLES
@given(st.binary(max_size=300), st.sampled_from(SUFFIXES))
def test_random_bytes(folder, content, suffix):
    read(write(folder, suffix, content))


@EXAMPLES
@given(csv_text(), st.sampled_from(["utf-8", "utf-16", "latin-1"]))
def test_malformed_csv(folder, text, encoding):
    read(write(folder, ".csv", text.encode(encoding, errors="replace")))


@EXAMPLES
@given(json_text())
def test_malformed_json(folder, text):
    read(write(folder, ".json", text))


@settings(max_examples=25, deadline=None)
@given(deep_nesting())
def test_deeply_nested_json(folder, text):
    assert read(write(folder, ".json", text)) is None


coordinates = st.one_of(st.floats(-50.0, 50.0), st.floats(-2e9, 2e9))


@EXAMPLES
@given(
    st.lists(st.tuples(coordinates, coordinates), min_size=2, max_size=8),
    st.sampled_from([".csv", ".json"]),
    st.booleans(),
)
def test_well_formed_files_give_exactly_their_points(folder, pairs, suffix, with_bom):
    # The truth is the numbers written: a file of well-separated points within the limit
    # reads back bit for bit; one with a point beyond it is refused.
    if suffix == ".csv":
        text = "\n".join(f"{x!r},{y!r}" for x, y in pairs)
    else:
        text = json.dumps([list(pair) for pair in pairs])
    path = read(write(folder, suffix, (BOM if with_bom else "") + text))
    points = np.array(pairs)
    within = np.abs(points).max() <= MAX_COORDINATE
    separated = np.all(np.hypot(*np.diff(points, axis=0).T) >= 1e-6)
    if within and separated:
        assert path is not None and np.array_equal(path.points, points)
    if not within:
        assert path is None

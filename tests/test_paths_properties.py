"""Path geometry properties, by hypothesis (the ``dev`` extra): projection against brute
force, and hinted projection along random reversals."""

import itertools
import math

import numpy as np
import pytest

pytest.importorskip("hypothesis", reason="property tests need hypothesis (the dev extra)")

from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from test_paths import follow_with_hint

from mobile_envs.world.geometry import TIE_TOLERANCE
from mobile_envs.world.paths import Path

coordinates = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
point_lists = st.lists(st.tuples(coordinates, coordinates), min_size=2, max_size=8)


def brute_force_projection(points, xy):
    """Closest point of a polyline by a plain loop over segments: (distance, segment, s, side).

    Ties go to the earliest segment; side is the sign of the cross product of the segment's
    direction and the vector from its start to xy.
    """
    best = None
    start_s = 0.0
    for index, (a, b) in enumerate(itertools.pairwise(points)):
        direction = b - a
        length = math.hypot(*direction)
        along = min(1.0, max(0.0, float(np.dot(xy - a, direction)) / length**2))
        distance = math.hypot(*(xy - (a + along * direction)))
        if best is None or distance < best[0]:
            side = direction[0] * (xy[1] - a[1]) - direction[1] * (xy[0] - a[0])
            best = (distance, index, start_s + along * length, side)
        start_s += length
    return best


def make_path(points):
    try:
        return Path(points)
    except ValueError:
        assume(False)


@settings(max_examples=150, deadline=None)
@given(point_lists, st.lists(st.tuples(coordinates, coordinates), min_size=1, max_size=6))
@example(points=[(0.0, 0.0), (1e-09, 1.0), (0.0, 1.0)], queries=[(0.0, 1.0)])
def test_global_projection_matches_brute_force(points, queries):
    path = make_path(points)
    xy = np.array(queries)
    s, error, segment = path.project(xy)
    for i, query in enumerate(xy):
        distance, index, expected_s, side = brute_force_projection(path.points, query)
        # Points equally close within TIE_TOLERANCE tie, and the earlier may win by design:
        # its distance can exceed the closest one's by up to the tolerance (and rounding).
        assert abs(abs(error[i]) - distance) <= TIE_TOLERANCE * (1 + 1e-6)
        second = sorted(
            brute_force_projection(path.points[j : j + 2], query)[0]
            for j in range(path.num_segments)
        )
        if len(second) == 1 or second[1] - second[0] > 1e-7:
            assert segment[i] == index
            assert s[i] == pytest.approx(expected_s, abs=1e-9)
            if distance > 1e-9 and abs(side) > 1e-9:
                assert np.sign(error[i]) == np.sign(side)


@st.composite
def reversal_paths(draw):
    """Collinear legs that turn back over each other, in any direction, with perpendicular
    side steps between some of them."""
    heading = draw(st.floats(-math.pi, math.pi))
    direction = np.array([math.cos(heading), math.sin(heading)])
    normal = np.array([-direction[1], direction[0]])
    points = [np.array([draw(coordinates), draw(coordinates)])]
    sign = 1.0
    for _ in range(draw(st.integers(2, 5))):
        points.append(points[-1] + sign * draw(st.floats(1.5, 6.0)) * direction)
        if draw(st.booleans()):
            points.append(points[-1] + draw(st.sampled_from([-1.0, 1.0])) * 2.0 * normal)
        sign = -sign
    return Path(points)


@settings(max_examples=40, deadline=None)
@given(reversal_paths())
def test_hinted_projection_follows_random_reversals(path):
    s = np.arange(0.0, path.length, 0.05)
    np.testing.assert_allclose(follow_with_hint(path, s), s, rtol=0, atol=1e-8)

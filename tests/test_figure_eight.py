"""The figure eight against the lemniscate of Bernoulli's closed forms: its length, where and
how it crosses itself, its curvature against every model's tightest turn; its ids, and pure
pursuit round it on every one."""

import itertools
import math

import gymnasium as gym
import numpy as np
import pytest

from agents.controllers.pure_pursuit import PurePursuit
from agents.harness.evaluate import evaluate
from mobile_envs.envs.registration import env_specs, model_ids
from mobile_envs.robots.model import MODELS
from mobile_envs.sim.config import build_model
from mobile_envs.tracks import PATH_SETS, path_set
from mobile_envs.tracks.course import OPEN_AREA_REFLECTORS
from mobile_envs.tracks.figure_eight import (
    FIGURE_EIGHT_CENTRE,
    FIGURE_EIGHT_HALF_WIDTH,
    figure_eight_path,
    lemniscate_points,
)

A = FIGURE_EIGHT_HALF_WIDTH
#: The lemniscate constant varpi = Gamma(1/4)^2 / (2 sqrt(2 pi)) = 2.62205755...
VARPI = math.gamma(0.25) ** 2 / (2.0 * math.sqrt(2.0 * math.pi))
FIGURE_EIGHT_IDS = sorted(
    env_id for env_id, kwargs in env_specs().items() if kwargs.get("paths") == "figure_eight"
)
#: The ids pure pursuit must complete: all but odometry alone, whose drift takes the robot off
#: track on every path set (pure pursuit completes 0-20 % of Lines and Segments on it too).
DRIVEN_IDS = [
    env_id
    for env_id in FIGURE_EIGHT_IDS
    if gym.spec(env_id).kwargs.get("localization") != "odometry"
    and "plant" not in gym.spec(env_id).kwargs  # an imperfect robot is no test of the path
]


def test_the_curve_is_as_long_as_the_closed_form_and_the_polyline_just_shorter():
    # Gauss-Legendre quadrature of the speed |r'(t)| = a / sqrt(1 + sin^2 t) over one turn,
    # on each quarter (the integrand is smooth there).
    nodes, weights = np.polynomial.legendre.leggauss(40)
    length = 0.0
    for start in np.arange(4) * math.pi / 2:
        t = start + (nodes + 1.0) * math.pi / 4
        length += math.pi / 4 * float(np.sum(weights * A / np.sqrt(1.0 + np.sin(t) ** 2)))
    assert length == pytest.approx(2.0 * VARPI * A, rel=1e-12)
    # Each chord c is shorter than its arc by at most c^3 kappa_max^2 / 24.
    path = figure_eight_path()
    chords = path.segment_lengths
    deficit = float(np.sum(chords**3)) * (3.0 / A) ** 2 / 24.0
    assert length - deficit <= path.length < length
    assert chords.max() < 0.09


def test_the_samples_lie_on_the_lemniscate():
    """(x^2 + y^2)^2 = a^2 (x^2 - y^2) about the centre, the curve's implicit equation."""
    points = figure_eight_path().points - FIGURE_EIGHT_CENTRE
    x, y = points[:, 0], points[:, 1]
    np.testing.assert_allclose((x**2 + y**2) ** 2, A**2 * (x**2 - y**2), atol=1e-12)
    assert points[:, 0].min() == pytest.approx(-A) and points[:, 0].max() == pytest.approx(A)
    assert np.abs(points[:, 1]).max() == pytest.approx(A / (2 * math.sqrt(2)), rel=1e-4)


def segment_crossings(points):
    """Every pair of non-adjacent segments that cross, and where: brute force over all pairs."""
    crossings = []
    for i, j in itertools.combinations(range(len(points) - 1), 2):
        if j - i < 2 or (i == 0 and j == len(points) - 2):  # neighbours share a vertex
            continue
        p, r = points[i], points[i + 1] - points[i]
        q, s = points[j], points[j + 1] - points[j]
        denominator = r[0] * s[1] - r[1] * s[0]
        if denominator == 0.0:
            continue
        u = ((q - p)[0] * s[1] - (q - p)[1] * s[0]) / denominator
        v = ((q - p)[0] * r[1] - (q - p)[1] * r[0]) / denominator
        if 0.0 <= u <= 1.0 and 0.0 <= v <= 1.0:
            crossings.append((i, j, p + u * r))
    return crossings


def test_it_crosses_itself_once_at_the_centre_at_right_angles():
    points = figure_eight_path().points
    crossings = segment_crossings(points)
    assert len(crossings) == 1
    first, second, where = crossings[0]
    np.testing.assert_allclose(where, FIGURE_EIGHT_CENTRE, atol=1e-6)
    along = [points[k + 1] - points[k] for k in (first, second)]
    cosine = np.dot(*along) / (np.linalg.norm(along[0]) * np.linalg.norm(along[1]))
    assert abs(cosine) < 1e-3  # the lemniscate of Bernoulli's tangents there are at +-45 deg
    # Crossed heading south-west, then south-east, a quarter and three quarters round.
    assert along[0][0] < 0 and along[0][1] < 0 and along[1][0] > 0 and along[1][1] < 0
    assert abs(first / (len(points) - 1) - 0.25) < 0.01
    assert abs(second / (len(points) - 1) - 0.75) < 0.01


def test_its_curvature_is_3r_over_a_squared_and_every_model_can_turn_it():
    """The circle through each three consecutive samples (Menger curvature) against the
    closed form 3 r / a^2 at the middle one; its peak, 3 / a at the tips, is within every
    model's tightest turn."""
    points = figure_eight_path().points[:-1]  # the closed loop, each sample once
    before, middle, after = np.roll(points, 1, axis=0), points, np.roll(points, -1, axis=0)
    first, second = middle - before, after - middle
    cross = first[:, 0] * second[:, 1] - first[:, 1] * second[:, 0]
    sides = (
        np.linalg.norm(middle - before, axis=1)
        * np.linalg.norm(after - middle, axis=1)
        * np.linalg.norm(after - before, axis=1)
    )
    menger = 2.0 * np.abs(cross) / sides
    radius_from_centre = np.linalg.norm(middle - FIGURE_EIGHT_CENTRE, axis=1)
    np.testing.assert_allclose(menger, 3.0 * radius_from_centre / A**2, atol=1e-3 * 3.0 / A)
    assert menger.max() == pytest.approx(3.0 / A, rel=1e-3)
    for name in MODELS:
        assert build_model(name).min_turning_radius < A / 3.0, name


def test_the_start_is_the_right_tip_heading_along_the_curve():
    path = figure_eight_path()
    np.testing.assert_array_equal(path.points[0], path.points[-1])
    np.testing.assert_allclose(path.points[0], lemniscate_points(np.zeros(1))[0])
    assert path.start_heading == pytest.approx(
        math.atan2(*(path.points[1] - path.points[0])[::-1]), abs=0.05
    )


def test_every_model_has_its_ids_with_beacons_in_the_course_area():
    entry = PATH_SETS["figure_eight"]
    assert entry.env_id == "FigureEight"
    np.testing.assert_array_equal(path_set("figure_eight").reflectors, OPEN_AREA_REFLECTORS)
    for model in model_ids():
        assert f"mobile_envs/{model}-FigureEight-v0" in FIGURE_EIGHT_IDS
        assert f"mobile_envs/{model}-FigureEight-Beacons-v0" in FIGURE_EIGHT_IDS
    assert set(FIGURE_EIGHT_IDS) <= set(gym.registry)
    assert len(DRIVEN_IDS) == 2 * len(MODELS) + sum(
        "OdometryBeacons" in env_id for env_id in FIGURE_EIGHT_IDS
    )
    for model in model_ids():
        assert f"mobile_envs/{model}-FigureEight-Realistic-v0" in FIGURE_EIGHT_IDS
    points = figure_eight_path().points
    assert ((points > 0.0) & (points < 13.0)).all()  # inside the reflectors' room


@pytest.mark.parametrize("env_id", DRIVEN_IDS)
def test_pure_pursuit_goes_round_it_on_every_id(env_id):
    summary = evaluate(PurePursuit(), env_id, episodes=1).summary
    assert summary["completion_rate"] == 1.0
    assert summary["max_abs_cte"] < 0.05

"""Laser-beacon positioning (seed 003 section 2) against exact geometry and error propagation."""

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest

from mobile_envs.sensing.beacons import (
    DEFAULT_MAX_HEADING_GAIN,
    FIX,
    HEADING_KEPT,
    LAB_REFLECTORS,
    NO_FIX,
    OPEN_AREA_REFLECTORS,
    LaserHead,
    bearing_sensitivity,
    correct_bearings,
    default_reflectors,
    sweep_screw_bearings,
    triangulate,
    triangulate_near,
    triangulate_robot,
    twist_relative_poses,
    validate_reflectors,
    visible_reflectors,
)
from mobile_envs.tracks import path_set_names, the_maze
from mobile_envs.world.paths import RANDOM_AREA, arc_straight_path, course_path

RESOLUTION = 2 * math.pi / 65535
TRIPLE = np.array([[-0.5, -0.5], [13.5, 1.0], [6.0, 13.5]])


def true_bearings(reflectors, position, heading):
    """Bearings of the reflectors from ``position``, relative to ``heading``, by atan2."""
    offsets = np.asarray(reflectors) - np.asarray(position)
    return np.arctan2(offsets[:, 1], offsets[:, 0]) - heading


def jacobian_gains(reflectors, position):
    """The first-order error propagation of a three-bearing fix, by numpy's inverse.

    theta_i = atan2(y_i - y, x_i - x) - psi, so d theta_i / d(x, y, psi) =
    ((y_i - y) / d_i^2, -(x_i - x) / d_i^2, -1). Inverting that Jacobian J, a bearing error
    vector e moves the fix by J^-1 e. A common error in all three bearings only turns the
    heading (J^-1 (1, 1, 1) = (0, 0, -1)), so floor quantization's errors in [0, res) act on
    the position as errors in [-res/2, res/2): |dP| <= res/2 sum_i |J^-1_P e_i|. The heading
    takes the full [0, res): |dpsi| <= res sum_i |J^-1_psi e_i|.

    :return: (sum_i |column i of J^-1's position rows|, sum_i |J^-1_psi,i|)
    """
    offsets = np.asarray(reflectors) - np.asarray(position)
    squared = (offsets**2).sum(axis=1)
    jacobian = np.column_stack((offsets[:, 1] / squared, -offsets[:, 0] / squared, -np.ones(3)))
    try:
        inverse = np.linalg.inv(jacobian)
    except np.linalg.LinAlgError:  # on the triple's critical circle
        return math.inf, math.inf
    return np.linalg.norm(inverse[:2], axis=0).sum(), np.abs(inverse[2]).sum()


def best_triple_gains(reflectors, position):
    """The gains of the triple with the smallest position gain at ``position``."""
    gains = [
        jacobian_gains(reflectors[list(triple)], position)
        for triple in itertools.combinations(range(len(reflectors)), 3)
    ]
    return min(gains)


def angle_error(a, b):
    return abs(math.remainder(a - b, 2 * math.pi))


def course_area_grid(step=0.5):
    low, high = RANDOM_AREA[0] - 0.5, RANDOM_AREA[1] + 0.5  # the whole 0-13 m plot
    axis = np.arange(low, high + 1e-9, step)
    return np.array([(x, y) for x in axis for y in axis])


# ---------------------------------------------------------------- triangulation, exact


def test_exact_bearings_give_the_exact_pose_for_heading_errors_up_to_80_degrees():
    rng = np.random.default_rng(0)
    checked = 0
    for position in course_area_grid(1.0):
        heading = rng.uniform(-math.pi, math.pi)
        bearings = true_bearings(TRIPLE, position, heading)
        if jacobian_gains(TRIPLE, position)[1] > DEFAULT_MAX_HEADING_GAIN:
            continue  # near the critical circle: see the fallback test
        for delta in np.radians([-80, -45, -10, -0.5, 0, 0.5, 10, 45, 80]):
            x, y, psi, _ = triangulate(TRIPLE, bearings, heading + delta)
            assert math.hypot(x - position[0], y - position[1]) < 1e-9
            assert angle_error(psi, heading) < 1e-11
            checked += 1
    assert checked > 9 * 150


def test_exact_with_the_head_aligned_with_two_reflectors():
    """P on the line through two reflectors puts a vertex of both triangles at infinity:
    eq. 5 takes the finite sides. Between the two, and beyond one of them."""
    for position in ([6.5, 0.25], [-3.5, -0.7142857142857143], [9.0, 12.0]):
        for delta in np.radians([-60, 20]):
            bearings = true_bearings(TRIPLE, position, 0.4)
            x, y, psi, _ = triangulate(TRIPLE, bearings, 0.4 + delta)
            assert math.hypot(x - position[0], y - position[1]) < 1e-9
            assert angle_error(psi, 0.4) < 1e-11


def test_on_the_critical_circle_the_heading_stays_the_estimate_and_all_is_finite():
    """Every point of the circle through the reflectors sees them at the same relative
    angles: the fix keeps psi_est, and the lines at psi_est meet on the circle itself."""
    centre, radius = np.array([2.0, 1.0]), 5.0
    angles = np.radians([10.0, 130.0, 250.0])
    reflectors = centre + radius * np.column_stack((np.cos(angles), np.sin(angles)))
    for on_circle in np.radians([60.0, 200.0, 300.0]):
        position = centre + radius * np.array([math.cos(on_circle), math.sin(on_circle)])
        bearings = true_bearings(reflectors, position, 0.3)
        for delta in np.radians([0.0, 2.0, -30.0]):
            x, y, psi, _ = triangulate(reflectors, bearings, 0.3 + delta)
            assert psi == pytest.approx(math.remainder(0.3 + delta, 2 * math.pi))
            assert math.isfinite(x) and math.isfinite(y)
            assert math.hypot(x - centre[0], y - centre[1]) == pytest.approx(radius)
            if delta == 0.0:
                assert math.hypot(x - position[0], y - position[1]) < 1e-9


@pytest.mark.parametrize(("error", "least_kept"), [(1e-3, 3), (RESOLUTION, 1)])
def test_near_the_critical_circle_the_fix_keeps_the_estimate_only_inside_the_band(
    error, least_kept
):
    """Walking across the circle with psi_est 0.05 rad off, the heading is fixed wherever
    the heading gain g is within the limit or g e is below 0.05 rad (the fix tells psi_est
    from psi), and kept at psi_est where it is neither. With e = 1 mrad the band is that of
    the gain limit alone (g e >= 0.05 rad from g = 50 on); with one count it narrows to
    where g >= 521."""
    centre, radius = np.array([0.0, 0.0]), 6.0
    angles = np.radians([0.0, 100.0, 220.0])
    reflectors = radius * np.column_stack((np.cos(angles), np.sin(angles)))
    kept = fixed = 0
    for distance in np.linspace(radius - 1.0, radius + 1.0, 81):
        position = centre + distance * np.array([math.cos(0.9), math.sin(0.9)])
        bearings = true_bearings(reflectors, position, -1.0)
        x, y, psi, _ = triangulate(reflectors, bearings, -1.0 + 0.05, bearing_error=error)
        assert all(map(math.isfinite, (x, y, psi)))
        gain = jacobian_gains(reflectors, position)[1]
        if gain <= DEFAULT_MAX_HEADING_GAIN * 0.99 or gain * error < 0.05 * 0.99:
            fixed += 1
            assert angle_error(psi, -1.0) < 1e-9
        elif gain > DEFAULT_MAX_HEADING_GAIN * 1.01 and gain * error > 0.05 * 1.01:
            kept += 1
            assert psi == pytest.approx(-0.95)
    assert kept >= least_kept and fixed >= 60


def circumcircle(points):
    """Centre and radius of the circle through three points (the perpendicular bisectors)."""
    (ax, ay), (bx, by), (cx, cy) = points
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    ux = (ax**2 + ay**2) * (by - cy) + (bx**2 + by**2) * (cy - ay) + (cx**2 + cy**2) * (ay - by)
    uy = (ax**2 + ay**2) * (cx - bx) + (bx**2 + by**2) * (ax - cx) + (cx**2 + cy**2) * (bx - ax)
    centre = np.array([ux / d, uy / d])
    return centre, math.hypot(*(points[0] - centre))


def brute_force_pose(reflectors, bearings, heading_estimate):
    """The pose (x, y, psi) from which three reflectors have ``bearings``, by search: for
    every heading on a grid of 0.02 degrees within 90 degrees of psi_est, the point nearest
    (least squares) to the three lines at those headings and its squared distances, then the
    best heading's pose refined by scipy's least_squares on the bearings themselves."""
    from scipy.optimize import least_squares

    headings = heading_estimate + np.radians(np.arange(-89.99, 90.0, 0.02))
    angles = headings[:, None] + np.asarray(bearings)[None, :]
    normals = np.stack((-np.sin(angles), np.cos(angles)), axis=-1)  # (H, 3, 2)
    offsets = np.einsum("hij,ij->hi", normals, reflectors)  # the lines: n . p = n . R_i
    normal_t = np.transpose(normals, (0, 2, 1))
    moments = np.einsum("hji,hj->hi", normals, offsets)
    points = np.linalg.solve(normal_t @ normals, moments[..., None])[..., 0]
    residuals = (np.einsum("hij,hj->hi", normals, points) - offsets) ** 2
    best = int(np.argmin(residuals.sum(axis=1)))

    def bearing_residuals(pose):
        offsets = reflectors - pose[:2]
        seen = np.arctan2(offsets[:, 1], offsets[:, 0]) - pose[2]
        return np.remainder(seen - bearings + np.pi, 2 * np.pi) - np.pi

    start = np.array([*points[best], headings[best]])
    return least_squares(bearing_residuals, start, xtol=1e-15, ftol=1e-15, gtol=1e-15).x


@pytest.mark.parametrize("counts", [None, 65535])
def test_on_random_layouts_the_fix_is_the_brute_force_pose_unless_psi_est_is_better(counts):
    """Random triples, heads anywhere and within 0.5 m of the critical circle, psi_est up to
    60 degrees off, exact and 65535-count bearings. Against a brute-force solver: a fix is
    the pose that gives the bearings, and it is taken exactly where its heading gain g is
    within the limit or its first-order heading error g e is below the error it finds in
    psi_est; elsewhere psi_est is kept. Against the truth, with counts: the heading errs by
    at most g e when fixed and 2 g e when kept (first order, g at the truth)."""
    rng = np.random.default_rng(30)
    head = LaserHead(counts_per_revolution=counts)
    error = head.bearing_resolution
    fixed_beyond_the_limit = kept = 0
    for trial in range(300):
        reflectors = rng.uniform(-10.0, 10.0, (3, 2))
        centre, radius = circumcircle(reflectors)
        if jacobian_gains(reflectors, [0.0, 0.0])[0] > 1e6 or radius > 40.0:
            continue  # nearly collinear
        if trial % 2:
            angle = rng.uniform(-math.pi, math.pi)
            distance = radius + rng.uniform(-0.5, 0.5)
            position = centre + distance * np.array([math.cos(angle), math.sin(angle)])
        else:
            position = rng.uniform(-12.0, 12.0, 2)
        if np.hypot(*(reflectors - position).T).min() < 0.5:
            continue
        heading = rng.uniform(-math.pi, math.pi)
        bearings, _ = head.measure([*position, heading], reflectors)
        estimate = heading + math.radians(rng.uniform(-60.0, 60.0))
        fix = triangulate(reflectors, bearings, estimate, bearing_error=error)
        assert all(map(math.isfinite, fix))
        solved = brute_force_pose(reflectors, bearings, estimate)
        gain = jacobian_gains(reflectors, solved[:2])[1]
        found = angle_error(estimate, solved[2])  # the error the fix finds in psi_est
        bound = gain * max(error, 1e-15)
        if abs(bound - found) < 0.02 * found or abs(gain - DEFAULT_MAX_HEADING_GAIN) < 0.5:
            continue  # on the edge of the test: rounding may go either way
        takes_fix = gain <= DEFAULT_MAX_HEADING_GAIN or bound < found
        if takes_fix:
            assert fix.status == FIX, (trial, gain, bound, found)
            scale = max(1.0, jacobian_gains(reflectors, solved[:2])[0])
            assert math.hypot(fix.x - solved[0], fix.y - solved[1]) < 1e-10 * scale, trial
            assert angle_error(fix.heading, solved[2]) < 1e-10 * max(1.0, gain), trial
            fixed_beyond_the_limit += gain > DEFAULT_MAX_HEADING_GAIN
        else:
            assert fix.status == HEADING_KEPT, (trial, gain, bound, found)
            assert angle_error(fix.heading, estimate) < 1e-12
            kept += 1
        true_gain = jacobian_gains(reflectors, position)[1]
        if counts is not None and true_gain * error < 0.05:  # where first order holds
            allowed = (1 if fix.status == FIX else 2) * true_gain * error
            assert angle_error(fix.heading, heading) <= 1.05 * allowed + 1e-12, trial
    assert fixed_beyond_the_limit >= 10 and kept >= (10 if counts else 0)


def test_the_fix_of_the_issue_s_layout_is_exact_where_the_gain_limit_fell_back_2_m_off():
    """Issue 30's case: the head 0.94 m inside the critical circle, heading gain 68, psi_est
    7.47 degrees off. The gain limit alone kept psi_est and put the head 2.0 m off; one
    count's worth of bearing error makes the fix err by 68 x 0.096 mrad = 6.5 mrad at most,
    far less than the 130 mrad psi_est is off, so the fix is taken."""
    reflectors = np.array([[-2.896, 3.111], [-1.7, -2.307], [9.317, -4.906]])
    position, heading = np.array([5.9376, 9.1645]), -0.4954
    assert jacobian_gains(reflectors, position)[1] == pytest.approx(68.44, abs=0.01)
    estimate = heading + math.radians(7.47)
    x, y, psi, status = triangulate(
        reflectors, true_bearings(reflectors, position, heading), estimate
    )
    assert status == FIX and math.hypot(x - position[0], y - position[1]) < 1e-9
    assert angle_error(psi, heading) < 1e-11
    bearings, _ = LaserHead().measure([*position, heading], reflectors)
    x, y, psi, status = triangulate(reflectors, bearings, estimate)
    assert status == FIX and angle_error(psi, heading) <= 68.5 * RESOLUTION
    position_gain = jacobian_gains(reflectors, position)[0]
    assert math.hypot(x - position[0], y - position[1]) <= position_gain * RESOLUTION / 2


def test_garbage_bearings_never_give_nan_nor_raise():
    """In a control loop a bad sweep gives a finite, flagged fix: bearings that no pose gives
    (all lines parallel) hold the estimate, flagged NO_FIX."""
    rng = np.random.default_rng(1)
    statuses = set()
    for _ in range(2000):
        bearings = rng.uniform(-4, 4, 3)
        result = triangulate(TRIPLE, bearings, rng.uniform(-4, 4))
        assert all(map(math.isfinite, result))
        statuses.add(result.status)
    assert statuses <= {FIX, HEADING_KEPT, NO_FIX}
    for bearings in ([0.3, 0.3, 0.3], [0.3, 0.3 + math.pi, 0.3], [1.0, 1.0, 1.0 + 1e-12]):
        held = triangulate(TRIPLE, bearings, 0.2, position_estimate=(4.0, 5.0))
        assert held == (4.0, 5.0, pytest.approx(0.2), NO_FIX)
    assert triangulate(TRIPLE, [0.3, 0.3, 0.3], 7.0).heading == pytest.approx(7.0 - 2 * math.pi)


def test_sensitivity_is_the_inverse_jacobian():
    for position in ([3.0, 4.0], [12.0, 0.5], [6.0, 13.0]):
        position_gain, heading_gain = bearing_sensitivity(TRIPLE, position)
        assert (position_gain, heading_gain) == pytest.approx(jacobian_gains(TRIPLE, position))
    batch = bearing_sensitivity(TRIPLE, [[3.0, 4.0], [12.0, 0.5]])
    assert batch[0].shape == (2,)


# ---------------------------------------------------------------- quantization


def quantized_fix_errors(reflectors, positions, rng, walls=None):
    """Per position: (position error, its first-order bound, heading error, its bound) of a
    fix from 65535-count bearings, psi_est up to 30 degrees off, the bound that of the
    triple with the smallest position gain among the visible reflectors."""
    head = LaserHead()
    rows = []
    for position in positions:
        heading = rng.uniform(-math.pi, math.pi)
        bearings, visible = head.measure([*position, heading], reflectors, walls)
        seen = reflectors[visible]
        x, y, psi, _ = triangulate(seen, bearings[visible], heading + rng.uniform(-0.5, 0.5))
        position_gain, heading_gain = best_triple_gains(seen, position)
        rows.append(
            (
                math.hypot(x - position[0], y - position[1]),
                RESOLUTION / 2 * position_gain,
                angle_error(psi, heading),
                RESOLUTION * heading_gain,
            )
        )
    return np.array(rows)


def test_quantized_bearings_stay_within_the_predicted_millimetres_on_one_triple():
    rng = np.random.default_rng(2)
    positions = [p for p in course_area_grid(0.5) if jacobian_gains(TRIPLE, p)[1] <= 50]
    errors = quantized_fix_errors(TRIPLE, positions, rng)
    # Second-order terms are far below the first-order bound: 2 % of slack.
    assert (errors[:, 0] <= 1.02 * errors[:, 1]).all()
    assert (errors[:, 2] <= 1.02 * errors[:, 3]).all()
    assert np.median(errors[:, 0]) > 0.05 * np.median(errors[:, 1])  # the bound is not loose


def test_quantized_fixes_over_the_course_area_stay_within_1_2_mm():
    """The open layout's six reflectors: the best triple everywhere on the 0-13 m plot, the
    whole area within the bound and the bound within 1.2 mm."""
    rng = np.random.default_rng(3)
    errors = quantized_fix_errors(OPEN_AREA_REFLECTORS, course_area_grid(0.5), rng)
    assert (errors[:, 0] <= 1.02 * errors[:, 1]).all()
    assert (errors[:, 2] <= 1.02 * errors[:, 3]).all()
    assert errors[:, 1].max() < 1.2e-3
    assert errors[:, 3].max() < 1.6 * RESOLUTION


def maze_route_samples(offsets=(-0.3, 0.0, 0.3), per_leg=12):
    """Points along the canonical maze's route and beside it, ``offsets`` metres left."""
    points = the_maze().path.points
    samples = []
    for start, end in itertools.pairwise(points):
        along = end - start
        left = np.array([-along[1], along[0]]) / np.hypot(*along)
        for fraction in np.linspace(0.0, 1.0, per_leg, endpoint=False):
            samples.extend(start + fraction * along + offset * left for offset in offsets)
    return np.array(samples)


def test_maze_posts_give_three_reflectors_past_the_walls_all_along_the_route():
    track = the_maze()
    posts = default_reflectors("maze")
    samples = maze_route_samples()
    visible = visible_reflectors(samples, posts, track.maze.walls)
    assert visible.sum(axis=1).min() >= 8
    rng = np.random.default_rng(4)
    errors = quantized_fix_errors(posts, samples[::5], rng, walls=track.maze.walls)
    assert (errors[:, 0] <= 1.02 * errors[:, 1]).all()
    assert errors[:, 1].max() < 0.2e-3


def test_the_lab_layout_fixes_seed_003s_run_within_half_a_millimetre():
    path = arc_straight_path()
    # The head at O, which trails the drive wheel by 1 m, and at C, along the whole run.
    positions = np.vstack((path.points, path.points - [0.0, 1.0]))
    rng = np.random.default_rng(5)
    errors = quantized_fix_errors(LAB_REFLECTORS, positions, rng)
    assert (errors[:, 0] <= 1.02 * errors[:, 1]).all()
    assert errors[:, 1].max() < 0.5e-3


def test_every_registered_path_set_has_a_layout_covering_its_paths():
    for name in path_set_names():
        reflectors = default_reflectors(name)
        assert reflectors.ndim == 2 and reflectors.shape[1] == 2 and len(reflectors) >= 3
    for name in ("segments", "sharp_segments", "diagonal_line"):
        for point in course_path(name).points:
            assert best_triple_gains(OPEN_AREA_REFLECTORS, point)[0] * RESOLUTION / 2 < 1.2e-3
    with pytest.raises(ValueError, match="path_set_name"):
        default_reflectors("moon")


# ---------------------------------------------------------------- occlusion


def crosses_before_reflector(head, reflector, wall):
    """Exact (rational) test: does the wall meet the closed segment head-reflector anywhere
    but at the reflector itself? Walls seen edge-on (parallel to the sight) do not count."""
    h, r = [Fraction(v) for v in head], [Fraction(v) for v in reflector]
    a, b = [Fraction(v) for v in wall[:2]], [Fraction(v) for v in wall[2:]]
    sight = (r[0] - h[0], r[1] - h[1])
    along = (b[0] - a[0], b[1] - a[1])
    denominator = sight[0] * along[1] - sight[1] * along[0]
    if denominator == 0:
        return False
    to = (a[0] - h[0], a[1] - h[1])
    t = (to[0] * along[1] - to[1] * along[0]) / denominator
    u = (to[0] * sight[1] - to[1] * sight[0]) / denominator
    return 0 <= u <= 1 and 0 <= t < 1


def brute_force_visible(head, reflectors, walls):
    visible = []
    for reflector in reflectors:
        candidates = [
            wall
            for wall in walls
            if min(wall[0], wall[2]) <= max(head[0], reflector[0])
            and max(wall[0], wall[2]) >= min(head[0], reflector[0])
            and min(wall[1], wall[3]) <= max(head[1], reflector[1])
            and max(wall[1], wall[3]) >= min(head[1], reflector[1])
        ]
        visible.append(not any(crosses_before_reflector(head, reflector, w) for w in candidates))
    return np.array(visible)


def test_occlusion_matches_exact_segment_intersection_among_random_walls():
    rng = np.random.default_rng(6)
    starts = rng.uniform(0, 10, (25, 2))
    walls = np.hstack((starts, starts + rng.uniform(-2, 2, (25, 2))))
    reflectors = rng.uniform(0, 10, (12, 2))
    heads = rng.uniform(0, 10, (60, 2))
    visible = visible_reflectors(heads, reflectors, walls)
    for head, row in zip(heads, visible, strict=True):
        assert np.array_equal(row, brute_force_visible(head, reflectors, walls))
    assert 0.1 < visible.mean() < 0.9


def test_occlusion_matches_exact_segment_intersection_in_the_maze():
    """Posts sit on wall ends: their own walls must not hide them, the others must."""
    maze = the_maze().maze
    walls = maze.walls.reshape(-1, 4)
    posts = default_reflectors("maze")
    rng = np.random.default_rng(7)
    cells = rng.integers(0, 8, (25, 2))
    heads = (cells + rng.uniform(0.05, 0.95, (25, 2))) * maze.cell_size
    visible = visible_reflectors(heads, posts, maze.walls)
    for head, row in zip(heads, visible, strict=True):
        assert np.array_equal(row, brute_force_visible(head, posts, walls))
        corners = np.floor(head / maze.cell_size) * maze.cell_size
        for corner in corners + maze.cell_size * np.array([[0, 0], [0, 1], [1, 0], [1, 1]]):
            assert row[np.flatnonzero((posts == corner).all(axis=1))[0]]


def test_a_reflector_behind_a_wall_is_not_used_and_too_few_give_no_fix():
    head = LaserHead(counts_per_revolution=None)
    reflectors = np.array([[0.0, 5.0], [5.0, 5.0], [6.0, -1.0], [-3.0, -3.0]])
    wall = np.array([[-2.0, -1.0, -1.0, -2.0]])  # hides the fourth one from the origin
    bearings, visible = head.measure([0.0, 0.0, 0.2], reflectors, wall)
    assert visible.tolist() == [True, True, True, False]
    out = np.full(3, 7.0)
    status = triangulate_robot(reflectors, bearings, visible, 0.25, 50.0, RESOLUTION, out)
    assert status == FIX
    np.testing.assert_allclose(out, [0.0, 0.0, 0.2], atol=1e-12)
    visible[1] = False
    out = np.full(3, 7.0)
    assert triangulate_robot(reflectors, bearings, visible, 0.25, 50.0, RESOLUTION, out) == NO_FIX
    assert (out == 7.0).all()  # untouched
    far = LaserHead(max_range=6.5).measure([0.0, 0.0, 0.2], reflectors)[1]
    assert far.tolist() == [True, False, True, True]


def test_kept_heading_is_reported_by_the_kernel():
    centre, radius = np.array([0.0, 0.0]), 5.0
    angles = np.radians([10.0, 130.0, 250.0, 60.0])
    reflectors = radius * np.column_stack((np.cos(angles), np.sin(angles)))
    bearings = true_bearings(reflectors[:3], reflectors[3], 0.0)
    out = np.empty(3)
    status = triangulate_robot(
        reflectors[:3], bearings, np.ones(3, bool), 0.1, 50.0, RESOLUTION, out
    )
    assert status == HEADING_KEPT and out[2] == pytest.approx(0.1)
    assert math.hypot(*(out[:2] - centre)) == pytest.approx(radius)


# ---------------------------------------------------------------- the head while moving


def test_each_reading_is_the_beam_angle_and_the_true_bearing_at_its_instant():
    head = LaserHead(counts_per_revolution=None, offset=(0.4, -0.1))
    pose, speed, yaw_rate, start = np.array([1.0, 2.0, 0.5]), 0.8, -0.6, 1.0
    twist = (speed, yaw_rate)
    bearings, times, visible, end = head.sweep(pose, twist, LAB_REFLECTORS, None, start)
    assert visible.all() and (times >= 0).all() and (times < head.period).all()
    spin = 2 * math.pi * head.frequency
    for bearing, t, reflector in zip(bearings, times, LAB_REFLECTORS, strict=True):
        assert angle_error(bearing, start + spin * t) < 1e-9
        # The pose at t along the arc of constant curvature, by its circle's centre.
        radius = speed / yaw_rate
        turn = yaw_rate * t
        x = pose[0] + radius * (math.sin(pose[2] + turn) - math.sin(pose[2]))
        y = pose[1] - radius * (math.cos(pose[2] + turn) - math.cos(pose[2]))
        heading = pose[2] + turn
        head_x = x + 0.4 * math.cos(heading) + 0.1 * math.sin(heading)
        head_y = y + 0.4 * math.sin(heading) - 0.1 * math.cos(heading)
        expected = math.atan2(reflector[1] - head_y, reflector[0] - head_x) - heading
        assert angle_error(bearing, expected) < 1e-9
    assert end == pytest.approx(start)  # a whole revolution


def test_a_head_moving_sideways_reads_the_true_bearing_at_each_instant():
    """The holonomic robot's screw: a constant body twist (v_x, v_y, omega) turns the body
    about its instantaneous centre p + R(theta) (-v_y, v_x) / omega."""
    head = LaserHead(counts_per_revolution=None, offset=(0.3, 0.2))
    pose, (v_x, v_y, omega), start = np.array([2.0, 1.0, -0.7]), (0.4, -0.6, 1.5), 2.0
    bearings, times = np.empty(5), np.empty(5)
    visible = np.empty(5, dtype=bool)
    reflectors = np.ascontiguousarray(LAB_REFLECTORS)
    end = sweep_screw_bearings(
        pose, v_x, v_y, omega, start, head.period, reflectors, np.zeros((0, 4)),
        head.kernel_parameters, bearings, times, visible,
    )  # fmt: skip
    assert visible.all() and end == pytest.approx(start)
    spin = 2 * math.pi * head.frequency
    rotation = np.array(
        [[math.cos(pose[2]), -math.sin(pose[2])], [math.sin(pose[2]), math.cos(pose[2])]]
    )
    centre = pose[:2] + rotation @ np.array([-v_y, v_x]) / omega
    for bearing, t, reflector in zip(bearings, times, reflectors, strict=True):
        assert angle_error(bearing, start + spin * t) < 1e-9
        turn = omega * t
        spin_about = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
        position = centre + spin_about @ (pose[:2] - centre)
        heading = pose[2] + turn
        head_point = position + np.array(
            [0.3 * math.cos(heading) - 0.2 * math.sin(heading),
             0.3 * math.sin(heading) + 0.2 * math.cos(heading)]
        )  # fmt: skip
        offset = reflector - head_point
        assert angle_error(bearing, math.atan2(offset[1], offset[0]) - heading) < 1e-9


def test_a_prior_position_gives_the_exact_fix_and_a_poor_prior_stays_finite():
    """With the true position as prior the best triple fixes exactly; a prior 1 m off may
    pick a worse triple, whose fix is still exact unless the head is near its critical
    circle, where the heading is kept: finite either way."""
    rng = np.random.default_rng(11)
    reflectors = np.ascontiguousarray(OPEN_AREA_REFLECTORS)
    out = np.empty(3)
    statuses = []
    for position in course_area_grid(step=1.0):
        heading = rng.uniform(-math.pi, math.pi)
        bearings = true_bearings(reflectors, position, heading)
        estimate = heading + rng.uniform(-0.3, 0.3)
        for prior in (position, position + rng.uniform(-1.0, 1.0, 2)):
            status = triangulate_near(
                reflectors, bearings, len(reflectors), *prior, estimate,
                DEFAULT_MAX_HEADING_GAIN, RESOLUTION, out,
            )  # fmt: skip
            statuses.append(status)
            assert status in (FIX, HEADING_KEPT) and np.isfinite(out).all()
            if status == FIX:
                np.testing.assert_allclose(out[:2], position, atol=1e-7)
                assert angle_error(out[2], heading) < 1e-9
    assert statuses[::2] == [FIX] * (len(statuses) // 2)  # every true prior fixes
    assert (
        triangulate_near(reflectors, np.zeros(6), 2, 0.0, 0.0, 0.0, 50.0, RESOLUTION, out) == NO_FIX
    )


def test_standing_still_a_sweep_reads_what_measure_reads():
    head = LaserHead()
    pose = [2.0, 1.0, -0.4]
    bearings, times, visible, _ = head.sweep(pose, (0.0, 0.0), LAB_REFLECTORS)
    still, seen = head.measure(pose, LAB_REFLECTORS)
    assert np.array_equal(bearings, still) and np.array_equal(visible, seen)
    spin = 2 * math.pi * head.frequency
    # The beam reaches each reflector within a count after the count it reads.
    assert ((times - still / spin) >= 0).all() and (
        (times - still / spin) < RESOLUTION / spin
    ).all()
    short = head.sweep(pose, (0.0, 0.0), LAB_REFLECTORS, duration=0.5 * head.period)[2]
    assert short.tolist() == (times < 0.5 * head.period).tolist()


def moving_sweep(head, estimate_error):
    """A sweep while driving seed 003's arc at 0.2 m/s; the reference pose is the last
    reading's, estimated with ``estimate_error`` added."""
    pose, speed, yaw_rate = np.array([1.0, 0.5, 1.2]), 0.2, -0.2 / 1.24
    bearings, times, visible, _ = head.sweep(pose, (speed, yaw_rate), LAB_REFLECTORS, None, 0.3)
    assert visible.all()
    reference_time = times.max()
    turn = yaw_rate * reference_time
    chord = speed * reference_time * math.sin(turn / 2) / (turn / 2)
    middle = pose[2] + turn / 2
    reference = pose + np.array([chord * math.cos(middle), chord * math.sin(middle), turn])
    relative = twist_relative_poses(speed, yaw_rate, times, reference_time)
    estimate = reference + np.asarray(estimate_error)
    corrected = correct_bearings(LAB_REFLECTORS, bearings, relative, estimate, head)
    return bearings, corrected, reference, estimate


def fix_error(head, bearings, reference, estimate):
    x, y, psi, _ = triangulate(LAB_REFLECTORS, bearings, estimate[2])
    true_head = head.head_position(reference)
    return math.hypot(x - true_head[0], y - true_head[1]), angle_error(psi, reference[2])


def test_correcting_a_moving_sweep_to_one_pose_makes_the_fix_exact():
    head = LaserHead(counts_per_revolution=None, offset=(0.5, 0.0))
    raw, corrected, reference, estimate = moving_sweep(head, (0.0, 0.0, 0.0))
    assert fix_error(head, corrected, reference, estimate)[0] < 1e-9
    assert fix_error(head, raw, reference, estimate)[0] > 5e-3  # 2.5 cm driven in a sweep


def test_the_correction_tolerates_an_odometric_estimate_off_by_5_cm_and_a_degree():
    head = LaserHead(offset=(0.5, 0.0))
    raw, corrected, reference, estimate = moving_sweep(head, (0.05, -0.05, math.radians(1)))
    corrected_error, corrected_heading = fix_error(head, corrected, reference, estimate)
    raw_error, raw_heading = fix_error(head, raw, reference, estimate)
    assert corrected_error < 1e-3 < 10 * corrected_error < raw_error
    assert corrected_heading < 0.2e-3 < raw_heading


# ---------------------------------------------------------------- validation


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"frequency": 0.0}, "frequency"),
        ({"frequency": math.nan}, "frequency"),
        ({"counts_per_revolution": 0}, "counts_per_revolution"),
        ({"counts_per_revolution": 1.5}, "counts_per_revolution"),
        ({"counts_per_revolution": True}, "counts_per_revolution"),
        ({"max_range": -1.0}, "max_range"),
        ({"offset": (0.0, 0.0, 0.0)}, "offset"),
        ({"offset": (math.inf, 0.0)}, "offset"),
    ],
)
def test_bad_head_settings_raise_value_errors_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        LaserHead(**kwargs)


@pytest.mark.parametrize(
    ("arguments", "name"),
    [
        ((TRIPLE[:2], [0.0, 1.0], 0.0), "reflectors"),
        (([[0, 0], [1, 1], [2, 2]], [0.0, 1.0, 2.0], 0.0), "collinear"),
        ((TRIPLE, [0.0, 1.0], 0.0), "bearings"),
        ((TRIPLE, [0.0, 1.0, math.nan], 0.0), "bearings"),
        ((TRIPLE, [0.0, 1.0, 2.0], math.inf), "heading_estimate"),
        ((TRIPLE, [0.0, 1.0 + 2j, 2.0], 0.0), "bearings"),  # was cast to 1.0, with a warning
        ((TRIPLE, ["0", "1", "2"], 0.0), "bearings"),  # was read as numbers
    ],
)
def test_bad_triangulation_input_raises_value_errors_naming_it(arguments, name):
    with pytest.raises(ValueError, match=name):
        triangulate(*arguments)
    with pytest.raises(ValueError, match="max_heading_gain"):
        triangulate(TRIPLE, [0.0, 1.0, 2.0], 0.0, max_heading_gain=0.0)
    for error in (-1e-3, math.nan, [1e-4, 1e-4]):
        with pytest.raises(ValueError, match="bearing_error"):
            triangulate(TRIPLE, [0.0, 1.0, 2.0], 0.0, bearing_error=error)
    for estimate in ((0.0,), (0.0, math.inf), "here"):
        with pytest.raises(ValueError, match="position_estimate"):
            triangulate(TRIPLE, [0.0, 1.0, 2.0], 0.0, position_estimate=estimate)
    with pytest.raises(ValueError, match="heading_estimate"):
        triangulate(TRIPLE, [0.0, 1.0, 2.0], [0.0, 1.0])


def test_other_bad_input_raises_value_errors_naming_it():
    with pytest.raises(ValueError, match="walls"):
        visible_reflectors([0.0, 0.0], TRIPLE, np.zeros((3, 3)))
    with pytest.raises(ValueError, match="points"):
        visible_reflectors([0.0, 0.0, 0.0], TRIPLE)
    with pytest.raises(ValueError, match="reflectors"):
        validate_reflectors([[0.0, 0.0], [1.0, math.nan], [2.0, 0.0]])
    with pytest.raises(ValueError, match="relative_poses"):
        correct_bearings(TRIPLE, [0.0, 1.0, 2.0], np.zeros((3, 2)), [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="twists"):
        LaserHead().sweep(np.zeros((2, 3)), np.zeros((3, 2)), TRIPLE)
    with pytest.raises(ValueError, match="duration"):
        LaserHead().sweep(np.zeros(3), np.zeros(2), TRIPLE, duration=-1.0)
    layout = validate_reflectors(TRIPLE)
    assert not layout.flags.writeable and np.array_equal(layout, TRIPLE)

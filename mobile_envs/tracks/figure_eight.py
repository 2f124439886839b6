"""A figure eight: the lemniscate of Bernoulli across the course's area, a path that crosses
itself, with ids for every model (``mobile_envs/<Model>-FigureEight-v0``) and its localized
ids, beacons included."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from mobile_envs._kernels import exact_math
from mobile_envs.tracks.catalogue import register_path_set
from mobile_envs.tracks.course import OPEN_AREA_REFLECTORS
from mobile_envs.tracks.sets import FixedPathSet, PathSet, Track
from mobile_envs.world.paths import Path

#: The lemniscate's centre, where it crosses itself, and its half-width a (m): it spans
#: x in [1, 12] m, y in 6.5 +- a / (2 sqrt 2) = [4.56, 8.44] m, inside the course's area.
FIGURE_EIGHT_CENTRE = (6.5, 6.5)
FIGURE_EIGHT_HALF_WIDTH = 5.5
#: Segments of the polyline, at equal steps of the parameter t: chords of 6-9 cm. Not a
#: multiple of 4, so the crossing falls inside two segments rather than on vertices.
FIGURE_EIGHT_SEGMENTS = 402


def lemniscate_points(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Points of the lemniscate of Bernoulli of half-width a centred at (c_x, c_y):
    x = c_x + a cos t / (1 + sin^2 t), y = c_y + a sin t cos t / (1 + sin^2 t).

    t = 0 is the right tip, t = pi / 2 and 3 pi / 2 the centre (crossed heading south-west,
    then south-east), t = pi the left tip: the right lobe turns counter-clockwise, the left
    clockwise. The curvature is 3 r / a^2 at distance r from the centre, at most 3 / a at
    the tips; the length 2 varpi a, varpi = Gamma(1/4)^2 / (2 sqrt(2 pi)) the lemniscate
    constant.

    :return: (len(t), 2) points (m)
    """
    a = FIGURE_EIGHT_HALF_WIDTH
    # The C library's sin and cos (exact_math), the same bits on every CPU.
    sin_t, cos_t = exact_math.sin(t), exact_math.cos(t)
    scale = a / (1.0 + sin_t**2)
    x = FIGURE_EIGHT_CENTRE[0] + scale * cos_t
    y = FIGURE_EIGHT_CENTRE[1] + scale * sin_t * cos_t
    return np.column_stack((x, y))


def figure_eight_path() -> Path:
    """Once round the figure eight from its right tip, (12, 6.5), heading north (its
    tangent), back to the tip: :data:`FIGURE_EIGHT_SEGMENTS` chords at equal steps of t."""
    t = np.linspace(0.0, 2.0 * math.pi, FIGURE_EIGHT_SEGMENTS + 1)
    points = lemniscate_points(t)
    points[-1] = points[0]  # closed exactly
    return Path(points, name="figure_eight", start_heading=math.pi / 2)


def figure_eight_set() -> PathSet:
    """The figure eight, in the course's area and its reflectors."""
    return FixedPathSet("figure_eight", [Track(figure_eight_path())], OPEN_AREA_REFLECTORS)


register_path_set(
    "figure_eight", figure_eight_set, env_id="FigureEight", env_kwargs={"start_noise": 0.0}
)

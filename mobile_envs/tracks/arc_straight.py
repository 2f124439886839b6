"""Seed 003's run: the arc-and-straight path of Font-Llagunes & Batlle (2006), in their
laboratory's reflectors, with ids for the tricycle they drove it with."""

from __future__ import annotations

import numpy as np

from mobile_envs.tracks.catalogue import register_path_set
from mobile_envs.tracks.sets import FixedPathSet, PathSet, Track
from mobile_envs.world.paths import arc_straight_path

#: Seed 003's laboratory for the ``arc_straight`` run. The paper maps its reflectors (its
#: Fig. 6b) without coordinates, so this layout is ours: five reflectors on the walls of an
#: 8 m x 7 m room, x in [-1, 7], y in [-2, 5], around the run's 1.24 m arc and 3 m
#: straight. From anywhere in x in [0, 6], y in [-0.5, 3] the best triple fixes the
#: position within 0.5 mm of 65535-count quantization.
LAB_REFLECTORS = np.array([[3.0, -2.0], [6.5, -2.0], [7.0, 3.5], [-0.5, 5.0], [-1.0, -0.5]])
LAB_REFLECTORS.flags.writeable = False


def arc_straight_set() -> PathSet:
    """Seed 003's path (:func:`~mobile_envs.world.paths.arc_straight_path`) in its lab."""
    return FixedPathSet("arc_straight", [Track(arc_straight_path())], LAB_REFLECTORS)


register_path_set(
    "arc_straight",
    arc_straight_set,
    env_id="ArcStraight",
    # Seed 003 drove this run at 0.2 m/s, a third of the nominal speed that sets the default
    # time limit: allow three traversals at 0.2 m/s.
    env_kwargs={"step_limit": 750},
    env_models=("tricycle",),
    env_localizations=("beacons",),
)

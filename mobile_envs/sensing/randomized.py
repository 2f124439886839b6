"""Domain randomization over localizations: ``localization="randomized"``.

A policy that only ever trained with one localization, or with exact poses, meets a robot
whose odometry drifts faster or whose laser head reads worse than it learned. With
``localization="randomized"`` every robot draws, at each reset, one of several localization
*variants* (each a localization name and its settings) and keeps it for the episode, so the
policy meets them all, episode by episode::

    gym.make(
        "mobile_envs/DiffDrive-Random-v0",
        localization="randomized",
        localization_params={"variants": [
            {"localization": "exact"},
            {"localization": "odometry+beacons"},
            {"localization": "odometry+beacons", "k_distance": 4e-4, "bearing_noise": 0.002},
        ]},
    )

The draw is one ``integers(len(variants))`` from the robot's own generator, before anything
its variant draws, so a vector env of N robots still equals N single envs bit for bit.
:data:`DEFAULT_VARIANTS` is the spread the shipped policies train on.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mobile_envs.robots import KinematicModel
from mobile_envs.sensing.localization import (
    Array,
    Generators,
    Indices,
    Localization,
    LocalizationWorld,
    make_localization,
)
from mobile_envs.sensing.odometry import (
    DEFAULT_K_DISTANCE,
    DEFAULT_K_DISTANCE_HEADING,
    DEFAULT_K_HEADING,
)
from mobile_envs.tracks.sets import PathSet


def _noisier(scale: float, bearing_noise: float) -> dict[str, Any]:
    """odometry+beacons with eq. 17's three K ``scale`` times the seeds' defaults and a laser
    head that reads with ``bearing_noise`` (rad) beyond its count."""
    return {
        "localization": "odometry+beacons",
        "k_distance": scale * DEFAULT_K_DISTANCE,
        "k_distance_heading": scale * DEFAULT_K_DISTANCE_HEADING,
        "k_heading": scale * DEFAULT_K_HEADING,
        "bearing_noise": bearing_noise,
    }


#: The spread of :class:`RandomizedLocalization` by default: exact poses; the seeds'
#: odometry corrected by the beacons at its default settings; and twice the odometry's noise
#: (eq. 17's K) with a laser head that reads with 1 mrad of noise beyond its count. Every
#: setting not named is the localization's default. (Four times the noise and 2 mrad as a
#: fourth variant made the shipped recipes' policies too cautious: they missed pure
#: pursuit's mean |cte| on Lines and completed 90 % of the bicycle's Segments.)
DEFAULT_VARIANTS: tuple[dict[str, Any], ...] = (
    {"localization": "exact"},
    {"localization": "odometry+beacons"},
    _noisier(2.0, 0.001),
)


class ExactPose(Localization):
    """The robot knows its pose: the estimate is the true pose, at every reset and step (the
    ``"exact"`` variant of :class:`RandomizedLocalization`; an env without a localization
    needs none)."""

    def reset(
        self, world: LocalizationWorld, indices: Indices, rngs: Generators, estimate: Array
    ) -> None:
        estimate[indices] = world.state[indices, :3]

    def update(
        self, world: LocalizationWorld, indices: Indices, rngs: Generators, estimate: Array
    ) -> None:
        estimate[indices] = world.state[indices, :3]


def _variant(settings: object, position: int) -> Localization:
    """The localization variant ``settings`` (a mapping with ``"localization"``) describes."""
    where = f"localization_params variants[{position}]"
    if not isinstance(settings, Mapping):
        raise ValueError(f"{where} must be a mapping with a 'localization' name, got {settings!r}")
    parameters = dict(settings)
    name = parameters.pop("localization", None)
    if not isinstance(name, str):
        raise ValueError(f"{where} needs 'localization': a name, got {name!r}")
    if name == RandomizedLocalization.name:
        raise ValueError(f"{where}: a randomized localization cannot be one of its variants")
    try:
        built = make_localization(name, parameters)
    except ValueError as error:
        raise ValueError(f"{where}: {error}") from None
    return ExactPose() if built is None else built


class RandomizedLocalization(Localization):
    """A localization drawn for each robot at each reset from ``variants``:
    ``localization="randomized"``.

    Each robot draws its variant uniformly from its own generator (one
    ``integers(len(variants))``, before its variant's own draws) and keeps it until its next
    reset; the variant then resets and updates that robot's estimate as it would alone.
    :attr:`variant_of` tells which variant each robot drew.

    :param variants: mappings ``{"localization": name, **settings}``, each a localization
        ``make_localization`` builds (``"exact"`` included), at least one;
        :data:`DEFAULT_VARIANTS` by default
    :raises ValueError: for an empty list, a variant that is not such a mapping or has bad
        settings (naming its position), or variants whose steering encoders differ (the
        believed wheel angle is read the same way for every robot)
    """

    name = "randomized"

    def __init__(self, variants: Sequence[Mapping[str, Any]] = DEFAULT_VARIANTS):
        if isinstance(variants, (str, bytes, Mapping)) or not isinstance(variants, Sequence):
            raise ValueError(
                f"localization_params variants must be a list of mappings, got {variants!r}"
            )
        if len(variants) == 0:
            raise ValueError("localization_params variants must name at least one variant")
        self.variants = [_variant(settings, k) for k, settings in enumerate(variants)]
        #: Each variant's settings, as given.
        self.settings = [copy.deepcopy(dict(settings)) for settings in variants]
        steering = {settings.get("steering_counts") for settings in self.settings}
        if len(steering) > 1:
            raise ValueError(
                f"localization_params variants read the steering angle differently "
                f"(steering_counts {sorted(steering, key=str)}); give them all the same"
            )
        self.variant_of: NDArray[np.int64] = np.zeros(0, dtype=np.int64)

    def allocate(self, num_robots: int, model: KinematicModel, path_set: PathSet) -> None:
        for position, variant in enumerate(self.variants):
            try:
                variant.allocate(num_robots, model, path_set)
            except ValueError as error:
                raise ValueError(f"localization_params variants[{position}]: {error}") from None
        self.variant_of = np.zeros(num_robots, dtype=np.int64)

    def _groups(self, indices: Indices) -> list[tuple[Localization, NDArray[np.int64]]]:
        robots = np.asarray(indices, dtype=np.int64)
        drawn = self.variant_of[robots]
        groups = [
            (variant, robots[drawn == position]) for position, variant in enumerate(self.variants)
        ]
        return [(variant, group) for variant, group in groups if group.size]

    def reset(
        self, world: LocalizationWorld, indices: Indices, rngs: Generators, estimate: Array
    ) -> None:
        count = len(self.variants)
        for index in np.asarray(indices, dtype=np.int64).tolist():
            self.variant_of[index] = int(rngs[index].integers(count))
        for variant, robots in self._groups(indices):
            variant.reset(world, robots, rngs, estimate)

    def update(
        self, world: LocalizationWorld, indices: Indices, rngs: Generators, estimate: Array
    ) -> None:
        for variant, robots in self._groups(indices):
            variant.update(world, robots, rngs, estimate)

    def read_model_state(self, states: Array) -> Array:
        return self.variants[0].read_model_state(states)  # the same for all (checked)

    @property
    def landmarks(self) -> Array | None:
        for variant in self.variants:
            if variant.landmarks is not None:
                return variant.landmarks
        return None

    def sightings(self, index: int) -> Array:
        return self.variants[int(self.variant_of[index])].sightings(index)

"""The observation's layout: one table of blocks from which names, scales and writes derive.

An observation is, in order: the path block (preview points, tracking errors, twist), the
model's observed state (:attr:`mobile_envs.robots.model.KinematicModel.observed_state`), the
remaining fraction of the path, the previous action, then each sensor's readings
(:mod:`mobile_envs.sensing.sensors`). :class:`ObservationLayout` lays the blocks out once;
``observation_names``, the scales and the column offsets the compiled writer
(:func:`mobile_envs.sim.step.observe_robots`) uses all come from it.
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mobile_envs.robots import KinematicModel
from mobile_envs.sensing.sensors import Sensor

#: Preview points: K points ahead on the path at a fixed arc-length spacing.
PREVIEW_POINTS = 10
PREVIEW_SPACING = 0.25
#: Saturating, high-gain copies of the errors make centimetres visible to the policy: the
#: linear ones, scaled by the off-track distance, read 0.01 for 1 cm.
FINE_CROSS_TRACK = 0.05
FINE_HEADING = 0.1

TRACKING_NAMES = (
    "cross_track_error",
    "heading_error",
    "cross_track_error_fine",
    "heading_error_fine",
    "speed",
    "yaw_rate",
)


class PathScale(enum.IntEnum):
    """Entries of the scales array that the path block's elements are multiplied by."""

    PREVIEW = 0
    CROSS_TRACK = 1
    HEADING = 2
    FINE_CROSS_TRACK = 3
    FINE_HEADING = 4
    SPEED = 5
    YAW_RATE = 6


class LayoutEntry(enum.IntEnum):
    """Entries of the int64 layout array the compiled writer reads; after them come
    (source, column) pairs, one per observed model quantity."""

    MODEL_STATE = 0
    REMAINING_FRACTION = 1
    PREVIOUS_ACTION = 2
    SENSORS = 3
    OBSERVED_COUNT = 4


@dataclass(frozen=True)
class ObservationBlock:
    """A contiguous run of observation elements with one owner."""

    name: str
    names: tuple[str, ...]
    start: int

    @property
    def stop(self) -> int:
        return self.start + len(self.names)

    @property
    def slice(self) -> slice:
        return slice(self.start, self.stop)


def preview_offsets() -> NDArray[np.float64]:
    """Arc lengths (m) of the preview points ahead of the robot's projection."""
    return PREVIEW_SPACING * np.arange(1, PREVIEW_POINTS + 1, dtype=np.float64)


class ObservationLayout:
    """The observation of a model with sensors, block by block.

    :param model: the kinematic model (its input count and observed state)
    :param sensors: the sensors, in observation order
    :param max_cross_track: the off-track distance (m), which scales the path block
    """

    def __init__(self, model: KinematicModel, sensors: Sequence[Sensor], max_cross_track: float):
        preview = tuple(f"preview_{axis}_{k}" for k in range(PREVIEW_POINTS) for axis in "xy")
        observed = model.observed_state
        contents: list[tuple[str, tuple[str, ...]]] = [
            ("path", (*preview, *TRACKING_NAMES)),
            ("model_state", tuple(item.name for item in observed)),
            ("remaining_fraction", ("remaining_fraction",)),
            ("previous_action", tuple(f"previous_action_{k}" for k in range(model.input_dim))),
        ]
        contents += [(type(sensor).__name__, sensor.names) for sensor in sensors]
        blocks, start = [], 0
        for name, names in contents:
            blocks.append(ObservationBlock(name, names, start))
            start += len(names)
        self.blocks = tuple(blocks)
        self.sensor_blocks = self.blocks[4:]
        self.names = tuple(name for block in self.blocks for name in block.names)
        self.size = len(self.names)

        path_scales = np.empty(len(PathScale))
        path_scales[PathScale.PREVIEW] = 1.0 / (PREVIEW_SPACING * PREVIEW_POINTS + max_cross_track)
        path_scales[PathScale.CROSS_TRACK] = 1.0 / max_cross_track
        path_scales[PathScale.HEADING] = 1.0 / np.pi
        path_scales[PathScale.FINE_CROSS_TRACK] = 1.0 / FINE_CROSS_TRACK
        path_scales[PathScale.FINE_HEADING] = 1.0 / FINE_HEADING
        path_scales[PathScale.SPEED] = 1.0 / model.top_speed
        path_scales[PathScale.YAW_RATE] = 1.0 / model.top_yaw_rate
        #: float64 scales: the path block's (by :class:`PathScale`), the observed state's,
        #: then every sensor's.
        self.scales = np.concatenate(
            [
                path_scales,
                np.array([item.scale for item in observed], dtype=np.float64),
                *(np.asarray(sensor.scales, dtype=np.float64) for sensor in sensors),
            ]
        )
        layout = [0] * len(LayoutEntry)
        layout[LayoutEntry.MODEL_STATE] = self.blocks[1].start
        layout[LayoutEntry.REMAINING_FRACTION] = self.blocks[2].start
        layout[LayoutEntry.PREVIOUS_ACTION] = self.blocks[3].start
        layout[LayoutEntry.SENSORS] = self.blocks[4].start if sensors else self.size
        layout[LayoutEntry.OBSERVED_COUNT] = len(observed)
        for item in observed:
            layout += [item.source, item.column]
        #: int64 offsets and observed-state sources for the compiled writer.
        self.kernel_layout = np.array(layout, dtype=np.int64)

    def block(self, name: str) -> ObservationBlock:
        """The block called ``name`` (``"path"``, ``"model_state"``, ``"remaining_fraction"``,
        ``"previous_action"`` or a sensor's class name)."""
        for block in self.blocks:
            if block.name == name:
                return block
        raise KeyError(f"no observation block {name!r}; blocks: {[b.name for b in self.blocks]}")

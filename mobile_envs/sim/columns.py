"""Named columns of the core's packed per-robot arrays, and of the kernels' settings.

Every per-robot scalar of :class:`mobile_envs.sim.core.PathFollowingCore` lives in a column of one
of three packed arrays, ``floats``, ``ints`` and ``flags`` (N, columns): one array argument per
kind keeps the compiled kernels' calls short (a call costs about 30 ns per array argument).
Each column is named once, here, as a member of an :class:`~enum.IntEnum` whose value is its
index; the kernels index with the members (numba folds them to constants) and the core
exposes each column as a typed view of the same name (:class:`PackedColumn`), so an order
that drifts from a name cannot happen.
"""

from __future__ import annotations

import enum
from typing import Any, Generic, TypeVar, overload

import numpy as np
from numpy.typing import NDArray


class _Columns(enum.IntEnum):
    """Members numbered 0, 1, 2, ... in the order they are written."""

    @staticmethod
    def _generate_next_value_(name: str, start: int, count: int, last_values: list[Any]) -> int:
        return count


class FloatColumn(_Columns):
    """Columns of ``floats``: where the robot is on its path, its twist, episode sums."""

    ARC_LENGTH = enum.auto()
    CROSS_TRACK_ERROR = enum.auto()
    HEADING_ERROR = enum.auto()
    SPEED = enum.auto()
    YAW_RATE = enum.auto()
    PATH_LENGTH = enum.auto()
    PROGRESS = enum.auto()
    FARTHEST_ARC_LENGTH = enum.auto()
    SUM_ABS_CTE = enum.auto()
    SUM_SQ_CTE = enum.auto()
    MAX_ABS_CTE = enum.auto()
    # The largest |cross-track error| since the reset, the start pose's included (the
    # episode metric above starts after the first step), and this step's growth of it.
    PEAK_ABS_CTE = enum.auto()
    PEAK_GROWTH = enum.auto()
    DISTANCE = enum.auto()
    REWARD = enum.auto()
    # What the robot believes, when it localizes (mobile_envs.sensing.localization): its estimated
    # pose's projection, in the order of ARC_LENGTH, CROSS_TRACK_ERROR, HEADING_ERROR.
    ESTIMATED_ARC_LENGTH = enum.auto()
    ESTIMATED_CROSS_TRACK_ERROR = enum.auto()
    ESTIMATED_HEADING_ERROR = enum.auto()
    SUM_LOCALIZATION_ERROR = enum.auto()
    MAX_LOCALIZATION_ERROR = enum.auto()
    LOCALIZATION_ERROR = enum.auto()
    HEADING_LOCALIZATION_ERROR = enum.auto()


class IntColumn(_Columns):
    """Columns of ``ints``: the robot's path-table row, segment and step counters."""

    PATH_ROW = enum.auto()
    SEGMENT = enum.auto()
    STEPS = enum.auto()
    TIME_LIMIT = enum.auto()
    STEPS_WITHOUT_PROGRESS = enum.auto()
    ESTIMATED_SEGMENT = enum.auto()


class FlagColumn(_Columns):
    """Columns of ``flags``: the outcome of the robot's last step."""

    COLLISION = enum.auto()
    SUCCESS = enum.auto()
    OFF_TRACK = enum.auto()
    STALLED = enum.auto()
    TERMINATED = enum.auto()
    TRUNCATED = enum.auto()


class Setting(_Columns):
    """Entries of the kernels' ``settings`` array: the configuration as numbers."""

    DT = enum.auto()
    SEARCH_DISTANCE = enum.auto()
    GOAL_RADIUS = enum.auto()
    MAX_CROSS_TRACK = enum.auto()
    STALL_STEPS = enum.auto()
    STALL_PROGRESS = enum.auto()
    PROGRESS_WEIGHT = enum.auto()
    TIME_WEIGHT = enum.auto()
    CROSS_TRACK_WEIGHT = enum.auto()
    CROSS_TRACK_SQUARED_WEIGHT = enum.auto()
    HEADING_WEIGHT = enum.auto()
    ACTION_CHANGE_WEIGHT = enum.auto()
    PEAK_CROSS_TRACK_WEIGHT = enum.auto()
    GOAL_BONUS = enum.auto()
    FAILURE_PENALTY = enum.auto()


#: The packed array each kind of column lives in, by attribute name on the core.
PACKED_ARRAYS: dict[type[_Columns], str] = {
    FloatColumn: "floats",
    IntColumn: "ints",
    FlagColumn: "flags",
}

ScalarT = TypeVar("ScalarT", bound=np.generic)


class PackedColumn(Generic[ScalarT]):
    """A column of a packed array as an attribute: ``core.arc_length`` is
    ``core.floats[:, FloatColumn.ARC_LENGTH]``, a view (read and write through it).

    The column is the member of ``columns`` named like the attribute, so an attribute
    without a column (or a misspelt one) fails when the class is defined. The view is made
    at each access, never stored, so copies and pickles of the owner stay consistent.
    """

    def __init__(self, columns: type[_Columns]) -> None:
        self.columns = columns
        self.packed = PACKED_ARRAYS[columns]
        self.column = -1

    def __set_name__(self, owner: type, name: str) -> None:
        try:
            self.column = int(self.columns[name.upper()])
        except KeyError:
            raise TypeError(
                f"{owner.__name__}.{name} names no column of {self.columns.__name__}"
            ) from None

    @overload
    def __get__(self, owner: None, owner_type: type | None = None) -> PackedColumn[ScalarT]: ...

    @overload
    def __get__(self, owner: object, owner_type: type | None = None) -> NDArray[ScalarT]: ...

    def __get__(
        self, owner: object | None, owner_type: type | None = None
    ) -> NDArray[ScalarT] | PackedColumn[ScalarT]:
        if owner is None:
            return self
        packed: NDArray[ScalarT] = getattr(owner, self.packed)
        return packed[:, self.column]

    def __set__(self, owner: object, value: object) -> None:
        raise AttributeError(
            f"{self.packed} column views cannot be replaced; assign into them "
            f"(core.{self.columns(self.column).name.lower()}[...] = value)"
        )

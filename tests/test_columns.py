"""Packed per-robot columns: named once, indexed by name, exposed as typed views."""

import numpy as np
import pytest

from mobile_envs.sim.columns import FlagColumn, FloatColumn, IntColumn, PackedColumn, Setting
from mobile_envs.sim.core import PathFollowingCore


@pytest.mark.parametrize("columns", [FloatColumn, IntColumn, FlagColumn, Setting])
def test_columns_are_numbered_in_order_from_zero(columns):
    assert [int(member) for member in columns] == list(range(len(columns)))


@pytest.mark.parametrize("columns", [FloatColumn, IntColumn, FlagColumn])
def test_the_core_has_a_view_for_every_column(columns):
    for member in columns:
        assert isinstance(vars(PathFollowingCore)[member.name.lower()], PackedColumn)


def test_a_view_without_a_column_fails_when_the_class_is_defined():
    # Python < 3.12 wraps errors raised in __set_name__ in a RuntimeError.
    with pytest.raises((TypeError, RuntimeError)) as raised:

        class Misspelt:
            arc_lenght = PackedColumn[np.float64](FloatColumn)

    error = raised.value
    assert "names no column of FloatColumn" in f"{error} {error.__cause__}"


def test_views_read_and_write_the_packed_array_and_cannot_be_replaced():
    class Robots:
        arc_length = PackedColumn[np.float64](FloatColumn)
        steps = PackedColumn[np.int64](IntColumn)

        def __init__(self):
            self.floats = np.zeros((3, len(FloatColumn)))
            self.ints = np.zeros((3, len(IntColumn)), dtype=np.int64)

    robots = Robots()
    robots.arc_length[1] = 2.5
    robots.steps[:] = 7
    assert robots.floats[1, FloatColumn.ARC_LENGTH] == 2.5
    assert (robots.ints[:, IntColumn.STEPS] == 7).all()
    with pytest.raises(AttributeError, match="assign into them"):
        robots.arc_length = np.ones(3)

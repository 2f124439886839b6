"""The package's one set of checks of user-given numbers (mobile_envs/validation.py).

Each check either returns the value in the type the code uses or raises a ValueError whose
message starts with the setting's name; nothing else escapes, whatever the value (an int
beyond float64 once raised OverflowError from five modules' own copies of these checks).
"""

import math

import numpy as np
import pytest

from mobile_envs.validation import (
    MAX_COUNT,
    as_choice,
    as_count,
    as_in_open_interval,
    as_limit,
    as_non_negative,
    as_optional_count,
    as_positive,
    as_real,
)

HUGE = 10**400  # beyond float64: float() raises OverflowError
NOT_NUMBERS = [True, np.True_, None, "0.5", b"1", 1j, [0.5], np.array([0.5]), object()]
CHECKS = [
    as_real,
    as_positive,
    as_non_negative,
    as_count,
    as_optional_count,
    as_limit,
    lambda name, value: as_in_open_interval(name, value, -1.0, 1.0, "(-1, 1)"),
]


@pytest.mark.parametrize("check", CHECKS)
@pytest.mark.parametrize(
    "value", [*NOT_NUMBERS, math.nan, pytest.param(-HUGE, id="-10**400"), -math.inf], ids=repr
)
def test_every_check_refuses_what_is_no_usable_number_naming_the_setting(check, value):
    if check is as_optional_count and value is None:
        assert check("k_setting", value) is None  # None is "not kept", by design
        return
    with pytest.raises(ValueError, match=r"^k_setting must "):
        check("k_setting", value)


@pytest.mark.parametrize("check", [as_real, as_positive, as_non_negative, as_count])
@pytest.mark.parametrize(
    "value",
    [pytest.param(HUGE, id="10**400"), math.inf, np.float64(math.inf), np.longdouble("1e400")],
    ids=repr,
)
def test_numbers_beyond_float64_are_refused_as_not_finite(check, value):
    with pytest.raises(ValueError, match=r"^setting must "):
        check("setting", value)


@pytest.mark.parametrize(
    "value", [pytest.param(HUGE, id="10**400"), math.inf, np.float32(math.inf)], ids=repr
)
def test_a_limit_beyond_float64_is_no_limit(value):
    assert as_limit("max_speed", value) == math.inf


@pytest.mark.parametrize(
    ("value", "expected"),
    [(0.25, 0.25), (3, 3.0), (np.float32(0.5), 0.5), (np.int8(-4), -4.0), (10**20, 1e20)],
)
def test_reals_come_back_as_python_floats(value, expected):
    number = as_real("setting", value)
    assert type(number) is float and number == expected


def test_the_bounds_are_where_the_names_say():
    assert as_non_negative("k", 0) == 0.0 and as_non_negative("k", -0.0) == 0.0
    # -0.0 comes back without its sign: numpy's uniform(0.0, -0.0) refuses the range
    assert math.copysign(1.0, as_non_negative("k", -0.0)) == 1.0
    with pytest.raises(ValueError, match=r"^k must be a number >= 0"):
        as_non_negative("k", -5e-324)
    with pytest.raises(ValueError, match=r"^k must be a positive number"):
        as_positive("k", 0.0)
    assert as_positive("k", 5e-324) == 5e-324
    assert as_non_negative("angle", math.pi, math.pi) == math.pi
    with pytest.raises(ValueError, match=r"^angle must be at most 3.14159 rad \(why\)"):
        as_non_negative("angle", math.nextafter(math.pi, 4.0), math.pi, " rad", "why")
    with pytest.raises(ValueError, match=r"^e must lie in"):
        as_in_open_interval("e", 1.0, -1.0, 1.0, "(-1, 1)")


def test_counts_are_whole_numbers_within_their_range():
    assert as_count("n", 25.0) == 25 and type(as_count("n", np.uint8(7))) is int
    assert as_count("n", MAX_COUNT) == MAX_COUNT
    for bad in (0, 2.5, MAX_COUNT + 1, float(2**63)):
        with pytest.raises(ValueError, match=r"^n must be"):
            as_count("n", bad)
    assert as_count("readings", 3, minimum=3) == 3
    with pytest.raises(ValueError, match=r"^readings must be an integer >= 3, got 2"):
        as_count("readings", 2, minimum=3)
    with pytest.raises(ValueError, match=r"^n must be a positive integer, got 0"):
        as_count("n", 0)
    with pytest.raises(ValueError, match=r"^n must be at most 8, got 9"):
        as_count("n", 9, maximum=8)
    with pytest.raises(ValueError, match=r"^readings must be an integer >= 3"):
        as_count("readings", None, minimum=3)
    assert as_optional_count("counts", None) is None and as_optional_count("counts", 8.0) == 8


def test_a_choice_is_one_of_the_names_and_nothing_that_merely_compares_equal():
    assert as_choice("method", "exact", ("euler", "exact")) == "exact"
    # An array made "not in" raise numpy's "truth value of an array is ambiguous" error.
    for bad in ("rk4", np.array(["exact", "euler"]), ["exact"], None, 3):
        with pytest.raises(ValueError, match=r"^method must be one of \('euler', 'exact'\)"):
            as_choice("method", bad, ("euler", "exact"))

"""Fuzzing the plant argument: whatever a user writes, a clean run or a ValueError naming the
plant's key, never a NaN, a hang or another exception (the strategies and checks of
tests/test_fuzz.py; ``python benchmarks/fuzz_long.py`` runs them longer)."""

from __future__ import annotations

import math
from typing import Any

import pytest

pytest.importorskip("hypothesis", reason="the fuzz suite needs hypothesis (the dev extra)")

from hypothesis import given, settings
from hypothesis import strategies as st
from test_fuzz import CI, assert_clean_run, record, setting_values

from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.robots import MODELS
from mobile_envs.sim.plant import PRESETS

#: What a user may pass for a plant's sizes: plausible ones and every kind of wrong one.
sizes = st.one_of(
    st.sampled_from((0.0, 0.1, 0.2, 0.3, 0.05, 0.15, 1e-12)),
    setting_values,
)
ranges = st.one_of(
    st.tuples(sizes, sizes),
    st.lists(sizes, max_size=3),
    sizes,
)


@st.composite
def plants(draw: Any) -> tuple[Any, str]:
    """A plant argument and the model it goes with."""
    model = draw(st.sampled_from(sorted(MODELS)))
    kind = draw(st.sampled_from(("preset", "dict", "dict", "dict", "other")))
    if kind == "preset":
        return draw(st.sampled_from((*PRESETS, "bumpy", ""))), model
    if kind == "other":
        return draw(st.sampled_from((3, [0.1], ("delay",), math.nan))), model
    keys = draw(
        st.sets(
            st.sampled_from(
                ("delay", "time_constant", "parameter_errors", "slip", "randomize", "gusts")
            ),
            max_size=4,
        )
    )
    plant: dict[str, Any] = {}
    errors = (*MODELS[model].parameter_errors, "wheel_radius", "bogus")
    for key in keys:
        if key == "parameter_errors":
            names = draw(st.sets(st.sampled_from(errors), max_size=3))
            plant[key] = {name: draw(sizes) for name in names}
        elif key == "slip":
            plant[key] = draw(st.one_of(st.tuples(sizes, sizes, sizes), ranges))
        elif key == "randomize":
            randomized = draw(
                st.sets(
                    st.sampled_from(
                        ("delay", "time_constant", "parameter_errors", "steering_offset", "slip")
                    ),
                    max_size=3,
                )
            )
            plant[key] = {
                name: draw(sizes if name in ("parameter_errors", "steering_offset") else ranges)
                for name in randomized
            }
        else:
            plant[key] = draw(sizes)
    return plant, model


@settings(CI, max_examples=100)
@given(plants(), st.booleans())
def test_any_plant_runs_cleanly_or_is_refused_naming_it(plant_and_model, vector):
    plant, model = plant_and_model
    try:
        if vector:
            env: Any = PathFollowingVectorEnv(3, model, "segments", plant=plant)
        else:
            env = PathFollowingEnv(model, "segments", plant=plant)
    except ValueError as error:
        assert "plant" in str(error), f"ValueError: {error} does not name the plant"
        record("plant refused (ValueError)")
        return
    assert_clean_run(env, steps=6)
    record("plant ran")

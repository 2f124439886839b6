"""The observation layout: one table from which names, scales and the writes derive."""

import math

import numpy as np
import pytest

from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.robots import MODELS
from mobile_envs.sensing.sensors import RangeSensor
from mobile_envs.sim.observation import PREVIEW_POINTS, ObservationLayout

MODEL_NAMES = sorted(MODELS)


@pytest.mark.parametrize("model", MODEL_NAMES)
def test_blocks_tile_the_observation_in_the_documented_order(model):
    env = PathFollowingEnv(model, "segments")
    layout = env.config.layout
    assert [block.name for block in layout.blocks] == [
        "path",
        "model_state",
        "remaining_fraction",
        "previous_action",
        "RangeSensor",
    ]
    stops = [0] + [block.stop for block in layout.blocks]
    assert [block.start for block in layout.blocks] == stops[:-1]  # contiguous, no gaps
    assert layout.size == stops[-1] == env.observation_space.shape[0]
    # The documented size: D = 43 + m + e.
    extra = len(env.model.observed_state)
    assert layout.size == 43 + env.model.input_dim + extra
    assert layout.names[2 * PREVIEW_POINTS] == "cross_track_error"
    assert layout.names[layout.block("remaining_fraction").start] == "remaining_fraction"


@pytest.mark.parametrize("model", MODEL_NAMES)
def test_each_block_holds_what_its_names_say(model):
    """Elements read back through the layout's slices match the quantities they name."""
    env = PathFollowingEnv(model, "maze", start_noise=(0.1, 0.2))
    layout = env.config.layout
    rng = np.random.default_rng(0)
    env.reset(seed=2)
    for _ in range(30):
        action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        observation, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
        previous = observation[layout.block("previous_action").slice]
        np.testing.assert_array_equal(previous, action)
        remaining = observation[layout.block("remaining_fraction").slice][0]
        assert remaining == pytest.approx(1.0 - info["progress"], abs=1e-6)
        path = observation[layout.block("path").slice]
        assert path[2 * PREVIEW_POINTS] == pytest.approx(info["cross_track_error"], abs=1e-6)
        for value, observed in zip(
            observation[layout.block("model_state").slice], env.model.observed_state, strict=True
        ):
            source = env.core.state[0] if observed.source == 0 else env.core.inputs[0]
            assert value == pytest.approx(source[observed.column] * observed.scale, abs=1e-6)


def test_scales_follow_the_model_and_the_sensors():
    model = PathFollowingEnv("tricycle").model
    layout = ObservationLayout(model, [RangeSensor(rays=4, max_range=2.0)], max_cross_track=0.5)
    assert layout.names[-4:] == ("range_0", "range_1", "range_2", "range_3")
    # The path block's seven factors, then the wheel angle's, then the sensor's.
    assert layout.scales[0] == 1.0 / (0.25 * PREVIEW_POINTS + 0.5)
    assert layout.scales[5] == 1.0 / model.top_speed
    assert layout.scales[6] == 1.0 / model.top_yaw_rate
    assert layout.scales[7] == pytest.approx(1.0 / math.radians(85.0))
    np.testing.assert_array_equal(layout.scales[8:], [0.5] * 4)
    with pytest.raises(KeyError, match="no observation block"):
        layout.block("lidar")

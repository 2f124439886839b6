"""Delay-compensated control: the pose it steers from is the pose the robot has when the
command lands, and without delay it is the agent it wraps."""

import numpy as np
import pytest

from agents import PurePursuit, RegulatedPurePursuit, evaluate
from agents.controllers.delay_compensation import DelayCompensated
from mobile_envs.envs.path_following import PathFollowingEnv


class Recording(PurePursuit):
    """Pure pursuit that remembers the states it was asked to steer from."""

    def __init__(self) -> None:
        super().__init__()
        self.asked: list[np.ndarray] = []

    def inputs(self, state, model, dt):
        self.asked.append(np.array(state, dtype=np.float64))
        return super().inputs(state, model, dt)


@pytest.mark.parametrize("model", ["diff_drive", "tricycle", "mecanum"])
@pytest.mark.parametrize(("delay", "time_constant"), [(0.2, 0.0), (0.3, 0.15)])
def test_the_predicted_pose_is_where_the_robot_is_when_the_command_lands(
    model, delay, time_constant
):
    plant = {"delay": delay, "time_constant": time_constant}
    env = PathFollowingEnv(model, "segments", plant=plant, start_noise=(0.2, 0.3))
    env.reset(seed=3)
    agent = DelayCompensated(Recording(), delay, time_constant).bind(env)
    recording = agent.robots[0].agent  # the bound agent drives its own copy
    steps = round(delay / env.dt)
    states = []
    for _ in range(40):
        states.append(env.unwrapped.core.state[0].copy())
        action, _ = agent.predict(None)
        env.step(action)
    # The command computed at step k lands at step k + steps: it was computed for that state.
    # The env applies actions clipped to float32; the prediction used the exact inputs.
    for k in range(len(states) - steps):
        np.testing.assert_allclose(recording.asked[k][:3], states[k + steps][:3], atol=1e-5)


def test_without_delay_it_is_the_agent_it_wraps():
    wrapped = evaluate(
        DelayCompensated(RegulatedPurePursuit(), 0.0), "mobile_envs/Bicycle-Segments-v0", 3
    ).summary
    plain = evaluate(RegulatedPurePursuit(), "mobile_envs/Bicycle-Segments-v0", 3).summary
    assert wrapped == plain


def test_it_tracks_better_than_pure_pursuit_on_a_delayed_robot():
    plant = {"delay": 0.3, "time_constant": 0.2}
    env_id = "mobile_envs/DiffDrive-Segments-v0"
    plain = evaluate(PurePursuit(), env_id, 3, plant=dict(plant)).summary
    compensated = evaluate(DelayCompensated(PurePursuit(), 0.3, 0.2), env_id, 3, plant=plant)
    assert compensated.summary["completion_rate"] > plain["completion_rate"]
    assert compensated.summary["mean_abs_cte"] < plain["mean_abs_cte"]


@pytest.mark.parametrize(
    ("arguments", "named"),
    [
        ({"agent": "pure_pursuit"}, "agent"),
        ({"agent": PurePursuit(), "delay": -0.1}, "delay"),
        ({"agent": PurePursuit(), "time_constant": float("nan")}, "time_constant"),
    ],
)
def test_bad_settings_raise_naming_them(arguments, named):
    with pytest.raises(ValueError, match=named):
        DelayCompensated(**arguments)


def test_bound_without_settings_it_takes_the_env_plants():
    env = PathFollowingEnv("diff_drive", "segments", plant={"delay": 0.2, "time_constant": 0.1})
    bound = DelayCompensated(PurePursuit()).bind(env).robots[0]
    assert (bound.delay, bound.time_constant) == (0.2, 0.1)
    ideal = DelayCompensated(PurePursuit()).bind(PathFollowingEnv("diff_drive")).robots[0]
    assert (ideal.delay, ideal.time_constant) == (0.0, 0.0)


def test_a_delay_that_is_no_whole_number_of_steps_is_refused_when_it_drives():
    env = PathFollowingEnv("diff_drive", "segments")
    env.reset(seed=0)
    agent = DelayCompensated(PurePursuit(), 0.15).bind(env)
    with pytest.raises(ValueError, match="multiple of dt"):
        agent.predict(None)

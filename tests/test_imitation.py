"""Warm starts by behaviour cloning (agents.training.imitation): the demonstrations hold the
teacher's own actions and the exact discounted returns, and cloning makes a policy act like them."""

from __future__ import annotations

import math
import sys

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason="needs the train extra (stable-baselines3)")

import torch
from stable_baselines3 import PPO, SAC

from agents.controllers.mppi import MPPI
from agents.controllers.pure_pursuit import RegulatedPurePursuit
from agents.training.imitation import (
    Demonstrations,
    _discounted,
    clone,
    record_demonstrations,
    warm_start,
)

LINES = "mobile_envs/DiffDrive-Lines-v0"


def test_discounted_returns_match_the_geometric_sum():
    gamma, reward, steps = 0.9, 2.0, 7
    returns = _discounted([reward] * steps, gamma)
    for k, value in enumerate(returns):
        remaining = steps - k
        assert value == pytest.approx(reward * (1 - gamma**remaining) / (1 - gamma), rel=1e-12)


@pytest.mark.parametrize(
    ("name", "teacher_class"), [("regulated_pure_pursuit", RegulatedPurePursuit), ("mppi", MPPI)]
)
def test_demonstrations_hold_the_teachers_actions_and_returns(name, teacher_class):
    gamma = 0.99
    demonstrations = record_demonstrations(name, LINES, robots=3, steps=400, gamma=gamma, seed=5)
    assert demonstrations.completed >= 1
    # Replay robot 0's first episode with the teacher, on a vector env reset the same way.
    vector = gym.make_vec(LINES, num_envs=3, autoreset_mode="SameStep")
    observations, _ = vector.reset(seed=5)
    teacher = teacher_class().bind(vector)
    rewards, first_actions = [], []
    while True:
        actions, _ = teacher.predict(observations)
        first_actions.append(actions[0].astype(np.float32))
        observations, reward, terminated, truncated, infos = vector.step(actions)
        rewards.append(float(reward[0]))
        if terminated[0] or truncated[0]:
            break
    assert infos["final_info"]["is_success"][0], "the teacher completes a course line"
    vector.close()
    # Completed episodes are stored robot by robot in the order they ended; find robot 0's.
    expected_returns = _discounted(rewards, gamma)
    length = len(rewards)
    matches = [
        start
        for start in range(len(demonstrations.actions) - length + 1)
        if np.array_equal(demonstrations.actions[start : start + length], np.array(first_actions))
    ]
    assert matches, "robot 0's episode is among the demonstrations, action for action"
    start = matches[0]
    np.testing.assert_allclose(
        demonstrations.returns[start : start + length], expected_returns, rtol=1e-5
    )


def _linear_demonstrations(samples: int = 4000) -> Demonstrations:
    rng = np.random.default_rng(0)
    observations = rng.uniform(-1, 1, (samples, 45)).astype(np.float32)
    actions = np.tanh(observations[:, :2] * 0.8 - observations[:, 2:4] * 0.5).astype(np.float32)
    returns = (3.0 * observations[:, 5] - 1.0).astype(np.float32)
    return Demonstrations(observations, actions, returns, episodes=1, completed=1)


def test_cloning_makes_the_policy_act_and_value_like_the_demonstrations():
    torch.set_num_threads(1)
    demonstrations = _linear_demonstrations()
    model = PPO("MlpPolicy", gym.make(LINES), seed=0, device="cpu")
    observations = torch.as_tensor(demonstrations.observations)

    def errors() -> tuple[float, float]:
        with torch.no_grad():
            mean = model.policy.get_distribution(observations).distribution.mean.numpy()
            values = model.policy.predict_values(observations).numpy().ravel()
        return (
            float(np.mean((mean - demonstrations.actions) ** 2)),
            float(np.mean((values - demonstrations.returns) ** 2)),
        )

    before = errors()
    log_std = model.policy.log_std.detach().clone()
    losses = clone(
        model.policy, demonstrations, epochs=60, batch_size=256, learning_rate=1e-3, seed=0
    )
    after = errors()
    assert after[0] < 0.02 < before[0]
    assert after[1] < 0.1 * before[1]
    assert losses["action_mse"] == pytest.approx(after[0], rel=0.5)
    assert torch.equal(model.policy.log_std, log_std), "the exploration noise is kept"


@pytest.mark.parametrize("shared", [True, False], ids=["shared-features", "separate-features"])
def test_cloning_gives_the_weights_of_the_plain_loop_over_sb3s_api_bit_for_bit(shared):
    """The cloning loop computes the mean and the value without SB3's action distribution;
    the weights must be those of the plain loop (get_distribution's mean, predict_values) on
    the same minibatches: the shipped policies' warm starts depend on it."""
    torch.set_num_threads(1)
    demonstrations = _linear_demonstrations(samples=1000)
    kwargs = {"share_features_extractor": shared, "net_arch": [32, 32]}

    def fresh() -> PPO:
        return PPO("MlpPolicy", gym.make(LINES), seed=0, device="cpu", policy_kwargs=kwargs)

    fast = fresh()
    clone(fast.policy, demonstrations, epochs=3, batch_size=96, learning_rate=1e-3, seed=5)
    plain = fresh()
    policy = plain.policy
    parameters = [p for name, p in policy.named_parameters() if name != "log_std"]
    optimizer = torch.optim.Adam(parameters, lr=1e-3)
    generator = torch.Generator().manual_seed(5)
    observations = torch.as_tensor(demonstrations.observations)
    actions = torch.as_tensor(demonstrations.actions)
    returns = torch.as_tensor(demonstrations.returns)
    policy.set_training_mode(True)
    for _ in range(3):
        order = torch.randperm(len(observations), generator=generator)
        for start in range(0, len(order), 96):  # the last minibatch is shorter
            batch = order[start : start + 96]
            mean = policy.get_distribution(observations[batch]).distribution.mean
            values = policy.predict_values(observations[batch]).flatten()
            loss = torch.nn.functional.mse_loss(mean, actions[batch])
            loss = loss + torch.nn.functional.mse_loss(values, returns[batch])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
    fast_weights, plain_weights = fast.policy.state_dict(), policy.state_dict()
    assert list(fast_weights) == list(plain_weights)
    changed = [
        name for name in fast_weights if not torch.equal(fast_weights[name], plain_weights[name])
    ]
    assert not changed, f"weights differ from the plain loop's: {changed}"
    untrained = fresh().policy.state_dict()
    assert not torch.equal(fast_weights["action_net.weight"], untrained["action_net.weight"])


def test_warm_start_is_deterministic_and_reports_what_it_kept():
    torch.set_num_threads(1)
    weights = []
    for _ in range(2):
        model = PPO("MlpPolicy", gym.make(LINES), seed=0, device="cpu")
        report = warm_start(model, LINES, seed=1, robots=4, steps=300, epochs=2, batch_size=256)
        weights.append(torch.nn.utils.parameters_to_vector(model.policy.parameters()))
    assert torch.equal(weights[0], weights[1])
    assert report["completed"] <= report["episodes"]
    assert report["samples"] > 0 and math.isfinite(report["action_mse"])


def test_warm_start_refuses_bad_settings():
    model = PPO("MlpPolicy", gym.make(LINES), seed=0, device="cpu")
    with pytest.raises(ValueError, match="unknown teacher"):
        warm_start(model, LINES, teacher="nobody", steps=1)
    with pytest.raises(ValueError, match="epochs"):
        warm_start(model, LINES, epochs=0)
    with pytest.raises(ValueError, match="robots"):
        warm_start(model, LINES, robots=0)
    with pytest.raises(ValueError, match="completed none"):
        warm_start(model, LINES, robots=2, steps=3)
    sac = SAC("MlpPolicy", gym.make(LINES), seed=0, device="cpu", buffer_size=100)
    with pytest.raises(ValueError, match="actor-critic"):
        warm_start(sac, LINES)


class StopAt:
    """A ``check_stop`` that raises at its ``at``-th call, as a stop signal's poll does."""

    def __init__(self, at: int):
        self.at, self.calls = at, 0

    def __call__(self) -> None:
        self.calls += 1
        if self.calls == self.at:
            raise KeyboardInterrupt


WARM_START = {"seed": 1, "robots": 4, "steps": 300, "epochs": 3, "batch_size": 256}


def fresh_model() -> PPO:
    return PPO("MlpPolicy", gym.make(LINES), seed=0, device="cpu")


@pytest.mark.parametrize("where", ["recording", "first-minibatch", "last-minibatch"])
def test_a_stopped_warm_start_goes_on_from_its_checkpoint_to_the_same_weights(where, tmp_path):
    """Stopped at the recording's 120th step, or at the cloning's first or last minibatch
    (the 300 recording polls come first), saved, then continued by a call on a freshly
    built model: the weights and the report are those of a warm start that was never
    stopped, bit for bit."""
    torch.set_num_threads(1)
    whole = fresh_model()
    uninterrupted_polls = StopAt(0)
    expected = warm_start(whole, LINES, check_stop=uninterrupted_polls, **WARM_START)
    total = uninterrupted_polls.calls
    assert total > 300 + 2 * WARM_START["epochs"]  # some minibatches in every epoch
    stop_at = {"recording": 120, "first-minibatch": 301, "last-minibatch": total}[where]
    checkpoint = tmp_path / "warm_start.pkl"
    stopped = fresh_model()
    untouched = torch.nn.utils.parameters_to_vector(stopped.policy.parameters()).clone()
    with pytest.raises(KeyboardInterrupt):
        warm_start(stopped, LINES, check_stop=StopAt(stop_at), checkpoint=checkpoint, **WARM_START)
    assert checkpoint.is_file()
    assert not list(tmp_path.glob(".*.partial"))
    resumed = fresh_model()
    polls = StopAt(0)
    report = warm_start(resumed, LINES, check_stop=polls, checkpoint=checkpoint, **WARM_START)
    assert report == expected
    weights = torch.nn.utils.parameters_to_vector(resumed.policy.parameters())
    assert torch.equal(weights, torch.nn.utils.parameters_to_vector(whole.policy.parameters()))
    assert not torch.equal(weights, untouched)
    # It went on from where it stopped: the polls before the stop were not made again.
    assert polls.calls == total - stop_at + 1
    # Once done, the checkpoint holds the cloned weights: a third call only reads them.
    again = fresh_model()
    assert warm_start(again, LINES, check_stop=StopAt(1), checkpoint=checkpoint, **WARM_START) == (
        expected
    )
    assert torch.equal(torch.nn.utils.parameters_to_vector(again.policy.parameters()), weights)


def test_a_warm_start_checkpoint_of_other_settings_is_refused(tmp_path):
    checkpoint = tmp_path / "warm_start.pkl"
    with pytest.raises(KeyboardInterrupt):
        warm_start(fresh_model(), LINES, check_stop=StopAt(3), checkpoint=checkpoint, **WARM_START)
    with pytest.raises(ValueError, match="other settings"):
        warm_start(fresh_model(), LINES, checkpoint=checkpoint, **{**WARM_START, "epochs": 4})
    checkpoint.write_bytes(b"not a pickle")
    with pytest.raises(ValueError, match="not a readable warm-start checkpoint"):
        warm_start(fresh_model(), LINES, checkpoint=checkpoint, **WARM_START)


def test_the_warm_start_says_what_it_does(capsys):
    warm_start(fresh_model(), LINES, progress=True, **WARM_START)
    out = capsys.readouterr()
    lines = out.out.splitlines()
    assert lines[0].startswith(f"warm start: regulated_pure_pursuit drives 4 robots of {LINES}")
    assert "cloning" in lines[1] and "3 epochs" in lines[1]
    assert lines[2].startswith("warm start: done, action mse")
    assert "epoch" in out.err and "step" in out.err  # the two progress bars


def test_the_warm_start_logged_to_a_file_writes_its_bars_as_lines_every_few_seconds(capsys):
    """A bar written to a file or a pipe (capsys' stderr is not a terminal) is a line every
    LOG_REDRAW_INTERVAL seconds, not a carriage-return redraw ten times a second: a start and
    an end line per bar for a warm start shorter than the interval."""
    assert not sys.stderr.isatty()
    warm_start(fresh_model(), LINES, progress=True, **WARM_START)
    logged = capsys.readouterr().err
    assert "\r" not in logged
    bars = logged.splitlines()
    assert [line.split()[:2] for line in bars] == [
        ["0%", "0/300"],
        ["100%", "300/300"],
        ["0%", "0/3"],
        ["100%", "3/3"],
    ], bars
    assert "step/s" in bars[1] and "epoch" in bars[3] and "action_mse=" in bars[3]


def test_a_labelled_warm_start_names_itself_on_every_line(capsys):
    """Runs writing to one output (the grid's) put their name before every stage and bar."""
    warm_start(fresh_model(), LINES, progress=True, label="seed7", **WARM_START)
    said = capsys.readouterr()
    stages, bars = said.out.splitlines(), said.err.splitlines()
    assert len(stages) == 3 and len(bars) == 4  # recording, cloning, done; two bars each
    assert all(line.startswith("seed7: ") for line in stages + bars), stages + bars


def straight_ahead(observations: np.ndarray) -> np.ndarray:
    """A driver that ignores the path: both wheels forward, the right a little faster."""
    return np.tile(np.array([1.0, 0.8], dtype=np.float32), (len(observations), 1))


def test_a_dagger_recording_labels_the_drivers_states_with_the_teachers_commands():
    """The driver steers, the teacher's command at each state it reaches is the label, and
    every ended episode is kept, failed or not: replayed step by step on a vector env reset
    the same way, driven the same way, with a teacher of its own."""
    robots, steps, seed = 2, 60, 5
    demonstrations = record_demonstrations(
        "regulated_pure_pursuit",
        LINES,
        robots=robots,
        steps=steps,
        gamma=0.99,
        seed=seed,
        driver=straight_ahead,
    )
    vector = gym.make_vec(LINES, num_envs=robots, autoreset_mode="SameStep")
    observations, _ = vector.reset(seed=seed)
    teacher = RegulatedPurePursuit().bind(vector)
    running: list[list[tuple[np.ndarray, np.ndarray]]] = [[] for _ in range(robots)]
    kept, episodes, completed = [], 0, 0
    for _ in range(steps):
        labels, _ = teacher.predict(observations)
        following, _, terminated, truncated, infos = vector.step(straight_ahead(observations))
        for robot in range(robots):
            running[robot].append((observations[robot], labels[robot].astype(np.float32)))
            if terminated[robot] or truncated[robot]:
                episodes += 1
                completed += bool(infos["final_info"]["is_success"][robot])
                kept += running[robot]
                running[robot] = []
        observations = following
    vector.close()
    assert episodes >= 4 and completed == 0, "driving straight fails every course line"
    assert (demonstrations.episodes, demonstrations.completed) == (episodes, completed)
    np.testing.assert_array_equal(demonstrations.observations, [sample[0] for sample in kept])
    np.testing.assert_array_equal(demonstrations.actions, [sample[1] for sample in kept])
    # The labels are the teacher's steering back to the line, not the driver's commands.
    assert not np.allclose(demonstrations.actions, straight_ahead(demonstrations.actions))


def test_the_teachers_parameters_reach_the_teacher():
    """A slower regulated pure pursuit's recording holds its own commands, step for step
    (replayed with a teacher built with the same parameters), not the default's."""
    steps = 40
    recorded = {}
    for speed in (None, 0.45):
        recorded[speed] = record_demonstrations(
            "regulated_pure_pursuit",
            LINES,
            robots=1,
            steps=400,
            gamma=0.99,
            seed=3,
            teacher_kwargs=None if speed is None else {"speed": speed},
        ).actions[:steps]
    env = gym.make_vec(LINES, num_envs=1, autoreset_mode="SameStep")
    observations, _ = env.reset(seed=3)
    teacher = RegulatedPurePursuit(speed=0.45).bind(env)
    expected = []
    for _ in range(steps):
        actions, _ = teacher.predict(observations)
        expected.append(actions[0].astype(np.float32))
        observations, *_ = env.step(actions)
    env.close()
    np.testing.assert_array_equal(recorded[0.45], expected)
    assert not np.array_equal(recorded[0.45], recorded[None])


def test_dagger_settings_are_checked_before_any_work():
    model = fresh_model()
    for rounds in (-1, 1.5, True, "2"):
        with pytest.raises(ValueError, match="dagger_rounds must be an integer >= 0"):
            warm_start(model, LINES, dagger_rounds=rounds)
    with pytest.raises(ValueError, match="dagger_steps"):
        warm_start(model, LINES, dagger_rounds=1, dagger_steps=0)
    with pytest.raises(ValueError, match="dagger_epochs"):
        warm_start(model, LINES, dagger_rounds=1, dagger_epochs=-2)
    with pytest.raises(ValueError, match="teacher_kwargs for regulated_pure_pursuit"):
        warm_start(model, LINES, teacher_kwargs={"look_ahead": 0.5})
    with pytest.raises(ValueError, match="teacher_kwargs must be a mapping"):
        warm_start(model, LINES, teacher_kwargs=[("speed", 0.5)])
    with pytest.raises(ValueError, match="speed"):
        warm_start(model, LINES, teacher_kwargs={"speed": -1.0})


DAGGER = {**WARM_START, "dagger_rounds": 1, "dagger_steps": 100, "dagger_epochs": 2}


@pytest.mark.parametrize("where", ["dagger-recording", "dagger-cloning"])
def test_a_warm_start_stopped_in_its_dagger_round_goes_on_to_the_same_weights(where, tmp_path):
    """A DAgger round adds the samples of the policy's own episodes; stopped in its
    recording or its cloning and continued on a fresh model, it ends at the weights of a
    warm start never stopped, bit for bit."""
    torch.set_num_threads(1)
    plain_polls = StopAt(0)
    plain = warm_start(fresh_model(), LINES, check_stop=plain_polls, **WARM_START)
    whole = fresh_model()
    whole_polls = StopAt(0)
    expected = warm_start(whole, LINES, check_stop=whole_polls, **DAGGER)
    # Round 0 is the plain warm start (same seeds); the round adds 100 recording polls and
    # its cloning's minibatches over every sample.
    assert expected["samples"] > plain["samples"]
    assert expected["episodes"] > plain["episodes"]
    assert whole_polls.calls > plain_polls.calls + 100 + 2
    stop_at = plain_polls.calls + {"dagger-recording": 50, "dagger-cloning": 101}[where]
    checkpoint = tmp_path / "warm_start.pkl"
    with pytest.raises(KeyboardInterrupt):
        warm_start(
            fresh_model(), LINES, check_stop=StopAt(stop_at), checkpoint=checkpoint, **DAGGER
        )
    resumed = fresh_model()
    polls = StopAt(0)
    report = warm_start(resumed, LINES, check_stop=polls, checkpoint=checkpoint, **DAGGER)
    assert report == expected
    assert polls.calls == whole_polls.calls - stop_at + 1
    assert torch.equal(
        torch.nn.utils.parameters_to_vector(resumed.policy.parameters()),
        torch.nn.utils.parameters_to_vector(whole.policy.parameters()),
    )


def test_a_dagger_round_says_what_it_does(capsys):
    warm_start(fresh_model(), LINES, progress=True, **DAGGER)
    lines = capsys.readouterr().out.splitlines()
    assert lines[2].startswith(
        f"warm start: DAgger round 1 of 1: the policy drives 4 robots of {LINES} for 100 steps"
    )
    assert "cloning" in lines[3] and "2 epochs" in lines[3]
    assert lines[4].startswith("warm start: done")

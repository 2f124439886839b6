"""The evaluation harness and the comparison command."""

import math

import gymnasium as gym
import numpy as np
import pytest

from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from agents.harness.evaluate import EvaluationResult, evaluate
from mobile_envs.envs.path_following import PathFollowingEnv


def _compare_module():
    """agents.harness.compare, whose plots need matplotlib (the render extra)."""
    pytest.importorskip("matplotlib", reason="the compare command's plots need matplotlib")
    from agents.harness import compare

    return compare


NOISY_LINES = {"start_noise": (0.2, 0.3)}
LINES_ID = "mobile_envs/DiffDrive-Lines-v0"


def record_values(result: EvaluationResult):
    return [
        (
            episode.completed,
            episode.mean_abs_cte,
            episode.max_abs_cte,
            episode.rms_cte,
            episode.time,
            episode.collision,
            episode.trajectory.tolist(),
        )
        for episode in result.episodes
    ]


def test_identical_seeds_give_identical_results():
    first = evaluate(PurePursuit(), LINES_ID, episodes=3, seed=7, **NOISY_LINES)
    second = evaluate(PurePursuit(), LINES_ID, episodes=3, seed=7, **NOISY_LINES)
    assert record_values(first) == record_values(second)
    other = evaluate(PurePursuit(), LINES_ID, episodes=3, seed=8, **NOISY_LINES)
    assert record_values(first) != record_values(other)


def test_every_agent_meets_the_same_episodes():
    results = [
        evaluate(agent, LINES_ID, episodes=4, seed=0, **NOISY_LINES)
        for agent in (PurePursuit(), RegulatedPurePursuit())
    ]
    starts = [[episode.trajectory[0] for episode in result.episodes] for result in results]
    paths = [[episode.path.name for episode in result.episodes] for result in results]
    np.testing.assert_array_equal(starts[0], starts[1])
    assert paths[0] == paths[1]
    assert len(set(paths[0])) > 1  # the episodes differ from each other
    assert not np.array_equal(
        results[0].episodes[0].trajectory[-1], results[1].episodes[0].trajectory[-1]
    )


def test_the_summary_aggregates_the_episode_records():
    result = evaluate(
        PurePursuit(speed=0.9), "mobile_envs/Bicycle-SharpSegments-v0", episodes=3, seed=0
    )
    records = result.episodes
    summary = result.summary
    completed = [record for record in records if record.completed]
    assert summary["episodes"] == 3
    assert summary["completion_rate"] == len(completed) / 3
    assert summary["mean_abs_cte"] == pytest.approx(sum(r.mean_abs_cte for r in records) / 3)
    assert summary["max_abs_cte"] == max(r.max_abs_cte for r in records)
    assert summary["rms_cte"] == pytest.approx(math.sqrt(sum(r.rms_cte**2 for r in records) / 3))
    assert summary["collision_rate"] == sum(r.collision for r in records) / 3
    if completed:
        assert summary["mean_time"] == pytest.approx(
            sum(r.time_to_goal for r in completed) / len(completed)
        )
    else:
        assert math.isnan(summary["mean_time"])


def test_episode_records_match_the_envs_own_metrics():
    env = gym.make("mobile_envs/DiffDrive-Maze-v0")
    record = evaluate(RegulatedPurePursuit(), env, episodes=1, seed=0).episodes[0]
    agent = RegulatedPurePursuit.for_env(env)
    observation, _ = env.reset(seed=0)
    terminated = truncated = False
    while not (terminated or truncated):
        observation, _, terminated, truncated, info = env.step(agent.predict(observation)[0])
    assert record.completed == info["completed"]
    assert record.mean_abs_cte == pytest.approx(info["mean_abs_cte"], rel=1e-12)
    assert record.max_abs_cte == info["max_abs_cte"]
    assert record.rms_cte == pytest.approx(info["rms_cte"], rel=1e-12)
    assert record.time == pytest.approx(info["episode_time"])
    assert record.maze is env.unwrapped.track.maze
    assert len(record.trajectory) == record.steps + 1
    np.testing.assert_array_equal(record.trajectory[-1], env.unwrapped.pose)


def test_episodes_cut_by_a_time_limit_are_measured_and_have_no_time_to_goal():
    env = gym.make(LINES_ID, max_episode_steps=5)  # a TimeLimit wrapper, not the env's limit
    result = evaluate(PurePursuit(), env, episodes=2)
    assert [episode.steps for episode in result.episodes] == [5, 5]
    assert result.summary["completion_rate"] == 0.0
    assert math.isnan(result.summary["mean_time"])


def test_agents_can_be_given_bound_unbound_or_as_factories():
    env = PathFollowingEnv("diff_drive", "segments")
    expected = record_values(evaluate(PurePursuit(), env, episodes=1))
    for agent in (PurePursuit, lambda: PurePursuit(), PurePursuit.for_env(env)):
        assert record_values(evaluate(agent, env, episodes=1)) == expected


def test_an_sb3_policy_runs_through_the_same_loop_and_the_compare_command(tmp_path):
    compare = _compare_module()
    ppo = pytest.importorskip("stable_baselines3").PPO
    env = gym.make(LINES_ID, max_episode_steps=20)
    policy = ppo("MlpPolicy", env, seed=0, device="cpu", n_steps=64, batch_size=64)
    result = evaluate(policy, env, episodes=1)
    assert result.episodes[0].steps == 20  # an untrained policy does not reach the goal
    policy.save(tmp_path / "policy.zip")
    table = compare.main(
        [
            "--episodes", "2",
            "--agents", f"ppo:{tmp_path / 'policy.zip'}", "pure_pursuit",
            "--envs", LINES_ID,
            "--env-kwargs", '{"max_episode_steps": 20}',
            "--output", str(tmp_path / "comparison"),
        ]
    )  # fmt: skip
    assert table.count("DiffDrive-Lines-v0") == 2
    # Nobody reaches the goal in 2 s: 0 of 2, whose 95% Wilson interval is [0, 0.66].
    assert "| 0.00 [0.00, 0.66] |" in table


def test_misuse_is_refused():
    with pytest.raises(ValueError, match="episodes"):
        evaluate(PurePursuit(), LINES_ID, episodes=0)
    with pytest.raises(ValueError, match="env_kwargs"):
        evaluate(PurePursuit(), PathFollowingEnv(), episodes=1, start_noise=0.1)
    with pytest.raises(TypeError, match="predict"):
        evaluate(42, LINES_ID, episodes=1)


def test_the_compare_command_writes_its_table_and_plot(tmp_path, capsys):
    compare = _compare_module()
    table = compare.main(
        [
            "--episodes", "1",
            "--agents", "pure_pursuit", "regulated_pure_pursuit", "tricycle_guidance",
            "--envs", "mobile_envs/DiffDrive-Maze-v0",
            "--output", str(tmp_path),
        ]
    )  # fmt: skip
    written = (tmp_path / "comparison.md").read_text()
    assert written == table
    rows = [line.split("|")[1:3] for line in written.splitlines()[2:]]
    assert [[cell.strip() for cell in row] for row in rows] == [
        ["DiffDrive-Maze-v0", "pure_pursuit"],
        ["DiffDrive-Maze-v0", "regulated_pure_pursuit"],
    ]
    assert (tmp_path / "DiffDrive-Maze-v0.png").read_bytes().startswith(b"\x89PNG")
    printed = capsys.readouterr().out
    assert "skipping tricycle_guidance, which cannot drive the diff_drive model" in printed
    assert "DiffDrive-Maze-v0 regulated_pure_pursuit: completion 1.00" in printed


def test_compare_names_the_known_agents_on_a_typo():
    compare = _compare_module()
    env = PathFollowingEnv()
    with pytest.raises(ValueError, match="pure_pursuit_textbook"):
        compare.make_agent("pure_pursuitt", env)


def synthetic_result(completed, mean_abs_ctes, times):
    from agents.harness.records import EpisodeRecord
    from mobile_envs.world.paths import Path

    path = Path([[0, 0], [1, 0]])
    return EvaluationResult(
        [
            EpisodeRecord(
                completed=done,
                mean_abs_cte=cte,
                max_abs_cte=2 * cte,
                rms_cte=1.5 * cte,
                time=time,
                time_to_goal=time if done else math.nan,
                collision=False,
                off_track=not done,
                steps=10,
                trajectory=np.zeros((11, 3)),
                path=path,
            )
            for done, cte, time in zip(completed, mean_abs_ctes, times, strict=True)
        ]
    )


def test_the_intervals_are_wilson_for_rates_and_t_for_means():
    from agents.harness.intervals import t_quantile, wilson_interval

    ctes = [0.01, 0.02, 0.04, 0.03]
    result = synthetic_result([True, True, False, True], ctes, [5.0, 6.0, 9.0, 7.0])
    intervals = result.intervals()
    assert intervals["completion_rate"] == wilson_interval(3, 4)
    assert intervals["off_track_rate"] == wilson_interval(1, 4)
    assert intervals["collision_rate"] == (0.0, wilson_interval(0, 4)[1])
    half = t_quantile(0.95, 3) * np.std(ctes, ddof=1) / 2
    assert intervals["mean_abs_cte"] == pytest.approx((max(0.025 - half, 0.0), 0.025 + half))
    half_time = t_quantile(0.95, 2) * np.std([5.0, 6.0, 7.0], ddof=1) / math.sqrt(3)
    assert intervals["mean_time"] == pytest.approx((6.0 - half_time, 6.0 + half_time))
    squares = [(1.5 * cte) ** 2 for cte in ctes]
    half_square = t_quantile(0.95, 3) * np.std(squares, ddof=1) / 2
    low, high = intervals["rms_cte"]
    assert high == pytest.approx(math.sqrt(np.mean(squares) + half_square))
    assert low == pytest.approx(math.sqrt(max(np.mean(squares) - half_square, 0.0)))
    assert "max_abs_cte" not in intervals  # an extreme has no such interval
    lone = synthetic_result([True], [0.01], [5.0]).intervals()
    assert all(math.isnan(value) for value in lone["mean_abs_cte"])


def test_the_comparison_table_prints_each_interval_beside_its_value():
    compare = _compare_module()
    result = synthetic_result([True, True, False, True], [0.01, 0.02, 0.04, 0.03], [5, 6, 9, 7])
    table = compare.markdown_table([(LINES_ID, "agent", result.summary, result.intervals())])
    header, _, row = table.splitlines()
    assert "completion [95% Wilson]" in header and "mean abs cte (m) [95% t]" in header
    cells = [cell.strip() for cell in row.split("|")[1:-1]]
    low, high = result.intervals()["completion_rate"]
    assert low < 0.75 < high
    assert cells[2] == f"0.75 [{low:.2f}, {high:.2f}]"
    assert cells[4] == "0.080"  # the largest |cte|: no interval

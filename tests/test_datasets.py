"""Offline datasets (issue 31, item 2): Minari records the env through UniformInfo, and
agents.harness.datasets writes datasets of any harness agent from the batched vector env that
load back, hold the harness's own episodes and recover the env."""

import gymnasium as gym
import numpy as np
import pytest

import mobile_envs  # noqa: F401  (registers the ids)
from agents.controllers.pure_pursuit import RegulatedPurePursuit
from agents.harness.evaluate import evaluate
from mobile_envs.envs.interface import EPISODE_INFO_KEYS, STEP_INFO_KEYS
from mobile_envs.envs.recording import UniformInfo

minari = pytest.importorskip("minari", reason="datasets need the minari extra")

LINES = "mobile_envs/DiffDrive-Lines-v0"


@pytest.fixture(autouse=True)
def datasets_folder(tmp_path, monkeypatch):
    """Every test's datasets in its own folder, never the user's ~/.minari."""
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))
    return tmp_path / "datasets"


@pytest.mark.parametrize("localization", ["exact", "odometry"])
def test_uniform_info_has_the_same_keys_every_step_and_the_metrics_at_the_end(localization):
    raw = gym.make(LINES, step_limit=40, localization=localization)
    wrapped = UniformInfo(gym.make(LINES, step_limit=40, localization=localization))
    _, raw_info = raw.reset(seed=3)
    _, info = wrapped.reset(seed=3)
    keys = set(info)
    assert keys == set(raw_info) | set(EPISODE_INFO_KEYS) | (
        {"mean_localization_error", "max_localization_error"} if localization != "exact" else set()
    )
    rng = np.random.default_rng(0)
    while True:
        action = rng.uniform(-0.2, 1.0, 2).astype(np.float32)
        raw_step = raw.step(action)
        step = wrapped.step(action)
        info, raw_info = step[4], raw_step[4]
        assert set(info) == keys
        assert all(isinstance(value, (np.generic, np.ndarray)) for value in info.values())
        np.testing.assert_array_equal(step[0], raw_step[0])
        assert step[1:4] == raw_step[1:4]
        for key, value in raw_info.items():  # the env's own values, bit for bit
            np.testing.assert_array_equal(info[key], value, strict=False)
        if step[2] or step[3]:
            break
        assert np.isnan(info["mean_abs_cte"]) and not info["completed"]
    assert info["mean_abs_cte"] == raw_info["mean_abs_cte"]


def assert_episodes_are_the_harness(dataset, agent, env_id, seed, **env_kwargs):
    """Each recorded episode i is the harness's episode with seed ``seed + i``: the same
    poses (info["pose"]) and cross-track errors, bit for bit, and its end metrics."""
    episodes = list(dataset.iterate_episodes())
    harness = evaluate(agent, env_id, len(episodes), seed=seed, **env_kwargs).episodes
    for index, (episode, record) in enumerate(zip(episodes, harness, strict=True)):
        assert episode.id == index
        np.testing.assert_array_equal(episode.infos["pose"], record.trajectory, strict=False)
        assert len(episode.actions) == record.steps
        errors = np.abs(episode.infos["cross_track_error"][1:])
        assert float(np.mean(errors)) == record.mean_abs_cte
        assert bool(episode.infos["completed"][-1]) == record.completed
        assert np.isnan(episode.infos["mean_abs_cte"][:-1]).all()
        assert episode.infos["mean_abs_cte"][-1] == pytest.approx(record.mean_abs_cte, rel=1e-12)
        assert bool(episode.terminations[-1] or episode.truncations[-1])
        assert not (episode.terminations[:-1].any() or episode.truncations[:-1].any())


def test_a_recorded_dataset_loads_back_holds_the_harness_episodes_and_recovers_the_env():
    from agents.harness.datasets import record_dataset

    env_kwargs = {"start_noise": [0.2, 0.3]}
    dataset_id = "mobile_envs/DiffDrive-Lines/rpp-test-v0"
    # 7 episodes on 3 robots: robots restart with later seeds, and idle at the end.
    record_dataset(
        "regulated_pure_pursuit", LINES, dataset_id, episodes=7, robots=3, seed=4,
        env_kwargs=env_kwargs,
    )  # fmt: skip
    dataset = minari.load_dataset(dataset_id)
    assert dataset.total_episodes == 7
    assert set(next(dataset.iterate_episodes()).infos) >= set(STEP_INFO_KEYS) | set(
        EPISODE_INFO_KEYS
    )
    assert_episodes_are_the_harness(dataset, RegulatedPurePursuit(), LINES, 4, **env_kwargs)
    env = dataset.recover_environment()
    assert env.spec.id == LINES and env.spec.kwargs["start_noise"] == [0.2, 0.3]
    observation, _ = env.reset(seed=4)
    np.testing.assert_array_equal(observation, next(dataset.iterate_episodes()).observations[0])
    assert dataset.observation_space == env.observation_space
    with pytest.raises(ValueError, match="already exists"):
        record_dataset("regulated_pure_pursuit", LINES, dataset_id, episodes=1)


def test_a_ppo_policy_records_through_the_same_command(datasets_folder):
    pytest.importorskip("stable_baselines3", reason="a saved policy needs the train extra")
    import torch

    from agents.harness.datasets import cli
    from agents.harness.policies import load_policy

    torch.set_num_threads(1)  # on 2 cores, 2 torch threads make small batches ~15x slower
    policy = "models/diffdrive_ppo.zip"
    env_id = "mobile_envs/DiffDrive-Segments-v0"
    assert cli(["--agent", f"ppo:{policy}", "--env", env_id, "--episodes", "3", "--robots", "2",
                "--no-progress"]) == 0  # fmt: skip
    dataset = minari.load_dataset("mobile_envs/DiffDrive-Segments/ppo-diffdrive-ppo-v0")
    assert dataset.total_episodes == 3
    episodes = list(dataset.iterate_episodes())
    harness = evaluate(load_policy(policy), env_id, 3).episodes
    for episode, record in zip(episodes, harness, strict=True):
        # A batch of two through the network may round differently from a batch of one.
        np.testing.assert_allclose(episode.infos["pose"], record.trajectory, atol=1e-4)
        assert bool(episode.infos["completed"][-1]) == record.completed


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--agent", "nobody", "--env", LINES], "unknown agent 'nobody'"),
        (["--agent", "pure_pursuit", "--env", "mobile_envs/Nope-v0"], "--env"),
        (["--agent", "ppo:missing.zip", "--env", LINES], "no policy file at missing.zip"),
        (["--agent", "pure_pursuit", "--env", LINES, "--episodes", "0"], "--episodes"),
        (["--agent", "pure_pursuit", "--env", LINES, "--dataset-id", "a/b/"], "--dataset-id"),
    ],
    ids=["agent", "env", "policy-file", "episodes", "dataset-id"],
)
def test_bad_input_is_one_line_naming_it_and_writes_nothing(argv, named, capsys, datasets_folder):
    from agents.harness.datasets import cli

    assert cli(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and named in err
    assert not any(path.is_dir() for path in datasets_folder.glob("*/*"))


def test_the_minari_recipe_of_the_docs_runs(datasets_folder, monkeypatch, capsys):
    """docs/recipes/minari_dataset.py, which docs/integrations.md shows: Minari's own
    DataCollector(record_infos=True) records through UniformInfo (on the bare env it raised a
    pytree structure error at the first episode's end), and the batched recorder's dataset
    loads back."""
    import runpy
    import sys
    from pathlib import Path

    pytest.importorskip("jax", reason="Minari's DataCollector needs minari[create] (jax)")
    recipe = Path(__file__).resolve().parents[1] / "docs" / "recipes" / "minari_dataset.py"
    monkeypatch.setattr(sys, "argv", [str(recipe)])
    scope = runpy.run_path(str(recipe), run_name="__main__")
    assert scope["dataset"].total_episodes == 32
    random_driving = scope["random_driving"]
    assert random_driving.total_episodes >= 1
    episode = next(random_driving.iterate_episodes())
    steps = len(episode.actions)
    assert episode.infos["completed"].shape == episode.infos["mean_abs_cte"].shape == (steps + 1,)
    assert np.isnan(episode.infos["mean_abs_cte"][:-1]).all()
    assert np.isfinite(episode.infos["mean_abs_cte"][-1])
    assert scope["env"].spec.id == "mobile_envs/DiffDrive-Random-v0"
    assert "32 episodes" in capsys.readouterr().out
    assert (datasets_folder / "mobile_envs" / "DiffDrive-Random").is_dir()


def test_train_py_dataset_is_the_same_command(datasets_folder, capsys):
    train = pytest.importorskip("train", reason="train.py reads YAML (the train extra)")
    argv = ["dataset", "--agent", "pure_pursuit", "--env", LINES, "--episodes", "2", "--robots",
            "2", "--dataset-id", "mobile_envs/pp-v1", "--no-progress"]  # fmt: skip
    assert train.main(argv) == 0
    out = capsys.readouterr().out
    assert f"to {datasets_folder / 'mobile_envs' / 'pp-v1'}" in out
    assert minari.load_dataset("mobile_envs/pp-v1").total_episodes == 2
    assert train.main(argv) == 2  # the id is taken now
    assert "train.py dataset: error: --dataset-id: a Minari dataset" in capsys.readouterr().err

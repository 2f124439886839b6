"""train.py: a short run saves, loads and predicts; Ctrl-C keeps the work; resume continues."""

import os
import pathlib
import signal
import subprocess
import sys
import time

import gymnasium as gym
import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3", reason="training needs the train extra")

import train
from agents.ppo import load_policy

ROOT = pathlib.Path(__file__).resolve().parents[1]
SMALL_RUN = ["--n-envs", "4", "--no-progress", "--eval-episodes", "1"]


def test_a_short_run_saves_a_policy_that_loads_and_predicts(tmp_path):
    folder = tmp_path / "run"
    code = train.main(
        [
            "--timesteps",
            "512",
            "--output",
            str(folder),
            "--eval-freq",
            "512",
            "--checkpoint-freq",
            "512",
            *SMALL_RUN,
        ]
    )
    assert code == 0
    for name in ("config.yml", "command.txt", "final_model.zip", "best_model.zip"):
        assert (folder / name).is_file(), name
    assert (folder / "checkpoints" / "latest.zip").is_file()
    config = yaml.safe_load((folder / "config.yml").read_text())
    assert config["env"] == train.DEFAULT_ENV and config["n_envs"] == 4
    env = gym.make(train.DEFAULT_ENV)
    model = load_policy(folder / "final_model.zip", env)
    assert model.num_timesteps >= 512
    observation, _ = env.reset(seed=0)
    action, _ = model.predict(observation, deterministic=True)
    assert env.action_space.contains(action)
    again, _ = load_policy(folder / "final_model.zip", env).predict(observation, deterministic=True)
    np.testing.assert_array_equal(action, again)


def test_ctrl_c_saves_a_checkpoint_and_resume_continues_from_its_step_count(tmp_path):
    folder = tmp_path / "run"
    command = [
        sys.executable,
        str(ROOT / "train.py"),
        "--timesteps",
        "1000000",
        "--output",
        str(folder),
        "--eval-freq",
        "0",
        *SMALL_RUN,
    ]
    process = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, text=True)
    assert "run folder" in process.stdout.readline()
    assert "training" in process.stdout.readline()
    time.sleep(3.0)  # let PPO collect a few rollouts
    process.send_signal(signal.SIGINT)
    output, _ = process.communicate(timeout=60)
    assert process.returncode == 130, output
    assert "interrupted at step" in output
    checkpoint = folder / "checkpoints" / "latest.zip"
    saved_steps = load_policy(checkpoint).num_timesteps
    assert 0 < saved_steps < 1_000_000

    # Resume with a smaller target: the run goes on from the saved count, not from zero.
    config = yaml.safe_load((folder / "config.yml").read_text())
    config["timesteps"] = saved_steps + 1024
    (folder / "config.yml").write_text(yaml.safe_dump(config))
    assert train.main(["--resume", str(folder), "--no-progress"]) == 0
    resumed = load_policy(folder / "final_model.zip")
    assert saved_steps + 1024 <= resumed.num_timesteps < saved_steps + 2 * 1024 + 4 * 256


def test_a_second_run_into_the_same_folder_is_refused(tmp_path):
    folder = tmp_path / "run"
    args = ["--timesteps", "256", "--output", str(folder), "--eval-freq", "0", *SMALL_RUN]
    assert train.main(args) == 0
    assert train.main(args) == 2  # ValueError, reported without a traceback


def test_a_mismatched_policy_raises_naming_both_spaces(tmp_path):
    folder = tmp_path / "run"
    train.main(["--timesteps", "256", "--output", str(folder), "--eval-freq", "0", *SMALL_RUN])
    other = gym.make("mobile_envs/ConstantVelocity-Segments-v0")
    mismatch = r"observation space is Box.*\(45,\).*the env.s is Box.*\(47,\)"
    with pytest.raises(ValueError, match=mismatch):
        load_policy(folder / "final_model.zip", other)
    # Same observation and action sizes, another robot: the recorded training env tells.
    bicycle = gym.make("mobile_envs/Bicycle-Segments-v0")
    with pytest.raises(ValueError, match="trained on mobile_envs/DiffDrive-Random-v0"):
        load_policy(folder / "final_model.zip", bicycle)
    with pytest.raises(ValueError, match="no policy file"):
        load_policy(tmp_path / "missing.zip", other)


def test_evaluate_command_reports_the_harness_summary(tmp_path, capsys):
    folder = tmp_path / "run"
    train.main(["--timesteps", "256", "--output", str(folder), "--eval-freq", "0", *SMALL_RUN])
    code = train.main(
        [
            "evaluate",
            "--model",
            str(folder / "final_model.zip"),
            "--env",
            "mobile_envs/DiffDrive-Lines-v0",
            "--episodes",
            "2",
        ]
    )
    assert code == 0
    assert "mobile_envs/DiffDrive-Lines-v0" in capsys.readouterr().out


def test_threads_default_to_one():
    args = train.parse_args([])
    assert args.command == "train" and args.threads == 1 and args.env == train.DEFAULT_ENV
    assert os.path.isfile(args.hyperparams)

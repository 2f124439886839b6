"""Training progress lines: what train.py prints instead of SB3's bar when its output is a file."""

import io
import itertools
import pathlib
import subprocess
import sys

import gymnasium as gym
import pytest

import mobile_envs  # noqa: F401  (registers the ids)

pytest.importorskip("stable_baselines3", reason="training needs the train extra")
from stable_baselines3 import PPO

from agents.training.progress import ProgressLines

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_a_line_every_interval_of_the_clock_and_one_at_the_end():
    # A clock that advances 1 s at every reading: read once when training starts (t = 0),
    # then once a step (t = k after k steps of one robot), once more at the end.
    ticks = itertools.count()
    stream = io.StringIO()
    progress = ProgressLines(128, interval=50.0, stream=stream, clock=lambda: float(next(ticks)))
    model = PPO("MlpPolicy", gym.make("mobile_envs/DiffDrive-Lines-v0"), n_steps=64,
                batch_size=64, n_epochs=1, seed=0)  # fmt: skip
    model.learn(128, callback=progress)
    assert stream.getvalue().splitlines() == [
        "step 50 of 128 (39%), 1 steps/s",
        "step 100 of 128 (78%), 1 steps/s",
        # the end: 128 steps after 129 readings of the clock since the start
        f"step 128 of 128 (100%), {128 / 129:,.0f} steps/s",
    ]


def test_a_label_names_the_run_on_each_line():
    stream = io.StringIO()
    progress = ProgressLines(64, stream=stream, clock=lambda: 0.0, label="seed3")
    model = PPO("MlpPolicy", gym.make("mobile_envs/DiffDrive-Lines-v0"), n_steps=64,
                batch_size=64, n_epochs=1, seed=0)  # fmt: skip
    model.learn(64, callback=progress)
    assert stream.getvalue() == "seed3: step 64 of 64 (100%), 0 steps/s\n"


@pytest.mark.parametrize(("total", "interval"), [(0, 1.0), (10, 0.0), (10, float("nan"))])
def test_bad_settings_are_refused_by_name(total, interval):
    with pytest.raises(ValueError, match="total" if total < 1 else "interval"):
        ProgressLines(total, interval=interval)


def test_train_py_writing_to_a_file_prints_progress_lines_not_a_bar(tmp_path):
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(
        "mobile_envs/DiffDrive-Random-v0:\n  n_envs: 2\n  n_steps: 64\n  batch_size: 64\n"
        "  n_epochs: 1\n  policy: MlpPolicy\n"
    )
    result = subprocess.run(
        [sys.executable, "train.py", "--timesteps", "128", "--eval-freq", "0",
         "--hyperparams", str(hyperparams), "--output", str(tmp_path / "run")],
        cwd=ROOT, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert "step 128 of 128 (100%)" in lines[-2], result.stdout  # then "done: ..."
    assert "━" not in result.stdout  # no rich bar drawn into the file

"""train.py: a short run saves, loads and predicts; Ctrl-C and SIGTERM keep the work; --resume
continues to the run's total; a run never overwrites a folder; saves are atomic and durable.

The failure cases of the command lines (one line, no traceback) are in test_cli_errors.py.
"""

import errno
import json
import os
import pathlib
import re
import shlex
import shutil
import signal
import stat
import subprocess
import sys
import time

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("yaml", reason="training reads YAML (the train extra)")

import yaml

pytest.importorskip("stable_baselines3", reason="training needs the train extra")

import train
from agents.ppo import load_policy, write_atomically

ROOT = pathlib.Path(__file__).resolve().parents[1]
SMALL_RUN = ["--n-envs", "4", "--no-progress", "--eval-episodes", "1"]
ROLLOUT = 4 * 256  # 4 robots x n_steps in hyperparams/ppo.yml: PPO trains in whole rollouts
# Subprocess training with a save that stalls once the run is interrupted, so that a second
# signal lands inside the checkpoint save.
STALLING_SAVE = """
import sys, time
from stable_baselines3 import PPO
import train

real_save, real_save_interrupted_run = PPO.save, train.save_interrupted_run
stalling = False

def save(self, path, *args, **kwargs):
    real_save(self, path, *args, **kwargs)
    if stalling:
        print("save stalled", flush=True)
        time.sleep(60)

def save_interrupted_run(*args):
    global stalling
    stalling = True
    return real_save_interrupted_run(*args)

PPO.save = save
train.save_interrupted_run = save_interrupted_run
sys.exit(train.main(sys.argv[1:]))
"""


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> pathlib.Path:
    """A run that reached its total of one rollout; copy it before changing it."""
    folder = tmp_path_factory.mktemp("runs") / "finished"
    args = ["--timesteps", str(ROLLOUT), "--output", str(folder), "--eval-freq", "0"]
    assert train.main([*args, *SMALL_RUN]) == 0
    return folder


def start_training(command: list[str], folder: pathlib.Path) -> subprocess.Popen:
    """Start a long run and return once it has saved its first periodic checkpoint."""
    environment = {**os.environ, "OMP_NUM_THREADS": "1"}
    settings = ["--timesteps", "1000000", "--eval-freq", "0", "--checkpoint-freq", str(ROLLOUT)]
    process = subprocess.Popen(
        [*command, *settings, "--output", str(folder), *SMALL_RUN],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment,
    )
    assert process.stdout is not None
    assert "run folder" in process.stdout.readline()
    assert "training" in process.stdout.readline()
    deadline = time.monotonic() + 120  # the first steps may compile the kernels
    while not (folder / "checkpoints" / "latest.zip").exists():
        assert process.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    return process


def interrupted_step(output: str, signal_name: str) -> int:
    found = re.search(rf"interrupted by {signal_name} at step (\d+)", output)
    assert found, output
    return int(found[1])


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


def test_sigterm_saves_a_checkpoint_exits_143_and_resume_reaches_the_new_total(tmp_path):
    folder = tmp_path / "run"
    process = start_training([sys.executable, "train.py"], folder)
    process.send_signal(signal.SIGTERM)
    output, errors = process.communicate(timeout=60)
    assert process.returncode == 128 + signal.SIGTERM, output + errors
    assert errors == ""
    saved = interrupted_step(output, "SIGTERM")
    checkpoint = folder / "checkpoints" / "latest.zip"
    assert load_policy(checkpoint).num_timesteps == saved >= ROLLOUT
    assert not (folder / "final_model.zip").exists()  # written only when the run is done

    # The printed command resumes; --timesteps is the run's new total.
    printed = re.search(r"Continue with: (.+)", output)
    assert printed, output
    resume = shlex.split(printed[1])
    assert resume[:2] == ["python", "train.py"] and resume[2:] == ["--resume", str(folder)]
    total = saved + 2 * ROLLOUT
    assert train.main([*resume[2:], "--timesteps", str(total), "--no-progress"]) == 0
    assert load_policy(checkpoint).num_timesteps == total  # from `saved`, in whole rollouts
    assert load_policy(folder / "final_model.zip").num_timesteps == total
    assert yaml.safe_load((folder / "config.yml").read_text())["timesteps"] == total


def test_ctrl_c_is_handled_as_sigterm_is_with_status_130(tmp_path):
    folder = tmp_path / "run"
    process = start_training([sys.executable, "train.py"], folder)
    process.send_signal(signal.SIGINT)
    output, errors = process.communicate(timeout=60)
    assert process.returncode == 128 + signal.SIGINT, output + errors
    assert errors == ""
    assert load_policy(folder / "checkpoints" / "latest.zip").num_timesteps == interrupted_step(
        output, "SIGINT"
    )
    assert f"Continue with: python train.py --resume {folder}" in output


def test_a_second_signal_during_that_save_keeps_the_last_checkpoint_and_no_partial(tmp_path):
    folder = tmp_path / "run"
    process = start_training([sys.executable, "-c", STALLING_SAVE], folder)
    process.send_signal(signal.SIGTERM)
    assert process.stdout is not None
    for line in process.stdout:
        if "save stalled" in line:
            break
    process.send_signal(signal.SIGTERM)
    output, errors = process.communicate(timeout=60)
    assert process.returncode == 128 + signal.SIGTERM, output + errors
    assert "Traceback" not in errors and errors == ""
    assert "again during the save" in output
    assert [path.name for path in folder.rglob("*.partial")] == []
    # What stays is the last periodic checkpoint, complete: saved at a whole rollout.
    kept = load_policy(folder / "checkpoints" / "latest.zip").num_timesteps
    assert kept >= ROLLOUT and kept % ROLLOUT == 0


def test_resume_to_a_larger_total_trains_the_extra_steps(finished_run, tmp_path):
    folder = tmp_path / "run"
    shutil.copytree(finished_run, folder)
    checkpoint = folder / "checkpoints" / "latest.zip"
    assert load_policy(checkpoint).num_timesteps == ROLLOUT

    # At its total already: nothing to train, nothing changed.
    before = checkpoint.read_bytes()
    assert train.main(["--resume", str(folder), "--no-progress"]) == 0
    assert checkpoint.read_bytes() == before

    assert train.main(["--resume", str(folder), "--timesteps", "2500", "--no-progress"]) == 0
    assert load_policy(checkpoint).num_timesteps == 3 * ROLLOUT  # 2500 rounded up to rollouts
    assert yaml.safe_load((folder / "config.yml").read_text())["timesteps"] == 2500
    assert len((folder / "command.txt").read_text().splitlines()) == 2


def test_a_second_run_into_the_same_folder_is_refused(finished_run):
    before = (finished_run / "config.yml").read_bytes()
    args = ["--timesteps", "256", "--output", str(finished_run), "--eval-freq", "0", *SMALL_RUN]
    assert train.main(args) == train.EXIT_USAGE
    assert (finished_run / "config.yml").read_bytes() == before


def test_a_mismatched_policy_raises_naming_both_spaces(finished_run, tmp_path):
    other = gym.make("mobile_envs/ConstantVelocity-Segments-v0")
    mismatch = r"observation space is Box.*\(45,\).*the env.s is Box.*\(47,\)"
    with pytest.raises(ValueError, match=mismatch):
        load_policy(finished_run / "final_model.zip", other)
    # Same observation and action sizes, another robot: the recorded training env tells.
    bicycle = gym.make("mobile_envs/Bicycle-Segments-v0")
    with pytest.raises(ValueError, match="trained on mobile_envs/DiffDrive-Random-v0"):
        load_policy(finished_run / "final_model.zip", bicycle)
    with pytest.raises(ValueError, match="no policy file"):
        load_policy(tmp_path / "missing.zip", other)


def test_evaluate_command_reports_the_harness_summary(finished_run, capsys):
    code = train.main(
        [
            "evaluate",
            "--model",
            str(finished_run / "final_model.zip"),
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


# ------------------------------------------------------------------ atomic, durable writes


def test_a_write_syncs_the_file_renames_it_then_syncs_the_folder(tmp_path, monkeypatch):
    events: list[tuple[str, object, object]] = []
    real_fsync, real_replace = os.fsync, os.replace

    def fsync(descriptor):
        status = os.fstat(descriptor)
        kind = "folder" if stat.S_ISDIR(status.st_mode) else "file"
        events.append(("fsync", kind, status.st_ino))
        real_fsync(descriptor)

    def replace(source, target):
        events.append(("replace", os.stat(source).st_ino, pathlib.Path(target)))
        real_replace(source, target)

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace)
    target = tmp_path / "config.yml"
    write_atomically(target, lambda file: file.write(b"new"))

    file_sync, rename, folder_sync = events
    assert file_sync[:2] == ("fsync", "file")
    assert rename == ("replace", file_sync[2], target)  # the synced file is the one renamed
    assert folder_sync == ("fsync", "folder", tmp_path.stat().st_ino)
    assert target.read_bytes() == b"new" and os.listdir(tmp_path) == ["config.yml"]


@pytest.mark.parametrize(
    "failure",
    [KeyboardInterrupt(), OSError(errno.ENOSPC, "No space left on device")],
    ids=["signal", "disk-full"],
)
def test_a_write_stopped_midway_keeps_the_old_file_and_leaves_no_partial(tmp_path, failure):
    target = tmp_path / "latest.zip"
    target.write_bytes(b"old checkpoint")

    def write_half(file):
        file.write(b"half of a new")
        raise failure

    with pytest.raises(type(failure)) as raised:
        write_atomically(target, write_half)
    if isinstance(failure, OSError):
        assert raised.value.errno == errno.ENOSPC and raised.value.filename == str(target)
    assert target.read_bytes() == b"old checkpoint"
    assert os.listdir(tmp_path) == ["latest.zip"]


def test_a_resumed_run_keeps_its_best_model_unless_a_better_one_comes(tmp_path, monkeypatch):
    """The best score lives beside best_model.zip, so a resumed run's first (worse)
    evaluation does not replace the best policy; evaluations count from the resumed step."""
    from stable_baselines3.common.logger import configure

    from agents.ppo import BEST_SCORE_FILE, HarnessEvalCallback

    scores = iter([(0.9, 0.02), (0.8, 0.01), (0.85, 0.01), (0.9, 0.015)])

    class Result:
        def __init__(self, completion, cte):
            self.summary = {"completion_rate": completion, "mean_abs_cte": cte}

    # agents.evaluate is both a module and (re-exported by agents) its function.
    evaluate_module = sys.modules["agents.evaluate"]
    monkeypatch.setattr(evaluate_module, "evaluate", lambda *args, **kwargs: Result(*next(scores)))

    class Model:
        """Stands in for a policy: saving writes which evaluation it was saved at."""

        def __init__(self):
            self.logger = configure(None, [])
            self.saved_at = 0

        def save(self, file):
            file.write(f"policy {self.saved_at}".encode())

    def evaluate_at(callback, step):
        callback.num_timesteps = callback.model.saved_at = step
        callback.run_evaluation()

    def run(steps):
        callback = HarnessEvalCallback("mobile_envs/DiffDrive-Lines-v0", tmp_path, every=1)
        callback.model = Model()  # the callback's logger is its model's
        for step in steps:
            evaluate_at(callback, step)
        return callback

    best = tmp_path / "best_model.zip"
    run([100, 200])  # 0.9 then a worse 0.8: the first is kept
    assert best.read_bytes() == b"policy 100"
    assert json.loads((tmp_path / BEST_SCORE_FILE).read_text()) == {
        "completion_rate": 0.9,
        "mean_abs_cte": 0.02,
    }
    resumed = run([300])  # after a resume: 0.85, worse than the kept 0.9
    assert best.read_bytes() == b"policy 100"
    evaluate_at(resumed, 400)  # 0.9 with a smaller error: better
    assert best.read_bytes() == b"policy 400"
    assert resumed.best_score == (0.9, -0.015)
    resumed.num_timesteps = 4096
    resumed._on_training_start()
    assert not resumed.every or resumed._last == 4096  # the next evaluation is due later

"""train.py: a short run saves, loads and predicts; Ctrl-C and SIGTERM keep the work; --resume
continues to the run's total, for PPO, SAC, TD3 and TQC (an off-policy run with its replay
buffer); a run never overwrites a folder; saves are atomic and durable; the same command twice
gives the same weights bit for bit; run folders record the machine; the warm_start hook is
called once, for a new run.

The failure cases of the command lines (one line, no traceback) are in test_cli_errors.py.
"""

import atexit
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
import tempfile
import time

import gymnasium as gym
import numpy as np
import pytest
import torch

pytest.importorskip("yaml", reason="training reads YAML (the train extra)")

import yaml

pytest.importorskip("stable_baselines3", reason="training needs the train extra")

import train
from agents.harness.policies import load_policy
from agents.interrupts import StopRequests
from agents.training.checkpoints import load_checkpoint, replay_buffer_path
from agents.training.files import write_atomically
from agents.training.machine import read_machine_file

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: PPO's default settings in hyperparams/ppo.yml, without the entries' warm start: these tests
#: check the machinery, and a behaviour-cloning warm start would take most of their time.
SMALL_PPO = {
    "default": {
        "n_steps": 256,
        "batch_size": 1024,
        "n_epochs": 10,
        "policy_kwargs": {"net_arch": [64, 64], "log_std_init": -0.5},
    }
}
SMALL_PPO_FILE = pathlib.Path(tempfile.mkdtemp(prefix="test_train_")) / "ppo.yml"
SMALL_PPO_FILE.write_text(yaml.safe_dump(SMALL_PPO))
atexit.register(shutil.rmtree, SMALL_PPO_FILE.parent, ignore_errors=True)
SMALL_FLAGS = ["--n-envs", "4", "--no-progress", "--eval-episodes", "1"]
SMALL_RUN = [*SMALL_FLAGS, "--hyperparams", str(SMALL_PPO_FILE)]
ROLLOUT = 4 * 256  # 4 robots x n_steps in hyperparams/ppo.yml: PPO trains in whole rollouts
OFF_POLICY = ("sac", "td3", "tqc")
#: Off-policy settings that train a few hundred steps in a second or two.
TINY_OFF_POLICY = {
    "learning_starts": 64,
    "buffer_size": 20_000,
    "batch_size": 32,
    "train_freq": 1,
    "gradient_steps": 1,
    "policy_kwargs": {"net_arch": [16, 16]},
}


def tiny_hyperparams(folder: pathlib.Path, algo: str, **extra) -> pathlib.Path:
    """A hyperparameter file for ``algo`` with one tiny ``default`` entry."""
    entry = {**TINY_OFF_POLICY, **extra}
    if algo == "td3":
        entry.update(noise_type="normal", noise_std=0.1)
    if algo == "ppo":
        entry = {"n_steps": 64, "batch_size": 64, "policy_kwargs": {"net_arch": [16, 16]}, **extra}
    path = folder / f"{algo}.yml"
    path.write_text(yaml.safe_dump({"default": entry}))
    return path


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


def start_training(
    command: list[str], folder: pathlib.Path, flags: list[str] = SMALL_RUN
) -> subprocess.Popen:
    """Start a long run and return once it has saved its first periodic checkpoint."""
    environment = {**os.environ, "OMP_NUM_THREADS": "1"}
    settings = ["--timesteps", "1000000", "--eval-freq", "0", "--checkpoint-freq", str(ROLLOUT)]
    process = subprocess.Popen(
        [*command, *settings, "--output", str(folder), *flags],
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


def interrupt_training(
    command: list[str], folder: pathlib.Path, signum: int, flags: list[str] = SMALL_RUN
) -> str:
    """Start a long run (:func:`start_training`), send it ``signum`` once it has saved its
    first checkpoint, and assert that it exits with 128 + ``signum``, nothing on stderr.

    :return: what the run printed
    """
    process = start_training(command, folder, flags)
    process.send_signal(signum)
    output, errors = process.communicate(timeout=60)
    assert process.returncode == 128 + signum, output + errors
    assert errors == ""
    return output


def test_sigterm_saves_a_checkpoint_exits_143_and_resume_reaches_the_new_total(tmp_path):
    folder = tmp_path / "run"
    output = interrupt_training([sys.executable, "train.py"], folder, signal.SIGTERM)
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
    output = interrupt_training([sys.executable, "train.py"], folder, signal.SIGINT)
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

    from agents.training.checkpoints import BEST_SCORE_FILE, HarnessEvalCallback

    scores = iter([(0.9, 0.02), (0.8, 0.01), (0.85, 0.01), (0.9, 0.015)])

    class Result:
        def __init__(self, completion, cte):
            self.summary = {"completion_rate": completion, "mean_abs_cte": cte}

    # agents.harness.evaluate is both a module and (re-exported by agents) its function.
    evaluate_module = sys.modules["agents.harness.evaluate"]
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
        "steps": 100,
    }
    resumed = run([300])  # after a resume: 0.85, worse than the kept 0.9
    assert best.read_bytes() == b"policy 100"
    evaluate_at(resumed, 400)  # 0.9 with a smaller error: better
    assert best.read_bytes() == b"policy 400"
    assert resumed.best_score == (0.9, -0.015)
    resumed.num_timesteps = 4096
    resumed._on_training_start()
    assert not resumed.every or resumed._last == 4096  # the next evaluation is due later


# ------------------------------------------------------------------ SAC, TD3, TQC


def test_an_off_policy_periodic_checkpoint_s_buffer_holds_every_step_it_counts(tmp_path):
    # SB3 stores a step's transitions after the callbacks' on_step: a checkpoint saved there
    # would count one step more than its buffer holds.
    from stable_baselines3 import SAC

    from agents.training.checkpoints import AtomicCheckpointCallback
    from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv

    env = PathFollowingSB3VecEnv("mobile_envs/DiffDrive-Random-v0", 4, seed=0)
    model = SAC("MlpPolicy", env, learning_starts=1000, buffer_size=1000, seed=0, device="cpu")
    model.learn(48, callback=AtomicCheckpointCallback(tmp_path, every=20))
    saved = load_checkpoint(tmp_path)
    assert saved.num_timesteps == 40  # due at 20 steps, 4 robots a step: 20, 40
    assert saved.replay_buffer.size() * 4 == saved.num_timesteps


@pytest.mark.parametrize("algo", OFF_POLICY)
def test_an_off_policy_run_resumes_after_sigterm_with_its_replay_buffer(algo, tmp_path):
    folder = tmp_path / "run"
    hyperparams = tiny_hyperparams(tmp_path, algo)
    command = [sys.executable, "train.py", "--algo", algo, "--hyperparams", str(hyperparams)]
    output = interrupt_training(command, folder, signal.SIGTERM, SMALL_FLAGS)
    saved = interrupted_step(output, "SIGTERM")
    assert f"Continue with: python train.py --resume {folder}" in output
    # The buffer saved with the checkpoint holds every transition collected up to it.
    checkpoint = load_checkpoint(folder)
    assert type(checkpoint).__name__ == algo.upper() and checkpoint.num_timesteps == saved
    assert checkpoint.replay_buffer.size() * 4 == saved
    assert [path.name for path in (folder / "checkpoints").glob("*.pkl")] == [
        replay_buffer_path(folder, saved).name
    ]

    total = saved + 40  # off-policy runs train in whole collections: 4 robots x train_freq 1
    assert train.main(["--resume", str(folder), "--timesteps", str(total), "--no-progress"]) == 0
    resumed = load_checkpoint(folder)
    assert resumed.num_timesteps == total
    # Continued, not restarted: the buffer has the transitions from before the interruption.
    assert resumed.replay_buffer.size() * 4 == total
    assert load_policy(folder / "final_model.zip", algo=algo).num_timesteps == total
    config = yaml.safe_load((folder / "config.yml").read_text())
    assert config["algo"] == algo and config[algo]["batch_size"] == 32
    # What the YAML said, not what SB3 added to it while building the model (use_sde).
    assert config[algo]["policy_kwargs"] == TINY_OFF_POLICY["policy_kwargs"]
    assert [entry["started_at_step"] for entry in read_machine_file(folder)] == [0, saved]


def test_an_off_policy_resume_without_its_replay_buffer_is_refused(tmp_path):
    folder = tmp_path / "run"
    hyperparams = tiny_hyperparams(tmp_path, "sac")
    args = ["--algo", "sac", "--hyperparams", str(hyperparams), "--output", str(folder)]
    assert train.main([*args, "--timesteps", "128", "--eval-freq", "0", *SMALL_FLAGS]) == 0
    replay_buffer_path(folder, 128).unlink()
    code = train.main(["--resume", str(folder), "--timesteps", "256", "--no-progress"])
    assert code == train.EXIT_USAGE
    assert load_policy(folder / "checkpoints" / "latest.zip").num_timesteps == 128


def test_the_default_hyperparams_follow_the_algo():
    for algo in ("ppo", *OFF_POLICY):
        args = train.parse_args(["--algo", algo])
        assert args.hyperparams == ROOT / "hyperparams" / f"{algo}.yml"
        entry = yaml.safe_load(args.hyperparams.read_text())["default"]
        from agents.training.runs import check_algorithm_settings

        ignored = ("n_timesteps", "n_envs", "env_kwargs", "warm_start")
        settings = {k: v for k, v in entry.items() if k not in ignored}
        check_algorithm_settings(algo, settings, args.hyperparams)  # every key is the algo's


# ------------------------------------------------------------------ reproducibility


def policy_weights(path: pathlib.Path) -> dict[str, torch.Tensor]:
    return load_policy(path).policy.state_dict()


@pytest.mark.parametrize("algo", ["ppo", *OFF_POLICY])
def test_the_same_command_twice_gives_the_same_weights_bit_for_bit(algo, tmp_path):
    hyperparams = tiny_hyperparams(tmp_path, algo)
    weights = []
    for name in ("first", "second"):
        folder = tmp_path / name
        args = ["--algo", algo, "--hyperparams", str(hyperparams), "--output", str(folder)]
        assert train.main([*args, "--timesteps", "512", "--eval-freq", "0", *SMALL_FLAGS]) == 0
        weights.append(policy_weights(folder / "final_model.zip"))
    first, second = weights
    assert first.keys() == second.keys()
    for key in first:
        assert first[key].dtype == second[key].dtype
        assert torch.equal(first[key], second[key]), key
    # Training moved the weights: the equality is not that of two untouched initializations.
    other = tmp_path / "seed1"
    args = ["--algo", algo, "--hyperparams", str(hyperparams), "--output", str(other)]
    assert (
        train.main([*args, "--seed", "1", "--timesteps", "512", "--eval-freq", "0", *SMALL_FLAGS])
        == 0
    )
    moved = policy_weights(other / "final_model.zip")
    assert any(not torch.equal(first[key], moved[key]) for key in first)


# ------------------------------------------------------------------ machine.yml


def test_a_run_folder_records_the_machine_and_its_settings(finished_run, monkeypatch, tmp_path):
    entries = read_machine_file(finished_run)
    assert len(entries) == 1
    entry = entries[0]
    assert entry["started_at_step"] == 0
    assert entry["python"] == ".".join(map(str, sys.version_info[:3]))
    import numba
    import sb3_contrib
    import stable_baselines3

    assert entry["libraries"] == {
        "numpy": np.__version__,
        "numba": numba.__version__,
        "torch": torch.__version__,
        "gymnasium": gym.__version__,
        "stable_baselines3": stable_baselines3.__version__,
        "sb3_contrib": sb3_contrib.__version__,
    }
    cpuinfo = pathlib.Path("/proc/cpuinfo")
    if cpuinfo.is_file():
        text = cpuinfo.read_text()
        model = re.search(r"^model name\s*:\s*(.+)$", text, re.MULTILINE)
        flags = set(re.search(r"^flags\s*:(.*)$", text, re.MULTILINE)[1].split())
        assert model is None or entry["cpu"]["model"] == model[1].strip()
        assert ("avx2" in entry["cpu"]["kernel_flags"]) == ("avx2" in flags)
        assert ("avx512f" in entry["cpu"]["kernel_flags"]) == ("avx512f" in flags)
    assert entry["cpu"]["logical_cores"] == os.cpu_count()
    assert entry["torch"]["num_threads"] == 1  # --threads' default, set before the record
    assert entry["torch"]["cpu_capability"] == torch.backends.cpu.get_cpu_capability()

    # Two threads and a NUMBA_ setting, as a resumed session on another machine might have.
    folder = tmp_path / "run"
    shutil.copytree(finished_run, folder)
    monkeypatch.setenv("NUMBA_OPT", "2")
    args = ["--resume", str(folder), "--timesteps", str(2 * ROLLOUT), "--threads", "2"]
    try:
        assert train.main([*args, "--no-progress"]) == 0
    finally:
        torch.set_num_threads(1)
    first, resumed = read_machine_file(folder)
    assert first == entry
    assert resumed["started_at_step"] == ROLLOUT
    assert resumed["torch"]["num_threads"] == 2
    assert resumed["environment"]["NUMBA_OPT"] == "2"


# ------------------------------------------------------------------ warm start


class WarmStartRecorder:
    """Stands in for agents.training.imitation: records each call, and moves every weight (but the
    log standard deviations) by +0.5, a mark the trained policy must carry."""

    def __init__(self):
        self.calls = []
        self.stop_polls = []
        self.checkpoints = []
        self.warm_weights = None

    def warm_start(
        self, model, env_id, check_stop=None, checkpoint=None, progress=False, label="", **kwargs
    ):
        self.calls.append((type(model).__name__, model.num_timesteps, env_id, kwargs))
        self.stop_polls.append(check_stop)
        self.checkpoints.append(checkpoint)
        with torch.no_grad():
            for name, parameter in model.policy.named_parameters():
                if "log_std" not in name:
                    parameter.add_(0.5)
        self.warm_weights = {k: v.clone() for k, v in model.policy.state_dict().items()}

    def assert_trained_from_warm_weights(self, final):
        """A few hundred steps move weights by a few hundredths: the final weights lie near the
        warm-started ones, half a unit from any fresh initialization."""
        for key, warm in self.warm_weights.items():
            if warm.is_floating_point():
                assert float((final[key] - warm).abs().max()) < 0.1, key


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_a_warm_start_entry_is_called_once_before_training_of_a_new_run(
    algo, tmp_path, monkeypatch
):
    import types

    recorder = WarmStartRecorder()
    module = types.ModuleType("agents.training.imitation")
    module.warm_start = recorder.warm_start
    monkeypatch.setitem(sys.modules, "agents.training.imitation", module)
    settings = {"steps": 300, "robots": 8}
    env_kwargs = {"start_noise": [0.2, 0.3]}
    hyperparams = tiny_hyperparams(tmp_path, algo, warm_start=settings, env_kwargs=env_kwargs)
    folder = tmp_path / "run"
    args = ["--algo", algo, "--hyperparams", str(hyperparams), "--output", str(folder)]
    assert (
        train.main([*args, "--seed", "7", "--timesteps", "256", "--eval-freq", "0", *SMALL_FLAGS])
        == 0
    )
    assert recorder.calls == [
        (
            algo.upper(),
            0,
            train.DEFAULT_ENV,
            {"seed": 7, "env_kwargs": env_kwargs, **settings},
        )
    ]
    # train.py's stop requests, polled between the warm start's steps (tests/test_interrupts)
    (poll,) = recorder.stop_polls
    assert poll.__func__ is StopRequests.raise_if_requested
    assert recorder.checkpoints == [folder / "checkpoints" / "warm_start.pkl"]
    config = yaml.safe_load((folder / "config.yml").read_text())
    assert config["warm_start"] == settings and "warm_start" not in config[algo]
    recorder.assert_trained_from_warm_weights(policy_weights(folder / "final_model.zip"))

    assert train.main(["--resume", str(folder), "--timesteps", "512", "--no-progress"]) == 0
    assert len(recorder.calls) == 1  # a resumed run keeps its weights


def test_train_run_warm_starts_a_new_run_too(tmp_path, monkeypatch):
    """agents.training.runs.train_run (the sweep's and the grid's trainer) calls the same hook."""
    import types

    from agents.training.runs import run_config, train_run

    recorder = WarmStartRecorder()
    module = types.ModuleType("agents.training.imitation")
    module.warm_start = recorder.warm_start
    monkeypatch.setitem(sys.modules, "agents.training.imitation", module)
    hyperparams = tiny_hyperparams(tmp_path, "ppo", warm_start={"epochs": 2}, n_envs=4)
    config = run_config(train.DEFAULT_ENV, hyperparams, seed=3, timesteps=256)
    assert config["warm_start"] == {"epochs": 2}
    train_run(tmp_path / "run", config)
    assert recorder.calls == [
        ("PPO", 0, train.DEFAULT_ENV, {"seed": 3, "env_kwargs": {}, "epochs": 2})
    ]
    assert recorder.stop_polls == [None]  # no stop requests were given
    train_run(tmp_path / "run")  # at its total: resumes, trains nothing, no second call
    assert len(recorder.calls) == 1


def test_two_runs_started_at_once_on_one_output_do_not_overwrite_each_other(tmp_path):
    """Issue 30: both exited 0 and the folder held the second run. The folder is claimed by
    creating its command.txt exclusively: one run trains, the other is refused."""
    folder = tmp_path / "run"
    command = [sys.executable, "train.py", "--timesteps", str(ROLLOUT), "--eval-freq", "0"]
    runs = [
        subprocess.Popen(
            [*command, "--seed", str(seed), "--output", str(folder), *SMALL_RUN],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for seed in (1, 2)
    ]
    outcomes = [(run.wait(timeout=300), run.stderr.read()) for run in runs]
    assert sorted(status for status, _ in outcomes) == [0, 2], outcomes
    winner, loser = (0, 1) if outcomes[0][0] == 0 else (1, 0)
    line = outcomes[loser][1].strip()
    assert len(line.splitlines()) == 1 and str(folder) in line and "Traceback" not in line
    assert yaml.safe_load((folder / "config.yml").read_text())["seed"] == winner + 1
    (claim,) = (folder / "command.txt").read_text().splitlines()
    assert shlex.split(claim)[shlex.split(claim).index("--seed") + 1] == str(winner + 1)


def test_a_write_into_a_read_only_folder_names_the_file_not_the_temporary_one(
    tmp_path, monkeypatch
):
    """Issue 30: a resume on a read-only folder named a temporary .partial file: the open
    failed, and so did removing the temporary file it never made."""
    target = tmp_path / "machine.yml"
    real_open = open

    def read_only(path, *args, **kwargs):
        if str(path).endswith(".partial"):
            raise OSError(errno.EROFS, "Read-only file system", str(path))
        return real_open(path, *args, **kwargs)

    def unlink(path, *args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system", str(path))

    monkeypatch.setattr("builtins.open", read_only)
    monkeypatch.setattr(pathlib.Path, "unlink", unlink)
    with pytest.raises(OSError) as raised:
        write_atomically(target, lambda file: file.write(b"new"))
    assert raised.value.errno == errno.EROFS and raised.value.filename == str(target)


def test_a_write_that_must_not_replace_refuses_a_file_that_appeared(tmp_path):
    target = tmp_path / "policy.onnx"
    write_atomically(target, lambda file: file.write(b"first"), overwrite=False)
    with pytest.raises(FileExistsError) as raised:
        write_atomically(target, lambda file: file.write(b"second"), overwrite=False)
    assert raised.value.filename == str(target)
    assert target.read_bytes() == b"first" and os.listdir(tmp_path) == ["policy.onnx"]


# ------------------------------------------------------------------ snapshots


def test_snapshots_keep_the_policy_every_n_steps_and_change_nothing_of_the_run(tmp_path):
    """--snapshot-every 256 keeps the policy at steps 0, 256 and 512 with when each was saved;
    the run ends at the weights of a run without snapshots, and its last snapshot is them."""
    hyperparams = tiny_hyperparams(tmp_path, "ppo")  # 4 robots x 64 steps: 256 a rollout
    flags = ["--hyperparams", str(hyperparams), "--timesteps", "512", "--eval-freq", "0"]
    plain, snapshotted = tmp_path / "plain", tmp_path / "snapshotted"
    assert train.main([*flags, *SMALL_FLAGS, "--output", str(plain)]) == 0
    started = time.time()
    assert (
        train.main([*flags, *SMALL_FLAGS, "--output", str(snapshotted), "--snapshot-every", "256"])
        == 0
    )
    assert not (plain / "snapshots").exists(), "no snapshots unless asked"
    folder = snapshotted / "snapshots"
    names = sorted(path.name for path in folder.glob("*.zip"))
    assert names == [f"steps_{steps:010d}.zip" for steps in (0, 256, 512)]
    times = [line.split(",") for line in (folder / "times.csv").read_text().splitlines()]
    assert [int(row[0]) for row in times] == [0, 256, 512]
    walls = [float(row[1]) for row in times]
    cpus = [float(row[2]) for row in times]
    assert started <= walls[0] <= walls[1] <= walls[2] <= time.time()
    assert 0 < cpus[0] <= cpus[1] <= cpus[2]
    final = policy_weights(snapshotted / "final_model.zip")
    for name, weights in policy_weights(plain / "final_model.zip").items():
        assert torch.equal(weights, final[name]), name
    last = policy_weights(folder / "steps_0000000512.zip")
    first = policy_weights(folder / "steps_0000000000.zip")
    assert all(torch.equal(last[name], final[name]) for name in final)
    assert any(not torch.equal(first[name], final[name]) for name in final)


def test_best_model_is_the_best_evaluated_policy_and_evaluating_changes_nothing(
    tmp_path, monkeypatch
):
    """Evaluations run between collections and at the end: with --eval-freq and
    --snapshot-every 256, they measure the snapshots of steps 256 to 1024. best_model.zip is
    the snapshot that the harness, run on each snapshot alone, scores best (the highest
    completion, then the lowest mean |cte|, the earliest of ties), best_model.json its score;
    and the run trains to the weights of a run without evaluations."""
    from agents.harness.evaluate import evaluate

    measured = []  # the weights of each policy the run evaluates, in order

    def recording_evaluate(agent, *args, **kwargs):
        measured.append({name: value.clone() for name, value in agent.policy.state_dict().items()})
        return evaluate(agent, *args, **kwargs)

    # agents.harness.evaluate is both a module and (re-exported by agents) its function.
    monkeypatch.setattr(sys.modules["agents.harness.evaluate"], "evaluate", recording_evaluate)
    hyperparams = tiny_hyperparams(tmp_path, "ppo")  # 4 robots x 64 steps: 256 a rollout
    flags = ["--hyperparams", str(hyperparams), "--timesteps", "1024", "--n-envs", "4"]
    plain, evaluated = tmp_path / "plain", tmp_path / "evaluated"
    assert train.main([*flags, "--no-progress", "--eval-freq", "0", "--output", str(plain)]) == 0
    assert not (plain / "best_model.zip").exists(), "no evaluations, no best model"
    evaluations = ["--eval-freq", "256", "--eval-episodes", "3", "--snapshot-every", "256"]
    assert train.main([*flags, "--no-progress", *evaluations, "--output", str(evaluated)]) == 0
    final = policy_weights(evaluated / "final_model.zip")
    for name, weights in policy_weights(plain / "final_model.zip").items():
        assert torch.equal(weights, final[name]), name

    snapshots = [
        evaluated / "snapshots" / f"steps_{steps:010d}.zip" for steps in (256, 512, 768, 1024)
    ]
    assert len(measured) == len(snapshots)
    for weights, snapshot in zip(measured, snapshots, strict=True):
        kept = policy_weights(snapshot)
        assert all(torch.equal(value, kept[name]) for name, value in weights.items()), snapshot.name

    env_kwargs = yaml.safe_load((evaluated / "config.yml").read_text())["env_kwargs"]
    scores = {}
    for snapshot in snapshots:
        summary = evaluate(
            load_policy(snapshot), "mobile_envs/DiffDrive-Random-v0", 3, seed=10_000, **env_kwargs
        ).summary
        scores[snapshot] = (summary["completion_rate"], -summary["mean_abs_cte"])
    best = max(scores, key=lambda snapshot: scores[snapshot])  # max keeps the first of ties
    kept = policy_weights(evaluated / "best_model.zip")
    assert all(torch.equal(weights, kept[name]) for name, weights in policy_weights(best).items())
    record = json.loads((evaluated / "best_model.json").read_text())
    assert (record["completion_rate"], -record["mean_abs_cte"]) == scores[best]
    assert best.name == f"steps_{record['steps']:010d}.zip"


def test_a_linear_schedule_falls_to_zero_so_the_last_update_changes_nothing(tmp_path):
    """``learning_rate: lin_1e-3`` as rl-baselines3-zoo writes it: the rate falls linearly from
    1e-3 to 0 over the run. SB3 updates after each rollout at the fraction of the run left, so
    over two rollouts the first update runs at 5e-4 and the last at 0: Adam moves nothing, and
    the final policy is the one snapshotted after the first rollout. The saved model keeps the
    schedules themselves, not their last values."""
    schedules = {"learning_rate": "lin_1e-3", "clip_range": "lin_0.2"}
    hyperparams = tiny_hyperparams(tmp_path, "ppo", **schedules)  # 256 steps a rollout
    folder = tmp_path / "run"
    flags = ["--hyperparams", str(hyperparams), "--timesteps", "512", "--eval-freq", "0"]
    assert (
        train.main([*flags, *SMALL_FLAGS, "--output", str(folder), "--snapshot-every", "256"]) == 0
    )
    assert yaml.safe_load((folder / "config.yml").read_text())["ppo"]["learning_rate"] == "lin_1e-3"
    final = policy_weights(folder / "final_model.zip")
    after_one = policy_weights(folder / "snapshots" / "steps_0000000256.zip")
    before = policy_weights(folder / "snapshots" / "steps_0000000000.zip")
    assert all(torch.equal(after_one[name], final[name]) for name in final)
    assert any(not torch.equal(before[name], after_one[name]) for name in final)
    model = load_policy(folder / "final_model.zip")
    assert model.lr_schedule(0.5) == pytest.approx(5e-4, rel=1e-12)
    assert model.clip_range(0.25) == pytest.approx(0.05, rel=1e-12)
    assert model.policy.optimizer.param_groups[0]["lr"] == 0.0


def test_a_trained_agent_is_where_a_new_run_starts_and_its_entry_sets_how_it_learns(tmp_path):
    """``--trained-agent`` (rl-baselines3-zoo's ``-i``): a new run starts from the saved
    weights, not from a fresh network nor the entry's warm start, and learns with its own
    entry's settings. Over one rollout a ``lin_1e-3`` rate updates at 0, so the final policy
    is the trained agent's bit for bit; at a constant 1e-3 it moves. The steps count from 0
    and config.yml records the agent, without the warm start."""
    source = tmp_path / "source"
    flags = ["--timesteps", "256", "--eval-freq", "0", *SMALL_FLAGS]  # one rollout: 4 x 64
    first = ["--hyperparams", str(tiny_hyperparams(tmp_path, "ppo")), "--seed", "1"]
    assert train.main([*flags, *first, "--output", str(source)]) == 0
    agent = source / "final_model.zip"
    warm_start = {"teacher": "regulated_pure_pursuit", "robots": 2, "steps": 50, "epochs": 1}
    finals = {}
    for rate in ("lin_1e-3", 1e-3):
        folder = tmp_path / f"from_agent_{rate}"
        hyperparams = tiny_hyperparams(
            folder.parent, "ppo", learning_rate=rate, warm_start=warm_start
        )
        argv = [*flags, "--hyperparams", str(hyperparams), "--trained-agent", str(agent)]
        assert train.main([*argv, "--output", str(folder), "--seed", "2"]) == 0
        config = yaml.safe_load((folder / "config.yml").read_text())
        assert config["trained_agent"] == str(agent) and "warm_start" not in config
        assert config["ppo"]["learning_rate"] == rate
        assert load_policy(folder / "final_model.zip").num_timesteps == 256
        finals[rate] = policy_weights(folder / "final_model.zip")
    start = policy_weights(agent)
    assert all(torch.equal(start[name], finals["lin_1e-3"][name]) for name in start)
    assert any(not torch.equal(start[name], finals[1e-3][name]) for name in start)


def test_the_fine_tuning_entries_are_settings_ppo_and_the_env_take():
    """hyperparams/ppo_finetune.yml (fine-tuning on the drawn robots): every entry is PPO's
    settings and env kwargs the env builds with (its randomized plant), and none warm-starts:
    a run from a trained agent starts from that agent's weights."""
    from agents.training.runs import check_algorithm_settings, check_env_kwargs, run_config

    path = ROOT / "hyperparams" / "ppo_finetune.yml"
    for env_id in yaml.safe_load(path.read_text()):
        config = run_config(env_id, path)
        check_algorithm_settings("ppo", config["ppo"], path)
        check_env_kwargs(env_id, config, path)
        assert "warm_start" not in config and config["env_kwargs"]["plant"]["randomize"]

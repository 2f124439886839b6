"""The command lines answer bad input and failing folders with one line, never a traceback.

Every case runs the real CLI in a subprocess and checks its exit status (2: bad input, an
argument or a file it names; 1: the system failed the command), that stderr is exactly one
``PROG: error: ...`` line naming the file or the argument, and that nothing was overwritten.
"""

import atexit
import os
import pathlib
import resource
import shutil
import subprocess
import sys
import tempfile

import gymnasium as gym
import pytest

pytest.importorskip("yaml", reason="the CLIs read YAML (the train extra)")
pytest.importorskip("hypothesis", reason="the fuzz cases need hypothesis (the dev extra)")

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("stable_baselines3", reason="the model files need the train extra")
from stable_baselines3 import PPO

import mobile_envs  # noqa: F401  (registers the ids)
import train
from agents.harness.policies import load_policy

ROOT = pathlib.Path(__file__).resolve().parents[1]
TRAIN = [sys.executable, str(ROOT / "train.py")]
COMPARE = [sys.executable, "-m", "agents.harness.compare"]
LINES = "mobile_envs/DiffDrive-Lines-v0"
#: PPO's default settings without the warm start some entries of hyperparams/ppo.yml have:
#: these tests check messages, not learning.
FAST_PPO = {
    "default": {"n_steps": 256, "batch_size": 1024, "policy_kwargs": {"net_arch": [64, 64]}}
}
FAST_PPO_FILE = pathlib.Path(tempfile.mkdtemp(prefix="test_cli_errors_")) / "ppo.yml"
FAST_PPO_FILE.write_text(yaml.safe_dump(FAST_PPO))
atexit.register(shutil.rmtree, FAST_PPO_FILE.parent, ignore_errors=True)
FAST_FLAGS = ["--n-envs", "4", "--eval-freq", "0", "--no-progress"]
FAST_RUN = [*FAST_FLAGS, "--hyperparams", str(FAST_PPO_FILE)]


def run(command: list[str], **options) -> subprocess.CompletedProcess:
    environment = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.run(
        command, cwd=ROOT, capture_output=True, text=True, timeout=120, env=environment, **options
    )


def assert_one_line_error(result: subprocess.CompletedProcess, status: int, *named: str) -> str:
    """The line, after checking the status, the single line and the things it names."""
    assert result.returncode == status, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert ": error: " in lines[0]
    for text in named:
        assert text in lines[0], (text, lines[0])
    return lines[0]


@pytest.fixture(scope="module")
def policy_file(tmp_path_factory) -> pathlib.Path:
    """An untrained but complete PPO policy for the DiffDrive envs."""
    path = tmp_path_factory.mktemp("policy") / "policy.zip"
    PPO("MlpPolicy", gym.make(LINES), n_steps=64, batch_size=64, device="cpu").save(path)
    return path


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> pathlib.Path:
    """A real run of 1024 steps (one rollout of 4 robots x 256 steps)."""
    folder = tmp_path_factory.mktemp("runs") / "finished"
    assert train.main(["--timesteps", "1024", "--output", str(folder), *FAST_RUN]) == 0
    return folder


def truncated_copy(source: pathlib.Path, target: pathlib.Path) -> pathlib.Path:
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_bytes(source.read_bytes()[: source.stat().st_size // 2])
    return target


def snapshot(folder: pathlib.Path) -> dict[str, bytes]:
    files = (path for path in folder.rglob("*") if path.is_file())
    return {str(path.relative_to(folder)): path.read_bytes() for path in files}


# ------------------------------------------------------------------ model files


def test_evaluate_names_a_truncated_model(policy_file, tmp_path):
    model = truncated_copy(policy_file, tmp_path / "cut.zip")
    result = run([*TRAIN, "evaluate", "--model", str(model), "--env", LINES, "--episodes", "1"])
    assert_one_line_error(result, 2, str(model), "truncated")


def test_compare_names_a_truncated_model(policy_file, tmp_path):
    model = truncated_copy(policy_file, tmp_path / "cut.zip")
    result = run(
        [*COMPARE, "--agents", f"ppo:{model}", "--envs", LINES, "--output", str(tmp_path / "out")]
    )
    assert_one_line_error(result, 2, str(model), "truncated")


def test_resume_names_a_truncated_checkpoint(finished_run, tmp_path):
    folder = tmp_path / "run"
    (folder / "checkpoints").mkdir(parents=True)
    (folder / "config.yml").write_bytes((finished_run / "config.yml").read_bytes())
    checkpoint = truncated_copy(
        finished_run / "checkpoints" / "latest.zip", folder / "checkpoints" / "latest.zip"
    )
    result = run([*TRAIN, "--resume", str(folder)])
    assert_one_line_error(result, 2, str(checkpoint))


def test_export_names_a_missing_or_truncated_model(policy_file, tmp_path):
    output = tmp_path / "policy.onnx"
    result = run([*TRAIN, "export", "--model", str(tmp_path / "none.zip"), "--output", str(output)])
    assert_one_line_error(result, 2, str(tmp_path / "none.zip"))
    model = truncated_copy(policy_file, tmp_path / "cut.zip")
    result = run([*TRAIN, "export", "--model", str(model), "--output", str(output)])
    assert_one_line_error(result, 2, str(model), "truncated")
    assert not output.exists()


def test_export_to_a_folder_that_cannot_be_created_is_one_line_with_status_1(policy_file, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    output = blocker / "policy.onnx"
    result = run([*TRAIN, "export", "--model", str(policy_file), "--output", str(output)])
    assert_one_line_error(result, 1, str(output))


def test_an_algo_prefix_that_does_not_match_the_zip_is_named(policy_file, tmp_path):
    result = run(
        [*COMPARE, "--agents", f"sac:{policy_file}", "--envs", LINES, "--output", str(tmp_path)]
    )
    assert_one_line_error(result, 2, str(policy_file), "PPO model, not SAC")


# ------------------------------------------------------------------ run folders and config.yml


def test_resume_of_a_folder_without_config_names_it(tmp_path):
    result = run([*TRAIN, "--resume", str(tmp_path)])
    assert_one_line_error(result, 2, "--resume", str(tmp_path), "config.yml")


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("env: [unclosed\n", "not valid YAML"),
        ("just a string\n", "not a run's config"),
        ("env: mobile_envs/DiffDrive-Random-v0\n", "'seed'"),
    ],
    ids=["syntax", "not-a-mapping", "missing-setting"],
)
def test_resume_with_a_malformed_config_names_the_file(tmp_path, text, named):
    (tmp_path / "config.yml").write_text(text)
    result = run([*TRAIN, "--resume", str(tmp_path)])
    assert_one_line_error(result, 2, str(tmp_path / "config.yml"), named)


def test_resume_with_another_algo_is_refused(finished_run):
    before = snapshot(finished_run)
    result = run([*TRAIN, "--resume", str(finished_run), "--algo", "sac"])
    assert_one_line_error(result, 2, "--algo sac", "ppo run")
    assert snapshot(finished_run) == before


@pytest.mark.parametrize(
    ("entry", "named"),
    [
        ({"n_steps": 64, "bogus": 1}, "PPO has no setting 'bogus'"),
        ({"warm_start": [1, 2]}, "warm_start must be a mapping"),
        ({"seed": 3}, "seed is set by train.py"),
    ],
    ids=["unknown-setting", "warm-start-list", "reserved"],
)
def test_a_bad_hyperparameter_entry_is_named(tmp_path, entry, named):
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump({"default": entry}))
    folder = tmp_path / "run"
    command = [*TRAIN, "--hyperparams", str(hyperparams), "--output", str(folder), *FAST_FLAGS]
    assert_one_line_error(run(command), 2, str(hyperparams), named)
    assert not folder.exists()


@pytest.mark.parametrize(
    ("entry", "named"),
    [
        ({"noise_type": "pink"}, "noise_type must be one of"),
        ({"noise_type": "normal", "noise_std": -0.1}, "noise_std must be a positive"),
        ({"noise_std": 0.1}, "noise_std needs a noise_type"),
        ({"n_epochs": 3}, "TD3 has no setting 'n_epochs'"),
    ],
    ids=["noise-type", "noise-std", "std-alone", "ppo-setting"],
)
def test_a_bad_off_policy_entry_is_named(tmp_path, entry, named):
    hyperparams = tmp_path / "td3.yml"
    hyperparams.write_text(yaml.safe_dump({"default": entry}))
    folder = tmp_path / "run"
    command = [*TRAIN, "--algo", "td3", "--hyperparams", str(hyperparams), "--output", str(folder)]
    assert_one_line_error(run([*command, *FAST_FLAGS]), 2, str(hyperparams), named)
    assert not folder.exists()


def test_resume_to_a_total_below_the_trained_steps_is_refused(finished_run):
    before = snapshot(finished_run)
    result = run([*TRAIN, "--resume", str(finished_run), "--timesteps", "512"])
    assert_one_line_error(result, 2, "--timesteps 512", "1024 steps")
    assert snapshot(finished_run) == before


def test_a_new_run_into_a_folder_of_other_files_is_refused_and_leaves_them(tmp_path):
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "config.yml").write_text("my settings\n")
    (folder / "final_model.zip").write_bytes(b"my model")
    before = snapshot(folder)
    result = run([*TRAIN, "--timesteps", "256", "--output", str(folder), *FAST_RUN])
    assert_one_line_error(result, 2, str(folder), "not empty", "--output")
    assert snapshot(folder) == before


def test_a_new_run_into_an_existing_run_points_to_resume(finished_run):
    before = snapshot(finished_run)
    result = run([*TRAIN, "--timesteps", "256", "--output", str(finished_run), *FAST_RUN])
    assert_one_line_error(result, 2, f"--resume {finished_run}")
    assert snapshot(finished_run) == before


# ------------------------------------------------------------------ env ids and env kwargs


UNKNOWN_ID = "mobile_envs/DifDrive-Random-v0"


@pytest.mark.parametrize(
    "command",
    [
        [*TRAIN, "--env", UNKNOWN_ID, "--output"],
        [*TRAIN, "evaluate", "--model", "unused.zip", "--env", UNKNOWN_ID, "--env-kwargs"],
        [*COMPARE, "--envs", UNKNOWN_ID, "--output"],
    ],
    ids=["train", "evaluate", "compare"],
)
def test_an_unknown_env_id_is_named(command, tmp_path):
    last = "{}" if command[-1] == "--env-kwargs" else str(tmp_path / "out")
    line = assert_one_line_error(run([*command, last]), 2, UNKNOWN_ID)
    assert "Did you mean" in line  # gymnasium's suggestion comes through
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("env_kwargs", "named"),
    [('{"dt": -1}', "dt must be a positive"), ('{"bogus": 1}', "'bogus'")],
    ids=["bad-value", "unknown-name"],
)
def test_compare_reports_a_value_error_in_one_line(tmp_path, env_kwargs, named):
    result = run([*COMPARE, "--envs", LINES, "--env-kwargs", env_kwargs, "--output", str(tmp_path)])
    assert_one_line_error(result, 2, "--env-kwargs", named)


# ------------------------------------------------------------------ folders that cannot be written


def test_an_output_folder_that_cannot_be_created_is_one_line_with_status_1(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    result = run([*TRAIN, "--timesteps", "256", "--output", str(blocker / "run"), *FAST_RUN])
    assert_one_line_error(result, 1, str(blocker / "run"))
    result = run([*COMPARE, "--envs", LINES, "--episodes", "1", "--output", str(blocker / "out")])
    assert_one_line_error(result, 1, str(blocker / "out"))


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root ignores permissions")
def test_a_read_only_output_folder_is_one_line_with_status_1(tmp_path):
    tmp_path.chmod(0o555)
    try:
        result = run([*TRAIN, "--timesteps", "256", "--output", str(tmp_path / "run"), *FAST_RUN])
        assert_one_line_error(result, 1, "Permission denied", str(tmp_path / "run"))
    finally:
        tmp_path.chmod(0o755)


def test_a_full_disk_during_a_save_is_one_line_with_status_1_and_no_partial_file(tmp_path):
    # RLIMIT_FSIZE makes writes past 150 kB fail as a full disk does, mid-file: the config and
    # machine.yml (<2 kB) are written, the checkpoint (~200 kB) is not. Python ignores
    # SIGXFSZ, so the write fails with EFBIG instead of killing the process.
    limit = 150_000

    def limit_file_size() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    # A run without the limit first: numba compiles the kernels and writes its cache (over
    # 150 kB) whenever mobile_envs changed, and that write must not be the one that fails.
    assert train.main(["--timesteps", "256", "--output", str(tmp_path / "warm"), *FAST_RUN]) == 0
    folder = tmp_path / "run"
    command = [*TRAIN, "--timesteps", "1024", "--checkpoint-freq", "0", "--output", str(folder)]
    result = run([*command, *FAST_RUN], preexec_fn=limit_file_size)
    assert_one_line_error(result, 1, str(folder / "checkpoints" / "latest.zip"))
    assert yaml.safe_load((folder / "config.yml").read_text())["timesteps"] == 1024
    assert sorted(path.name for path in folder.rglob("*") if path.is_file()) == [
        "command.txt",
        "config.yml",
        "machine.yml",
    ]


# ------------------------------------------------------------------ fuzz: damaged files


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_a_damaged_model_file_loads_or_is_one_value_error_naming_it(policy_file, data):
    """Truncations and overwritten bytes anywhere in a model zip: the policy loads, or
    load_policy raises a ValueError naming the file; never another exception."""
    original = policy_file.read_bytes()
    lengths = st.just(len(original)) | st.integers(0, len(original))  # whole files half the time
    damaged = bytearray(original[: data.draw(lengths, label="length")])
    if damaged:
        positions = st.lists(st.integers(0, len(damaged) - 1), max_size=4)
        for position in data.draw(positions, label="positions"):
            damaged[position] = data.draw(st.integers(0, 255), label="byte")
    path = policy_file.with_name("damaged.zip")
    path.write_bytes(bytes(damaged))
    try:
        load_policy(path)
    except ValueError as error:
        assert str(path) in str(error)
        assert "\n" not in str(error)


VALID_CONFIG = {
    "env": "mobile_envs/DiffDrive-Random-v0",
    "seed": 0,
    "timesteps": 1024,
    "n_envs": 4,
    "env_kwargs": {},
    "vec_env": "native",
    "eval_freq": 0,
    "eval_episodes": 1,
    "checkpoint_freq": 0,
    "algo": "ppo",
    "ppo": {"n_steps": 256},
}
YAML_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda children: (
        st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=8), children, max_size=3)
    ),
    max_leaves=6,
)


@settings(max_examples=150, deadline=None)
@given(
    changes=st.dictionaries(st.sampled_from(sorted(VALID_CONFIG)), YAML_VALUES, max_size=3),
    removed=st.sets(st.sampled_from(sorted(VALID_CONFIG)), max_size=2),
    text=st.none() | st.text(st.characters(exclude_categories=["Cs"]), max_size=60),
)
def test_any_config_yml_reads_or_is_one_value_error_naming_it(
    tmp_path_factory, changes, removed, text
):
    """A run's config.yml with settings changed, removed, or replaced by random text: it reads
    as a complete, well-typed config, or read_run_config raises a ValueError naming it."""
    folder = tmp_path_factory.mktemp("run")
    config = {
        key: value for key, value in {**VALID_CONFIG, **changes}.items() if key not in removed
    }
    path = folder / "config.yml"
    path.write_text(yaml.safe_dump(config) if text is None else text, encoding="utf-8")
    try:
        read = train.read_run_config(folder)
    except ValueError as error:
        assert str(path) in str(error)
        assert "\n" not in str(error)
    else:
        for key, kind in train.RUN_CONFIG_TYPES.items():
            assert isinstance(read[key], kind)
        assert read["timesteps"] >= 1 and read["n_envs"] >= 1


# ------------------------------------------------------------------ issue 30: found before training


def assert_usage_error(result: subprocess.CompletedProcess, *named: str) -> str:
    """argparse's refusal: exit status 2, its usage, then one error line naming the argument."""
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert ": error: " in last
    for text in named:
        assert text in last, (text, last)
    return last


@pytest.mark.parametrize(
    "command",
    [
        [*TRAIN, "--seed", "-1", "--output", "{out}"],
        [*TRAIN, "--seed", str(2**32), "--output", "{out}"],
        [*TRAIN, "evaluate", "--model", "unused.zip", "--env", LINES, "--seed", "-5"],
        [*TRAIN, "grid", "--seeds", "\u00b2", "--output", "{out}"],
        [*TRAIN, "grid", "--eval-seed", "-5", "--output", "{out}"],
        [*TRAIN, "sweep", "--eval-seed", "-5", "--output", "{out}"],
        [*TRAIN, "sweep", "--sampler-seed", "x", "--output", "{out}"],
    ],
    ids=["train-negative", "train-too-large", "evaluate", "grid-seeds", "grid", "sweep", "sampler"],
)
def test_a_bad_seed_is_refused_naming_its_flag(command, tmp_path):
    result = run([part.format(out=tmp_path / "out") for part in command])
    flag = next(part for part in command if part.startswith("--") and "seed" in part)
    assert_usage_error(result, flag)
    assert not (tmp_path / "out").exists()


def test_compare_refuses_a_negative_seed_naming_it(tmp_path):
    result = run([*COMPARE, "--seed", "-3", "--envs", LINES, "--output", str(tmp_path / "out")])
    assert_one_line_error(result, 2, "--seed")


@pytest.mark.parametrize("command", ["sweep", "grid"])
def test_an_output_that_is_a_file_is_bad_input(command, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("mine\n")
    result = run([*TRAIN, command, "--output", str(blocker)])
    assert_usage_error(result, "--output", str(blocker), "not a folder")
    assert blocker.read_text() == "mine\n"


@pytest.mark.parametrize(
    ("setting", "named"),
    [
        ({"n_steps": 0}, "n_steps must be at least 1"),
        ({"batch_size": 0}, "batch_size must be at least 1"),
        ({"batch_size": 1}, "PPO refuses these settings"),  # SB3's own assertion, named
        ({"learning_rate": "abc"}, "learning_rate must be a finite number"),
        ({"learning_rate": "lin_fast"}, "learning_rate must be a finite number or lin_<number>"),
        ({"learning_rate": "lin_-1e-3"}, "learning_rate must be at least"),
        ({"clip_range": "lin_nan"}, "clip_range must be a finite number or lin_<number>"),
        ({"gamma": "x"}, "gamma must be a finite number"),
        ({"gamma": 1.5}, "gamma must be in [0, 1]"),
        ({"n_epochs": 2.5}, "n_epochs must be a whole number"),
        ({"policy_kwargs": {"net_arch": "big"}}, "policy_kwargs.net_arch must be a list"),
        ({"policy_kwargs": {"net_arch": {"pi": [8], "zz": [8]}}}, "pi, vf and qf"),
    ],
    ids=lambda value: str(value)[:24],
)
def test_a_bad_hyperparameter_value_is_named_and_leaves_no_run_folder(tmp_path, setting, named):
    """Issue 30: SB3's own errors came out as tracebacks, and gamma "x" left a half-made run
    folder that a rerun refused."""
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump({"default": {**FAST_PPO["default"], **setting}}))
    folder = tmp_path / "run"
    command = [*TRAIN, "--timesteps", "256", "--output", str(folder), *FAST_FLAGS]
    result = run([*command, "--hyperparams", str(hyperparams)])
    assert_one_line_error(result, 2, str(hyperparams), named)
    assert not folder.exists()


def test_a_run_that_fails_before_training_leaves_its_folder_as_it_found_it(tmp_path):
    folder = tmp_path / "run"
    folder.mkdir()
    kwargs = tmp_path / "ppo.yml"
    kwargs.write_text(yaml.safe_dump({"default": {**FAST_PPO["default"], "env_kwargs": {"x": 1}}}))
    refused = run([*TRAIN, "--timesteps", "256", "--output", str(folder), *FAST_FLAGS,
                   "--hyperparams", str(kwargs)])  # fmt: skip
    assert_one_line_error(refused, 2, "env_kwargs")
    assert list(folder.iterdir()) == []  # the claim was taken back
    assert run([*TRAIN, "--timesteps", "256", "--output", str(folder), *FAST_RUN]).returncode == 0


def test_resume_after_n_envs_was_edited_names_config_yml(finished_run, tmp_path):
    folder = tmp_path / "run"
    shutil.copytree(finished_run, folder)
    config = yaml.safe_load((folder / "config.yml").read_text())
    (folder / "config.yml").write_text(yaml.safe_dump({**config, "n_envs": 8}))
    before = snapshot(folder)
    result = run([*TRAIN, "--resume", str(folder), "--timesteps", "2048"])
    assert_one_line_error(result, 2, str(folder / "config.yml"), "'n_envs' is 8", "4 robots")
    assert snapshot(folder) == before


def test_export_names_an_opset_torch_does_not_write(policy_file, tmp_path):
    output = tmp_path / "policy.onnx"
    command = [*TRAIN, "export", "--model", str(policy_file), "--output", str(output)]
    assert_one_line_error(run([*command, "--opset", "99999"]), 2, "--opset", "99999")
    assert not output.exists()


def test_a_trained_agent_that_is_missing_or_for_another_robot_is_named(policy_file, tmp_path):
    """--trained-agent names a missing model and one trained on another robot (the
    differential drive and the bicycle have the same spaces), before any run folder exists;
    it does not go with --resume, whose run goes on from its own checkpoint."""
    missing = tmp_path / "missing.zip"
    result = run(
        [*TRAIN, *FAST_RUN, "--trained-agent", str(missing), "--output", str(tmp_path / "a")]
    )
    assert_one_line_error(result, 2, str(missing))
    diff_drive = tmp_path / "diff_drive.zip"
    model = load_policy(policy_file)
    model.trained_on = LINES  # as train.py records it
    model.save(diff_drive)
    bicycle = ["--env", "mobile_envs/Bicycle-Random-v0", "--output", str(tmp_path / "b")]
    result = run([*TRAIN, *FAST_RUN, *bicycle, "--trained-agent", str(diff_drive)])
    assert_one_line_error(result, 2, str(diff_drive), LINES, "another robot")
    assert not (tmp_path / "a").exists()
    result = run([*TRAIN, "--resume", str(tmp_path / "b"), "--trained-agent", str(policy_file)])
    assert_one_line_error(result, 2, "--trained-agent", "--resume")

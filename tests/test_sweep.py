"""agents.sweeps.sweep on real Optuna storages: trials scored by the harness, failures recorded,
pruning, workers sharing a study on a journal file and on PostgreSQL, and killed or
interrupted workers whose trials come back.

The PostgreSQL tests need a server: ``bash .ci/run`` starts one and sets
MOBILE_ENVS_TEST_POSTGRES_URL (a URL whose user may create databases). Trainings are tiny
(1-2 thousand steps on 4 robots), so what is checked is the machinery, not learning.
"""

import os
import pathlib
import signal
import subprocess
import sys
import time
import uuid

import pytest
import sweep_extras  # noqa: F401  (skips this module without the train and sweep extras)

# isort: split
import optuna
import yaml
from optuna.distributions import CategoricalDistribution, FloatDistribution
from optuna.trial import TrialState
from tiny_runs import TINY_PPO

from agents.harness.evaluate import evaluate
from agents.harness.policies import load_policy
from agents.sweeps.objectives import Objective
from agents.sweeps.storage import database_url, open_storage, open_study
from agents.sweeps.sweep import (
    TrialObjective,
    main,
    parse_args,
    run_worker,
    settings_from_args,
    study_folder_name,
)
from agents.training.runs import env_kwargs_for

ROOT = pathlib.Path(__file__).resolve().parents[1]
ENV_ID = "mobile_envs/DiffDrive-Random-v0"
TINY_SPACE = {
    "ppo": {
        "learning_rate": {"type": "float", "low": 1e-4, "high": 1e-2, "log": True},
        "policy_kwargs.net_arch": {
            "type": "categorical",
            "choices": {"tiny": [8], "small": [16, 16]},
        },
        "env.reward_weights.cross_track": {"type": "float", "low": 1.0, "high": 30.0, "log": True},
    }
}
TINY_DISTRIBUTIONS = {
    "learning_rate": FloatDistribution(1e-4, 1e-2, log=True),
    "policy_kwargs.net_arch": CategoricalDistribution(["tiny", "small"]),
    "env.reward_weights.cross_track": FloatDistribution(1.0, 30.0, log=True),
}
EVAL_EPISODES = 2
#: The default study's name, ENV_ALGO.
STUDY = "DiffDrive-Random-v0_ppo"


def trial_path(output, number, study=STUDY):
    """Where trial ``number`` of ``study`` trains: its folder keyed by the study."""
    return output / "trials" / study / f"trial_{number:04d}"


@pytest.fixture
def tiny_files(tmp_path):
    hyperparams, space = tmp_path / "ppo.yml", tmp_path / "space.yml"
    hyperparams.write_text(yaml.safe_dump(TINY_PPO, sort_keys=False))
    space.write_text(yaml.safe_dump(TINY_SPACE, sort_keys=False))
    return hyperparams, space


def flags(output, tiny_files, *extra, timesteps=1024):
    hyperparams, space = tiny_files
    return [
        "--output",
        str(output),
        "--hyperparams",
        str(hyperparams),
        "--search-space",
        str(space),
        "--timesteps",
        str(timesteps),
        "--eval-freq",
        "512",
        "--eval-episodes",
        str(EVAL_EPISODES),
        *extra,
    ]


def journal_study(output):
    backend = open_storage(str(output / "study.journal"), heartbeat=60)
    return optuna.load_study(study_name="DiffDrive-Random-v0_ppo", storage=backend)


def start_worker(arguments):
    return subprocess.Popen(
        [sys.executable, "-m", "agents.sweeps.sweep", *arguments],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def wait_for(path, process, timeout=120.0):
    """Wait until ``path`` exists while ``process`` runs."""
    deadline = time.monotonic() + timeout
    while not path.exists():
        if process.poll() is not None:
            pytest.fail(f"the worker ended before {path} appeared:\n{process.stdout.read()}")
        if time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"{path} did not appear in {timeout} s")
        time.sleep(0.05)


def server_url(variable):
    url = os.environ.get(variable)
    if url:
        return url
    if os.environ.get("CI"):
        pytest.fail(f"{variable} is not set: .ci/run starts the server these tests need")
    pytest.skip(f"needs a PostgreSQL server: set {variable} (bash .ci/run starts one)")


@pytest.fixture
def postgres_database():
    """A URL of a fresh, empty PostgreSQL database, dropped afterwards."""
    import sqlalchemy

    server = sqlalchemy.engine.make_url(database_url(server_url("MOBILE_ENVS_TEST_POSTGRES_URL")))
    name = f"sweep_test_{uuid.uuid4().hex[:12]}"
    admin = sqlalchemy.create_engine(server, isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        connection.execute(sqlalchemy.text(f"CREATE DATABASE {name}"))
    yield server.set(database=name).render_as_string(hide_password=False)
    with admin.connect() as connection:
        connection.execute(sqlalchemy.text(f"DROP DATABASE {name} WITH (FORCE)"))
    admin.dispose()


def test_a_sweep_scores_each_trial_with_the_harness_on_held_out_paths(tmp_path, tiny_files):
    output = tmp_path / "sweep"
    assert main(flags(output, tiny_files, "--trials", "2", "--report", "--sampler-seed", "0")) == 0
    study = journal_study(output)
    assert [trial.state for trial in study.trials] == [TrialState.COMPLETE] * 2
    for trial in study.trials:
        folder = trial_path(output, trial.number)
        config = yaml.safe_load((folder / "config.yml").read_text())
        assert config["ppo"]["learning_rate"] == trial.params["learning_rate"]
        weights = config["env_kwargs"]["reward_weights"]
        assert weights["cross_track"] == trial.params["env.reward_weights.cross_track"]
        named = TINY_SPACE["ppo"]["policy_kwargs.net_arch"]["choices"]
        assert (
            config["ppo"]["policy_kwargs"]["net_arch"]
            == named[trial.params["policy_kwargs.net_arch"]]
        )
        policy = load_policy(folder / "final_model.zip")
        assert policy.num_timesteps >= 1024
        # Independent truth: the harness, run again on the held-out episodes.
        summary = evaluate(
            policy, ENV_ID, EVAL_EPISODES, seed=1_000_000, **env_kwargs_for(config)
        ).summary
        for metric in ("completion_rate", "mean_abs_cte", "max_abs_cte"):
            assert trial.user_attrs[metric] == summary[metric]
        assert trial.value == Objective().values(summary)[0]
        assert set(trial.intermediate_values) == {512, 1024}

    best = max(study.trials, key=lambda trial: trial.value)
    report = output / "report" / STUDY
    entry = yaml.safe_load((report / "best_hyperparams.yml").read_text())
    assert entry == {ENV_ID: best.user_attrs["settings"]}
    assert entry[ENV_ID]["learning_rate"] == best.params["learning_rate"]
    rows = [
        line
        for line in (report / "top_trials.md").read_text().splitlines()
        if line.startswith("| 1 |")
    ]
    assert rows and rows[0].split("|")[2].strip() == str(best.number)
    for name in ("history.png", "importances.png"):
        assert (report / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name


def test_a_trial_that_raises_is_recorded_failed_and_the_sweep_goes_on(tmp_path, tiny_files):
    space = tiny_files[1]
    space.write_text(
        yaml.safe_dump({"ppo": {"env.dt": {"type": "categorical", "choices": [0.1, -1.0]}}})
    )
    output = tmp_path / "sweep"
    args = parse_args(flags(output, tiny_files, "--timesteps", "512", "--eval-freq", "0"))
    settings = settings_from_args(args)
    study = open_study(args.storage, args.study_name, settings.to_attrs())
    study.enqueue_trial({"env.dt": -1.0})
    study.enqueue_trial({"env.dt": 0.1})
    assert run_worker(study, args.storage, TrialObjective(settings, output), trials=2) == 0
    failed, completed = study.trials
    assert failed.state == TrialState.FAIL
    assert "ValueError: dt must be a positive" in failed.user_attrs["error"]
    assert completed.state == TrialState.COMPLETE and completed.user_attrs.get("error") is None


def test_pruning_stops_a_trial_that_trails_the_completed_ones(tmp_path, tiny_files):
    output = tmp_path / "sweep"
    args = parse_args(flags(output, tiny_files, "--prune-after", "1"))
    settings = settings_from_args(args)
    study = open_study(
        args.storage, args.study_name, settings.to_attrs(), prune_after=args.prune_after
    )
    # A finished trial with the best value there is: all 2 episodes complete, |cte| = 0.
    perfect = Objective().values({"completion_rate": 1.0, "mean_abs_cte": 0.0, "episodes": 2})[0]
    study.add_trial(
        optuna.trial.create_trial(
            params={
                "learning_rate": 1e-3,
                "policy_kwargs.net_arch": "tiny",
                "env.reward_weights.cross_track": 8.0,
            },
            distributions=TINY_DISTRIBUTIONS,
            value=perfect,
            intermediate_values={512: perfect, 1024: perfect},
        )
    )
    assert run_worker(study, args.storage, TrialObjective(settings, output), trials=1) == 0
    trial = study.trials[1]
    assert trial.state == TrialState.PRUNED
    assert list(trial.intermediate_values) == [512]
    assert trial.intermediate_values[512] < perfect
    checkpoint = trial_path(output, 1) / "checkpoints" / "latest.zip"
    # The evaluation runs between two collections; training stops at the next step (4 robots).
    assert load_policy(checkpoint).num_timesteps == 512 + 4, "training stopped at the evaluation"


def snapshot(folder):
    return {path: path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


def test_studies_sharing_an_output_train_their_own_trials(tmp_path, tiny_files):
    """Issue 30: study B's trial 0 reported study A's model. Each study's trials now train in
    a folder keyed by the study, and B's value is the harness's on B's own policy."""
    output = tmp_path / "sweep"
    common = flags(output, tiny_files, "--trials", "1", "--eval-freq", "0", timesteps=512)
    assert main([*common, "--study-name", "A", "--sampler-seed", "0"]) == 0
    first = snapshot(output / "trials" / "A")
    assert main([*common, "--study-name", "B", "--sampler-seed", "1"]) == 0
    assert snapshot(output / "trials" / "A") == first  # untouched by B
    backend = open_storage(str(output / "study.journal"), heartbeat=60)
    for name in ("A", "B"):
        (trial,) = optuna.load_study(study_name=name, storage=backend).trials
        folder = trial_path(output, 0, name)
        assert pathlib.Path(trial.user_attrs["folder"]) == folder.resolve()
        config = yaml.safe_load((folder / "config.yml").read_text())
        assert config["ppo"]["learning_rate"] == trial.params["learning_rate"]
        summary = evaluate(
            load_policy(folder / "final_model.zip"),
            ENV_ID,
            EVAL_EPISODES,
            seed=1_000_000,
            **env_kwargs_for(config),
        ).summary
        assert trial.value == Objective().values(summary)[0]


def test_a_trial_refuses_a_folder_another_study_of_its_name_left(tmp_path, tiny_files):
    output = tmp_path / "sweep"
    stale = trial_path(output, 0)
    stale.mkdir(parents=True)
    (stale / "config.yml").write_text("left by a study since deleted\n")
    args = parse_args(flags(output, tiny_files, "--timesteps", "512", "--eval-freq", "0"))
    settings = settings_from_args(args)
    study = open_study(args.storage, args.study_name, settings.to_attrs())
    assert run_worker(study, args.storage, TrialObjective(settings, output), trials=1) == 1
    (trial,) = study.trials
    assert trial.state == TrialState.FAIL
    assert (
        str(stale) in trial.user_attrs["error"] and "not this trial's" in trial.user_attrs["error"]
    )
    assert (stale / "config.yml").read_text() == "left by a study since deleted\n"


def test_a_study_s_folder_name_is_its_name_made_safe():
    assert study_folder_name("DiffDrive-Random-v0_ppo") == "DiffDrive-Random-v0_ppo"
    assert study_folder_name("team/run 1") == "team%2Frun%201"
    assert study_folder_name("..") == "%2E%2E" and study_folder_name(".") == "%2E"
    names = ["a/b", "a%2Fb", "ä", "..", ".", "x.y"]
    assert len({study_folder_name(name) for name in names}) == len(names)


def test_a_worker_with_other_settings_is_refused(tmp_path, tiny_files):
    output = tmp_path / "sweep"
    first = parse_args(flags(output, tiny_files))
    open_study(first.storage, first.study_name, settings_from_args(first).to_attrs())
    other = parse_args(flags(output, tiny_files, timesteps=2048))
    with pytest.raises(ValueError, match=r"runs other settings .*base_config"):
        open_study(other.storage, other.study_name, settings_from_args(other).to_attrs())
    assert (
        main(
            flags(
                output, tiny_files, "--trials", "1", "--objective", "mean_time", "completion_rate"
            )
        )
        == 2
    )


def test_two_workers_started_at_once_on_one_output_share_the_study(tmp_path, tiny_files):
    output = tmp_path / "sweep"
    command = [sys.executable, "train.py", "sweep", *flags(output, tiny_files, "--trials", "1")]
    workers = [
        subprocess.Popen(
            command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
        for _ in range(2)
    ]
    for worker in workers:
        log, _ = worker.communicate(timeout=300)
        assert worker.returncode == 0, log
    study = journal_study(output)
    assert [trial.number for trial in study.trials] == [0, 1]
    assert all(trial.state == TrialState.COMPLETE for trial in study.trials)
    pids = {trial.user_attrs["owner"].split(":")[1] for trial in study.trials}
    assert pids == {str(worker.pid) for worker in workers}
    for number in (0, 1):
        assert (trial_path(output, number) / "final_model.zip").is_file()


def check_retried_from_checkpoint(study, timesteps):
    """Trial 0 failed; trial 1 re-ran its parameters from its checkpoint to the end."""
    failed, retried = study.trials
    assert failed.state == TrialState.FAIL
    assert retried.state == TrialState.COMPLETE
    assert retried.params == failed.params
    assert retried.system_attrs["failed_trial"] == 0
    assert retried.user_attrs["continued_from"] == 0
    assert set(failed.intermediate_values) <= set(retried.intermediate_values)
    folder = pathlib.Path(retried.user_attrs["folder"])
    assert load_policy(folder / "final_model.zip").num_timesteps >= timesteps


def test_a_killed_worker_s_trial_is_retried_from_its_checkpoint(tmp_path, tiny_files):
    output = tmp_path / "sweep"
    arguments = flags(output, tiny_files, "--trials", "1", timesteps=2048)
    doomed = start_worker(arguments)
    wait_for(trial_path(output, 0) / "checkpoints" / "latest.zip", doomed)
    doomed.kill()
    doomed.wait()
    assert journal_study(output).trials[0].state == TrialState.RUNNING  # left behind
    assert main(arguments) == 0
    check_retried_from_checkpoint(journal_study(output), 2048)


def test_sigterm_fails_the_running_trial_and_queues_it_again(tmp_path, tiny_files):
    output = tmp_path / "sweep"
    worker = start_worker(flags(output, tiny_files, "--trials", "1", timesteps=100_000))
    wait_for(trial_path(output, 0) / "checkpoints" / "latest.zip", worker)
    worker.send_signal(signal.SIGTERM)
    log, _ = worker.communicate(timeout=120)
    assert worker.returncode == 128 + signal.SIGTERM, log
    interrupted, queued = journal_study(output).trials
    assert interrupted.state == TrialState.FAIL
    assert interrupted.user_attrs["error"].startswith("interrupted")
    assert queued.state == TrialState.WAITING and queued.params == interrupted.params
    checkpoint = trial_path(output, 0) / "checkpoints" / "latest.zip"
    assert 512 <= load_policy(checkpoint).num_timesteps < 100_000


def test_a_sigterm_inside_numba_s_kernels_stops_the_worker_and_queues_the_trial_again(
    tmp_path, tiny_files, monkeypatch
):
    # The signal comes inside numba's dispatcher. Raised there, as before
    # agents.interrupts,
    # it came out as a SystemError (the trial failed as an error and the worker went on) or
    # as a segmentation fault.
    from test_interrupts import signal_inside_numba

    import agents.sweeps.sweep

    def train_run_signalled(*args, **kwargs):
        sys.setprofile(signal_inside_numba(signal.SIGTERM))
        try:
            return real_train_run(*args, **kwargs)
        finally:
            sys.setprofile(None)

    real_train_run = agents.sweeps.sweep.train_run
    monkeypatch.setattr(agents.sweeps.sweep, "train_run", train_run_signalled)
    output = tmp_path / "sweep"
    args = parse_args(flags(output, tiny_files))
    settings = settings_from_args(args)
    study = open_study(args.storage, args.study_name, settings.to_attrs())
    status = run_worker(study, args.storage, TrialObjective(settings, output), trials=2)
    assert status == 128 + signal.SIGTERM
    interrupted, queued = study.trials
    assert interrupted.state == TrialState.FAIL
    assert interrupted.user_attrs["error"].startswith("interrupted")
    assert queued.state == TrialState.WAITING and queued.params == interrupted.params


def test_workers_started_at_once_on_a_fresh_postgres_database_share_one_study(
    tmp_path, tiny_files, postgres_database
):
    arguments = flags(
        tmp_path / "sweep", tiny_files, "--trials", "1", "--storage", postgres_database
    )
    workers = [start_worker(arguments) for _ in range(2)]
    for worker in workers:
        log, _ = worker.communicate(timeout=300)
        assert worker.returncode == 0, log
    study = optuna.load_study(
        study_name="DiffDrive-Random-v0_ppo", storage=database_url(postgres_database)
    )
    assert [trial.number for trial in study.trials] == [0, 1]
    assert all(trial.state == TrialState.COMPLETE for trial in study.trials)


def test_postgres_heartbeats_recover_a_killed_worker_s_trial(
    tmp_path, tiny_files, postgres_database
):
    output = tmp_path / "sweep"
    arguments = flags(
        output,
        tiny_files,
        "--trials",
        "1",
        "--storage",
        postgres_database,
        "--heartbeat",
        "1",
        timesteps=2048,
    )
    doomed = start_worker(arguments)
    wait_for(trial_path(output, 0) / "checkpoints" / "latest.zip", doomed)
    doomed.kill()
    doomed.wait()
    time.sleep(2.5)  # past the grace period of 2 heartbeats
    assert main(arguments) == 0
    study = optuna.load_study(
        study_name="DiffDrive-Random-v0_ppo", storage=database_url(postgres_database)
    )
    check_retried_from_checkpoint(study, 2048)

# ruff: noqa: F401, F811  (fixtures imported from test_sweep are the tests' arguments)
"""agents.sweeps.storage under the failures a cluster meets: a full disk under the journal
(RLIMIT_FSIZE makes a real write fail midway, as a full disk does), a writer killed mid-line,
a damaged journal, a dead worker's process id taken over, databases that refuse or go away.
The sweeps are tiny (512-1024 steps on 4 robots): what is checked is the machinery."""

import errno
import json
import os
import re
import resource
import socket
import subprocess
import sys
import time

import pytest
import sweep_extras  # skips this module without the train and sweep extras

# isort: split
import optuna
import sqlalchemy
from optuna.trial import TrialState
from test_sweep import (
    ROOT,
    STUDY,
    flags,
    journal_study,
    postgres_database,
    server_url,
    tiny_files,
    trial_path,
    wait_for,
)

from agents.sweeps.storage import (
    WholeLineJournal,
    database_url,
    describe_storage_failure,
    fail_dead_local_trials,
    open_storage,
    open_study,
    owner_of_this_process,
    process_start,
    storage_failure_in,
)
from agents.sweeps.sweep import parse_args, settings_from_args

RECORDS = [
    {"op_code": 0, "worker_id": "w", "study_name": f"s{n}", "directions": [1]} for n in range(3)
]


def journal_lines(path):
    """Every line of a journal file, each parsed: a half-written line fails here."""
    text = path.read_bytes().decode()
    assert text == "" or text.endswith("\n"), "the journal ends mid-line"
    return [json.loads(line) for line in text.splitlines()]


def sweep_process(arguments, file_size_limit=None):
    """A sweep worker in its own process, with writes past ``file_size_limit`` bytes failing
    as on a full disk (EFBIG: Python ignores SIGXFSZ)."""

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (file_size_limit, file_size_limit))

    return subprocess.run(
        [sys.executable, "train.py", "sweep", *arguments],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        preexec_fn=None if file_size_limit is None else limit,
    )


def assert_ends_in_one_error_line(result, status, *named):
    assert result.returncode == status, result.stderr
    assert "Traceback" not in result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith("train.py sweep: error: "), last
    for text in named:
        assert text in last, (text, last)
    return last


# ---------------------------------------------------------------- the journal file


def test_an_append_a_full_disk_cuts_short_leaves_the_journal_as_it_was(tmp_path, monkeypatch):
    path = tmp_path / "study.journal"
    journal = WholeLineJournal(str(path))
    journal.append_logs(RECORDS[:2])
    before = path.read_bytes()
    real_pwrite = os.pwrite

    def full_disk(descriptor, data, offset):
        real_pwrite(descriptor, bytes(data[: len(data) // 2]), offset)  # half, as a disk fills
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "pwrite", full_disk)
    with pytest.raises(OSError) as raised:
        journal.append_logs(RECORDS[2:])
    assert raised.value.errno == errno.ENOSPC and raised.value.filename == str(path)
    assert path.read_bytes() == before
    monkeypatch.undo()
    journal.append_logs(RECORDS[2:])
    assert journal_lines(path) == RECORDS
    assert list(WholeLineJournal(str(path)).read_logs(0)) == RECORDS


def test_a_line_a_killed_writer_left_half_written_is_cut_before_the_next_append(tmp_path):
    path = tmp_path / "study.journal"
    whole = "".join(json.dumps(record) + "\n" for record in RECORDS[:2])
    path.write_text(whole + json.dumps(RECORDS[2])[:25])  # Optuna's own writer, cut short
    journal = WholeLineJournal(str(path))
    assert list(journal.read_logs(0)) == RECORDS[:2]  # Optuna's reader skips the tail...
    journal.append_logs(RECORDS[2:])  # ...and the next record is not written onto it
    assert journal_lines(path) == RECORDS


def test_a_damaged_line_is_named_with_its_file_and_number(tmp_path, tiny_files):
    output = tmp_path / "sweep"
    args = parse_args(flags(output, tiny_files))
    open_study(args.storage, args.study_name, settings_from_args(args).to_attrs()).ask()
    path = output / "study.journal"
    lines = path.read_text().splitlines(keepends=True)
    assert len(lines) >= 3  # the study, its settings, a trial
    # What Optuna's own writer left after a full disk: half a record, the next one after it.
    lines[1] = lines[1][:30] + lines[1]
    path.write_text("".join(lines))
    with pytest.raises(ValueError, match=rf"{re.escape(str(path))}, line 2: not a journal record"):
        open_study(args.storage, args.study_name, settings_from_args(args).to_attrs())
    result = sweep_process(flags(output, tiny_files, "--report"))
    assert_ends_in_one_error_line(result, 2, str(path), "line 2")


def padded_study(output, tiny_files, size):
    """A sweep folder whose journal holds the study and another study's ``size`` bytes."""
    args = parse_args(flags(output, tiny_files, "--trials", "1"))
    settings = settings_from_args(args)  # also compiles the kernels before any limit
    open_study(args.storage, args.study_name, settings.to_attrs())
    padding = optuna.create_study(storage=open_storage(args.storage, 60), study_name="padding")
    padding.set_user_attr("padding", "x" * size)
    return output / "study.journal"


def test_a_worker_whose_journal_fills_the_disk_stops_in_one_line_and_the_next_recovers(
    tmp_path,
    tiny_files,
):
    """Issue 30: a full disk left half a line at the journal's end, the next worker wrote
    onto it, and every worker and --report failed from then on."""
    output = tmp_path / "sweep"
    journal = padded_study(output, tiny_files, 100_000)  # more than a checkpoint's size
    limit = journal.stat().st_size + 1500  # fills during the trial
    arguments = flags(output, tiny_files, "--trials", "1", timesteps=1024)
    failed = sweep_process(arguments, file_size_limit=limit)
    assert_ends_in_one_error_line(failed, 1, "File too large", str(journal))
    assert journal.stat().st_size <= limit
    journal_lines(journal)  # every line whole
    assert sweep_process(arguments).returncode == 0
    study = journal_study(output)
    assert TrialState.COMPLETE in [trial.state for trial in study.trials]
    assert sweep_process(flags(output, tiny_files, "--report")).returncode == 0
    assert (output / "report" / STUDY / "best_hyperparams.yml").is_file()


def test_a_trial_a_full_disk_fails_is_queued_again_and_the_worker_stops_with_status_1(
    tmp_path,
    tiny_files,
):
    output = tmp_path / "sweep"
    padded_study(output, tiny_files, 0)  # the kernels compiled, the study made
    arguments = flags(output, tiny_files, "--trials", "2", timesteps=1024)
    # The journal stays far below 20 kB; the first checkpoint (~36 kB) does not fit.
    result = sweep_process(arguments, file_size_limit=20_000)
    checkpoint = trial_path(output, 0) / "checkpoints" / "latest.zip"
    assert_ends_in_one_error_line(result, 1, "trial 0", "File too large", str(checkpoint))
    failed, queued = journal_study(output).trials
    assert failed.state == TrialState.FAIL and "File too large" in failed.user_attrs["error"]
    assert queued.state == TrialState.WAITING and queued.params == failed.params
    assert sweep_process(flags(output, tiny_files, "--trials", "1")).returncode == 0
    assert journal_study(output).trials[1].state == TrialState.COMPLETE


# ---------------------------------------------------------------- dead workers


def test_a_dead_worker_s_trial_comes_back_though_its_process_id_was_taken(tmp_path, tiny_files):
    output = tmp_path / "sweep"
    args = parse_args(flags(output, tiny_files))
    study = open_study(args.storage, args.study_name, settings_from_args(args).to_attrs())
    stranger = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        # A worker that died, whose id the stranger now has (its start is not the stranger's).
        taken = study.ask()
        taken.set_user_attr("owner", f"{socket.gethostname()}:{stranger.pid}:{taken.number}")
        taken.set_user_attr("owner_start", process_start(os.getpid()))
        # A worker that runs: the stranger itself.
        alive = study.ask()
        alive.set_user_attr("owner", f"{socket.gethostname()}:{stranger.pid}:{alive.number}")
        alive.set_user_attr("owner_start", process_start(stranger.pid))
        assert fail_dead_local_trials(study, args.storage) == [taken.number]
    finally:
        stranger.kill()
        stranger.wait()
    states = [trial.state for trial in study.get_trials(deepcopy=False)]
    assert states == [TrialState.FAIL, TrialState.RUNNING, TrialState.WAITING]
    assert owner_of_this_process(3).split(":")[1] == str(os.getpid())
    assert process_start(os.getpid()) != process_start(stranger.pid)


# ---------------------------------------------------------------- databases


@pytest.mark.parametrize(
    ("url", "named"),
    [
        ("mysql://user@127.0.0.1/db", "'mysql'"),
        ("foo://somewhere", "'foo'"),
    ],
)
def test_a_storage_url_a_sweep_cannot_use_is_one_line_with_status_2(
    url, named, tiny_files, tmp_path
):
    result = sweep_process(flags(tmp_path / "sweep", tiny_files, "--storage", url, "--trials", "1"))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "--storage: unsupported database" in result.stderr and named in result.stderr


def test_an_unreachable_server_is_one_line_with_status_1(tiny_files, tmp_path):
    url = "postgresql://someone:secret@127.0.0.1:1/sweeps"
    result = sweep_process(flags(tmp_path / "sweep", tiny_files, "--storage", url, "--trials", "1"))
    line = assert_ends_in_one_error_line(result, 1, "127.0.0.1:1", "Connection refused")
    assert "secret" not in line and len(result.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("wrong", ["database", "user"])
def test_an_unknown_database_or_user_is_one_line_with_status_2(wrong, tiny_files, tmp_path):
    server = sqlalchemy.engine.make_url(server_url("MOBILE_ENVS_TEST_POSTGRES_URL"))
    url = (
        server.set(database="no_such_database")
        if wrong == "database"
        else server.set(username="no_such_user")
    )
    arguments = ["--storage", url.render_as_string(hide_password=False), "--trials", "1"]
    result = sweep_process(flags(tmp_path / "sweep", tiny_files, *arguments))
    assert_ends_in_one_error_line(result, 2, f"no_such_{wrong}", "does not exist")


def test_a_database_gone_mid_trial_is_one_line_and_the_trial_comes_back(
    tmp_path,
    tiny_files,
    postgres_database,
):
    """Issue 30: ten chained tracebacks ending in UnboundLocalError. The database stops
    taking connections mid-trial (its sessions ended, as a server restart ends them)."""
    output = tmp_path / "sweep"
    arguments = flags(
        output, tiny_files, "--trials", "1", "--storage", postgres_database, "--heartbeat", "1",
        timesteps=4096,
    )  # fmt: skip
    worker = subprocess.Popen(
        [sys.executable, "train.py", "sweep", *arguments],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    wait_for(trial_path(output, 0) / "checkpoints" / "latest.zip", worker)
    database = sqlalchemy.engine.make_url(postgres_database).database
    admin = sqlalchemy.create_engine(
        sqlalchemy.engine.make_url(postgres_database).set(database="postgres"),
        isolation_level="AUTOCOMMIT",
    )
    closed = f"ALTER DATABASE {database} ALLOW_CONNECTIONS "
    with admin.connect() as connection:
        connection.execute(sqlalchemy.text(closed + "false"))
        connection.execute(
            sqlalchemy.text(
                f"SELECT pg_terminate_backend(pid) FROM pg_stat_activity "
                f"WHERE datname = '{database}'"
            )
        )
    try:
        _, stderr = worker.communicate(timeout=300)
    finally:
        with admin.connect() as connection:
            connection.execute(sqlalchemy.text(closed + "true"))
        admin.dispose()
    result = subprocess.CompletedProcess(worker.args, worker.returncode, "", stderr)
    assert_ends_in_one_error_line(result, 1, "--storage", "trial 0")
    time.sleep(2.5)  # two heartbeats: the next worker fails the trial and queues it again
    assert sweep_process(arguments).returncode == 0
    study = optuna.load_study(study_name=STUDY, storage=database_url(postgres_database))
    interrupted, retried = study.trials
    assert interrupted.state == TrialState.FAIL and retried.state == TrialState.COMPLETE
    assert retried.user_attrs["continued_from"] == 0


def test_storage_failures_are_found_inside_what_optuna_lets_out():
    disk = OSError(errno.ENOSPC, "No space left on device", "study.journal")
    try:
        try:
            raise disk
        except OSError:
            raise UnboundLocalError("cannot access local variable 'updated_state'") from None
    except UnboundLocalError as outer:
        assert storage_failure_in(outer) is None  # "from None" hides it: not found
    try:
        try:
            raise disk
        except OSError:
            raise UnboundLocalError("cannot access local variable 'updated_state'")  # noqa: B904
    except UnboundLocalError as outer:
        assert storage_failure_in(outer) is disk
    assert describe_storage_failure(disk, "x") == ("No space left on device: study.journal", 1)
    assert storage_failure_in(ValueError("a trial's own error")) is None

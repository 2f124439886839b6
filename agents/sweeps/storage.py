"""Where a sweep's Optuna study lives, and how its workers share it safely.

- :func:`open_study` creates a study, or joins one after checking that the worker brings the
  study's own settings. Creation runs under :func:`creation_lock` (a PostgreSQL advisory
  lock, or a lock file beside a journal or SQLite file): two workers that start at once on a
  fresh database otherwise race on table creation ("table studies already exists").
- On a database (:func:`open_storage`) every trial sends heartbeats; the next worker that
  starts a trial fails a trial whose heartbeats stopped for two intervals and queues it again
  with its parameters and intermediate values (:func:`retry_callback`).
- A journal file has no heartbeats: :func:`fail_dead_local_trials` fails and queues again the
  RUNNING trials whose worker process on this machine is gone (a process that took over its
  id since is told apart by its start time).
- A journal file is appended whole or not at all (:class:`WholeLineJournal`): a full disk
  or a killed writer never leaves half a record for the next writer to write onto, and a
  damaged line is named with its file and number.
- :func:`storage_failure_in` finds the storage's failure (a full disk, a database gone) in
  whatever exception Optuna let out, so a worker reports it in one line.

Requires the ``sweep`` extra (optuna; psycopg for PostgreSQL).
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import pathlib
import socket
import threading
import warnings
from collections.abc import Generator, Iterator
from typing import Any

import optuna
import sqlalchemy
from optuna.storages.journal import JournalFileBackend, JournalFileSymlinkLock
from optuna.trial import TrialState

from agents.sweeps.objectives import Objective

#: The study's user attribute that holds the settings every worker must share.
STUDY_ATTR = "mobile_envs_sweep"
#: Key of the PostgreSQL advisory lock that serializes study creation.
ADVISORY_LOCK_KEY = 0x6D6F62696C65  # "mobile"
#: The database URL schemes a sweep runs on (Optuna's RDB storage with the drivers the
#: ``sweep`` extra installs); anything without ``://`` is a journal file.
DATABASE_SCHEMES = ("postgresql", "postgres", "sqlite")
#: What a PostgreSQL server says when the URL names a database or user it does not have, or
#: a wrong password: bad input (exit status 2), where anything else is a failed system (1).
_REFUSED_BY_NAME = ("does not exist", "authentication failed", "password")


def default_storage(output: pathlib.Path) -> str:
    """The study file of a sweep folder."""
    return str(output / "study.journal")


def is_database(storage: str) -> bool:
    """Whether ``storage`` is a database URL (else a journal file path)."""
    return "://" in storage


def check_storage(storage: str) -> str:
    """``storage`` if a sweep can run on it: a journal file's path or a URL of one of
    :data:`DATABASE_SCHEMES`.

    :raises ValueError: naming ``--storage`` for another scheme
    """
    scheme = storage.partition("://")[0].partition("+")[0]
    if is_database(storage) and scheme not in DATABASE_SCHEMES:
        raise ValueError(
            f"--storage: unsupported database {scheme!r} in {shown_url(storage)}; use "
            "postgresql://USER@HOST:PORT/DB, sqlite:///FILE or a journal file's path"
        )
    return storage


def shown_url(storage: str) -> str:
    """``storage`` as messages show it: a database URL without its password."""
    if not is_database(storage):
        return storage
    try:
        return sqlalchemy.engine.make_url(storage).render_as_string(hide_password=True)
    except sqlalchemy.exc.ArgumentError:
        return storage.partition("://")[0] + "://..."


class WholeLineJournal(JournalFileBackend):
    """Optuna's journal file (one JSON record a line), appended whole or not at all.

    Optuna's own backend writes a batch of records with one buffered write: a full disk or a
    signal mid-way leaves part of a line, the next writer appends onto it, and the merged
    line stops every reader for good. Here, under the journal's lock, an unterminated tail
    (which Optuna's reader never reads) is cut first, and an append that fails is cut back to
    the size before it. A line that still cannot be read (damaged by hand, or by an older
    writer) is reported with the file and its number.

    :param file_path: the journal file, created if missing
    """

    def __init__(self, file_path: str):
        self._append_lock = JournalFileSymlinkLock(file_path)
        super().__init__(file_path, lock_obj=self._append_lock)
        self._path = file_path

    def append_logs(self, logs: list[dict[str, Any]]) -> None:
        records = "".join(json.dumps(log, separators=(",", ":")) + "\n" for log in logs)
        self._append_lock.acquire()
        try:
            descriptor = os.open(self._path, os.O_RDWR)
            try:
                end = _whole_lines_end(descriptor)
                try:
                    pending = memoryview(records.encode("utf-8"))
                    offset = end
                    while pending:
                        written = os.pwrite(descriptor, pending, offset)
                        pending, offset = pending[written:], offset + written
                    os.fsync(descriptor)
                except BaseException:
                    os.ftruncate(descriptor, end)  # shrinking needs no space
                    raise
            finally:
                os.close(descriptor)
        except OSError as error:
            raise OSError(error.errno, error.strerror, self._path) from error
        finally:
            self._append_lock.release()

    def read_logs(self, log_number_from: int) -> Generator[dict[str, Any], None, None]:
        line = log_number_from
        try:
            for log in super().read_logs(log_number_from):
                yield log
                line += 1
        except ValueError as error:  # json.JSONDecodeError included
            raise ValueError(
                f"{self._path}, line {line + 1}: not a journal record ({error}): a write cut "
                "short left part of one; remove that part (or restore the file) to go on"
            ) from None


def _whole_lines_end(descriptor: int) -> int:
    """The size of the file up to its last newline, the file cut there if it goes on: what
    follows is part of a record whose writer was stopped mid-way."""
    size = os.fstat(descriptor).st_size
    end = size
    chunk = 4096
    while end > 0:
        start = max(0, end - chunk)
        block = os.pread(descriptor, end - start, start)
        newline = block.rfind(b"\n")
        if newline >= 0:
            end = start + newline + 1
            break
        end = start
    if end != size:
        os.ftruncate(descriptor, end)
    return end


def database_url(storage: str) -> str:
    """``storage`` with PostgreSQL's driver named: psycopg (3), whichever SQLAlchemy
    version would otherwise pick for ``postgresql://``."""
    for scheme in ("postgresql://", "postgres://"):
        if storage.startswith(scheme):
            return "postgresql+psycopg://" + storage.removeprefix(scheme)
    return storage


@contextlib.contextmanager
def file_lock(path: pathlib.Path) -> Iterator[None]:
    """Hold an exclusive lock on ``path`` (created if missing) for the block."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


@contextlib.contextmanager
def creation_lock(storage: str) -> Iterator[None]:
    """Serialize study creation (and the tables under it) among all workers of ``storage``.

    PostgreSQL: an advisory lock on the server, so workers on every machine take turns.
    SQLite or a journal file: a lock file beside it. Other databases get no lock; create
    their study first with ``--trials 0``, then start the workers.
    """
    if storage.startswith(("postgresql", "postgres://")):
        import sqlalchemy

        engine = sqlalchemy.create_engine(database_url(storage), poolclass=sqlalchemy.pool.NullPool)
        with engine.connect() as connection:
            connection.execute(sqlalchemy.text(f"SELECT pg_advisory_lock({ADVISORY_LOCK_KEY})"))
            try:
                yield
            finally:
                connection.execute(
                    sqlalchemy.text(f"SELECT pg_advisory_unlock({ADVISORY_LOCK_KEY})")
                )
        engine.dispose()
    elif storage.startswith("sqlite:///"):
        with file_lock(pathlib.Path(storage.removeprefix("sqlite:///") + ".create-lock")):
            yield
    elif not is_database(storage):
        with file_lock(pathlib.Path(storage + ".create-lock")):
            yield
    else:
        yield


def retry_callback() -> Any:
    """Queues a failed trial again with its parameters and its intermediate values."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        return optuna.storages.RetryHeartbeatStaleTrialCallback(
            max_retry=3, inherit_intermediate_values=True
        )


def open_storage(storage: str, heartbeat: int) -> optuna.storages.BaseStorage:
    """An Optuna storage: a database with heartbeats every ``heartbeat`` seconds, or a
    journal file. Call under :func:`creation_lock`: a fresh database makes its tables here."""
    if is_database(storage):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            return optuna.storages.RDBStorage(
                database_url(storage),
                heartbeat_interval=heartbeat,
                grace_period=2 * heartbeat,
                heartbeat_stale_trial_callback=retry_callback(),
            )
    pathlib.Path(storage).parent.mkdir(parents=True, exist_ok=True)
    return optuna.storages.JournalStorage(WholeLineJournal(storage))


def open_study(
    storage: str,
    study_name: str,
    settings: dict[str, Any] | None,
    *,
    heartbeat: int = 60,
    sampler_seed: int | None = None,
    prune_after: int = 5,
) -> optuna.Study:
    """Create the study, or join it after checking that it runs the same ``settings``.

    :param storage: a database URL or a journal file's path
    :param study_name: the study's name
    :param settings: what every trial shares (:meth:`agents.sweeps.sweep.SweepSettings.to_attrs`;
        its ``objective`` gives the directions), or None to open an existing study as it is
    :param heartbeat: seconds between a database trial's heartbeats
    :param sampler_seed: seed of this worker's TPE sampler (None: random)
    :param prune_after: completed trials before the median pruner stops any trial
    :raises ValueError: for a study that does not exist (with ``settings`` None), one not made
        by a sweep, or one that runs other settings
    """
    if settings is None and not is_database(storage) and not pathlib.Path(storage).is_file():
        raise ValueError(f"no sweep at {storage}: no such study file")
    sampler = optuna.samplers.TPESampler(seed=sampler_seed)
    pruner = optuna.pruners.MedianPruner(n_startup_trials=prune_after)
    with creation_lock(storage):
        backend = open_storage(storage, heartbeat)
        if study_name not in optuna.study.get_all_study_names(storage=backend):
            if settings is None:
                raise ValueError(f"no study named {study_name!r} in {storage}")
            study = optuna.create_study(
                storage=backend,
                study_name=study_name,
                directions=[
                    optuna.study.StudyDirection[direction.upper()]
                    for direction in Objective.from_attrs(settings["objective"]).directions
                ],
                sampler=sampler,
                pruner=pruner,
            )
            study.set_user_attr(STUDY_ATTR, settings)
            return study
        study = optuna.load_study(
            study_name=study_name, storage=backend, sampler=sampler, pruner=pruner
        )
    stored = study.user_attrs.get(STUDY_ATTR)
    if stored is None:
        raise ValueError(f"study {study_name!r} in {storage} was not made by train.py sweep")
    if settings is not None and stored != settings:
        differing = sorted(key for key, value in settings.items() if stored.get(key) != value)
        raise ValueError(
            f"study {study_name!r} in {storage} runs other settings ({', '.join(differing)} "
            f"differ); join it with the same flags, or name another --study-name"
        )
    return study


def study_settings(study: optuna.Study) -> dict[str, Any]:
    """The settings a study was created with
    (:meth:`agents.sweeps.sweep.SweepSettings.to_attrs`)."""
    return dict(study.user_attrs[STUDY_ATTR])


def owner_of_this_process(trial_number: int) -> str:
    """The ``owner`` attribute of a trial this process runs: host, pid and trial number (a
    retried trial inherits its failed attempt's attributes, with the old number)."""
    return f"{socket.gethostname()}:{os.getpid()}:{trial_number}"


def process_start(pid: int) -> str | None:
    """What tells the process ``pid`` from a later one given the same id: the boot's id and
    the process's start time in clock ticks since boot (Linux's ``/proc``); None where the
    system does not say, or no such process runs.

    The ``owner_start`` attribute of a trial this process runs.
    """
    try:
        boot = pathlib.Path("/proc/sys/kernel/random/boot_id").read_text().strip()
        stat = pathlib.Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    # The fields after the command's closing parenthesis start at field 3; starttime is 22.
    return f"{boot}:{stat[stat.rindex(')') + 2 :].split()[19]}"


def process_alive(pid: int, start: str | None = None) -> bool:
    """Whether a process with this id runs on this machine, and is the one that started at
    ``start`` (:func:`process_start`; None: any process with this id)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    if start is None:
        return True
    now = process_start(pid)
    return now is None or now == start


def fail_dead_local_trials(study: optuna.Study, storage: str) -> list[int]:
    """Fail the RUNNING trials whose worker process on this machine is gone, and queue each
    again; return their numbers. A journal file has no heartbeats: this is how its dead
    workers' trials come back. A process that took over a dead worker's id does not keep its
    trial: the trial's ``owner_start`` tells them apart."""
    host = socket.gethostname()
    recovered = []
    with creation_lock(storage):
        for trial in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
            owner = str(trial.user_attrs.get("owner", ""))
            owner_host, _, rest = owner.partition(":")
            pid, _, number = rest.partition(":")
            if owner_host != host or number != str(trial.number) or not pid.isdigit():
                continue
            if process_alive(int(pid), trial.user_attrs.get("owner_start")):
                continue
            frozen = study.tell(trial.number, state=TrialState.FAIL)
            retry_callback()(study, frozen)
            recovered.append(trial.number)
    return recovered


def storage_failure_in(error: BaseException) -> BaseException | None:
    """The storage's failure that ``error`` is or came from: an ``OSError`` (a full disk, a
    journal that cannot be written) or a database error, found along ``__cause__`` and
    ``__context__`` unless suppressed (Optuna lets another error out when recording a trial
    fails, an ``UnboundLocalError`` when its database has gone); None when there is none."""
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        if isinstance(current, (OSError, sqlalchemy.exc.SQLAlchemyError)):
            return current
        seen.add(id(current))
        current = current.__cause__ or (
            None if current.__suppress_context__ else current.__context__
        )
    return None


def describe_storage_failure(failure: BaseException, storage: str) -> tuple[str, int]:
    """One line for a storage's failure, and the exit status: 2 when the database refused the
    URL's database or user (bad input), 1 otherwise (the system failed)."""
    if isinstance(failure, sqlalchemy.exc.SQLAlchemyError):
        cause = getattr(failure, "orig", None) or failure
        lines = [line.strip() for line in str(cause).splitlines() if line.strip()]
        text = lines[0] if lines else type(cause).__name__
        reason = text.partition("FATAL:")[2].strip() or text
        refused = any(words in reason for words in _REFUSED_BY_NAME)
        return f"--storage {shown_url(storage)}: {reason}", 2 if refused else 1
    if isinstance(failure, OSError) and failure.strerror and failure.filename is not None:
        return f"{failure.strerror}: {failure.filename}", 1
    return f"{type(failure).__name__}: {failure}", 1


@contextlib.contextmanager
def quiet_storage_failures_in_threads() -> Iterator[None]:
    """Within the block, a storage failure in another thread (Optuna's heartbeat) prints no
    traceback: the worker's own thread meets it too, and reports it in one line."""
    previous = threading.excepthook

    def hook(arguments: threading.ExceptHookArgs) -> None:
        if arguments.exc_value is None or storage_failure_in(arguments.exc_value) is None:
            previous(arguments)

    threading.excepthook = hook
    try:
        yield
    finally:
        threading.excepthook = previous

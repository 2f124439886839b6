"""Where a sweep's Optuna study lives, and how its workers share it safely.

- :func:`open_study` creates a study, or joins one after checking that the worker brings the
  study's own settings. Creation runs under :func:`creation_lock` (a PostgreSQL advisory
  lock, or a lock file beside a journal or SQLite file): two workers that start at once on a
  fresh database otherwise race on table creation ("table studies already exists").
- On a database (:func:`open_storage`) every trial sends heartbeats; the next worker that
  starts a trial fails a trial whose heartbeats stopped for two intervals and queues it again
  with its parameters and intermediate values (:func:`retry_callback`).
- A journal file has no heartbeats: :func:`fail_dead_local_trials` fails and queues again the
  RUNNING trials whose worker process on this machine is gone.

Requires the ``sweep`` extra (optuna; psycopg for PostgreSQL).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import pathlib
import socket
import warnings
from collections.abc import Iterator
from typing import Any

import optuna
from optuna.trial import TrialState

from agents.sweeps.objectives import Objective

#: The study's user attribute that holds the settings every worker must share.
STUDY_ATTR = "mobile_envs_sweep"
#: Key of the PostgreSQL advisory lock that serializes study creation.
ADVISORY_LOCK_KEY = 0x6D6F62696C65  # "mobile"


def default_storage(output: pathlib.Path) -> str:
    """The study file of a sweep folder."""
    return str(output / "study.journal")


def is_database(storage: str) -> bool:
    """Whether ``storage`` is a database URL (else a journal file path)."""
    return "://" in storage


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
    from optuna.storages.journal import JournalFileBackend

    return optuna.storages.JournalStorage(JournalFileBackend(storage))


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


def process_alive(pid: int) -> bool:
    """Whether a process with this id runs on this machine."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def fail_dead_local_trials(study: optuna.Study, storage: str) -> list[int]:
    """Fail the RUNNING trials whose worker process on this machine is gone, and queue each
    again; return their numbers. A journal file has no heartbeats: this is how its dead
    workers' trials come back."""
    host = socket.gethostname()
    recovered = []
    with creation_lock(storage):
        for trial in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
            owner = str(trial.user_attrs.get("owner", ""))
            owner_host, _, rest = owner.partition(":")
            pid, _, number = rest.partition(":")
            if owner_host != host or number != str(trial.number) or not pid.isdigit():
                continue
            if process_alive(int(pid)):
                continue
            frozen = study.tell(trial.number, state=TrialState.FAIL)
            retry_callback()(study, frozen)
            recovered.append(trial.number)
    return recovered

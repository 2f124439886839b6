"""Files written whole or not at all: a crash or a full disk never leaves half a file."""

from __future__ import annotations

import contextlib
import errno
import io
import os
import pathlib
from collections.abc import Callable

#: What ``os.link`` raises where the file system has no hard links.
_NO_HARD_LINKS = (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV, errno.EMLINK)


def write_atomically(
    path: str | os.PathLike[str],
    write: Callable[[io.BufferedWriter], object],
    *,
    overwrite: bool = True,
) -> pathlib.Path:
    """Write a file so that a crash, a signal or a power loss leaves either its old or its new
    contents at ``path``, never a mix, and no temporary file.

    ``write`` fills a temporary file in the same folder, which is flushed and synced to disk
    (``os.fsync``), renamed over ``path`` (``os.replace``, atomic on POSIX and Windows), and
    then the folder itself is synced so that the rename survives a power loss (POSIX only;
    skipped where the OS or file system cannot sync a folder).

    :param path: the file to write; its folder is created if needed
    :param write: writes the contents to the binary file it is given
    :param overwrite: False to publish the file only where nothing is at ``path``, checked
        and linked in one step (``os.link``), so a file that appears meanwhile is not
        replaced either
    :raises FileExistsError: naming ``path`` when ``overwrite`` is False and it exists
    :raises OSError: with ``path`` as its file name when the folder is not writable or full
        (never the temporary file's name)
    """
    path = pathlib.Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.partial")
    made = False
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(temporary, "wb") as file:
            made = True
            write(file)
            file.flush()
            os.fsync(file.fileno())
        if overwrite:
            os.replace(temporary, path)
        else:
            _publish_new(temporary, path)
        made = False
    except OSError as error:
        _remove_partial(temporary, made)
        raise OSError(error.errno, error.strerror or str(error), str(path)) from error
    except BaseException:  # KeyboardInterrupt included: never leave a .partial file behind
        _remove_partial(temporary, made)
        raise
    _sync_folder(path.parent)
    return path


def _publish_new(temporary: pathlib.Path, path: pathlib.Path) -> None:
    """Give the finished ``temporary`` the name ``path`` unless something is there already."""
    try:
        os.link(temporary, path)
    except OSError as error:
        if error.errno not in _NO_HARD_LINKS:
            raise
        if os.path.lexists(path):
            raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(path)) from None
        os.replace(temporary, path)
        return
    temporary.unlink()


def _remove_partial(temporary: pathlib.Path, made: bool) -> None:
    """Remove the temporary file if this write made it. Failing to remove it (the folder
    turned read-only) is not the error to report: the write's own is."""
    if made:
        with contextlib.suppress(OSError):
            temporary.unlink()


def _sync_folder(folder: pathlib.Path) -> None:
    if os.name != "posix":
        return  # Windows cannot open a folder with os.open, so there is nothing to sync
    descriptor = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        os.fsync(descriptor)
    except OSError as error:
        if error.errno not in (errno.EINVAL, errno.ENOTSUP, errno.EBADF):
            raise  # some file systems cannot sync a folder; a failing disk still raises
    finally:
        os.close(descriptor)

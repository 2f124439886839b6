"""Files written whole or not at all: a crash or a full disk never leaves half a file."""

from __future__ import annotations

import contextlib
import errno
import io
import os
import pathlib
from collections.abc import Callable


def write_atomically(
    path: str | os.PathLike[str], write: Callable[[io.BufferedWriter], object]
) -> pathlib.Path:
    """Write a file so that a crash, a signal or a power loss leaves either its old or its new
    contents at ``path``, never a mix, and no temporary file.

    ``write`` fills a temporary file in the same folder, which is flushed and synced to disk
    (``os.fsync``), renamed over ``path`` (``os.replace``, atomic on POSIX and Windows), and
    then the folder itself is synced so that the rename survives a power loss (POSIX only;
    skipped where the OS or file system cannot sync a folder).

    :param path: the file to write; its folder is created if needed
    :param write: writes the contents to the binary file it is given
    :raises OSError: with ``path`` as its file name when the folder is not writable or full
    """
    path = pathlib.Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.partial")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(temporary, "wb") as file:
            write(file)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, path)
    except OSError as error:
        _remove_partial(temporary)
        raise OSError(error.errno, error.strerror or str(error), str(path)) from error
    except BaseException:  # KeyboardInterrupt included: never leave a .partial file behind
        _remove_partial(temporary)
        raise
    _sync_folder(path.parent)
    return path


def _remove_partial(temporary: pathlib.Path) -> None:
    """Remove a temporary file if it was made; where it could not be (its folder is a file,
    or is missing) there is nothing to remove."""
    with contextlib.suppress(FileNotFoundError, NotADirectoryError):
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

"""Drop numba's compiled kernels when any source of the package changed.

numba keys a cached kernel on its own source file only, but a kernel compiles into itself
every function it calls: the step kernels of ``robot_step.py`` carry the physics of
``kinematics.py`` and the geometry of ``path_geometry.py``. After an edit to those, numba
would load the old machine code. This module runs when ``mobile_envs`` is imported, before
any kernel module: it hashes every ``.py`` file of the package and, in the directory where
numba keeps the package's kernels, compares the hash with the one stamped there by the last
import. When they differ it deletes the package's ``*.nbi``/``*.nbc`` files (numba then
compiles afresh, about 5 s) and stamps the new hash.

Any edit invalidates every kernel of the package: there is no list of which module inlines
which, so a new kernel module or a renamed one needs nothing here. Failures to read or write
the cache never break the import: an unusable cache directory is one numba does not use
either, and a deletion that fails leaves the old stamp, so the next import tries again.
"""

import contextlib
import fnmatch
import hashlib
import os
import secrets
import sys
import tempfile
from collections.abc import Iterator

#: The package whose sources and kernels this module follows: the folder above ``_kernels``.
PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: File in each kernel cache directory holding the sources' hash its kernels were built from.
STAMP_NAME = "mobile_envs-kernel-sources.sha256"
_CACHE_PATTERNS = ("*.nbi", "*.nbc")


def sources_digest(package_dir: str = PACKAGE_DIR) -> str:
    """The sha256 of every ``.py`` file under ``package_dir``, names and contents.

    :param package_dir: directory of the package whose sources to hash
    :return: the hex digest; it changes with any edit, new file, deletion or rename
    """
    digest = hashlib.sha256()
    for source_dir, names in _source_dirs(package_dir):
        relative_dir = os.path.relpath(source_dir, package_dir).replace(os.sep, "/")
        for name in names:
            digest.update(f"{relative_dir}/{name}\0".encode())
            with open(os.path.join(source_dir, name), "rb") as source:
                digest.update(source.read())
            digest.update(b"\0")
    return digest.hexdigest()


def kernel_cache_dir(source_dir: str) -> str | None:
    """The directory where numba caches the kernels of the modules in ``source_dir``.

    Follows numba's locators in numba's order: ``NUMBA_CACHE_DIR`` (as numba's config holds
    it), then ``__pycache__`` beside the sources, then numba's per-user cache directory; the
    first one that can be created and written to wins. The latter two are keyed, as numba keys
    them, on the absolute, unresolved path of ``source_dir``.

    :param source_dir: directory holding kernel modules
    :return: the directory, created if missing, or ``None`` when numba could use none
    """
    for candidate in _candidate_cache_dirs(os.path.abspath(source_dir)):
        if _is_writable_dir(candidate):
            return candidate
    return None


def invalidate_stale_kernel_caches(package_dir: str = PACKAGE_DIR) -> list[str]:
    """Delete the package's cached kernels wherever they predate the current sources.

    Safe to run from many processes at once: deleting is idempotent and the stamp is written
    to a private file and renamed into place, so a reader sees the old stamp or the new one.

    :param package_dir: directory of the package
    :return: the cache files deleted (empty when the caches are current)
    """
    digest = sources_digest(package_dir)
    deleted: list[str] = []
    for source_dir, _ in _source_dirs(package_dir):
        cache_dir = kernel_cache_dir(source_dir)
        if cache_dir is not None:
            deleted += _refresh(cache_dir, digest)
    return deleted


def kernels_cached(package_dir: str = PACKAGE_DIR) -> bool:
    """Whether numba's cache holds compiled step kernels of the package (``sim/``): False on
    the first run after installing or after an edit, which compiles them (about 30 s for a
    training run's), so a command can say so before its first step seems to hang.

    :param package_dir: directory of the package
    """
    cache_dir = kernel_cache_dir(os.path.join(package_dir, "sim"))
    if cache_dir is None:
        return False
    try:
        names = os.listdir(cache_dir)
    except OSError:
        return False
    return any(fnmatch.fnmatch(name, "*.nbi") for name in names)


def _source_dirs(package_dir: str) -> Iterator[tuple[str, list[str]]]:
    """Each directory under ``package_dir`` that holds ``.py`` files, with their sorted names."""
    for source_dir, dirs, files in os.walk(package_dir):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__" and not d.startswith("."))
        names = sorted(name for name in files if name.endswith(".py"))
        if names:
            yield source_dir, names


def _candidate_cache_dirs(source_dir: str) -> Iterator[str]:
    # numba's UserProvidedCacheLocator, InTreeCacheLocator and UserWideCacheLocator
    # (numba/core/caching.py), in the order numba tries them.
    subpath = "_".join(
        (os.path.basename(source_dir), hashlib.sha1(source_dir.encode()).hexdigest())
    )
    configured = _configured_numba_cache_dir()
    if configured:
        yield os.path.join(configured, subpath)
    yield os.path.join(source_dir, "__pycache__")
    yield os.path.join(_numba_user_cache_dir(), subpath)


def _configured_numba_cache_dir() -> str:
    """``NUMBA_CACHE_DIR`` as numba sees it, without importing numba when it need not be."""
    if "numba" in sys.modules or os.path.isfile(".numba_config.yaml"):
        # numba's config may differ from the environment: set in code or by the yaml file.
        from numba.core import config

        return str(getattr(config, "CACHE_DIR", ""))
    return os.environ.get("NUMBA_CACHE_DIR", "")


def _numba_user_cache_dir() -> str:
    # Reached only when the package's own __pycache__ is unusable (a read-only install):
    # numba's per-user directory is platform-specific, so ask numba rather than copy its rules.
    from numba.misc.appdirs import AppDirs

    return str(AppDirs(appname="numba", appauthor=False).user_cache_dir)


def _is_writable_dir(path: str) -> bool:
    # The test numba's locators make before they use a directory.
    try:
        os.makedirs(path, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


def _refresh(cache_dir: str, digest: str) -> list[str]:
    """Delete the kernels in ``cache_dir`` unless its stamp is ``digest``, then stamp it."""
    stamp_path = os.path.join(cache_dir, STAMP_NAME)
    if _read_stamp(stamp_path) == digest:
        return []
    deleted: list[str] = []
    try:
        names = sorted(os.listdir(cache_dir))
    except OSError:
        return []
    # Index files first: numba treats a missing index as an empty cache and a missing data
    # file as a miss, so a process loading kernels meanwhile recompiles rather than fails.
    # numba's in-flight "*.nbi.tmp.<id>" files match neither pattern and are left alone.
    for pattern in _CACHE_PATTERNS:
        for name in fnmatch.filter(names, pattern):
            path = os.path.join(cache_dir, name)
            try:
                os.remove(path)
            except FileNotFoundError:
                continue
            except OSError:
                # Kept a kernel (on Windows, one open elsewhere): keep the old stamp too.
                return deleted
            deleted.append(path)
    _write_stamp(stamp_path, digest)
    return deleted


def _read_stamp(stamp_path: str) -> str | None:
    try:
        with open(stamp_path, encoding="ascii", errors="replace") as stamp:
            return stamp.read()
    except OSError:
        return None


def _write_stamp(stamp_path: str, digest: str) -> None:
    private = f"{stamp_path}.tmp.{os.getpid()}.{secrets.token_hex(8)}"
    try:
        with open(private, "w", encoding="ascii") as stamp:
            stamp.write(digest)
        os.replace(private, stamp_path)
    except OSError:
        with contextlib.suppress(OSError):
            os.remove(private)


invalidate_stale_kernel_caches()

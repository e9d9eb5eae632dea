"""An on-disk cache of the compiled kernels, so that building them is paid once per machine.

:mod:`brdfkit.compiled` traces a model's code and compiles the generated source with numba;
the render's tile kernel (``render/_reflection_kernels.py``) calls those kernels. Both cost
seconds, every process. numba's own ``cache=True`` cannot help: it keys its files on a
function's source file (the generated code has none) and on a pickle of a closure's cells (a
compiled function pickles with a random id, so it never matches in the next process). This
module gives a numba dispatcher a cache keyed instead by a string the caller computes from
everything the machine code depends on (the generated source, its constants, the tile's
options), under a folder that names the version of brdfkit's code, numba and Python; numba
adds the CPU (its own "magic tuple") to each entry. It also keeps small JSON records (the
generated source of a model structure's kernel), so that a warm process does not even trace,
and arrays (:func:`store_arrays`: the tables of an environment map, which
:mod:`brdfkit.light.environment` is given as its second level of cache when this module is
imported, :func:`brdfkit.light.environment.use_table_store`).

The folder is ``$BRDFKIT_CACHE_DIR`` if set (empty: no disk cache), else
``platformdirs.user_cache_dir("brdfkit")``, then ``kernels/<version>``. Files are written
atomically (numba's own temporary-and-rename; :func:`brdfkit.io.atomic_write` for records), so
processes building the same kernel at once are safe. A folder that cannot be written, or an
entry that cannot be read (corrupt, truncated, another numba), degrades to compiling in
memory with no error; :data:`STATS` counts what happened. numba's cache classes are
subclassed in ``compiled/_numba.py``, which warns where they have changed. Version folders of
this cache unused for :data:`STALE_DAYS` are removed (only folders holding this cache's
marker file).

References
----------
.. [1] Numba documentation, "Notes on Caching" (index and data files, cache invalidation).
"""

from __future__ import annotations

import collections
import functools
import hashlib
import json
import os
import shutil
import sys
import tempfile
import threading
import time
import weakref
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from brdfkit.compiled import _numba
from brdfkit.light.environment import TableStore, use_table_store

ENV = "BRDFKIT_CACHE_DIR"
"""Environment variable overriding the cache folder (an empty value turns the cache off)."""
STALE_DAYS = 30
"""Days after which a version folder not used since is removed."""
_MARKER = "brdfkit-kernel-cache"

STATS: collections.Counter[str] = collections.Counter()
"""Counts of ``hits``/``misses`` (numba machine code loaded from disk or compiled),
``record_hits``/``record_misses`` (generated sources), ``array_hits``/``array_misses``
(:func:`load_arrays`) and ``errors`` (entries that could not be
read or written: the kernel was then compiled in memory), since the process started."""

_LOCK = threading.Lock()
_VERSION_LOCK = threading.Lock()
_USABLE: dict[Path, bool] = {}
_KEYS: weakref.WeakKeyDictionary[Any, str] = weakref.WeakKeyDictionary()


_APPLICATION = frozenset(
    {"cli", "explore", "report", "distributed", "fit", "vision", "interop", "checks", "plot.py"}
)
"""brdfkit's packages and modules (first path component) that no kernel's trace or source
reaches, left out of :func:`version` so that editing them keeps the cache."""


def version() -> str:
    """A hash of everything the cached kernels depend on besides their key: the source of
    every module of brdfkit but those of :data:`_APPLICATION` (the models, the tracer, the
    hand-written kernels), the numba toolchain's versions and Python's. The versions are read
    from the installed packages' metadata, so that a process asking for the cache's version
    (the atlas's workers) does not import numba. Computed once per process, by the first
    thread to ask (a render's kernels and its maps' tables ask at once)."""
    with _VERSION_LOCK:
        return _version()


@functools.cache
def _version() -> str:
    digest = hashlib.sha256(f"{_numba.toolchain()}|{sys.version}".encode())
    package = Path(__file__).parents[1]
    for relative in _kernel_sources(package):
        digest.update(relative.encode())
        digest.update((package / relative).read_bytes())
    return digest.hexdigest()[:20]


def _kernel_sources(package: Path) -> list[str]:
    """The paths (relative, ``/``-separated, sorted) of the modules under ``package`` that
    kernels may depend on: every ``.py`` file but those under :data:`_APPLICATION`, whose
    folders are not walked."""
    found = []
    for folder, subfolders, files in os.walk(package):
        relative = Path(folder).relative_to(package).as_posix()
        if relative == ".":
            subfolders[:] = [d for d in subfolders if d not in _APPLICATION]
            found += [f for f in files if f.endswith(".py") and f not in _APPLICATION]
        else:
            found += [f"{relative}/{f}" for f in files if f.endswith(".py")]
    return sorted(found)


def root() -> Path | None:
    """The folder holding every version of the cache, or ``None`` when turned off."""
    override = os.environ.get(ENV)
    if override is not None:
        return Path(override).expanduser() if override else None
    import platformdirs

    return Path(platformdirs.user_cache_dir("brdfkit")) / "kernels"


def directory() -> Path | None:
    """This version's folder, created, or ``None`` when the cache is off or cannot be written."""
    base = root()
    if base is None:
        return None
    path = base / version()
    with _LOCK:
        usable = _USABLE.get(path)
        if usable is None:
            usable = _USABLE[path] = _prepare(path)
    return path if usable else None


def _prepare(path: Path) -> bool:
    """Create ``path`` with its marker, check it can be written, prune stale versions."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        marker = path / _MARKER
        marker.touch()  # its time: when this version was last used
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    _prune(path.parent, keep=path)
    return True


def _prune(base: Path, keep: Path) -> None:
    """Remove the version folders under ``base`` that hold this cache's marker and were not
    used for :data:`STALE_DAYS` (nothing else: a folder without the marker is not ours)."""
    cutoff = time.time() - STALE_DAYS * 86400
    try:
        folders = [p for p in base.iterdir() if p.is_dir() and p != keep]
    except OSError:
        return
    for folder in folders:
        try:
            if (folder / _MARKER).stat().st_mtime < cutoff:
                shutil.rmtree(folder)
        except OSError:
            continue


def key(*parts: Any) -> str:
    """A cache key: the hash of ``parts``' text."""
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:32]


# --------------------------------------------------------------------------- numba entries
def _entry(cache_key: str) -> Path | None:
    folder = directory()
    return None if folder is None else folder / "numba" / cache_key


def has(cache_key: str) -> bool:
    """Whether numba machine code for ``cache_key`` is on disk (loading it compiles nothing)."""
    path = _entry(cache_key)
    return path is not None and any(path.glob("*.nbi"))


def key_of(dispatcher: Any) -> str | None:
    """The key :func:`enable` gave ``dispatcher``, or ``None`` (compiled in memory only)."""
    return _KEYS.get(dispatcher)


def enable(dispatcher: Any, cache_key: str) -> bool:
    """Give a numba dispatcher (not yet compiled) the disk cache of ``cache_key``; ``False``
    (and nothing changed) where the cache is off or cannot be written, or where numba's
    cache could not be installed (:func:`brdfkit.compiled._numba.install_keyed_cache` warns
    then)."""
    path = _entry(cache_key)
    if path is None:
        return False
    if not _numba.install_keyed_cache(dispatcher, cache_key, path, _count):
        STATS["errors"] += 1
        return False
    _KEYS[dispatcher] = cache_key
    return True


def _count(event: str) -> None:
    """One more ``event`` of the numba entries in :data:`STATS`."""
    STATS[event] += 1


def njit(py_func: Callable[..., Any], cache_key: str, **options: Any) -> Any:
    """``numba.njit(**options)(py_func)`` with the disk cache of ``cache_key``."""
    numba = _numba.numba_module()

    dispatcher = numba.njit(**options)(py_func)
    enable(dispatcher, cache_key)
    return dispatcher


# --------------------------------------------------------------------------- JSON records
def _record_path(kind: str, cache_key: str) -> Path | None:
    folder = directory()
    return None if folder is None else folder / kind / f"{cache_key}.json"


def load_record(kind: str, cache_key: str) -> dict | None:
    """The record stored under ``kind``/``cache_key``, or ``None`` (absent or unreadable)."""
    path = _record_path(kind, cache_key)
    if path is None:
        return None
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        STATS["record_misses"] += 1
        return None
    except (OSError, ValueError):
        STATS["errors"] += 1
        return None
    if not isinstance(record, dict):
        STATS["errors"] += 1
        return None
    STATS["record_hits"] += 1
    return record


def store_record(kind: str, cache_key: str, record: dict) -> None:
    """Store ``record`` (JSON) under ``kind``/``cache_key``, atomically; errors are counted,
    never raised."""
    from brdfkit.io import atomic_write

    path = _record_path(kind, cache_key)
    if path is None:
        return
    text = json.dumps(record)
    try:
        atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    except OSError:
        STATS["errors"] += 1


# --------------------------------------------------------------------------- arrays
def _array_path(kind: str, cache_key: str) -> Path | None:
    folder = directory()
    return None if folder is None else folder / kind / f"{cache_key}.npz"


def load_arrays(kind: str, cache_key: str) -> dict[str, Any] | None:
    """The NumPy arrays stored under ``kind``/``cache_key`` by :func:`store_arrays`, or
    ``None`` (absent, or unreadable: truncated, corrupt, holding objects). Whether their
    shapes, types and values are what the caller expects is the caller's to check."""
    import numpy as np

    path = _array_path(kind, cache_key)
    if path is None:
        return None
    try:
        with np.load(path, allow_pickle=False) as stored:
            arrays = {name: stored[name] for name in stored.files}
    except FileNotFoundError:
        STATS["array_misses"] += 1
        return None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile):
        STATS["errors"] += 1
        return None
    STATS["array_hits"] += 1
    return arrays


def store_arrays(kind: str, cache_key: str, arrays: dict[str, Any]) -> None:
    """Store NumPy ``arrays`` (an ``.npz`` file) under ``kind``/``cache_key``, atomically;
    errors are counted, never raised."""
    writer = array_writer(kind, cache_key)
    if writer is not None:
        writer(arrays)


def array_writer(kind: str, cache_key: str) -> Callable[[dict[str, Any]], None] | None:
    """:func:`store_arrays` for ``kind``/``cache_key`` with its file fixed now (in the cache
    folder of this moment), to call later; ``None`` where the cache is off."""
    path = _array_path(kind, cache_key)
    return None if path is None else functools.partial(_write_arrays, path)


def _write_arrays(path: Path, arrays: dict[str, Any]) -> None:
    import numpy as np

    from brdfkit.io import atomic_write

    def write(tmp: Path) -> None:
        with tmp.open("wb") as handle:
            np.savez(handle, **arrays)

    try:
        atomic_write(path, write)
    except OSError:
        STATS["errors"] += 1


use_table_store(TableStore(load_arrays, array_writer))


__all__ = [
    "ENV",
    "STALE_DAYS",
    "STATS",
    "array_writer",
    "directory",
    "enable",
    "has",
    "key",
    "key_of",
    "load_arrays",
    "load_record",
    "njit",
    "root",
    "store_arrays",
    "store_record",
    "version",
]

"""Derived tables kept on disk across processes: set-up paid once per sensor configuration.

A fingertip's mode bands, per-mode limits and gel tables take a few hundred milliseconds to
compute and depend only on its parameters.  Within a process they are cached by
:meth:`Fingertip.config_key`; this module keeps them on disk too, so the workers of a sweep and
the next command start with them.

Safety, in order of importance:

- The key is a SHA-256 of the namespace, the ``repr`` of the configuration key (every
  parameter, floats written exactly) and a fingerprint of the source of every module of
  ``piezotip.sensor`` (and of any module the caller names): a change of parameter or of code
  computes afresh; an entry is never reused for anything else.
- Entries are plain arrays (``.npz`` read with ``allow_pickle=False``): no code is loaded from
  the cache.
- Written to a temporary file and renamed (atomic on POSIX): a reader never sees half an entry;
  two processes computing the same entry write the same content.  An unreadable entry is
  computed again and replaced.

Where: ``$PIEZOTIP_CACHE_DIR``, else ``$XDG_CACHE_HOME/piezotip``, else ``~/.cache/piezotip``.
``PIEZOTIP_CACHE=off`` turns caching off, on disk and in memory (:func:`enabled`): every run
then computes its own set-up, which is what ``bench --throughput`` compares against.

Bounded: the folder holds at most ``$PIEZOTIP_CACHE_MAX_MB`` megabytes (default
:data:`DEFAULT_MAX_MB`).  Every new configuration (a sweep over sensor units, each edit of the
sensor's code) adds entries that nothing else will read, so after a write that takes the folder
over its bound the least recently used entries go (a read marks an entry used) until it is
under :data:`PRUNE_TO` of it.  An entry removed under a reader is computed again, like a torn one.
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
import zipfile
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

_FINGERPRINTS: dict[tuple[str, ...], str] = {}

#: The cache folder's default bound, MB (a fingertip configuration's entries take about 0.07 MB).
DEFAULT_MAX_MB = 200.0
#: Pruning goes down to this fraction of the bound, so that it runs once in many writes.
PRUNE_TO = 0.8


def enabled() -> bool:
    """Whether derived tables are cached at all (in memory and on disk): ``PIEZOTIP_CACHE=off``
    says no.  The in-process caches (keyed by :meth:`Fingertip.config_key`) ask this too."""
    return os.environ.get("PIEZOTIP_CACHE", "").lower() not in ("0", "off", "false", "no")


def cache_dir() -> Path | None:
    """The cache folder, or None when caching is off."""
    if not enabled():
        return None
    if os.environ.get("PIEZOTIP_CACHE_DIR"):
        return Path(os.environ["PIEZOTIP_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "piezotip"


def max_bytes() -> int:
    """The cache folder's bound, bytes: ``$PIEZOTIP_CACHE_MAX_MB`` megabytes, else DEFAULT_MAX_MB.
    Raises ValueError naming the variable's value when it is not a non-negative number."""
    text = os.environ.get("PIEZOTIP_CACHE_MAX_MB", "").strip()
    if not text:
        return int(DEFAULT_MAX_MB * 1e6)
    try:
        mb = float(text)
    except ValueError:
        mb = math.nan
    if not (mb >= 0.0 and math.isfinite(mb)):
        raise ValueError(f"PIEZOTIP_CACHE_MAX_MB must be a non-negative number of megabytes, got {text!r}")
    return int(mb * 1e6)


def prune(folder: Path, limit_bytes: int) -> list[Path]:
    """Remove the least recently used entries of ``folder`` (by modification time, which a read
    refreshes) while its entries take more than ``limit_bytes``, down to PRUNE_TO of it; returns
    the entries removed.  Another process's removal of the same entry is not an error."""
    entries = []
    total = 0
    with os.scandir(folder) as it:
        for item in it:
            if not item.name.endswith(".npz") or item.name.startswith(".tmp-"):
                continue
            try:
                st = item.stat()
            except OSError:
                continue
            entries.append((st.st_mtime_ns, st.st_size, item.path))
            total += st.st_size
    removed = []
    if total <= limit_bytes:
        return removed
    target = PRUNE_TO * limit_bytes
    for _, size, path in sorted(entries):
        if total <= target:
            break
        try:
            os.unlink(path)
        except OSError:
            pass
        total -= size
        removed.append(Path(path))
    return removed


def source_fingerprint(extra_modules: Iterable[str] = ()) -> str:
    """SHA-256 of the source text of every ``piezotip.sensor`` module and of ``extra_modules``
    (files, by path): the code that computes an entry is part of its key."""
    extra = tuple(sorted(str(p) for p in extra_modules))
    if extra not in _FINGERPRINTS:
        digest = hashlib.sha256()
        files = sorted(Path(__file__).parent.glob("*.py")) + [Path(p) for p in extra]
        for path in files:
            digest.update(path.name.encode())
            digest.update(path.read_bytes())
        _FINGERPRINTS[extra] = digest.hexdigest()
    return _FINGERPRINTS[extra]


def entry_key(namespace: str, key: object, extra_modules: Iterable[str] = ()) -> str:
    """The file name stem of an entry: a hash of everything it depends on."""
    text = f"{namespace}\n{key!r}\n{source_fingerprint(extra_modules)}"
    return f"{namespace}-{hashlib.sha256(text.encode()).hexdigest()[:40]}"


def disk_cached(
    namespace: str, key: object, compute: Callable[[], dict[str, np.ndarray]], extra_modules: Iterable[str] = ()
) -> dict[str, np.ndarray]:
    """``compute()`` (a dict of arrays) stored under ``key``, or the stored copy when there is one.

    ``key`` must hold every parameter the result depends on (its ``repr`` is hashed; use
    immutable values whose repr is exact, e.g. frozen dataclasses of floats).
    """
    folder = cache_dir()
    if folder is None:
        return compute()
    limit = max_bytes()
    path = folder / f"{entry_key(namespace, key, extra_modules)}.npz"
    if path.exists():
        try:
            with np.load(path, allow_pickle=False) as npz:
                value = {name: npz[name] for name in npz.files}
            _touch(path)
            return value
        except (OSError, ValueError, EOFError, zipfile.BadZipFile):
            pass  # torn, foreign or pruned under us: compute and replace below
    value = compute()
    tmp = None
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=".npz")
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **value)
        os.replace(tmp, path)
        prune(folder, limit)
    except OSError:  # a read-only or full disk: the value is still right, only not kept
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
    return value


def _touch(path: Path) -> None:
    """Mark an entry used (its modification time, which pruning goes by)."""
    try:
        os.utime(path)
    except OSError:  # a read-only cache is still a cache
        pass

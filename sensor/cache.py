"""Derived tables kept on disk across processes: set-up paid once per sensor configuration.

A fingertip's mode bands, per-mode limits and gel tables take a few hundred milliseconds to
compute and depend only on its parameters.  Within a process they are cached by
:meth:`Fingertip.config_key`; this module keeps them on disk too, so the workers of a sweep and
the next command start with them.

A cache must not change a result, so, in order of importance:

- The key is a SHA-256 of the namespace, the ``repr`` of the configuration key (every
  parameter, floats written exactly) and a fingerprint of the code that runs to compute it
  (:func:`code_files`): the source of every module of ``piezotip.sensor`` and of any module the
  caller names, the Cython sources (``.pyx``, ``.pxd``, a compiled kernel's ``.py``) beside
  them, and the compiled extension modules there that this interpreter imports (their files'
  bytes: an edited source that has not been rebuilt is not what runs, the built module is; its
  source is keyed too, which costs at most one recomputation).  A change of parameter or of code computes afresh; an entry is never reused
  for anything else.
- Every entry carries a manifest (:data:`MANIFEST`): the key it was written under, each array's
  dtype, shape and count of non-finite values, and a SHA-256 of all of them and of the arrays'
  bytes.  An entry that fails any check on reading (unreadable, truncated, no manifest, written for
  another key, an array missing, extra, of another dtype or shape, NaN where there was none, any
  other change of content) is computed again and replaced, with one warning line on the
  ``piezotip.sensor.cache`` logger naming its file and the check that failed.  A logger, not
  :func:`warnings.warn`: the caller has nothing to change, the entry is repaired, but a disk that
  corrupts files should be seen.  A checksum finds damage, not forgery: whoever can write the
  folder can write a consistent wrong entry.
- Entries are plain arrays (``.npz`` read with ``allow_pickle=False``): no code is loaded from
  the cache.
- Written to a temporary file and renamed (atomic on POSIX): a reader never sees half an entry;
  two processes computing the same entry write the same bytes.  An entry removed under a reader
  (pruned by another process) is computed again without a warning.

Where: ``$PIEZOTIP_CACHE_DIR``, else ``$XDG_CACHE_HOME/piezotip``, else ``~/.cache/piezotip``.
``PIEZOTIP_CACHE=off`` turns caching off, on disk and in memory (:func:`enabled`): every run
then computes its own set-up, which is what ``bench --throughput`` compares against.

Bounded: the cache's entries take at most ``$PIEZOTIP_CACHE_MAX_MB`` megabytes (default
:data:`DEFAULT_MAX_MB`).  Every new configuration (a sweep over sensor units, each edit of the
sensor's code) adds entries that nothing else will read, so after a write that takes them over
the bound the least recently used entries go (a read marks an entry used) until they are under
:data:`PRUNE_TO` of it.  An entry removed under a reader is computed again, like a torn one.
Pruning counts and removes the cache's own entries only (:func:`is_own_entry`: named as
:func:`entry_key` names them, ``<namespace>-<40 hex digits>.npz``, and holding an entry's
manifest), never another file in the folder: the folder may be one a user keeps files in.

What checking costs: the fingerprint hashes some 3 MB of code once per process (about 5 ms, the
compiled modules most of it, 2.5 ms more than the Python sources alone); checking the 14 entries
a grasp reads adds 1.5 ms to reading them (measured: no difference in a whole run's time).
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import json
import logging
import math
import os
import re
import stat
import tempfile
import zipfile
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from . import compiled

_LOG = logging.getLogger(__name__)

#: Fingerprints by the caller's extra modules, and each code file's digest: what runs is what was
#: there when the process first computed them (modules are not reloaded).
_FINGERPRINTS: dict[tuple[str, ...], str] = {}
_DIGESTS: dict[Path, bytes] = {}

#: The member of an entry's ``.npz`` holding its manifest (JSON, UTF-8 bytes): the key it was
#: written under, each array's dtype, shape and count of non-finite values, and the checksum.
MANIFEST = "__entry__"
#: The manifest's format; an entry of another format fails its check and is computed again.
FORMAT = 1

#: The cache folder's default bound, MB (a fingertip configuration's entries take about 0.076 MB).
DEFAULT_MAX_MB = 200.0
#: Pruning goes down to this fraction of the bound, so that it runs once in many writes.
PRUNE_TO = 0.8

#: A namespace: lower-case words joined by hyphens (what :data:`ENTRY_NAME` can tell apart from
#: the 40 hex digits of the key that follow it).
_NAMESPACE = re.compile(r"[a-z0-9]+(?:-[a-z0-9]+)*")
#: An entry's file name, as :func:`entry_key` makes it: the only files pruning counts or removes.
ENTRY_NAME = re.compile(rf"{_NAMESPACE.pattern}-[0-9a-f]{{40}}\.npz")


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
    the entries removed.  Another process's removal of the same entry is not an error.

    Only the cache's own entries count and go (:func:`is_own_entry`): any other file there (a
    user's ``.npz``, a temporary being written, a file merely named like an entry) is neither
    counted nor removed."""
    entries = []
    total = 0
    with os.scandir(folder) as it:
        for item in it:
            if not ENTRY_NAME.fullmatch(item.name):
                continue
            try:
                st = item.stat(follow_symlinks=False)
            except OSError:
                continue
            if not stat.S_ISREG(st.st_mode):  # a link or a folder named like an entry is not one
                continue
            entries.append((st.st_mtime_ns, st.st_size, item.path))
            total += st.st_size
    removed: list[Path] = []
    if total <= limit_bytes:
        return removed
    # Over the bound (once in many writes): now open them, since a file with an entry's name but
    # no manifest is someone else's, and neither counts nor goes.
    entries = [e for e in entries if is_own_entry(Path(e[2]))]
    total = sum(size for _, size, _ in entries)
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


def is_own_entry(path: Path) -> bool:
    """Whether ``path`` is an entry this cache wrote: named as :func:`entry_key` names entries
    (:data:`ENTRY_NAME`) and a ``.npz`` holding the manifest member (:data:`MANIFEST`).  Its
    content is not checked (reading does that); a file gone or unreadable is not one."""
    if not ENTRY_NAME.fullmatch(path.name):
        return False
    try:
        with zipfile.ZipFile(path) as npz:
            return f"{MANIFEST}.npy" in npz.namelist()
    except (OSError, zipfile.BadZipFile, ValueError):
        return False


def code_files(extra_modules: Iterable[str] = ()) -> list[Path]:
    """The files whose content computes an entry: every ``piezotip.sensor`` module, the modules
    ``extra_modules`` (paths), and in each of their folders the Cython sources (``*.pyx``,
    ``*.pxd``, and a compiled kernel's ``.py``: one with a ``.pxd`` beside it) and the extension
    modules built from them that this interpreter imports (for each module name, the first file
    by :data:`importlib.machinery.EXTENSION_SUFFIXES`, as the import system picks it).  With
    ``PIEZOTIP_PURE_PYTHON`` set the extension modules are not imported
    (:mod:`piezotip.sensor.compiled`) and are left out."""
    here = Path(__file__).parent
    extra = sorted({Path(p) for p in extra_modules})
    files = sorted(here.glob("*.py")) + extra
    for folder in sorted({here} | {p.parent for p in extra}):
        declarations = sorted(folder.glob("*.pxd"))
        files += sorted(folder.glob("*.pyx")) + declarations
        files += [p.with_suffix(".py") for p in declarations if p.with_suffix(".py").is_file() and p.with_suffix(".py") not in files]
        if not compiled.PURE_PYTHON:
            files += _extension_modules(folder)
    return files


def _extension_modules(folder: Path) -> list[Path]:
    """The extension module files of ``folder`` this interpreter would import, one per module."""
    names = {entry.name for entry in os.scandir(folder)}
    chosen = {}
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:  # in the import system's order
        for name in names:
            module = name[: -len(suffix)]
            if name.endswith(suffix) and module and "." not in module and module not in chosen:
                chosen[module] = folder / name
    return [chosen[m] for m in sorted(chosen)]


def source_fingerprint(extra_modules: Iterable[str] = ()) -> str:
    """SHA-256 of the names and contents of :func:`code_files` (``extra_modules`` as paths): the
    code that computes an entry is part of its key."""
    extra = tuple(sorted(str(p) for p in extra_modules))
    if extra not in _FINGERPRINTS:
        digest = hashlib.sha256(b"pure-python" if compiled.PURE_PYTHON else b"compiled")
        for path in code_files(extra):
            if path not in _DIGESTS:
                with open(path, "rb") as fh:
                    _DIGESTS[path] = hashlib.file_digest(fh, "sha256").digest()
            digest.update(f"\0{path.name}\0".encode())
            digest.update(_DIGESTS[path])
        _FINGERPRINTS[extra] = digest.hexdigest()
    return _FINGERPRINTS[extra]


def entry_key(namespace: str, key: object, extra_modules: Iterable[str] = ()) -> str:
    """The file name stem of an entry: a hash of everything it depends on,
    ``<namespace>-<40 hex digits>``.  Raises ValueError for a namespace that is not lower-case
    words joined by hyphens (pruning would not know its entries: :data:`ENTRY_NAME`)."""
    if not _NAMESPACE.fullmatch(namespace):
        raise ValueError(f"cache namespace {namespace!r} must be lower-case letters and digits, words joined by '-'")
    text = f"{namespace}\n{key!r}\n{source_fingerprint(extra_modules)}"
    return f"{namespace}-{hashlib.sha256(text.encode()).hexdigest()[:40]}"


def disk_cached(
    namespace: str, key: object, compute: Callable[[], dict[str, np.ndarray]], extra_modules: Iterable[str] = ()
) -> dict[str, np.ndarray]:
    """``compute()`` (a dict of numeric arrays) stored under ``key``, or the stored copy when there
    is one and it passes every check (:func:`read_entry`); one that fails is computed again and
    replaced, with one warning line naming its file and the failed check.

    ``key`` must hold every parameter the result depends on (its ``repr`` is hashed; use
    immutable values whose repr is exact, e.g. frozen dataclasses of floats).
    """
    folder = cache_dir()
    if folder is None:
        return compute()
    limit = max_bytes()
    stem = entry_key(namespace, key, extra_modules)
    path = folder / f"{stem}.npz"
    if path.exists():
        try:
            value = read_entry(path, stem)
            _touch(path)
            return value
        except FileNotFoundError:
            pass  # pruned under us by another process: nothing is wrong, compute it again
        except InvalidEntry as failed:
            _LOG.warning("piezotip cache: entry %s failed its check (%s); computing it again and replacing it", path, failed)
    value = compute()
    arrays = {name: np.asarray(array) for name, array in value.items()}
    tmp = None
    try:
        content = dict(arrays, **{MANIFEST: np.array(_manifest(stem, arrays).encode())})
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=".npz")
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **content)
        os.replace(tmp, path)
        prune(folder, limit)
    except OSError:  # a read-only or full disk: the value is still right, only not kept
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
    return value


class InvalidEntry(Exception):
    """A stored entry failed a check (:func:`read_entry`); the message says which, on one line."""


def read_entry(path: Path, stem: str) -> dict[str, np.ndarray]:
    """The arrays of the entry ``path`` stored under the key ``stem``, checked against its manifest.

    Raises InvalidEntry saying which check failed (unreadable or truncated, no manifest or an
    unreadable one, written under another key, an array missing or extra, another dtype or shape,
    NaN or infinite values where there were none, a checksum mismatch), FileNotFoundError when the
    file is gone (removed under the reader)."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            stored = {name: npz[name] for name in npz.files}
    except FileNotFoundError:
        raise
    except Exception as error:  # whatever a damaged file raises, it is a failed check
        raise InvalidEntry(f"unreadable: {type(error).__name__}: {_one_line(error)}") from None
    if MANIFEST not in stored:
        raise InvalidEntry(f"no manifest ({MANIFEST!r}): damaged, or written by an older version")
    try:
        manifest = json.loads(stored.pop(MANIFEST)[()].decode())
        written_for, specs, checksum = manifest["key"], manifest["arrays"], manifest["sha256"]
        if manifest["format"] != FORMAT or not isinstance(specs, dict):
            raise ValueError(f"format {manifest['format']!r}, expected {FORMAT}")
        specs = {name: (str(spec["dtype"]), tuple(int(n) for n in spec["shape"]), int(spec["nonfinite"])) for name, spec in specs.items()}
    except Exception as error:  # a damaged manifest, however it is damaged
        raise InvalidEntry(f"manifest unreadable: {type(error).__name__}: {_one_line(error)}") from None
    if written_for != stem:
        raise InvalidEntry(f"written for another entry ({written_for!r})")
    if set(stored) != set(specs):
        missing, extra = sorted(set(specs) - set(stored)), sorted(set(stored) - set(specs))
        raise InvalidEntry(f"arrays missing {missing}, unexpected {extra}")
    for name in sorted(specs):
        dtype, shape, nonfinite = specs[name]
        array = stored[name]
        if array.dtype.str != dtype:
            raise InvalidEntry(f"array {name!r} has dtype {array.dtype.str}, expected {dtype}")
        if array.shape != shape:
            raise InvalidEntry(f"array {name!r} has shape {array.shape}, expected {shape}")
        if _nonfinite(array) != nonfinite:
            raise InvalidEntry(f"array {name!r} has {_nonfinite(array)} NaN or infinite values, expected {nonfinite}")
    if _checksum(stem, stored) != checksum:
        raise InvalidEntry("checksum mismatch: the arrays' content changed")
    return stored


def _manifest(stem: str, arrays: dict[str, np.ndarray]) -> str:
    """An entry's manifest (JSON): its key, each array's dtype, shape and non-finite count, the
    checksum.  Raises ValueError for a name the manifest takes or an array of objects."""
    for name, array in arrays.items():
        if name == MANIFEST or array.dtype.hasobject:
            raise ValueError(f"cannot cache array {name!r} of dtype {array.dtype}: the name {MANIFEST!r} and objects are not stored")
    specs = {name: {"dtype": a.dtype.str, "shape": list(a.shape), "nonfinite": _nonfinite(a)} for name, a in arrays.items()}
    return json.dumps({"format": FORMAT, "key": stem, "arrays": specs, "sha256": _checksum(stem, arrays)}, sort_keys=True)


def _checksum(stem: str, arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 of the key and of each array's name, dtype, shape and bytes (C order)."""
    digest = hashlib.sha256(stem.encode())
    for name in sorted(arrays):
        array = arrays[name]
        digest.update(f"\0{name}\0{array.dtype.str}\0{array.shape}\0".encode())
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()


def _nonfinite(array: np.ndarray) -> int:
    """How many NaN or infinite values ``array`` holds (0 for integers, booleans, strings)."""
    if array.dtype.kind not in "fc":
        return 0
    return int(array.size - np.count_nonzero(np.isfinite(array)))


def _one_line(error: BaseException) -> str:
    return " ".join(str(error).split())[:200]


def _touch(path: Path) -> None:
    """Mark an entry used (its modification time, which pruning goes by)."""
    try:
        os.utime(path)
    except OSError:  # a read-only cache is still a cache
        pass

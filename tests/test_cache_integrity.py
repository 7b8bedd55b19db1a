"""A damaged cache entry cannot change a result (issue 30): every check an entry must pass on
reading, each kind of damage, and the project's own entries damaged on disk under a real run."""

import importlib
import itertools
import json
import logging
import os
import re
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest

from piezotip.sensor import cache as cache_module
from piezotip.sensor.cache import MANIFEST, disk_cached, entry_key, read_entry

REPO = Path(__file__).resolve().parents[1]


def _rewrite(path: Path, change) -> None:
    """Rewrite the entry ``path`` as a well-formed ``.npz`` with its data arrays changed by
    ``change`` (a dict of arrays to a dict of arrays); its manifest, if any, is kept as it was."""
    with np.load(path, allow_pickle=False) as npz:
        members = {name: npz[name] for name in npz.files}
    kept = {name: a for name, a in members.items() if name == MANIFEST}
    data = change({name: a for name, a in members.items() if name != MANIFEST})
    with open(path, "wb") as fh:
        np.savez(fh, **kept, **data)


def _each(function):
    """A change applying ``function`` to every array."""
    return lambda data: {name: function(a) for name, a in data.items()}


def _randomized(a: np.ndarray) -> np.ndarray:
    rng = np.random.default_rng(zlib.crc32(a.tobytes()))
    if a.dtype.kind in "fc":
        return (rng.standard_normal(a.shape) * 1e3).astype(a.dtype)
    return rng.integers(0, 100, a.shape).astype(a.dtype)


def _scaled(a: np.ndarray) -> np.ndarray:
    return (a * 1.5).astype(a.dtype) if a.dtype.kind in "fc" else (a * 2 + 1).astype(a.dtype)


def _nan(a: np.ndarray) -> np.ndarray:
    if a.dtype.kind not in "fc" or a.size == 0:
        return (a + 1).astype(a.dtype)
    a = a.copy()
    a.flat[0] = np.nan
    return a


def _retyped(a: np.ndarray) -> np.ndarray:
    return a.astype(np.float32 if a.dtype == np.float64 else np.float64)


def _garbage(path: Path, others) -> None:
    path.write_bytes(np.random.default_rng(0).integers(0, 256, path.stat().st_size, dtype=np.uint8).tobytes())


#: How an entry is damaged: name -> function(path, the other entries' files).  The first six are
#: the issue's; the rest are the other checks' (a torn file, another entry's file, an entry of
#: another format, a damaged manifest).
CORRUPTIONS = {
    "truncated": lambda path, others: path.write_bytes(path.read_bytes()[: path.stat().st_size // 2]),
    "randomized": lambda path, others: _rewrite(path, _each(_randomized)),
    "scaled": lambda path, others: _rewrite(path, _each(_scaled)),
    "nan": lambda path, others: _rewrite(path, _each(_nan)),
    "zeroed": lambda path, others: _rewrite(path, _each(np.zeros_like)),
    "reshaped": lambda path, others: _rewrite(path, _each(lambda a: a.reshape((*a.shape, 1)))),
    "garbage": _garbage,
    "emptied": lambda path, others: path.write_bytes(b""),
    "retyped": lambda path, others: _rewrite(path, _each(_retyped)),
    "array-dropped": lambda path, others: _rewrite(path, lambda data: {n: data[n] for n in sorted(data)[1:]}),
    "array-added": lambda path, others: _rewrite(path, lambda data: dict(data, extra=np.zeros(2))),
    "swapped": lambda path, others: path.write_bytes(others[0].read_bytes()),
    "no-manifest": lambda path, others: _drop_manifest(path),
    "manifest-garbled": lambda path, others: _garble_manifest(path),
}
ISSUE_WAYS = ("truncated", "randomized", "scaled", "nan", "zeroed", "reshaped")


def _drop_manifest(path: Path) -> None:
    """The entry as the cache wrote it before it had manifests."""
    with np.load(path, allow_pickle=False) as npz:
        data = {name: npz[name] for name in npz.files if name != MANIFEST}
    with open(path, "wb") as fh:
        np.savez(fh, **data)


def _garble_manifest(path: Path) -> None:
    with np.load(path, allow_pickle=False) as npz:
        members = {name: npz[name] for name in npz.files}
    text = members[MANIFEST][()].decode()
    members[MANIFEST] = np.array(text.replace('"sha256": "', '"sha256": "0').encode())  # the checksum altered
    with open(path, "wb") as fh:
        np.savez(fh, **members)


#: What each check's warning says, by corruption (a regular expression).
REASONS = {
    "truncated": "unreadable",
    "randomized": "NaN|checksum",  # the NaN that belongs there is gone, or the numbers differ
    "scaled": "checksum",
    "nan": "NaN",
    "zeroed": "NaN|checksum",
    "reshaped": "shape",
    "garbage": "unreadable",
    "emptied": "unreadable",
    "retyped": "dtype",
    "array-dropped": "missing",
    "array-added": "unexpected",
    "swapped": "another entry",
    "no-manifest": "no manifest",
    "manifest-garbled": "checksum",
}


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("PIEZOTIP_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PIEZOTIP_CACHE", raising=False)
    monkeypatch.delenv("PIEZOTIP_CACHE_MAX_MB", raising=False)
    return tmp_path


def _table(scale: float = 1.0) -> dict[str, np.ndarray]:
    """An entry of every shape the project stores: a scalar, a vector, a table, an integer array,
    and a NaN that belongs there (a mode without a measurable range): no false alarm."""
    return {
        "root": np.array(1.875104068711961 * scale),
        "floor_pa": np.array(np.nan),
        "v": np.linspace(0.0, 1.0, 7) * scale,
        "bands": np.arange(12.0).reshape(4, 3) * scale,
        "modes": np.arange(1, 5),
    }


def _warnings(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "piezotip.sensor.cache" and r.levelno == logging.WARNING]


@pytest.mark.parametrize("way", sorted(CORRUPTIONS))
def test_a_damaged_entry_is_computed_again_with_one_warning_and_replaced(cache_dir, caplog, way):
    disk_cached("other", "k", lambda: _table(3.0))  # another entry, for "swapped"
    disk_cached("t", "k", _table)
    path = cache_dir / f"{entry_key('t', 'k')}.npz"
    CORRUPTIONS[way](path, [cache_dir / f"{entry_key('other', 'k')}.npz"])
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="piezotip.sensor.cache"):
        got = disk_cached("t", "k", _table)
    for name, expected in _table().items():
        np.testing.assert_array_equal(got[name], expected, strict=True)
    (message,) = _warnings(caplog)
    assert "\n" not in message and "cache" in message and str(path) in message
    assert re.search(REASONS[way], message), message
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="piezotip.sensor.cache"):
        again = disk_cached("t", "k", lambda: pytest.fail("the replaced entry is read"))
    assert _warnings(caplog) == []
    for name, expected in _table().items():
        np.testing.assert_array_equal(again[name], expected, strict=True)


def test_an_entry_removed_under_the_reader_is_computed_again_without_a_warning(cache_dir, caplog, monkeypatch):
    disk_cached("t", "k", _table)
    read = cache_module.read_entry

    def pruned_first(path, stem):  # another process prunes the entry between exists() and the read
        path.unlink()
        return read(path, stem)

    monkeypatch.setattr(cache_module, "read_entry", pruned_first)
    with caplog.at_level(logging.WARNING, logger="piezotip.sensor.cache"):
        got = disk_cached("t", "k", lambda: _table(2.0))
    assert _warnings(caplog) == []
    assert float(got["root"]) == float(_table(2.0)["root"])


def test_what_cannot_be_stored_is_refused(cache_dir):
    with pytest.raises(ValueError, match=MANIFEST):
        disk_cached("t", "a", lambda: {MANIFEST: np.ones(1)})
    with pytest.raises(ValueError, match="objects"):
        disk_cached("t", "b", lambda: {"v": np.array([None])})


def test_the_one_line_a_damaged_entry_gives_on_stderr(cache_dir):
    """Without any logging set up (a script, a sweep's worker) the warning is one line on stderr."""
    code = (
        "import numpy as np; from piezotip.sensor.cache import disk_cached\n"
        "print(float(disk_cached('t', 'k', lambda: {'v': np.array(2.0)})['v']))"
    )
    env = {**os.environ, "PIEZOTIP_CACHE_DIR": str(cache_dir)}
    env.pop("PIEZOTIP_CACHE", None)
    subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True)
    (path,) = cache_dir.glob("t-*.npz")
    _rewrite(path, _each(_scaled))
    done = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True)
    assert done.stdout == "2.0\n"
    (line,) = done.stderr.splitlines()
    assert str(path) in line and "checksum" in line


# --- The project's own entries, damaged on disk under a real run ------------------------------

#: Forks a child per line read on stdin (a JSON dict of environment variables to set), the
#: modules imported but no set-up computed, so that each run starts with empty in-memory caches
#: like a new process, without paying the imports each time; prints one JSON line per run: the
#: summary (timings left out), a digest of every recorded column, the lines the child wrote to
#: stderr, or the traceback.
DRIVER = r"""
import hashlib, json, os, sys, tempfile, traceback
import piezotip.api, piezotip.analysis.runner
SCENARIO = sys.argv[1]
for line in sys.stdin:
    read, write = os.pipe()
    err = tempfile.TemporaryFile()
    pid = os.fork()
    if pid == 0:
        os.close(read)
        os.dup2(err.fileno(), 2)
        try:
            os.environ.update(json.loads(line))
            result = piezotip.api.run(SCENARIO)
            summary = {k: v for k, v in result.summary.items() if k not in ("wall_time_s", "realtime_factor", "files")}
            columns = {k: hashlib.sha256(repr((v.dtype.str, v.shape)).encode() + v.tobytes()).hexdigest() for k, v in result.data.items()}
            out = {"summary": summary, "columns": columns}
        except BaseException:
            out = {"error": traceback.format_exc()}
        sys.stderr.flush()
        err.seek(0)
        out["stderr"] = err.read().decode(errors="replace").splitlines()
        with os.fdopen(write, "w") as fh:
            json.dump(out, fh, default=repr)
        os._exit(0)
    os.close(write)
    with os.fdopen(read) as fh:
        text = fh.read()
    os.waitpid(pid, 0)
    err.close()
    print(text.replace("\n", " "), flush=True)
"""


class Runs:
    """The driver process: ``run(env)`` is one run of the scenario in a fresh child."""

    def __init__(self, scenario: str, cache: Path) -> None:
        env = {**os.environ, "PIEZOTIP_CACHE_DIR": str(cache)}
        for name in ("PIEZOTIP_CACHE", "PIEZOTIP_CACHE_MAX_MB"):
            env.pop(name, None)
        self.process = subprocess.Popen(
            [sys.executable, "-c", DRIVER, scenario], stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env, text=True, cwd=REPO
        )

    def run(self, env: dict[str, str] | None = None) -> dict:
        self.process.stdin.write(json.dumps(env or {}) + "\n")
        self.process.stdin.flush()
        out = json.loads(self.process.stdout.readline())
        assert "error" not in out, out["error"]
        return out

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait(timeout=30)


def _stored_namespaces() -> set[str]:
    """Every kind of entry the project stores: the namespaces of its ``disk_cached`` calls."""
    found = set()
    for name in ("piezotip", "piezotip.sensor", "piezotip.cosim", "piezotip.analysis", "piezotip.reports", "piezotip.scenarios"):
        for folder in importlib.import_module(name).__path__:
            for path in Path(folder).rglob("*.py"):
                if path.name != "cache.py":
                    found |= set(re.findall(r"disk_cached\(\s*\"([\w-]+)\"", path.read_text()))
    return found


def _kind(path: Path) -> str:
    return path.name.rsplit("-", 1)[0]


def _cache_lines(out: dict) -> list[str]:
    return [line for line in out["stderr"] if "cache" in line]


@pytest.mark.slow
def test_every_damaged_project_entry_gives_the_uncached_result(tmp_path):
    """The default grasp with every kind of entry damaged each way gives exactly the numbers of
    ``PIEZOTIP_CACHE=off``: the summary and every recorded column; each damaged file is named in
    one warning line and holds a sound entry again after the run."""
    cache = tmp_path / "cache"
    runs = Runs("grasp", cache)
    try:
        reference = runs.run({"PIEZOTIP_CACHE": "off"})
        assert not cache.exists()
        filled = runs.run()
        assert (filled["summary"], filled["columns"]) == (reference["summary"], reference["columns"])
        assert _cache_lines(filled) == []
        entries = sorted(cache.glob("*.npz"))
        originals = {path: path.read_bytes() for path in entries}
        kinds = sorted({_kind(path) for path in entries})
        assert set(kinds) == _stored_namespaces(), "a kind of entry the grasp does not store is not tested"
        warm = runs.run()
        assert (warm["summary"], warm["columns"], _cache_lines(warm)) == (reference["summary"], reference["columns"], [])

        def check(way: str, damaged: list[Path]) -> None:
            for path in entries:
                path.write_bytes(originals[path])
            for path in damaged:
                others = [p for p in entries[entries.index(path) + 1 :] + entries if p != path]
                CORRUPTIONS[way](path, others)
            out = runs.run()
            case = f"{way} {[p.name for p in damaged]}"
            assert out["summary"] == reference["summary"], case
            assert out["columns"] == reference["columns"], case
            lines = _cache_lines(out)
            assert len(lines) == len(damaged), (case, lines)
            assert all(sum(str(p) in line for line in lines) == 1 for p in damaged), (case, lines)  # one line each
            for path in damaged:  # replaced by the computed value: the same bytes as the sound entry
                assert path.read_bytes() == originals[path], case
                read_entry(path, path.name.removesuffix(".npz"))

        # Every way on every entry at once, and each kind alone (one way each, in turn): each kind
        # under each way alone took three times as many runs, and every damaged file is still
        # named in its own line and recomputed on its own here.
        for way in ISSUE_WAYS:
            check(way, entries)
        for kind, way in zip(kinds, itertools.cycle(ISSUE_WAYS)):
            check(way, [p for p in entries if _kind(p) == kind])
        for way in sorted(set(CORRUPTIONS) - set(ISSUE_WAYS)):
            check(way, entries)
    finally:
        runs.close()

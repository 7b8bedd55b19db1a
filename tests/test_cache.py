"""The on-disk cache of derived tables: keyed by every parameter and by the code, safe to share."""

import dataclasses
import importlib.machinery
import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from piezotip.cosim.control import selector
from piezotip.sensor import Fingertip, GelModel, GelParams, NoiseParams, SensorElement, compiled
from piezotip.sensor import cache as cache_module
from piezotip.sensor.cache import disk_cached, entry_key
from piezotip.sensor.element import ElementParams
from piezotip.sensor.stress import Mounting


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("PIEZOTIP_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PIEZOTIP_CACHE", raising=False)
    return tmp_path


def _changed(value):
    """A different value of the same kind (every field of the parameter dataclasses)."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, (int, float)):
        return value * 0.999 + 1e-9 if value > 0 else value - 1e-3
    if isinstance(value, tuple):
        return tuple(_changed(v) for v in value)
    if isinstance(value, str):
        return {"backed": "free-span", "free-span": "backed"}.get(value, value + "x")
    raise TypeError(value)


def _variants() -> list[tuple[str, Fingertip]]:
    """The default fingertip with one parameter changed, for every parameter it depends on."""
    out = []
    for f in dataclasses.fields(ElementParams):
        params = dataclasses.replace(ElementParams(), **{f.name: _changed(getattr(ElementParams(), f.name))})
        out.append((f"element.{f.name}", Fingertip(element=SensorElement(params))))
    for f in dataclasses.fields(GelParams):
        params = dataclasses.replace(GelParams(), **{f.name: _changed(getattr(GelParams(), f.name))})
        out.append((f"gel.{f.name}", Fingertip(gel=GelModel(params=params))))
    out.append(("gel.layer", Fingertip(gel=GelModel(layer="dynamic"))))
    out.append(("gel.frequency_dependent", Fingertip(gel=GelModel(frequency_dependent=False))))
    out.append(("boundary", Fingertip(element=SensorElement(boundary="clamped-clamped"))))
    out.append(("coverage", Fingertip(coverage=(0.0065, 0.0075))))
    out.append(("noise", Fingertip(noise=NoiseParams(relative_floor=2e-3))))
    out.append(("modes", Fingertip(modes=(1, 2))))
    out.append(("rated", Fingertip(rated_pressure_pa=5e5)))
    out.append(("mounting", Fingertip(mounting=Mounting(kind="free-span"))))
    return out


def test_the_key_changes_with_every_parameter_the_tables_depend_on():
    base = entry_key("allowed-ranges", (Fingertip().config_key(), (1, 2, 3, 4)))
    keys = {}
    for name, tip in _variants():
        key = entry_key("allowed-ranges", (tip.config_key(), (1, 2, 3, 4)))
        assert key != base, f"{name} does not change the cache key"
        keys[name] = key
    assert len(set(keys.values())) == len(keys)  # and no two changes share one
    assert entry_key("allowed-ranges", (Fingertip().config_key(), (1, 2))) != base
    assert entry_key("resolved-floor", (Fingertip().config_key(), (1, 2, 3, 4))) != base  # namespaces apart
    assert entry_key("allowed-ranges", (Fingertip().config_key(), (1, 2, 3, 4))) == base  # and it is stable


def _forget_the_code():
    """What a new process sees: the fingerprints are computed once per process."""
    cache_module._FINGERPRINTS.clear()
    cache_module._DIGESTS.clear()


@pytest.fixture
def forget_the_code():
    _forget_the_code()
    yield
    _forget_the_code()


def test_the_key_changes_with_the_code(tmp_path, forget_the_code):
    module = tmp_path / "tables.py"
    module.write_text("A = 1\n")
    before = entry_key("x", 1, [module])
    module.write_text("A = 2\n")
    _forget_the_code()
    assert entry_key("x", 1, [module]) != before


EXTENSION = importlib.machinery.EXTENSION_SUFFIXES[0]


@pytest.mark.parametrize("changed", ["_tables.pyx", "_helpers.pxd", f"_tables{EXTENSION}"])
def test_the_key_changes_with_a_compiled_source_or_the_built_module(tmp_path, forget_the_code, changed):
    """The Cython sources beside a module the key names, and the extension module built from
    them (what runs: an edited .pyx not rebuilt is not), are part of the key."""
    module = tmp_path / "tables.py"
    module.write_text("A = 1\n")
    for name in ("_tables.pyx", "_helpers.pxd", f"_tables{EXTENSION}"):
        (tmp_path / name).write_bytes(b"one")
    before = entry_key("x", 1, [module])
    (tmp_path / changed).write_bytes(b"two")
    _forget_the_code()
    assert entry_key("x", 1, [module]) != before


def test_an_extension_another_interpreter_imports_is_not_part_of_the_key(tmp_path, forget_the_code):
    module = tmp_path / "tables.py"
    module.write_text("A = 1\n")
    before = entry_key("x", 1, [module])
    (tmp_path / "_tables.cpython-39-x86_64-linux-gnu.so").write_bytes(b"not ours")  # another Python's build
    (tmp_path / "notes.txt").write_text("")
    _forget_the_code()
    assert entry_key("x", 1, [module]) == before


def test_the_key_covers_the_project_s_compiled_twins_as_they_are_imported(forget_the_code, monkeypatch):
    """Every Cython source of the sensor and of the controller's modules, and the very files the
    twins are imported from (the references alone with PIEZOTIP_PURE_PYTHON)."""
    sensor = Path(cache_module.__file__).parent
    control = Path(selector.__file__).parent
    files = set(cache_module.code_files([selector.__file__]))
    declarations = set(sensor.glob("*.pxd")) | set(control.glob("*.pxd"))
    sources = declarations | {p.with_suffix(".py") for p in declarations}  # and the kernels' sources
    assert len(sources) >= 6 and sources <= files
    for name in ("piezotip.sensor._inference", "piezotip.sensor._sampler", "piezotip.sensor._estimator"):
        spec = importlib.util.find_spec(name)
        if spec is not None:  # built
            assert Path(spec.origin) in files
            assert Path(spec.origin) in set(cache_module.code_files())
    spec = importlib.util.find_spec("piezotip.cosim.control._control")
    if spec is not None:
        assert Path(spec.origin) in files
    compiled_key = entry_key("x", 1, [selector.__file__])
    monkeypatch.setattr(compiled, "PURE_PYTHON", True)
    _forget_the_code()
    assert not any(p.name.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES)) for p in cache_module.code_files([selector.__file__]))
    assert entry_key("x", 1, [selector.__file__]) != compiled_key


def test_a_stored_entry_is_read_back_exactly_and_computed_once(cache_dir):
    calls = []

    def compute():
        calls.append(1)
        return {"value": np.array([1.0 / 3.0, np.pi]), "n": np.arange(3)}

    first = disk_cached("t", ("k", 1.5), compute)
    second = disk_cached("t", ("k", 1.5), compute)
    assert len(calls) == 1
    for name in first:
        np.testing.assert_array_equal(first[name], second[name])
    disk_cached("t", ("k", 1.5000000000000002), compute)  # the next float: another entry
    assert len(calls) == 2


def test_a_torn_entry_is_computed_again(cache_dir):
    disk_cached("t", "k", lambda: {"v": np.ones(3)})
    (path,) = cache_dir.glob("t-*.npz")
    path.write_bytes(path.read_bytes()[:20])
    assert disk_cached("t", "k", lambda: {"v": np.zeros(3)})["v"].tolist() == [0.0, 0.0, 0.0]
    assert disk_cached("t", "k", lambda: {"v": np.ones(3)})["v"].tolist() == [0.0, 0.0, 0.0]  # and replaced


def test_off_switch_and_an_unwritable_folder(tmp_path, monkeypatch):
    monkeypatch.setenv("PIEZOTIP_CACHE", "off")
    calls = []
    for _ in range(2):
        disk_cached("t", "k", lambda: calls.append(1) or {"v": np.ones(1)})
    assert len(calls) == 2
    monkeypatch.delenv("PIEZOTIP_CACHE")
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("PIEZOTIP_CACHE_DIR", str(blocker / "sub"))  # cannot be created
    assert disk_cached("t", "k", lambda: {"v": np.ones(1)})["v"].tolist() == [1.0]


def test_cached_ranges_equal_computed_ones_in_a_fresh_process(cache_dir, monkeypatch):
    """A second process reads what the first wrote, and both equal a computation without cache."""
    code = (
        "from piezotip.cosim.control.selector import allowed_ranges; from piezotip.sensor import Fingertip;"
        "r = allowed_ranges(Fingertip(coverage=(0.0062, 0.0075)), (1, 2, 3)); print(repr(r[1:]))"
    )
    env = {**__import__("os").environ, "PIEZOTIP_CACHE_DIR": str(cache_dir)}
    first = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    assert list(cache_dir.glob("allowed-ranges-*.npz"))
    second = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    monkeypatch.setenv("PIEZOTIP_CACHE", "off")
    selector._RANGES.clear()
    fresh = selector.allowed_ranges(Fingertip(coverage=(0.0062, 0.0075)), (1, 2, 3))
    assert first == second == repr(fresh[1:]) + "\n"


def _entries(folder):
    return sorted(p.name for p in folder.glob("t-*.npz"))


def test_the_folder_stays_under_its_bound_dropping_the_least_recently_used(cache_dir, monkeypatch):
    import os

    payload = {"v": np.zeros(1000)}  # about 8 kB an entry
    size = None
    for k in range(6):
        disk_cached("t", k, lambda: payload)
        path = cache_dir / f"{entry_key('t', k)}.npz"
        size = path.stat().st_size
        os.utime(path, ns=(k * 10**9, k * 10**9))  # written in order, a second apart
    assert len(_entries(cache_dir)) == 6  # no bound reached yet (200 MB)
    disk_cached("t", 0, lambda: pytest.fail("entry 0 is stored"))  # a read: entry 0 is now the newest
    # A bound of four entries: the next write prunes the least recently used down to 80 % of it.
    monkeypatch.setenv("PIEZOTIP_CACHE_MAX_MB", str(4.5 * size / 1e6))
    disk_cached("t", 6, lambda: payload)
    kept = _entries(cache_dir)
    total = sum((cache_dir / name).stat().st_size for name in kept)
    assert total <= 0.8 * 4.5 * size
    expected = {entry_key("t", k) + ".npz" for k in (0, 5, 6)}  # the read one and the newest
    assert set(kept) == expected
    disk_cached("t", 1, lambda: payload)  # a pruned entry is simply computed again
    assert entry_key("t", 1) + ".npz" in _entries(cache_dir)


def test_prune_counts_only_entries_and_tolerates_a_concurrent_removal(tmp_path, monkeypatch):
    """Only the cache's entries count and go: not a user's ``.npz`` (the oldest file there), a
    temporary, a text file (issue 44: a user's file in the folder went)."""
    import os

    entries = [f"{entry_key('t', k)}.npz" for k in range(3)]
    for name in entries:  # an entry: its name and its manifest member (what prune opens)
        np.savez(tmp_path / name, **{cache_module.MANIFEST: np.array(b"{}"), "v": np.zeros(30)})
    for name, nbytes in (("a.npz", 300), (".tmp-x.npz", 10_000), ("notes.txt", 10_000)):
        (tmp_path / name).write_bytes(b"x" * nbytes)
    for k, name in enumerate(["a.npz", *entries, ".tmp-x.npz", "notes.txt"]):
        os.utime(tmp_path / name, ns=(k * 10**9, k * 10**9))
    size = (tmp_path / entries[0]).stat().st_size
    assert cache_module.prune(tmp_path, 3 * size) == []  # three entries: within the bound, whatever else is there
    unlink = os.unlink

    def raced(path):  # another process removes the entry first
        unlink(path)
        raise FileNotFoundError(path)

    monkeypatch.setattr(cache_module.os, "unlink", raced)
    removed = cache_module.prune(tmp_path, int(2.3 * size))  # down to 80 % of 2.3 entries: the two oldest go
    assert [p.name for p in removed] == entries[:2]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([".tmp-x.npz", "a.npz", entries[2], "notes.txt"])


@pytest.mark.parametrize("text", ["-1", "lots", "nan", "inf"])
def test_a_bad_bound_is_an_error_naming_it(cache_dir, monkeypatch, text):
    monkeypatch.setenv("PIEZOTIP_CACHE_MAX_MB", text)
    with pytest.raises(ValueError, match=f"PIEZOTIP_CACHE_MAX_MB.*{text!r}"):
        disk_cached("t", "k", lambda: {"v": np.ones(1)})

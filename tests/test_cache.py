"""The on-disk cache of derived tables: keyed by every parameter and by the code, safe to share."""

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from piezotip.cosim.control import selector
from piezotip.sensor import Fingertip, GelModel, GelParams, NoiseParams, SensorElement
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


def test_the_key_changes_with_the_code(tmp_path):
    module = tmp_path / "tables.py"
    module.write_text("A = 1\n")
    before = entry_key("x", 1, [module])
    module.write_text("A = 2\n")
    cache_module._FINGERPRINTS.clear()
    assert entry_key("x", 1, [module]) != before


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

"""The compiled twins (sensor/_inference.pyx, sensor/_lookup.pyx) are their Python references, bit for bit.

:class:`piezotip.sensor.inference.PySteadyInference` documents the readout's inference and is
the reference; the readout runs its compiled twin where the package was built with it.  Both
are stepped through the same readings (held loads, steps that restart the window, ramps that
shorten it, a ring-up from rest after a switch, a run past the re-basing age, copies made
mid-run) and must return the same (a_ss, gain, trusted) on every reading: the same floats, not
close ones.  The same for the pads' gel-law lookup (:class:`PyUniformPairTable`).
"""

from __future__ import annotations

import copy
import math
import pickle
import random

import numpy as np
import pytest

from piezotip.cosim.pads import PadGeometry, _GelTable
from piezotip.sensor import GelModel, inference, lookup
from piezotip.sensor.compiled import PURE_PYTHON

pytestmark = pytest.mark.skipif(PURE_PYTHON, reason="PIEZOTIP_PURE_PYTHON is set: the references run")

TAU0_S = 0.66  # Table I's unloaded envelope time constant, s
SIGMA = 1e-3  # one reading's noise, V_1 units


def test_the_compiled_twins_are_built():
    """An install builds them (``pip install -e .``; setup.py): without them every run is slower
    and this fails, unless PIEZOTIP_PURE_PYTHON asks for the references."""
    assert inference.COMPILED, "sensor/_inference.pyx is not built: reinstall (pip install -e .) with a C compiler"
    assert inference.SteadyInference is not inference.PySteadyInference
    assert lookup.UNIFORM_COMPILED, "sensor/_lookup.pyx is not built: reinstall (pip install -e .) with a C compiler"
    assert lookup.UniformPairTable is not lookup.PyUniformPairTable


def readings(n: int, dt_s: float, ring_up: bool, seed: int):
    """(t, a) of a noisy envelope relaxing toward a load that steps, holds and ramps."""
    rng = random.Random(seed)
    targets = (1 + 0j, 0.8 - 0.1j, 0.5 - 0.3j, 0.95 - 0.02j)
    a = 0j if ring_up else 1 + 0j
    decay = math.exp(-dt_s / TAU0_S)
    for k in range(n):
        segment = (k // 700) % len(targets)
        target = targets[segment] + (k % 700) * 1e-5 * (segment == 3)  # the last one ramps
        a = target + (a - target) * decay
        yield (k + 1) * dt_s, a + complex(rng.gauss(0.0, SIGMA), rng.gauss(0.0, SIGMA))


def outputs(cls, n: int, dt_s: float, ring_up: bool, seed: int, copy_at: int | None = None) -> list[tuple]:
    inf = cls(TAU0_S, SIGMA)
    if ring_up:
        inf.restart(0.0, 0j)
    else:
        inf.seed(1 + 0j, 0.0, dt_s)
    out = []
    for k, (t, a) in enumerate(readings(n, dt_s, ring_up, seed)):
        out.append(inf.step(t, a))
        if k == copy_at:
            inf = copy.deepcopy(inf)
    return out


def same(x: tuple, y: tuple) -> bool:
    """Equal values (NaN envelopes equal as NaN)."""
    (a1, g1, t1), (a2, g2, t2) = x, y
    envelope = a1 == a2 or (math.isnan(a1.real) and math.isnan(a2.real))
    return envelope and (g1 == g2) and (t1 is t2)


@pytest.mark.parametrize("dt_s", [0.005, 0.001])
@pytest.mark.parametrize("ring_up", [False, True])
def test_the_compiled_inference_returns_the_references_numbers(dt_s, ring_up):
    n = 7000  # 35 s at 5 ms: past the re-basing age (30 s), several restarts and ramps
    reference = outputs(inference.PySteadyInference, n, dt_s, ring_up, seed=3)
    compiled = outputs(inference.SteadyInference, n, dt_s, ring_up, seed=3, copy_at=n // 2)
    differing = [k for k, (x, y) in enumerate(zip(reference, compiled, strict=True)) if not same(x, y)]
    first = differing[0] if differing else None
    assert not differing, f"{len(differing)} readings differ, first at {first}: {reference[first]} != {compiled[first]}"
    # The sequence exercised what it was meant to: restarts (untrusted) and trusted fits.
    trusted = sum(1 for _, _, ok in reference if ok)
    assert 0 < n - trusted < n // 10 < trusted


def test_a_pickled_compiled_inference_goes_on_as_the_original():
    inf = inference.SteadyInference(TAU0_S, SIGMA)
    inf.seed(1 + 0j, 0.0, 0.005)
    stream = list(readings(900, 0.005, False, seed=5))
    for t, a in stream[:800]:
        inf.step(t, a)
    twin = pickle.loads(pickle.dumps(inf))
    assert [twin.step(t, a) for t, a in stream[800:]] == [inf.step(t, a) for t, a in stream[800:]]


def test_the_equivalence_test_can_fail(monkeypatch):
    """A changed constant in the reference (read when the compiled module was imported) is seen."""
    monkeypatch.setattr(inference, "CHANGE_STAT", inference.CHANGE_STAT * 0.5)
    reference = outputs(inference.PySteadyInference, 2000, 0.005, False, seed=3)
    compiled = outputs(inference.SteadyInference, 2000, 0.005, False, seed=3)
    assert any(not same(x, y) for x, y in zip(reference, compiled, strict=True))


# ---------------------------------------------------------------------------------------
# The pads' gel-law lookup.
# ---------------------------------------------------------------------------------------


def test_the_compiled_lookup_returns_the_references_numbers():
    table = _GelTable.build(GelModel(), PadGeometry())
    args = (table.grid_m, table.pressure_pa, table.tangent_pa_m)
    reference, compiled = lookup.PyUniformPairTable(*args), lookup.UniformPairTable(*args)
    g = table.grid_m
    rng = np.random.default_rng(4)
    qs = np.concatenate([rng.uniform(g[0] - 1e-4, g[-1] + 1e-4, 20000), g, np.nextafter(g, 1), np.nextafter(g, -1), [-1.0, 1.0]])
    assert [compiled.at(q) for q in qs.tolist()] == [reference.at(q) for q in qs.tolist()]
    assert all(math.isnan(v) for v in compiled.at(math.nan))
    twin = pickle.loads(pickle.dumps(compiled))
    assert [twin.at(q) for q in qs[:100].tolist()] == [reference.at(q) for q in qs[:100].tolist()]


def test_the_compiled_lookup_checks_its_table_as_the_reference_does():
    with pytest.raises(ValueError, match="strictly increasing"):
        lookup.UniformPairTable([0.0, 0.0, 1.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0])

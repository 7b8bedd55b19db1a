"""The compiled twins (sensor/_*.pyx, cosim/_pad_kernels.pyx) are their Python references, bit for bit.

:class:`piezotip.sensor.inference.PySteadyInference` documents the readout's inference and is
the reference; the readout runs its compiled twin where the package was built with it.  Both
are stepped through the same readings (held loads, steps that restart the window, ramps that
shorten it, a ring-up from rest after a switch, a run past the re-basing age, copies made
mid-run) and must return the same (a_ss, gain, trusted) on every reading: the same floats, not
close ones.  The same for the pads' gel-law lookup (:class:`PyUniformPairTable`), a
channel's reading (:class:`PyModeSampler`), the inverse of an inferred reading
(:class:`PyInverseCore`), the pads' kernels (:class:`PyGelForces`, :class:`PyPadPressures`)
a control step's row (:class:`PyRowBuilder`), and the controller's mode selector, touch detector
and per-step records (:class:`PyModeSelector`, :class:`PyTouchDetector`, ``py_make_*``).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import pickle
import random

import numpy as np
import pytest

from piezotip.cosim import pad_kernels, rows
from piezotip.cosim.control import interface, selector
from piezotip.cosim.pads import PadGeometry, _GelTable
from piezotip.sensor import Fingertip, GelModel, SensorElement, estimator, inference, lookup, resonator, sampler
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.compiled import PURE_PYTHON
from piezotip.sensor.estimator import _TABLE_P, foundation_table

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
    assert sampler.SAMPLER_COMPILED, "sensor/_sampler.pyx is not built: reinstall (pip install -e .) with a C compiler"
    assert sampler.ModeSampler is not sampler.PyModeSampler
    assert estimator.INVERSE_COMPILED, "sensor/_estimator.pyx is not built: reinstall (pip install -e .) with a C compiler"
    assert estimator.InverseCore is not estimator.PyInverseCore
    assert pad_kernels.PAD_KERNELS_COMPILED, "cosim/_pad_kernels.pyx is not built: reinstall (pip install -e .) with a C compiler"
    assert pad_kernels.GelForces is not pad_kernels.PyGelForces and pad_kernels.PadPressures is not pad_kernels.PyPadPressures
    assert rows.ROWS_COMPILED, "cosim/_rows.pyx is not built: reinstall (pip install -e .) with a C compiler"
    assert rows.RowBuilder is not rows.PyRowBuilder
    assert selector.SELECTOR_COMPILED, "cosim/control/_control.pyx is not built: reinstall (pip install -e .) with a C compiler"
    assert selector.ModeSelector is not selector.PyModeSelector and selector.TouchDetector is not selector.PyTouchDetector
    assert interface.INTERFACE_COMPILED and interface.make_command is not interface.py_make_command


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
    # The sequence exercised what it was meant to: restarts and ramps (untrusted: since
    # RAMP_SUSPECT_CHI2 a reading under a ramp is, a fifth to two fifths of these) and trusted
    # fits, most of them.
    trusted = sum(1 for _, _, ok in reference if ok)
    assert 0 < n - trusted < n // 2 < trusted


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


# ---------------------------------------------------------------------------------------
# A channel's reading.
# ---------------------------------------------------------------------------------------


def _samplers(mode: int, cells: int, envelope: bool):
    """The reference and the twin for one mode of the default fingertip, ``cells`` cells."""
    tip = Fingertip(element=SensorElement().with_quality_factor(70), coverage=(6.5e-3, 7.5e-3))
    edges = np.linspace(6.5e-3, 7.5e-3, cells + 1)
    ch = SensorChannel(tip, edges_m=edges, dynamics="envelope", noise=False)
    omega, sigma, _, weights = ch._fast[mode]
    args = (mode, omega, sigma, ch._c_f, ch._rho_a_f, foundation_table(tip, mode), weights, envelope)
    return sampler.PyModeSampler(*args), sampler.ModeSampler(*args)


def _pressures(n: int, seed: int) -> list[float]:
    """Pressures, Pa: zero, below the table, its points exactly and beside them, log-uniform
    over and past its range, a step up and back."""
    rng = np.random.default_rng(seed)
    grid = _TABLE_P[:: max(1, len(_TABLE_P) // 50)]
    special = [0.0, 1e-9, 5e-4, *grid, *np.nextafter(grid, 0), *np.nextafter(grid, np.inf), 1e8, 1e12]
    rest = 10 ** rng.uniform(-4, 7.5, max(n - len(special), 0))
    return [float(p) for p in [*special, *rest, 0.0, 5e5, 5e5, 0.0]]


def _items(record) -> tuple:
    """A record's (field, value) pairs in the fields' order, read from the instance (every slot filled)."""
    return tuple((f.name, getattr(record, f.name)) for f in dataclasses.fields(record))


def _exact(reading, envelope) -> tuple:
    """Every field and the envelope as exact text (a float's repr round-trips; -0.0 and NaN kept)."""
    return (repr(_items(reading)), repr(envelope), type(reading))


@pytest.mark.parametrize("envelope", [True, False])
@pytest.mark.parametrize(("mode", "cells"), [(1, 1), (3, 1), (2, 3)])
def test_the_compiled_sampler_returns_the_references_readings(mode, cells, envelope):
    reference, compiled = _samplers(mode, cells, envelope)
    rng = np.random.default_rng(7)
    pressures = _pressures(3000, seed=mode)
    a_ref = a_cmp = 0j  # a ring-up from rest
    t = 0.0
    for k, p in enumerate(pressures):
        profile = [p * (1.0 + 0.1 * i) for i in range(cells)]
        dt = (0.001, 0.005, 0.0002)[k % 3]
        t = math.inf if k == 1500 else t + dt  # a settled history, then on
        noise = None if k % 4 == 0 else complex(*rng.standard_normal(2))
        r_ref, a_ref = reference.sample(profile, a_ref, dt, t, noise)
        r_cmp, a_cmp = compiled.sample(profile, a_cmp, dt, t, noise)
        assert _exact(r_cmp, a_cmp) == _exact(r_ref, a_ref), f"sample {k} at {profile} Pa"
        if k == 2000:
            compiled = pickle.loads(pickle.dumps(compiled))  # a copy goes on as the original
    assert compiled.lookups == reference.lookups == len(pressures) * cells


def test_the_sampler_equivalence_test_can_fail():
    """A twin given another damping returns other readings: the comparison sees the last bit."""
    reference, _ = _samplers(1, 1, True)
    tip_args = (1, reference._omega, reference._sigma, reference._c * (1 + 2**-52), reference._rho_a)
    tip = Fingertip(element=SensorElement().with_quality_factor(70), coverage=(6.5e-3, 7.5e-3))
    compiled = sampler.ModeSampler(*tip_args, foundation_table(tip, 1), reference._weights, True)
    r_ref, a_ref = reference.sample([500.0], 1 + 0j, 0.005, 1.0, None)
    r_cmp, a_cmp = compiled.sample([500.0], 1 + 0j, 0.005, 1.0, None)
    assert _exact(r_cmp, a_cmp) != _exact(r_ref, a_ref)


def test_a_channel_with_the_compiled_sampler_reads_as_with_the_reference(monkeypatch):
    """A whole channel (its noise, clocks, switches) through the reference and through the twin."""
    tip = Fingertip(element=SensorElement().with_quality_factor(70), coverage=(6.5e-3, 7.5e-3))
    runs = []
    for cls in (sampler.PyModeSampler, sampler.ModeSampler):
        monkeypatch.setattr("piezotip.sensor.channel.ModeSampler", cls)
        ch = SensorChannel(tip, dynamics="envelope", rng=np.random.default_rng(3))
        assert all(type(s) is cls for s in ch._samplers.values())
        out = []
        for k, p in enumerate(_pressures(1200, seed=2)):
            if k in (300, 700):
                ch.select_mode(3 if k == 300 else 1)
            r = ch.update([p], 0.005)
            out.append((*_exact(r, ch.envelope), repr(ch.estimate(r))))
        runs.append(out)
    assert runs[0] == runs[1]


# ---------------------------------------------------------------------------------------
# The inverse of an inferred reading.
# ---------------------------------------------------------------------------------------


def _cores(mode: int):
    """The reference and the twin of the default fingertip's inverse in ``mode``, and it."""
    tip = Fingertip(element=SensorElement().with_quality_factor(70), coverage=(6.5e-3, 7.5e-3))
    inverse = SensorChannel(tip, noise=False).inverse(mode)
    args = (
        inverse._neg_v_list,
        inverse._log_p_list,
        inverse._dv_dlogp_list,
        inverse._v_first,
        inverse._v_last,
        inverse._slope0,
        inverse._sigma_f,
        inverse._p_min_f,
        inverse._p_max_f,
    )
    return estimator.PyInverseCore(*args), estimator.InverseCore(*args), inverse


@pytest.mark.parametrize("mode", [1, 2, 3, 4])
def test_the_compiled_inverse_returns_the_references_estimates(mode):
    reference, compiled, inverse = _cores(mode)
    rng = np.random.default_rng(mode)
    curve = (-np.asarray(reference._neg_v)).tolist()
    v1s = [
        *curve,
        *np.nextafter(curve, 2.0).tolist(),
        *np.nextafter(curve, -1.0).tolist(),
        *rng.uniform(inverse._v_last - 0.02, 1.02, 5000).tolist(),
        1.0,
        1.0 - 3.0 * reference._sigma,
        0.0,
        -0.5,
        math.nan,
        math.inf,
    ]
    gains = [0.5, 1.0, 1.7, 25.0, 1e3, math.nan]
    for k, v1 in enumerate(v1s):
        gain = gains[k % len(gains)]
        ref, cmp = reference.inferred(v1, gain), compiled.inferred(v1, gain)
        assert repr(_items(cmp)) == repr(_items(ref)), f"V_1 = {v1!r}, gain {gain}"
        assert type(cmp) is type(ref)
    statuses = {reference.inferred(v1, 1.0).status for v1 in v1s}
    assert statuses == {"ok", "below_detection", "saturated"}  # every branch was taken
    twin = pickle.loads(pickle.dumps(compiled))
    assert [repr(twin.inferred(v, 1.3)) for v in v1s[:200]] == [repr(reference.inferred(v, 1.3)) for v in v1s[:200]]


def test_the_inverse_equivalence_test_can_fail():
    reference, _, _ = _cores(2)
    args = (reference._neg_v, reference._log_p, reference._dv_dlogp, reference._v_first, reference._v_last)
    compiled = estimator.InverseCore(*args, reference._slope0, reference._sigma * (1 + 2**-52), reference._p_min, reference._p_max)
    v1 = (reference._v_first + reference._v_last) / 2
    assert repr(compiled.inferred(v1, 1.0)) != repr(reference.inferred(v1, 1.0))


def test_the_mode_inverse_runs_the_compiled_core():
    _, _, inverse = _cores(1)
    assert estimator.INVERSE_COMPILED and type(inverse._core) is estimator.InverseCore


# ---------------------------------------------------------------------------------------
# The pads' kernels: the gel law on the strip joints, the pressure read.
# ---------------------------------------------------------------------------------------


def _pad_arrays(rng, table, n_q: int = 40) -> np.ndarray:
    """A qpos-like array: indentations inside, at and past the gel law's grid, and NaN."""
    g = table.grid_m
    q = rng.uniform(g[0] - 1e-4, g[-1] + 1e-4, n_q)
    q[:6] = [g[0], g[-1], g[3], np.nextafter(g[5], 1), -1.0, math.nan]
    return q


def test_the_compiled_gel_forces_write_what_the_reference_writes():
    table = _GelTable.build(GelModel(), PadGeometry())
    columns = (table.grid_m, table.pressure_pa, table.tangent_pa_m)
    rng = np.random.default_rng(11)
    n = 12
    qadr, dof, jnt = rng.permutation(40)[:n].tolist(), rng.permutation(30)[:n].tolist(), rng.permutation(20)[:n].tolist()
    area, qspring = rng.uniform(1e-6, 1e-4, n).tolist(), rng.uniform(-1e-4, 1e-4, n).tolist()
    twins = {cls: cls(columns, qadr, dof, jnt, area, qspring) for cls in (pad_kernels.PyGelForces, pad_kernels.GelForces)}
    for k in range(200):
        qpos = _pad_arrays(rng, table)
        written = {}
        for cls, kernel in twins.items():
            qfrc, stiffness = np.full(30, 7.0), np.full(20, 7.0)
            kernel.bind(qpos, qfrc, stiffness)
            kernel.apply()
            written[cls] = (qfrc.tobytes(), stiffness.tobytes())
        assert written[pad_kernels.GelForces] == written[pad_kernels.PyGelForces], f"state {k}"
        if k == 100:
            twins = {cls: pickle.loads(pickle.dumps(kernel)) for cls, kernel in twins.items()}  # copies come unbound
            with pytest.raises(RuntimeError, match="bind"):
                twins[pad_kernels.GelForces].apply()


def test_the_compiled_pressure_read_returns_the_references_pressures():
    table = _GelTable.build(GelModel(), PadGeometry())
    columns = (table.grid_m, table.pressure_pa, table.tangent_pa_m)
    rng = np.random.default_rng(12)
    per_pad = 5
    qadr = rng.permutation(40)[: 2 * per_pad].tolist()
    element = [3, 1, 2]
    weights = [[(0, 0.25), (1, 0.5), (4, 0.25)], [(2, 1.0)], [(3, 0.3), (4, -0.0), (0, 0.7)]]
    kernels = {cls: cls(columns, qadr, per_pad, element, weights) for cls in (pad_kernels.PyPadPressures, pad_kernels.PadPressures)}
    for k in range(300):
        qpos = _pad_arrays(rng, table)
        out = {}
        for cls, kernel in kernels.items():
            kernel.bind(qpos)
            out[cls] = repr(kernel.read())
        assert out[pad_kernels.PadPressures] == out[pad_kernels.PyPadPressures], f"state {k}"


def test_the_pad_kernels_check_their_indices_as_the_references_do():
    table = _GelTable.build(GelModel(), PadGeometry())
    columns = (table.grid_m, table.pressure_pa, table.tangent_pa_m)
    for cls in (pad_kernels.PyPadPressures, pad_kernels.PadPressures):
        with pytest.raises(ValueError, match="do not make pads"):
            cls(columns, [0, 1, 2], 2, [0], [[(0, 1.0)]])
        with pytest.raises(ValueError, match="weight indices"):
            cls(columns, [0, 1], 2, [0], [[(2, 1.0)]])
        with pytest.raises(ValueError, match="at least one"):
            cls(columns, [0, 1], 2, [0], [[]])
        with pytest.raises(ValueError, match="qpos indices"):
            cls(columns, [0, 9], 2, [0], [[(1, 1.0)]]).bind(np.zeros(5))
    for cls in (pad_kernels.PyGelForces, pad_kernels.GelForces):
        with pytest.raises(ValueError, match="dof indices"):
            cls(columns, [0], [7], [0], [1e-5], [0.0]).bind(np.zeros(3), np.zeros(3), np.zeros(3))


def test_the_pad_kernels_equivalence_test_can_fail():
    table = _GelTable.build(GelModel(), PadGeometry())
    columns = (table.grid_m, table.pressure_pa, table.tangent_pa_m)
    other = (table.grid_m, table.pressure_pa * (1 + 2**-52), table.tangent_pa_m)
    qpos = np.full(4, 0.5 * (table.grid_m[0] + table.grid_m[-1]))
    a, b = pad_kernels.PyPadPressures(columns, [0, 1], 2, [0], [[(1, 1.0)]]), pad_kernels.PadPressures(other, [0, 1], 2, [0], [[(1, 1.0)]])
    a.bind(qpos)
    b.bind(qpos)
    assert repr(a.read()) != repr(b.read())


def test_the_simulation_runs_the_compiled_pad_kernels():
    from piezotip import scenarios
    from piezotip.cosim.loop import CoSimulation

    sim = CoSimulation(scenarios.get("grasp"))
    assert pad_kernels.PAD_KERNELS_COMPILED
    assert type(sim.bridge._gel_forces) is pad_kernels.GelForces and type(sim._pressure_reader) is pad_kernels.PadPressures


# ---------------------------------------------------------------------------------------
# A control step's recorded row.
# ---------------------------------------------------------------------------------------


class _BothRows:
    """Makes each row with the reference and the twin, bound to the same arrays, and keeps both."""

    def __init__(self, sim):
        args = sim._row_builder.__reduce__()[1]
        self.builders = [cls(*args) for cls in (rows.PyRowBuilder, rows.RowBuilder)]
        for b in self.builders:
            b.bind(sim._object_xpos, sim._object_qvel, sim._sensordata)
        self.pairs = []

    def row(self, *args):
        made = [b.row(*args) for b in self.builders]
        self.pairs.append((repr(made[0]), repr(made[1]), [type(v) for v in made[0]] == [type(v) for v in made[1]]))
        self.length = len(made[0])
        return made[0]


@pytest.mark.parametrize(
    "overrides",
    [
        [],
        ["object.crush_force_n=0.5"],  # the fingers' peak forces in the row
        ["sensor.coverage_mm=(2.0, 4.5)", "physics.pad_segments=3"],  # profiles and cells of several values
    ],
)
def test_the_compiled_row_is_the_references_row(overrides):
    from piezotip import scenarios
    from piezotip.cosim.loop import CoSimulation

    sim = CoSimulation(scenarios.get("grasp", overrides))
    assert type(sim._row_builder) is rows.RowBuilder
    both = sim._row_builder = _BothRows(sim)
    for _ in range(900):  # through touch, squeeze and the lift
        sim.advance()
    differing = [k for k, (a, b, types) in enumerate(both.pairs) if a != b or not types]
    assert not differing, f"{len(differing)} rows differ, first at step {differing[0]}"
    assert len(both.pairs) == 900 and both.length == len(sim.columns)


def test_the_row_equivalence_test_can_fail():
    from piezotip import scenarios
    from piezotip.cosim.loop import CoSimulation

    sim = CoSimulation(scenarios.get("grasp"))
    both = _BothRows(sim)
    args = list(sim._row_builder.__reduce__()[1])
    args[7] = {status: index + 1.0 for status, index in args[7].items()}  # another status numbering
    both.builders[1] = rows.RowBuilder(*args)
    both.builders[1].bind(sim._object_xpos, sim._object_qvel, sim._sensordata)
    sim._row_builder = both
    sim.advance()
    assert both.pairs[0][0] != both.pairs[0][1]


def test_the_row_builders_check_their_arrays_as_the_reference_does():
    for cls in (rows.PyRowBuilder, rows.RowBuilder):
        builder = cls(["left_pad"], [5], [1, 3], 7, False, [1.0], 1e5, {"ok": 0.0})
        with pytest.raises(ValueError, match="outside"):
            builder.bind(np.zeros(3), np.zeros(6), np.zeros(8))
        with pytest.raises(ValueError, match="contiguous"):
            builder.bind(np.zeros(6)[::2], np.zeros(6), np.zeros(12))
        with pytest.raises(RuntimeError, match="bind"):
            pickle.loads(pickle.dumps(builder)).row(0.0, None, None, [[1.0]], [[1.0]], ())


def test_the_compiled_row_stacking_is_numpys():
    rng = np.random.default_rng(5)
    chunk = [rng.standard_normal(39).tolist() for _ in range(500)]
    chunk[3][4], chunk[7][0], chunk[9][1] = math.nan, -0.0, math.inf
    ref, cmp = rows.py_stack_rows(chunk, 39), rows.stack_rows(chunk, 39)
    assert cmp.dtype == ref.dtype == np.float64 and cmp.shape == ref.shape == (500, 39)
    assert cmp.tobytes() == ref.tobytes()
    assert rows.stack_rows([], 39).shape == (0, 39)
    mixed = [[1, 2.5, True]]  # not all floats: numpy's own conversion
    assert rows.stack_rows(mixed, 3).tobytes() == np.asarray(mixed, dtype=float).tobytes()
    for stack in (rows.py_stack_rows, rows.stack_rows):
        with pytest.raises(ValueError):
            stack([[1.0, 2.0], [1.0]], 2)
        with pytest.raises(ValueError, match="rows of 3 values"):
            stack([[1.0, 2.0]], 3)


def test_each_value_of_a_row_lands_under_its_column_name():
    """row_columns and the row builders agree, column by column: a row made from distinct, known
    values reads each back under its name, in both builders; the gel sits on its stop exactly
    from the stop's pressure on (``bottomed``)."""
    from types import SimpleNamespace as NS

    stop_pa = 1000.0
    columns = rows.row_columns(["left_pad", "right_pad"], 2, True)
    status_index = {status: float(i) for i, status in enumerate(rows.STATUS_CODES)}
    xpos, qvel = np.array([0.1, 0.2, 0.3]), np.array([0.0, 0.0, -2.0, 3.0, 0.0, 4.0])
    sensordata = np.arange(20, dtype=float) - 30.0  # negative: the row records magnitudes
    obs = NS(
        lift_pos_m=0.01,
        opening_m=0.02,
        grip_force_n=1.5,
        lift_force_n=2.5,
        pads={
            "left_pad": NS(
                reading=NS(mode=2, v1=0.8, v1_true=0.81, settled=True),
                estimate=NS(pressure_pa=500.0, uncertainty_pa=5.0, status="ok"),
            ),
            "right_pad": NS(
                reading=NS(mode=3, v1=0.9, v1_true=0.91, settled=False),
                estimate=NS(pressure_pa=math.nan, uncertainty_pa=math.nan, status="settling"),
            ),
        },
    )
    command = NS(phase=4)
    profiles, cells = [[999.0, 998.0], [1000.0, 10.0]], [[100.0, 300.0], [7.0, 9.0]]
    for cls in (rows.PyRowBuilder, rows.RowBuilder):
        builder = cls(["left_pad", "right_pad"], [5, 6], [1, 3], 7, True, [0.25, 0.75], stop_pa, status_index)
        builder.bind(xpos, qvel, sensordata)
        row = dict(zip(columns, builder.row(1.25, obs, command, profiles, cells, (11.0, 12.0)), strict=True))
        assert (row["time_s"], row["phase"], row["lift_m"], row["opening_m"]) == (1.25, 4.0, 0.01, 0.02)
        assert (row["object_height_m"], row["object_x_m"], row["object_y_m"], row["object_vz_m_s"]) == (0.3, 0.1, 0.2, -2.0)
        assert (row["object_speed_m_s"], row["object_spin_rad_s"]) == (2.0, 5.0)
        assert (row["table_force_n"], row["left_finger_force_n"], row["right_finger_force_n"]) == (21.0, 29.0, 27.0)
        assert (row["left_finger_peak_force_n"], row["right_finger_peak_force_n"]) == (11.0, 12.0)
        assert (row["left_true_pressure_pa"], row["left_coverage_pressure_pa"], row["left_contact_force_n"]) == (998.5, 250.0, 25.0)
        assert (row["left_estimate_pa"], row["left_status"], row["left_mode"], row["left_settled"]) == (500.0, 0.0, 2.0, 1.0)
        assert (row["left_v1"], row["left_v1_true"], row["left_cell1_pressure_pa"]) == (0.8, 0.81, 998.0)
        assert row["left_bottomed"] == 0.0 and row["right_bottomed"] == 1.0  # 999 Pa below the stop, 1000 Pa on it
        assert math.isnan(row["right_estimate_pa"]) and row["right_status"] == float(rows.STATUS_CODES.index("settling"))
        assert (row["right_coverage_pressure_pa"], row["right_cell0_pressure_pa"], row["right_settled"]) == (8.5, 1000.0, 0.0)


# -- the controller's per-reading parts (cosim/control/_control.pyx) ---------------------------


def selector_estimates(p_max_pa: float, n: int, seed: int, edges_pa=()):
    """Estimates a selector meets: pressures over every band (log-uniform from well under the
    lowest mode's detection limit to past the highest's P_max), held, stepped and ramped, with
    settling, saturated, below-detection and non-finite readings among them; and a tenth of
    the time one of ``edges_pa`` (the switch thresholds and their neighbouring floats, where
    the comparisons' arithmetic decides)."""
    from piezotip.sensor.channel import Estimate

    rng = random.Random(seed)
    p = 1.0
    for _ in range(n):
        roll = rng.random()
        if edges_pa and roll < 0.1:
            p = rng.choice(edges_pa)
        elif roll < 0.2:
            p = 10 ** rng.uniform(-2.0, math.log10(3.0 * p_max_pa))  # a step anywhere
        elif roll < 0.8:
            p *= 10 ** rng.uniform(-0.05, 0.08)  # a ramp, mostly up
        status = rng.choices(["ok", "settling", "saturated", "below_detection", "nan"], [70, 10, 8, 8, 4])[0]
        if status == "nan":
            yield Estimate(math.nan, math.nan, "ok")
        elif status == "saturated":
            yield Estimate(math.nan, math.nan, "saturated")
        else:
            yield Estimate(p, 0.01 * p + 1e-3, status)


SELECTOR_FIELDS = (
    "mode",
    "blind",
    "estimate_pa",
    "uncertainty_pa",
    "status",
    "trusted",
    "empty",
    "_saturated",
    "_above_switch",
    "_under_switch",
)


def _selector_state(sel) -> tuple:
    return tuple(getattr(sel, name) for name in SELECTOR_FIELDS)


def _same(a, b) -> bool:
    """Equal, NaN equal to NaN, and of the same types."""
    return type(a) is type(b) and (a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b)))


@pytest.mark.parametrize(
    ("modes", "hysteresis", "persist", "seed"),
    [((1, 2, 3, 4), 0.25, 3, 0), ((1, 3), 0.1, 1, 1), ((2,), 0.25, 3, 2), ((1, 2, 3, 4), 0.0, 2, 3)],
)
def test_the_compiled_selector_decides_as_the_reference(modes, hysteresis, persist, seed):
    tip = Fingertip()
    ref, cmp = selector.PyModeSelector(tip, modes, hysteresis, persist), selector.ModeSelector(tip, modes, hysteresis, persist)
    assert (cmp.modes, cmp.bands, cmp.p_min_pa, cmp.p_max_pa, cmp.switch_pa) == (
        ref.modes,
        ref.bands,
        ref.p_min_pa,
        ref.p_max_pa,
        ref.switch_pa,
    )
    switches = 0
    edges = []
    for s in ref.switch_pa.values():  # each threshold up and down, and the floats either side of it
        for threshold in (s * (1 + hysteresis), s * (1 - hysteresis)):
            edges += [math.nextafter(threshold, 0.0), threshold, math.nextafter(threshold, math.inf)]
    for k, estimate in enumerate(selector_estimates(ref.p_max_pa[max(modes)], 3000, seed, tuple(edges))):
        if k == 1500:
            cmp = copy.deepcopy(cmp)  # a copy goes on as the original
        (mode_r, why_r), (mode_c, why_c) = ref.update(estimate), cmp.update(estimate)
        assert (mode_c, str(why_c)) == (mode_r, str(why_r)), k
        assert type(mode_c) is type(mode_r) and type(why_c) is type(why_r)
        state_r, state_c = _selector_state(ref), _selector_state(cmp)
        assert all(_same(a, b) for a, b in zip(state_r, state_c, strict=True)), (k, state_r, state_c)
        switches += str(why_r).startswith("switch")
    assert switches >= (20 if len(modes) > 1 else 0)  # the sequence went through the bands


def test_the_compiled_touch_detector_alarms_as_the_reference():
    rng = random.Random(7)
    for drift, alarm, single in ((0.5, 8.0, 6.0), (0.0, 3.0, 1e9), (2.0, 1e9, 4.0)):
        ref, cmp = selector.PyTouchDetector(1e-3, drift, alarm, single), selector.TouchDetector(1e-3, drift, alarm, single)
        for _ in range(20):
            v1 = 1.0 + rng.gauss(0.0, 1e-3)
            ref.learn(v1)
            cmp.learn(v1)
        assert cmp.baseline == ref.baseline and cmp._count == ref._count and cmp._sum == ref._sum
        for k in range(400):
            v1 = 1.0 - 2e-5 * k + rng.gauss(0.0, 1e-3)  # a slow drift, then touched
            assert cmp.update(v1) is ref.update(v1)
            assert (cmp.score, cmp.touched) == (ref.score, ref.touched), k
            if k == 300:
                ref.rearm()
                cmp.rearm()
                cmp = pickle.loads(pickle.dumps(cmp))
        assert ref.touched
    for cls in (selector.PyTouchDetector, selector.TouchDetector):
        detector = cls(0.0)
        detector.learn(1.0)
        with pytest.raises(ZeroDivisionError):
            detector.update(0.5)


def test_the_selector_equivalence_test_can_fail():
    """A selector with another hysteresis decides otherwise on the same estimates."""
    tip = Fingertip()
    ref, other = selector.PyModeSelector(tip, (1, 2, 3, 4)), selector.ModeSelector(tip, (1, 2, 3, 4), hysteresis=0.3)
    decisions = [(ref.update(e)[0], other.update(e)[0]) for e in selector_estimates(ref.p_max_pa[4], 3000, 0)]
    assert any(a != b for a, b in decisions)


def test_record_maker_takes_every_field_of_a_slots_dataclass():
    from piezotip.sensor.channel import Estimate
    from piezotip.sensor.compiled import record_maker

    @dataclasses.dataclass(frozen=True)
    class Plain:
        x: float

    with pytest.raises(TypeError, match=r"Plain\.x is not a slot"):
        record_maker(Plain)
    make = record_maker(Estimate)
    assert make(1.0, 2.0, "ok") == Estimate(1.0, 2.0, "ok")
    with pytest.raises(ValueError):
        make(1.0, 2.0)  # a field left out would leave its slot empty


def test_the_compiled_records_are_the_dataclasses():
    from dataclasses import FrozenInstanceError

    from piezotip.cosim.control import Command, Observation, PadSignal, Phase
    from piezotip.sensor.channel import Estimate, Reading

    reading = Reading(2, 0.9, 0.91, -0.1, 1.0, 0.2, True, 1e3, 2.0, 0.9 + 0.01j)
    estimate = Estimate(120.0, 3.0, "ok")
    pads = {"left_pad": None}
    made = {
        "signal": ((reading, estimate), PadSignal, interface.py_make_pad_signal, interface.make_pad_signal),
        "observation": ((1.5, pads, 0.02, 0.05, 3.0, 2.0, -0.01), Observation, interface.py_make_observation, interface.make_observation),
        "default velocity": ((1.5, pads, 0.02, 0.05, 3.0, 2.0), Observation, interface.py_make_observation, interface.make_observation),
        "command": ((0.03, 0.0, 4.0, {"left_pad": 2}, Phase.LIFT, "squeeze"), Command, interface.py_make_command, interface.make_command),
        "reading": (tuple(getattr(reading, f.name) for f in dataclasses.fields(reading)), Reading, resonator._reading, resonator._reading),
        "estimate": ((120.0, 3.0, "ok"), Estimate, estimator._estimate, estimator._estimate),
    }
    for name, (args, cls, reference, compiled) in made.items():
        expected = cls(*args)
        for make in (reference, compiled):
            record = make(*args)
            assert type(record) is cls and record == expected, name
            assert not hasattr(record, "__dict__"), name  # slots: one allocation, no instance dict
            assert [type(getattr(record, f)) for f in expected.__dataclass_fields__] == [
                type(getattr(expected, f)) for f in expected.__dataclass_fields__
            ]
            with pytest.raises(FrozenInstanceError):
                record.__setattr__(next(iter(expected.__dataclass_fields__)), 0.0)
            assert pickle.loads(pickle.dumps(record)) == expected

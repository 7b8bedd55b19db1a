"""The co-simulation's fast paths compute what the documented formulas compute, and only what is needed.

* sensor: the scalar envelope formulas equal sensor/readout.py's; a channel's samples equal a
  reference channel written with those functions and numpy tables (to ~1e-12); the scalar
  table lookups equal np.interp; the fast Reading/Estimate constructors build ordinary ones;
* pads: the gel forces and element pressures equal the numpy formulas they replaced;
* loop: each control step runs control_period / timestep physics steps, and each channel
  evaluates the gel and sensor exactly once, for its active mode; the recorded row is what
  the public, checked API gives; the recorder's fast path writes what append() writes.

Nothing here is timed: the cost is measured by ``run_sim.py bench``.
"""

from __future__ import annotations

import copy
import dataclasses
import math

import mujoco
import numpy as np
import pytest
from numpy.testing import assert_allclose

from piezotip import scenarios
from piezotip.cosim.loop import CoSimulation
from piezotip.cosim.pad_bridge import PadBridge, _GelTable
from piezotip.cosim.pad_geometry import PadGeometry
from piezotip.cosim.pad_kernels import UniformPairTable
from piezotip.cosim.pad_model import build_model
from piezotip.cosim.recorder import Recorder
from piezotip.sensor import Fingertip, SensorElement
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.estimator import _TABLE_P, Estimate, FoundationTable, _estimate
from piezotip.sensor.gel import GelModel
from piezotip.sensor.lookup import interp as _interp
from piezotip.sensor.resonator import _SETTLE_TAUS, Reading, _rate, _reading, _steady, _step, envelope_rate, envelope_step, steady_envelope

RTOL = 1e-12


@pytest.fixture(scope="module")
def tip():
    return Fingertip(element=SensorElement().with_quality_factor(70), coverage=(6.5e-3, 7.5e-3))


# ---------------------------------------------------------------------------------------
# Sensor: formulas, tables, the channel.
# ---------------------------------------------------------------------------------------


def test_scalar_envelope_formulas_equal_the_documented_functions():
    rng = np.random.default_rng(1)
    for _ in range(2000):
        omega, c, rho = 10 ** rng.uniform(3, 6), 10 ** rng.uniform(-3, 1), 10 ** rng.uniform(-4, -1)
        kappa, gamma = 10 ** rng.uniform(-3, 7) * rng.integers(0, 2), 10 ** rng.uniform(-6, 1)
        env = complex(*rng.normal(size=2))
        dt = 10 ** rng.uniform(-5, -1)
        steady, rate = _steady(omega, c, kappa, gamma), _rate(rho, omega, c, kappa, gamma)
        assert_allclose(steady, complex(steady_envelope(omega, c, kappa, gamma)), rtol=RTOL)
        assert_allclose(rate, complex(envelope_rate(rho, omega, c, kappa, gamma)), rtol=RTOL)
        assert_allclose(_step(env, steady, dt, rate), complex(envelope_step(env, steady, dt, rate)), rtol=RTOL, atol=1e-300)


def test_interp_is_np_interp():
    rng = np.random.default_rng(2)
    xp = np.sort(rng.uniform(-3, 5, 301))
    fp = rng.normal(size=xp.size)
    xs = np.concatenate([rng.uniform(-4, 6, 5000), xp, np.nextafter(xp, np.inf), np.nextafter(xp, -np.inf)])
    ours = np.array([_interp(x, xp.tolist(), fp.tolist()) for x in xs.tolist()])
    assert_allclose(ours, np.interp(xs, xp, fp), rtol=1e-15, atol=0)
    assert math.isnan(_interp(math.nan, xp.tolist(), fp.tolist()))


def test_foundation_table_lookup_equals_the_array_call(tip):
    for mode in tip.modes:
        table = FoundationTable(tip, mode)
        pressures = np.concatenate([[0.0, 1e-9, _TABLE_P[0], _TABLE_P[-1], 2e7], np.logspace(-5, 7.5, 3000), _TABLE_P[::7]])
        k_ref, c_ref = table(pressures)
        ours = np.array([table.at(p) for p in pressures.tolist()])
        assert_allclose(ours[:, 0], k_ref, rtol=RTOL, atol=0)
        assert_allclose(ours[:, 1], c_ref, rtol=RTOL, atol=0)


def test_mode_inverse_equals_its_np_interp_form(tip):
    """The inverse's lists-and-bisect lookups against the np.interp code they replaced."""
    ch = SensorChannel(tip)
    checked = 0
    for mode in tip.modes:
        inv = ch.inverse(mode)
        for v1 in np.linspace(inv._v_last - 0.01, 1.01, 4001).tolist():
            e = inv(v1)
            if not (v1 > inv._v_last and v1 < inv._v_first and 1.0 - v1 >= 3.0 * inv.sigma):
                continue
            log_p = float(np.interp(-v1, inv._neg_v, inv._log_p))
            p = math.exp(log_p)
            if not p <= inv.p_max_pa:
                assert e.status == "saturated"
                continue
            slope = abs(float(np.interp(log_p, inv._log_p, inv._dv_dlogp))) / p
            assert e.status == "ok"
            assert (e.pressure_pa, e.uncertainty_pa) == pytest.approx((p, inv.sigma / slope), rel=1e-15)
            checked += 1
    assert checked > 1000


def test_fast_constructors_build_ordinary_frozen_records():
    fields = [f.name for f in dataclasses.fields(Reading)]
    values = (2, 0.5, 0.49, 0.1, 1.5, 0.6, True, 3.0, 0.02, 0.4 + 0.3j)
    r = _reading(*values)
    assert r == Reading(*values) and [getattr(r, f) for f in fields] == list(values)
    assert _estimate(1.0, 2.0, "ok") == Estimate(1.0, 2.0, "ok")
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.v1 = 0.0


class ReferenceChannel:
    """SensorChannel's sample as documented: numpy tables and sensor/readout.py's functions."""

    def __init__(self, channel: SensorChannel) -> None:
        self.ch = channel
        self.envelope = 1 + 0j
        self.time_in_mode_s = math.inf
        self.mode = channel.mode

    def select_mode(self, mode: int) -> None:
        if mode != self.mode:
            self.mode, self.time_in_mode_s = mode, 0.0
            if self.ch.dynamics == "envelope":
                self.envelope = 0j

    def update(self, pressure, dt):
        ch, mode = self.ch, self.mode
        p = np.asarray(pressure, float)
        k_e, c_e = ch.tip.foundation(p, mode) if ch.exact else ch._tables[mode](p)
        w = ch._weights[mode]
        kappa, gamma = float(k_e @ w), float(c_e @ w)
        omega, rho, c = ch._omega[mode], ch._rho_a, ch._c
        steady = complex(steady_envelope(omega, c, kappa, gamma))
        rate = complex(envelope_rate(rho, omega, c, kappa, gamma))
        self.time_in_mode_s += dt
        tau = 1.0 / rate.real
        if ch.dynamics == "envelope":
            self.envelope = complex(envelope_step(self.envelope, steady, dt, rate))
            settled = self.time_in_mode_s >= tau * math.log(1.0 / 1e-3)
        else:
            self.envelope, settled = steady, True
        v1_true = abs(self.envelope)
        phase = -math.atan2(self.envelope.imag, self.envelope.real) if v1_true > 0 else 0.0
        return mode, v1_true, phase, self.time_in_mode_s, tau, settled, kappa, gamma


@pytest.mark.parametrize("dynamics", ["envelope", "steady"])
@pytest.mark.parametrize(("cells", "exact"), [(1, False), (4, False), (1, True), (3, True)])
def test_channel_samples_equal_the_reference(tip, dynamics, cells, exact):
    assert _SETTLE_TAUS == math.log(1.0 / 1e-3)
    edges = np.linspace(*tip.coverage, cells + 1)
    rng = np.random.default_rng(7)
    ch = SensorChannel(tip, edges_m=edges, dynamics=dynamics, rng=np.random.default_rng(3), exact=exact)
    ref = ReferenceChannel(ch)
    for step in range(300):
        if step % 60 == 59:
            mode = int(rng.choice(tip.modes))
            ch.select_mode(mode)
            ref.select_mode(mode)
        profile = (10 ** rng.uniform(-4, 6, cells)) * (rng.uniform(size=cells) > 0.1)
        dt = float(rng.choice([1e-3, 5e-3, 2e-2]))
        r = ch.update(profile, dt) if step % 2 else ch.update_trusted(profile.tolist(), dt)
        mode, v1_true, phase, t, tau, settled, kappa, gamma = ref.update(profile, dt)
        assert (r.mode, r.settled, r.time_in_mode_s) == (mode, settled, t)
        assert_allclose([r.v1_true, r.tau_s, r.kappa, r.gamma], [v1_true, tau, kappa, gamma], rtol=RTOL, atol=0)
        assert_allclose(r.phase_rad, phase, rtol=RTOL, atol=1e-15)
        # The reading is the noisy lock-in output's magnitude; the noise moves it by O(sigma).
        assert r.v1 == abs(r.iq)
        assert abs(r.v1 - r.v1_true) <= 8 * ch._sigma[mode]
    assert ch.evaluations == 300


def test_select_mode_still_checks_the_mode(tip):
    ch = SensorChannel(tip)
    ch.select_mode(1)  # the current mode: nothing happens
    assert ch.mode == 1 and ch.time_in_mode_s == math.inf
    for bad in (0, 7, 1.0, "1"):
        with pytest.raises((ValueError, TypeError)):
            ch.select_mode(bad)


# ---------------------------------------------------------------------------------------
# Pads: gel forces and pressures.
# ---------------------------------------------------------------------------------------


def test_table_lookup_equals_np_interp_of_both_columns():
    table = _GelTable.build(GelModel(), PadGeometry())
    lookup = UniformPairTable(table.grid_m, table.pressure_pa, table.tangent_pa_m)
    rng = np.random.default_rng(4)
    g = table.grid_m
    qs = np.concatenate([rng.uniform(g[0] - 1e-4, g[-1] + 1e-4, 20000), g, np.nextafter(g, 1), np.nextafter(g, -1), [-1.0, 1.0]])
    ours = np.array([lookup.at(q) for q in qs.tolist()])
    assert_allclose(ours[:, 0], np.interp(qs, g, table.pressure_pa), rtol=1e-15, atol=0)
    assert_allclose(ours[:, 1], np.interp(qs, g, table.tangent_pa_m), rtol=1e-15, atol=0)
    assert all(math.isnan(v) for v in lookup.at(math.nan))


def test_a_uniform_table_names_a_bad_grid():
    with pytest.raises(ValueError, match="strictly increasing"):
        UniformPairTable([0.0, 0.0, 1.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="shape"):
        UniformPairTable([0.0, 1.0], [1.0], [1.0, 2.0])


@pytest.mark.parametrize("segments", [1, 3])
def test_gel_forces_and_pressures_equal_the_numpy_formulas(segments):
    model = build_model("grasp", pad_segments=segments)
    data = mujoco.MjData(model)
    bridge = PadBridge(model)
    t = bridge._table
    rng = np.random.default_rng(5)
    for _ in range(200):
        data.qpos[bridge._qadr] = rng.uniform(-0.7e-3, 4.2e-3, bridge._qadr.size)
        q = data.qpos[bridge._qadr]
        stiffness = bridge._area * np.interp(q, t.grid_m, t.tangent_pa_m)
        force = stiffness * (q - bridge._qspring) - bridge._area * np.interp(q, t.grid_m, t.pressure_pa)
        bridge.apply_gel_forces(data)
        assert_allclose(model.jnt_stiffness[bridge._jnt], stiffness, rtol=1e-15, atol=0)
        assert_allclose(data.qfrc_applied[bridge._dof], force, rtol=1e-15, atol=1e-300)
        pressures = np.maximum(np.interp(data.qpos[bridge._qadr_element], t.grid_m, t.pressure_pa), 0.0).reshape(2, -1)
        assert_allclose(bridge.element_pressures(data), pressures, rtol=1e-15, atol=0)
        assert bridge.element_pressure_values(data) == pytest.approx(pressures.ravel().tolist(), rel=1e-15, abs=0)


# ---------------------------------------------------------------------------------------
# The loop: work per control step, and the row.
# ---------------------------------------------------------------------------------------


def _count_work(sim: CoSimulation):
    """Count gel-force applications (one per physics step, through the loop's own instrument
    hook); the channels' samplers count their table lookups per mode themselves
    (``ModeSampler.lookups``)."""
    counts = {"gel": 0}

    def wrap(stage, method):
        if stage != "gel_forces":
            return method

        def counted(data):
            counts["gel"] += 1
            method(data)

        return counted

    sim.wrap_stages(wrap)

    def lookups() -> dict[str, dict[int, int]]:
        return {pad: {m: s.lookups for m, s in ch._samplers.items()} for pad, ch in sim.channels.items()}

    return counts, lookups


@pytest.mark.parametrize(
    ("period", "segments", "kind", "gel_update"),
    [
        (0.005, 1, "multimode", "substep"),
        (0.005, 1, "multimode", "control"),
        (0.002, 1, "scripted", "substep"),
        (0.003, 3, "scripted", "substep"),
    ],
)
def test_each_control_step_does_the_work_it_needs_once(period, segments, kind, gel_update):
    config = scenarios.get(
        "grasp",
        [
            f"physics.control_period_s={period}",
            f"physics.pad_segments={segments}",
            f"controller.kind={kind}",
            f"physics.gel_update={gel_update}",
        ],
    )
    sim = CoSimulation(config)
    substeps = round(period / config.physics.timestep_s)
    gel_per_step = substeps if gel_update == "substep" else 1
    assert sim.substeps == substeps
    counts, lookups = _count_work(sim)
    steps = 120
    modes = {pad: [] for pad in sim.pads}
    for k in range(1, steps + 1):
        row = sim.step()
        assert counts["gel"] == k * gel_per_step  # the gel's law before every physics step (or once a period), no more
        assert sim.data.time == pytest.approx(k * period, rel=1e-12)
        for pad in sim.pads:
            assert sim.channels[pad].evaluations == k  # one gel/sensor evaluation per control step
            modes[pad].append(int(row[f"{pad.removesuffix('_pad')}_mode"]))
    cells = sim.channels[sim.pads[0]].n_cells
    done = lookups()
    for pad in sim.pads:  # each evaluation in the mode driven at that step, one lookup per cell
        assert set(done[pad]) == set(sim.channels[pad]._fast)  # a sampler for every mode used
        assert done[pad] == {m: cells * modes[pad].count(m) for m in done[pad]}


def test_recorded_row_is_what_the_checked_api_gives():
    """Step a simulation and, beside it, recompute each row's inputs with the public numpy paths."""
    config = scenarios.get("grasp", ["physics.pad_segments=3", "sensor.noise=False", "controller.kind=scripted"])
    sim = CoSimulation(config)
    twins = {pad: SensorChannel(sim.fingertip, edges_m=ch.edges_m, dynamics=ch.dynamics, noise=False) for pad, ch in sim.channels.items()}
    for _ in range(400):
        row = sim.step()
        pressures = sim.bridge.element_pressures(sim.data)[:, ::-1]
        for pad, twin in twins.items():
            side, prow = pad.removesuffix("_pad"), ("left_pad", "right_pad").index(pad)
            cells = [row[f"{side}_cell{k}_pressure_pa"] for k in range(3)]
            assert cells == pressures[prow].tolist()
            assert row[f"{side}_true_pressure_pa"] == float(np.mean(pressures[prow]))
            twin.select_mode(int(row[f"{side}_mode"]))
            r = twin.update(sim.coverage_pressures()[sim.pads.index(pad)], sim.dt)
            assert row[f"{side}_v1"] == pytest.approx(r.v1, rel=RTOL)
            e = twin.estimate(r)
            assert row[f"{side}_estimate_pa"] == pytest.approx(e.pressure_pa, rel=1e-9, nan_ok=True)
        assert row["object_height_m"] == float(sim.data.xpos[sim.model.body("object").id][2])
        assert row["time_s"] == sim.time_s


def test_append_values_writes_what_append_writes(tmp_path):
    rows = [{"time_s": 0.1 * i, "a_pa": float(i * i), "b": -float(i)} for i in range(7)]
    with Recorder(tmp_path / "dict", flush_every=3) as rec:
        for row in rows:
            rec.append(row)
    columns = list(rows[0])
    with Recorder(tmp_path / "values", flush_every=3) as rec:
        for row in rows:
            rec.append_values([row[c] for c in columns], columns)
    a, b = np.load(tmp_path / "dict.npz"), np.load(tmp_path / "values.npz")
    for c in columns:
        np.testing.assert_array_equal(a[c], b[c])
    rec = Recorder(tmp_path / "bad")
    with pytest.raises(ValueError, match="column names"):
        rec.append_values([1.0])
    rec.append_values([1.0, 2.0], ["x", "y"])
    with pytest.raises(ValueError, match="values"):
        rec.append_values([1.0], ["x", "y"])
    with pytest.raises(ValueError, match="columns"):
        rec.append_values([1.0, 2.0], ["x", "z"])


def test_a_deep_copy_steps_on_its_own_model_and_data():
    """The per-step views (memoryviews of MuJoCo's arrays) are rebuilt for a copy, not shared."""
    sim = CoSimulation(scenarios.get("grasp", ["controller.kind=scripted"]))
    for _ in range(150):
        sim.step()
    twin = copy.deepcopy(sim)
    assert twin.data is not sim.data and twin.bridge.model is twin.model
    for _ in range(100):  # interleaved: neither may write into the other's arrays
        np.testing.assert_equal(sim.step(), twin.step())  # (NaN equal to NaN: a contact tilt where none touches)


def test_fast_controller_records_equal_their_constructors():
    from piezotip.cosim.control import Command, Observation, PadSignal, make_command, make_observation, make_pad_signal

    r = Reading(2, 0.5, 0.49, 0.1, 1.5, 0.6, True, 3.0, 0.02, 0.4 + 0.3j)
    e = Estimate(120.0, 3.0, "ok")
    assert make_pad_signal(r, e) == PadSignal(r, e)
    args = (1.0, {"left_pad": make_pad_signal(r, e)}, -0.2, 0.03, 4.0, 2.0)
    assert make_observation(*args) == Observation(*args)
    args = (-0.2, 0.0, 5.0, {"left_pad": 2}, "lift", "why")
    assert make_command(*args) == Command(*args)
    with pytest.raises(dataclasses.FrozenInstanceError):
        make_command(*args).phase = "hold"

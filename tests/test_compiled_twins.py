"""Each compiled kernel is its own source run as Python, bit for bit; and what the kernels promise either way.

A kernel (:mod:`piezotip.sensor.compiled`) is one Python module that runs as it is and that
setup.py compiles with Cython.  :func:`test_the_compiled_kernel_is_its_source_run_as_python`
drives the built extension module and the same source run as Python
(:func:`piezotip.sensor.compiled.source_module`) through the same inputs, one driver per kernel,
and compares every output exactly: floats by their bits (-0.0, a NaN's sign and one ulp count),
records field by field with their types.  :func:`test_each_comparison_can_fail` drives the
compiled kernel once more with one input one ulp off, and needs another output.  The drivers
step through what the per-step path meets and what it rarely does: held loads, steps and ramps,
ring-ups from rest, zero and non-finite values, a run past the inference's re-basing age, NumPy
scalars where a caller passes them, and a deep copy made mid-run that goes on in the original's
place.

The rest holds for whichever runs (the suite passes with ``PIEZOTIP_PURE_PYTHON=1`` too): copies
are made from the constructors' arguments, bad input is refused, a row's values land under their
columns, the records are the dataclasses.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import importlib
import math
import os
import pickle
import random
import struct
import subprocess
import sys
from types import SimpleNamespace as NS

import numpy as np
import pytest

from piezotip.cosim import pad_kernels, period, rows
from piezotip.cosim.control import interface, selector
from piezotip.cosim.pad_bridge import _GelTable
from piezotip.cosim.pad_geometry import PadGeometry
from piezotip.sensor import Fingertip, GelModel, SensorElement, compiled, estimator, inference, resonator, sampler
from piezotip.sensor._channel import ChannelCore
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.compiled import PURE_PYTHON, is_compiled, source_module
from piezotip.sensor.estimator import _TABLE_P, Estimate, foundation_table
from piezotip.sensor.resonator import Reading

needs_the_build = pytest.mark.skipif(PURE_PYTHON, reason="PIEZOTIP_PURE_PYTHON is set: the kernels run as Python")

TAU0_S = 0.66  # Table I's unloaded envelope time constant, s
SIGMA = 1e-3  # one reading's noise, V_1 units
ULP = 1 + 2**-52  # a factor one ulp above 1


def exact(value) -> object:
    """``value`` as comparable text that keeps every bit: a float's bits, a complex number's two,
    containers item by item, a dataclass record field by field, an array's dtype and bytes;
    each with its type's name."""
    if isinstance(value, float):
        return ("float", struct.pack("<d", value).hex())
    if isinstance(value, complex):
        return ("complex", exact(value.real), exact(value.imag))
    if isinstance(value, (list, tuple)):
        return (type(value).__name__, *[exact(v) for v in value])
    if isinstance(value, dict):
        return ("dict", *[(exact(k), exact(v)) for k, v in value.items()])
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return (type(value).__name__, *[exact(getattr(value, f.name)) for f in dataclasses.fields(value)])
    if isinstance(value, np.ndarray):
        return ("ndarray", value.dtype.str, value.shape, value.tobytes().hex())
    if isinstance(value, interface.Why):
        return ("Why", str(value))
    return (type(value).__name__, repr(value))


# -- the drivers: each runs one kernel module through its inputs, and returns every output ------


def _pressures(n: int, seed: int) -> list[float]:
    """Pressures, Pa: zero of both signs, below the table, its points exactly and beside them,
    log-uniform over and past its range, a step up and back."""
    rng = np.random.default_rng(seed)
    grid = _TABLE_P[:: max(1, len(_TABLE_P) // 50)]
    special = [0.0, -0.0, 5e-324, 1e-9, 5e-4, *grid, *np.nextafter(grid, 0), *np.nextafter(grid, np.inf), 1e8, 1e12]
    rest = 10 ** rng.uniform(-4, 7.5, max(n - len(special), 0))
    return [float(p) for p in [*special, *rest, 0.0, 5e5, 5e5, 0.0]]


def _sampler_args(mode: int, cells: int, envelope: bool) -> tuple:
    """A ModeSampler's arguments for one mode of the default fingertip at Q = 70, ``cells`` cells."""
    tip = Fingertip(element=SensorElement().with_quality_factor(70), coverage=(6.5e-3, 7.5e-3))
    ch = SensorChannel(tip, edges_m=np.linspace(6.5e-3, 7.5e-3, cells + 1), dynamics="envelope", noise=False)
    omega, sigma, _, weights = ch._fast[mode]
    return (mode, omega, sigma, ch._c_f, ch._rho_a_f, foundation_table(tip, mode), weights, envelope)


def drive_sampler(kernel, perturb: bool = False) -> list:
    out = []
    for mode, cells, envelope in ((1, 1, True), (3, 1, False), (2, 3, True), (2, 3, False)):
        args = _sampler_args(mode, cells, envelope)
        if perturb and mode == 1:
            args = (*args[:3], args[3] * ULP, *args[4:])  # the damping c one ulp up
        for skip in (True, False):
            s = kernel.ModeSampler(*args, skip_unloaded=skip)
            rng = np.random.default_rng(7)
            a, t = 0j, 0.0  # a ring-up from rest
            for k, p in enumerate(_pressures(1500, seed=mode)):
                dt = (0.001, 0.005, 0.0002)[k % 3]
                t = math.inf if k == 700 else t + dt  # a settled history, then on
                noise = None if k % 4 == 0 else complex(*rng.standard_normal(2))
                reading, a = s.sample([p * (1.0 + 0.1 * i) for i in range(cells)], a, dt, t, noise)
                out.append((reading, a))
                if k == 1000:
                    s = copy.deepcopy(s)  # a copy goes on as the original
            out.append((s.lookups, s.unloaded_samples, s.mode))
    return out


def _inverse_args(mode: int) -> tuple:
    tip = Fingertip(element=SensorElement().with_quality_factor(70), coverage=(6.5e-3, 7.5e-3))
    inverse = SensorChannel(tip, noise=False).inverse(mode)
    return (
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


def drive_estimator(kernel, perturb: bool = False) -> list:
    out = []
    for mode in (1, 2, 3, 4):
        args = _inverse_args(mode)
        if perturb and mode == 2:
            args = (*args[:6], args[6] * ULP, *args[7:])  # a reading's noise one ulp up
        core = kernel.InverseCore(*args)
        curve = (-np.asarray(args[0])).tolist()
        rng = np.random.default_rng(mode)
        v1s = [
            *curve,
            *np.nextafter(curve, 2.0).tolist(),
            *np.nextafter(curve, -1.0).tolist(),
            *rng.uniform(args[4] - 0.02, 1.02, 3000).tolist(),
            1.0,
            1.0 - 3.0 * args[6],
            0.0,
            -0.0,
            -0.5,
            math.nan,
            math.inf,
        ]
        gains = (0.5, 1.0, 1.7, 25.0, 1e3, math.nan)
        out += [core.inferred(v1, gains[k % len(gains)]) for k, v1 in enumerate(v1s)]
        core = copy.deepcopy(core)
        out += [core.inferred(v1, 1.3) for v1 in v1s[:100]]
    return out


def _readings(n: int, dt_s: float, ring_up: bool, seed: int):
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


def drive_inference(kernel, perturb: bool = False) -> list:
    out = []
    for dt_s in (0.005, 0.001):
        for ring_up in (False, True):
            n = 7000  # 35 s at 5 ms: past the re-basing age (30 s), several restarts and ramps
            inf = kernel.SteadyInference(TAU0_S, SIGMA * (ULP if perturb else 1.0))
            if ring_up:
                inf.restart(0.0, 0j)
            else:
                inf.seed(1 + 0j, 0.0, dt_s)
            for k, (t, a) in enumerate(_readings(n, dt_s, ring_up, seed=3)):
                out.append(inf.step(t, a))
                if k == n // 2:
                    inf = copy.deepcopy(inf)
            out.append((inf.tau0, inf.sigma, inf.w_target))
    # A unit channel's readings without noise: NumPy scalars (its envelope is NumPy's), their
    # arithmetic not to be carried into the window (NumPy's complex division rounds differently
    # from CPython's, which the compiled kernel's is).
    for numpy_times, ring_up in ((False, False), (True, True)):
        inf = kernel.SteadyInference(np.float64(TAU0_S), np.float64(SIGMA * (ULP if perturb else 1.0)))
        if ring_up:
            inf.restart(np.float64(0.0), np.complex128(0j))
        else:
            inf.seed(np.complex128(1 + 0j), np.float64(0.0), np.float64(0.005))
        for k, (t, a) in enumerate(_drifting_readings(1500, 0.005, ring_up)):
            out.append(inf.step(np.float64(t) if numpy_times else t, a))
            if k == 1000:
                inf.restart(t, a)  # a re-zero: from the envelope where it is
    return out


def _drifting_readings(n: int, dt_s: float, ring_up: bool):
    """(t, a) of a noiseless envelope (NumPy complex scalars) relaxing toward a load that holds
    and steps, its mu drifting slowly with the unit's temperature (its detuning)."""
    a = np.complex128(0j if ring_up else 1 + 0j)
    for k in range(n):
        t = (k + 1) * dt_s
        mu = (1 + 0j, 1.4 - 0.5j, 1.1 - 0.05j)[(k // 400) % 3] - 2e-3j * t
        a_ss = 1.0 / mu
        a = a_ss + (a - a_ss) * np.exp(-mu * dt_s / TAU0_S)
        yield t, a


def _channel_core(kernel, ch: SensorChannel, perturb: bool):
    """``kernel``'s ChannelCore for the channel ``ch`` (its samplers, inverses and state), put
    in place of its own: ``ch``'s methods then run through it (the noise from generator 11)."""
    tau0 = ch._tau0 * (ULP if perturb else 1.0)  # (perturbed: the inference's tau0 one ulp up)
    args = (ch._samplers, ch._inverse, ch._sigma, ch._low_amplitude, tau0, ch._saturation_s, ch.dynamics)
    core = kernel.ChannelCore(*args, ch.mode, ch.noise, np.random.default_rng(11))
    ch._core = ch._fast_core = core
    ch._bind_fast_path()
    return core


def drive_channel(kernel, perturb: bool = False) -> list:
    """Readings and estimates of channels run through ``kernel``'s core: envelope and steady
    dynamics, one cell and three, with noise and without; a settled start, loads on and off,
    held, stepping and past the mode's range, mode switches (ring-ups from rest), a reading
    estimated twice, one of a mode no longer driven, periods of three lengths, a deep copy and
    a pickled copy made mid-run that go on in the original's place."""
    out = []
    tip = Fingertip(element=SensorElement().with_quality_factor(70), coverage=(6.5e-3, 7.5e-3))
    for dynamics, cells, noise in (("envelope", 1, True), ("envelope", 3, False), ("steady", 1, True), ("envelope", 1, False)):
        ch = SensorChannel(tip, edges_m=np.linspace(6.5e-3, 7.5e-3, cells + 1), dynamics=dynamics, noise=noise)
        core = _channel_core(kernel, ch, perturb)
        rng = np.random.default_rng(cells)
        stale = None
        for k in range(2400):
            if k in (500, 1300, 1900):
                stale = core.update([0.0] * cells, 0.005)  # a reading of the mode before the switch
                ch.select_mode((2, 4, 1)[(500, 1300, 1900).index(k)])
            segment = (k // 150) % 6
            p = (0.0, 800.0, 3e4, 0.0, 2e6, 150.0)[segment] * (1.0 + 1e-3 * rng.standard_normal())
            dt = (0.005, 0.004, 0.001)[k % 3]
            if k % 2:
                reading, estimate = core.sample([p * (1.0 + 0.2 * i) for i in range(cells)], dt)
            else:
                reading = ch.update_trusted([p * (1.0 + 0.2 * i) for i in range(cells)], dt)
                estimate = ch.estimate(reading)
            out.append((reading, estimate, ch.envelope, ch.time_in_mode_s, ch._clock_s, ch._low_since_s))
            if k % 97 == 0:
                out.append((ch.estimate(reading) is estimate or dynamics == "steady", len(ch._noise)))
            if stale is not None:
                out.append(ch.estimate(stale))
                stale = None
            if k in (700, 1600):  # (the source run as Python is not pickled: its class has no importable name)
                ch = copy.deepcopy(ch) if k == 700 else pickle.loads(pickle.dumps(ch)) if kernel is _channel_kernel() else ch
                core = ch._core
        out.append((ch.evaluations, ch.mode, ch._inference_mode, ch._estimated_at, ch._dt_s, ch._seed_a))
    return out


def _channel_kernel():
    """The channel kernel as the channels import it (what a pickled core is loaded as)."""
    return importlib.import_module("piezotip.sensor._channel")


def _gel_table() -> tuple:
    table = _GelTable.build(GelModel(), PadGeometry())
    return table.grid_m, table.pressure_pa, table.tangent_pa_m


def _indentations(rng, grid: np.ndarray, n: int) -> np.ndarray:
    """A qpos-like array: indentations inside, at and past the gel law's grid, and NaN."""
    q = rng.uniform(grid[0] - 1e-4, grid[-1] + 1e-4, n)
    q[:6] = [grid[0], grid[-1], grid[3], np.nextafter(grid[5], 1), -1.0, math.nan]
    return q


def drive_pad_kernels(kernel, perturb: bool = False) -> list:
    grid, pressure, tangent = _gel_table()
    columns = (grid, pressure * ULP if perturb else pressure, tangent)
    out = []
    table = kernel.UniformPairTable(*columns)
    rng = np.random.default_rng(4)
    qs = np.concatenate([rng.uniform(grid[0] - 1e-4, grid[-1] + 1e-4, 5000), grid, np.nextafter(grid, 1), np.nextafter(grid, -1)])
    out += [table.at(q) for q in [*qs.tolist(), -1.0, 1.0, math.nan, math.inf, -0.0]]
    rng = np.random.default_rng(11)
    n = 12
    qadr, dof, jnt = rng.permutation(40)[:n].tolist(), rng.permutation(30)[:n].tolist(), rng.permutation(20)[:n].tolist()
    forces = kernel.GelForces(columns, qadr, dof, jnt, rng.uniform(1e-6, 1e-4, n).tolist(), rng.uniform(-1e-4, 1e-4, n).tolist())
    weights = [[(0, 0.25), (1, 0.5), (4, 0.25)], [(2, 1.0)], [(3, 0.3), (4, -0.0), (0, 0.7)]]
    pressures = kernel.PadPressures(columns, rng.permutation(40)[:10].tolist(), 5, [3, 1, 2], weights)
    for k in range(300):
        qpos, qfrc, stiffness = _indentations(rng, grid, 40), np.full(30, 7.0), np.full(20, 7.0)
        forces.bind(qpos, qfrc, stiffness)
        forces.apply()
        pressures.bind(qpos)
        out += [qfrc, stiffness, pressures.read()]
        if k == 150:  # copies come unbound: their owner binds them
            forces, pressures = copy.deepcopy(forces), copy.deepcopy(pressures)
    passive = kernel.PassiveGelForces(
        columns,
        qadr,
        dof,
        jnt,
        rng.uniform(1e-6, 1e-4, n).tolist(),
        rng.uniform(0, 1e-3, n).tolist(),
        rng.uniform(0, 1, n).tolist(),
        2e-3,
        0.5,
    )
    for k in range(200):
        qpos, arrays = (
            _indentations(rng, grid, 40),
            [np.full(30, 7.0), rng.normal(size=30), np.full(20, 7.0), np.full(30, 7.0), np.full(30, 7.0)],
        )
        passive.bind(qpos, arrays[0], arrays[1], arrays[2], arrays[3], arrays[4])
        if k % 3 == 0:
            passive.linearize()
        out.append(passive.changed())
        passive.apply(k % 2 == 0, k % 3 != 1)
        passive.stiffness(k % 5 == 0)
        out += [a.copy() for a in arrays]
        passive.scale_masses(rng.uniform(0, 1e4, n))
        out += [arrays[3].copy(), arrays[4].copy()]
        if k == 100:
            passive = copy.deepcopy(passive)
    return out


_DRIVE_XML = """<mujoco><option timestep="0.001"/><worldbody><body><joint name="lift" type="slide" axis="0 0 1"/>
<geom size=".01" mass=".1"/><body><joint name="l" type="slide" axis="1 0 0"/><geom size=".005" pos=".02 0 0" mass=".01"/></body>
<body><joint name="r" type="slide" axis="1 0 0"/><geom size=".005" pos="-.02 0 0" mass=".01"/></body></body></worldbody>
<actuator><position joint="lift" kp="100"/><position joint="l" kp="50"/><position joint="r" kp="50"/></actuator>
<sensor><jointvel joint="l"/><jointvel joint="r"/></sensor></mujoco>"""


def drive_period(kernel, perturb: bool = False) -> list:
    """The period's substeps on a three-servo model (run_drive: two finger actuators, the gel
    call counted, peaks tracked or not, the sensors' flag) and in the co-simulation (run: the
    house gripper, a crush-tracking object, the gel law every substep); copies rebound."""
    import mujoco

    from piezotip import scenarios
    from piezotip.cosim.loop import _NO_SENSORS, CoSimulation

    out = []
    model = mujoco.MjModel.from_xml_string(_DRIVE_XML)
    for substeps, every, track in ((1, False, True), (4, False, True), (4, True, False), (3, False, False)):
        data = mujoco.MjData(model)
        calls: list[float] = []
        gel = functools.partial(lambda d, seen: seen.append(d.time), data, calls)
        period = kernel.PeriodPhysics(substeps, 0, [1, 2], every, track, [0, 1], _NO_SENSORS)
        period.bind(model, data, mujoco.mj_step, gel)
        fingers = [0.0, 0.0]
        for k in range(40):
            target = [0.01 * math.sin(0.3 * k), -0.01 * math.cos(0.2 * k) * (ULP if perturb else 1.0)]
            stable = period.run_drive(0.001 * k, 0.001 * (k + 1), fingers, target)
            fingers = target
            out += [stable, period.left_peak, period.right_peak, data.qpos.copy(), data.qvel.copy(), data.ctrl.copy()]
            out.append(int(model.opt.disableflags))
            if k == 20:
                period = copy.deepcopy(period)  # unbound: its owner binds it
                period.bind(model, data, mujoco.mj_step, gel)
        out.append(list(calls))
        data.qvel[0] = math.nan
        out.append(period.stable())
    for overrides in ((), ("object.crush_force_n=0.5",), ("physics.gel_update=substep",)):
        sim = CoSimulation(scenarios.get("grasp", list(overrides)))
        sim._period = kernel.PeriodPhysics(*sim._period.__reduce__()[1])
        sim._bind_period()
        for _ in range(150):
            out.append(sim.advance())
            out.append((sim._period.left_peak, sim._period.right_peak))
    return out


#: Each case's row builder's inputs, captured from a simulation once (see _row_inputs).
_ROW_INPUTS: dict[tuple, tuple] = {}


def _row_inputs(overrides: tuple[str, ...]) -> tuple:
    """(the row builder's arguments, each control step's row inputs and the object's position,
    velocity and sensordata then) of 600 control steps of the grasp under ``overrides``:
    through touch, squeeze and the lift."""
    if overrides not in _ROW_INPUTS:
        from piezotip import scenarios
        from piezotip.cosim.loop import CoSimulation

        sim = CoSimulation(scenarios.get("grasp", list(overrides)))
        builder, steps = sim._row_builder, []

        class Capture:
            def row(self, time_s, obs, command, profiles, cells, finger_peaks):
                arrays = [np.array(a) for a in (sim._object_xpos, sim._object_qvel, sim._sensordata)]
                steps.append(((time_s, obs, command, profiles, cells, list(finger_peaks)), arrays))
                return builder.row(time_s, obs, command, profiles, cells, finger_peaks)

        sim._row_builder = Capture()
        for _ in range(600):
            sim.advance()
        _ROW_INPUTS[overrides] = (builder.__reduce__()[1], steps)
    return _ROW_INPUTS[overrides]


def drive_rows(kernel, perturb: bool = False) -> list:
    out = []
    cases = ((), ("object.crush_force_n=0.5",), ("sensor.coverage_mm=(2.0, 4.5)", "physics.pad_segments=3"))
    for overrides in cases:  # the fingers' peak forces in the row; profiles and cells of several values
        args, steps = _row_inputs(overrides)
        if perturb:
            args = (*args[:7], {status: index + 1.0 for status, index in args[7].items()})  # another status numbering
        builder = kernel.RowBuilder(*args)
        arrays = [np.array(a) for a in steps[0][1]]
        builder.bind(*arrays)
        for inputs, values in steps:
            for live, now in zip(arrays, values, strict=True):
                live[:] = now
            out.append(builder.row(*inputs))
    rng = np.random.default_rng(5)
    chunk = [rng.standard_normal(39).tolist() for _ in range(200)]
    chunk[3][4], chunk[7][0], chunk[9][1] = math.nan, -0.0, math.inf
    out += [kernel.stack_rows(chunk, 39), kernel.stack_rows([], 39), kernel.stack_rows([[1, 2.5, True]], 3)]
    return out


def _selector_estimates(p_max_pa: float, n: int, seed: int, edges_pa=()):
    """Estimates a selector meets: pressures over every band (log-uniform from well under the
    lowest mode's detection limit to past the highest's P_max), held, stepped and ramped, with
    settling, saturated, below-detection and non-finite readings among them; and a tenth of
    the time one of ``edges_pa`` (the switch thresholds and their neighbouring floats, where
    the comparisons' arithmetic decides)."""
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


SELECTOR_STATE = ("mode", "blind", "estimate_pa", "uncertainty_pa", "status", "trusted", "empty")
SELECTOR_STATE += ("_saturated", "_above_switch", "_under_switch")


def drive_control(kernel, perturb: bool = False) -> list:
    out = []
    tip = Fingertip()
    cases = (((1, 2, 3, 4), 0.25, 3, 0), ((1, 3), 0.1, 1, 1), ((2,), 0.25, 3, 2), ((1, 2, 3, 4), 0.0, 2, 3))
    for modes, hysteresis, persist, seed in cases:
        sel = kernel.ModeSelector(tip, modes, hysteresis, persist)
        out.append((sel.modes, sel.bands, sel.p_min_pa, sel.p_max_pa, sel.switch_pa))
        edges = []
        for s in sel.switch_pa.values():  # each threshold up and down, and the floats either side of it
            for threshold in (s * (1 + hysteresis), s * (1 - hysteresis)):
                edges += [math.nextafter(threshold, 0.0), threshold, math.nextafter(threshold, math.inf)]
        for k, estimate in enumerate(_selector_estimates(sel.p_max_pa[max(modes)], 3000, seed, tuple(edges))):
            if k == 1500:
                sel = copy.deepcopy(sel)  # a copy goes on as the original
            out.append((sel.update(estimate), *[getattr(sel, name) for name in SELECTOR_STATE]))
    rng = random.Random(7)
    for drift, alarm, single in ((0.5, 8.0, 6.0), (0.0, 3.0, 1e9), (2.0, 1e9, 4.0)):
        detector = kernel.TouchDetector(1e-3 * (ULP if perturb else 1.0), drift, alarm, single)
        for _ in range(20):
            detector.learn(1.0 + rng.gauss(0.0, 1e-3))
        out.append((detector.baseline, detector._sum, detector._count))
        for k in range(400):
            out.append((detector.update(1.0 - 2e-5 * k + rng.gauss(0.0, 1e-3)), detector.score, detector.touched))
            if k == 300:
                detector.rearm()
                detector = copy.deepcopy(detector)
    reading = Reading(2, 0.9, 0.91, -0.1, 1.0, 0.2, True, 1e3, 2.0, 0.9 + 0.01j)
    signal = kernel.make_pad_signal(reading, Estimate(120.0, 3.0, "ok"))
    out += [
        signal,
        kernel.make_observation(1.5, {"left_pad": signal}, 0.02, 0.05, 3.0, 2.0, -0.01),
        kernel.make_observation(1.5, {"left_pad": signal}, 0.02, 0.05, 3.0, 2.0),
        kernel.make_command(0.03, 0.0, 4.0, {"left_pad": 2}, interface.Phase.LIFT, "squeeze"),
    ]
    return out


_READOUT_XML = """<mujoco><worldbody><body name="palm" pos="0 0 .1"><geom type="box" size=".04 .02 .005"/>
<site name="a" type="box" size=".01 .01 .0055" pos="-.0125 0 .005"/><site name="b" type="box" size=".01 .01 .0055" pos=".0125 0 .005"/>
<site name="c" type="box" size=".00375 .0025 .001" pos=".03 0 .005"/></body>
<body name="box" pos="-.0125 0 .126"><freejoint/><geom type="box" size=".008 .008 .02" mass=".2"/></body></worldbody></mujoco>"""


def drive_readout(kernel, perturb: bool = False) -> list:
    """Every fingertip's sensor values and records, through ``kernel``'s pass in place of the
    bound fingertips' own: touch pads and gel pads (three strips a pad and one), a box resting,
    pressed past the gel's range and lifted off, noise and none, steady dynamics, a reset."""
    import mujoco

    from piezotip.cosim.attach import attach

    out = []
    for pad, sites, config in (
        ("touch", ["a", "b"], None),
        ("touch", ["a", "b", "c"], {"sensor.noise": False}),
        ("gel", ["a", "b"], None),
        ("gel", ["c", "a"], {"sensor.dynamics": "steady"}),
    ):
        spec = mujoco.MjSpec.from_string(_READOUT_XML)
        tips = attach(spec, sites=sites, pad=pad, config=config)
        model = spec.compile()
        data = mujoco.MjData(model)
        loop = tips.bind(model, data)
        hook = loop._hook
        if perturb and pad == "touch":
            hook._readers[sites[0]].area_m2 *= ULP  # the first pad's area one ulp up
        hook._new_pass = lambda _kind, hook=hook: type(hook)._new_pass(hook, kernel.ReadoutPass)
        hook._start()
        box = model.body("box").id
        for k in range(900):
            data.xfrc_applied[box, 2] = (0.0, -40.0, -2000.0, 6.0)[(k // 150) % 4]
            if k == 600:
                mujoco.mj_resetData(model, data)  # time goes back: the readout starts afresh
            mujoco.mj_step(model, data)
            out.append(data.sensordata.copy())
            if k % 50 == 49:
                p = hook._pass
                out += [list(p.readings), list(p.estimates), list(p.truths), list(p.pasts), p.values()]
        loop.step()
        out.append(loop.readings())
    return out


#: Each kernel's driver, by its module's name.
DRIVERS = {
    "piezotip.sensor._sampler": drive_sampler,
    "piezotip.sensor._estimator": drive_estimator,
    "piezotip.sensor._inference": drive_inference,
    "piezotip.sensor._channel": drive_channel,
    "piezotip.cosim._pad_kernels": drive_pad_kernels,
    "piezotip.cosim._period": drive_period,
    "piezotip.cosim._readout": drive_readout,
    "piezotip.cosim._rows": drive_rows,
    "piezotip.cosim.control._control": drive_control,
}


def test_every_kernel_has_a_driver():
    assert set(DRIVERS) == set(compiled.KERNELS)


@needs_the_build
def test_every_kernel_is_built_and_runs():
    """An install builds them (``pip install -e .``; setup.py): without them every run is slower
    and this fails, unless PIEZOTIP_PURE_PYTHON asks for the Python."""
    built = compiled.compiled_kernels()
    assert all(built.values()), f"not built (reinstall with a C compiler: pip install -e .): {[k for k, v in built.items() if not v]}"
    assert sampler.SAMPLER_COMPILED and estimator.INVERSE_COMPILED and inference.COMPILED
    classes = [sampler.ModeSampler, estimator.InverseCore, inference.SteadyInference, rows.RowBuilder, selector.ModeSelector]
    classes += [pad_kernels.GelForces, pad_kernels.PadPressures, pad_kernels.UniformPairTable, selector.TouchDetector, period.PeriodPhysics]
    classes += [ChannelCore]
    heap = [cls.__qualname__ for cls in classes if cls.__flags__ & (1 << 9)]  # Py_TPFLAGS_HEAPTYPE: a Python class
    assert not heap, f"compiled without their .pxd (Python classes, no C types): {heap}"
    assert pad_kernels.PAD_KERNELS_COMPILED and rows.ROWS_COMPILED and selector.SELECTOR_COMPILED and period.PERIOD_COMPILED
    from piezotip import scenarios
    from piezotip.cosim.loop import CoSimulation

    sim = CoSimulation(scenarios.get("grasp"))  # the loop runs them
    kernels = [sim.bridge._gel_forces, sim._pressure_reader, sim._row_builder, sim._period, *sim.channels.values()]
    kernels += [*next(iter(sim.channels.values()))._samplers.values(), *(ch._core for ch in sim.channels.values())]
    kernels += [*sim.controller.selectors.values(), *sim.controller.touch.values()]
    assert all(is_compiled(sys.modules[type(k).__module__]) for k in kernels if type(k).__module__ in compiled.KERNELS)
    expected = {"piezotip.cosim._pad_kernels", "piezotip.cosim._period", "piezotip.cosim._rows", "piezotip.sensor._sampler"}
    expected |= {"piezotip.sensor._channel"}
    assert {type(k).__module__ for k in kernels} >= expected


def test_pure_python_loads_every_kernel_from_its_source():
    """``PIEZOTIP_PURE_PYTHON=1``: every kernel is imported from its ``.py``, built or not."""
    script = "from piezotip.sensor import compiled; print(sorted(k for k, c in compiled.compiled_kernels().items() if not c))"
    env = {**os.environ, "PIEZOTIP_PURE_PYTHON": "1"}
    result = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
    assert result.stdout.strip() == repr(sorted(compiled.KERNELS))


@needs_the_build
@pytest.mark.parametrize("name", sorted(DRIVERS))
def test_the_compiled_kernel_is_its_source_run_as_python(name):
    built, source = importlib.import_module(name), source_module(name)
    assert is_compiled(built) and not is_compiled(source)
    expected, got = [exact(v) for v in DRIVERS[name](source)], [exact(v) for v in DRIVERS[name](built)]
    assert len(got) == len(expected)
    differing = [k for k, (a, b) in enumerate(zip(expected, got, strict=True)) if a != b]
    first = differing[0] if differing else None
    assert not differing, f"{len(differing)} outputs differ, first {first}: {expected[first]} as Python, {got[first]} compiled"


@needs_the_build
@pytest.mark.parametrize("name", sorted(DRIVERS))
def test_each_comparison_can_fail(name):
    """One input one ulp off (or, for the row, another status numbering) gives other outputs:
    the comparison above sees the last bit of what each driver exercises."""
    built = importlib.import_module(name)
    assert [exact(v) for v in DRIVERS[name](built)] != [exact(v) for v in DRIVERS[name](built, perturb=True)]


def test_the_comparison_tells_every_bit():
    assert exact(0.0) != exact(-0.0) and exact(1.0) != exact(math.nextafter(1.0, 2.0)) and exact(1) != exact(1.0)
    assert exact(float("nan")) != exact(-float("nan")) and exact(complex(0.0, -0.0)) != exact(0j)
    assert exact(Estimate(1.0, 2.0, "ok")) != exact(Estimate(1.0, 2.0, "saturated"))


# -- whichever runs: the inference's window, copies, checks, rows, records ----------------------


def _kernel(name: str, run: str):
    """The kernel module ``name`` as it runs ("built": compiled where it is) or its source run as Python."""
    return importlib.import_module(name) if run == "built" else source_module(name)


def test_the_inference_sequence_exercises_restarts_ramps_and_trust():
    """The drivers' readings do what they are meant to: restarts and ramps (untrusted: since
    RAMP_SUSPECT_CHI2 a reading under a ramp is, a fifth to two fifths of these) and trusted
    fits, most of them."""
    inf = inference.SteadyInference(TAU0_S, SIGMA)
    inf.seed(1 + 0j, 0.0, 0.005)
    out = [inf.step(t, a) for t, a in _readings(7000, 0.005, False, seed=3)]
    trusted = sum(1 for _, _, ok in out if ok)
    assert 0 < 7000 - trusted < 7000 // 2 < trusted
    assert sum(1 for a, _, _ in out if math.isnan(a.real)) > 10  # restarts at changes


def test_pickled_kernels_go_on_as_their_originals():
    inf = inference.SteadyInference(TAU0_S, SIGMA)
    inf.seed(1 + 0j, 0.0, 0.005)
    stream = list(_readings(900, 0.005, False, seed=5))
    for t, a in stream[:800]:
        inf.step(t, a)
    twin = pickle.loads(pickle.dumps(inf))
    assert [exact(twin.step(t, a)) for t, a in stream[800:]] == [exact(inf.step(t, a)) for t, a in stream[800:]]
    s = sampler.ModeSampler(*_sampler_args(2, 1, True))
    s.sample([400.0], 0j, 0.005, 0.005, None)
    twin = pickle.loads(pickle.dumps(s))
    assert (twin.lookups, twin.unloaded_samples) == (s.lookups, s.unloaded_samples) == (1, 0)
    assert exact(twin.sample([0.0], 0.5j, 0.005, 0.01, 0.3 - 0.1j)) == exact(s.sample([0.0], 0.5j, 0.005, 0.01, 0.3 - 0.1j))
    core = estimator.InverseCore(*_inverse_args(1))
    assert exact(pickle.loads(pickle.dumps(core)).inferred(0.99, 1.5)) == exact(core.inferred(0.99, 1.5))
    table = pad_kernels.UniformPairTable(*_gel_table())
    assert pickle.loads(pickle.dumps(table)).at(1e-4) == table.at(1e-4)
    ch = SensorChannel(Fingertip(), rng=np.random.default_rng(2))
    for p in (0.0, 500.0, 500.0):
        ch.estimate(ch.update_trusted([p], 0.005))
    twin = pickle.loads(pickle.dumps(ch._core))
    assert [exact(twin.sample([700.0], 0.005)) for _ in range(50)] == [exact(ch._core.sample([700.0], 0.005)) for _ in range(50)]


def test_the_pad_kernels_check_their_input_and_come_unbound():
    columns = _gel_table()
    for cls in (pad_kernels.PadPressures,):
        with pytest.raises(ValueError, match="do not make pads"):
            cls(columns, [0, 1, 2], 2, [0], [[(0, 1.0)]])
        with pytest.raises(ValueError, match="weight indices"):
            cls(columns, [0, 1], 2, [0], [[(2, 1.0)]])
        with pytest.raises(ValueError, match="at least one"):
            cls(columns, [0, 1], 2, [0], [[]])
        with pytest.raises(ValueError, match="qpos indices"):
            cls(columns, [0, 9], 2, [0], [[(1, 1.0)]]).bind(np.zeros(5))
        with pytest.raises(RuntimeError, match="bind"):
            pickle.loads(pickle.dumps(cls(columns, [0, 1], 2, [0], [[(1, 1.0)]]))).read()
    with pytest.raises(ValueError, match="dof indices"):
        pad_kernels.GelForces(columns, [0], [7], [0], [1e-5], [0.0]).bind(np.zeros(3), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="a spring reference"):
        pad_kernels.GelForces(columns, [0], [0, 1], [0], [1e-5], [0.0])
    with pytest.raises(RuntimeError, match="bind"):
        pickle.loads(pickle.dumps(pad_kernels.GelForces(columns, [0], [0], [0], [1e-5], [0.0]))).apply()
    with pytest.raises(ValueError, match="strictly increasing"):
        pad_kernels.UniformPairTable([0.0, 0.0, 1.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0])


def test_the_row_builder_checks_its_arrays_and_comes_unbound():
    builder = rows.RowBuilder(["left_pad"], [5], [1, 3], 7, False, [1.0], 1e5, {"ok": 0.0})
    with pytest.raises(ValueError, match="outside"):
        builder.bind(np.zeros(3), np.zeros(6), np.zeros(8))
    with pytest.raises(ValueError, match="contiguous"):
        builder.bind(np.zeros(6)[::2], np.zeros(6), np.zeros(12))
    with pytest.raises(RuntimeError, match="bind"):
        pickle.loads(pickle.dumps(builder)).row(0.0, None, None, [[1.0]], [[1.0]], ())


def test_stacking_rows_is_numpys():
    rng = np.random.default_rng(5)
    chunk = [rng.standard_normal(39).tolist() for _ in range(500)]
    chunk[3][4], chunk[7][0], chunk[9][1] = math.nan, -0.0, math.inf
    table = rows.stack_rows(chunk, 39)
    assert table.dtype == np.float64 and table.tobytes() == np.asarray(chunk, dtype=float).tobytes()
    assert rows.stack_rows([], 39).shape == (0, 39)
    mixed = [[1, 2.5, True]]  # not all floats: numpy's own conversion
    assert rows.stack_rows(mixed, 3).tobytes() == np.asarray(mixed, dtype=float).tobytes()
    with pytest.raises(ValueError):
        rows.stack_rows([[1.0, 2.0], [1.0]], 2)
    with pytest.raises(ValueError, match="rows of 3 values"):
        rows.stack_rows([[1.0, 2.0]], 3)


@pytest.mark.parametrize("records", [True, False], ids=["records", "other objects"])
@pytest.mark.parametrize("run", ["built", "source"])
def test_each_value_of_a_row_lands_under_its_column_name(run, records):
    """row_columns and the row builder agree, column by column: a row made from distinct, known
    values reads each back under its name, from the step's records (read by their slots where
    compiled) and from any objects with those attributes; the gel sits on its stop exactly from
    the stop's pressure on (``bottomed``)."""
    kernel = _kernel("piezotip.cosim._rows", run)
    stop_pa = 1000.0
    columns = rows.row_columns(["left_pad", "right_pad"], 2, True)
    status_index = {status: float(i) for i, status in enumerate(rows.STATUS_CODES)}
    xpos, qvel = np.array([0.1, 0.2, 0.3]), np.array([0.0, 0.0, -2.0, 3.0, 0.0, 4.0])
    sensordata = np.arange(20, dtype=float) - 30.0  # negative: the row records magnitudes

    def make(cls, *values):
        return cls(*values) if records else NS(**dict(zip(cls.__dataclass_fields__, values, strict=True)))

    signals = {
        "left_pad": make(
            interface.PadSignal,
            make(Reading, 2, 0.8, 0.81, 0.0, 1.0, 0.1, True, 1.0, 1.0, 0.8 + 0j),
            make(Estimate, 500.0, 5.0, "ok"),
        ),
        "right_pad": make(
            interface.PadSignal,
            make(Reading, 3, 0.9, 0.91, 0.0, 1.0, 0.1, False, 1.0, 1.0, 0.9 + 0j),
            make(Estimate, math.nan, math.nan, "settling"),
        ),
    }
    obs = make(interface.Observation, 1.0, signals, 0.01, 0.02, 2.5, 1.5, 0.0)
    command = NS(phase=4)
    profiles, cells = [[999.0, 998.0], [1000.0, 10.0]], [[100.0, 300.0], [7.0, 9.0]]
    builder = kernel.RowBuilder(["left_pad", "right_pad"], [5, 6], [1, 3], 7, True, [0.25, 0.75], stop_pa, status_index)
    builder.bind(xpos, qvel, sensordata)
    row = dict(zip(columns, builder.row(1.25, obs, command, profiles, cells, (11.0, 12.0)), strict=True))
    assert (row["time_s"], row["phase"], row["lift_m"], row["opening_m"]) == (1.25, 4.0, 0.01, 0.02)
    assert (row["grip_force_n"], row["lift_force_n"]) == (1.5, 2.5)
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


@pytest.mark.parametrize("run", ["built", "source"])
def test_a_touch_detector_with_no_noise_refuses_to_divide(run):
    kernel = _kernel("piezotip.cosim.control._control", run)
    detector = kernel.TouchDetector(0.0)
    detector.learn(1.0)
    with pytest.raises(ZeroDivisionError):
        detector.update(0.5)


def test_the_sampler_s_response_is_eq_10_and_the_envelope_rate():
    """The sampler spells out :func:`sensor.equations.normalized_response` and
    :func:`sensor.resonator._rate` (C calls, compiled): the same floats, bit for bit."""
    from piezotip.sensor.equations import normalized_response

    s = source_module("piezotip.sensor._sampler").ModeSampler(*_sampler_args(2, 1, True))
    rng = np.random.default_rng(3)
    for kappa, gamma in [(0.0, 0.0), (-0.0, -0.0), *(10 ** rng.uniform([-3, -6], [7, 1], (500, 2))).tolist()]:
        steady, rate, tau = s._response(kappa, gamma)
        expected = resonator._rate(s._rho_a, s._omega, s._c, kappa, gamma)
        assert exact((steady, rate, tau)) == exact((normalized_response(kappa, gamma, s._omega, s._c), expected, 1.0 / expected.real))


def test_record_maker_takes_every_field_of_a_slots_dataclass():
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


@pytest.mark.parametrize("run", ["built", "source"])
def test_the_records_made_by_slots_are_the_dataclasses(run):
    from dataclasses import FrozenInstanceError

    from piezotip.cosim.control import Command, Observation, PadSignal, Phase

    control = _kernel("piezotip.cosim.control._control", run)
    reading = Reading(2, 0.9, 0.91, -0.1, 1.0, 0.2, True, 1e3, 2.0, 0.9 + 0.01j)
    estimate = Estimate(120.0, 3.0, "ok")
    pads = {"left_pad": None}
    made = {
        "signal": ((reading, estimate), PadSignal, [control.make_pad_signal]),
        "observation": ((1.5, pads, 0.02, 0.05, 3.0, 2.0, -0.01), Observation, [control.make_observation]),
        "default velocity": ((1.5, pads, 0.02, 0.05, 3.0, 2.0), Observation, [control.make_observation]),
        "command": ((0.03, 0.0, 4.0, {"left_pad": 2}, Phase.LIFT, "squeeze"), Command, [control.make_command]),
        "reading": (tuple(getattr(reading, f.name) for f in dataclasses.fields(reading)), Reading, [resonator._reading]),
        "estimate": ((120.0, 3.0, "ok"), Estimate, [estimator._estimate]),
    }
    for name, (args, cls, makers) in made.items():
        expected = cls(*args)
        for make in makers:
            record = make(*args)
            assert type(record) is cls and record == expected, name
            assert not hasattr(record, "__dict__"), name  # slots: one allocation, no instance dict
            assert exact(record) == exact(expected), name
            with pytest.raises(FrozenInstanceError):
                record.__setattr__(next(iter(expected.__dataclass_fields__)), 0.0)
            assert pickle.loads(pickle.dumps(record)) == expected
    # The sampler's readings and the inverse's estimates are such records too.
    kernel = _kernel("piezotip.sensor._sampler", run)
    reading, _ = kernel.ModeSampler(*_sampler_args(1, 1, True)).sample([300.0], 1 + 0j, 0.005, 1.0, 0.1 + 0.2j)
    assert type(reading) is Reading and pickle.loads(pickle.dumps(reading)) == reading


@pytest.mark.parametrize("run", ["built", "source"])
def test_a_fingers_contact_tilt_is_its_normal_forces_resultants(run):
    """The row's ``{side}_contact_tilt_rad``: the tilt below the horizontal of sum_i N_i n_i over
    the contacts the finger's sensor found (found, force in the contact frame, normal: 7 values a
    contact), not its strongest contact's.  Closed form: normal forces 3 and 1 along normals
    tilted -a and +b (a, b below the horizontal) give atan((3 sin a - sin b) / (3 cos a + cos b))
    upward; slots past those found, and a finger with none, do not count."""
    kernel = _kernel("piezotip.cosim._rows", run)
    a, b = math.radians(7.0), math.radians(3.0)
    columns = rows.row_columns(["left_pad"], 1, False)
    status_index = {status: float(i) for i, status in enumerate(rows.STATUS_CODES)}
    slots = 3
    # found, force (normal first), normal (world, from the finger into the object): left finger at +x
    left = [2.0, 3.0, 0.1, 0.2, math.cos(a), 0.0, math.sin(a)]  # pressing up: the normal points up (+z)
    left += [2.0, 1.0, 0.0, 0.0, math.cos(b), 0.0, -math.sin(b)]  # pressing down
    left += [2.0, 50.0, 0.0, 0.0, 0.0, 0.0, 1.0]  # past the two found: not counted
    right = [0.0] * (7 * slots)  # none found
    head = [0.0] * 10
    sensordata = np.array(head + left + right, dtype=float)
    builder = kernel.RowBuilder(["left_pad"], [5], [1, 3], 7, False, [1.0], 1e5, status_index, None, [10, 10 + 7 * slots], slots)
    builder.bind(np.zeros(3), np.zeros(6), sensordata)
    reading = Reading(1, 1.0, 1.0, 0.0, 1.0, 0.1, True, 1.0, 1.0, 1.0 + 0j)
    sig = interface.PadSignal(reading, Estimate(math.nan, math.nan, "below_detection"))
    obs = interface.Observation(0.0, {"left_pad": sig}, 0.0, 0.0, 0.0, 0.0, 0.0)
    row = dict(zip(columns, builder.row(0.0, obs, NS(phase=0), [[0.0]], [[0.0]], ()), strict=True))
    expected = -math.atan2(3 * math.sin(a) - math.sin(b), 3 * math.cos(a) + math.cos(b))  # up: a negative tilt
    assert row["left_contact_tilt_rad"] == pytest.approx(expected, abs=1e-15)
    assert math.isnan(row["right_contact_tilt_rad"])
    strongest = -a  # what the strongest contact alone said
    assert abs(row["left_contact_tilt_rad"] - strongest) > math.radians(2.0)
    with pytest.raises(ValueError, match="normal_slots"):
        kernel.RowBuilder(["left_pad"], [5], [1, 3], 7, False, [1.0], 1e5, status_index, None, [10, 31], 0)

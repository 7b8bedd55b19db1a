"""The co-simulation loop: one control step, in the order the data flows.

    physics -> pad pressure -> gel -> sensor -> readout -> controller -> actuators -> record

:meth:`CoSimulation.step` is that order, in one screen.  Everything a step needs (ids,
tables, modal integrals) is prepared once in the constructor.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from scenarios.config import ScenarioConfig
from sensor import ElementParams, Fingertip, GelModel, SensorElement
from sensor.channel import SensorChannel

from .controller import Command, Observation, PadSignal, ScriptedGrasp, phase_index
from .pads import PAD_NAMES, PadBridge
from .recorder import Recorder
from .scene import build_scene, finite_state, object_height_m, reset_home


class SimulationDiverged(RuntimeError):
    """The physics produced a warning or a non-finite state; the message says which and when."""


def make_fingertip(config: ScenarioConfig) -> Fingertip:
    """The scenario's Fingertip: Table I element (or the configured Q), gel, coverage, modes."""
    s = config.sensor
    element = SensorElement(ElementParams())
    if s.quality_factor is not None:
        element = element.with_quality_factor(s.quality_factor)
    gel = GelModel(frequency_dependent=s.gel_frequency_dependent, reference_freq_hz=element.natural_frequency_hz(s.modes[0]))
    coverage = (s.coverage_mm[0] * 1e-3, s.coverage_mm[1] * 1e-3)
    return Fingertip(element=element, gel=gel, coverage=coverage, modes=s.modes)


def make_controller(config: ScenarioConfig, home: dict[str, float], fingertip: Fingertip):
    """The scenario's controller."""
    c = config.controller
    pads = tuple(f"{p}_pad" for p in config.sensor.pads)
    if c.kind == "scripted":
        return ScriptedGrasp(c, home["lift_m"], home["opening_m"], pads)
    from .grasp import MultimodeGrasp

    return MultimodeGrasp(c, home["lift_m"], home["opening_m"], pads, fingertip)


@dataclass(frozen=True)
class RunResult:
    """What a finished (or stopped) run produced.

    Attributes
    ----------
    steps : control steps simulated.
    sim_time_s : simulated time, s.
    wall_time_s : wall-clock time of the loop, s.
    files : files written.
    error : the message of the error that stopped the run, or None.
    """

    steps: int
    sim_time_s: float
    wall_time_s: float
    files: list[Path]
    error: str | None


class CoSimulation:
    """One scenario, stepped at the control period with physics substeps.

    Parameters
    ----------
    config : the scenario's whole configuration (validated here).
    """

    def __init__(self, config: ScenarioConfig) -> None:
        self.config = config.validate()
        self.model = build_scene(config)
        self.data = mujoco.MjData(self.model)
        self.home = reset_home(self.model, self.data, config)
        self.fingertip = make_fingertip(config)
        self.bridge = PadBridge(self.model, gel=self.fingertip.gel)
        self.dt = config.physics.control_period_s
        self.substeps = config.physics.substeps
        # The element's x runs from its clamped root (palm side) to its free tip (distal);
        # the bridge orders strips from the distal end up, so a profile is reversed.
        n = self.bridge.geometry.segments
        length = self.fingertip.element.params.length_m
        edges = np.linspace(0.0, length, n + 1)
        rng = np.random.default_rng(config.sensor.seed)
        self.pads = tuple(f"{p}_pad" for p in config.sensor.pads)
        self._pad_rows = [PAD_NAMES.index(p) for p in self.pads]
        self.channels = {
            pad: SensorChannel(
                self.fingertip,
                edges_m=edges,
                dynamics=config.sensor.dynamics,
                noise=config.sensor.noise,
                rng=np.random.default_rng(rng.integers(2**63)),
            )
            for pad in self.pads
        }
        self.controller = make_controller(config, self.home, self.fingertip)
        m = self.model
        self._lift_qpos = m.joint("lift_joint").qposadr[0]
        self._finger_qpos = [m.joint(f"{s}_finger_joint").qposadr[0] for s in ("left", "right")]
        self._lift_act = m.actuator("lift_actuator").id
        self._finger_act = m.actuator("fingers_actuator").id
        self.time_s = 0.0
        self.steps = 0
        self._start_object_height = object_height_m(m, self.data)
        self._finger_limit = float(m.actuator_forcerange[self._finger_act, 1])
        # Ground truth for the referee and the record (never in the Observation): each
        # finger's net contact force, world x is the closing direction ("found" then force).
        self._contact_adr = {pad: m.sensor(f"{pad.removesuffix('_pad')}_finger_contact").adr[0] + 1 for pad in self.pads}

    # -- one control step --------------------------------------------------------------

    def step(self) -> dict[str, float]:
        """Advance one control period; return the recorded row."""
        m, d = self.model, self.data
        # 1. physics (the gel's law acts on the pad joints every substep)
        for _ in range(self.substeps):
            self.bridge.apply_gel_forces(d)
            mujoco.mj_step(m, d)
        self._check_stable()
        self.time_s += self.dt
        self.steps += 1
        # 2. pad pressure along each element (Pa), root to tip
        pressures = self.bridge.element_pressures(d)[:, ::-1]
        # 3-5. gel -> sensor (envelope) -> readout (inverse)
        signals = {}
        for pad, row in zip(self.pads, self._pad_rows, strict=True):
            channel = self.channels[pad]
            reading = channel.update(pressures[row], self.dt)
            signals[pad] = PadSignal(reading, channel.estimate(reading))
        # 6. controller (sensors and proprioception only)
        obs = self._observe(signals)
        command = self.controller.step(obs, self.dt)
        # 7. actuators and drive modes
        self._actuate(command)
        # 8. record
        return self._row(obs, command, pressures)

    def _observe(self, signals: dict[str, PadSignal]) -> Observation:
        d = self.data
        return Observation(
            time_s=self.time_s,
            pads=signals,
            lift_pos_m=float(d.qpos[self._lift_qpos]),
            opening_m=float(d.qpos[self._finger_qpos[0]] + d.qpos[self._finger_qpos[1]]),
            lift_force_n=float(d.actuator_force[self._lift_act]),
            grip_force_n=-float(d.actuator_force[self._finger_act]),
        )

    def _actuate(self, command: Command) -> None:
        m, d = self.model, self.data
        d.ctrl[self._lift_act] = command.lift_m
        d.ctrl[self._finger_act] = command.opening_m
        limit = min(max(command.grip_force_limit_n, 0.0), self._finger_limit)
        m.actuator_forcerange[self._finger_act] = (-limit, limit)
        for pad, mode in command.modes.items():
            self.channels[pad].select_mode(mode)

    def _check_stable(self) -> None:
        d = self.data
        warned = [mujoco.mjtWarning(i).name for i in range(len(d.warning)) if d.warning[i].number > 0]
        if warned or not finite_state(d):
            what = ", ".join(warned) if warned else "non-finite state (NaN or inf in qpos/qvel)"
            raise SimulationDiverged(
                f"simulation diverged at t = {d.time:.4f} s: {what} "
                f"(timestep {self.model.opt.timestep:g} s, integrator {self.config.physics.integrator})"
            )

    def _row(self, obs: Observation, command: Command, pressures: np.ndarray) -> dict[str, float]:
        m, d = self.model, self.data
        row = {
            "time_s": self.time_s,
            "phase": float(phase_index(command.phase)) if command.phase else -1.0,
            "lift_m": obs.lift_pos_m,
            "opening_m": obs.opening_m,
            "grip_force_n": obs.grip_force_n,
            "lift_force_n": obs.lift_force_n,
            "object_height_m": object_height_m(m, d),
        }
        for pad, prow in zip(self.pads, self._pad_rows, strict=True):
            side = pad.removesuffix("_pad")
            sig = obs.pads[pad]
            r, e = sig.reading, sig.estimate
            row[f"{side}_true_pressure_pa"] = float(np.mean(pressures[prow]))
            row[f"{side}_contact_force_n"] = abs(float(d.sensordata[self._contact_adr[pad]]))
            row[f"{side}_estimate_pa"] = e.pressure_pa
            row[f"{side}_uncertainty_pa"] = e.uncertainty_pa
            row[f"{side}_status"] = float(_STATUS.index(e.status))
            row[f"{side}_mode"] = float(r.mode)
            row[f"{side}_v1"] = r.v1
            row[f"{side}_v1_true"] = r.v1_true
            row[f"{side}_settled"] = float(r.settled)
            for k, p in enumerate(pressures[prow]):
                row[f"{side}_cell{k}_pressure_pa"] = float(p)
        return row

    # -- a whole run ---------------------------------------------------------------------

    def run(self, recorder: Recorder | None = None, progress=None, max_steps: int | None = None, on_step=None) -> RunResult:
        """Step until the scenario's duration (or the controller finishes); record every step.

        ``on_step(sim)`` is called after every step (e.g. to render frames).  Errors (a
        divergence, Ctrl-C) stop the run; what was recorded is kept (the recorder is closed in
        any case) and a divergence's message is in ``RunResult.error`` (a KeyboardInterrupt
        propagates after the files are written).
        """
        total = max_steps if max_steps is not None else math.ceil(self.config.duration_s / self.dt - 1e-9)
        start = time.perf_counter()
        error = None
        try:
            for _ in range(total):
                row = self.step()
                if recorder is not None:
                    recorder.append(row)
                if progress is not None:
                    progress.update(1)
                if on_step is not None:
                    on_step(self)
                if getattr(self.controller, "finished", False):
                    break
        except SimulationDiverged as err:
            error = str(err)
        finally:
            wall = time.perf_counter() - start
            files = recorder.close() if recorder is not None else []
        return RunResult(self.steps, self.time_s, wall, files, error)


#: Readout statuses, recorded as their index.
_STATUS = ("ok", "below_detection", "saturated", "settling")
STATUSES = _STATUS

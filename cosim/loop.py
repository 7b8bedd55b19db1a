"""The co-simulation loop: one control step, in the order the data flows.

    physics -> pad pressure -> gel -> sensor -> readout -> controller -> actuators -> record

:meth:`CoSimulation.advance` is that order, in one screen, one method per stage (which
``run_sim.py bench`` times one by one); :meth:`CoSimulation.step` returns its row as a dict.
Everything a step needs (ids, tables, modal integrals, views of MuJoCo's arrays) is prepared
once in the constructor, and the per-step path works on Python floats: for a handful of
numbers, numpy's per-call overhead would cost more than MuJoCo's step itself.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from piezotip.cosim.build_checks import check_buildable
from piezotip.cosim.config import ScenarioConfig
from piezotip.sensor import Fingertip
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.resonator import Reading
from piezotip.sensor.spread import spread_weights

from .assembly import build_scene
from .control import Command, Controller, Observation, PadSignal, RobotLimits, make_observation, make_pad_signal
from .disturb import LoadDisturbance
from .instrument import make_channels, make_fingertip, make_unit
from .pad_bridge import PadBridge
from .pad_geometry import PAD_NAMES, PAD_SIDES, PadGeometry
from .period import PeriodPhysics
from .recorder import Recorder
from .rows import _STATUS_INDEX, RowBuilder, row_columns
from .scene import check_reach, finite_state, gravity_m_s2, reset_home, robot_limits


class SimulationDiverged(RuntimeError):
    """The physics produced a warning or a non-finite state; the message says which and when."""


def make_controller(config: ScenarioConfig, robot: RobotLimits, fingertip: Fingertip) -> Controller:
    """The scenario's controller: the class registered as its ``controller.kind``
    (:mod:`piezotip.controllers`), built from the scenario (the multimode ones first run the
    element's self-test); a ``MODULE:CLASS`` kind is imported here, in whichever process runs it."""
    from .control import registry

    return registry.get(config.controller.kind).controller.from_scenario(config, robot, fingertip)


#: After the controller finishes, the recording goes on at least this long, s, and until the
#: object is at rest (so a drop is recorded), at most REST_MAX_S.
REST_MIN_S = 0.3
REST_MAX_S = 3.0
#: The object is at rest below these speeds: 1 mm/s and 0.05 rad/s.
REST_SPEED_M_S = 1e-3
REST_SPIN_RAD_S = 0.05


def coverage_cells(strip_edges_m: np.ndarray, coverage: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Cells of the gel-covered part of the element, and the pad strip each lies under.

    The pad's strips tile the element's length (``strip_edges_m``, root to tip, m); the gel
    touches the element over ``coverage`` = (x1, x2) only.  Returns the cell edges (the
    coverage cut at the strip edges inside it, m) and, per cell, the index of its strip, so a
    strip-pressure profile ``p`` becomes the cells' profile ``p[index]``.
    """
    x1, x2 = coverage
    inner = strip_edges_m[(strip_edges_m > x1) & (strip_edges_m < x2)]
    edges = np.concatenate([[x1], inner, [x2]])
    mids = 0.5 * (edges[1:] + edges[:-1])
    index = np.clip(np.searchsorted(strip_edges_m, mids) - 1, 0, strip_edges_m.size - 2)
    return edges, index


def coverage_weights(
    geometry: PadGeometry, element_length_m: float, cell_edges_m: np.ndarray, depth_m: float
) -> list[list[tuple[int, float]]]:
    """What each coverage cell feels of the pad's strips: per cell, (strip, weight) pairs whose
    weighted sum of strip pressures is the cell's mean pressure (sensor.spread, eq. S4).

    The element lies centred under the pad, its x running from the clamped root (palm side,
    z = +L/2) to the free tip (distal, z = -L/2): x = L/2 - z.  Strips are indexed as the pad
    lists them (distal first, guards included); ``cell_edges_m`` are the element's x (m);
    ``depth_m`` the gel's thickness (0: each cell feels the strip above it only).  Pairs of
    zero weight are left out.
    """
    z_edges = geometry.strip_edges_m  # distal first: x decreasing
    x_edges = (0.5 * element_length_m - z_edges)[::-1]
    weights = spread_weights(x_edges, cell_edges_m, depth_m)
    last = len(z_edges) - 2  # x-ordered column j is strip last - j
    return [[(last - j, float(w)) for j, w in enumerate(row) if w > 0.0] for row in weights]


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
    interrupted : whether Ctrl-C (KeyboardInterrupt) stopped the run.
    """

    steps: int
    sim_time_s: float
    wall_time_s: float
    files: list[Path]
    error: str | None
    interrupted: bool = False


class HouseDrive:
    """The house gripper's fingers: one position servo on their opening (``fingers_actuator``),
    its force range the grip's limit.  The stages of :class:`CoSimulation` that touch the fingers
    run through a drive object (this, or :class:`MountedDrive`), each given the simulation: its
    per-step views and state are the simulation's (:meth:`CoSimulation._prepare_step`); a drive
    holds nothing of its own, so a copied simulation's drive is its copy's."""

    def physics(self, sim: CoSimulation) -> None:
        """One control period: the lift's and fingers' set-points interpolated over its substeps."""
        # The servos interpolate their set-points over the period, as real servos do between a
        # controller's set-points: a lift target that jumped once per period would make the
        # servo's force ripple by kp v T (10 N at 0.1 m/s) and hide the load it carries, and
        # fingers moved in jerks press their own gel on the pascal-sensitive element.  With
        # gel_update=period the gel's law is linearized once per control period: the bridge's
        # tangent stiffness and offset force make MuJoCo apply -A P(q0) - A P'(q0) (q - q0) at
        # every substep (implicitly), no gel law in Python between.  MuJoCo's sensors (the
        # referee's ground truth, read by _record alone) are computed in the period's last
        # substep only: they never act on the dynamics.  For an object with a crush limit they
        # run in every substep, for the fingers' peak force (PEAK_COLUMNS).  (cosim/_period.py)
        stable = sim._period.run(sim._lift_from, sim._lift_to, sim._fingers_from, sim._fingers_to)
        sim._after_period(stable)

    def observe(self, sim: CoSimulation, signals: dict[str, PadSignal]) -> Observation:
        """The observation: the opening from the two finger joints, the grip the servo's force."""
        qpos, force = sim._qpos, sim._actuator_force
        return make_observation(
            time_s=sim.time_s,
            pads=signals,
            lift_pos_m=qpos[sim._lift_q],
            opening_m=qpos[sim._finger_q[0]] + qpos[sim._finger_q[1]],
            lift_force_n=force[sim._lift_act],
            grip_force_n=-force[sim._finger_act],
            lift_vel_m_s=sim._qvel[sim._lift_dof_i],
        )

    def actuate(self, sim: CoSimulation, command: Command) -> None:
        """The lift's and the opening's targets for the next period, the grip's limit the servo's force range."""
        sim._lift_to = command.lift_m  # both reached over the next period (physics)
        sim._fingers_to = command.opening_m
        limit = min(max(command.grip_force_limit_n, 0.0), sim._finger_limit)
        forcerange = sim._forcerange
        forcerange[sim._finger_act, 0] = -limit
        forcerange[sim._finger_act, 1] = limit

    def model_settings(self, sim: CoSimulation) -> tuple[np.ndarray, np.ndarray, int]:
        """The pad joints' stiffness, the finger servo's force range and the disable flags, copied."""
        m = sim.model
        return m.jnt_stiffness[sim.bridge.joint_ids].copy(), m.actuator_forcerange[sim._finger_act].copy(), int(m.opt.disableflags)

    def apply_model_settings(self, sim: CoSimulation, settings: tuple[np.ndarray, np.ndarray, int]) -> None:
        m = sim.model
        stiffness, forcerange, flags = settings
        m.jnt_stiffness[sim.bridge.joint_ids] = stiffness
        m.actuator_forcerange[sim._finger_act] = forcerange
        m.opt.disableflags = flags


class MountedDrive:
    """A mounted gripper's fingers (``gripper.mjcf``; :class:`cosim.gripper_mount.MountedGripper`'s
    ``drive``): its actuators' commands for the opening target, their force limits for the grip
    (each within its rating), the opening and the grip read through its drive."""

    def physics(self, sim: CoSimulation) -> None:
        """One period, each actuator's command interpolated from the drive's commands for the last
        opening target to the new one's."""
        stable = sim._period.run_drive(sim._lift_from, sim._lift_to, sim._fingers_from, sim._fingers_to)
        sim._after_period(stable)

    def observe(self, sim: CoSimulation, signals: dict[str, PadSignal]) -> Observation:
        d, drive = sim.data, sim.mounted.drive
        return make_observation(
            time_s=sim.time_s,
            pads=signals,
            lift_pos_m=float(d.qpos[sim._lift_qpos]),
            opening_m=drive.opening_m(d),
            lift_force_n=float(d.actuator_force[sim._lift_act]),
            grip_force_n=drive.grip_force_n(d),
            lift_vel_m_s=float(d.qvel[sim._lift_dof]),
        )

    def actuate(self, sim: CoSimulation, command: Command) -> None:
        drive = sim.mounted.drive
        sim._lift_to = command.lift_m
        limit = min(max(command.grip_force_limit_n, 0.0), sim._finger_limit)
        opening = drive.opening_m(sim.data)
        sim._fingers_to = drive.ctrl_for(command.opening_m, limit, opening)
        sim.model.actuator_forcerange[drive.actuators] = np.column_stack(drive.force_limits(limit, opening))

    def model_settings(self, sim: CoSimulation) -> tuple[np.ndarray, np.ndarray, int]:
        """As the house's, with every finger actuator's force range."""
        m, actuators = sim.model, sim.mounted.drive.actuators
        return m.jnt_stiffness[sim.bridge.joint_ids].copy(), m.actuator_forcerange[actuators].copy(), int(m.opt.disableflags)

    def apply_model_settings(self, sim: CoSimulation, settings: tuple[np.ndarray, np.ndarray, int]) -> None:
        stiffness, forcerange, flags = settings
        sim.model.jnt_stiffness[sim.bridge.joint_ids] = stiffness
        sim.model.actuator_forcerange[sim.mounted.drive.actuators] = forcerange
        sim.model.opt.disableflags = flags


class CoSimulation:
    """One scenario, stepped at the control period with physics substeps.

    Parameters
    ----------
    config : the scenario's whole configuration (validated here).
    """

    def __init__(self, config: ScenarioConfig) -> None:
        self.config = check_buildable(config.validate())  # once per gripper file and sensor (cached)
        self.mounted = None  # a third-party gripper on the lift (gripper.mjcf), or None: the house's
        if config.gripper.mjcf is None:
            self.model = build_scene(config)
            self.data = mujoco.MjData(self.model)
            self.home = reset_home(self.model, self.data, config)
            self.fingertip = make_fingertip(config)
            self.unit = make_unit(config)  # the physical unit, when it is not the model itself
            self.bridge = PadBridge(self.model, gel=self.fingertip.gel)
            self.robot = robot_limits(self.model, self.home, self.bridge.geometry, self.fingertip.gel.params)
        else:
            self._mount(config)
        check_reach(config, self.robot)  # before the sensor's set-up: a bad lift fails fast
        self.dt = config.physics.control_period_s
        self._gel_every_substep = config.physics.gel_update == "substep"
        self.substeps = config.physics.substeps
        # The element's x runs from its clamped root (palm side) to its free tip (distal);
        # the bridge orders strips from the distal end up, so a profile is reversed.
        n = self.bridge.geometry.segments
        length = self.fingertip.element.params.length_m
        coverage = self.unit.coverage if self.unit is not None else self.fingertip.coverage  # where the gel touches
        edges, _ = coverage_cells(np.linspace(0.0, length, n + 1), coverage)
        # With a spreading layer every coverage cell feels the whole pad's face (guards too);
        # without, the strip above it alone (a weight of exactly 1).
        depth = self.fingertip.gel.params.thickness_m if config.sensor.load_spread == "layer" else 0.0
        self._cell_weights = coverage_weights(self.bridge.geometry, length, edges, depth)
        self._cell_fractions = (np.diff(edges) / (edges[-1] - edges[0])).tolist()  # of the coverage's length
        self.pads = tuple(f"{p}_pad" for p in config.sensor.pads)
        self._pad_rows = [PAD_NAMES.index(p) for p in self.pads]
        self.channels: dict[str, SensorChannel] = make_channels(config, self.fingertip, self.unit, {pad: edges for pad in self.pads})
        self.controller = make_controller(config, self.robot, self.fingertip)
        m = self.model
        self._lift_qpos = m.joint("lift_joint").qposadr[0]
        self._lift_act = m.actuator("lift_actuator").id
        if self.mounted is None:
            self._finger_qpos = [m.joint(f"{s}_finger_joint").qposadr[0] for s in ("left", "right")]
            self._finger_act = m.actuator("fingers_actuator").id
        else:
            self._finger_qpos = []  # the opening is the mounted drive's (MountedDrive.observe)
        self.time_s = 0.0
        self.steps = 0
        self._finger_limit = self.robot.finger_force_limit_n  # the model's, before _actuate rewrites its forcerange
        # Ground truth for the referee and the record (never in the Observation): each
        # finger's net contact force on the object alone, world x is the closing direction
        # ("found" then force).
        self._contact_adr = {pad: m.sensor(f"{pad.removesuffix('_pad')}_object_contact").adr[0] + 1 for pad in self.pads}
        self._finger_adr = [m.sensor(f"{side}_object_contact").adr[0] + 1 for side in PAD_SIDES]
        self._normal_adr = [int(m.sensor(f"{side}_object_normal").adr[0]) for side in PAD_SIDES]
        # How many contacts each reports: its ``num`` (the contact sensor's third integer parameter).
        self._normal_slots = int(m.sensor_intprm[m.sensor("left_object_normal").id, 2])
        self._table_adr = m.sensor("object_table_contact").adr[0] + 1
        self._object_dof = m.joint("object_joint").dofadr[0]
        self._lift_dof = m.joint("lift_joint").dofadr[0]
        self._lift_from = self._lift_to = float(self.data.ctrl[self._lift_act])
        if self.mounted is None:
            self._fingers_from = self._fingers_to = float(self.data.ctrl[self._finger_act])
        else:
            self._fingers_from = self._fingers_to = self.data.ctrl[self.mounted.drive.actuators].tolist()
        # The referee judges a crush on the fingers' largest force, which can peak between two
        # control periods' samples (a squeeze rings within a period): for an object with a
        # crush limit, MuJoCo's sensors run in every physics step and each period records the
        # fingers' peak over its steps (PEAK_COLUMNS); other objects do not pay for it
        # (tests/test_grasp_outcomes.py::test_a_crush_between_two_samples_is_still_a_crush and
        # test_peaks_cost_nothing_for_a_robust_object_and_never_change_the_motion).
        self._track_peaks = config.object.crush_force_n is not None
        self._finger_peaks = (0.0, 0.0)
        # A load change while held (disturb.*): None where none comes on, so that the per-step
        # path of every other run is untouched (the actuators' stage is wrapped below).
        self._object_body = m.body("object").id
        self.disturbance: LoadDisturbance | None = None
        if config.disturb.active:
            weight_n = float(m.body_mass[self._object_body]) * gravity_m_s2(m)  # what extra_load_n None stands for
            xfrc = self.data.xfrc_applied[self._object_body]
            self.disturbance = LoadDisturbance(config.disturb.load_n(weight_n), config.disturb.ramp_s, config.controller.hold_s, xfrc)
        # The fingers' drive: the house's one finger servo, or the mounted gripper's actuators.
        self.drive: HouseDrive | MountedDrive = HouseDrive() if self.mounted is None else MountedDrive()
        self._prepare_step()
        if self.disturbance is not None:
            self._actuate_undisturbed, self._actuate = self._actuate, self._actuate_disturbed

    def _mount(self, config: ScenarioConfig) -> None:
        """The scene, home, pads and limits with ``gripper.mjcf`` on the lift (cosim.gripper_mount)."""
        from .gripper_mount import mount_gripper  # imports cosim.attach, which imports this module

        self.mounted = mount_gripper(config)
        self.model = self.mounted.model
        self.data = mujoco.MjData(self.model)
        self.home = self.mounted.reset_home(self.data, config)
        self.fingertip = make_fingertip(config)
        self.unit = make_unit(config)
        self.bridge = PadBridge(self.model, gel=self.fingertip.gel, geometry=self.mounted.geometry, pads=self.mounted.pads)
        self.robot = self.mounted.robot_limits(self.home, self.fingertip.gel.params)

    #: Live views of the model's and data's arrays (see _prepare_step): rebuilt, not copied.
    _VIEWS = (
        "_qpos",
        "_actuator_force",
        "_qvel",
        "_sensordata",
        "_forcerange",
        "_period",
        "_object_xpos",
        "_object_qvel",
        "_mj_step",
        "_pressure_reader",
        "_row_builder",
    )

    def __getstate__(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if k not in self._VIEWS}

    def __setstate__(self, state: dict) -> None:  # a copy gets views of its own model and data
        self.__dict__.update(state)
        self._prepare_step()

    def _prepare_step(self) -> None:
        """Everything the per-step path reads, as Python scalars, lists and live array views."""
        m, d = self.model, self.data
        # Per instrumented pad, only the strips read: the element's (the record's profile) and
        # those the coverage cells weigh; as flat indices into the bridge's strips (pads in
        # PAD_NAMES order, strips distal first), and the profile and weights as positions
        # among one pad's strips read.
        geometry = self.bridge.geometry
        self._n_strips = n_strips = len(geometry.strip_lengths_m)
        element = np.flatnonzero(geometry.on_element).tolist()[::-1]  # root to tip
        read = sorted({*element, *(i for row in self._cell_weights for i, _ in row)})
        at = {strip: k for k, strip in enumerate(read)}
        self._pressure_reader = self.bridge.pressure_reader(
            [row * n_strips + strip for row in self._pad_rows for strip in read],
            len(read),
            [at[i] for i in element],
            [[(at[i], w) for i, w in row] for row in self._cell_weights],
        )
        self._pressure_reader.bind(d.qpos)
        self._channel_list = [self.channels[pad] for pad in self.pads]
        kind = type(self._channel_list[0])  # every pad's channel is of one class (__init__)
        self._update_trusted, self._estimate = kind.update_trusted, kind.estimate
        self._dts = (self.dt,) * len(self._channel_list)
        self._qpos, self._actuator_force = memoryview(d.qpos), memoryview(d.actuator_force)
        # Memoryviews: an item is read and set, and a list made, faster than through numpy.
        self._qvel, self._sensordata = memoryview(d.qvel), d.sensordata
        self._forcerange = memoryview(m.actuator_forcerange)
        self._mj_step = mujoco.mj_step  # watch_mj_step puts an instrument in front of it (not copied)
        # The object's position and velocity as live views of their own (the record's).
        self._object_xpos = d.xpos[m.body("object").id]
        self._object_qvel = d.qvel[int(self._object_dof) : int(self._object_dof) + 6]
        self._lift_q, self._finger_q = int(self._lift_qpos), [int(a) for a in self._finger_qpos]
        self._object_dof_i, self._lift_dof_i = int(self._object_dof), int(self._lift_dof)
        self._finger_list, self._table_i = [int(a) for a in self._finger_adr], int(self._table_adr)
        fingers = [self._finger_act] if self.mounted is None else self.mounted.drive.actuators
        self._period = PeriodPhysics(
            self.substeps,
            self._lift_act,
            [int(a) for a in fingers],
            self._gel_every_substep,
            self._track_peaks,
            self._finger_list,
            _NO_SENSORS,
        )
        self._bind_period()
        self.columns = row_columns(self.pads, geometry.segments, self._track_peaks)
        stop_pa = float(self.fingertip.gel.pressure_from_indentation(geometry.stop_m)) * (1 - 1e-9)  # the housing's stop
        self._row_builder = RowBuilder(
            self.pads,
            [int(self._contact_adr[pad]) for pad in self.pads],
            self._finger_list,
            self._table_i,
            self._track_peaks,
            self._cell_fractions,
            stop_pa,
            _STATUS_INDEX,
            # Where the model ends: readings past it are recorded "outside_model".
            (self.fingertip.gel.params.max_valid_pressure_pa, self.fingertip.backstop_pressure_pa()),
            self._normal_adr,
            self._normal_slots,
        )
        self._row_builder.bind(self._object_xpos, self._object_qvel, self._sensordata)
        if self.disturbance is not None:  # a copy's load acts on its own data
            self.disturbance.bind(d.xfrc_applied[self._object_body])

    def _bind_period(self) -> None:
        """(Re)bind the period's kernel to this model and data, through the step and gel-force
        callables in place now (an instrument may stand in front of either: watch_mj_step,
        wrap_stages)."""
        instrument = vars(self.bridge).get("apply_gel_forces")  # wrap_stages's, on the instance
        gel = functools.partial(instrument, self.data) if instrument is not None else self.bridge.gel_forces_on(self.data)
        self._period.bind(self.model, self.data, self._mj_step, gel)

    # -- one control step --------------------------------------------------------------

    def advance(self) -> list[float]:
        """Advance one control period; return the recorded row's values, in :attr:`columns` order."""
        # 1. physics (the gel's law acts on the pad joints every substep)
        self._physics()
        # 2. pad pressure along each element (Pa), root to tip, and on its coverage cells
        profiles, cells = self._pressures()
        # 3-4. gel -> sensor (envelope), the driven mode only
        readings = self._sense(cells)
        # 5. readout (inverse)
        signals = self._readout(readings)
        # 6. controller (sensors and proprioception only)
        obs = self._observe(signals)
        command = self.controller.step(obs, self.dt)
        # 7. actuators and drive modes
        self._actuate(command)
        # 8. record
        return self._record(obs, command, profiles, cells)

    # -- the same step in two halves, for a driver outside the loop (a Gymnasium agent) -------

    def sense(self) -> Observation:
        """Steps 1-5 of :meth:`advance`: physics over one control period, then what the
        controller would see.  Follow it with :meth:`act`."""
        self._physics()
        self._pending_profiles, self._pending_cells = self._pressures()
        self._pending_obs = self._observe(self._readout(self._sense(self._pending_cells)))
        return self._pending_obs

    def act(self, command: Command) -> list[float]:
        """Steps 7-8 of :meth:`advance` for the observation :meth:`sense` returned: apply
        ``command`` and return the recorded row.  ``sense(); act(controller.step(obs))`` is
        exactly :meth:`advance`."""
        self._actuate(command)
        return self._record(self._pending_obs, command, self._pending_profiles, self._pending_cells)

    def step(self) -> dict[str, float]:
        """Advance one control period; return the recorded row (column name -> value)."""
        return dict(zip(self.columns, self.advance(), strict=True))

    def _physics(self) -> None:
        """One control period's physics through the fingers' drive (:meth:`HouseDrive.physics`)."""
        self.drive.physics(self)

    def _after_period(self, stable: bool) -> None:
        if self._track_peaks:
            self._finger_peaks = (self._period.left_peak, self._period.right_peak)
        self._lift_from, self._fingers_from = self._lift_to, self._fingers_to
        if not stable:
            self._check_stable()
        self.time_s += self.dt
        self.steps += 1

    def _pressures(self) -> tuple[list[list[float]], list[list[float]]]:
        """Per instrumented pad: the gel pressure over its element strips (Pa, root to tip: the
        record's cells) and the mean pressure on each coverage cell (Pa: the channel's input)."""
        return self._pressure_reader.read()

    def coverage_pressures(self) -> np.ndarray:
        """The mean gel pressure on each coverage cell of each instrumented pad now, Pa, shape
        (pads, cells): the sensor channels' input, computed with numpy from every strip's
        pressure (a check on the per-step path; :func:`coverage_weights`)."""
        strips = np.maximum(self.bridge.strip_pressures(self.data), 0.0)[self._pad_rows]
        matrix = np.zeros((len(self._cell_weights), self._n_strips))
        for c, row in enumerate(self._cell_weights):
            for i, w in row:
                matrix[c, i] = w
        return strips @ matrix.T

    # Per pad, channel.update_trusted(cells, dt) and channel.estimate(reading), through map over
    # the channels' class's functions: a comprehension costs Python 3.11 a call of its own.

    def _sense(self, cells: list[list[float]]) -> list[Reading]:
        return list(map(self._update_trusted, self._channel_list, cells, self._dts))

    def _readout(self, readings: list[Reading]) -> dict[str, PadSignal]:
        return dict(zip(self.pads, map(make_pad_signal, readings, map(self._estimate, self._channel_list, readings)), strict=True))

    def _observe(self, signals: dict[str, PadSignal]) -> Observation:
        """What the controller sees: the readout's signals and the robot's own joints, read
        through the fingers' drive (:meth:`HouseDrive.observe`)."""
        return self.drive.observe(self, signals)

    def _actuate(self, command: Command) -> None:
        """``command`` to the lift, through the fingers' drive (:meth:`HouseDrive.actuate`), and
        its modes to the channels."""
        self.drive.actuate(self, command)
        for pad, mode in command.modes.items():
            self.channels[pad].select_mode(mode)

    def _actuate_disturbed(self, command: Command) -> None:
        """:meth:`_actuate` (or the mounted drive's), then the extra load on the object for the
        next period, scheduled by the phase just commanded (cosim.disturb)."""
        self._actuate_undisturbed(command)
        self.disturbance.command(command.phase, self.time_s, self.dt)

    def _check_stable(self) -> None:
        """SimulationDiverged, naming MuJoCo's warnings or the non-finite state, unless the
        state is stable (:meth:`PeriodPhysics.stable`)."""
        if self._period.stable():
            return
        d = self.data
        warned = [mujoco.mjtWarning(i).name for i in range(len(d.warning)) if d.warning[i].number > 0]
        if warned or not finite_state(d):
            what = ", ".join(warned) if warned else "non-finite state (NaN or inf in qpos/qvel)"
            raise SimulationDiverged(
                f"simulation diverged at t = {d.time:.4f} s: {what} "
                f"(timestep {self.model.opt.timestep:g} s, integrator {self.config.physics.integrator})"
            )

    def _record(self, obs: Observation, command: Command, profiles: list[list[float]], cells: list[list[float]]) -> list[float]:
        """The row's values in :attr:`columns` order (all Python floats: cosim/rows.py)."""
        return self._row_builder.row(self.time_s, obs, command, profiles, cells, self._finger_peaks)

    # -- instruments (run_sim.py bench): measured without patching ---------------------------

    def wrap_stages(self, wrap: Callable[[str, Callable], Callable]) -> None:
        """Put ``wrap(stage, method)`` (a timer, a tracer) in place of each method that makes a
        stage of :meth:`advance`, on this instance (:data:`STAGE_METHODS` names them; the gel
        forces are a stage of their own inside physics).  The recorder's appends are the
        caller's to wrap: the recorder is the caller's."""
        owners = {"": self, "controller": self.controller, "bridge": self.bridge}
        for stage, paths in STAGE_METHODS.items():
            for path in paths:
                owner_name, _, attr = path.rpartition(".")
                owner = owners[owner_name]
                setattr(owner, attr, wrap(stage, getattr(owner, attr)))
        self._bind_period()  # the period's kernel calls the wrapped gel forces

    def watch_mj_step(self, before: Callable[[mujoco.MjModel, mujoco.MjData], None]) -> None:
        """Call ``before(model, data)`` before every ``mj_step`` of this simulation (the bench
        captures the states it times bare ``mj_step`` from)."""
        step = mujoco.mj_step

        def watched(m: mujoco.MjModel, d: mujoco.MjData) -> None:
            before(m, d)
            step(m, d)

        self._mj_step = watched
        self._bind_period()

    def model_settings(self) -> tuple[np.ndarray, np.ndarray, int]:
        """What the loop writes into the model as it runs, copied: the pad joints' stiffness
        (the gel's tangent), the fingers' force ranges and the disable flags.  With the
        integration state, what a physics step of this simulation starts from."""
        return self.drive.model_settings(self)

    def apply_model_settings(self, settings: tuple[np.ndarray, np.ndarray, int]) -> None:
        """Write :meth:`model_settings`' values back into the model."""
        self.drive.apply_model_settings(self, settings)

    # -- a whole run ---------------------------------------------------------------------

    def run(self, recorder: Recorder | None = None, progress=None, max_steps: int | None = None, on_step=None) -> RunResult:
        """Step until the controller finishes or the scenario's duration runs out; record every step.

        Once the controller has finished, the recording goes on until the object is at rest
        (at least ``REST_MIN_S``, at most ``REST_MAX_S``), so a drop after a release is in the
        record.  ``on_step(sim)`` is called after every step (e.g. to render frames).  A
        divergence or Ctrl-C stops the run; what was recorded is kept (the recorder is closed in
        any case), a divergence's message is in ``RunResult.error`` and Ctrl-C sets
        ``RunResult.interrupted``.
        """
        total = max_steps if max_steps is not None else math.ceil(self.config.duration_s / self.dt - 1e-9)
        start = time.perf_counter()
        error, interrupted = None, False
        tail_min, tail_max = round(REST_MIN_S / self.dt), round(REST_MAX_S / self.dt)
        finished_at = None
        try:
            step = 0
            while step < total or (finished_at is not None and max_steps is None):
                values = self.advance()
                step += 1
                if recorder is not None:
                    recorder.append_values(values, self.columns, owned=True)
                if progress is not None:
                    progress.update(1)
                if on_step is not None:
                    on_step(self)
                if finished_at is None and self.controller.finished:
                    finished_at = step
                if finished_at is not None:
                    after = step - finished_at
                    if after >= tail_max or (after >= tail_min and self.object_at_rest()):
                        break
        except SimulationDiverged as err:
            error = str(err)
        except KeyboardInterrupt:
            interrupted = True
        finally:
            wall = time.perf_counter() - start
            files = recorder.close() if recorder is not None else []
        return RunResult(self.steps, self.time_s, wall, files, error, interrupted)

    def object_at_rest(self) -> bool:
        """Whether the object has stopped moving (ground truth: ends the recording's tail)."""
        v = self.data.qvel[self._object_dof_i : self._object_dof_i + 6]
        return bool(np.linalg.norm(v[:3]) < REST_SPEED_M_S and np.linalg.norm(v[3:]) < REST_SPIN_RAD_S)


#: The stages of :meth:`CoSimulation.advance` in its order, each with the methods that make it
#: (:meth:`CoSimulation.wrap_stages`); "gel_forces" runs inside "physics", once per control
#: period (every substep with ``physics.gel_update=substep``).
STAGE_METHODS = {
    "physics": ("_physics",),
    "gel_forces": ("bridge.apply_gel_forces",),
    "pressure": ("_pressures",),
    "sensor": ("_sense",),
    "readout": ("_readout",),
    "controller": ("_observe", "controller.step"),
    "actuators": ("_actuate",),
    "record": ("_record",),
}

_NO_SENSORS = int(mujoco.mjtDisableBit.mjDSBL_SENSOR)

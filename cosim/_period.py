# cython: boundscheck=False, wraparound=False, initializedcheck=False
# (compiled, an index is not checked where it is read: every one is checked once, in bind().)
"""One control period's physics: the servos' set-points interpolated over its substeps, the gel
law, ``mj_step``, the fingers' peak force, and the check that the state stayed finite.

A kernel (:mod:`piezotip.sensor.compiled`): this module runs as Python and, where built,
compiled (``_period.pxd`` types it).  :class:`PeriodPhysics` is what
:meth:`cosim.loop.CoSimulation._physics` runs each control period, for the house gripper (one
finger servo) and a mounted one (any number of finger actuators) alike.  In Python a substep's
few lines of bookkeeping cost a tenth of ``mj_step``; compiled, nothing but ``mj_step`` and the
two writes of MuJoCo's disable flags remain Python calls.

Per period of ``substeps`` physics steps (k = 1 .. substeps):

- each servo's command is ``start + k (end - start) / substeps`` (a real servo interpolates
  its set-point between a controller's; the lift's force would otherwise ripple by kp v T);
- the gel law is applied before the first substep (``every_substep``: before each one), through
  the callable :meth:`bind` was given (the pad bridge's gel-force kernel, or an instrument
  around it);
- MuJoCo's sensors are disabled in all but the last substep (they never act on the dynamics;
  the referee reads them once a period), unless ``track_peaks``: then they run in every substep
  and the largest |value| of the two finger sensors is kept (:attr:`left_peak`,
  :attr:`right_peak`; a crush can peak between two periods' samples);
- after the period, the state is stable when MuJoCo counted no warning and every ``qpos`` and
  ``qvel`` is finite.
"""

from __future__ import annotations

from array import array
from collections.abc import Sequence

from piezotip.sensor import _kernel_helpers as kh


class PeriodPhysics:
    """A control period's substeps on one model and data (the module docstring).

    Parameters
    ----------
    substeps : physics steps per control period (>= 1).
    lift_actuator : the lift servo's actuator id.
    finger_actuators : the finger actuators' ids (one for the house gripper).
    every_substep : apply the gel law before every substep (else once, before the first).
    track_peaks : run MuJoCo's sensors in every substep and keep the fingers' peak |force|.
    peak_sensors : the ``sensordata`` addresses of the left and right fingers' force.
    no_sensors_flag : the disable bit of MuJoCo's sensors (``mjDSBL_SENSOR``).
    """

    __slots__ = (
        "_args",
        "_bound",
        "_ctrl",
        "_data",
        "_deltas",
        "_every",
        "_fingers",
        "_gel",
        "_lift",
        "_model",
        "_no_sensors",
        "_opt",
        "_peak_left",
        "_peak_right",
        "_qpos",
        "_qvel",
        "_sensordata",
        "_starts",
        "_step",
        "_substeps",
        "_track",
        "_warnings",
        "left_peak",
        "right_peak",
    )

    def __init__(
        self,
        substeps: int,
        lift_actuator: int,
        finger_actuators: Sequence[int],
        every_substep: bool,
        track_peaks: bool,
        peak_sensors: Sequence[int],
        no_sensors_flag: int,
    ) -> None:
        self._args = (substeps, lift_actuator, tuple(finger_actuators), every_substep, track_peaks, tuple(peak_sensors), no_sensors_flag)
        if int(substeps) < 1:
            raise ValueError(f"a control period needs at least one physics step, got substeps={substeps!r}")
        if len(peak_sensors) != 2:
            raise ValueError(f"peak_sensors needs the two fingers' sensordata addresses, got {peak_sensors!r}")
        self._substeps = int(substeps)
        self._lift = int(lift_actuator)
        self._fingers = array("q", [int(a) for a in finger_actuators])
        self._starts = array("d", [0.0] * len(self._fingers))
        self._deltas = array("d", [0.0] * len(self._fingers))
        self._every = bool(every_substep)
        self._track = bool(track_peaks)
        self._peak_left, self._peak_right = int(peak_sensors[0]), int(peak_sensors[1])
        self._no_sensors = int(no_sensors_flag)
        self.left_peak = self.right_peak = 0.0
        self._bound = False

    def bind(self, model, data, step, gel) -> None:
        """Step ``model`` and ``data`` (MuJoCo's) with ``step(model, data)`` (``mujoco.mj_step``,
        or an instrument in front of it), applying the gel law with ``gel()``."""
        ctrl, sensordata = memoryview(data.ctrl), memoryview(data.sensordata)
        bad = [a for a in [self._lift, *list(self._fingers)] if not 0 <= a < len(ctrl)]
        bad += [a for a in (self._peak_left, self._peak_right) if not 0 <= a < len(sensordata)]
        if bad:
            raise ValueError(f"actuator or sensor addresses {bad} are outside the model's arrays")
        self._model, self._data, self._opt, self._step, self._gel = model, data, model.opt, step, gel
        self._ctrl, self._sensordata = ctrl, sensordata
        self._qpos, self._qvel = memoryview(data.qpos), memoryview(data.qvel)
        self._warnings = memoryview(data.warning.number)
        self._bound = True

    def run(self, lift_from: float, lift_to: float, finger_from: float, finger_to: float) -> bool:
        """One period with one finger actuator, its command from ``finger_from`` to
        ``finger_to`` (the lift's from ``lift_from`` to ``lift_to``); whether the state is
        stable after it (the module docstring)."""
        self._starts[0] = finger_from
        self._deltas[0] = (finger_to - finger_from) / self._substeps
        return self._period(lift_from, lift_to, 1)

    def run_drive(self, lift_from: float, lift_to: float, fingers_from: Sequence[float], fingers_to: Sequence[float]) -> bool:
        """:meth:`run` with one command per finger actuator (a mounted gripper's drive)."""
        n = len(self._fingers)
        if len(fingers_from) != n or len(fingers_to) != n:
            raise ValueError(f"{n} finger actuators need {n} commands, got {len(fingers_from)} and {len(fingers_to)}")
        for i in range(n):
            start, end = fingers_from[i], fingers_to[i]
            self._starts[i] = start
            self._deltas[i] = (end - start) / self._substeps
        return self._period(lift_from, lift_to, n)

    def _period(self, lift_from: float, lift_to: float, n: int) -> bool:
        if not self._bound:
            raise RuntimeError("bind() the model and data first")
        ctrl, opt, model, data, step = self._ctrl, self._opt, self._model, self._data, self._step
        last = self._substeps
        delta = (lift_to - lift_from) / last
        flags = opt.disableflags  # the model's own, between periods (kept in every substep)
        inner = flags if self._track else flags | self._no_sensors
        if last > 1 and inner != flags:
            opt.disableflags = inner  # set twice a period, not every substep
        left_peak = right_peak = 0.0
        for k in range(1, last + 1):
            ctrl[self._lift] = lift_from + k * delta
            for i in range(n):
                ctrl[self._fingers[i]] = self._starts[i] + k * self._deltas[i]
            if k == 1 or self._every:
                self._gel()
            if k == last:
                opt.disableflags = flags
            step(model, data)
            if self._track:
                value = abs(self._sensordata[self._peak_left])
                if value > left_peak:
                    left_peak = value
                value = abs(self._sensordata[self._peak_right])
                if value > right_peak:
                    right_peak = value
        if self._track:
            self.left_peak, self.right_peak = left_peak, right_peak
        return self.stable()

    def stable(self) -> bool:
        """Whether MuJoCo counted no warning and every ``qpos`` and ``qvel`` is finite."""
        if not self._bound:
            raise RuntimeError("bind() the model and data first")
        for i in range(len(self._warnings)):
            if self._warnings[i] != 0:
                return False
        for i in range(len(self._qpos)):
            if not kh.isfinite(self._qpos[i]):
                return False
        for i in range(len(self._qvel)):
            if not kh.isfinite(self._qvel[i]):
                return False
        return True

    def __reduce__(self):  # a copy is unbound: its owner binds it to its own model and data
        return type(self), self._args

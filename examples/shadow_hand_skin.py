"""A skin on a hand: a piezotip fingertip on each of the five fingertips of the Shadow Hand.

    pip install -e ".[hand]"          # Gymnasium-Robotics: only its Shadow Hand model is used
    python examples/shadow_hand_skin.py
    python examples/shadow_hand_skin.py --out out/shadow-hand --seconds 4
    python examples/shadow_hand_skin.py --bench   # mj_step bare, with gel pads, with touch pads

Gymnasium-Robotics' Shadow Hand (``envs/assets/hand/reach.xml``: the hand palm up on its
mount, read from the installed package, never copied) gets a box site on the palm side of each
distal phalanx (first, middle, ring and little finger, thumb); ``piezotip.attach`` puts a gel
pad, its element and readout on each, and ``bind`` makes MuJoCo's own ``mj_step`` run them.  An
80 mm ball of 100 g is dropped onto the palm, the thumb closes beside it and the fingers close
over it with the hand's own position servos (:class:`GraspScript`), and the hand holds it.

The loop is a plain ``mujoco.mj_step`` loop: every step sets the scripted servos' targets in
``data.ctrl`` and calls ``mj_step``.  Once a period (the readout's sample: 5 ms rounded to the
hand's 2 ms steps, 4 ms) it reads each fingertip's five sensors from ``data.sensordata`` by name
(``piezotip/ff_pad/pressure_pa``, ``sigma_pa``, ``status``, ``mode``, ``true_pressure_pa``),
notes whether the pad touches the ball (MuJoCo's contacts), and drives the fingertip's mode with
the house multimode controller's selector through ``sim.set_mode`` (up a mode when saturated or
past its switch pressure, down when below detection).  It records what ``data.sensordata``
holds and nothing more: the sensed voltage is only in ``sim.readings()`` and nothing here needs
it.  Of the checks ``sim.step()`` would make, it keeps the one that matters in a plain loop:
that MuJoCo did not reset a diverged state and step on.

Writes ``readings.npz`` and ``readings.csv`` (units in the column names) and ``skin.png``
(five panels: the true pressure, the estimate with its 3-sigma band where the status is "ok",
the status along the bottom, the hold shaded, and under each every "ok" reading's error in its
own sigmas) into ``--out``, and prints per fingertip the peak true pressure and the share of
its "ok" readings whose 3-sigma band holds the truth (over the run, and in the hold).  Headless
(matplotlib's Agg).

The hand's options are as reach.xml has them (MuJoCo's Euler at 2 ms, 20 solver iterations:
``attach`` takes any integrator at any step, docs/attach.md) but for two of its friction's,
both for the grasp, not the fingertips (the bare hand without them slides the ball as fast):

- ``cone`` pyramidal -> elliptic.  Under the hand's pyramidal cone the squeezed ball slides
  towards the wrist at about 11 mm/s, out from under the fingertips: in the hold they touch it
  3 % (first finger), 26 %, 52 % and 88 % (little finger) of the periods, with 0-7 "ok" readings
  each.
- ``impratio`` 1 -> 100 (MuJoCo's ratio of friction to normal impedance, its remedy for slip).
  At the hand's 1, MuJoCo's soft friction lets the squeezed ball slide at 6 mm/s under the
  elliptic cone too, with the fingertips as without them: the four fingertips' loads fall
  through the hold (from 2.8 to 4 s the first finger's 17 -> 0.9 kPa, the little finger's 23 ->
  19 kPa, 8-33 %/s), the first finger lets go at 4.06 s, the middle at 4.6 s, the ring at 5.3 s,
  and the readout reads "settling" for most of the hold (its 57, 104, 43 and 0 "ok" readings
  all hold the truth: the little finger's falling load reads "settling" throughout).  At 10 the
  ball still slides 2 mm/s; at 30-300 it stays (every load within 0.5 % over the hold); at 1000
  the squeeze pinches it out of the hand at about 2 s.  Under the pyramidal cone, 100 keeps the
  ball but not its loads (3-8 % drift over the hold, the thumb pressed against it).

The readings to judge the readout by are those of the hold (:func:`hold_from_s`): from the hand
closed, its servos settled (five time constants, 0.5 s) and one readout inference window on
(``sensor.inference.WINDOW_S``, 0.5 s), 2.8 s.  While the fingers close (1.5-2 s), their pads
stick and slip on the ball: the true pressure jumps by 17-42 % from one period to the next (95th
percentile), and the readout reads "settling" through most of it.

What it shows (4 s): the first, middle, ring and little finger hold the ball at 26.6, 31.6,
32.1 and 29.7 kPa (steady within 0.5 %), read "ok" at 296, 295, 300 and 301 of the hold's 301
periods ("settling" at the others), and every one of those 1192 readings holds the truth within
3 sigma (sigma 0.5-0.6 % of the load; the largest error 1.5 sigma).  Over the whole run, closing
included, so do all 1720 of their "ok" readings.  The thumb presses the ball from 0.95 s (up to
3.9 kPa) until the fingers push it off at 1.68 s; 52 of its 53 "ok" readings hold the truth (one
at 3.2 sigma, at 1.28 s), and in the hold it reads below detection.

Everything else of the hand (its geoms, contacts, joints, tendons, servos and their gains) is
as shipped.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

import piezotip
from piezotip.cosim.control import ModeSelector
from piezotip.cosim.control.selector import allowed_ranges
from piezotip.sensor.inference import WINDOW_S

# ---------------------------------------------------------------------------------------
# The hand and its pads.
# ---------------------------------------------------------------------------------------

#: The hand's model inside the Gymnasium-Robotics package.
HAND_SCENE = Path("envs", "assets", "hand", "reach.xml")

FINGERTIPS = ("ff", "mf", "rf", "lf", "th")
FINGER_NAMES = {"ff": "first finger", "mf": "middle finger", "rf": "ring finger", "lf": "little finger", "th": "thumb"}

#: The pads' half-sizes, m: 16 mm along the distal phalanx by 12 mm across it, the same on all
#: five.  Across: a finger's distal phalanx is a capsule 14.1 mm thick (radius 7.05 mm, the
#: thumb's 18.4 mm), so a 12 mm flat pad keeps the gel within the finger's outline.  Along: the
#: phalanx's cylinder is 24 mm long (the thumb's 26 mm); 16 mm centred on it stays 4 mm clear
#: of the joint and of the tip's dome.  The 7.5 x 5 mm element fits with 4.25 mm of gel guard
#: at each end.  The house pad is 20 x 20 mm, wider than these fingers.
PAD_HALF_LENGTH_M = 0.008
PAD_HALF_WIDTH_M = 0.006

#: Each pad site in its distal body: (body, origin on the phalanx's palm-side surface at the
#: middle of its cylinder, m; xyaxes).  The distal bodies run along their +z from the joint; a
#: finger's palm side is its body's -y (the capsule's radius 7.05 mm), the thumb's its -x (radius
#: 9.18 mm, the side its touch sensor marks).  The site's +x points along the phalanx towards its
#: joint (the element's clamped root, as on the house finger), its +z out of the palm side.
PAD_SITES = {
    "ff": ("robot0:ffdistal", (0.0, -0.00705, 0.012), (0, 0, -1, 1, 0, 0)),
    "mf": ("robot0:mfdistal", (0.0, -0.00705, 0.012), (0, 0, -1, 1, 0, 0)),
    "rf": ("robot0:rfdistal", (0.0, -0.00705, 0.012), (0, 0, -1, 1, 0, 0)),
    "lf": ("robot0:lfdistal", (0.0, -0.00705, 0.012), (0, 0, -1, 1, 0, 0)),
    "th": ("robot0:thdistal", (-0.00918, 0.0, 0.013), (0, 0, -1, 0, -1, 0)),
}

#: The ball: radius, m, and mass, kg (80 mm and 100 g: between a tennis ball and a softball).
BALL_RADIUS_M = 0.04
BALL_MASS_KG = 0.1
#: Where it is let go, m (world): over the palm's centre line, just proximal of the knuckles
#: (y = 0.865), its bottom 1 mm above the palm (the palm's face is at z = 0.1511).  The wrist's
#: servo sags 5 degrees under the hand's weight, tilting the palm towards the fingers: the ball
#: rolls onto the curled fingers' proximal phalanges and rests there.
BALL_START_M = (0.99, 0.90, 0.1511 + BALL_RADIUS_M + 0.001)


def hand_assets() -> Path | None:
    """Gymnasium-Robotics' Shadow Hand scene (reach.xml) if the package is installed, else None.

    Found without importing the package (its import registers environments and needs what the
    hand model does not)."""
    spec = importlib.util.find_spec("gymnasium_robotics")
    if spec is None or not spec.submodule_search_locations:
        return None
    for root in spec.submodule_search_locations:
        scene = Path(root) / HAND_SCENE
        if scene.is_file():
            return scene
    return None


#: The two friction options the grasp changes (module docstring): MuJoCo's elliptic cone for the
#: hand's pyramidal one, and a ratio of frictional to normal impedance of 100 for the hand's 1.
GRASP_CONE = mujoco.mjtCone.mjCONE_ELLIPTIC
GRASP_IMPRATIO = 100.0


def build_scene(scene: Path) -> mujoco.MjSpec:
    """The hand as shipped but for its friction cone and impratio (:data:`GRASP_CONE`,
    :data:`GRASP_IMPRATIO`: the grasp's, module docstring), its five pad sites and the ball."""
    try:
        spec = mujoco.MjSpec.from_file(str(scene))
    except ValueError as err:  # Gymnasium-Robotics 1.4.0 and 1.4.1 set <option apirate>, which MuJoCo refuses
        raise ValueError(f"the Shadow Hand's {scene} does not load ({err}); it needs gymnasium-robotics>=1.4.2") from err
    spec.option.cone = GRASP_CONE
    spec.option.impratio = GRASP_IMPRATIO
    for tip, (body, pos, xyaxes) in PAD_SITES.items():
        site = spec.body(body).add_site(name=f"{tip}_pad", type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(pos))
        site.size = [PAD_HALF_LENGTH_M, PAD_HALF_WIDTH_M, 0.0005]  # z: not used, a thin box to show
        site.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
        site.alt.xyaxes = list(xyaxes)
    ball = spec.worldbody.add_body(name="ball", pos=list(BALL_START_M))
    ball.add_freejoint(name="ball_free")
    ball.add_geom(name="ball", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[BALL_RADIUS_M, 0, 0], mass=BALL_MASS_KG, rgba=[0.9, 0.4, 0.2, 1])
    return spec


# ---------------------------------------------------------------------------------------
# The grasp: a scripted closing of the hand's position servos.
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class GraspScript:
    """When and where the hand's position servos go (joint targets, rad; times, s).

    The fingers start curled at the knuckle (J2) so the ball rests against them.  The thumb
    closes beside the ball first: to where its pad meets the ball resting there (a kinematic
    search: the pad's normal through the ball's centre, the gel's surface on it: THJ4..THJ0 =
    -0.291, 1.177, -0.115, -0.432, -0.604), pressed in by 2 N along the pad's normal through its
    Jacobian (J^T n = 0.052, 0.004, 0, -0.039, -0.013 N m per N) at the servos' kp = 1 N m/rad:
    THJ4, THJ1 and THJ0 move on by 0.10, -0.08 and -0.03 rad (THJ3's 0.008 left out).
    Then the fingers curl J2 and J1 (J1 drives J0 through the hand's coupling tendon) towards
    targets past the ball: each stops on it, and its servos turn the remaining error into the
    squeeze (the middle and ring finger stop near J2 = 1.17, J1 = 0.73-0.80: 0.1-0.2 N m).
    They push the ball towards the wrist and off the thumb, which then stands beside it
    untouched.  Each move is a smooth step (3 s^2 - 2 s^3).

    Attributes
    ----------
    finger_open : the fingers' (J2, J1) at the start, rad.
    finger_closed : their targets (J2, J1), rad.
    thumb_closed : the thumb's (THJ4, THJ3, THJ2, THJ1, THJ0) closed, rad (open: all 0).
    thumb_from_s, thumb_for_s : when the thumb starts closing and how long it takes, s.
    fingers_from_s, fingers_for_s : the same for the fingers, s.
    """

    finger_open: tuple[float, float] = (1.2, 0.0)
    finger_closed: tuple[float, float] = (1.35, 0.9)
    thumb_closed: tuple[float, ...] = (-0.19, 1.177, -0.115, -0.51, -0.63)
    thumb_from_s: float = 0.4
    thumb_for_s: float = 0.6
    fingers_from_s: float = 1.0
    fingers_for_s: float = 0.8

    @property
    def closed_s(self) -> float:
        """When the hand is closed, s."""
        return max(self.thumb_from_s + self.thumb_for_s, self.fingers_from_s + self.fingers_for_s)

    def targets(self, t: float) -> dict[str, float]:
        """Every scripted servo's target at time ``t``, rad, by joint name (``FFJ2``, ``THJ4``, ...)."""
        fingers = _smooth_step((t - self.fingers_from_s) / self.fingers_for_s)
        thumb = _smooth_step((t - self.thumb_from_s) / self.thumb_for_s)
        out = {}
        for finger in ("FF", "MF", "RF", "LF"):
            for joint, start, end in zip(("J2", "J1"), self.finger_open, self.finger_closed, strict=True):
                out[f"{finger}{joint}"] = start + (end - start) * fingers
        for joint, end in zip(("THJ4", "THJ3", "THJ2", "THJ1", "THJ0"), self.thumb_closed, strict=True):
            out[joint] = end * thumb
        return out


#: Servo time constants after the hand closed before its fingers count as settled: e^-5, the
#: last 0.7 % of a first-order step left.
SETTLED_TIME_CONSTANTS = 5


def hold_from_s(model: mujoco.MjModel, script: GraspScript) -> float:
    """Where the hold's readings start, s: the hand closed, its scripted joints settled (five
    of their servos' slowest time constant, damping / kp: 0.1 s on this hand), and then one
    readout inference window (``WINDOW_S``), so that every reading of the hold infers from
    loads the settled hand put on its fingertip."""
    servo_s = 0.0
    for joint in script.targets(0.0):
        actuator = model.actuator(f"robot0:A_{joint}").id
        dof = model.jnt_dofadr[model.joint(f"robot0:{joint}").id]
        servo_s = max(servo_s, float(model.dof_damping[dof] / model.actuator_gainprm[actuator, 0]))
    return script.closed_s + SETTLED_TIME_CONSTANTS * servo_s + WINDOW_S


def _smooth_step(s: float) -> float:
    s = min(max(s, 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


def _start_open(model: mujoco.MjModel, data: mujoco.MjData, targets: dict[str, float]) -> dict[str, int]:
    """Put the hand in the script's open pose (joints and their servos) and return each
    scripted servo's actuator index by joint name."""
    actuators = {}
    for joint, value in targets.items():
        actuators[joint] = model.actuator(f"robot0:A_{joint}").id
        data.ctrl[actuators[joint]] = value
        data.qpos[model.jnt_qposadr[model.joint(f"robot0:{joint}").id]] = value
    mujoco.mj_forward(model, data)
    return actuators


# ---------------------------------------------------------------------------------------
# The run: what each fingertip reads.
# ---------------------------------------------------------------------------------------


#: The fingertip's five MuJoCo sensors, ``piezotip/<fingertip>_pad/<field>`` (docs/attach.md).
FIELDS = ("pressure_pa", "sigma_pa", "status", "mode", "true_pressure_pa")
#: The status sensor's codes: 0 ok, 1 below detection, 2 saturated, 3 settling.
STATUS_NAMES = ("ok", "below_detection", "saturated", "settling")
OK = STATUS_NAMES.index("ok")


@dataclass(frozen=True)
class SkinRecord:
    """What the fingertips read, one row per readout sample (once a period), one column per fingertip.

    Attributes
    ----------
    fingertips : the column names ("ff", "mf", "rf", "lf", "th").
    time_s : the time of the state each row's sample read, s (a whole number of periods).
    pressure_pa, sigma_pa, status, mode, true_pressure_pa : the fingertip's five sensors
        (:data:`FIELDS`) as ``data.sensordata`` holds them: the readout's estimate and its
        one-sigma uncertainty (Pa, NaN where unknown), its status (a code, :data:`STATUS_NAMES`),
        the mode driven, and the gel's mean pressure on the element's coverage (Pa: the truth).
    touching : whether a strip of the pad touched the ball in that state (MuJoCo's contacts).
    detection_limit_pa : mode 1's detection limit, Pa (the lowest pressure any mode reads).
    closed_s, hold_from_s : when the hand closed and where the hold's readings start, s.
    """

    fingertips: tuple[str, ...]
    time_s: np.ndarray
    pressure_pa: np.ndarray
    sigma_pa: np.ndarray
    status: np.ndarray
    mode: np.ndarray
    true_pressure_pa: np.ndarray
    touching: np.ndarray
    detection_limit_pa: float
    closed_s: float
    hold_from_s: float

    @property
    def hold(self) -> np.ndarray:
        """The periods of the hold (per row)."""
        return self.time_s >= self.hold_from_s

    def ok(self) -> np.ndarray:
        """Where the status is "ok" and the estimate finite (the readings the contract covers)."""
        return (self.status == OK) & np.isfinite(self.pressure_pa) & np.isfinite(self.sigma_pa)

    def within_3_sigma(self) -> np.ndarray:
        """Where an "ok" reading's estimate +- 3 sigma holds the truth (False elsewhere)."""
        with np.errstate(invalid="ignore"):
            return self.ok() & (np.abs(self.pressure_pa - self.true_pressure_pa) <= 3.0 * self.sigma_pa)


@dataclass(frozen=True)
class _Estimate:
    """A fingertip's sensors as the mode selector reads a readout estimate."""

    pressure_pa: float
    uncertainty_pa: float
    status: str


def _touching(model: mujoco.MjModel, data: mujoco.MjData, strip_pad: dict[int, int], ball_geom: int, count: int) -> np.ndarray:
    """Per pad, whether one of its strips touches the ball in ``data``'s contacts."""
    out = np.zeros(count, dtype=bool)
    for contact in data.contact[: data.ncon]:
        g1, g2 = int(contact.geom[0]), int(contact.geom[1])
        other = g2 if g1 == ball_geom else g1 if g2 == ball_geom else -1
        pad = strip_pad.get(int(model.geom_bodyid[other]), -1) if other >= 0 else -1
        if pad >= 0:
            out[pad] = True
    return out


#: MuJoCo's warnings on which it resets the data to the model's initial state and steps on.
_RESETS = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)


def run(scene: Path, seconds: float, script: GraspScript = GraspScript()) -> SkinRecord:
    """Close the hand on the ball for ``seconds`` of simulated time in a plain ``mj_step`` loop
    and record every fingertip's sensors each time the readout samples."""
    spec = build_scene(scene)
    tips = piezotip.attach(spec, sites=[f"{tip}_pad" for tip in FINGERTIPS])
    model = spec.compile()
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)  # from here on mj_step runs the fingertips
    actuators = _start_open(model, data, script.targets(0.0))

    # The house multimode controller's selector (its switch pressures are the fingertip's own).
    modes = tuple(sorted(tips.config.sensor.modes))
    selectors = {name: ModeSelector(tips.fingertip, modes) for name in sim.names}
    _, _, p_min_pa, _ = allowed_ranges(tips.fingertip, modes)
    strip_pad = {model.body(strip).id: k for k, pad in enumerate(tips.pads) for strip in pad.strips}
    ball_geom = model.geom("ball").id
    # Each fingertip's five sensors' addresses in data.sensordata (fingertips x FIELDS).
    address = np.array([[model.sensor(f"piezotip/{name}/{field}").adr[0] for field in FIELDS] for name in sim.names])

    # The readout samples once a period (sim.substeps steps, sim.period_s): in the callback of
    # the step that starts at a period's end.  As for every MuJoCo sensor, the values after an
    # mj_step (and its contacts) are those of the state it started from.
    steps = round(seconds / model.opt.timestep)
    periods = steps // sim.substeps
    columns = {field: np.full((periods, len(FINGERTIPS)), np.nan) for field in FIELDS}
    touching = np.zeros((periods, len(FINGERTIPS)), dtype=bool)
    resets = [data.warning[w].number for w in _RESETS]
    for i in range(periods * sim.substeps + 1):
        t = data.time
        for joint, target in script.targets(t).items():
            data.ctrl[actuators[joint]] = target
        mujoco.mj_step(model, data)
        if i == 0 or i % sim.substeps:
            continue
        if [data.warning[w].number for w in _RESETS] != resets:  # MuJoCo reset the data and stepped on
            raise RuntimeError(f"the simulation diverged before t = {data.time:.4f} s (MuJoCo reset the data to its initial state)")
        k = i // sim.substeps - 1
        values = data.sensordata[address]
        for f, field in enumerate(FIELDS):
            columns[field][k] = values[:, f]
        touching[k] = _touching(model, data, strip_pad, ball_geom, len(FINGERTIPS))
        for j, name in enumerate(sim.names):
            pressure, sigma, status, mode, _ = values[j]
            drive, _ = selectors[name].update(_Estimate(float(pressure), float(sigma), STATUS_NAMES[int(status)]))
            if drive != mode:
                sim.set_mode(name, drive)  # from the next period on: it rings up, "settling" meanwhile
    return SkinRecord(
        fingertips=tuple(name.removesuffix("_pad") for name in sim.names),
        time_s=sim.period_s * np.arange(1, periods + 1),
        pressure_pa=columns["pressure_pa"],
        sigma_pa=columns["sigma_pa"],
        status=columns["status"].astype(np.int8),
        mode=columns["mode"].astype(np.int8),
        true_pressure_pa=columns["true_pressure_pa"],
        touching=touching,
        detection_limit_pa=p_min_pa[modes[0]],
        closed_s=script.closed_s,
        hold_from_s=hold_from_s(model, script),
    )


# ---------------------------------------------------------------------------------------
# What it writes and prints.
# ---------------------------------------------------------------------------------------

#: The per-fingertip columns of the CSV and the npz: (record field, column name with its unit).
COLUMNS = (
    ("pressure_pa", "pressure_pa"),
    ("sigma_pa", "sigma_pa"),
    ("status", "status"),
    ("mode", "mode"),
    ("true_pressure_pa", "true_pressure_pa"),
    ("touching", "touching_ball"),
)


def save_readings(record: SkinRecord, out: Path) -> tuple[Path, Path]:
    """``readings.npz`` (arrays: time x fingertip; the status as an index into ``status_names``)
    and ``readings.csv`` (one row per period and fingertip; the status by name)."""
    npz = out / "readings.npz"
    np.savez(
        npz,
        time_s=record.time_s,
        fingertips=np.array(record.fingertips),
        status_names=np.array(STATUS_NAMES),
        detection_limit_pa=record.detection_limit_pa,
        closed_s=record.closed_s,
        hold_from_s=record.hold_from_s,
        **{column: getattr(record, field) for field, column in COLUMNS},
    )
    path = out / "readings.csv"
    status = [column for _, column in COLUMNS].index("status")
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["time_s", "fingertip", *(column for _, column in COLUMNS)])
        for k, t in enumerate(record.time_s):
            for j, tip in enumerate(record.fingertips):
                row = [_csv_value(getattr(record, field)[k, j]) for field, _ in COLUMNS]
                row[status] = STATUS_NAMES[int(record.status[k, j])]
                writer.writerow([f"{t:.4f}", tip, *row])
    return npz, path


def _csv_value(value) -> str:
    if isinstance(value, np.bool_ | np.integer):
        return str(int(value))
    return f"{value:.6g}" if math.isfinite(value) else ""


@dataclass(frozen=True)
class TipSummary:
    """One fingertip over the run and over the hold.

    Attributes
    ----------
    fingertip : its name.
    peak_true_pa : the largest true pressure of the run, Pa.
    touched, holds : whether it touched the ball at all, and in the hold (at any period of it).
    ok, within : its "ok" readings and how many held the truth within 3 sigma, over the run.
    hold_ok, hold_within : the same in the hold.
    """

    fingertip: str
    peak_true_pa: float
    touched: bool
    holds: bool
    ok: int
    within: int
    hold_ok: int
    hold_within: int


def summarize(record: SkinRecord) -> list[TipSummary]:
    """Per fingertip, what the run and its hold read (:class:`TipSummary`)."""
    ok, held, hold = record.ok(), record.within_3_sigma(), record.hold
    return [
        TipSummary(
            fingertip=tip,
            peak_true_pa=float(np.max(record.true_pressure_pa[:, j])),
            touched=bool(record.touching[:, j].any()),
            holds=bool(record.touching[hold, j].any()),
            ok=int(ok[:, j].sum()),
            within=int(held[:, j].sum()),
            hold_ok=int(ok[hold, j].sum()),
            hold_within=int(held[hold, j].sum()),
        )
        for j, tip in enumerate(record.fingertips)
    ]


def _share(within: int, ok: int) -> str:
    return f"{100 * within / ok:.1f} % of {ok}" if ok else f"- of {ok}"


#: How each status is drawn along the bottom of a panel (the run plot's colours, analysis/run_report.py).
STATUS_STYLE = {"ok": ("tab:green", 0.8), "below_detection": ("0.7", 0.5), "saturated": ("tab:red", 0.8), "settling": ("gold", 0.6)}
#: The pressure axis's floor, Pa (log scale; a band reaching zero runs off it).
PRESSURE_FLOOR_PA = 0.1


#: How far the error strip under each panel reaches, sigmas (errors beyond are drawn at its edge).
ERROR_STRIP_SIGMA = 10.0
#: Mode switches closer than this fraction of the run share one label ("m2, m3").
MODE_LABEL_SPAN = 0.03


def plot_skin(record: SkinRecord, path: Path) -> Path:
    """``skin.png``: per fingertip a panel of the truth against the "ok" estimates and their
    3-sigma band (mode 1's detection limit, the status along the bottom, the modes driven), and
    under it a strip of each "ok" reading's error in its own sigmas against the +-3 sigma band
    (on the pressure panel's log scale a 1-5 % sigma is too thin to see)."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    from piezotip.analysis.plotting import PNG_COMPRESS_LEVEL

    t, n = record.time_s, len(record.fingertips)
    fig = Figure(figsize=(10, 2.9 * n + 0.8), layout="constrained")
    axes = []
    for panel in fig.subfigures(n, 1):  # per fingertip its pressure and error axes, one time axis for all
        grid = panel.add_gridspec(2, 1, height_ratios=[3.0, 1.0])
        for row in (0, 1):
            axes.append(panel.add_subplot(grid[row], sharex=axes[0] if axes else None))
    ok, summary = record.ok(), summarize(record)
    with np.errstate(invalid="ignore", divide="ignore"):
        error = np.where(ok, (record.pressure_pa - record.true_pressure_pa) / record.sigma_pa, np.nan)
    top = max(10 * PRESSURE_FLOOR_PA, float(np.nanmax(np.where(ok, record.pressure_pa + 3 * record.sigma_pa, record.true_pressure_pa))))
    for j, s in enumerate(summary):
        ax, strip = axes[2 * j], axes[2 * j + 1]
        for a in (ax, strip):
            a.axvspan(record.hold_from_s, t[-1], color="0.93", lw=0, zorder=0)
            a.axvline(record.closed_s, color="0.6", lw=0.8, ls="--")
        truth = record.true_pressure_pa[:, j]
        ax.plot(t, np.where(truth > 0, truth, np.nan), color="tab:blue", lw=2.5, alpha=0.45, label="true pressure")
        est, sigma = np.where(ok[:, j], record.pressure_pa[:, j], np.nan), np.where(ok[:, j], record.sigma_pa[:, j], np.nan)
        low = np.maximum(np.nan_to_num(est - 3 * sigma), 0.5 * PRESSURE_FLOOR_PA)
        band = "estimate $\\pm 3\\sigma$"
        ax.fill_between(t, low, np.nan_to_num(est + 3 * sigma), where=ok[:, j], color="tab:orange", alpha=0.5, lw=0, label=band)
        ax.plot(t, est, ".", ms=2.5, color="saddlebrown", label='estimate (status "ok")')
        ax.axhline(record.detection_limit_pa, color="0.4", ls=":", lw=1, label="detection limit (mode 1)")
        for code, name in enumerate(STATUS_NAMES):
            color, alpha = STATUS_STYLE[name]
            spans = [(t[a] - (t[1] - t[0]), t[b - 1] - t[a] + (t[1] - t[0])) for a, b in _runs(record.status[:, j] == code)]
            ax.broken_barh(spans, (0, 0.05), transform=ax.get_xaxis_transform(), color=color, alpha=alpha, lw=0)
        labels: list[tuple[float, list[str]]] = []  # switches closer than a label's width share one
        for k in np.flatnonzero(np.diff(record.mode[:, j])) + 1:
            if labels and t[k] - labels[-1][0] < MODE_LABEL_SPAN * (t[-1] - t[0]):
                labels[-1][1].append(f"m{record.mode[k, j]}")
            else:
                labels.append((t[k], [f"m{record.mode[k, j]}"]))
        for at, names in labels:
            ax.annotate(", ".join(names), (at, 1.0), xycoords=("data", "axes fraction"), fontsize=7, ha="left", va="bottom", color="0.3")
        ax.set_yscale("log")
        ax.set_ylim(PRESSURE_FLOOR_PA, 3 * top)
        ax.set_ylabel("pressure [Pa]")
        touch = "holds the ball" if s.holds else "touches the ball, not in the hold" if s.touched else "never touches the ball"
        ax.set_title(
            f"{FINGER_NAMES[s.fingertip]} ({s.fingertip}): {touch}; peak {s.peak_true_pa / 1e3:.3g} kPa; "
            f"ok readings within 3$\\sigma$: {_share(s.within, s.ok)} (hold: {_share(s.hold_within, s.hold_ok)})",
            fontsize=9,
            loc="left",
            pad=9,
        )
        strip.axhspan(-3, 3, color="tab:orange", alpha=0.25, lw=0)
        strip.plot(t, np.clip(error[:, j], -ERROR_STRIP_SIGMA, ERROR_STRIP_SIGMA), ".", ms=2, color="saddlebrown")
        strip.set_ylim(-ERROR_STRIP_SIGMA * 1.1, ERROR_STRIP_SIGMA * 1.1)
        strip.set_yticks([-ERROR_STRIP_SIGMA, -3, 3, ERROR_STRIP_SIGMA])
        strip.tick_params(axis="y", labelsize=7)
        strip.set_ylabel("error\n[$\\sigma$]", fontsize=8)
    for a in axes[:-1]:
        a.tick_params(labelbottom=False)
    axes[-1].set_xlabel("time [s]   (dashed: the hand closed; grey: the hold; m2, m3: the mode driven from there)")
    handles, _ = axes[0].get_legend_handles_labels()
    handles += [Patch(facecolor=c, alpha=a, label=f"status: {n.replace('_', ' ')}") for n, (c, a) in STATUS_STYLE.items()]
    fig.legend(handles=handles, loc="outside upper center", ncol=4, fontsize=8, frameon=False)
    fig.savefig(path, dpi=120, format="png", pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    return path


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The (first, stop) index pairs of ``mask``'s runs of True."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(), strict=True))


def print_summary(record: SkinRecord) -> None:
    print(f"ok readings within 3 sigma of the truth: over the run, and in the hold (from {record.hold_from_s:g} s)")
    print(f"{'fingertip':<15} {'touches':>15} {'peak true (Pa)':>15} {'run':>15} {'hold':>15}")
    for s in summarize(record):
        touch = "in the hold" if s.holds else "before the hold" if s.touched else "never"
        run, hold = _share(s.within, s.ok), _share(s.hold_within, s.hold_ok)
        print(f"{FINGER_NAMES[s.fingertip]:<15} {touch:>15} {s.peak_true_pa:15.1f} {run:>15} {hold:>15}")


def bench(scene: Path, steps: int = 500, repeats: int = 5) -> dict[str, float]:
    """What the five fingertips cost the hand per ``mj_step`` (us, the fastest of ``repeats``
    rounds of ``steps``, the variants alternating in one process): the hand with its pad sites
    and the ball (``bare``), with gel pads (``attach``'s default) and with touch pads
    (``pad="touch"``: no pad geometry), each bound and stepped from the same start (the ball
    dropping onto the palm, the hand open: its own dynamics, its contacts, every readout)."""
    variants = {}
    for kind in ("bare", "gel", "touch"):
        spec = build_scene(scene)
        tips = None if kind == "bare" else piezotip.attach(spec, sites=[f"{tip}_pad" for tip in FINGERTIPS], pad=kind)
        model = spec.compile()
        data = mujoco.MjData(model)
        if tips is not None:
            tips.bind(model, data)
        variants[kind] = (model, data)
    best = dict.fromkeys(variants, math.inf)
    for _ in range(repeats):
        for kind, (model, data) in variants.items():
            start = time.perf_counter()
            for _ in range(steps):
                mujoco.mj_step(model, data)
            best[kind] = min(best[kind], 1e6 * (time.perf_counter() - start) / steps)
    return best


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("out/shadow-hand"), help="output folder (default out/shadow-hand)")
    parser.add_argument("--seconds", type=float, default=4.0, help="simulated time, s (default 4; the hold's readings start at 2.8 s)")
    parser.add_argument("--bench", action="store_true", help="only time mj_step: the hand bare, with gel pads, with touch pads")
    args = parser.parse_args(argv)
    script = GraspScript()
    if not script.closed_s < args.seconds <= 60:
        parser.error(f"--seconds must be in ({script.closed_s:g}, 60] (the hand is closed at {script.closed_s:g} s), got {args.seconds!r}")
    scene = hand_assets()
    if scene is None:
        print("the Shadow Hand needs Gymnasium-Robotics: pip install -e '.[hand]'", file=sys.stderr)
        return 2
    if args.bench:
        times = bench(scene)
        print("the Shadow Hand's mj_step with five fingertips (fastest round; ratios measured side by side):")
        for kind, us in times.items():
            print(f"  {kind:<6} {us:7.1f} us/step  {us / times['bare']:5.2f}x bare")
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    record = run(scene, args.seconds, script)
    files = [*save_readings(record, args.out), plot_skin(record, args.out / "skin.png")]
    print_summary(record)
    print("wrote " + ", ".join(str(f) for f in files))
    return 0


if __name__ == "__main__":
    sys.exit(main())

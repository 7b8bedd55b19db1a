"""The referee: one outcome for a grasp, judged from the physics record as a person watching would.

It reads the simulator's ground truth (the object's position and velocity, the table's and each
finger's contact force), which no controller ever sees, and the controller's own account (its
events: give-ups and faults, which explain a failure but never make a success).

Outcomes, in the order they are decided (the first that applies wins):

``fault``         the simulation diverged, or the controller refused or stopped on a sensor
                  fault (self-test, a reading out of range);
``crushed``       a finger pressed harder than the object's crush limit at any time;
``dropped``       the object fell: it was free (not held by both fingers, not on the table)
                  above the table, or it landed faster than ``landing_speed_m_s``, or it was let
                  go and did not come to rest where it started;
``slipped``       while carried, the object moved in the fingers by more than
                  ``slip_tolerance_m``;
``blind``         the controller gave up because the grip the load needed was more than the
                  fingertip can measure;
``never_lifted``  the object never rose to the target height (it never left the table, or
                  the controller gave up before), a finger having touched it or the
                  controller having finished;
``timeout``       the scenario's time ran out before the controller finished: the object
                  lifted, or no finger ever touched it (nothing was tried on the object, so
                  it is not ``never_lifted``);
``success``       lifted to the target height, held there for the hold time with slip under
                  tolerance, put back (resting within ``placed_tolerance_m`` of its starting
                  height, landing under ``landing_speed_m_s``), released, never crushed.

The run's validity is separate: ``outside_model`` lists where the gel or the element left the
model's valid range (the outcome stands; the flag says how far to trust it).

Besides the outcome, the referee measures (:class:`Verdict`): the grip economy (the grip held
against the grip needed), the touch (``touch_peak_n``, ``time_to_touch_s``) and, where the
scenario puts an extra load on the held object (``disturb.*``), the answer to it
(``disturb_slip_mm``, ``disturb_reaction_ms``, ``disturb_grip_margin``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

OUTCOMES = ("success", "crushed", "slipped", "dropped", "never_lifted", "blind", "timeout", "fault")

#: The recorded ``phase`` codes the referee reads (cosim.control.Phase's values, which the record
#: keeps stable): the closing's start and the hold.
CLOSE_PHASE = 1
HOLD_PHASE = 4

#: The share by which the true grip must rise over its value at a disturbance's onset to count as
#: the controller's answer (``disturb_reaction_ms``): 10 %.
REACTION_RISE = 0.1


@dataclass(frozen=True)
class Criteria:
    """What a watcher would call success, stated once.

    Attributes
    ----------
    slip_tolerance_m : the most the object may move in the fingers while carried, m (5 mm: a
        quarter of the 20 mm pad; more and a watcher sees it slide).
    placed_tolerance_m : a placed object rests within this of its starting height, m; an object
        higher than this above its start is off the table, m.
    landing_speed_m_s : the fastest a placed object may meet the table, m/s (0.1 m/s: the speed
        of a 0.5 mm fall; faster is a drop a watcher hears).
    rest_speed_m_s : below this speed the object is at rest, m/s.
    contact_force_n : a finger touches the object when its contact force exceeds this, N.
    """

    slip_tolerance_m: float = 0.005
    placed_tolerance_m: float = 0.002
    landing_speed_m_s: float = 0.1
    rest_speed_m_s: float = 0.005
    contact_force_n: float = 1e-6


@dataclass(frozen=True)
class Disturbance:
    """A load change while the object is held, as the referee needs it (scenarios.config.DisturbConfig).

    Attributes
    ----------
    extra_load_n : the extra downward load that came on, N.
    ramp_s : its rise time, s.
    needed_grip_n : the least grip that holds the object under it, N per finger:
        (m g + extra) / (2 mu) (:func:`needed_grip_n` with ``extra_load_n``).
    """

    extra_load_n: float
    ramp_s: float
    needed_grip_n: float


@dataclass(frozen=True)
class Verdict:
    """The referee's judgement of one run (lengths m, speeds m/s, forces N, times s).

    Grip economy, from the truth: ``hold_grip_n`` is the fingers' true force on the object (the
    mean of the two fingers, N) as a median over the samples in which the object was carried
    clear of the table (NaN if it never was); ``needed_grip_n`` the least grip that holds it
    (:func:`needed_grip_n`: on the contacts as they were while held, where the record has
    their tilts and the judge the friction, else on level contacts); ``contact_tilt_deg`` the
    fingers' mean contact tilt below the horizontal while held (deg: positive where they press
    the object down, NaN where not recorded); ``grip_margin`` their ratio (1 holds it exactly;
    people keep 1.1-1.4);
    ``peak_contact_n`` the largest true force of either finger at any time (touch, lift, touchdown
    and release included; over every physics step where the record has the peaks), N.

    The touch (:func:`touch_metrics`): ``touch_peak_n`` is the largest true force of either
    finger from the first contact until the object leaves the table, N; ``time_to_touch_s`` the
    time from the start of closing to the first contact, s.  NaN where never touched.

    A load change while held (:func:`disturbance_metrics`; NaN without one, or where the object
    was never held when it came): ``disturb_slip_mm`` the object's largest movement relative to
    the pads from the load's onset to the end of the hold, mm; ``disturb_reaction_ms`` the time
    from the onset until the true grip has risen by 10 % over its value then, ms;
    ``disturb_hold_grip_n`` the new hold's grip, N; ``disturb_needed_grip_n`` the grip that holds
    the object under the load, (m g + extra) / (2 mu) on level contacts (as the need, on the
    contacts' tilts where known), N; ``disturb_grip_margin`` their ratio.
    """

    outcome: str
    reason: str
    lifted: bool
    placed: bool
    released: bool
    crushed: bool
    slipped: bool
    dropped: bool
    object_start_height_m: float
    object_final_height_m: float
    max_rise_m: float
    max_slip_m: float
    landing_speed_m_s: float
    held_s: float
    peak_grip_force_n: float
    hold_grip_n: float = math.nan
    needed_grip_n: float = math.nan
    grip_margin: float = math.nan
    contact_tilt_deg: float = math.nan
    peak_contact_n: float = math.nan
    touch_peak_n: float = math.nan
    time_to_touch_s: float = math.nan
    disturb_slip_mm: float = math.nan
    disturb_reaction_ms: float = math.nan
    disturb_hold_grip_n: float = math.nan
    disturb_needed_grip_n: float = math.nan
    disturb_grip_margin: float = math.nan

    @property
    def success(self) -> bool:
        return self.outcome == "success"

    def as_dict(self) -> dict:
        d = {k: getattr(self, k) for k in self.__dataclass_fields__}
        d["success"] = self.success
        return d


def needed_grip_n(
    mass_kg: float,
    friction: float,
    gravity_m_s2: float = 9.81,
    fingers: int = 2,
    extra_load_n: float = 0.0,
    tilts_rad: Sequence[float] | None = None,
) -> float:
    """The least grip that holds an object against gravity by friction, N per finger.

    The grip G is each finger's horizontal push on the object (equal and opposite between two
    fingers).  On level contacts (normals horizontal) each finger carries at most ``friction``
    times G: the object is held while ``fingers * friction * G >= m g``, so
    ``G = m g / (fingers * friction)`` (m g / (2 mu) for a two-finger grip).

    On tilted contacts (``tilts_rad``, one per finger: the angle a of the contact's normal below
    the horizontal, positive where the finger presses the object down, as on a round object
    held above its centre): the finger's force lies in its friction cone about the normal, of
    half-angle phi = atan(mu), so for a horizontal push G its largest upward part is
    G tan(phi - a).  The object is held while ``sum_i G tan(phi - a_i) >= m g``:
    ``G = m g / sum_i tan(phi - a_i)``, the wedge's self-locking law (Coulomb friction on an
    inclined face; a = 0 gives m g / (2 mu), and G grows without bound as a nears phi: no
    squeeze holds a sphere pinched above its centre by more than its friction angle, ``inf``).

    ``mass_kg`` in kg, ``friction`` the pad-object coefficient (dimensionless), ``gravity_m_s2``
    in m/s^2.  An ``extra_load_n`` (N, downward, a disturbance's) adds to the weight: (m g + extra).
    """
    tilts = None if tilts_rad is None else [float(a) for a in tilts_rad]
    if not (mass_kg > 0 and friction > 0 and gravity_m_s2 > 0 and fingers > 0 and 0 <= extra_load_n < math.inf):
        got = f"{mass_kg!r} kg, friction {friction!r}, {gravity_m_s2!r} m/s^2, {fingers!r} fingers, {extra_load_n!r} N extra"
        raise ValueError(f"needed_grip_n needs positive mass, friction, gravity and fingers and a finite extra load >= 0, got {got}")
    load_n = mass_kg * gravity_m_s2 + extra_load_n
    if tilts is None:
        return load_n / (fingers * friction)
    if not tilts or not all(abs(a) < math.pi / 2 for a in tilts):
        raise ValueError(f"needed_grip_n: tilts_rad must be one angle per finger within (-pi/2, pi/2) rad, got {tilts_rad!r}")
    total = sum(_lift_per_grip(friction, a) for a in tilts)
    return load_n / total if total > 0 else math.inf


def _lift_per_grip(friction: float, tilt_rad: float) -> float:
    """tan(phi - a), phi = atan(mu): the most a finger holds up per unit of horizontal grip on a
    contact tilted ``tilt_rad`` below the horizontal, as (mu - tan a) / (1 + mu tan a) (exactly mu
    at a = 0); 0 past the friction angle (it holds nothing), inf where the cone reaches past the
    vertical (a contact under the object: it carries any weight)."""
    t = math.tan(tilt_rad)
    if t >= friction:
        return 0.0
    below = 1.0 + friction * t
    return (friction - t) / below if below > 0 else math.inf


def contact_tilts(data: dict[str, np.ndarray], held: np.ndarray) -> tuple[float, float] | None:
    """Each finger's contact tilt while the object was held (rad, below the horizontal: the
    record's ``{side}_contact_tilt_rad``, median over the samples ``held``), or None where the
    record has no such columns or the fingers touched nothing there."""
    columns = ("left_contact_tilt_rad", "right_contact_tilt_rad")
    if not all(c in data for c in columns) or not held.any():
        return None
    tilts = [np.asarray(data[c], float)[held] for c in columns]
    if not all(np.isfinite(a).any() for a in tilts):
        return None
    return float(np.nanmedian(tilts[0])), float(np.nanmedian(tilts[1]))


def tilted_need_factor(friction: float, tilts_rad: Sequence[float]) -> float:
    """The least grip on the fingers' tilted contacts over that on level ones (>= 1 where they
    press the object down): :func:`needed_grip_n` with the tilts over it without."""
    return needed_grip_n(1.0, friction, 1.0, fingers=len(tilts_rad), tilts_rad=tilts_rad) * len(tilts_rad) * friction


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the True runs of ``mask``."""
    padded = np.concatenate([[False], mask, [False]])
    edges = np.flatnonzero(padded[1:] != padded[:-1])
    return list(zip(edges[::2], edges[1::2], strict=True))


def _landing_speed(vz: np.ndarray, table: np.ndarray, after: int) -> float:
    """Fastest downward speed at which the object met the table after sample ``after``, m/s."""
    speeds = [0.0]
    for start, _stop in _runs(table[after:]):
        i = after + start
        if i == after:
            continue  # on the table already at ``after``: not a landing
        window = vz[max(i - 2, 0) : i + 1]
        speeds.append(float(max(-window.min(), 0.0)))
    return max(speeds)


def touch_metrics(
    time_s: np.ndarray, phase: np.ndarray | None, force_n: np.ndarray, touching: np.ndarray, off_table: np.ndarray
) -> tuple[float, float]:
    """(``touch_peak_n``, ``time_to_touch_s``): how hard, and how soon, the fingers first touch.

    Parameters
    ----------
    time_s : the record's times, s.
    phase : its ``phase`` codes (cosim.control.Phase), or None where the record has none.
    force_n : the larger of the two fingers' true forces on the object per sample (their peak
        over the period's physics steps where recorded), N.
    touching : per sample, whether either finger's true force exceeds the contact threshold
        (Criteria.contact_force_n, 1 uN): the first such sample is the first contact.
    off_table : per sample, whether the object is more than Criteria.placed_tolerance_m (2 mm)
        above its start: the referee's lift-off.

    ``touch_peak_n`` (N) is ``force_n``'s largest value from the first contact up to the last
    sample before the object first leaves the table (2 mm up, as the referee's ``off_table``
    says) after it; to the end of the record where it never leaves.  ``time_to_touch_s`` (s) is
    the time from the start of closing (the first sample recorded in the close phase, the phase
    the controller commanded at that time) to the first contact: within one control period,
    the record's resolution; negative where something touched the object before the fingers
    closed, NaN without a close phase.  Both NaN where nothing ever touched the object.
    """
    contact = np.flatnonzero(touching)
    if contact.size == 0:
        return math.nan, math.nan
    first = int(contact[0])
    lifted = np.flatnonzero(off_table[first:])
    end = first + int(lifted[0]) if lifted.size else time_s.size
    peak = float(np.max(force_n[first : max(end, first + 1)]))
    closing = np.flatnonzero(phase == CLOSE_PHASE) if phase is not None else np.zeros(0, int)
    to_touch = float(time_s[first] - time_s[closing[0]]) if closing.size else math.nan
    return peak, to_touch


def impact_n(data) -> float:
    """The touch's own force from a run's record, N: the largest true finger force (the physics
    steps' peak where recorded) from the first contact until the lift phase begins; NaN where
    nothing touched."""
    from piezotip.cosim.control import phase_index

    left, right = (data.get(f"{side}_finger_peak_force_n", data[f"{side}_finger_force_n"]) for side in ("left", "right"))
    force = np.maximum(left, right)
    touched = np.flatnonzero(force > 1e-6)
    if touched.size == 0:
        return math.nan
    lifting = np.flatnonzero(data["phase"] >= phase_index("lift"))
    end = lifting[0] if lifting.size else force.size
    return float(force[touched[0] : max(end, touched[0] + 1)].max())


def disturb_onset_s(time_s: np.ndarray, phase: np.ndarray | None, hold_s: float) -> float:
    """When a disturbance's load came on, s: the middle of the hold as the controller's phases
    define it, the first sample recorded in the hold phase plus half of ``hold_s`` (s) (the
    loop's schedule, cosim.disturb.onset_s); NaN where the record never holds."""
    held = np.flatnonzero(phase == HOLD_PHASE) if phase is not None else np.zeros(0, int)
    return float(time_s[held[0]]) + 0.5 * hold_s if held.size else math.nan


def disturbance_metrics(data: dict[str, np.ndarray], hold_s: float, disturbance: Disturbance, clear: np.ndarray) -> dict[str, float]:
    """The answer to a load change while held (:class:`Verdict`'s ``disturb_*``), from the record.

    The load came on at :func:`disturb_onset_s`; the disturbance lasts from there to the end of
    the hold (its last sample in the hold phase).  Over it:

    - ``disturb_slip_mm``: the object's largest movement relative to the pads, mm: its centre
      in the gripper's frame (x, y, height less the lift's position: the fingers only translate
      with the lift), against where it was at the onset;
    - ``disturb_reaction_ms``: from the onset to the first sample from which the true grip (the
      two fingers' mean true force on the object, N) stays at least 10 % (REACTION_RISE) over its
      value at the onset to the end of the hold, ms.  The rise must last: pads sliding under the
      load chatter, and their force swings by +-50 % from one period to the next (the gentle
      controller's box read 1.15x 40 ms after the onset while it slid out of the fingers), which
      is no answer.  NaN where the grip never rises for good (a drop included);
    - ``disturb_hold_grip_n``: the new hold's grip, N: the true grip's median over the samples
      from the ramp's end to the end of the hold in which the object was carried clear of the
      table (``clear``); ``disturb_needed_grip_n`` the disturbance's ``needed_grip_n``;
      ``disturb_grip_margin`` their ratio.

    All but the needed grip are NaN where the record never held, or ended before the onset.
    """
    t = np.asarray(data["time_s"], float)
    result = dict.fromkeys(("disturb_slip_mm", "disturb_reaction_ms", "disturb_hold_grip_n", "disturb_grip_margin"), math.nan)
    result["disturb_needed_grip_n"] = float(disturbance.needed_grip_n)
    phase = data.get("phase")
    onset = disturb_onset_s(t, phase, hold_s)
    held = np.flatnonzero(phase == HOLD_PHASE) if phase is not None else np.zeros(0, int)
    if not math.isfinite(onset) or t[-1] < onset:
        return result
    # The hold's end: the last sample of its first run in the hold phase (a later hold is none).
    breaks = np.flatnonzero(np.diff(held) != 1)
    end = int(held[breaks[0]]) if breaks.size else int(held[-1])
    start = int(np.searchsorted(t, onset + 1e-9 * max(1.0, abs(onset)), side="right")) - 1  # the last sample at or before the onset
    if start < 0 or end < start:
        return result
    window = slice(start, end + 1)
    rel = np.stack([data["object_x_m"], data["object_y_m"], data["object_height_m"] - data["lift_m"]], axis=1)[window]
    result["disturb_slip_mm"] = 1e3 * float(np.linalg.norm(rel - rel[0], axis=1).max())
    grip = 0.5 * (data["left_finger_force_n"] + data["right_finger_force_n"])
    g0 = float(grip[start])
    if g0 > 0:  # (the onset's own sample is below the rise: ``below`` is never empty)
        below = np.flatnonzero(grip[window] < (1.0 + REACTION_RISE) * g0)
        risen = start + int(below[-1]) + 1  # the first sample of the rise that lasts to the end
        if risen <= end:
            result["disturb_reaction_ms"] = 1e3 * float(t[risen] - onset)
    settled = np.zeros(t.size, bool)
    settled[window] = t[window] >= onset + disturbance.ramp_s - 1e-9
    settled &= clear
    if settled.any():
        hold = float(np.median(grip[settled]))
        result["disturb_hold_grip_n"] = hold
        need = float(disturbance.needed_grip_n)
        result["disturb_grip_margin"] = hold / need if need > 0 else math.nan
    return result


def judge(
    data: dict[str, np.ndarray],
    lift_height_m: float,
    hold_s: float,
    crush_force_n: float | None,
    events: list[dict] | tuple = (),
    finished: bool = True,
    error: str | None = None,
    criteria: Criteria = Criteria(),
    needed_grip: float | None = None,
    disturbance: Disturbance | None = None,
    friction: float | None = None,
) -> Verdict:
    """Judge one recorded run.

    Parameters
    ----------
    data : the record's columns: ``time_s``, ``lift_m`` and the ground truth
        (``object_height_m``, ``object_x_m``, ``object_y_m``, ``object_vz_m_s``,
        ``object_speed_m_s``, ``table_force_n``, ``left_finger_force_n``,
        ``right_finger_force_n``: each finger's push on the object, the house gripper's fingers
        or, with ``gripper.mjcf``, the fingers that carry the named fingertips, whole (the body
        under the gripper's common root that holds each: cosim.gripper_mount); and, for an
        object with a crush limit, each finger's peak over
        the period's physics steps, ``left_finger_peak_force_n``, ``right_finger_peak_force_n``,
        on which the crush and ``peak_grip_force_n`` are judged).
    lift_height_m, hold_s : what the controller was asked to do, m and s.
    crush_force_n : the object's crush limit per finger, N (None: robust).
    events : the controller's events (dicts with ``kind``, ``message``, ``time_s``).
    finished : whether the controller finished before the time ran out.
    error : the message of an error that stopped the run (a divergence), or None.
    needed_grip : the least grip that holds the object on level contacts, N per finger
        (:func:`needed_grip_n` of its simulated mass and friction); None leaves
        ``needed_grip_n`` and ``grip_margin`` NaN.
    friction : the pad-object friction coefficient.  Given, with the record's contact tilts
        (``{side}_contact_tilt_rad``), the need (and a disturbance's) is the one on the fingers'
        contacts as they were while the object was held (:func:`needed_grip_n`'s tilts: a
        round object held above its centre needs more than on level contacts).
    disturbance : the load change the run put on the held object (:class:`Disturbance`), or None
        (the ``disturb_*`` fields NaN).  Its onset is read from the record's ``phase`` column, as
        are the start of closing and the hold (:func:`touch_metrics`, :func:`disturbance_metrics`).
    """
    c = criteria
    t = np.asarray(data.get("time_s", ()), float)
    if t.size == 0:
        nothing = Verdict("fault", error or "nothing was recorded", *([False] * 6), *([math.nan] * 2), 0.0, 0.0, 0.0, 0.0, 0.0)
        needed_disturbed = math.nan if disturbance is None else float(disturbance.needed_grip_n)
        return dataclasses.replace(
            nothing, needed_grip_n=math.nan if needed_grip is None else float(needed_grip), disturb_needed_grip_n=needed_disturbed
        )
    z = data["object_height_m"]
    z0 = float(z[0])
    rise = z - z0
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    left, right = data["left_finger_force_n"], data["right_finger_force_n"]
    gripped = (left > c.contact_force_n) & (right > c.contact_force_n)
    touching = (left > c.contact_force_n) | (right > c.contact_force_n)
    on_table = data["table_force_n"] > c.contact_force_n
    off_table = rise > c.placed_tolerance_m
    carried = gripped & off_table
    max_rise = float(rise.max())
    lift_tol = c.slip_tolerance_m
    lifted = max_rise >= lift_height_m - lift_tol

    # Slip: the object's position in the gripper's frame (which only translates, by lift_m).
    max_slip = 0.0
    if carried.any():
        rel = np.stack([data["object_x_m"], data["object_y_m"], z - data["lift_m"]], axis=1)[carried]
        max_slip = float(np.linalg.norm(rel - rel[0], axis=1).max())
    slipped = max_slip > c.slip_tolerance_m
    held_s = float(np.count_nonzero(carried & (rise >= lift_height_m - lift_tol)) * dt)

    # Drops: free above the table (for two samples or more), or a hard landing after lift-off.
    free = off_table & ~gripped & ~on_table
    fell = [(a, b) for a, b in _runs(free) if b - a >= 2]
    first_off = int(np.argmax(off_table)) if off_table.any() else t.size
    landing = _landing_speed(data["object_vz_m_s"], on_table, first_off) if first_off < t.size else 0.0
    final_rise = float(rise[-1])
    at_rest = float(data["object_speed_m_s"][-1]) < c.rest_speed_m_s
    released = not touching[-1]
    resting_home = abs(final_rise) <= c.placed_tolerance_m and at_rest and bool(on_table[-1])
    placed = bool(max_rise > c.placed_tolerance_m and resting_home and landing <= c.landing_speed_m_s)
    dropped = bool(fell) or landing > c.landing_speed_m_s or (max_rise > c.placed_tolerance_m and released and not resting_home)

    # The fingers' peak over every physics step where it was recorded (an object with a crush
    # limit: cosim.rows.PEAK_COLUMNS), else their force at each control period.
    grip = np.maximum(data.get("left_finger_peak_force_n", left), data.get("right_finger_peak_force_n", right))
    peak_grip = float(grip.max())
    clear = gripped & off_table & ~on_table
    hold_grip = float(np.median(0.5 * (left + right)[clear])) if clear.any() else math.nan
    needed = math.nan if needed_grip is None else float(needed_grip)
    tilts = contact_tilts(data, clear)
    tilt_deg = math.nan if tilts is None else math.degrees(0.5 * (tilts[0] + tilts[1]))
    if tilts is not None and friction is not None:  # the need on the contacts as they were
        factor = tilted_need_factor(float(friction), tilts)
        needed *= factor
        if disturbance is not None:
            disturbance = dataclasses.replace(disturbance, needed_grip_n=disturbance.needed_grip_n * factor)
    crushed = crush_force_n is not None and peak_grip > crush_force_n
    phase = data.get("phase")
    touch_peak, time_to_touch = touch_metrics(t, phase, grip, touching, off_table)
    disturbed = disturbance_metrics(data, hold_s, disturbance, clear) if disturbance is not None else {}

    kinds = {e["kind"]: e for e in events}

    def told(*names: str) -> str:
        for name in names:
            if name in kinds:
                return f"{name}: {kinds[name]['message']} (t = {kinds[name]['time_s']:.2f} s)"
        return ""

    if error is not None:
        outcome, reason = "fault", error
    elif crushed:
        i = int(np.argmax(grip > crush_force_n))
        outcome, reason = "crushed", f"grip {peak_grip:.3g} N over the object's {crush_force_n:g} N crush limit (first at t = {t[i]:.2f} s)"
    elif dropped:
        if fell:
            a, _b = fell[0]
            outcome, reason = "dropped", f"fell from {1e3 * rise[a]:.1f} mm above the table at t = {t[a]:.2f} s"
        elif landing > c.landing_speed_m_s:
            outcome, reason = "dropped", f"landed at {landing:.2f} m/s (limit {c.landing_speed_m_s:g} m/s)"
        else:
            outcome, reason = "dropped", f"let go {1e3 * final_rise:+.1f} mm from its starting height, not resting there"
        reason += "; " + told("lost") if "lost" in kinds else ""
    elif slipped:
        tolerance = f"tolerance {1e3 * c.slip_tolerance_m:g} mm"
        outcome, reason = "slipped", f"moved {1e3 * max_slip:.1f} mm in the fingers while carried ({tolerance})"
    elif "self_test" in kinds or "out_of_range" in kinds:
        outcome, reason = "fault", told("self_test", "out_of_range")
    elif "blind" in kinds:
        outcome, reason = "blind", told("blind")
    elif not finished and not touching.any():
        # The clock ran out before anything touched: nothing was tried on the object, so no
        # failure to lift it can be judged (a run cut short is not one that gave up).
        outcome = "timeout"
        reason = f"the time ran out after {t[-1]:.2f} s before the fingers touched the object (the controller had not finished)"
    elif not lifted:
        why = told("never_lifted", "no_object", "unfelt_contact", "over_limit", "lost")
        outcome = "never_lifted"
        reason = f"rose {1e3 * max_rise:.1f} mm of the {1e3 * lift_height_m:g} mm asked" + (f"; {why}" if why else "")
    elif not finished:
        outcome, reason = "timeout", f"the controller had not finished after {t[-1]:.2f} s"
    elif held_s < hold_s - dt - 1e-9:
        why = told("over_limit", "lost", "never_lifted")
        outcome = "slipped" if "over_limit" in kinds else "timeout"
        reason = f"held {held_s:.2f} s of the {hold_s:g} s asked" + (f"; {why}" if why else "")
    elif not (placed and released):
        outcome = "timeout"
        reason = "not released" if not released else f"not placed: {1e3 * final_rise:+.1f} mm from its starting height"
    else:
        outcome, reason = "success", f"lifted {1e3 * max_rise:.1f} mm, held {held_s:.2f} s, placed at {landing:.3f} m/s, released"
    return Verdict(
        outcome=outcome,
        reason=reason,
        lifted=bool(lifted),
        placed=placed,
        released=bool(released),
        crushed=bool(crushed),
        slipped=bool(slipped),
        dropped=bool(dropped),
        object_start_height_m=z0,
        object_final_height_m=float(z[-1]),
        max_rise_m=max_rise,
        max_slip_m=max_slip,
        landing_speed_m_s=landing,
        held_s=held_s,
        peak_grip_force_n=peak_grip,
        hold_grip_n=hold_grip,
        needed_grip_n=needed,
        grip_margin=hold_grip / needed if needed > 0 else math.nan,
        contact_tilt_deg=tilt_deg,
        peak_contact_n=peak_grip,
        touch_peak_n=touch_peak,
        time_to_touch_s=time_to_touch,
        **disturbed,
    )


def outside_model(limits: dict) -> list[str]:
    """Where a run left the models' valid range, in words (empty: all within range)."""
    flags = []
    if limits.get("gel_beyond_valid_strain"):
        flags.append(f"gel strain {100 * limits['max_gel_strain']:.0f} % past its law's valid range")
    if limits.get("bottomed"):
        flags.append("gel bottomed on the housing")
    if limits.get("element_on_backstop"):
        flags.append("element resting on its backstop (readings outside the model)")
    if limits.get("element_overstressed"):
        flags.append(f"element overstressed ({limits['max_bending_stress_pa'] / 1e6:.0f} MPa)")
    return flags

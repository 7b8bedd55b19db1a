"""Each fidelity preset's price and error, side by side, and how far the reference is to be trusted.

Runs (``run_sim.py bench``).  For every standard scene every preset (scenarios/presets.py)
is run with its recorder, as ``run_sim.py run`` does, twice:

- with the multimode controller: its cost (wall time per simulated second), whether its
  referee outcome agrees with the reference's, when it felt the touch, and the grip it chose
  (the referee's hold grip and peak contact force: what decides an outcome, issue 29);
- at a fixed grip (:func:`scripted_overrides`): the scripted controller squeezes at twice the
  grip the object's weight needs and drives the one mode that resolves that grip's pressure
  best.  The pressures are compared here, not in the multimode runs: the multimode
  controller's grip follows what it measured and ratchets up while it lifts, so its held
  pressure differs between resolutions by its decisions (by 30 % between the reference and
  its halved steps on the light grasp), not by the physics or the sensor.  The fixed-grip
  runs stop a little after the window they are compared over (:func:`fixed_grip_duration_s`).

The errors, each pad's median over the held window (:func:`held_window`: the first second
after the lift has settled at the top), the worst pad:

- ``pressure_estimate``: relative difference of the pressure estimate, the number a grasp
  controller acts on;
- ``true_pressure``: the same for the true pad pressure (the physics' share of the error);
- ``output_v1``: absolute difference of the measured output V_1, V (same mode in both);
- ``touch_time_s``: the difference in the time touch was detected (multimode runs), s;
- ``hold_grip``, ``peak_contact``: relative difference of the referee's hold grip (the true
  finger force while carried) and peak contact force (multimode runs);
- ``outcome``: whether the multimode runs' referee outcome agrees with the reference's.

The reference's own convergence.  The fixed-grip run is repeated with every resolution step
of the reference halved once and twice (:func:`piezotip.scenarios.presets.reference_refined`:
timestep, pad strip width and carrier sampling interval together), and the multimode run with
them halved once (the touch time and outcome; its cost is the ``reference-halved`` row).  For
each compared quantity, from its three values q0 (the reference), q1, q2 (:func:`ladder_convergence`):

- the observed order p = log2((q0 - q1) / (q1 - q2)) (:func:`observed_order`);
- Richardson's limit q* = q2 + (q2 - q1) / (2^p - 1) (:func:`richardson`);
- the reference's uncertainty: 1.25 |q0 - q*| when the three are in the asymptotic range
  (both changes of one sign, p >= 0.5), else 3 max(|q0 - q1|, |q0 - q2|): Roache's safety
  factors for a three-resolution study and for one that does not show its order.

A preset's error below the reference's uncertainty on a scene is reported as that bound
("< u"), not as a value: the reference cannot tell it from its own error.  An error of at
least 3 u (:data:`CERTIFY_FACTOR`) is *certified*: the reference's own error changes it by
a third at most.  :func:`refinement_study` refines each step alone, to find which one limits
the reference (not part of ``bench``: it costs about a minute a scene).
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np

from piezotip.scenarios.presets import PRESETS, REFERENCE_HALVED, RESOLUTION_KNOBS, reference_refined

#: The standard scenes: a light grasp and the heaviest (all modes in use).
STANDARD_SCENES = ("grasp", "grasp-10kg")
#: The recorded codes of the "lift" and "hold" phases (cosim.control.Phase).
LIFT, HOLD = 3.0, 4.0
#: The issue's targets: fast within 5 % of reference, accurate within 1 %.
FAST_TARGET, ACCURATE_TARGET = 0.05, 0.01
ERROR_KINDS = ("pressure_estimate", "true_pressure", "output_v1", "touch_time_s", "hold_grip", "peak_contact")
#: The multimode runs' grip quantities compared (the summary's keys), by error kind.
GRIP_KINDS = {"hold_grip": "hold_grip_n", "peak_contact": "peak_contact_n"}

#: The held window: this long, from when the lift has settled within LIFT_SETTLED_M of where
#: it holds.  The scripted controller's hold lasts 1 s; a lift that sags more than the
#: controller's 2 mm under its load (the 10 kg block: 4.9 mm) never enters "hold", and is held
#: in "lift" instead: the window is found from the lift's position, not from the phase.
HELD_WINDOW_S = 1.0
LIFT_SETTLED_M = 1e-4
#: A window shorter than this share of HELD_WINDOW_S (the object dropped, the run cut short)
#: gives no value (NaN).
HELD_WINDOW_MIN_SHARE = 0.9
#: A fixed-grip run stops this long after the cheapest preset's held window ended: the others'
#: schedules differ from its by a control period or two (when the closing fingers stall).
CUT_MARGIN_S = 0.25

#: The reference's convergence ladder: its steps halved 0, 1, 2 times.
LADDER_HALVINGS = (0, 1, 2)
REFINEMENT_RATIO = 2.0
#: Below this observed order a three-value ladder is not taken as asymptotic (its Richardson
#: correction 1 / (2^p - 1) would exceed 2.4 times the last change).
MIN_ASYMPTOTIC_ORDER = 0.5
#: Roache's safety factors (Roache 1998, the grid convergence index): on a Richardson estimate
#: from three resolutions that show their order, and on a ladder that does not.
SAFETY_ASYMPTOTIC, SAFETY_NOT_ASYMPTOTIC = 1.25, 3.0
#: An error is certified when it is at least this many times the reference's uncertainty.
CERTIFY_FACTOR = 3.0


# ---------------------------------------------------------------------------------------
# Richardson extrapolation.
# ---------------------------------------------------------------------------------------


def observed_order(coarse: float, medium: float, fine: float, ratio: float = REFINEMENT_RATIO) -> float:
    """The order p of q(h) = q* + C h^p seen in three values at steps h, h/r, h/r^2.

    (coarse - medium) / (medium - fine) = r^p; NaN when the two changes are not of one sign
    (or either is zero): the values do not show an order.
    """
    d_coarse, d_fine = coarse - medium, medium - fine
    if not (math.isfinite(d_coarse) and math.isfinite(d_fine)) or d_coarse * d_fine <= 0:
        return math.nan
    return math.log(d_coarse / d_fine) / math.log(ratio)


def richardson(medium: float, fine: float, order: float, ratio: float = REFINEMENT_RATIO) -> float:
    """Richardson's limit q* from the values at h/r and h/r^2 and the order p.

    q(h) = q* + C h^p gives q(h/r) - q(h/r^2) = C (h/r^2)^p (r^p - 1), hence
    q* = fine + (fine - medium) / (r^p - 1).  NaN for a non-positive or unknown order.
    """
    if not (math.isfinite(order) and order > 0):
        return math.nan
    return fine + (fine - medium) / (ratio**order - 1.0)


def ladder_convergence(values, relative: bool = False, ratio: float = REFINEMENT_RATIO) -> dict:
    """The convergence of one quantity from its values at steps h, h/r, h/r^2 (h: the reference).

    Returns the values, ``halving_change`` (q1 - q0) and ``finest_change`` (q2 - q1), the
    ``observed_order``, the ``extrapolated`` limit, whether the ladder is ``asymptotic`` and the
    reference's ``uncertainty`` (module docstring); changes and uncertainty are divided by
    |q0| with ``relative``.  Three equal values converge exactly (uncertainty 0).
    """
    q0, q1, q2 = (float(v) for v in values)
    order = observed_order(q0, q1, q2, ratio)
    if q0 == q1 == q2:
        asymptotic, extrapolated, uncertainty = True, q0, 0.0
    elif math.isfinite(order) and order >= MIN_ASYMPTOTIC_ORDER:
        asymptotic, extrapolated = True, richardson(q1, q2, order, ratio)
        uncertainty = SAFETY_ASYMPTOTIC * abs(q0 - extrapolated)
    else:
        asymptotic, extrapolated = False, math.nan
        uncertainty = SAFETY_NOT_ASYMPTOTIC * max(abs(q0 - q1), abs(q0 - q2))
    scale = abs(q0) if relative else 1.0
    if not (scale > 0 and math.isfinite(scale)):
        scale = math.nan
    return {
        "values": [q0, q1, q2],
        "halving_change": (q1 - q0) / scale,
        "finest_change": (q2 - q1) / scale,
        "observed_order": order,
        "extrapolated": extrapolated,
        "asymptotic": asymptotic,
        "uncertainty": uncertainty / scale,
        "relative": relative,
    }


# ---------------------------------------------------------------------------------------
# Runs and what is compared.
# ---------------------------------------------------------------------------------------


def held_mode(scene: str, grip_n: float) -> int:
    """The mode with the finest resolution at the pressure ``grip_n`` puts on a pad."""
    from piezotip import scenarios
    from piezotip.cosim.loop import make_fingertip
    from piezotip.cosim.pad_geometry import PadGeometry

    pressure_pa = grip_n / PadGeometry().pad_area_m2
    return int(make_fingertip(scenarios.get(scene)).best_mode(np.array([pressure_pa]))[0])


def scripted_overrides(scene: str) -> list[str]:
    """The scripted controller at a fixed grip: twice what the scene's object's weight needs at
    its friction (m g / mu per finger, at most the fingers' force limit, the gripper model's), so it is held still, driving
    the mode that resolves the pressure of that grip best (the scripted controller drives its
    first mode, mode 1, which saturates at 3 kPa: the 10 kg block's grip is 245 kPa)."""
    from piezotip import scenarios
    from piezotip.analysis.experiment import gripper

    obj = scenarios.get(scene).object
    limit_n, g = gripper()
    grip = min(limit_n, obj.mass_kg * g / obj.friction)
    return ["controller.kind=scripted", f"controller.grip_force_n={grip!r}", f"controller.modes=[{held_mode(scene, grip)}]"]


#: Identical multimode runs per preset whose fastest loop time is its cost (fidelity_report).
COST_REPEATS = 3


def _run(scene: str, overrides: list[str], preset: str | None) -> tuple[dict, dict, float]:
    from piezotip.analysis.runner import run_scenario

    with tempfile.TemporaryDirectory(prefix="piezotip-fidelity-") as tmp:
        summary, data = run_scenario(scene, overrides, Path(tmp), plot=False, quiet=True, preset=preset)
    # The loop's wall time (set-up, tables and modal integrals are paid once per scene).
    return summary, data, summary["wall_time_s"]


def held_window(data: dict) -> np.ndarray:
    """The samples of the held grasp: lifted (phase lift or hold), the lift settled within
    LIFT_SETTLED_M of where it holds, the first HELD_WINDOW_S of that."""
    t, lift = data["time_s"], data["lift_m"]
    lifted = (data["phase"] == LIFT) | (data["phase"] == HOLD)
    if not lifted.any():
        return lifted
    top = lift[np.nonzero(lifted)[0][-1]]
    settled = lifted & (np.abs(lift - top) < LIFT_SETTLED_M)
    moving = lifted & ~settled
    start = t[moving][-1] if moving.any() else t[lifted][0] - 1e-12
    return settled & (t > start) & (t <= start + HELD_WINDOW_S * (1 + 1e-9))


def held_quantities(data: dict) -> dict[str, dict[str, float]]:
    """Each pad's median pressure estimate, true pressure, V_1 and mode over the held window
    (NaN when the window is shorter than HELD_WINDOW_MIN_SHARE of HELD_WINDOW_S)."""
    window = held_window(data)
    t = data["time_s"]
    period = float(np.median(np.diff(t))) if t.size > 1 else math.inf
    enough = window.sum() * period >= HELD_WINDOW_MIN_SHARE * HELD_WINDOW_S
    pads = [c.removesuffix("_estimate_pa") for c in data if c.endswith("_estimate_pa")]

    def median(column: str) -> float:
        values = data[column][window]
        values = values[np.isfinite(values)]
        return float(np.median(values)) if enough and values.size else math.nan

    return {
        "estimate_pa": {p: median(f"{p}_estimate_pa") for p in pads},
        "true_pressure_pa": {p: median(f"{p}_true_pressure_pa") for p in pads},
        "v1": {p: median(f"{p}_v1") for p in pads},
        "mode": {p: median(f"{p}_mode") for p in pads},
    }


def _rel(a: float, b: float) -> float:
    return abs(a - b) / abs(b) if b and math.isfinite(a) and math.isfinite(b) else math.nan


def _worst(values) -> float:
    finite = [v for v in values if not math.isnan(v)]
    return max(finite) if finite else math.nan


def errors(
    run: dict, ref: dict, outcome: bool = True, touch_s: tuple[float, float] = (math.nan, math.nan), grips: dict | None = None
) -> dict:
    """The errors of the module docstring, of the held quantities ``run`` against ``ref``
    (:func:`held_quantities`); ``outcome`` whether the multimode runs' outcomes agree,
    ``touch_s`` their touch times (the run's, the reference's), ``grips`` per grip kind
    (:data:`GRIP_KINDS`) the multimode runs' (run's, reference's) values, N."""
    pads = list(ref["estimate_pa"])
    same_mode = {p: run["mode"][p] == ref["mode"][p] for p in pads}
    t_run, t_ref = touch_s
    return {
        "pressure_estimate": _worst(_rel(run["estimate_pa"][p], ref["estimate_pa"][p]) for p in pads),
        "true_pressure": _worst(_rel(run["true_pressure_pa"][p], ref["true_pressure_pa"][p]) for p in pads),
        "output_v1": _worst(abs(run["v1"][p] - ref["v1"][p]) if same_mode[p] else math.nan for p in pads),
        "touch_time_s": abs(t_run - t_ref) if math.isfinite(t_run) and math.isfinite(t_ref) else math.nan,
        **{kind: _rel(*(grips or {}).get(kind, (math.nan, math.nan))) for kind in GRIP_KINDS},
        "outcome": outcome,
    }


def reference_convergence(ladder: list[dict], touch_s: tuple[float, float], outcome_same: bool, grips: dict | None = None) -> dict:
    """The reference's convergence on one scene, per error kind: from the held quantities of
    the fixed-grip ladder (:data:`LADDER_HALVINGS`) and the multimode touch times and grips
    (``grips``: per grip kind, the (reference's, halved reference's) values, N) at the
    reference's steps and at half of them.  Per kind: the worst pad's numbers (the pad of the
    largest uncertainty) and every pad's in ``pads``."""
    out = {}
    for kind, column, relative in (
        ("pressure_estimate", "estimate_pa", True),
        ("true_pressure", "true_pressure_pa", True),
        ("output_v1", "v1", False),
    ):
        pads = {p: ladder_convergence([q[column][p] for q in ladder], relative=relative) for p in ladder[0][column]}
        finite = {p: c for p, c in pads.items() if not math.isnan(c["uncertainty"])}
        worst = max(finite, key=lambda p: finite[p]["uncertainty"]) if finite else next(iter(pads))
        out[kind] = {
            "uncertainty": pads[worst]["uncertainty"],
            "halving_change": _worst(abs(c["halving_change"]) for c in pads.values()),
            "finest_change": _worst(abs(c["finest_change"]) for c in pads.values()),
            "observed_order": pads[worst]["observed_order"],
            "extrapolated": pads[worst]["extrapolated"],
            "asymptotic": all(c["asymptotic"] for c in pads.values()),
            "relative": relative,
            "pad": worst,
            "pads": pads,
        }
    # The touch is detected once per control period: its times are multiples of it, and one
    # halving is all the multimode ladder has (no order): the safety factor of a ladder that
    # does not show one.
    t_ref, t_half = touch_s
    out["touch_time_s"] = _one_halving(abs(t_half - t_ref) if math.isfinite(t_ref) and math.isfinite(t_half) else math.nan, False)
    # The grip the multimode controller chose: one halving too (relative changes).
    for kind in GRIP_KINDS:
        q_ref, q_half = (grips or {}).get(kind, (math.nan, math.nan))
        out[kind] = _one_halving(_rel(q_half, q_ref), True)
    out["outcome_same_when_halved"] = bool(outcome_same)
    return out


def _one_halving(change: float, relative: bool) -> dict:
    """The convergence entry of a quantity the reference has at one halving only: no order, its
    uncertainty the safety factor of a ladder that does not show one times the change."""
    return {
        "uncertainty": SAFETY_NOT_ASYMPTOTIC * change,
        "halving_change": change,
        "finest_change": math.nan,
        "observed_order": math.nan,
        "extrapolated": math.nan,
        "asymptotic": False,
        "relative": relative,
    }


def _bounds(found: dict, convergence: dict) -> dict:
    """Per error kind: the error as reported (itself, or the reference's uncertainty when below
    it), whether it is below, and whether it is certified (at least CERTIFY_FACTOR x u)."""
    out = {}
    for kind in ERROR_KINDS:
        error, u = found[kind], convergence[kind]["uncertainty"]
        if math.isnan(error) or math.isnan(u):
            out[kind] = {"value": error, "uncertainty": u, "below_uncertainty": False, "certified": False}
        else:
            below = error < u
            out[kind] = {
                "value": u if below else error,
                "uncertainty": u,
                "below_uncertainty": bool(below),
                "certified": bool(error >= CERTIFY_FACTOR * u and error > 0),
            }
    return out


def fixed_grip_duration_s(scene: str, fixed: list[str]) -> float:
    """How long a fixed-grip run of ``scene`` needs: until the held window of the cheapest
    preset (fast) ends, plus CUT_MARGIN_S; the scene's whole duration if it has none."""
    summary, data, _ = _run(scene, [*PRESETS["fast"], *fixed], None)
    window = held_window(data)
    if not window.any():
        return float(summary["sim_time_s"])
    return min(float(data["time_s"][window][-1]) + CUT_MARGIN_S, float(summary["sim_time_s"]))


def _fixed_grip(scene: str) -> list[str]:
    fixed = scripted_overrides(scene)
    return [*fixed, f"duration_s={fixed_grip_duration_s(scene, fixed)!r}"]


# ---------------------------------------------------------------------------------------
# The report.
# ---------------------------------------------------------------------------------------


def fidelity_report(scenes=STANDARD_SCENES, presets=tuple(PRESETS), progress=None, cost_repeats: int = COST_REPEATS) -> dict:
    """Run every preset on every scene, and the reference's ladder; cost, errors and the
    reference's convergence per preset (worst over scenes), per scene in ``scenes``.

    A preset's cost is its multimode runs' loop wall time, the fastest of ``cost_repeats``
    identical runs (they are deterministic: only the machine's noise differs, and it only
    ever adds time) for every preset but the reference and its refinement (run once: they
    cost more than the others together, and their cost is not compared with a target)."""
    names = list(dict.fromkeys([*presets, "reference"]))  # the reference is always run
    say = progress if progress is not None else (lambda message: None)
    multimode: dict[tuple[str, str], tuple[dict, dict, float]] = {}
    held: dict[tuple[str, str], dict] = {}
    ladders: dict[str, dict] = {}
    for scene in scenes:
        say(f"{scene} / fixed-grip schedule")
        fixed = _fixed_grip(scene)
        for name in [*names, "reference-halved"]:
            say(f"{scene} / {name} / multimode")
            if name == "reference-halved":
                multimode[(scene, name)] = _run(scene, list(REFERENCE_HALVED), None)
            else:
                runs = [_run(scene, [], name) for _ in range(1 if name == "reference" else max(1, cost_repeats))]
                summary, data, _ = runs[0]
                multimode[(scene, name)] = (summary, data, min(wall for _, _, wall in runs))
        for name in names:
            say(f"{scene} / {name} / fixed grip")
            held[(scene, name)] = held_quantities(_run(scene, fixed, name)[1])
        ladder = [held[(scene, "reference")]]
        for halvings in LADDER_HALVINGS[1:]:
            say(f"{scene} / reference, steps / {2**halvings} / fixed grip")
            ladder.append(held_quantities(_run(scene, [*reference_refined(halvings), *fixed], None)[1]))
        held[(scene, "reference-halved")] = ladder[1]
        ref_m, half_m = multimode[(scene, "reference")][0], multimode[(scene, "reference-halved")][0]
        ladders[scene] = reference_convergence(
            ladder,
            (ref_m["touch_time_s"], half_m["touch_time_s"]),
            half_m["outcome"] == ref_m["outcome"],
            {kind: (ref_m.get(key, math.nan), half_m.get(key, math.nan)) for kind, key in GRIP_KINDS.items()},
        )

    entries = []
    for name in [*names, "reference-halved"]:
        per_scene = {}
        wall = sim = 0.0
        for scene in scenes:
            s, _, w = multimode[(scene, name)]
            ref = multimode[(scene, "reference")][0]
            # The touch comes before any decision of the controller's can differ: compared on
            # the multimode runs.
            same_outcome = s["outcome"] == ref["outcome"]
            grips = {kind: (s.get(key, math.nan), ref.get(key, math.nan)) for kind, key in GRIP_KINDS.items()}
            found = errors(held[(scene, name)], held[(scene, "reference")], same_outcome, (s["touch_time_s"], ref["touch_time_s"]), grips)
            per_scene[scene] = found | {
                "outcome_name": s["outcome"],
                "sim_time_s": s["sim_time_s"],
                "wall_s": w,
                "error_bounds": _bounds(found, ladders[scene]),
            }
            wall += w
            sim += s["sim_time_s"]
        worst = {k: _worst(e[k] for e in per_scene.values()) for k in ERROR_KINDS}
        worst["outcome"] = all(e["outcome"] for e in per_scene.values())
        bounds = {}
        for kind in ERROR_KINDS:
            found = [e["error_bounds"][kind] for e in per_scene.values() if not math.isnan(e["error_bounds"][kind]["value"])]
            top = max(found, key=lambda b: (b["value"], not b["below_uncertainty"])) if found else None
            bounds[kind] = {
                "value": top["value"] if top else math.nan,
                "uncertainty": top["uncertainty"] if top else math.nan,
                "below_uncertainty": bool(top and top["below_uncertainty"]),
                "certified": bool(found) and all(b["certified"] for b in found),
            }
        entries.append(
            {
                "name": name,
                "settings": list(REFERENCE_HALVED if name == "reference-halved" else PRESETS[name]),
                "wall_s_per_sim_s": wall / sim,
                "realtime_factor": sim / wall,
                "errors": worst,
                # Beside each error: the reference's own uncertainty (worst over scenes) and the
                # error as it can be told from it.
                "error_bounds": bounds,
                "reference_convergence": _worst_convergence(ladders),
                "scenes": per_scene,
            }
        )
    by_name = {e["name"]: e for e in entries}
    halved = by_name["reference-halved"]
    halved["ladder"] = {
        "halvings": list(LADDER_HALVINGS),
        "refinement_ratio": REFINEMENT_RATIO,
        "settings": [list(reference_refined(h)) for h in LADDER_HALVINGS],
        "scenes": ladders,
    }
    return {
        "scenes": list(scenes),
        "presets": [e for e in entries if e["name"] != "reference-halved"],
        "convergence": halved,
        "checks": _checks(entries, ladders),
    }


def _worst_convergence(ladders: dict) -> dict:
    """Per error kind, the reference's convergence on the scene where its uncertainty is largest."""
    out = {}
    for kind in ERROR_KINDS:
        scenes = [s for s in ladders if not math.isnan(ladders[s][kind]["uncertainty"])] or list(ladders)
        scene = max(scenes, key=lambda s: ladders[s][kind]["uncertainty"] if not math.isnan(ladders[s][kind]["uncertainty"]) else -1)
        out[kind] = {k: v for k, v in ladders[scene][kind].items() if k != "pads"} | {"scene": scene}
    return out


def _checks(entries: list[dict], ladders: dict) -> dict:
    by_name = {e["name"]: e for e in entries}
    fast, accurate, halved = by_name.get("fast"), by_name.get("accurate"), by_name["reference-halved"]
    judged = [e for e in entries if e["name"] not in ("reference", "reference-halved")]
    u_estimate = _worst(ladders[s]["pressure_estimate"]["uncertainty"] for s in ladders)
    certified = [e["name"] for e in judged if e["error_bounds"]["pressure_estimate"]["certified"]]
    smallest_certified = min((e["errors"]["pressure_estimate"] for e in judged if e["name"] in certified), default=math.nan)
    checks = {
        "fast_speedup_over_accurate": accurate["wall_s_per_sim_s"] / fast["wall_s_per_sim_s"] if fast and accurate else math.nan,
        # The errors as they can be told from the reference's own (a bound when below it).
        "fast_pressure_estimate_error": fast["error_bounds"]["pressure_estimate"]["value"] if fast else math.nan,
        "accurate_pressure_estimate_error": accurate["error_bounds"]["pressure_estimate"]["value"] if accurate else math.nan,
        "reference_halving_change": halved["errors"]["pressure_estimate"],
        "reference_uncertainty": u_estimate,
        "reference_observed_order": {s: ladders[s]["pressure_estimate"]["observed_order"] for s in ladders},
        "reference_asymptotic": {s: ladders[s]["pressure_estimate"]["asymptotic"] for s in ladders},
        # The reference judges the targets: its uncertainty is at most a third of the finest (1 %).
        "reference_converged": bool(CERTIFY_FACTOR * u_estimate <= ACCURATE_TARGET),
        # Every scene's pressure-estimate error at least 3x the reference's uncertainty there.
        "presets_certified_by_reference": certified,
        "smallest_certified_error": smallest_certified,
        "presets_below_reference_uncertainty": [e["name"] for e in judged if e["error_bounds"]["pressure_estimate"]["below_uncertainty"]],
    }
    checks["targets_met"] = bool(
        checks["fast_speedup_over_accurate"] >= 10
        and checks["fast_pressure_estimate_error"] < FAST_TARGET
        and checks["accurate_pressure_estimate_error"] < ACCURATE_TARGET
    )
    return checks


def refinement_study(scene: str, knobs=RESOLUTION_KNOBS, progress=None) -> dict:
    """Which resolution step limits the reference on ``scene``: the fixed-grip ladder with
    each of ``knobs`` refined alone (the others at the reference's), and all together.

    Returns {knob or "all": :func:`reference_convergence` of that ladder (touch left out)}.
    Costs about a minute a scene; not part of ``bench``.
    """
    say = progress if progress is not None else (lambda message: None)
    fixed = _fixed_grip(scene)
    say(f"{scene} / reference")
    base = held_quantities(_run(scene, fixed, "reference")[1])
    out = {}
    for knob in (*knobs, "all"):
        chosen = RESOLUTION_KNOBS if knob == "all" else (knob,)
        ladder = [base]
        for halvings in LADDER_HALVINGS[1:]:
            say(f"{scene} / {knob} / {2**halvings}")
            ladder.append(held_quantities(_run(scene, [*reference_refined(halvings, chosen), *fixed], None)[1]))
        found = reference_convergence(ladder, (math.nan, math.nan), True)
        out[knob] = {k: found[k] for k in ("pressure_estimate", "true_pressure", "output_v1")}
    return out


# ---------------------------------------------------------------------------------------
# Output.
# ---------------------------------------------------------------------------------------


def _cell(bound: dict, error: float, fmt: str, reference: bool = False) -> str:
    """An error as it can be told from the reference: the value, or "<u" below its uncertainty
    (the reference itself: "±u", its own uncertainty)."""
    if reference:
        return "±" + format(bound["value"], fmt)
    if math.isnan(error):
        return "n/a"
    return ("<" + format(bound["value"], fmt)) if bound["below_uncertainty"] else format(error, fmt)


def format_fidelity(report: dict) -> str:
    """The price list as text, then the reference's convergence per scene."""
    head = (
        f"{'preset':<17} {'wall s/sim s':>12} {'RT factor':>9} {'P est err':>10} {'P true err':>10} {'V1 err V':>9}"
        f" {'touch dt ms':>11} {'hold err':>9} {'peak err':>9}  outcome"
    )
    lines = [
        f"fidelity presets on {', '.join(report['scenes'])} (errors: worst over scenes, against reference, "
        f"relative unless in V or ms; '<u': below the reference's own uncertainty u on some scene)",
        head,
    ]
    for e in [*report["presets"], report["convergence"]]:
        err, b = e["errors"], e.get("error_bounds")
        if b is None or e["name"] == "reference-halved":  # the halving change itself, not judged
            cells = [
                format(err["pressure_estimate"], ".2e"),
                format(err["true_pressure"], ".2e"),
                format(err["output_v1"], ".1e"),
                format(1e3 * err["touch_time_s"], ".1f"),
                format(err["hold_grip"], ".2e"),
                format(err["peak_contact"], ".2e"),
            ]
        else:
            ref = e["name"] == "reference"
            touch = {**b["touch_time_s"], "value": 1e3 * b["touch_time_s"]["value"]}
            cells = [
                _cell(b["pressure_estimate"], err["pressure_estimate"], ".2e", ref),
                _cell(b["true_pressure"], err["true_pressure"], ".2e", ref),
                _cell(b["output_v1"], err["output_v1"], ".1e", ref),
                _cell(touch, 1e3 * err["touch_time_s"], ".1f", ref),
                _cell(b["hold_grip"], err["hold_grip"], ".2e", ref),
                _cell(b["peak_contact"], err["peak_contact"], ".2e", ref),
            ]
        lines.append(
            f"{e['name']:<17} {e['wall_s_per_sim_s']:>12.4f} {e['realtime_factor']:>9.2f} {cells[0]:>10} {cells[1]:>10} {cells[2]:>9}"
            f" {cells[3]:>11} {cells[4]:>9} {cells[5]:>9}  {'same' if err['outcome'] else 'DIFFERS'}"
        )
    ladder = report["convergence"].get("ladder")
    if ladder:
        lines += [
            "",
            "pressure-estimate error per scene: against the reference's uncertainty u there "
            f"(certified: >= {CERTIFY_FACTOR:g} u; resolved: >= u; '<u': below it)",
            f"{'scene':<12} " + " ".join(f"{e['name']:>22}" for e in report["presets"] if e["name"] != "reference"),
        ]
        for scene in report["scenes"]:
            cells = []
            for e in report["presets"]:
                if e["name"] == "reference":
                    continue
                found = e["scenes"][scene]
                b = found["error_bounds"]["pressure_estimate"]
                verdict = "certified" if b["certified"] else "below u" if b["below_uncertainty"] else "resolved"
                value = _cell(b, found["pressure_estimate"], ".1e")
                cells.append(f"{value + ' ' + verdict:>22}")
            lines.append(f"{scene:<12} " + " ".join(cells))
        lines += [
            "",
            "reference convergence: its timestep, pad strip width and carrier sampling interval halved once and twice "
            "(changes relative, V1 in V, touch in ms; u = 1.25 |q0 - q*|, q* Richardson's limit, when the three show an "
            "order >= 0.5, else 3x the largest change)",
            f"{'scene':<12} {'quantity':<18} {'ref->1/2':>9} {'1/2->1/4':>9} {'order':>6} {'asympt.':>7} {'extrapolated':>13} {'u':>9}",
        ]
        units = {"pressure_estimate": ("P estimate", "Pa"), "true_pressure": ("P true", "Pa"), "output_v1": ("V1", "V")}
        for scene, found in ladder["scenes"].items():
            for kind, (label, unit) in units.items():
                c = found[kind]
                order = f"{c['observed_order']:.2f}" if math.isfinite(c["observed_order"]) else "n/a"
                extrapolated = f"{c['extrapolated']:.7g} {unit}" if math.isfinite(c["extrapolated"]) else "-"
                lines.append(
                    f"{scene:<12} {label + ' (' + c['pad'] + ')':<18} {c['halving_change']:>9.1e} {c['finest_change']:>9.1e} {order:>6} "
                    f"{'yes' if c['asymptotic'] else 'no':>7} {extrapolated:>13} {c['uncertainty']:>9.1e}"
                )
            t = found["touch_time_s"]
            touch_ms = (1e3 * t["halving_change"], 1e3 * t["uncertainty"])
            lines.append(f"{scene:<12} {'touch':<18} {touch_ms[0]:>9.1f} {'':>9} {'n/a':>6} {'':>7} {'':>13} {touch_ms[1]:>9.1f}")
            for kind, label in (("hold_grip", "hold grip"), ("peak_contact", "peak contact")):
                g = found[kind]
                change, u = g["halving_change"], g["uncertainty"]
                lines.append(f"{scene:<12} {label:<18} {change:>9.1e} {'':>9} {'n/a':>6} {'':>7} {'':>13} {u:>9.1e}")
    c = report["checks"]
    orders = ", ".join(
        f"{s} {p:.2f}" + ("" if c["reference_asymptotic"][s] else ", not asymptotic") for s, p in c["reference_observed_order"].items()
    )
    lines.append(
        f"fast is {c['fast_speedup_over_accurate']:.1f}x faster than accurate (target >= 10); pressure-estimate error: fast "
        f"{c['fast_pressure_estimate_error']:.2e} (< 5e-2), accurate {c['accurate_pressure_estimate_error']:.2e} (< 1e-2); "
        f"the reference's own uncertainty {c['reference_uncertainty']:.1e} (observed order: {orders}; "
        f"{'converged for the targets' if c['reference_converged'] else 'NOT converged for the targets'}); "
        f"errors certified (>= {CERTIFY_FACTOR:g}x it on every scene): {', '.join(c['presets_certified_by_reference']) or 'none'}; "
        f"below it on some scene: {', '.join(c['presets_below_reference_uncertainty']) or 'none'}"
    )
    return "\n".join(lines)


def plot_pareto(report: dict, path: Path) -> Path:
    """Error against cost, one point per preset (log-log), with the reference's uncertainty."""
    from piezotip.analysis.plotting import new_figure, save_figure

    fig, axes = new_figure(figsize=(7, 5))
    ax = axes[0][0]
    for e in [*report["presets"], report["convergence"]]:
        err = max(e["errors"]["pressure_estimate"], 1e-9)
        ax.loglog(e["wall_s_per_sim_s"], err, "o")
        ax.annotate(e["name"], (e["wall_s_per_sim_s"], err), xytext=(4, 4), textcoords="offset points", fontsize=8)
    ax.axhline(FAST_TARGET, color="tab:red", ls=":", lw=1, label="5 % (fast's target)")
    ax.axhline(ACCURATE_TARGET, color="tab:orange", ls=":", lw=1, label="1 % (accurate's target)")
    u = report["checks"].get("reference_uncertainty", math.nan)
    if math.isfinite(u) and u > 0:
        ax.axhspan(1e-9, u, color="0.85", label="below the reference's uncertainty")
    ax.set(xlabel="cost: wall time per simulated second [s]", ylabel="pressure-estimate error vs reference [-]")
    ax.set_title("fidelity presets: error against cost (1e-9 = no difference)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, path)

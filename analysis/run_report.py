"""A run's summary and plot, computed from its recording; the outcome is the referee's (analysis.referee)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from piezotip.cosim.loop import coverage_cells
from piezotip.scenarios.config import ObjectConfig, ScenarioConfig
from piezotip.sensor import Fingertip

from .plotting import save_figure
from .referee import Disturbance, judge, needed_grip_n, outside_model


def _finite_max(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(finite.max()) if finite.size else 0.0


def describe_object(obj: ObjectConfig) -> str:
    """The object as simulated, in words: '100 g box, 40 mm, friction 1' (+ crush limit)."""
    text = f"{1e3 * obj.mass_kg:.4g} g {obj.shape}, {1e3 * obj.size_m:.4g} mm, friction {obj.friction:g}"
    return text + (f", crushes above {obj.crush_force_n:g} N" if obj.crush_force_n is not None else "")


def object_needed_grip_n(model, extra_load_n: float = 0.0) -> float:
    """The least grip that holds the scene's object, N per finger, from the compiled model's truth
    (the object body's mass, the pad-object friction, which the pads' geoms carry, and gravity):
    :func:`~analysis.referee.needed_grip_n`, m g / (2 mu); with an extra downward load
    ``extra_load_n`` (N), (m g + extra) / (2 mu)."""
    from piezotip.cosim.scene import gravity_m_s2

    mass_kg = float(model.body("object").mass[0])
    return needed_grip_n(mass_kg, object_friction(model), gravity_m_s2(model), extra_load_n=extra_load_n)


def object_friction(model) -> float:
    """The pad-object friction coefficient the compiled model simulates (the pads' geoms carry it)."""
    return float(model.geom_friction[model.geom("left_pad_seg0_geom").id, 0])


def object_disturbance(config: ScenarioConfig, model=None) -> Disturbance | None:
    """The load change ``config`` puts on the held object (``disturb.*``) as the referee judges it,
    or None where none comes on.  From the compiled ``model``'s truth (the object body's weight,
    which ``disturb.extra_load_n`` None stands for, as the loop applies it: cosim.loop), or
    without a model from the config's object at standard gravity (9.81 m/s^2)."""
    d = config.disturb
    if not d.active:
        return None
    if model is None:
        o = config.object
        extra = d.load_n(o.mass_kg * 9.81)
        return Disturbance(extra, d.ramp_s, needed_grip_n(o.mass_kg, o.friction, extra_load_n=extra))
    from piezotip.cosim.scene import gravity_m_s2

    extra = d.load_n(float(model.body("object").mass[0]) * gravity_m_s2(model))
    return Disturbance(extra, d.ramp_s, object_needed_grip_n(model, extra))


def mode_changes(data: dict[str, np.ndarray], pads: tuple[str, ...]) -> tuple[int, list[int]]:
    """(number of mode switches over all pads, sorted modes used)."""
    switches, used = 0, set()
    for side in pads:
        modes = data[f"{side}_mode"]
        switches += int(np.count_nonzero(np.diff(modes)))
        used.update(int(m) for m in np.unique(modes))
    return switches, sorted(used)


def summary(
    config: ScenarioConfig,
    data: dict[str, np.ndarray],
    wall_time_s: float,
    files: list[str],
    error: str | None,
    events: list[dict] | None = None,
    finished: bool = True,
    needed_grip: float | None = None,
    disturbance: Disturbance | None = None,
    friction: float | None = None,
) -> dict:
    """The run's JSON summary: scenario, times, steps, pressures, modes, the referee's outcome, files.

    ``needed_grip``: the least grip that holds the object, N per finger (:func:`object_needed_grip_n`
    of the simulated model); None computes it from the config's object at standard gravity.
    ``disturbance``: the load change the run put on the held object (:func:`object_disturbance` of
    the simulated model); None computes it from the config (None again where it has none).
    ``friction``: the pad-object friction the referee reads the need on the contacts' recorded
    tilts with (:func:`object_friction` of the simulated model); None takes the config's."""
    pads = tuple(config.sensor.pads)
    sim_time = float(data["time_s"][-1]) if data else 0.0
    switches, used = mode_changes(data, pads) if data else (0, [])
    pressures = [data[f"{s}_true_pressure_pa"] for s in pads] if data else []
    result = {
        "scenario": config.name,
        "sim_time_s": sim_time,
        "wall_time_s": wall_time_s,
        "steps": int(data["time_s"].size) if data else 0,
        "realtime_factor": sim_time / wall_time_s if wall_time_s > 0 else math.inf,
        "max_pressure_pa": max((float(np.max(p)) for p in pressures), default=0.0),
        "max_estimate_pa": max((_finite_max(data[f"{s}_estimate_pa"]) for s in pads), default=0.0) if data else 0.0,
        "mode_switches": switches,
        "modes_used": used,
        "object": {
            "shape": config.object.shape,
            "mass_kg": config.object.mass_kg,
            "size_m": config.object.size_m,
            "friction": config.object.friction,
            "crush_force_n": config.object.crush_force_n,
            "description": describe_object(config.object),
        },
        "files": files,
        "error": error,
    }
    c = config.controller
    if needed_grip is None:
        needed_grip = needed_grip_n(config.object.mass_kg, config.object.friction)
    if disturbance is None:
        disturbance = object_disturbance(config)
    crush = config.object.crush_force_n
    friction = config.object.friction if friction is None else friction
    verdict = judge(
        data,
        c.lift_height_m,
        c.hold_s,
        crush,
        events or [],
        finished,
        error,
        needed_grip=needed_grip,
        disturbance=disturbance,
        friction=friction,
    )
    result.update(verdict.as_dict())
    result["limits"] = model_limits(config, result["max_pressure_pa"], data, pads)
    result["outside_model"] = outside_model(result["limits"])
    return result


def model_limits(config: ScenarioConfig, max_pressure_pa: float, data: dict[str, np.ndarray], pads: tuple[str, ...]) -> dict:
    """Where the run left the models' valid range: the gel's law, the housing stop, the ceramic.

    ``gel_beyond_valid_strain``: the gel was compressed past ``GelParams.max_valid_strain``;
    ``bottomed``: a pad's gel sat on its housing stop; ``element_on_backstop`` and
    ``element_overstressed``: the element's static bending at the largest pressure
    (sensor/stress.py, the fingertip's mounting).
    """
    from piezotip.cosim.loop import make_fingertip

    tip = make_fingertip(config)
    state = tip.gel.state(max_pressure_pa)
    stress = tip.stress(max_pressure_pa)
    return {
        "max_gel_strain": float(state.strain),
        "gel_beyond_valid_strain": bool(state.beyond_valid_strain),
        "bottomed": bool(any(np.any(data[f"{s}_bottomed"] > 0) for s in pads if f"{s}_bottomed" in data)),
        "max_bending_stress_pa": float(stress.stress_pa),
        "element_on_backstop": bool(stress.on_backstop),
        "element_overstressed": bool(stress.overstressed),
        "mounting": tip.mounting.kind,
    }


def _grip_economy(s: dict) -> str:
    """The grip against what the object needs, in words (the summary's grip-economy keys)."""
    held, need, margin = (s.get(k) for k in ("hold_grip_n", "needed_grip_n", "grip_margin"))
    ok = all(isinstance(v, float) and math.isfinite(v) for v in (held, need, margin))
    text = f"held {held:.3g} N where {need:.3g} N holds it ({margin:.2f}x)" if ok else "never carried clear of the table"
    return text + f"; peak contact {s['peak_contact_n']:.3g} N"


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _touch(s: dict) -> str:
    """The first touch in words (the summary's ``touch_peak_n``, ``time_to_touch_s``)."""
    peak, when = s.get("touch_peak_n"), s.get("time_to_touch_s")
    if not _finite(peak):
        return "never touched"
    first = f"first contact {when:.3f} s after closing began" if _finite(when) else "first contact"
    return f"{first}, {peak:.3g} N at most before lift-off"


def _disturbance(s: dict) -> str | None:
    """The answer to a load change in words (the summary's ``disturb_*``), or None without one."""
    need = s.get("disturb_needed_grip_n")
    if not _finite(need):
        return None
    slip, reaction = s.get("disturb_slip_mm"), s.get("disturb_reaction_ms")
    held, margin = s.get("disturb_hold_grip_n"), s.get("disturb_grip_margin")
    if not _finite(slip):
        return "load change: never held when it was due"
    answer = f"the grip rose 10 % for good {reaction:.0f} ms after the onset" if _finite(reaction) else "the grip never rose 10 % for good"
    hold = f"held {held:.3g} N" if _finite(held) else "never carried clear"
    hold += f" where {need:.3g} N holds it" + (f" ({margin:.2f}x)" if _finite(margin) else "")
    return f"load change: moved {slip:.2f} mm in the fingers; {answer}; {hold}"


def format_summary(s: dict) -> str:
    """A readable block of the summary."""
    lines = [
        f"scenario {s['scenario']}: {s['object']['description']}",
        f"  outcome: {s['outcome'].upper()}: {s['reason']}",
        f"  simulated {s['sim_time_s']:.2f} s in {s['wall_time_s']:.2f} s wall ({s['realtime_factor']:.1f}x real time, {s['steps']} steps)",
        f"  object rose {1e3 * s['max_rise_m']:.1f} mm, moved {1e3 * s['max_slip_m']:.1f} mm in the fingers, held {s['held_s']:.2f} s,"
        f" ended {1e3 * (s['object_final_height_m'] - s['object_start_height_m']):+.1f} mm from its start"
        f" (landing {s['landing_speed_m_s']:.3f} m/s)",
        f"  grip {_grip_economy(s)}",
        f"  touch: {_touch(s)}",
        f"  max pad pressure {s['max_pressure_pa']:.4g} Pa (true), {s['max_estimate_pa']:.4g} Pa (largest estimate)",
        f"  modes used {s['modes_used']}, {s['mode_switches']} switches",
    ]
    disturbed = _disturbance(s)
    if disturbed is not None:
        lines.append(f"  {disturbed}")
    lim = s.get("limits")
    if lim:
        flags = [
            name
            for name, on in (
                ("gel past its law's valid strain", lim["gel_beyond_valid_strain"]),
                ("gel bottomed on the housing", lim["bottomed"]),
                ("element on its backstop", lim["element_on_backstop"]),
                ("element OVERSTRESSED", lim["element_overstressed"]),
            )
            if on
        ]
        lines.append(
            f"  model limits: gel strain {100 * lim['max_gel_strain']:.0f} %,"
            f" PZT bending stress {lim['max_bending_stress_pa'] / 1e6:.1f} MPa"
            f" ({lim['mounting']}){': ' + ', '.join(flags) if flags else ', all within range'}"
        )
    if s.get("outside_model"):
        lines.append(f"  OUTSIDE THE MODEL: {'; '.join(s['outside_model'])}")
    if s.get("error"):
        lines.append(f"  STOPPED: {s['error']}")
    lines.extend(f"  MuJoCo warned ({w['count']}x): {w['message']}" for w in s.get("mujoco_warnings") or ())
    lines.extend(f"  wrote {f}" for f in s["files"])
    return "\n".join(lines)


def per_mode_outputs(fingertip: Fingertip, data: dict[str, np.ndarray], side: str) -> dict[int, np.ndarray]:
    """Steady V_1 of every mode under the recorded pressure profile (computed after the run).

    A robot sees only its driven mode; the others are for the plot, and cost nothing per step.
    """
    strips = sorted(
        (k for k in data if k.startswith(f"{side}_cell") and k.endswith("_pressure_pa")),
        key=lambda k: int(k.split("cell")[1].split("_")[0]),
    )
    el = fingertip.element
    edges, index = coverage_cells(np.linspace(0.0, el.params.length_m, len(strips) + 1), fingertip.coverage)
    profile = np.stack([data[k] for k in strips], axis=-1)[:, index]
    out = {}
    for m in fingertip.modes:
        k_e, c_e = fingertip.foundation(profile, m)
        kappa, gamma = el.modal_load_profile(k_e, c_e, m, edges)
        out[m] = el.normalized_output_from_modal(kappa, gamma, m)
    return out


#: How each readout status is drawn on the run plot's status strip (``{side}_status`` codes index
#: :data:`~piezotip.cosim.rows.STATUS_CODES`): only "ok" readings are drawn as estimates.
_STATUS_STYLE = {
    "ok": ("tab:green", 0.8, "ok (drawn as an estimate)"),
    "below_detection": ("0.7", 0.5, "below detection"),
    "saturated": ("tab:red", 0.8, "saturated"),
    "settling": ("gold", 0.6, "settling"),
    "outside_model": ("tab:purple", 0.7, "outside the model"),
}

#: The lowest pressure the run plot shows, Pa (the log axis's floor; a band reaching zero runs off it).
_PRESSURE_FLOOR_PA = 0.1
#: A crush limit more than this many times the largest force drawn is written in the force
#: panel's legend, off its scale, rather than setting the scale (the forces would be a flat line).
CRUSH_OFF_SCALE = 5.0


def estimate_readings(data: dict[str, np.ndarray], side: str) -> dict[str, np.ndarray]:
    """What the run plot draws of ``side``'s estimates: the record's arrays, NaN where the
    readout's status is not "ok" (below detection, saturated, settling: no estimate to draw).

    Keys: ``ok`` (bool per step), ``estimate``, ``low`` and ``high`` (the estimate -+ 3 sigma, its
    ``uncertainty_pa``; ``low`` not below zero), Pa."""
    from piezotip.cosim.rows import STATUS_CODES

    est = np.asarray(data[f"{side}_estimate_pa"], dtype=float)
    sigma = np.asarray(data.get(f"{side}_uncertainty_pa", np.zeros_like(est)), dtype=float)
    ok = (np.asarray(data[f"{side}_status"]) == STATUS_CODES.index("ok")) & np.isfinite(est)
    sigma = np.where(np.isfinite(sigma), sigma, 0.0)
    return {
        "ok": ok,
        "estimate": np.where(ok, est, np.nan),
        "low": np.where(ok, np.maximum(est - 3.0 * sigma, 0.0), np.nan),
        "high": np.where(ok, est + 3.0 * sigma, np.nan),
    }


def _status_runs(status: np.ndarray) -> dict[int, list[tuple[int, int]]]:
    """Per status code, its runs as (first, stop) sample indices."""
    changes = np.flatnonzero(np.diff(status)) + 1
    starts = np.concatenate([[0], changes])
    stops = np.concatenate([changes, [status.size]])
    runs: dict[int, list[tuple[int, int]]] = {}
    for a, b in zip(starts, stops, strict=True):
        runs.setdefault(int(status[a]), []).append((int(a), int(b)))
    return runs


def _grip_words(report: dict | None) -> str:
    """'hold grip 1.11 N = 2.25x the 0.491 N needed per finger', or why there is none."""
    if report is None:
        return ""
    held, need, margin = (report.get(k, math.nan) for k in ("hold_grip_n", "needed_grip_n", "grip_margin"))
    if all(isinstance(v, (int, float)) and math.isfinite(v) for v in (held, need, margin)):
        return f"grip margin {margin:.2f}x: held {held:.3g} N per finger where {need:.3g} N holds it"
    return "grip margin: none (never carried clear of the table)"


def sensed_pressure_pa(data: dict[str, np.ndarray], side: str) -> np.ndarray:
    """The true pressure ``side``'s sensing patch feels, Pa: the gel's mean on the element's
    coverage (``{side}_coverage_pressure_pa``, the readout's input and the truth its estimate is
    judged against, reports.coverage), or, in a record made before that column, the pad's mean
    over the element (``{side}_true_pressure_pa``; the same under a uniform load)."""
    return data.get(f"{side}_coverage_pressure_pa", data[f"{side}_true_pressure_pa"])


def run_figure(config: ScenarioConfig, fingertip: Fingertip, data: dict[str, np.ndarray], report: dict | None = None):
    """The run plot's figure (:func:`plot_run`); its axes in order: pressure, readout status,
    per-mode outputs, driven mode, force, height."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    from piezotip.cosim.rows import STATUS_CODES

    t = data["time_s"]
    sides = [s for s in config.sensor.pads if f"{s}_estimate_pa" in data]
    fig = Figure(figsize=(12, 14))
    ratios = (3.2, 0.25 * max(len(sides), 1) + 0.2, 2.2, 1.2, 2.6, 1.8)
    axes = fig.subplots(len(ratios), 1, sharex=True, gridspec_kw={"height_ratios": ratios})
    ax_p, ax_s, ax_v, ax_m, ax_f, ax_h = axes
    colors = dict(zip(sides, ("tab:blue", "tab:orange", "tab:purple", "tab:brown"), strict=False))
    dark = dict(zip(sides, ("navy", "saddlebrown", "indigo", "black"), strict=False))

    # pressure: the truth as lines, the "ok" estimates as points with their 3-sigma band
    top = _PRESSURE_FLOOR_PA
    for side in sides:
        color = colors[side]
        felt, pad_mean = sensed_pressure_pa(data, side), data[f"{side}_true_pressure_pa"]
        top = max(top, _finite_max(felt), _finite_max(pad_mean))
        # The truth the estimate answers to is what the sensing patch feels; the pad's mean over
        # the whole element differs where the contact is not uniform (held: an egg 1.25x, a 50 mm ball 1.47x, a 30 mm paper ball 1.82x).
        ax_p.plot(t, np.where(felt > 0, felt, np.nan), color=color, lw=3, alpha=0.4, label=f"{side}: true, felt by the sensing patch")
        if felt is not pad_mean:
            label = f"{side}: pad's mean over the element (not sensed)"
            ax_p.plot(t, np.where(pad_mean > 0, pad_mean, np.nan), ":", lw=0.8, color=color, label=label)
        r = estimate_readings(data, side)
        top = max(top, _finite_max(r["high"]))
        low = np.maximum(np.nan_to_num(r["low"]), 0.5 * _PRESSURE_FLOOR_PA)
        band = f"{side}: estimate $\\pm 3\\sigma$"
        ax_p.fill_between(t, low, np.nan_to_num(r["high"]), where=r["ok"], color=color, alpha=0.3, lw=0, zorder=3, label=band)
        ax_p.plot(t, r["estimate"], ".", ms=2.5, color=dark[side], zorder=4, label=f"{side}: estimate (status ok)")
    ax_p.set_yscale("log")
    ax_p.set_ylim(_PRESSURE_FLOOR_PA, 2.0 * top)
    ax_p.set(ylabel="pressure on element [Pa]")

    # the readout's status: one strip per pad, faint where there is no estimate
    for row, side in enumerate(sides):
        for code, runs in _status_runs(np.asarray(data[f"{side}_status"]).astype(int)).items():
            name = STATUS_CODES[code] if 0 <= code < len(STATUS_CODES) else "?"
            color, alpha, _ = _STATUS_STYLE.get(name, ("k", 0.5, name))
            spans = [(t[a], t[min(b, t.size - 1)] - t[a]) for a, b in runs]
            ax_s.broken_barh(spans, (row - 0.35, 0.7), facecolors=color, alpha=alpha, lw=0)
    ax_s.set_ylim(len(sides) - 0.5, -0.5)
    ax_s.set_yticks(range(len(sides)), sides)
    ax_s.set_ylabel("readout\nstatus", fontsize=8)
    ax_s.tick_params(axis="y", labelsize=7)
    ax_s.legend(
        handles=[Patch(facecolor=c, alpha=a, label=lab) for c, a, lab in _STATUS_STYLE.values()],
        fontsize=7,
        loc="upper left",
        bbox_to_anchor=(1.005, 1.3),
    )

    # per-mode outputs and the driven one
    side = config.sensor.pads[0]
    for m, v in per_mode_outputs(fingertip, data, side).items():
        ax_v.plot(t, v, lw=1, label=f"mode {m} (steady, {fingertip.freq_hz(m) / 1e3:.1f} kHz)")
    ax_v.plot(t, data[f"{side}_v1"], "k.", ms=1.5, alpha=0.5, label=f"{side}: measured, driven mode")
    ax_v.set(ylabel="normalized output $V_1$ [-]")
    for side in sides:
        ax_m.step(t, data[f"{side}_mode"], where="post", color=colors[side], label=side)
    ax_m.set(ylabel="driven mode")
    ax_m.set_yticks(sorted(config.sensor.modes))

    # force: the truth on the object, what holds it, what crushes it
    for finger, color in (("left", "tab:blue"), ("right", "tab:orange")):
        ax_f.plot(t, data[f"{finger}_finger_force_n"], color=color, lw=1.2, label=f"{finger} finger on the object (true)")
    peaks = [data[k] for k in ("left_finger_peak_force_n", "right_finger_peak_force_n") if k in data]
    if peaks:  # the crush test's force: a peak between two samples
        ax_f.plot(t, np.max(peaks, axis=0), color="0.4", lw=0.6, alpha=0.7, label="largest finger force within each step (true)")
    touching = np.maximum(data["left_finger_force_n"], data["right_finger_force_n"]) > 0
    drive = np.where(touching, data["grip_force_n"], np.nan)
    ax_f.plot(t, drive, ":", color="tab:purple", lw=1, label="commanded drive force (while touching)")
    if report is not None and math.isfinite(report.get("needed_grip_n", math.nan)):
        margin = report.get("grip_margin", math.nan)
        how = f"; hold margin {margin:.2f}x" if math.isfinite(margin) else "; never carried"
        label = f"needed grip {report['needed_grip_n']:.3g} N per finger{how}"
        ax_f.axhline(report["needed_grip_n"], color="tab:green", ls="--", lw=1.2, label=label)
    ax_f.set(ylabel="force on the object [N]")
    ax_f.set_ylim(bottom=0.0)
    crush_n = config.object.crush_force_n
    if crush_n is not None:
        # A crush limit far over every force drawn would flatten them to the panel's floor (an
        # egg's 25 N over its 0.7 N grip): the panel keeps their scale and the legend says where
        # the limit is.
        drawn = [data["left_finger_force_n"], data["right_finger_force_n"], drive, *peaks]
        if report is not None and math.isfinite(report.get("needed_grip_n", math.nan)):
            drawn.append(np.array([report["needed_grip_n"]]))
        top_n = max((float(np.nanmax(d)) for d in drawn if np.isfinite(d).any()), default=0.0)
        label = f"crush limit {crush_n:.3g} N"
        if top_n > 0.0 and crush_n > CRUSH_OFF_SCALE * top_n:
            ax_f.set_ylim(0.0, 1.15 * top_n)
            label += f" (off the scale: {crush_n / top_n:.3g}x the largest force drawn)"
        ax_f.axhline(crush_n, color="red", ls="-.", lw=1.2, label=label)

    ax_h.plot(t, 1e3 * (data["object_height_m"] - data["object_height_m"][0]), label="object")
    ax_h.plot(t, 1e3 * (data["lift_m"] - data["lift_m"][0]), "--", label="gripper")
    ax_h.set(ylabel="height change [mm]", xlabel="time [s]")

    title = f"{config.name}: {describe_object(config.object)}"
    if report is not None:
        title += f"\n{report['outcome'].upper()}: {report['reason']}\n{_grip_words(report)}"
        if report.get("outside_model"):
            title += f"\noutside the model: {'; '.join(report['outside_model'])}"
    ax_p.set_title(title, fontsize=9, color="tab:green" if report is not None and report["success"] else "black", pad=14)
    _shade_phases(t, data["phase"], (ax_p, ax_v, ax_m, ax_f, ax_h))
    for ax in (ax_p, ax_v, ax_m, ax_f, ax_h):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.005, 1.0))
    ax_p.grid(True, which="minor", alpha=0.1)
    return fig


def plot_run(config: ScenarioConfig, fingertip: Fingertip, data: dict[str, np.ndarray], out_dir: Path, report: dict | None = None) -> Path:
    """One PNG, ``run.png``: pressure (true, as the sensing patch feels it, :func:`sensed_pressure_pa`,
    and dotted the pad's mean over the element; the "ok" estimates with their 3-sigma band), each
    pad's readout status, per-mode outputs, driven mode, the true force on the object against
    the grip it needs and its crush limit, object height.

    The title names the object as simulated, the referee's outcome and the grip margin
    (``report``); the phases are shaded on every panel, so the place, release and what followed
    can be seen."""
    return save_figure(run_figure(config, fingertip, data, report), Path(out_dir) / "run.png")


def _shade_phases(t: np.ndarray, phase: np.ndarray, axes) -> None:
    """Alternate light bands for the controller's phases, named on the top panel."""
    from piezotip.cosim.control import PHASES

    changes = np.flatnonzero(np.diff(phase)) + 1
    starts = np.concatenate([[0], changes])
    stops = np.concatenate([changes, [t.size - 1]])
    for k, (a, b) in enumerate(zip(starts, stops, strict=True)):
        code = int(phase[a])
        for ax in axes:
            if k % 2:
                ax.axvspan(t[a], t[b], color="0.9", zorder=0)
        name = PHASES[code] if 0 <= code < len(PHASES) else "?"
        axes[0].text(0.5 * (t[a] + t[b]), 1.0, name, transform=axes[0].get_xaxis_transform(), ha="center", va="bottom", fontsize=6)

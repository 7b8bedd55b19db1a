"""The fingertip's dynamic range as a readable table, JSON, CSV and plots (``run_sim.py range``)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from piezotip.analysis.plotting import new_figure, save_figure
from piezotip.scenarios.config import MIN_COVERAGE_MM
from piezotip.sensor import Fingertip
from piezotip.sensor.fingertip import range_within_model

PRESSURE_GRID_PA = np.logspace(-1, 6.2, 300)
#: How finely :func:`check_coverage` finds the shortest coverage with a range, mm (and rounds it up to).
COVERAGE_STEP_MM = 1e-3


def has_range(tip: Fingertip) -> bool:
    """Whether some mode of ``tip`` both detects a pressure (P_min) and resolves one to 10 %
    (P_max) below its rated pressure: the sensor's limits, which ``range`` reports, exist."""
    p_min, p_max = tip.sensor_limits()
    return math.isfinite(p_min) and math.isfinite(p_max) and p_min < p_max


def _with_coverage(tip: Fingertip, x1_mm: float, x2_mm: float) -> Fingertip:
    return Fingertip(tip.element, tip.gel, (x1_mm * 1e-3, x2_mm * 1e-3), tip.noise, tip.modes, tip.rated_pressure_pa, tip.mounting)


def shortest_coverage_mm(tip: Fingertip, x1_mm: float) -> float | None:
    """The nearest end x2 (mm, a multiple of COVERAGE_STEP_MM) of a coverage from ``x1_mm`` over
    which ``tip`` (its element, gel, noise, modes and mounting) has a range, or None if even the
    element's far end gives none.  Bisection: more gel only adds load (the modal integrals of
    Z_n^2 grow with x2), so the range, once there, stays."""
    length_mm = 1e3 * tip.element.params.length_m
    lo, hi = x1_mm, length_mm
    if not has_range(_with_coverage(tip, x1_mm, hi)):
        return None
    while hi - lo > 0.25 * COVERAGE_STEP_MM:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if has_range(_with_coverage(tip, x1_mm, mid)) else (mid, hi)
    # Rounded up to a value a user types, and checked: the suggestion must work as printed.
    need = min(math.ceil(hi / COVERAGE_STEP_MM - 1e-9) * COVERAGE_STEP_MM, length_mm)
    while need < length_mm and not has_range(_with_coverage(tip, x1_mm, need)):
        need = min(need + COVERAGE_STEP_MM, length_mm)
    return round(need, 6)


def check_coverage(tip: Fingertip, coverage_mm: tuple[float, float]) -> None:
    """A ValueError naming ``--coverage X1_MM X2_MM`` and what it needs, if ``tip`` (whose
    coverage it is) cannot be reported on; else nothing.

    Two needs: the strip is at least :data:`~piezotip.scenarios.config.MIN_COVERAGE_MM` wide, as
    every scenario's is (a moulded strip narrower than its two edges' tolerances can close; the
    beam's stress model, on a 3.75 um grid, does not even see a strip of a few um), and under it
    some mode has both limits (:func:`has_range`): near the clamp a short strip moves no mode
    by 3 sigma, or none by enough to resolve 10 %, below the rated pressure, and every limit
    would be null.
    """
    x1, x2 = coverage_mm
    given = f"--coverage {x1:g} {x2:g}"
    width = x2 - x1
    if width < MIN_COVERAGE_MM:
        raise ValueError(
            f"{given} is {width:.3g} mm wide: the gel must cover at least {MIN_COVERAGE_MM:g} mm of the element "
            "(its moulded contact edges hold +-0.1 mm each; scenarios' sensor.coverage_mm has the same floor)"
        )
    if has_range(tip):
        return
    p_min, p_max = (f"{p:.3g} Pa" if math.isfinite(p) else "none" for p in tip.sensor_limits())
    why = (
        f"{given}: with the gel over {x1:g}-{x2:g} mm no mode both detects a pressure and resolves one to 10 % "
        f"below the rated {tip.rated_pressure_pa:.3g} Pa (sensor P_min {p_min}, P_max {p_max}), so there is no range"
    )
    need = shortest_coverage_mm(tip, x1)
    if need is None:
        raise ValueError(f"{why}; no coverage from {x1:g} mm has one: move X1_MM toward the tip (6.5 7.5 is the scenarios' default)")
    raise ValueError(f"{why}; from {x1:g} mm the gel must reach to at least {need:g} mm (--coverage {x1:g} {need:g})")


def format_table(report: dict) -> str:
    """A plain-text table of ``Fingertip.dynamic_range()``'s dict."""
    x1, x2 = (1e3 * v for v in report["coverage_m"])
    lines = [
        f"gel coverage {x1:g}-{x2:g} mm, rated pressure {report['rated_pressure_pa']:.3g} Pa",
        f"{'mode':>4}  {'freq [kHz]':>10}  {'P_min [Pa]':>11}  {'P_max [Pa]':>11}  {'sigma(V1)':>9}",
    ]
    for m in report["modes"]:
        lines.append(f"{m['mode']:>4}  {m['freq_hz'] / 1e3:>10.2f}  {m['p_min_pa']:>11.3g}  {m['p_max_pa']:>11.3g}  {m['sigma_v1']:>9.2e}")
    lines.append(f"sensor: P_min {report['p_min_pa']:.3g} Pa, P_max {report['p_max_pa']:.3g} Pa (the largest it resolves to 10 %)")
    lines.append(_within_model_line(report))
    bands = ", ".join(f"mode {b['mode']} {b['from_pa']:.3g}-{b['to_pa']:.3g} Pa" for b in report["mode_bands"])
    lines.append(f"most useful mode: {bands}")
    lines.append("switch pressures [Pa]: " + ", ".join(f"{p:.4g}" for p in report["switch_pressures_pa"]))
    if report.get("backstop_pressure_pa") is not None:
        lines.append(f"element rests on its backstop above {report['backstop_pressure_pa']:.3g} Pa (readings there are outside the model)")
    if "gel_valid_pressure_pa" in report:
        lines.append(f"gel compressed past its law's valid strain above {report['gel_valid_pressure_pa']:.3g} Pa (outside the model)")
    return "\n".join(lines)


#: How the range report names what ends the model (:meth:`sensor.Fingertip.model_limit`).
_MODEL_LIMIT_WORDS = {"backstop": "the element's backstop", "gel_strain": "the gel's valid strain"}


def _decibels(ratio: float) -> str:
    return f"{20 * math.log10(ratio):.0f} dB" if math.isfinite(ratio) and ratio > 0 else "none"


def _within_model_line(report: dict) -> str:
    """The dynamic range within the model, and P_max's figure past it when that is larger: a
    range whose top the model does not vouch for is named as such, never given alone."""
    within, beyond = report["dynamic_range"], report.get("dynamic_range_beyond_model", report["dynamic_range"])
    top, limit = report.get("p_max_within_model_pa", report["p_max_pa"]), report.get("model_limit")
    if not math.isfinite(within) and math.isfinite(top) and report["p_min_pa"] >= top:
        where = _MODEL_LIMIT_WORDS.get(limit, limit)
        why = f"P_min lies past {top:.3g} Pa, where {where} ends the model"
        return f"dynamic range within the model: none ({why}); P_max / P_min past it {beyond:.3g}"
    line = f"dynamic range within the model {within:.3g} ({_decibels(within)})"
    if limit is not None and top < report["p_max_pa"]:
        line += f": P_min to {top:.3g} Pa, where {_MODEL_LIMIT_WORDS.get(limit, limit)} ends the model"
        line += f"; to P_max, past the model's end, {beyond:.3g} ({_decibels(beyond)})"
    return line


def write_range_files(tip: Fingertip, out_dir: Path) -> list[Path]:
    """Plots (output, resolution, and (k_e, c_e) against pressure per mode) and their CSV."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    p = PRESSURE_GRID_PA
    columns: dict[str, np.ndarray] = {}
    fig_v, ax_v = new_figure(figsize=(8, 5))
    fig_r, ax_r = new_figure(figsize=(8, 5))
    fig_k, ax_k = new_figure(1, 2, figsize=(12, 5))
    for m in tip.modes:
        label = f"mode {m} ({tip.freq_hz(m) / 1e3:.1f} kHz)"
        v = tip.output(p, m)
        res = tip.resolution(p, m)
        k_e, c_e = tip.foundation(p, m)
        columns.update({f"v1_mode{m}": v, f"resolution_pa_mode{m}": res, f"k_e_n_m3_mode{m}": k_e, f"c_e_n_s_m3_mode{m}": c_e})
        ax_v[0][0].semilogx(p, v, label=label)
        ax_r[0][0].loglog(p, res, label=label)
        ax_k[0][0].loglog(p, np.where(k_e > 0, k_e, np.nan), label=label)
        ax_k[0][1].loglog(p, np.where(c_e > 0, c_e, np.nan), label=label)
    ax_r[0][0].loglog(p, 0.1 * p, "k--", label="10 % of P (upper-limit criterion)")
    for sw in tip.switch_pressures():
        for ax in (ax_v[0][0], ax_r[0][0]):
            ax.axvline(sw, color="grey", lw=0.8, ls=":")
    limit_pa, limit = tip.model_limit()
    for ax in (ax_v[0][0], ax_r[0][0]):  # past it the curves are computed, not vouched for
        ax.axvspan(limit_pa, p[-1], color="red", alpha=0.06, lw=0)
        ax.axvline(limit_pa, color="black", ls="-.", lw=1.0, label=f"the model ends: {_MODEL_LIMIT_WORDS[limit]}, {limit_pa:.3g} Pa")
    ax_v[0][0].set(
        xlabel="pressure P [Pa]", ylabel="normalized output $V_1$ [-]", title="Output against pressure (dotted: switch pressures)"
    )
    ax_r[0][0].set(xlabel="pressure P [Pa]", ylabel="resolution $3\\sigma / |dV_1/dP|$ [Pa]", title="Resolution against pressure")
    ax_r[0][0].set_ylim(1e-2, 1e7)
    ax_k[0][0].set(xlabel="pressure P [Pa]", ylabel="$k_e$ [N/m$^3$]", title="Gel elasticity seen by each mode")
    ax_k[0][1].set(xlabel="pressure P [Pa]", ylabel="$c_e$ [N s/m$^3$]", title="Gel viscosity seen by each mode")
    written = []
    for fig, axes, name in (
        (fig_v, ax_v, "output_vs_pressure.png"),
        (fig_r, ax_r, "resolution_vs_pressure.png"),
        (fig_k, ax_k, "gel_vs_pressure.png"),
    ):
        for row in axes:
            for ax in row:
                ax.grid(True, which="both", alpha=0.3)
                ax.legend(fontsize=8)
        written.append(save_figure(fig, out_dir / name))
    csv_path = out_dir / "range_curves.csv"
    with csv_path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["pressure_pa", *columns])
        for i, pi in enumerate(p):
            writer.writerow([f"{pi:.6e}", *(f"{c[i]:.9e}" for c in columns.values())])
    written.append(csv_path)
    return written


# ---------------------------------------------------------------------------------------
# A physical unit read through its calibration (sensor.variation, sensor.calibration).
# ---------------------------------------------------------------------------------------

#: Pressures at which the estimate's error is measured: this many, log-spaced over the
#: reported range [P_min, P_max] (ends included).
ERROR_POINTS = 41
#: The unit's pressure grid for its limits, Pa (the Fingertip's: ~40 points per decade).
_UNIT_GRID_PA = np.logspace(-4.0, 6.5, 421)
#: Relative step of the central difference for dV/dP (its error ~ step^2, 1e-8).
_SLOPE_STEP = 1e-4


def _mode_limits(unit, mode: int) -> tuple[float, float, float]:
    """(P_min, P_max, sigma) of one mode of a physical unit as its readout drives and reads it.

    The definitions of physics.md section 5 on the unit's steady reading v(P) = |reading|
    (:meth:`sensor.calibration.SensorUnit.reading`: the unit off resonance by what calibration
    missed, over the readout's reference) and its noise sigma in the same normalization:
    P_min is the smallest P with |v(P) - v(0)| >= 3 sigma, P_max the largest P up to the
    rating with 3 sigma / |dv/dP| <= 0.1 P (dv/dP by a central difference in P).
    """
    from scipy.optimize import brentq

    from piezotip.sensor.readout import DETECTION_SIGMAS, RESOLVED_FRACTION

    tip = unit.model
    sigma = unit.reading_sigma(mode)
    v0 = float(abs(unit.reading(mode, 0.0)))

    def v(p):
        return np.abs(unit.reading(mode, p))

    def excess(log_p: float) -> float:
        return abs(float(v(math.exp(log_p))) - v0) - DETECTION_SIGMAS * sigma

    grid = _UNIT_GRID_PA[_UNIT_GRID_PA <= tip.rated_pressure_pa]
    moved = np.abs(v(grid) - v0) >= DETECTION_SIGMAS * sigma
    p_min = math.inf
    if np.any(moved):
        i = int(np.argmax(moved))
        p_min = float(grid[0]) if i == 0 else math.exp(brentq(excess, math.log(grid[i - 1]), math.log(grid[i]), xtol=1e-12))

    def resolution(p):
        slope = np.abs(v(p * (1 + _SLOPE_STEP)) - v(p * (1 - _SLOPE_STEP))) / (2 * _SLOPE_STEP * p)
        with np.errstate(divide="ignore"):
            return np.where(slope > 0, DETECTION_SIGMAS * sigma / np.maximum(slope, 1e-300), np.inf)

    grid = np.append(grid, tip.rated_pressure_pa)
    ok = np.nonzero(resolution(grid) <= RESOLVED_FRACTION * grid)[0]
    if ok.size == 0:
        return p_min, math.nan, sigma
    i = int(ok[-1])
    if i == grid.size - 1:
        return p_min, float(tip.rated_pressure_pa), sigma

    def resolved(log_p: float) -> float:
        p = math.exp(log_p)
        return math.log(float(resolution(np.array([p]))[0]) / (RESOLVED_FRACTION * p))

    return p_min, math.exp(brentq(resolved, math.log(grid[i]), math.log(grid[i + 1]), xtol=1e-12)), sigma


def estimate_errors(unit, p_min_pa: float, p_max_pa: float, points: int = ERROR_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """(pressures, relative errors) of the readout's estimate over [P_min, P_max] (log-spaced).

    At each true pressure P the readout drives the mode whose band (its model's, the
    controller's switch pressures) holds P, reads the unit's steady, noise-free reading and
    inverts it with its model (:meth:`sensor.estimator.ModeInverse.pressure`); the error is
    |P_hat - P| / P, inf where the reading is past the model's table (no estimate at all).
    """
    from piezotip.sensor.estimator import mode_tables

    model = unit.model
    bands = model.mode_bands()
    pressures = np.geomspace(p_min_pa, p_max_pa, points)
    errors = np.empty(points)
    for k, p in enumerate(pressures):
        mode = bands[-1][0] if bands else model.modes[0]
        for m, _lo, hi in bands:
            if p <= hi:
                mode = m
                break
        inverse = mode_tables(model, mode, exact=model.gel.layer == "dynamic")[1]
        p_hat = inverse.pressure(float(abs(unit.reading(mode, p))))
        errors[k] = abs(p_hat - p) / p if math.isfinite(p_hat) else math.inf
    return pressures, errors


def unit_range_report(unit) -> dict:
    """``Fingertip.dynamic_range()``'s keys for a physical unit read through its calibration,
    plus ``max_estimate_error`` (the largest relative error of the estimate over pressures
    spread across the reported range, :func:`estimate_errors`), ``calibration`` (what it
    measured, :meth:`sensor.calibration.Calibration.summary`), ``unit`` (the draw and the
    temperature) and ``temperature_estimate_c`` (what the readout inferred).

    A nominal unit at 25 C without calibration is the model itself: its limits are
    ``Fingertip.dynamic_range()``'s, to the last digit.
    """
    model = unit.model
    if unit.config.is_nominal and unit.config.level == "none":
        report = model.dynamic_range()
    else:
        per_mode = []
        for m in model.modes:
            lo, hi, sigma = _mode_limits(unit, m)
            per_mode.append(
                {
                    "mode": m,
                    "freq_hz": unit.physical.fingertip_at(unit.config.temperature_c).freq_hz(m),
                    "p_min_pa": lo,
                    "p_max_pa": hi,
                    "sigma_v1": sigma,
                }
            )
        p_min = min(r["p_min_pa"] for r in per_mode)
        p_max = max((r["p_max_pa"] for r in per_mode if not math.isnan(r["p_max_pa"])), default=math.nan)
        # The model ends where the readout's model of the unit says (its calibrated element, gel, mounting).
        limit_pa, limit = model.model_limit()
        report = {
            "p_min_pa": p_min,
            "p_max_pa": p_max,
            **range_within_model(p_min, p_max, limit_pa),
            "modes": per_mode,
            "switch_pressures_pa": model.switch_pressures(),
            "mode_bands": [{"mode": m, "from_pa": lo, "to_pa": hi} for m, lo, hi in model.mode_bands()],
            "coverage_m": list(unit.coverage),
            "rated_pressure_pa": model.rated_pressure_pa,
            "backstop_pressure_pa": model.backstop_pressure_pa(),
            "gel_valid_pressure_pa": model.gel.params.max_valid_pressure_pa,
            "model_limit_pa": limit_pa,
            "model_limit": limit,
        }
    for entry in report["modes"]:
        entry["drive_freq_hz"] = unit.drive_hz[entry["mode"]]
    if math.isfinite(report["p_min_pa"]) and math.isfinite(report["p_max_pa"]) and report["p_max_pa"] > report["p_min_pa"]:
        _, errors = estimate_errors(unit, report["p_min_pa"], report["p_max_pa"])
        report["max_estimate_error"] = float(np.max(errors))
    else:
        report["max_estimate_error"] = math.inf
    report["calibration"] = unit.calibration.summary()
    c = unit.config
    report["unit"] = {
        "variation": c.variation,
        "unit_seed": c.unit_seed,
        "temperature_c": c.temperature_c,
        "draw": {k: v for k, v in unit.physical.draw.__dict__.items()},
    }
    report["temperature_estimate_c"] = unit.temperature_estimate_c
    return report


#: A unit "yields" (is fit for the fingertip's job) with at least this dynamic range within the
#: model (the paper's, physics.md section 4: pressures past the backstop or the gel's valid strain
#: count for nothing) and an estimate error at most YIELD_MAX_ERROR.
YIELD_MIN_DYNAMIC_RANGE = 1e4
YIELD_MAX_ERROR = 0.05


def _one_unit(args: tuple) -> dict:
    """One Monte Carlo unit (a process pool's task: a plain tuple in, a plain dict out)."""
    from piezotip.sensor.calibration import SensorUnit, UnitConfig

    nominal, variation, seed, calibration, temperature_c = args
    unit = SensorUnit(UnitConfig(variation, seed, calibration, temperature_c), nominal)
    r = unit_range_report(unit)
    return {
        "unit_seed": seed,
        "p_min_pa": r["p_min_pa"],
        "p_max_pa": r["p_max_pa"],
        "dynamic_range": r["dynamic_range"],
        "dynamic_range_beyond_model": r["dynamic_range_beyond_model"],
        "max_estimate_error": r["max_estimate_error"],
    }


def monte_carlo(
    nominal: Fingertip,
    variation: str,
    n_units: int,
    calibration: str | None = None,
    temperature_c: float = 25.0,
    workers: int = 1,
    progress: bool = False,
    first_seed: int = 0,
) -> dict:
    """The range of ``n_units`` units drawn from ``variation`` (seeds first_seed, first_seed + 1, ...).

    Returns ``units`` (per unit: seed, P_min, P_max, dynamic range within the model and beyond
    it, max estimate error),
    ``summary`` (per quantity: median, 5th and 95th percentiles, min, max) and ``yield``: the
    fraction of units with dynamic range (within the model) >= 1e4 and estimate error <= 5 %.  ``workers`` > 1
    spreads the units over a process pool.
    """
    from tqdm import tqdm

    if not isinstance(n_units, int) or n_units < 1:
        raise ValueError(f"--units must be a positive integer, got {n_units!r}")
    tasks = [(nominal, variation, first_seed + k, calibration, temperature_c) for k in range(n_units)]
    bar = tqdm(total=n_units, desc="units", unit="unit", disable=not progress)
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=workers) as pool:
            rows = []
            for row in pool.map(_one_unit, tasks, chunksize=max(1, n_units // (4 * workers))):
                rows.append(row)
                bar.update()
    else:
        rows = []
        for task in tasks:
            rows.append(_one_unit(task))
            bar.update()
    bar.close()
    summary = {}
    for key in ("p_min_pa", "p_max_pa", "dynamic_range", "dynamic_range_beyond_model", "max_estimate_error"):
        # a unit without a range (NaN) ranks lowest, one without an estimate (inf) highest;
        # percentiles are order statistics ("nearest"), so inf stays inf, never NaN
        values = np.array([r[key] for r in rows], float)
        finite = values[np.isfinite(values)]
        ranked = np.where(np.isnan(values), -np.inf, values)
        q5, q50, q95 = (float(np.percentile(ranked, q, method="nearest")) for q in (5, 50, 95))
        summary[key] = {
            "median": q50,
            "p5": q5,
            "p95": q95,
            "min": float(np.min(ranked)),
            "max": float(np.max(ranked)),
            "finite": int(finite.size),
        }
    good = [r["dynamic_range"] >= YIELD_MIN_DYNAMIC_RANGE and r["max_estimate_error"] <= YIELD_MAX_ERROR for r in rows]
    return {
        "variation": variation,
        "calibration": calibration,
        "temperature_c": temperature_c,
        "n_units": n_units,
        "units": rows,
        "summary": summary,
        "yield": float(np.mean(good)),
        "yield_criterion": {"min_dynamic_range": YIELD_MIN_DYNAMIC_RANGE, "max_estimate_error": YIELD_MAX_ERROR},
    }


def write_monte_carlo_plot(report: dict, out_dir: Path) -> Path:
    """Histograms of P_min, P_max, dynamic range and estimate error over the units."""
    fig, ax = new_figure(1, 4, figsize=(16, 4))
    rows = report["units"]
    for a, key, label, log in (
        (ax[0][0], "p_min_pa", "$P_{min}$ [Pa]", True),
        (ax[0][1], "p_max_pa", "$P_{max}$ [Pa]", True),
        (ax[0][2], "dynamic_range", "dynamic range within the model [-]", True),
        (ax[0][3], "max_estimate_error", "max estimate error [-]", True),
    ):
        values = np.array([r[key] for r in rows], float)
        values = values[np.isfinite(values) & (values > 0)]
        if values.size:
            bins = np.geomspace(values.min() / 1.1, values.max() * 1.1, 15) if log else 15
            a.hist(values, bins=bins, color="C0", alpha=0.8)
            a.set_xscale("log" if log else "linear")
        a.set(xlabel=label, ylabel="units", title=f"{label.split(' [')[0]} ({values.size} finite of {len(rows)})")
        a.grid(True, which="both", alpha=0.3)
    ax[0][2].axvline(YIELD_MIN_DYNAMIC_RANGE, color="k", ls="--", lw=0.8)
    ax[0][3].axvline(YIELD_MAX_ERROR, color="k", ls="--", lw=0.8)
    fig.suptitle(
        f"{report['n_units']} {report['variation']} units, calibration {report['calibration'] or 'default'}, "
        f"{report['temperature_c']:g} C: yield {100 * report['yield']:.0f} %"
    )
    return save_figure(fig, Path(out_dir) / "units.png")

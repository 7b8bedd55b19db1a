"""The fingertip's dynamic range as a readable table, JSON, CSV and plots (``run_sim.py range``)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from piezotip.sensor import Fingertip

from .plotting import new_figure, save_figure

PRESSURE_GRID_PA = np.logspace(-1, 6.2, 300)


def format_table(report: dict) -> str:
    """A plain-text table of ``Fingertip.dynamic_range()``'s dict."""
    x1, x2 = (1e3 * v for v in report["coverage_m"])
    lines = [
        f"gel coverage {x1:g}-{x2:g} mm, rated pressure {report['rated_pressure_pa']:.3g} Pa",
        f"{'mode':>4}  {'freq [kHz]':>10}  {'P_min [Pa]':>11}  {'P_max [Pa]':>11}  {'sigma(V1)':>9}",
    ]
    for m in report["modes"]:
        lines.append(f"{m['mode']:>4}  {m['freq_hz'] / 1e3:>10.2f}  {m['p_min_pa']:>11.3g}  {m['p_max_pa']:>11.3g}  {m['sigma_v1']:>9.2e}")
    lines.append(
        f"sensor: P_min {report['p_min_pa']:.3g} Pa, P_max {report['p_max_pa']:.3g} Pa, dynamic range {report['dynamic_range']:.3g}"
        f" ({20 * math.log10(report['dynamic_range']):.0f} dB)"
    )
    bands = ", ".join(f"mode {b['mode']} {b['from_pa']:.3g}-{b['to_pa']:.3g} Pa" for b in report["mode_bands"])
    lines.append(f"most useful mode: {bands}")
    lines.append("switch pressures [Pa]: " + ", ".join(f"{p:.4g}" for p in report["switch_pressures_pa"]))
    if "backstop_pressure_pa" in report:
        lines.append(f"element rests on its backstop above {report['backstop_pressure_pa']:.3g} Pa (readings there are outside the model)")
    return "\n".join(lines)


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

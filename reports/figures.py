"""The paper's analysis figures: V_1 and the sensitivities against k_e and c_e, per mode.

``write_figures(out_dir)`` writes, for the gel over the whole beam and over the tip only,
V_1 against k_e (c_e = 0) and against c_e (k_e = 0) for modes 1 to 4, the matching
sensitivity curves (eqs. 19 to 21), the same data as CSV, and ``crossovers.json``: for each
coverage, the k_e and c_e ranges in which each mode is the most sensitive.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from piezotip.analysis.plotting import new_figure, save_figure
from piezotip.sensor import SensorElement

#: The two coverages of the published analysis, m.
COVERAGES: dict[str, tuple[float, float]] = {"whole": (0.0, 7.5e-3), "tip": (6.5e-3, 7.5e-3)}
MODES = (1, 2, 3, 4)
K_E_GRID_N_M3 = np.logspace(2, 11, 361)
C_E_GRID_N_S_M3 = np.logspace(-4, 5, 361)
#: Two sensitivities closer than this (relative) are a tie, not a crossover.
_TIE = 1e-9

_VARIABLES = {
    "k_e": {"grid": K_E_GRID_N_M3, "label": "gel elasticity $k_e$ [N/m$^3$]", "unit": "n_m3", "sens_unit": "m^3/N"},
    "c_e": {"grid": C_E_GRID_N_S_M3, "label": "gel viscosity $c_e$ [N s/m$^3$]", "unit": "n_s_m3", "sens_unit": "m^3/(N s)"},
}


def _curves(element: SensorElement, variable: str, coverage: tuple[float, float], modes: Sequence[int]) -> tuple[np.ndarray, dict]:
    """Grid and per-mode (V_1, S) along one variable with the other held at zero."""
    grid = _VARIABLES[variable]["grid"]
    args = (lambda g: (g, 0.0)) if variable == "k_e" else (lambda g: (0.0, g))
    sens = element.sensitivity_k if variable == "k_e" else element.sensitivity_c
    out = {}
    for m in modes:
        out[m] = (element.normalized_output(*args(grid), mode=m, coverage=coverage), sens(*args(grid), mode=m, coverage=coverage))
    return grid, out


def most_sensitive_ranges(sensitivity: Callable[[float, int], float], grid: np.ndarray, modes: Sequence[int]) -> tuple[list[dict], bool]:
    """Ranges of ``grid`` over which each mode has the largest ``sensitivity(x, mode)``.

    Returns ``([{"mode", "from", "to"}, ...], all_equal)``; band edges are refined with brentq
    on the log-ratio of the two modes' sensitivities.  ``all_equal`` is True when every mode
    has the same sensitivity everywhere (then there is no crossover to report).
    """
    table = np.array([[sensitivity(x, m) for x in grid] for m in modes])
    spread = (table.max(axis=0) - table.min(axis=0)) / np.maximum(table.max(axis=0), 1e-300)
    if np.all(spread < _TIE):
        return [{"mode": list(modes), "from": float(grid[0]), "to": float(grid[-1])}], True
    best = np.asarray(modes)[np.argmax(table, axis=0)]
    bands, start = [], float(grid[0])
    for i in np.nonzero(best[1:] != best[:-1])[0]:
        a, b = int(best[i]), int(best[i + 1])

        def diff(lx: float, a: int = a, b: int = b) -> float:
            return math.log(sensitivity(math.exp(lx), a)) - math.log(sensitivity(math.exp(lx), b))

        cross = math.exp(brentq(diff, math.log(grid[i]), math.log(grid[i + 1]), xtol=1e-12))
        bands.append({"mode": a, "from": start, "to": cross})
        start = cross
    bands.append({"mode": int(best[-1]), "from": start, "to": float(grid[-1])})
    return bands, False


def crossovers(element: SensorElement, modes: Sequence[int] = MODES) -> dict:
    """For each coverage, the k_e (c_e = 0) and c_e (k_e = 0) ranges where each mode is most sensitive."""
    result: dict = {}
    for name, coverage in COVERAGES.items():
        entry: dict = {"coverage_m": list(coverage)}
        for variable, spec in _VARIABLES.items():
            if variable == "k_e":

                def sens(x: float, m: int, cov=coverage) -> float:
                    return float(element.sensitivity_k(x, 0.0, mode=m, coverage=cov))
            else:

                def sens(x: float, m: int, cov=coverage) -> float:
                    return float(element.sensitivity_c(0.0, x, mode=m, coverage=cov))

            bands, all_equal = most_sensitive_ranges(sens, spec["grid"], modes)
            unit = spec["unit"]
            entry[variable] = {
                "all_modes_equal": all_equal,
                "ranges": [{"mode": b["mode"], f"from_{unit}": b["from"], f"to_{unit}": b["to"]} for b in bands],
                "crossovers_" + unit: [b["to"] for b in bands[:-1]],
            }
        result[name] = entry
    return result


def _write_csv(path: Path, grid_name: str, grid: np.ndarray, columns: dict[str, np.ndarray]) -> None:
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow([grid_name, *columns])
        for i, g in enumerate(grid):
            writer.writerow([f"{g:.6e}", *(f"{col[i]:.9e}" for col in columns.values())])


def write_figures(out_dir: Path, element: SensorElement | None = None, modes: Sequence[int] = MODES) -> list[Path]:
    """Write the analysis figures (PNG), their data (CSV) and crossovers.json into ``out_dir``."""
    element = element or SensorElement()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for variable, spec in _VARIABLES.items():
        fig, axes = new_figure(2, 2, figsize=(11, 8))
        for col, (cov_name, coverage) in enumerate(COVERAGES.items()):
            grid, curves = _curves(element, variable, coverage, modes)
            ax_v, ax_s = axes[0][col], axes[1][col]
            for m, (v1, s) in curves.items():
                label = f"mode {m} ({element.natural_frequency_hz(m) / 1e3:.1f} kHz)"
                ax_v.semilogx(grid, v1, label=label)
                ax_s.loglog(grid, np.where(s > 0, s, np.nan), label=label)
            x1, x2 = (1e3 * c for c in coverage)
            ax_v.set_title(f"gel over {x1:g}-{x2:g} mm ({cov_name})")
            ax_v.set_ylabel("normalized output $V_1$ [-]")
            ax_v.set_ylim(-0.02, 1.05)
            ax_s.set_ylabel(f"sensitivity $S_{variable[0]}$ [{spec['sens_unit']}]")
            ax_s.set_xlabel(spec["label"])
            ax_v.set_xlabel(spec["label"])
            for ax in (ax_v, ax_s):
                ax.grid(True, which="both", alpha=0.3)
                ax.legend(fontsize=8)
            sens_key = {"k_e": "s_k_m3_per_n", "c_e": "s_c_m3_per_n_s"}[variable]
            columns = {}
            for m, (v1, s) in curves.items():
                columns[f"v1_mode{m}"] = v1
                columns[f"{sens_key}_mode{m}"] = s
            csv_path = out_dir / f"v1_vs_{variable}_{cov_name}.csv"
            _write_csv(csv_path, f"{variable}_{spec['unit']}", grid, columns)
            written.append(csv_path)
        other = "c_e = 0" if variable == "k_e" else "k_e = 0"
        fig.suptitle(f"Normalized output (eq. 19) and sensitivity (eq. {20 if variable == 'k_e' else 21}) against {variable}, {other}")
        png = out_dir / f"v1_vs_{variable}.png"
        save_figure(fig, png)
        written.append(png)
    cross_path = out_dir / "crossovers.json"
    cross_path.write_text(json.dumps(crossovers(element, modes), indent=2) + "\n")
    written.append(cross_path)
    return written

"""A sweep's tables and figure: ``sweep.csv``, ``sweep.parquet`` (units in the column names),
``sweep.png`` (:func:`write_sweep`), and the rows as a text table (:func:`format_rows`).
Both tables carry the sweep's provenance (:mod:`piezotip.provenance`).  pyarrow and matplotlib
are imported only when a file needs them."""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
from collections.abc import Sequence
from pathlib import Path

from .sweep_rows import COLUMN_TYPES, ERROR_OUTCOME, EXTRA_COLUMNS, RESULT_COLUMNS


def sweep_columns(grid_keys: Sequence[str]) -> list[str]:
    """The columns of ``sweep.csv``: the grid's keys as given, the results, then the extras."""
    return [*grid_keys, *RESULT_COLUMNS, *EXTRA_COLUMNS]


def _cell(value):
    if isinstance(value, (list, tuple)):
        return json.dumps(value)
    return value


def write_sweep(rows: list[dict], grid_keys: Sequence[str], out: Path, plot: bool = True, provenance: dict | None = None) -> list[Path]:
    """``sweep.csv``, ``sweep.parquet`` (units in the column names) and ``sweep.png``.

    ``provenance`` (:func:`analysis.sweep.sweep_provenance`; None: the versions alone) goes into
    both tables: the CSV's ``# `` header lines (:func:`piezotip.provenance.csv_header`) and the
    Parquet file's schema metadata, key ``piezotip``, as JSON.  The Parquet columns have their
    types (:data:`analysis.sweep_rows.COLUMN_TYPES`), nulls where a value is missing."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from piezotip.runtime.provenance import METADATA_KEY, csv_header, versions

    from .runner import json_safe

    provenance = {"versions": versions()} if provenance is None else provenance
    out = Path(out)
    columns = sweep_columns(grid_keys)
    csv_path = out / "sweep.csv"
    with csv_path.open("w", newline="") as fh:
        fh.write(csv_header(provenance, f"piezotip sweep of {provenance.get('scenario', 'a scenario')}"))
        write_csv_rows(fh, columns, [[_cell(r.get(c)) for c in columns] for r in rows])
    table = pa.table({c: _typed_column(COLUMN_TYPES[c], rows, c) if c in COLUMN_TYPES else _grid_column(rows, c) for c in columns})
    table = table.replace_schema_metadata({METADATA_KEY: json.dumps(json_safe(provenance), allow_nan=False)})
    parquet_path = out / "sweep.parquet"
    pq.write_table(table, parquet_path)
    files = [csv_path, parquet_path]
    if plot:
        files.append(plot_sweep(rows, grid_keys, out / "sweep.png"))
    return files


def write_csv_rows(fh, header: Sequence[str], rows: Sequence[Sequence]) -> None:
    """``header`` and ``rows`` as CSV lines into ``fh``, as the ``csv`` module writes them, but a
    cell holding "#" is quoted: pandas' ``comment="#"`` (which skips the header lines) would
    otherwise take the rest of its line for a comment."""
    for cells in (header, *rows):
        fh.write(",".join(_csv_field(cell) for cell in cells) + "\r\n")


def _csv_field(value) -> str:
    if value is None or value == "":
        return ""  # the csv module writes a lone empty field as "" (a row of it would be a blank line)
    text = io.StringIO()
    quoting = csv.QUOTE_ALL if "#" in str(value) else csv.QUOTE_MINIMAL
    csv.writer(text, quoting=quoting, lineterminator="").writerow([value])
    return text.getvalue()


def read_csv_rows(path: Path) -> list[dict]:
    """A table :func:`write_sweep` (or the experiment) wrote, as ``csv.DictReader`` reads it
    (every value text), its ``# `` header lines skipped."""
    with Path(path).open(newline="") as fh:
        return list(csv.DictReader(itertools.dropwhile(lambda line: line.startswith("#"), fh)))


def _missing(value) -> bool:
    return value is None or (isinstance(value, float) and math.isnan(value))


def _typed_column(kind: str, rows: list[dict], column: str):
    """A result column for Arrow, as its ``kind`` (:data:`COLUMN_TYPES`) says, null where missing."""
    import pyarrow as pa

    values = [r.get(column) for r in rows]
    if kind == "bool":
        return pa.array([None if _missing(v) else bool(v) for v in values], pa.bool_())
    if kind == "int":
        return pa.array([None if _missing(v) else int(v) for v in values], pa.int64())
    if kind == "float":
        return pa.array([None if _missing(v) else float(v) for v in values], pa.float64())
    if kind == "modes":  # "1 2" -> [1, 2]; none for a point that raised
        raised = [r.get("outcome") == ERROR_OUTCOME or v is None for r, v in zip(rows, values, strict=True)]
        modes = [None if no else [int(m) for m in str(v).split()] for no, v in zip(raised, values, strict=True)]
        return pa.array(modes, pa.list_(pa.int64()))
    if column == "error":  # "" is "no error"
        return pa.array([None if _missing(v) or v == "" else str(v) for v in values], pa.string())
    return pa.array([None if _missing(v) else str(v) for v in values], pa.string())


def _grid_column(rows: list[dict], column: str):
    """A grid key's values for Arrow, by what they are: true or false, whole numbers (int64),
    numbers (float64), else text (a list as JSON); null where one is missing (None or NaN)."""
    import pyarrow as pa

    values = [r.get(column) for r in rows]
    present = [v for v in values if not _missing(v)]
    if present and all(isinstance(v, bool) for v in present):
        return pa.array([None if _missing(v) else v for v in values], pa.bool_())
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return pa.array([None if _missing(v) else v for v in values], pa.int64())
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return pa.array([None if _missing(v) else float(v) for v in values], pa.float64())
    return pa.array([None if _missing(v) else json.dumps(v) if isinstance(v, (list, tuple)) else str(v) for v in values], pa.string())


#: Colour per outcome in the plots.
OUTCOME_COLOUR = {
    "success": "#4caf50",
    "never_lifted": "#bdbdbd",
    "blind": "#ffb74d",
    "timeout": "#ffe082",
    "slipped": "#ff8a65",
    "dropped": "#e57373",
    "crushed": "#b71c1c",
    "fault": "#7e57c2",
    ERROR_OUTCOME: "#212121",
}


def plot_sweep(rows: list[dict], grid_keys: Sequence[str], path: Path) -> Path:
    """The outcome over the grid: a coloured cell per point over the first two keys (the rest
    listed in the cell), and the peak pressure against the first key."""
    from matplotlib.patches import Patch, Rectangle

    from .plotting import new_figure, save_figure

    x_key = grid_keys[0]
    y_key = grid_keys[1] if len(grid_keys) > 1 else None
    xs = list(dict.fromkeys(_label(r[x_key]) for r in rows))
    ys = list(dict.fromkeys(_label(r[y_key]) for r in rows)) if y_key else [""]
    fig, axes = new_figure(1, 2, figsize=(14, 6))
    ax, ax_p = axes[0]
    cells: dict[tuple[int, int], list[dict]] = {}
    for r in rows:
        cells.setdefault((xs.index(_label(r[x_key])), ys.index(_label(r[y_key])) if y_key else 0), []).append(r)
    for (i, j), group in cells.items():
        outcomes = [g["outcome"] for g in group]
        main = max(set(outcomes), key=outcomes.count)
        ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, facecolor=OUTCOME_COLOUR.get(main, "white"), edgecolor="white"))
        text = main.replace("_", " ") if len(group) == 1 else f"{sum(g['success'] for g in group)}/{len(group)} ok"
        ax.text(i, j, text, ha="center", va="center", fontsize=7)
    ax.set_xlim(-0.5, len(xs) - 0.5)
    ax.set_ylim(-0.5, len(ys) - 0.5)
    ax.set_xticks(range(len(xs)), xs, rotation=30)
    ax.set_yticks(range(len(ys)), ys)
    ax.set(xlabel=x_key, ylabel=y_key or "", title="outcome per point (referee)")
    present = list(dict.fromkeys(r["outcome"] for r in rows))
    ax.legend(handles=[Patch(color=OUTCOME_COLOUR.get(o, "white"), label=o) for o in present], fontsize=7, loc="upper right")
    for y in ys:
        group = [r for r in rows if not y_key or _label(r[y_key]) == y]
        xi = [xs.index(_label(r[x_key])) for r in group]
        ax_p.semilogy(xi, [r["max_pressure_pa"] for r in group], "o-", label=f"{y_key} = {y}" if y_key else "peak")
    ax_p.set_xticks(range(len(xs)), xs, rotation=30)
    ax_p.set(xlabel=x_key, ylabel="peak pressure on the element [Pa]", title="peak pressure per point")
    ax_p.grid(True, which="both", alpha=0.3)
    ax_p.legend(fontsize=7)
    return save_figure(fig, path)


def _label(value) -> str:
    if isinstance(value, (list, tuple)):
        return json.dumps(value)
    return f"{value:g}" if isinstance(value, float) else str(value)


def format_rows(rows: list[dict], grid_keys: Sequence[str]) -> str:
    """The sweep's rows as a text table."""
    head = [*grid_keys, "outcome", "peak P [Pa]", "held P [Pa]", "grip margin", "modes", "wall [s]"]
    lines = []
    for r in rows:
        margin = r.get("grip_margin", math.nan)
        pressures = [f"{r['max_pressure_pa']:.3g}", f"{r['held_pressure_pa']:.3g}"]
        numbers = [*pressures, f"{margin:.2f}", r["modes_used"], f"{r['wall_time_s']:.2f}"]
        lines.append([*(_label(r[k]) for k in grid_keys), r["outcome"], *numbers])
    widths = [max(len(h), *(len(line[i]) for line in lines)) if lines else len(h) for i, h in enumerate(head)]
    text = ["  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True))]
    text += ["  ".join(c.ljust(w) for c, w in zip(line, widths, strict=True)) for line in lines]
    return "\n".join(text)

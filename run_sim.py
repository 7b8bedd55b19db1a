#!/usr/bin/env python3
"""piezotip's command line.

    python run_sim.py figures [--out DIR]        the paper's analysis figures + crossovers.json
    python run_sim.py range [--coverage X1_MM X2_MM] [--json] [--out DIR]
                                                 the fingertip's dynamic range and switch pressures

Every command is headless; figures are PNG (matplotlib Agg), data CSV/JSON with units in
their column and key names.  Errors print one line naming the bad value and exit with 2.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path


def _cmd_figures(args: argparse.Namespace) -> int:
    from analysis.figures import write_figures

    written = write_figures(Path(args.out))
    print(f"wrote {len(written)} files to {args.out}:")
    for path in written:
        print(f"  {path}")
    return 0


def _json_safe(value):
    """Replace non-finite floats by None so the output is strict JSON."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def _cmd_range(args: argparse.Namespace) -> int:
    from analysis.range_report import format_table, write_range_files
    from sensor import Fingertip

    coverage = None
    if args.coverage is not None:
        x1_mm, x2_mm = args.coverage
        length_mm = 7.5
        if not (0 <= x1_mm < x2_mm <= length_mm):
            raise ValueError(f"--coverage must satisfy 0 <= X1_MM < X2_MM <= {length_mm} (the element's length), got {x1_mm:g} {x2_mm:g}")
        coverage = (x1_mm * 1e-3, x2_mm * 1e-3)
    tip = Fingertip(coverage=coverage)
    report = tip.dynamic_range()
    files = []
    if args.out:
        out = Path(args.out)
        files = [str(p) for p in write_range_files(tip, out)]
        json_path = out / "range.json"
        json_path.write_text(json.dumps(_json_safe(report), indent=2) + "\n")
        files.append(str(json_path))
    if args.json:
        print(json.dumps(_json_safe(report), indent=2))
    else:
        print(format_table(report))
        for f in files:
            print(f"wrote {f}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="run_sim.py", description="piezotip: a robot fingertip with a multimode piezoelectric tactile sensor"
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("figures", help="the paper's analysis figures (V_1 and sensitivities against k_e, c_e)")
    p.add_argument("--out", default="out/figures", help="output directory (default: out/figures)")
    p.set_defaults(func=_cmd_figures)

    p = sub.add_parser("range", help="the fingertip's dynamic range, per mode, and its switch pressures")
    p.add_argument(
        "--coverage", nargs=2, type=float, metavar=("X1_MM", "X2_MM"), help="gel coverage on the element, mm (default: whole beam)"
    )
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument("--out", help="directory for plots, CSV and range.json")
    p.set_defaults(func=_cmd_range)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

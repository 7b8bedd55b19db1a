#!/usr/bin/env python3
"""piezotip's command line (``python run_sim.py`` in a checkout, the ``piezotip`` console script installed).

    python run_sim.py list                       the registered scenarios
    python run_sim.py run SCENARIO [--set KEY=VALUE ...] [--preset NAME] [--out DIR] [--json] [--csv] [--render] [--no-plot]
                      [--video [--video-fps FPS] [--video-size WxH]]   run.mp4: camera and a live strip
                                                 a scenario, headless: summary, plots, recording;
                                                 exit 0 on success, 1 on any other outcome (exit codes below),
                                                 130 on Ctrl-C, 143 on SIGTERM (the recording and a summary marked interrupted kept)
    python run_sim.py experiment grasp-range [--json] [--out DIR] [--preset NAME] [--set KEY=VALUE ...] [--video ...]
                                                 objects 1 g to 10 kg, multimode vs each mode alone
    python run_sim.py sweep SCENARIO --grid KEY=V1,V2,... [--grid ...] [--set KEY=VALUE ...] [--preset NAME]
                      [--workers N | --scheduler ADDRESS] [--out DIR] [--json] [--no-plot]
                                                 every grid point on Dask: sweep.csv, sweep.parquet, sweep.png;
                                                 resumable (same --out); exit 1 if a point raised
    python run_sim.py bench [--json] [--out DIR] [--no-presets]
                                                 cost (vs bare mj_step) and each preset's error
    python run_sim.py figures [--out DIR]        the paper's analysis figures + crossovers.json
    python run_sim.py range [--coverage X1_MM X2_MM] [--json] [--out DIR]
                                                 the fingertip's dynamic range and switch pressures
    python run_sim.py creep [--json] [--out DIR] [--quick]   held objects' creep (1.2x grip) and slide (0.8x), per contact model

Every command is headless; figures are PNG (matplotlib Agg), data CSV/JSON with units in
their column and key names.

Exit codes, for every command (a batch script tells them apart):

    0    success (run: the grasp succeeded; sweep: no point raised; experiment: multimode and
         gentle carried every object the gripper can and nothing it cannot)
    1    the command ran and the result is not a success: a grasp that did not succeed (any
         outcome but ``success``, a diverged run included), a sweep with a point that raised, an
         experiment that fails its rule, a benchmark that could not measure, creep that fails
    2    bad input or environment: one line ``error: ...`` naming the bad value, key, file or
         missing piece (a config value out of its range, an unknown name, an --out that cannot be
         written, no OpenGL backend for --video); argparse's usage errors too (its usage line, then
         the error)
    3    an internal error (a bug): one line ``internal error: <exception>: <message>`` and the path
         of a file holding the traceback (in the existing --out folder, else
         $TMPDIR/piezotip-traceback-<pid>.txt); ``--debug`` prints the traceback as well
    130  interrupted by Ctrl-C (SIGINT); 143 by SIGTERM: a run's recording so far, its plot and a
         summary marked ``"interrupted": true`` (its ``"signal"`` names which) are kept
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
import tempfile
import traceback
from pathlib import Path

from piezotip import interrupts

#: Exit codes (the module docstring): success, another outcome, bad input or environment, a bug, Ctrl-C.
EXIT_SUCCESS, EXIT_OUTCOME, EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
#: An error line's longest message, characters (a guard: every message is meant to be far shorter).
MAX_ERROR_CHARS = 4000
#: The most points a sweep's grid may have (each point is a run; the points are listed before any runs).
MAX_SWEEP_POINTS = 100_000
#: The most local worker processes per core (a process per core is what pays; past a few, only memory goes).
MAX_WORKERS_PER_CORE = 4


def _max_workers() -> int:
    return MAX_WORKERS_PER_CORE * (os.cpu_count() or 1)


def _rendering_backend() -> None:
    """For a command that renders (--render, --video), before anything imports MuJoCo (commands
    import it lazily; it reads MUJOCO_GL on its first import): headless EGL unless MUJOCO_GL says
    otherwise, and a backend that cannot load is one line naming MUJOCO_GL.  Commands that do not
    render need no backend at all (:func:`_no_rendering_backend`), so they run where there is no
    EGL."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    from piezotip.analysis.video import import_mujoco

    import_mujoco()


def _no_rendering_backend() -> None:
    """For the program's commands that do not render, before anything imports MuJoCo: no OpenGL
    backend (MUJOCO_GL=disable) unless MUJOCO_GL says otherwise.  With none named, MuJoCo's import
    loads GLFW, whose library search (pyGLFW) starts a Python process per candidate library to
    read its version, the file's name written to its stdin: 50 ms of every command's start, and a
    Ctrl-C or SIGTERM in that window left the probe reading a closed stdin, its traceback
    ("File "<string>", line 28 ... EOFError: EOF when reading a line") printed after the command's
    "interrupted" (tests/test_interrupts.py::
    test_a_signal_in_the_commands_first_tenths_of_a_second_is_one_line_and_its_status, 1 run in 8
    of the file).  Set in the process's environment, so a sweep's Dask workers skip it too; only
    for the program (run_sim.py, the ``piezotip`` script), not for :func:`main` called from a
    script, whose own later rendering would find MuJoCo imported without a backend."""
    os.environ.setdefault("MUJOCO_GL", "disable")


PRESET_NAMES = ("fast", "balanced", "accurate", "reference")


def _cmd_figures(args: argparse.Namespace) -> int:
    from piezotip.reports.figures import write_figures

    written = write_figures(Path(args.out))
    print(f"wrote {len(written)} files to {args.out}:")
    for path in written:
        print(f"  {path}")
    return 0


def _json_safe(value):
    """Strict JSON (NaN and inf as null): provenance.json_safe, imported when needed."""
    from piezotip.provenance import json_safe

    return json_safe(value)


def _cmd_range(args: argparse.Namespace) -> int:
    from piezotip.reports.range_report import check_coverage, format_table, write_range_files
    from piezotip.sensor import Fingertip

    coverage = None
    if args.coverage is not None:
        x1_mm, x2_mm = args.coverage
        length_mm = 7.5
        if not (0 <= x1_mm < x2_mm <= length_mm):
            raise ValueError(f"--coverage must satisfy 0 <= X1_MM < X2_MM <= {length_mm} (the element's length), got {x1_mm:g} {x2_mm:g}")
        coverage = (x1_mm * 1e-3, x2_mm * 1e-3)
    from piezotip.sensor import GelModel

    tip = Fingertip(coverage=coverage, gel=GelModel(layer=args.gel_layer))
    if args.coverage is not None:  # one too short for the limits is an error, not a report of nulls
        check_coverage(tip, args.coverage)
    if args.units is not None or any(v is not None for v in (args.variation, args.unit_seed, args.calibration, args.temperature_c)):
        return _range_unit(args, tip)
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


def _range_unit(args: argparse.Namespace, nominal) -> int:
    """``range`` of a physical unit (--variation, --unit-seed, --calibration, --temperature-c),
    or a Monte Carlo over --units of them."""
    from piezotip.reports.range_report import format_table, monte_carlo, unit_range_report, write_monte_carlo_plot
    from piezotip.sensor.calibration import SensorUnit, UnitConfig

    variation = args.variation or "none"
    temperature = 25.0 if args.temperature_c is None else args.temperature_c
    if args.units is not None:
        if args.unit_seed is not None:
            raise ValueError("give --unit-seed (one unit) or --units N (a Monte Carlo over seeds 0..N-1), not both")
        UnitConfig(variation, 0, args.calibration, temperature)  # bad names stop here, before any unit
        if args.units < 1:
            raise ValueError(f"--units must be a positive integer, got {args.units}")
        workers = args.workers if args.workers is not None else min(os.cpu_count() or 1, 2)
        if not 1 <= workers <= _max_workers():
            raise ValueError(f"--workers must be 1 to {_max_workers()} ({MAX_WORKERS_PER_CORE} per core), got {workers}")
        report = monte_carlo(nominal, variation, args.units, args.calibration, temperature, workers, progress=not args.json)
        files = []
        if args.out:
            out = Path(args.out)
            out.mkdir(parents=True, exist_ok=True)
            files.append(str(write_monte_carlo_plot(report, out)))
            (out / "units.json").write_text(json.dumps(_json_safe(report), indent=2) + "\n")
            files.append(str(out / "units.json"))
        if args.json:
            print(json.dumps(_json_safe({**report, "files": files}), indent=2))
        else:
            s = report["summary"]
            print(f"{args.units} {variation} units, calibration {args.calibration or 'default'}, {temperature:g} C:")
            labels = {
                "p_min_pa": "P_min [Pa]",
                "p_max_pa": "P_max [Pa]",
                "dynamic_range": "range within model",  # its top no higher than the backstop or the gel's valid strain
                "dynamic_range_beyond_model": "range beyond model",  # P_max / P_min, its top past them
                "max_estimate_error": "max estimate error",
            }
            for key, label in labels.items():
                q = s[key]
                print(f"  {label:<20} median {q['median']:.3g}  5-95 % {q['p5']:.3g} .. {q['p95']:.3g}", end="")
                print(f"  (min {q['min']:.3g}, max {q['max']:.3g})")
            print(f"  yield (dynamic range within the model >= 1e4, estimate error <= 5 %): {100 * report['yield']:.0f} %")
            for f in files:
                print(f"wrote {f}")
        return 0
    unit = SensorUnit(UnitConfig(variation, 0 if args.unit_seed is None else args.unit_seed, args.calibration, temperature), nominal)
    report = unit_range_report(unit)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "range.json").write_text(json.dumps(_json_safe(report), indent=2) + "\n")
    if args.json:
        print(json.dumps(_json_safe(report), indent=2))
    else:
        print(format_table(report))
        c = report["calibration"]
        seed, inferred = report["unit"]["unit_seed"], report["temperature_estimate_c"]
        print(f"unit: {variation} seed {seed} at {temperature:g} C (readout infers {inferred:g} C), calibration {c['level']}")
        print(f"max estimate error over the range: {100 * report['max_estimate_error']:.3g} %")
    return 0


def _cmd_list(args: argparse.Namespace) -> int:
    from piezotip import scenarios

    width = max(len(n) for n in scenarios.names())
    for name in scenarios.names():
        print(f"{name:<{width}}  {scenarios.get(name).description}")
    return 0


def _video_options(args: argparse.Namespace) -> dict:
    """run_scenario's video keywords from --video, --video-fps and --video-size (checked before any run)."""
    if not args.video:
        if args.video_fps is not None or args.video_size is not None:
            raise ValueError("--video-fps and --video-size need --video")
        return {}
    from piezotip.analysis.video import parse_size

    return {"video": True, "video_fps": args.video_fps, "video_size": parse_size(args.video_size) if args.video_size else None}


def _add_video_arguments(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--video", action="store_true", help=f"write {what} (H.264): the scene's camera and a live strip (MUJOCO_GL=egl)")
    p.add_argument("--video-fps", type=float, metavar="FPS", help="video frames per simulated second (default 30)")
    p.add_argument("--video-size", metavar="WxH", help="video frame size in pixels, even (default 960x540)")


def _add_dask_arguments(p: argparse.ArgumentParser) -> None:
    group = p.add_mutually_exclusive_group()
    group.add_argument(
        "--workers", type=int, metavar="N", help="local Dask cluster's processes (default: this machine's cores; 0: no Dask, one by one)"
    )
    group.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler, e.g. tcp://host:8786 (see README)")


def _cmd_run(args: argparse.Namespace) -> int:
    from piezotip.analysis.run_report import format_summary
    from piezotip.analysis.runner import default_out_dir, run_scenario

    video = _video_options(args)
    out = Path(args.out) if args.out else default_out_dir(args.scenario, args.set or [], args.preset)
    report, _ = run_scenario(
        args.scenario,
        args.set or [],
        out,
        csv=args.csv,
        render=args.render,
        plot=not args.no_plot,
        quiet=args.json,
        preset=args.preset,
        **video,
    )
    if report.get("interrupted"):  # the first signal decided: a later one cannot cut its report short
        interrupts.hold()
    if args.json:
        print(json.dumps(_json_safe(report), indent=2))
    else:
        print(format_summary(report))
    if report.get("interrupted"):
        from piezotip.analysis.runner import exit_status

        print(f"interrupted at t = {report['sim_time_s']:.2f} s; the recording up to there is in {out}", file=sys.stderr)
        return exit_status(report)
    # A batch script tells the outcomes apart: 0 success, 1 any other outcome (module docstring).
    return EXIT_SUCCESS if report["success"] else EXIT_OUTCOME


def _cmd_experiment(args: argparse.Namespace) -> int:
    if args.name != "grasp-range":
        raise ValueError(f"unknown experiment {args.name!r}; valid experiments: grasp-range")
    if not args.video:  # with --video each worker loads MuJoCo's GL backend itself, never a forked one
        _start_workers_early(args)
    from piezotip.analysis.experiment import controller_aim, experiment_provenance, format_table, passes, run_experiment, write_outputs
    from piezotip.analysis.runner import check_out_dir

    out = check_out_dir(Path(args.out or "out/grasp-range"))
    from piezotip import scenarios

    base = scenarios.get("grasp", list(args.set or ()), args.preset)  # bad overrides stop here, before any run
    _check_workers(args)
    video = _video_options(args)  # one clip per run: runs/NN/run.mp4, NN the row's index in the table
    result = run_experiment(args.preset, tuple(args.set or ()), out, args.workers, args.scheduler, progress=not args.json, options=video)
    rows = result.rows
    # the line drawn at the controller's aim is its config's as the user set it (--set controller.grip_safety=...)
    provenance = experiment_provenance(args.preset, tuple(args.set or ()))  # versions, seeds, config: the tables' header
    files = [str(p) for p in write_outputs(rows, out, plot=not args.no_plot, aim=controller_aim(base.controller), provenance=provenance)]
    if args.json:
        print(json.dumps(_json_safe({"rows": rows, "files": files, "skipped_done": result.skipped}), indent=2))
    else:
        print(format_table(rows))
        for f in files:
            print(f"wrote {f}")
    if result.skipped:
        # A resumed experiment keeps the rows it finds, whatever code made them: say so.
        print(
            f"{result.skipped} of {len(rows)} runs were done before in {out} and not run again (a new --out runs them all)",
            file=sys.stderr,
        )
    return 0 if passes(rows) else 1


def _check_workers(args: argparse.Namespace) -> None:
    if args.workers is not None and not 0 <= args.workers <= _max_workers():
        raise ValueError(f"--workers must be 0 (in this process) to {_max_workers()} ({MAX_WORKERS_PER_CORE} per core), got {args.workers}")
    if args.workers is not None and args.scheduler is not None:
        raise ValueError("give --workers (a local cluster) or --scheduler (an existing one), not both")


def _start_workers_early(args: argparse.Namespace) -> None:
    """For a command that will start a local Dask cluster: the server its workers are forked
    from, first (analysis.sweep_cluster.start_worker_server), so that the workers' imports run while
    this process imports and checks."""
    if args.scheduler is None and (args.workers is None or args.workers > 0):
        from piezotip.analysis.sweep_cluster import start_worker_server

        start_worker_server()


def _cmd_sweep(args: argparse.Namespace) -> int:
    from piezotip import scenarios
    from piezotip.analysis.sweep import run_points, runs_in_this_process, sweep_provenance
    from piezotip.analysis.sweep_grid import check_points, grid_points, parse_grid
    from piezotip.analysis.sweep_output import format_rows, write_sweep

    grid = parse_grid(args.grid or [])
    from piezotip.scenarios.config import parse_value

    for key, values in grid.items():  # each value bounded and parsed as --set would, its key named
        for value in values:
            parse_value(value, key)
    count = math.prod(len(values) for values in grid.values())
    if count > MAX_SWEEP_POINTS:
        raise ValueError(f"--grid: {' x '.join(str(len(v)) for v in grid.values())} = {count} points, more than {MAX_SWEEP_POINTS}")
    if args.scenario not in scenarios.names():
        scenarios.get(args.scenario)  # the unknown-scenario error, naming the valid ones
    if not runs_in_this_process(count, args.workers, args.scheduler):  # a single point starts no workers
        _start_workers_early(args)
    from piezotip.analysis.runner import check_out_dir

    points = grid_points(grid, list(args.set or ()))
    check_points(args.scenario, points, args.preset)  # every point's config valid before any run
    _check_workers(args)
    out = check_out_dir(Path(args.out) if args.out else _sweep_out_dir(args))
    result = run_points(args.scenario, points, args.preset, out, args.workers, args.scheduler, progress=not args.json)
    provenance = sweep_provenance(args.scenario, grid, list(args.set or ()), args.preset)  # versions, seeds, config
    files = [str(p) for p in write_sweep(result.rows, list(grid), out, plot=not args.no_plot, provenance=provenance)]
    report = {
        "scenario": args.scenario,
        "preset": args.preset,
        "overrides": list(args.set or ()),
        "grid": {k: v for k, v in grid.items()},
        "points": len(points),
        "skipped_done": result.skipped,
        "workers": result.workers,
        "wall_time_s": result.wall_time_s,
        "succeeded": sum(bool(r["success"]) for r in result.rows),
        "errors": sum(r["outcome"] == "error" for r in result.rows),
        "rows": result.rows,
        "files": files,
        **{key: provenance[key] for key in ("versions", "seed", "unit_seed", "config")},
    }
    (out / "sweep.json").write_text(json.dumps(_json_safe(report), indent=2) + "\n")
    files.append(str(out / "sweep.json"))
    if args.json:
        print(json.dumps(_json_safe(report), indent=2))
    else:
        print(format_rows(result.rows, list(grid)))
        print(
            f"{report['succeeded']}/{len(points)} succeeded, {report['errors']} errors; {result.skipped} done before;"
            f" {result.wall_time_s:.1f} s on {result.workers or 'no'} Dask workers"
        )
        for f in files:
            print(f"wrote {f}")
    return 0 if report["errors"] == 0 else 1


def _sweep_out_dir(args: argparse.Namespace) -> Path:
    from piezotip.analysis.runner import default_out_dir

    return default_out_dir(f"sweep-{args.scenario}", [*(args.set or ()), *args.grid], args.preset)


def _cmd_bench(args: argparse.Namespace) -> int:
    from piezotip.reports.bench import bench_report, format_report, grasp_cases, write_report

    if args.repeats < 1:
        raise ValueError(f"--repeats must be at least 1, got {args.repeats}")
    from piezotip.scenarios.presets import preset_overrides

    base = [*preset_overrides(args.preset), *(args.set or [])]
    cases = grasp_cases(all_scenes=args.all_scenes, overrides=base)
    if not args.no_presets:
        # The per-step cost grows with instrumented pads (x active modes, which is one each):
        # the same scene with one fingertip instrumented, beside the default two.
        from piezotip import scenarios
        from piezotip.reports.bench import BenchCase

        cases.append(BenchCase("grasp, 1 pad", scenarios.get("grasp", [*base, "sensor.pads=['left']"])))
    progress = None if args.json else (lambda name: print(f"benchmarking {name} ...", file=sys.stderr, flush=True))
    try:
        report = bench_report(cases, repeats=args.repeats, duration_s=args.duration, progress=progress)
    except RuntimeError as err:  # a run diverged or was not deterministic: no numbers to report
        print(f"error: {err}", file=sys.stderr)
        return 1
    if args.skin:
        from piezotip.reports.skin_bench import skin_report

        if progress:
            progress("a 16-fingertip skin")
        report["skin"] = skin_report(repeats=args.repeats)
    if not args.no_presets:
        from piezotip.reports.fidelity import fidelity_report, format_fidelity, plot_pareto

        fidelity = fidelity_report(progress=progress)
        report["presets"] = fidelity["presets"]
        report["convergence"] = fidelity["convergence"]
        report["fidelity_checks"] = fidelity["checks"]
    files = [str(p) for p in write_report(report, Path(args.out))] if args.out else []
    if args.out and not args.no_presets:
        files.append(str(plot_pareto(fidelity, Path(args.out) / "pareto.png")))
    if args.json:
        print(json.dumps(_json_safe(report), indent=2))
    else:
        print(format_report(report))
        if args.skin:
            from piezotip.reports.skin_bench import format_skin_report

            print()
            print(format_skin_report(report["skin"]))
        if not args.no_presets:
            print()
            print(format_fidelity(fidelity))
        for f in files:
            print(f"wrote {f}")
    return 0


def _cmd_creep(args: argparse.Namespace) -> int:
    from piezotip.reports.creep import creep_report, format_table

    out = None
    if args.out:
        from piezotip.analysis.runner import check_out_dir

        out = check_out_dir(Path(args.out))  # before the runs: a bad --out fails fast
    progress = None if args.json else (lambda what: print(f"measuring {what} ...", file=sys.stderr, flush=True))
    report = creep_report(quick=args.quick, progress=progress)
    files = []
    if out is not None:
        path = out / "creep.json"
        path.write_text(json.dumps(_json_safe(report), indent=2) + "\n")
        files.append(str(path))
    if args.json:
        print(json.dumps(_json_safe({**report, "files": files}), indent=2))
    else:
        print(format_table(report))
        for f in files:
            print(f"wrote {f}")
    # 0 when the model as it is meets the requirement on every object measured.
    return 0 if report["summary"]["current"]["meets_requirement"] else 1


def prog_name(argv0: str | None = None) -> str:
    """The name the command line was invoked as: ``piezotip`` (the console script) or ``run_sim.py``
    (the checkout's script, ``python -m piezotip.cli``, or a caller of :func:`main`)."""
    argv0 = (sys.argv[0] if sys.argv else "") if argv0 is None else argv0
    name = os.path.basename(argv0.replace("\\", "/"))  # Windows' piezotip.exe too
    return "piezotip" if os.path.splitext(name)[0] in ("piezotip", "piezotip-script") else "run_sim.py"


def build_parser(prog: str | None = None) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=prog or prog_name(), description="piezotip: a robot fingertip with a multimode piezoelectric tactile sensor"
    )
    debug_help = "on an internal error (exit 3) print the traceback too, not only the file it is written to"
    parser.add_argument("--debug", action="store_true", help=debug_help)
    # --debug after the command too (``run grasp --debug``); SUPPRESS keeps the sub-command from
    # overwriting a --debug given before it.
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=debug_help)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=_subparser(common))

    p = sub.add_parser("list", help="the registered scenarios")
    p.set_defaults(func=_cmd_list)

    p = sub.add_parser("run", help="run a scenario headless: summary, plots, recording")
    p.add_argument("scenario", help="scenario name (see 'list')")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a config value, e.g. object.mass_kg=0.4 (repeatable)")
    p.add_argument("--out", help="output directory (default: out/SCENARIO, or out/SCENARIO-<hash> with --set or --preset)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--csv", action="store_true", help="also write the recording as CSV")
    p.add_argument("--no-plot", action="store_true", help="no run.png (batch use: matplotlib is then never imported)")
    p.add_argument("--render", action="store_true", help="save a strip of frames from MuJoCo's offscreen renderer (MUJOCO_GL=egl)")
    p.add_argument("--preset", choices=PRESET_NAMES, help="fidelity preset (default: the scenario's own settings, = balanced)")
    _add_video_arguments(p, "run.mp4")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("experiment", help="grasp experiments: grasp-range (objects 1 g to 10 kg, multimode vs single-mode)")
    p.add_argument("name", help="experiment name: grasp-range")
    p.add_argument("--json", action="store_true", help="print the table as JSON")
    p.add_argument("--out", help="output directory (default: out/grasp-range)")
    p.add_argument("--preset", choices=PRESET_NAMES, help="fidelity preset for every run")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a config value of every run (repeatable)")
    p.add_argument("--no-plot", action="store_true", help="no grasp_range.png")
    _add_video_arguments(p, "one clip per run, runs/NN/run.mp4")
    _add_dask_arguments(p)
    p.set_defaults(func=_cmd_experiment)

    p = sub.add_parser("sweep", help="a scenario over a grid of settings, on Dask: sweep.csv, sweep.parquet, sweep.png")
    p.add_argument("scenario", help="scenario name (see 'list')")
    p.add_argument(
        "--grid",
        action="append",
        required=True,
        metavar="KEY=V1,V2,...",
        help="a key and its values, e.g. object.mass_kg=0.1,0.4 (repeatable)",
    )
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a config value of every point (repeatable)")
    p.add_argument("--preset", choices=PRESET_NAMES, help="fidelity preset of every point")
    p.add_argument("--out", help="output directory (default: out/sweep-SCENARIO-<hash>); run again with it to resume")
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    p.add_argument("--no-plot", action="store_true", help="no sweep.png")
    _add_dask_arguments(p)
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("figures", help="the paper's analysis figures (V_1 and sensitivities against k_e, c_e)")
    p.add_argument("--out", default="out/figures", help="output directory (default: out/figures)")
    p.set_defaults(func=_cmd_figures)

    p = sub.add_parser("range", help="the fingertip's dynamic range, per mode, and its switch pressures")
    p.add_argument(
        "--coverage", nargs=2, type=float, metavar=("X1_MM", "X2_MM"), help="gel coverage on the element, mm (default: whole beam)"
    )
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument("--out", help="directory for plots, CSV and range.json")
    p.add_argument(
        "--gel-layer", choices=("winkler", "dynamic"), default="winkler", help="the gel layer's model (default winkler; see README)"
    )
    p.add_argument("--variation", help="the physical unit: none (the nominal model), typical or wide (manufacturing spreads)")
    p.add_argument("--unit-seed", type=int, metavar="N", help="which unit (the same seed, the same unit; default 0)")
    p.add_argument("--calibration", help="none, self (resonance sweep) or full (plus known loads); default self for a varied unit")
    p.add_argument("--temperature-c", type=float, metavar="T", help="the unit's temperature, C (-20 to 80; calibrated at 25)")
    p.add_argument("--units", type=int, metavar="N", help="a Monte Carlo over N units (seeds 0..N-1): distributions and yield")
    p.add_argument("--workers", type=int, metavar="N", help="processes for --units (default: up to 2 cores)")
    p.set_defaults(func=_cmd_range)

    p = sub.add_parser("bench", help="the co-simulation's cost: real-time factor, overhead over bare mj_step, each preset's cost and error")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument("--out", help="directory for bench.json and bench.png")
    p.add_argument("--repeats", type=int, default=5, help="timed runs and bare-step passes; the fastest is kept (default 5)")
    p.add_argument("--duration", type=float, metavar="SECONDS", help="simulated seconds per run (default: the scenario's)")
    p.add_argument("--all-scenes", action="store_true", help="also the other registered grasp scenes")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a config value of every benchmarked scene (repeatable)")
    p.add_argument("--preset", choices=PRESET_NAMES, help="fidelity preset of the benchmarked scenes (the overhead part)")
    p.add_argument("--no-presets", action="store_true", help="skip the fidelity presets' cost and error table")
    p.add_argument("--skin", action="store_true", help="also a 16-fingertip skin (attach) against the bare model and MuJoCo's <touch>")
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser(
        "creep", help="held objects' creep at 1.2x the needed grip and sliding at 0.8x, per contact model, with its cost (exit 1: fails)"
    )
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument("--out", help="directory for creep.json")
    p.add_argument("--quick", action="store_true", help="a small grid (a 3 g and a 100 g box, 0.3 s holds) instead of the whole rating")
    p.set_defaults(func=_cmd_creep)
    return parser


def _subparser(common: argparse.ArgumentParser):
    """The sub-commands' parser class: each also takes ``common``'s options."""

    class SubParser(argparse.ArgumentParser):
        def __init__(self, *args, **kwargs) -> None:
            kwargs.setdefault("parents", [common])
            super().__init__(*args, **kwargs)

    return SubParser


def main(argv: list[str] | None = None) -> int:
    """Run the command line on ``argv`` (default ``sys.argv[1:]``); return the exit code (module
    docstring).  Nothing but argparse's own usage errors and ``--help`` (SystemExit) leaves it.

    SIGINT and SIGTERM stop the command from its start (exit 130, 143): ``interrupted``, a run's
    summary kept, not the process killed.  Run as the program (``argv`` None: ``run_sim.py``, the
    ``piezotip`` script), any later one is ignored once the status is decided, until the process
    ends: Python's exit (MuJoCo's and Dask's clean-up) takes a while, and a signal then would
    kill the process instead of letting it exit with the status it reported."""
    with interrupts.raised(keep_held=argv is None):  # piezotip.interrupts is light: before the command's imports
        try:
            status = _dispatch(build_parser().parse_args(argv), program=argv is None)
            signum = interrupts.noted()
            if signum is not None and status != 128 + signum:  # a signal a library swallowed, or one as the command ended
                return _interrupted(interrupts.interruption(signum))
            if argv is None:  # the program's status is decided: a signal while Python exits cannot change it
                interrupts.hold()
        except KeyboardInterrupt as exc:  # as it parsed its arguments, or as it ended
            return _interrupted(exc)
        return status


def _dispatch(args, program: bool = False) -> int:
    """Run the parsed command; map what it raises to the exit codes (module docstring).
    ``program``: run as the program, not from a script's call of :func:`main`."""
    try:
        if getattr(args, "render", False) or getattr(args, "video", False):
            _rendering_backend()
        elif program:
            _no_rendering_backend()
        return args.func(args)
    except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM outside a run's loop (imports, set-up, plots, sweeps)
        return _interrupted(exc)
    except Exception as exc:
        if interrupts.signal_in(exc) is not None:  # a signal a library turned into its own error (an import cut short)
            return _interrupted(exc)
        return _error_status(exc, args)


def _interrupted(exc: BaseException) -> int:
    """The one line of a command a signal stopped, and its exit status (130 Ctrl-C, 143 SIGTERM).
    A later signal is ignored from here on (:func:`main`'s notes): the first decided."""
    interrupts.hold()
    print("interrupted", file=sys.stderr)
    return 128 + (interrupts.signal_in(exc) or signal.SIGINT)


def _error_status(exc: Exception, args) -> int:
    """The exit status of an error (bad input, a missing dependency, a bug), its line printed."""
    if isinstance(exc, (ValueError, OSError)):  # bad input, or a file that cannot be read or written
        print(f"error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if isinstance(exc, ModuleNotFoundError) and exc.name and exc.name.split(".")[0] != "piezotip":  # the environment lacks a dependency
        print(f"error: {_one_line(exc)} (a dependency is missing: pip install piezotip's requirements)", file=sys.stderr)
        return EXIT_BAD_INPUT
    return _internal_error(exc, args)  # a bug: never read as an outcome


def _one_line(exc: BaseException) -> str:
    """An exception's message on one line of at most MAX_ERROR_CHARS characters."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    if len(text) > MAX_ERROR_CHARS:
        text = f"{text[: MAX_ERROR_CHARS - 200]} ... {text[-150:]} ({len(text)} characters)"
    return text


def _internal_error(exc: Exception, args: argparse.Namespace) -> int:
    """Exit 3: one line naming the exception and the file its traceback went to (printed too with --debug)."""
    text = "".join(traceback.format_exception(exc))
    if getattr(args, "debug", False):
        print(text, end="", file=sys.stderr)
    where = _write_traceback(text, getattr(args, "out", None))
    name = type(exc).__name__
    message = _one_line(exc)[:500]
    if where is None:  # nowhere to write it: the traceback itself, then the line
        if not getattr(args, "debug", False):
            print(text, end="", file=sys.stderr)
        print(f"internal error: {name}: {message} (a bug in piezotip; the traceback could not be written, it is above)", file=sys.stderr)
    else:
        print(f"internal error: {name}: {message} (a bug in piezotip; traceback in {where})", file=sys.stderr)
    return EXIT_INTERNAL


def _write_traceback(text: str, out: str | None) -> Path | None:
    """Write ``text`` to ``OUT/traceback.txt`` (an existing --out folder) or else to
    ``$TMPDIR/piezotip-traceback-<pid>.txt``; the path written, or None if neither could be."""
    candidates = []
    if out and Path(out).is_dir():
        candidates.append(Path(out) / "traceback.txt")
    candidates.append(Path(tempfile.gettempdir()) / f"piezotip-traceback-{os.getpid()}.txt")
    for path in candidates:
        try:
            path.write_text(text)
            return path
        except OSError:
            continue
    return None

"""A run that survives (issue 30): SIGTERM and a second Ctrl-C end it as the first Ctrl-C does,
a rerun leaves no stale summary and removes only the files a run writes, and a long run's
memory does not grow with its length.  Signals are sent in child processes (a test that
failed would otherwise take pytest down with it)."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from piezotip.analysis.runner import exit_status, run_scenario
from piezotip.cosim.recorder import read_recording

ROOT = Path(__file__).resolve().parent.parent

#: A cheap run: the fast preset, cut at 1 s.
SHORT = ["duration_s=1.0"]

#: The child's run, its loop's advance replaced so that the signals come at known places.
_CHILD = """
import json, os, signal, sys
from pathlib import Path
from piezotip.analysis import run_report
from piezotip.analysis.runner import run_scenario
from piezotip.cosim.loop import CoSimulation
from piezotip.cosim.recorder import Recorder

# Ctrl-C as in a terminal, whatever the test runner's parent left (a shell's background job
# starts with SIGINT ignored, and Python then installs no KeyboardInterrupt handler).
signal.signal(signal.SIGINT, signal.default_int_handler)
plan = json.loads(sys.argv[2])  # where to send which signal: {"step": name, "close": name, "summary": name}
advance, close, summary = CoSimulation.advance, Recorder.close, run_report.summary
steps = {"n": 0}

def send(where):
    if plan.get(where):
        os.kill(os.getpid(), getattr(signal, plan[where]))

def advance_then_signal(self):
    steps["n"] += 1
    if steps["n"] == 50:
        send("step")
    return advance(self)

def close_after_signal(self):
    send("close")
    return close(self)

def summary_after_signal(*args, **kwargs):
    send("summary")
    return summary(*args, **kwargs)

init = CoSimulation.__init__

def init_then_signal(self, *args, **kwargs):
    init(self, *args, **kwargs)
    send("setup")

CoSimulation.advance, Recorder.close, run_report.summary = advance_then_signal, close_after_signal, summary_after_signal
CoSimulation.__init__ = init_then_signal
try:
    report, data = run_scenario("grasp", ["duration_s=1.0"], Path(sys.argv[1]), plot=False, quiet=True, preset="fast")
except KeyboardInterrupt as err:
    print(json.dumps({"raised": type(err).__name__, "exit_status": getattr(err, "exit_status", None)}))
else:
    print(json.dumps({"interrupted": report["interrupted"], "signal": report["signal"], "rows": len(data["time_s"])}))
"""


def _child(out: Path, plan: dict) -> tuple[subprocess.CompletedProcess, dict | None]:
    proc = subprocess.run([sys.executable, "-c", _CHILD, str(out), json.dumps(plan)], cwd=ROOT, capture_output=True, text=True, timeout=120)
    summary = out / "summary.json"
    return proc, json.loads(summary.read_text()) if summary.exists() else None


def test_sigterm_ends_a_run_as_ctrl_c_does(tmp_path):
    proc, summary = _child(tmp_path, {"step": "SIGTERM"})
    assert proc.returncode == 0, proc.stderr  # before: killed by the signal (-15), no summary
    printed = json.loads(proc.stdout)
    assert printed["interrupted"] is True and printed["signal"] == "SIGTERM" and 49 <= printed["rows"] <= 50
    assert summary["interrupted"] is True and summary["signal"] == "SIGTERM"
    assert summary["reason"].startswith("interrupted (SIGTERM) at t = 0.2")
    assert exit_status(summary) == 143
    data, _ = read_recording(tmp_path / "run")
    assert len(data["time_s"]) == printed["rows"] and not (tmp_path / "run.chunks").exists()


def test_a_second_ctrl_c_or_a_sigterm_after_the_first_does_not_cut_the_close_or_the_summary(tmp_path):
    """The first Ctrl-C stops the loop; one more while the recording closes and a SIGTERM while
    the summary is made are held: the summary is written, marked interrupted by the first."""
    proc, summary = _child(tmp_path, {"step": "SIGINT", "close": "SIGINT", "summary": "SIGTERM"})
    assert proc.returncode == 0, proc.stderr  # before: a KeyboardInterrupt out of the close, no summary
    assert summary["interrupted"] is True and summary["signal"] == "SIGINT"
    assert summary["reason"].startswith("interrupted (Ctrl-C)")
    assert exit_status(summary) == 130
    assert len(np.load(tmp_path / "run.npz")["time_s"]) == json.loads(proc.stdout)["rows"]


def test_a_signal_after_the_loop_ended_holds_until_the_summary_is_written(tmp_path):
    proc, summary = _child(tmp_path, {"close": "SIGTERM"})
    assert proc.returncode == 0, proc.stderr
    assert summary["interrupted"] is True and summary["signal"] == "SIGTERM"
    assert len(np.load(tmp_path / "run.npz")["time_s"]) == 200  # the whole second was recorded


def test_the_command_stopped_by_sigterm_writes_its_summary(tmp_path):
    """The command line, a SIGTERM from outside while it runs: the summary kept, exit 143 (128 +
    SIGTERM, the shell's convention; it was killed with no summary before)."""
    out = tmp_path / "run"
    argv = [sys.executable, "run_sim.py", "run", "grasp", "--no-plot", "--preset", "fast", "--out", str(out)]
    argv += ["--set", "controller.hold_s=100", "--set", "duration_s=120"]
    proc = subprocess.Popen(argv, cwd=ROOT, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 90
        while not (out / "run.chunks" / "chunk_000002.npy").exists():
            assert proc.poll() is None and time.monotonic() < deadline, "the run never got going"
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=90)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 128 + signal.SIGTERM, (proc.returncode, err)  # before: -15
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interrupted"] is True and summary["signal"] == "SIGTERM"
    assert "Traceback" not in err


def _fake_outputs(out: Path) -> None:
    for name in ("run.png", "frames.png", "run.mp4", "run.csv"):
        (out / name).write_bytes(b"an old run's")


def test_a_rerun_that_dies_leaves_no_stale_summary_nor_an_old_runs_files(tmp_path, monkeypatch):
    from piezotip.cosim.loop import CoSimulation

    run_scenario("grasp", SHORT, tmp_path, plot=False, quiet=True, preset="fast")
    assert json.loads((tmp_path / "summary.json").read_text())["interrupted"] is False
    _fake_outputs(tmp_path)
    (tmp_path / "notes.txt").write_text("mine")
    advance, steps = CoSimulation.advance, {"n": 0}

    def dies_at_30(self):
        steps["n"] += 1
        if steps["n"] > 30:
            raise RuntimeError("the machine fell over")  # as a kill would, no summary is written
        return advance(self)

    monkeypatch.setattr(CoSimulation, "advance", dies_at_30)
    with pytest.raises(RuntimeError):
        run_scenario("grasp", SHORT, tmp_path, plot=False, quiet=True, preset="fast")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt", "run.npz"]  # before: the old summary, saying success
    assert len(np.load(tmp_path / "run.npz")["time_s"]) == 30


def test_a_rerun_into_a_folder_whose_chunks_hold_a_foreign_file_stops_before_touching_anything(tmp_path):
    run_scenario("grasp", SHORT, tmp_path, plot=False, quiet=True, preset="fast")
    (tmp_path / "run.chunks").mkdir()
    (tmp_path / "run.chunks" / "notes.txt").write_text("mine")
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(FileExistsError, match=r"notes\.txt"):  # before: run.chunks/ deleted, notes.txt with it
        run_scenario("grasp", SHORT, tmp_path, plot=False, quiet=True, preset="fast")
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert (tmp_path / "run.chunks" / "notes.txt").read_text() == "mine"


def test_the_returned_data_is_the_recording(tmp_path):
    report, data = run_scenario("grasp", SHORT, tmp_path, plot=False, quiet=True, preset="fast")
    saved, _ = read_recording(tmp_path / "run")
    assert list(data) == list(saved) and report["steps"] == len(data["time_s"]) == 200
    for key, values in saved.items():
        np.testing.assert_array_equal(data[key], values)
    assert report["signal"] is None and exit_status(report) is None
    assert str(tmp_path / "summary.json") in report["files"] and not (tmp_path / "summary.json.tmp").exists()


_PEAK = """
import resource, sys
import run_sim
code = run_sim.main(sys.argv[1:])
print("MAXRSS_KB", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)
sys.exit(code)
"""


def _peak_kib(out: Path, hold_s: float) -> int:
    argv = ["run", "grasp", "--no-plot", "--set", f"controller.hold_s={hold_s}", "--set", "duration_s=320", "--out", str(out)]
    proc = subprocess.run([sys.executable, "-c", _PEAK, *argv], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return int(proc.stderr.rsplit("MAXRSS_KB", 1)[1].split()[0])


@pytest.mark.slow
def test_a_300_s_hold_peaks_within_15_percent_of_a_10_s_hold(tmp_path):
    """Before: 115 MiB against 75 MiB (the chunks kept in memory, gathered whole to write run.npz,
    and the whole recording loaded for the summary)."""
    short, long = _peak_kib(tmp_path / "short", 10), _peak_kib(tmp_path / "long", 300)
    assert long <= 1.15 * short, (long, short)


def test_a_sigterm_before_the_loop_raises_a_keyboard_interrupt_carrying_its_exit_status(tmp_path):
    """As a Ctrl-C there does: no run, no summary; the exception says 143 for the command line."""
    proc, summary = _child(tmp_path, {"setup": "SIGTERM"})
    assert proc.returncode == 0, proc.stderr  # before: killed by the signal
    assert json.loads(proc.stdout) == {"raised": "Terminated", "exit_status": 143}  # SIGTERM's RunInterrupted (piezotip.interrupts)
    assert summary is None

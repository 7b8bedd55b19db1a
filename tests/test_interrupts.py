"""Ctrl-C and SIGTERM stop a script's loop over piezotip.run and piezotip.sweep, and the command
line at any moment (issue 44, item 6).  Before: the run cut short ended as an ordinary result
and the loop went on (exit 0 after every run); a Ctrl-C in the command's first tenths of a
second printed a traceback (or exit 3: an import it cut short); a signal while a sweep's Dask
cluster closed killed the command by the signal (-2, -15).  Signals are sent to child processes."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from piezotip import cli, interrupts
from piezotip.analysis import sweep_cluster

ROOT = Path(__file__).resolve().parent.parent

#: A run long enough to be cut short: the fast preset, a 100 s hold (about 3 s of wall time).
LONG = ["controller.hold_s=100", "duration_s=120"]

#: The user's script: a loop over piezotip.run (or piezotip.sweep), each run into its folder.
_LOOP = """
import json, signal, sys
import piezotip

signal.signal(signal.SIGINT, signal.default_int_handler)  # Ctrl-C as in a terminal, whatever the test's parent left
out, how, catch, long = sys.argv[1], sys.argv[2], sys.argv[3] == "catch", json.loads(sys.argv[4])
done = []

def loop():
    for i in range(3):
        if how == "run":
            piezotip.run("grasp", overrides=long, preset="fast", out=f"{out}/{i}")
        else:
            piezotip.sweep("grasp", {"object.mass_kg": [0.1, 0.2]}, preset="fast", overrides=long, workers=0, out=f"{out}/{i}")
        done.append(i)

if catch:
    try:
        loop()
    except KeyboardInterrupt as err:
        result = err.result
        print(json.dumps({
            "type": type(err).__name__, "signum": err.signum, "done": done, "system_exit": isinstance(err, SystemExit),
            "code": getattr(err, "code", None), "message": str(err) + " ".join(getattr(err, "__notes__", [])),
            "interrupted": None if result is None else result.summary["interrupted"],
            "rows": None if result is None else len(result.data["time_s"]),
        }))
else:
    loop()
"""


def _ctrl_c_as_in_a_terminal() -> None:
    """In the child, before it runs: SIGINT's default action, as a terminal's shell leaves it to the
    commands it starts.  A test run from a non-interactive shell's background (``cmd &``, nohup)
    inherits SIGINT ignored, and Python then installs no KeyboardInterrupt handler: the commands
    under test would never see the Ctrl-C these tests send."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _wait_for(path: Path, proc: subprocess.Popen, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not path.exists():
        assert proc.poll() is None, f"the child ended before {path} appeared: {proc.communicate()}"
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.02)


def _loop(tmp_path: Path, how: str, catch: bool, signum: int, started: str) -> tuple[subprocess.CompletedProcess, dict | None]:
    """The script's loop in a child, ``signum`` sent once ``started`` (a path under the output) exists."""
    argv = [sys.executable, "-c", _LOOP, str(tmp_path), how, "catch" if catch else "no", json.dumps(LONG)]
    proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        _wait_for(tmp_path / started, proc)
        proc.send_signal(signum)
        out, err = proc.communicate(timeout=30)  # before: the loop went on to its other runs (about 3 s each)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    done = subprocess.CompletedProcess(argv, proc.returncode, out, err)
    return done, json.loads(out) if catch and out.strip() else None


@pytest.mark.parametrize("signum, raised", [(signal.SIGINT, "KeyboardInterrupt"), (signal.SIGTERM, "Terminated")])
def test_a_signal_stops_a_scripts_loop_over_run_with_the_run_so_far_saved(tmp_path, signum, raised):
    proc, caught = _loop(tmp_path, "run", True, signum, "0/run.chunks/chunk_000001.npy")  # 5 s into the first run
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert caught is not None, proc.stderr[-3000:]
    assert caught["type"] == raised and caught["signum"] == signum and caught["done"] == []  # before: done [0, 1, 2]
    assert caught["system_exit"] == (signum == signal.SIGTERM) and caught["code"] == (143 if signum == signal.SIGTERM else None)
    assert caught["interrupted"] is True and caught["rows"] >= 1000  # the exception's result: the run so far
    summary = json.loads((tmp_path / "0" / "summary.json").read_text())
    assert summary["interrupted"] is True and summary["signal"] == signal.Signals(signum).name
    assert (tmp_path / "0" / "run.npz").exists() and not (tmp_path / "1").exists()
    assert "interrupted" in caught["message"] and str(tmp_path / "0") in caught["message"]


def test_an_uncaught_sigterm_ends_the_script_with_143_and_no_traceback(tmp_path):
    proc, _ = _loop(tmp_path, "run", False, signal.SIGTERM, "0/run.chunks/chunk_000001.npy")
    assert proc.returncode == 143, (proc.returncode, proc.stderr[-3000:])  # before: 0, every run done
    assert "Traceback" not in proc.stderr
    assert json.loads((tmp_path / "0" / "summary.json").read_text())["signal"] == "SIGTERM" and not (tmp_path / "1").exists()


def test_an_uncaught_ctrl_c_ends_the_script_as_pythons_own_does(tmp_path):
    proc, _ = _loop(tmp_path, "run", False, signal.SIGINT, "0/run.chunks/chunk_000001.npy")
    assert proc.returncode == -signal.SIGINT, (proc.returncode, proc.stderr[-3000:])  # Python's exit on KeyboardInterrupt
    assert proc.stderr.rstrip().splitlines()[-1].startswith("KeyboardInterrupt: piezotip.run('grasp'): interrupted (Ctrl-C) at t = ")
    assert not (tmp_path / "1").exists()


def test_a_signal_stops_a_scripts_loop_over_sweep(tmp_path):
    """The sweep's points run in the script's process (workers=0): the point in flight stops,
    nothing is journaled for it, and the exception leaves the call, naming the journal."""
    proc, caught = _loop(tmp_path, "sweep", True, signal.SIGINT, "0/points.jsonl")  # the first point is done
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert caught["type"] == "KeyboardInterrupt" and caught["done"] == [] and "points.jsonl" in caught["message"]
    assert len((tmp_path / "0" / "points.jsonl").read_text().splitlines()) == 1 and not (tmp_path / "1").exists()


#: The command line from its first line on: "go" as run_sim.py starts (Python's own start-up, before
#: any of the project's code, is not the project's to handle).
_COMMAND = """
import sys
code = compile(open("run_sim.py").read(), "run_sim.py", "exec")
sys.argv = ["run_sim.py", *sys.argv[1:]]
print("go", flush=True)
exec(code)
"""

#: The installed ``piezotip`` console script as pip's wrapper runs it: ``from <module> import
#: <function>; sys.exit(<function>())``, its entry point read from the project's metadata.
_CONSOLE_SCRIPT = """
import importlib, importlib.metadata, sys
(entry,) = importlib.metadata.entry_points(group="console_scripts", name="piezotip")
module, _, function = entry.value.partition(":")
sys.argv = ["piezotip", *sys.argv[1:]]
print("go", flush=True)
sys.exit(getattr(importlib.import_module(module), function)())
"""


@pytest.mark.parametrize(
    "command, signum, delay_s",
    [
        *(("run_sim.py", signal.SIGINT, d) for d in (0.01, 0.03, 0.07, 0.12, 0.2, 0.3)),
        ("run_sim.py", signal.SIGTERM, 0.01),
        ("run_sim.py", signal.SIGTERM, 0.12),
        *(("piezotip", signum, d) for signum in (signal.SIGINT, signal.SIGTERM) for d in (0.01, 0.12)),
    ],
)
def test_a_signal_in_the_commands_first_tenths_of_a_second_is_one_line_and_its_status(tmp_path, command, signum, delay_s):
    """Before: a traceback (an import cut short), or exit 3 (numpy's or MuJoCo's import cut
    short raises ImportError: initialization failed).  The console script ended by SIGTERM's
    default action (-15, no line) in its first tens of milliseconds, before piezotip/_console.py."""
    sets = [arg for setting in LONG for arg in ("--set", setting)]
    code = _COMMAND if command == "run_sim.py" else _CONSOLE_SCRIPT
    argv = [sys.executable, "-c", code, "run", "grasp", "--preset", "fast", "--no-plot", "--out", str(tmp_path / "run"), *sets]
    proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=_ctrl_c_as_in_a_terminal)
    try:
        assert proc.stdout.readline() == "go\n"
        time.sleep(delay_s)
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    lines = [line for line in err.replace("\r", "\n").splitlines() if line.strip() and not line.startswith("grasp:")]  # tqdm's bar
    assert proc.returncode == 128 + signum, (proc.returncode, err[-3000:])  # 130, 143
    assert "Traceback" not in err and lines[0].startswith("interrupted"), err[-3000:]
    assert len(lines) == 1, err[-3000:]


def test_an_error_an_interrupt_caused_is_the_interrupt():
    """A C extension whose import a Ctrl-C cuts short raises ImportError from the KeyboardInterrupt."""
    try:
        try:
            raise interrupts.interruption(signal.SIGTERM)
        except KeyboardInterrupt as cut:
            raise ImportError("initialization failed") from cut
    except ImportError as err:
        caused = err
    assert interrupts.signal_in(caused) == signal.SIGTERM
    assert interrupts.signal_in(KeyboardInterrupt()) == signal.SIGINT
    assert interrupts.signal_in(ImportError("no such module")) is None


def test_the_command_line_reads_an_error_an_interrupt_caused_as_the_interrupt(monkeypatch, capsys):
    def cut_short(args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as cut:
            raise ImportError("initialization failed") from cut

    monkeypatch.setattr(cli, "_cmd_list", cut_short)
    before = {signum: signal.getsignal(signum) for signum in interrupts.SIGNALS}
    assert cli.main(["list"]) == 130  # before: 3, "internal error: ImportError: initialization failed"
    assert capsys.readouterr().err == "interrupted\n"
    assert {signum: signal.getsignal(signum) for signum in interrupts.SIGNALS} == before  # called with argv: nothing held after


def test_sigterms_exception_is_a_keyboard_interrupt_and_an_exit_with_143():
    err = interrupts.interruption(signal.SIGTERM)
    assert isinstance(err, KeyboardInterrupt) and isinstance(err, SystemExit) and err.code == 143 == err.exit_status
    uncaught = subprocess.run(
        [sys.executable, "-c", "from piezotip import interrupts; raise interrupts.Terminated()"], capture_output=True, text=True
    )
    assert uncaught.returncode == 143 and uncaught.stderr == ""
    assert type(interrupts.caller_error(signal.SIGINT, "stopped")) is KeyboardInterrupt  # uncaught: Python's own Ctrl-C exit


@pytest.fixture
def ctrl_c_as_in_a_terminal():
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.mark.usefixtures("ctrl_c_as_in_a_terminal")
def test_a_signal_a_library_swallowed_is_still_the_interruption():
    """numpy's import cut short can clear the KeyboardInterrupt and raise an ImportError of its
    own ("PyCapsule_Import could not import module "datetime"", seen here as exit 3)."""
    with interrupts.raised():
        try:
            signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            pass  # swallowed
        err = ImportError('PyCapsule_Import could not import module "datetime"')
        assert err.__context__ is None and interrupts.signal_in(err) == signal.SIGINT == interrupts.noted()
    assert interrupts.noted() is None and interrupts.signal_in(err) is None  # outside the block: no signal behind it


@pytest.mark.usefixtures("ctrl_c_as_in_a_terminal")
def test_a_command_whose_signal_a_library_swallowed_ends_interrupted(monkeypatch, capsys):
    def swallows(args):
        try:
            signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            pass
        return 0

    monkeypatch.setattr(cli, "_cmd_list", swallows)
    assert cli.main(["list"]) == 130 and capsys.readouterr().err == "interrupted\n"


@pytest.mark.usefixtures("ctrl_c_as_in_a_terminal")
@pytest.mark.parametrize("leaving", [None, KeyboardInterrupt])
def test_a_signal_while_the_cluster_closes_waits_until_it_is_closed(monkeypatch, leaving):
    """The close goes to its end (before: cut short, Dask's own close at exit then met the half-closed
    cluster); the signal is raised after it, unless the first signal's exception is already leaving."""
    import dask.distributed

    events = []

    class Cluster:
        def __init__(self, **kwargs):
            events.append("started")

        def close(self):
            events.append("cluster closed")

    class Client:
        def __init__(self, cluster):
            events.append("client")

        def close(self):
            signal.raise_signal(signal.SIGINT)  # a second Ctrl-C, as the client closes
            events.append("client closed")

    monkeypatch.setattr(dask.distributed, "LocalCluster", Cluster)
    monkeypatch.setattr(dask.distributed, "Client", Client)
    with pytest.raises(KeyboardInterrupt) as raised:
        with sweep_cluster.dask_client(1, None):
            events.append("body")
            if leaving is not None:
                raise leaving("the first Ctrl-C")
    assert events == ["started", "client", "body", "client closed", "cluster closed"]
    assert (str(raised.value) == "the first Ctrl-C") == (leaving is not None)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signals_while_a_sweeps_cluster_closes_end_it_as_interrupted(tmp_path, signum):
    """The command line's sweep on a local Dask cluster: a signal, then more every 50 ms while
    it closes the cluster and exits.  Before: killed by the signal (-2, -15), no "interrupted"."""
    out = tmp_path / "sweep"
    argv = [sys.executable, "run_sim.py", "sweep", "grasp", "--grid", "object.mass_kg=0.05,0.1,0.2,0.3,0.4,0.5", "--preset", "fast"]
    argv += ["--set", "controller.hold_s=10", "--set", "duration_s=20", "--workers", "2", "--out", str(out), "--no-plot"]
    terminal = {"preexec_fn": _ctrl_c_as_in_a_terminal}
    proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, **terminal)
    try:
        _wait_for(out / "points.jsonl", proc, 120)  # the cluster is up, its first point done
        while proc.poll() is None:
            proc.send_signal(signum)
            time.sleep(0.05)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 128 + signum, (proc.returncode, err[-3000:])
    assert "interrupted" in err and "Traceback" not in err, err[-3000:]


@pytest.mark.parametrize("named", [None, "egl"])
def test_the_program_imports_no_opengl_backend_it_does_not_render_with(named):
    """Without MUJOCO_GL, MuJoCo's import loads GLFW, whose library search starts a Python process
    per candidate library and writes the file's name to its stdin: a signal in that window left
    the probe reading a closed stdin, its traceback ("File "<string>", line 28 ... EOFError")
    after "interrupted" (test_a_signal_in_the_commands_first_tenths_of_a_second_is_one_line_and_its_status,
    1 run in 8 of this file).  The program's commands that
    do not render take MUJOCO_GL=disable unless it is set; main() called from a script leaves
    the environment alone (the script may render later in the same process)."""
    import os

    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    if named:
        env["MUJOCO_GL"] = named
    show = "import os, sys; print(os.environ.get('MUJOCO_GL'), 'glfw' in sys.modules, 'mujoco' in sys.modules)"
    program = f"import sys; sys.argv = ['run_sim.py', 'list']; from piezotip.cli import main; main(); {show}"
    called = f"from piezotip.cli import main; main(['list']); {show}"
    as_program = subprocess.run([sys.executable, "-c", program], cwd=ROOT, env=env, capture_output=True, text=True)
    assert as_program.returncode == 0, as_program.stderr
    assert as_program.stdout.splitlines()[-1] == (f"{named} False True" if named else "disable False True")
    from_script = subprocess.run([sys.executable, "-c", called], cwd=ROOT, env=env, capture_output=True, text=True)
    assert from_script.stdout.splitlines()[-1].split()[0] == str(named)  # None, or as the script's caller set it

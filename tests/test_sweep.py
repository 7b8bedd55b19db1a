"""Sweeps on Dask: grid parsing, parallel rows equal serial ones, resume, errors, the files."""

import json
import math
import os
import time
from pathlib import Path

import pytest

from piezotip import cli
from piezotip.analysis import sweep as sweep_module
from piezotip.analysis import sweep_cluster
from piezotip.analysis.sweep import run_points
from piezotip.analysis.sweep_grid import grid_points, parse_grid, split_values
from piezotip.analysis.sweep_output import read_csv_rows
from piezotip.analysis.sweep_rows import ERROR_OUTCOME, RESULT_COLUMNS, error_row

#: A short, cheap scenario: the fast preset, the grasp cut at 3 s (touch, squeeze, lift begins).
SHORT = ("duration_s=3.0",)


@pytest.fixture(autouse=True)
def _spawned_workers_unless_started(monkeypatch):
    """Local clusters spawn their workers (Dask's way) unless the test starts the worker server
    (the command line does): one test's server does not change the next test's clusters."""
    monkeypatch.setattr(sweep_cluster, "_worker_server", False)


def _comparable(row: dict) -> dict:
    """A row without what depends on the machine (time, process)."""
    return {k: v for k, v in row.items() if k not in ("wall_time_s", "pid")}


def _same(a: dict, b: dict) -> bool:
    a, b = _comparable(a), _comparable(b)
    if a.keys() != b.keys():
        return False
    for key in a:
        x, y = a[key], b[key]
        if isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y):
            continue
        if x != y:
            return False
    return True


def test_values_split_at_top_level_commas_only():
    assert split_values("0.1,0.4, 2") == ["0.1", "0.4", "2"]
    assert split_values("[1, 2],[3],(6.5, 7.5)") == ["[1, 2]", "[3]", "(6.5, 7.5)"]
    assert split_values("'a,b',c") == ["'a,b'", "c"]
    for bad in ("[1, 2", "0.1,,0.2", "'open"):
        with pytest.raises(ValueError, match="--grid"):
            split_values(bad)


def test_grid_parses_keys_as_given_and_rejects_bad_specs():
    grid = parse_grid(["object.mass_kg=0.1,0.4", "controller.modes=[1],[1, 2]"])
    assert grid == {"object.mass_kg": ["0.1", "0.4"], "controller.modes": ["[1]", "[1, 2]"]}
    for bad in (["object.mass_kg"], ["=1,2"], ["object.mass_kg="], ["a=1", "a=2"], []):
        with pytest.raises(ValueError):
            parse_grid(bad)


def test_points_are_the_product_with_the_last_key_fastest_and_base_overrides_first():
    points = grid_points({"object.mass_kg": ["0.1", "0.4"], "object.friction": ["0.5", "1"]}, ["controller.hold_s=0.5"])
    assert [p.values for p in points] == [
        {"object.mass_kg": 0.1, "object.friction": 0.5},
        {"object.mass_kg": 0.1, "object.friction": 1},
        {"object.mass_kg": 0.4, "object.friction": 0.5},
        {"object.mass_kg": 0.4, "object.friction": 1},
    ]
    assert points[1].overrides == ("controller.hold_s=0.5", "object.mass_kg=0.1", "object.friction=1")
    # Python values (the API) give the same overrides as the command line's text.
    api = grid_points({"object.mass_kg": [0.1, 0.4], "object.friction": [0.5, 1]}, ["controller.hold_s=0.5"])
    assert [p.overrides for p in api] == [p.overrides for p in points]


def test_resume_skips_done_points_and_a_torn_line(tmp_path, monkeypatch):
    points = grid_points({"object.mass_kg": ["0.05", "0.2"]}, SHORT)
    first = run_points("grasp", points, "fast", tmp_path, workers=0, progress=False)
    assert first.skipped == 0 and all(r["outcome"] != ERROR_OUTCOME for r in first.rows)
    with (tmp_path / "points.jsonl").open("a") as fh:
        fh.write('{"key": "torn')  # a kill in the middle of a line

    def never(*args, **kwargs):
        raise AssertionError("a done point ran again")

    monkeypatch.setattr(sweep_module, "run_point", never)
    again = run_points("grasp", points, "fast", tmp_path, workers=0, progress=False)
    assert again.skipped == 2
    assert all(_same(a, b) for a, b in zip(first.rows, again.rows, strict=True))
    # A different point in the same folder is not "done".
    monkeypatch.undo()
    more = grid_points({"object.mass_kg": ["0.05", "0.2", "0.4"]}, SHORT)
    third = run_points("grasp", more, "fast", tmp_path, workers=0, progress=False)
    assert third.skipped == 2 and third.rows[2]["object.mass_kg"] == 0.4


def test_a_point_that_raises_is_recorded_and_the_sweep_goes_on(tmp_path, monkeypatch):
    from piezotip.analysis import runner

    real = runner.run_scenario

    def flaky(name, overrides, *args, **kwargs):
        if "object.mass_kg=0.2" in overrides:
            raise RuntimeError("the solver fell over")
        return real(name, overrides, *args, **kwargs)

    monkeypatch.setattr(runner, "run_scenario", flaky)
    points = grid_points({"object.mass_kg": ["0.2", "0.05"]}, SHORT)
    result = run_points("grasp", points, "fast", tmp_path, workers=0, progress=False)
    bad, good = result.rows
    assert bad["outcome"] == ERROR_OUTCOME and not bad["success"] and "the solver fell over" in bad["error"]
    assert good["outcome"] != ERROR_OUTCOME and good["error"] == ""
    # An errored point is run again on resume (it may have been the machine); a done one is not.
    monkeypatch.setattr(runner, "run_scenario", real)
    again = run_points("grasp", points, "fast", tmp_path, workers=0, progress=False)
    assert again.skipped == 1 and again.rows[0]["outcome"] != ERROR_OUTCOME


@pytest.mark.slow
def test_parallel_rows_equal_serial_rows(tmp_path):
    points = grid_points({"object.mass_kg": ["0.05", "0.3"], "object.friction": ["0.6", "1.0"]}, SHORT)
    serial = run_points("grasp", points, "fast", None, workers=0, progress=False)
    parallel = run_points("grasp", points, "fast", None, workers=2, progress=False)
    assert parallel.workers == 2
    assert len({r["pid"] for r in parallel.rows}) == 2  # both workers ran points
    for a, b in zip(serial.rows, parallel.rows, strict=True):
        assert _same(a, b), (a, b)


@pytest.mark.slow
def test_the_command_writes_csv_parquet_plot_and_json(tmp_path, capsys):
    import pyarrow.parquet as pq

    out = tmp_path / "sweep"
    argv = ["sweep", "grasp", "--grid", "object.mass_kg=0.05,0.2", "--set", SHORT[0], "--preset", "fast"]
    assert cli.main([*argv, "--workers", "0", "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["points"] == 2 and report["skipped_done"] == 0
    rows = read_csv_rows(out / "sweep.csv")  # its "# " header lines skipped
    header = list(rows[0])
    assert header[: 1 + len(RESULT_COLUMNS)] == ["object.mass_kg", *RESULT_COLUMNS]
    table = pq.read_table(out / "sweep.parquet").to_pylist()
    assert [r["object.mass_kg"] for r in table] == [0.05, 0.2]
    assert [r["outcome"] for r in table] == [r["outcome"] for r in rows] == [r["outcome"] for r in report["rows"]]
    assert table[0]["max_pressure_pa"] == pytest.approx(float(rows[0]["max_pressure_pa"]))
    assert (out / "sweep.png").stat().st_size > 10_000
    # Run again: every point is skipped, the files are the same rows.
    assert cli.main([*argv, "--workers", "0", "--out", str(out), "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["skipped_done"] == 2
    assert [_comparable(r) for r in again["rows"]] == [_comparable(r) for r in report["rows"]]


@pytest.mark.parametrize(
    "argv, named",
    [
        (["sweep", "grasp", "--grid", "object.mass_kg=0.1,abc"], "abc"),
        (["sweep", "grasp", "--grid", "object.nope=1"], "object.nope"),
        (["sweep", "nothere", "--grid", "object.mass_kg=1"], "nothere"),
        (["sweep", "grasp", "--grid", "object.mass_kg=1", "--workers", "-1"], "-1"),
        (["sweep", "grasp", "--grid", "object.mass_kg=[1"], "[1"),
    ],
)
def test_bad_sweeps_stop_before_any_run_with_one_line(argv, named, capsys, tmp_path):
    assert cli.main([*argv, "--out", str(tmp_path / "never")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and named in err and "\n" not in err
    assert not (tmp_path / "never" / "points.jsonl").exists()


def test_a_scheduler_that_is_not_there_is_named(capsys, tmp_path, monkeypatch):
    """Named once the connection's wait ends (a second here: the wait's own length is
    tests/test_batch_grade_inputs.py's)."""
    monkeypatch.setattr(sweep_cluster, "CONNECT_TIMEOUT_S", 1.0)
    argv = ["sweep", "grasp", "--grid", "object.mass_kg=0.1", "--scheduler", "tcp://127.0.0.1:1", "--out", str(tmp_path)]
    assert cli.main(argv) == 2
    assert "tcp://127.0.0.1:1" in capsys.readouterr().err


@pytest.mark.slow
def test_a_running_scheduler_takes_the_same_work(tmp_path, capsys):
    """--scheduler ADDRESS sends the points to a cluster someone started (here: one in this
    process, as `dask scheduler` + `dask worker` would be elsewhere); the rows equal serial ones."""
    from dask.distributed import LocalCluster

    argv = ["sweep", "grasp", "--grid", "object.mass_kg=0.05,0.2", "--set", SHORT[0], "--preset", "fast", "--json"]
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=50) as cluster:
        assert cli.main([*argv, "--scheduler", cluster.scheduler_address, "--out", str(tmp_path / "remote")]) == 0
        remote = json.loads(capsys.readouterr().out)
    assert cli.main([*argv, "--workers", "0", "--out", str(tmp_path / "serial")]) == 0
    serial = json.loads(capsys.readouterr().out)
    assert remote["workers"] == 1
    assert [_comparable(r) for r in remote["rows"]] == [_comparable(r) for r in serial["rows"]]


def _pid_point(scenario, overrides, preset, run_dir=None, options=None) -> dict:
    """A point's row at no cost, every column a row has (a resume takes no less), with the process that ran it."""
    row = {"outcome": "success", "reason": "lifted", "success": True, "max_pressure_pa": 1.0, "wall_time_s": 0.0, "pid": os.getpid()}
    return error_row("") | row


def test_a_single_point_to_run_runs_here_and_a_scheduler_always_gets_the_work():
    here = sweep_module.runs_in_this_process
    assert here(1, None, None) and here(1, 2, None) and here(1, 1, None) and here(5, 0, None)
    assert not here(2, None, None) and not here(2, 1, None) and not here(96, 2, None)
    assert not here(1, None, "tcp://127.0.0.1:8786") and not here(3, 0, "tcp://127.0.0.1:8786")


def test_run_points_starts_no_cluster_for_one_point_to_run(tmp_path, monkeypatch):
    """One point on a local cluster of 2 runs in this process, a resumed sweep's last point
    too; two points to run ask for the cluster."""

    def no_cluster(*args, **kwargs):
        raise AssertionError("a cluster was asked for")

    monkeypatch.setattr(sweep_module, "dask_client", no_cluster)
    monkeypatch.setattr(sweep_module, "run_point", _pid_point)
    points = grid_points({"object.mass_kg": ["0.05", "0.2"]}, SHORT)
    one = run_points("grasp", points[:1], "fast", tmp_path, workers=2, progress=False)
    assert one.workers == 0 and one.skipped == 0 and one.rows[0]["pid"] == os.getpid()
    resumed = run_points("grasp", points, "fast", tmp_path, workers=2, progress=False)
    assert resumed.workers == 0 and resumed.skipped == 1 and [r["pid"] for r in resumed.rows] == [os.getpid()] * 2
    with pytest.raises(AssertionError, match="a cluster was asked for"):
        run_points("grasp", points, "fast", tmp_path / "fresh", workers=2, progress=False)


def test_a_one_point_sweep_imports_neither_dask_nor_pyarrow_nor_matplotlib():
    """The API's one-point sweep (default workers: this machine's cores) runs in the calling
    process: no Dask (its import and cluster were the sweep's fixed second), no pyarrow or
    matplotlib without files."""
    import subprocess
    import sys

    script = (
        "import os, sys, piezotip\n"
        f"rows = piezotip.sweep('grasp', {{'object.mass_kg': [0.2]}}, preset='fast', overrides={list(SHORT)!r})\n"
        "print(rows[0]['pid'] == os.getpid(), rows[0]['outcome'] != 'error')\n"
        "print(*sorted(m for m in ('dask', 'distributed', 'pyarrow', 'matplotlib') if m in sys.modules))\n"
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.splitlines() == ["True True", ""]


def _plain(value):
    """``value`` with NaN as the text "nan" (NaN equals nothing, not even NaN)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return "nan" if isinstance(value, float) and math.isnan(value) else value


def _sweep_files(out) -> dict:
    """What a sweep wrote to ``out``, without what depends on the machine (times, processes,
    paths, the workers used)."""
    import pyarrow.parquet as pq

    table = [{k: v for k, v in r.items() if k != "wall_time_s"} for r in read_csv_rows(out / "sweep.csv")]
    report = json.loads((out / "sweep.json").read_text())
    journal = [json.loads(line) for line in (out / "points.jsonl").read_text().splitlines()]
    return {
        "csv": table,
        "parquet": [_plain(_comparable(r)) for r in pq.read_table(out / "sweep.parquet").to_pylist()],
        "png": (out / "sweep.png").read_bytes(),
        "json": {k: v for k, v in report.items() if k not in ("rows", "workers", "wall_time_s", "files")},
        "json_rows": [_comparable(r) for r in report["rows"]],
        "journal": [{"key": e["key"], "row": _comparable(e["row"])} for e in journal],
    }


@pytest.mark.slow
def test_a_single_point_here_writes_the_files_a_cluster_writes(tmp_path, capsys):
    """One point runs in the command's process (no worker server, no cluster): its sweep.csv,
    sweep.parquet, sweep.png, sweep.json and journal are those of the same point run by a Dask
    worker (a cluster's scheduler given, which always gets the work)."""
    from dask.distributed import LocalCluster

    argv = ["sweep", "grasp", "--grid", "object.mass_kg=0.2", "--set", SHORT[0], "--preset", "fast", "--json"]
    assert cli.main([*argv, "--workers", "2", "--out", str(tmp_path / "here")]) == 0
    here = json.loads(capsys.readouterr().out)
    assert not sweep_cluster._worker_server  # the command started no workers for one point
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=50) as cluster:
        assert cli.main([*argv, "--scheduler", cluster.scheduler_address, "--out", str(tmp_path / "there")]) == 0
        there = json.loads(capsys.readouterr().out)
    assert here["workers"] == 0 and there["workers"] == 1
    assert here["rows"][0]["pid"] == os.getpid() != there["rows"][0]["pid"]
    assert here["rows"][0]["outcome"] != ERROR_OUTCOME
    assert _sweep_files(tmp_path / "here") == _sweep_files(tmp_path / "there")


def _worker_view() -> tuple:
    """In a worker: its parent, the worker modules already imported, the server's flag, BLAS threads."""
    import os
    import sys

    from piezotip.analysis import sweep_cluster

    modules = [m for m in sweep_cluster.WORKER_MODULES if m in sys.modules]
    return os.getpid(), os.getppid(), modules, os.environ.get(sweep_cluster._SERVER_FLAG), os.environ.get("OMP_NUM_THREADS")


def _periodic_callbacks_ms(dask_worker=None, dask_scheduler=None) -> dict:
    server = dask_worker if dask_worker is not None else dask_scheduler
    return {name: pc.callback_time for name, pc in server.periodic_callbacks.items()}


def test_the_local_clusters_settings_leave_a_users_own_alone():
    import dask

    ours = {key: value for key, (_default, value) in sweep_cluster.LOCAL_CLUSTER_CONFIG.items()}
    assert sweep_cluster.local_cluster_config().items() >= ours.items()
    with dask.config.set({"distributed.admin.tick.interval": "50ms", "distributed.worker.profile.enabled": True}):
        config = sweep_cluster.local_cluster_config()
    # A changed tick is the user's; a profiler left at Dask's default (True) is switched off.
    assert "distributed.admin.tick.interval" not in config
    assert config["distributed.worker.profile.enabled"] is False
    # Each pair's first value is Dask's own default, so the check above compares like with like.
    defaults = dask.config.merge(*dask.config.defaults)  # the packages' own, without a user's files
    for key, (default, _ours) in sweep_cluster.LOCAL_CLUSTER_CONFIG.items():
        assert dask.config.get(key, config=defaults) == default, key


@pytest.mark.slow
def test_local_workers_are_forked_from_the_worker_server_with_their_imports_done():
    before = dict(os.environ)
    assert sweep_cluster.start_worker_server()
    assert dict(os.environ) == before  # the server's environment is its own
    with sweep_cluster.dask_client(2, None) as client:
        seen = list(client.run(_worker_view).values())
        callbacks = list(client.run(_periodic_callbacks_ms).values())
        scheduler_callbacks = client.run_on_scheduler(_periodic_callbacks_ms)
    assert len(seen) == 2
    # The local cluster's settings reached the workers through their nanny, and the scheduler:
    # no profiler, the loop's lag and the system monitor read seldom.
    for found in [*callbacks, scheduler_callbacks]:
        assert not {"profile", "profile-cycle"} & set(found)
        assert found["tick"] == 1000 and found["monitor"] == 5000
    for _pid, parent, modules, flag, omp in seen:
        assert parent != os.getpid()  # forked by the server, not spawned by this process
        assert modules == list(sweep_cluster.WORKER_MODULES)
        assert flag is None  # only the server itself saw it
        assert omp == os.environ.get("OMP_NUM_THREADS", "1")
    # Closed: no worker left behind.
    deadline = time.monotonic() + 10.0
    alive = [pid for pid, *_ in seen]
    while alive and time.monotonic() < deadline:
        alive = [pid for pid in alive if os.path.exists(f"/proc/{pid}") and "Z" not in open(f"/proc/{pid}/stat").read().split()[2]]
        time.sleep(0.05)
    assert not alive


@pytest.mark.slow
def test_the_command_on_local_workers_gives_the_serial_rows(tmp_path, capsys):
    """The command line's own path: the worker server started early, the workers forked from it."""
    argv = ["sweep", "grasp", "--grid", "object.mass_kg=0.05,0.3", "--grid", "object.friction=0.6,1.0"]
    argv += ["--set", SHORT[0], "--preset", "fast", "--json", "--no-plot"]
    assert cli.main([*argv, "--workers", "2", "--out", str(tmp_path / "parallel")]) == 0
    parallel = json.loads(capsys.readouterr().out)
    assert sweep_cluster._worker_server  # the command started it
    assert cli.main([*argv, "--workers", "0", "--out", str(tmp_path / "serial")]) == 0
    serial = json.loads(capsys.readouterr().out)
    assert parallel["workers"] == 2 and len({r["pid"] for r in parallel["rows"]}) == 2
    assert [_comparable(r) for r in parallel["rows"]] == [_comparable(r) for r in serial["rows"]]


@pytest.mark.slow
def test_the_worker_server_imports_from_the_commands_path_not_the_current_folder(tmp_path):
    """A module in the folder the command runs from does not stand in for an installed one in
    the workers (Python 3.11's forkserver would put that folder first on its import path)."""
    import subprocess
    import sys

    here, scripts = tmp_path / "here", tmp_path / "scripts"
    here.mkdir()
    scripts.mkdir()
    (here / "tqdm.py").write_text("# not the real tqdm\n")
    (scripts / "probe.py").write_text(
        "from piezotip.analysis import sweep_cluster\n"
        "if __name__ == '__main__':\n"
        "    sweep_cluster.start_worker_server()\n"
        "    with sweep_cluster.dask_client(1, None) as client:\n"
        "        print(*client.run(lambda: __import__('sys').modules['tqdm'].__file__).values())\n"
    )
    proc = subprocess.run([sys.executable, str(scripts / "probe.py")], cwd=here, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "site-packages" in proc.stdout and str(here) not in proc.stdout


@pytest.fixture
def ctrl_c_as_in_a_terminal():
    """Python's Ctrl-C handler on SIGINT for the test, whatever the runner's parent left (a
    shell's background job starts with SIGINT ignored, and then Python installs none)."""
    import signal

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.mark.usefixtures("ctrl_c_as_in_a_terminal")
def test_a_ctrl_c_while_the_cluster_starts_waits_until_it_is_up_then_closes_it(monkeypatch):
    """Dask cannot close a cluster interrupted half-started (its own close at exit then prints a
    traceback): the interrupt is held until the cluster is up, then it is closed and the
    KeyboardInterrupt goes on (the command says "interrupted", exit status 130)."""
    import signal

    import dask.distributed

    events = []

    class Cluster:
        def __init__(self, **kwargs):
            signal.raise_signal(signal.SIGINT)  # Ctrl-C in the middle of the start
            events.append("started")

        def close(self):
            events.append("cluster closed")

    class Client:
        def __init__(self, cluster):
            events.append("client")

        def close(self):
            events.append("client closed")

    monkeypatch.setattr(dask.distributed, "LocalCluster", Cluster)
    monkeypatch.setattr(dask.distributed, "Client", Client)
    with pytest.raises(KeyboardInterrupt):
        with sweep_cluster.dask_client(1, None):
            events.append("body")  # never reached
    assert events == ["started", "client", "client closed", "cluster closed"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.usefixtures("ctrl_c_as_in_a_terminal")
def test_held_interrupts_raise_on_leaving_and_only_then():
    import signal

    with pytest.raises(KeyboardInterrupt):
        with sweep_cluster._interrupts_deferred() as held:
            signal.raise_signal(signal.SIGINT)
            assert held.caught  # still inside: nothing raised yet
    with sweep_cluster._interrupts_deferred() as held:
        pass
    assert not held.caught and signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.usefixtures("ctrl_c_as_in_a_terminal")
def test_a_held_sigterm_raises_run_interrupted_on_leaving():
    """SIGTERM under the command line's handler is held like Ctrl-C, and leaves as RunInterrupted
    (exit 143), both handlers back as they were."""
    import signal

    from piezotip.analysis.runner import RunInterrupted, sigterm_as_interrupt

    previous = signal.signal(signal.SIGTERM, sigterm_as_interrupt)
    try:
        with pytest.raises(RunInterrupted) as raised:
            with sweep_cluster._interrupts_deferred() as held:
                signal.raise_signal(signal.SIGTERM)
                signal.raise_signal(signal.SIGINT)  # a second signal: the first one decides
                assert held.caught == signal.SIGTERM
        assert raised.value.exit_status == 128 + signal.SIGTERM
        assert signal.getsignal(signal.SIGTERM) is sigterm_as_interrupt
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGTERM, previous)


@pytest.mark.slow
def test_a_sweep_on_a_cluster_stopped_by_sigterm_exits_143_with_its_journal(tmp_path):
    """SIGTERM while a sweep's points run on Dask workers ends it as Ctrl-C does: exit 143 and
    "interrupted", the journal's rows kept (it was killed by the signal before: exit -15)."""
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "sweep"
    argv = [sys.executable, "run_sim.py", "sweep", "grasp", "--grid", "object.mass_kg=0.05,0.1,0.2,0.4,0.8,1.6", "--preset", "fast"]
    argv += ["--set", "controller.hold_s=30", "--set", "duration_s=40", "--workers", "2", "--out", str(out)]
    root = Path(__file__).resolve().parent.parent
    proc = subprocess.Popen(argv, cwd=root, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not (out / "points.jsonl").exists():  # the sweep got going: its journal is open
            assert proc.poll() is None and time.monotonic() < deadline, "the sweep never got going"
            time.sleep(0.05)
        time.sleep(1.0)  # the workers are running points
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 128 + signal.SIGTERM, (proc.returncode, err[-2000:])
    assert "interrupted" in err and "Traceback" not in err


def test_the_worker_server_is_quiet_about_errors_once_its_command_is_gone(monkeypatch, capsys):
    """A worker forked as the command was interrupted fails to reach it: no traceback for that;
    while the command lives, an error is printed as usual."""
    try:
        raise FileNotFoundError(2, "No such file or directory")
    except FileNotFoundError as err:
        info = (type(err), err, err.__traceback__)
    monkeypatch.setattr(sweep_cluster, "_command_pid", os.getpid())
    sweep_cluster._quiet_interrupt(*info)
    assert "FileNotFoundError" in capsys.readouterr().err
    import subprocess
    import sys

    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    monkeypatch.setattr(sweep_cluster, "_command_pid", gone.pid)
    sweep_cluster._quiet_interrupt(*info)
    assert capsys.readouterr().err == ""

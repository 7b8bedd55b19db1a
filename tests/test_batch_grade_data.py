"""Batch-grade II (issue 44): nothing lost, nothing hidden.

- item 1: the on-disk cache's pruning removes its own entries only, never a user's file in its folder;
- item 3: a sweep journal's line shaped like a row but missing its columns is skipped with a warning,
  its point run again, instead of stopping every resume;
- item 11: a full disk says so (the file and the bytes); a chunk torn under its final name ends the
  recording read back there, naming it, instead of hiding it all; a ``<freejoint>`` in a gripper
  file is named in that file, not in the scene's.
"""

import errno
import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_third_party_grippers import SERVOS, SLIDE_GRIPPER, keys

from piezotip import cli, scenarios
from piezotip.analysis import sweep as sweep_module
from piezotip.analysis.sweep_rows import error_row
from piezotip.cosim import gripper_mount
from piezotip.cosim import recorder as recorder_module
from piezotip.cosim.loop import CoSimulation
from piezotip.cosim.recorder import Recorder, read_recording
from piezotip.sensor import cache as cache_module
from piezotip.sensor.cache import disk_cached, entry_key

REPO = Path(__file__).resolve().parents[1]

# -- item 1: the cache prunes its own entries only ---------------------------------------------------

#: A user's file named as an entry would be (a git commit's 40 hex digits), but no entry.
SHA_NAMED = "results-" + "3f2a" * 10 + ".npz"
#: The user's files :func:`_user_files` puts in the cache folder.
USER_FILES = ("mine.npz", SHA_NAMED, "notes.txt")


def _user_files(folder: Path) -> dict[str, bytes]:
    """A user's files in the cache folder, older than anything the cache writes: a 300 kB
    ``.npz`` (the issue's), one named like an entry, a text file.  Returns their bytes by name."""
    np.savez(folder / "mine.npz", measured=np.arange(37_500, dtype=float))  # 300 kB of someone's data
    np.savez(folder / SHA_NAMED, measured=np.ones(1000))
    (folder / "notes.txt").write_text("mine\n")
    for name in USER_FILES:
        os.utime(folder / name, ns=(10**9, 10**9))  # 1970: the least recently used of all
    return {name: (folder / name).read_bytes() for name in USER_FILES}


def _own_entries(folder: Path) -> list[Path]:
    """The cache's entries in ``folder``: its ``.npz`` files but the user's and temporaries."""
    return [p for p in folder.glob("*.npz") if p.name not in USER_FILES and not p.name.startswith(".tmp-")]


def test_a_users_npz_in_the_cache_folder_survives_a_grasp_under_a_tiny_bound(tmp_path):
    """The issue's case, as a user runs it: ``run grasp`` with their files in
    ``$PIEZOTIP_CACHE_DIR`` and ``PIEZOTIP_CACHE_MAX_MB`` below what one grasp's entries take
    (about 0.076 MB), so pruning runs.  Before: the 300 kB ``mine.npz`` went (the oldest ``.npz``
    there); now the user's files stay byte for byte and the cache's own entries keep the bound."""
    folder = tmp_path / "cache"
    folder.mkdir()
    mine = _user_files(folder)
    env = {**os.environ, "PIEZOTIP_CACHE_DIR": str(folder), "PIEZOTIP_CACHE_MAX_MB": "0.03"}
    env.pop("PIEZOTIP_CACHE", None)
    proc = subprocess.run(
        [sys.executable, str(REPO / "run_sim.py"), "run", "grasp", "--preset", "fast", "--out", str(tmp_path / "run")],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert proc.returncode in (0, 1), proc.stderr[-2000:]
    assert {name: (folder / name).read_bytes() for name in mine if (folder / name).exists()} == mine
    own = _own_entries(folder)
    assert own and sum(p.stat().st_size for p in own) <= 0.03e6  # pruned: the bound holds for the cache's entries


def test_prune_counts_and_removes_only_the_caches_own_entries(tmp_path, monkeypatch):
    """Entries written by the cache, then a user's files (the oldest, and one with an entry's
    name): the user's bytes neither count towards the bound nor go, however small the bound."""
    monkeypatch.setenv("PIEZOTIP_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PIEZOTIP_CACHE", raising=False)
    for k in range(3):
        disk_cached("t", k, lambda: {"v": np.zeros(1000)})
        os.utime(tmp_path / f"{entry_key('t', k)}.npz", ns=(10**10 * (k + 1),) * 2)
    mine = _user_files(tmp_path)
    own = sum(p.stat().st_size for p in _own_entries(tmp_path))
    assert len(_own_entries(tmp_path)) == 3 and own < 100_000 < (tmp_path / "mine.npz").stat().st_size
    assert cache_module.prune(tmp_path, own) == []  # the user's 300 kB do not count
    removed = cache_module.prune(tmp_path, 0)
    assert [p.name for p in removed] == [f"{entry_key('t', k)}.npz" for k in range(3)]  # oldest first, all of them
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == mine


def test_a_namespace_pruning_could_not_tell_from_a_key_is_refused():
    with pytest.raises(ValueError, match=r"cache namespace 'Mode_Table'"):
        entry_key("Mode_Table", 1)


# -- item 3: a journal line shaped like a row but missing its columns --------------------------------


def _full_point(scenario, overrides, preset, run_dir=None, options=None) -> dict:
    """A point's whole row at no cost (every column), its numbers from its overrides."""
    mass = float(overrides[-1].partition("=")[2])
    return error_row("") | {"outcome": "success", "reason": "lifted", "success": True, "max_pressure_pa": 1e4 * mass, "wall_time_s": 0.0}


SWEEP = ["sweep", "grasp", "--grid", "object.mass_kg=0.05,0.2,0.4", "--preset", "fast", "--workers", "0", "--json"]


def _damaged(row: dict, how: str) -> dict:
    if how == "only its outcome":  # the issue's: a row's shape, its columns gone
        return {"outcome": row["outcome"]}
    if how == "one column missing":
        return {k: v for k, v in row.items() if k != "max_pressure_pa"}
    return row | {"max_pressure_pa": "high", "success": "yes"}  # "wrong types"


@pytest.mark.parametrize("how", ["only its outcome", "one column missing", "wrong types"])
def test_a_resume_skips_a_row_missing_its_columns_with_a_warning_and_runs_its_point_again(tmp_path, monkeypatch, caplog, how):
    """``sweep`` run whole, its journal's second line damaged, run again: before, every resume
    exited 3 (``KeyError: 'max_pressure_pa'`` in the tables) until the line was removed by hand;
    now the line is skipped with a warning naming the file and line, that point alone runs
    again, the resume exits 0 and its rows are the whole sweep's."""
    out = tmp_path / "sweep"
    ran = []

    def counted(scenario, overrides, *args, **kwargs):
        ran.append(overrides[-1])
        return _full_point(scenario, overrides, *args, **kwargs)

    monkeypatch.setattr(sweep_module, "run_point", counted)
    assert cli.main([*SWEEP, "--out", str(out)]) == 0
    whole = json.loads((out / "sweep.json").read_text())["rows"]
    journal = out / "points.jsonl"
    lines = journal.read_text().splitlines()
    entry = json.loads(lines[1])
    lines[1] = json.dumps({"key": entry["key"], "row": _damaged(entry["row"], how)})
    journal.write_text("\n".join(lines) + "\n")
    ran.clear()
    with caplog.at_level(logging.WARNING, logger="piezotip.analysis.sweep"):
        assert cli.main([*SWEEP, "--out", str(out)]) == 0
    assert ran == ["object.mass_kg=0.2"]  # that point, and only that one, again
    warnings = [r.getMessage() for r in caplog.records if r.name == "piezotip.analysis.sweep"]
    assert len(warnings) == 1 and warnings[0].startswith(f"{journal}:2: skipped a line that is a row ")
    assert "its point runs again" in warnings[0]
    report = json.loads((out / "sweep.json").read_text())
    assert report["skipped_done"] == 2 and report["rows"] == whole
    ran.clear()
    assert cli.main([*SWEEP, "--out", str(out)]) == 0 and ran == []  # the row appended last is whole: done


# -- item 11 (a): a full disk says so ----------------------------------------------------------------

COLUMNS = [f"c{i:02d}_pa" for i in range(12)]


def _rows(n: int) -> list[list[float]]:
    return np.random.default_rng(3).standard_normal((n, len(COLUMNS))).tolist()


def test_a_short_write_of_a_chunk_says_the_disk_is_full_naming_the_file_and_bytes(tmp_path):
    """A real short write: the file size limit (RLIMIT_FSIZE, its signal ignored) makes the
    kernel take only the first 3000 bytes of chunk 0's 4928, as a full disk takes what room is
    left.  numpy's fwrite then raised only "600 requested and 359 written" (values, no file)."""
    pytest.importorskip("resource")
    code = f"""
import resource, signal
from piezotip.cosim.recorder import Recorder
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (3000, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
rec = Recorder({str(tmp_path / "run")!r}, flush_every=50)
for row in {_rows(50)!r}:
    rec.append_values(row, {COLUMNS!r})
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    last = proc.stderr.strip().splitlines()[-1]
    chunk = tmp_path / "run.chunks" / "chunk_000000.tmp.npy"
    assert last.startswith(f"OSError: [Errno {errno.ENOSPC}] {chunk}: disk full"), proc.stderr[-2000:]
    assert "the file system took 3000 of the 4928 bytes of chunk 000000" in last
    assert not chunk.exists()  # no torn temporary left


def _short_save(calls_before_full: int, room: int = 3000):
    """np.save as a full disk runs it: after ``calls_before_full`` whole files, it writes the
    first ``room`` bytes of the next and raises what numpy's fwrite raises for a short write (its
    counts are values: the issue's message)."""
    real = np.save
    calls = {"n": 0}

    def save(path, array, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] <= calls_before_full:
            return real(path, array, *args, **kwargs)
        Path(path).write_bytes(b"\x93NUMPY" + b"\0" * (room - 6))
        raise OSError("19500 requested and 17904 written")

    return save


def test_a_chunk_that_finds_the_disk_full_names_it_and_keeps_its_rows(tmp_path, monkeypatch):
    monkeypatch.setattr(recorder_module.np, "save", _short_save(1))
    rec = Recorder(tmp_path / "run", flush_every=50)
    rows = _rows(120)
    with pytest.raises(OSError) as caught:
        for row in rows:
            rec.append_values(row, COLUMNS)
    chunk = tmp_path / "run.chunks" / "chunk_000001.tmp.npy"
    message = str(caught.value)
    assert caught.value.errno == errno.ENOSPC and "disk full" in message and str(chunk) in message
    assert "the file system took 3000 of the 4928 bytes of chunk 000001" in message  # bytes, not numpy's count of values
    assert not chunk.exists() and len(rec) == 100
    monkeypatch.undo()  # room again: the close writes the rows kept pending
    rec.close()
    data, _ = read_recording(tmp_path / "run")
    np.testing.assert_array_equal(data["c04_pa"], np.asarray(rows)[:100, 4])


def test_a_grasp_that_fills_the_disk_exits_2_saying_so(tmp_path, monkeypatch, capsys):
    """The command line: exit 2 and one line saying the disk is full, naming the chunk and the bytes."""
    monkeypatch.setattr(recorder_module.np, "save", _short_save(0))
    out = tmp_path / "run"
    assert cli.main(["run", "grasp", "--preset", "fast", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith(f"error: [Errno {errno.ENOSPC}] {out / 'run.chunks' / 'chunk_000000.tmp.npy'}: disk full")
    assert "the file system took 3000 of the " in err and "bytes of chunk 000000" in err


# -- item 11 (b): a chunk torn under its final name ---------------------------------------------------


def _unclosed(stem: Path, n: int) -> np.ndarray:
    """A recording of ``n`` rows in chunks of 50, never closed (the machine went down)."""
    table = np.asarray(_rows(n))
    rec = Recorder(stem, flush_every=50)
    for row in table.tolist():
        rec.append_values(row, COLUMNS, owned=True)
    return table


@pytest.mark.parametrize("tear", ["half its bytes", "no bytes", "its header only", "garbage"])
def test_a_chunk_torn_under_its_final_name_ends_the_recording_there_and_is_named(tmp_path, caplog, tear):
    """A machine's crash can keep a chunk's rename but not its bytes.  Before, reading the
    recording raised (ValueError or EOFError from numpy) and nothing of it could be read; now
    the chunks before the torn one are the recording, and a warning names the torn one."""
    table = _unclosed(tmp_path / "run", 170)  # chunks 0-2 on disk
    path = tmp_path / "run.chunks" / "chunk_000001.npy"
    whole = path.read_bytes()
    torn = {"half its bytes": whole[: len(whole) // 2], "no bytes": b"", "its header only": whole[:128], "garbage": b"\0" * len(whole)}
    path.write_bytes(torn[tear])
    with caplog.at_level(logging.WARNING, logger=recorder_module.__name__):
        data, meta = read_recording(tmp_path / "run")
    np.testing.assert_array_equal(np.column_stack([data[c] for c in COLUMNS]), table[:50])
    assert list(data) == COLUMNS and meta == {}
    assert [r.getMessage().split(" (")[0] for r in caplog.records] == [f"{tmp_path / 'run.chunks'}: chunk 000001 is torn"]
    assert caplog.records[0].getMessage().endswith("; read the 1 chunks before it")


def test_a_torn_first_chunk_leaves_an_empty_recording_with_its_columns(tmp_path, caplog):
    _unclosed(tmp_path / "run", 120)
    (tmp_path / "run.chunks" / "chunk_000000.npy").write_bytes(b"\x93NUMPY\x01\x00v\x00{'descr'")
    data, _ = read_recording(tmp_path / "run")
    assert list(data) == COLUMNS and all(len(v) == 0 for v in data.values())
    assert "chunk 000000 is torn" in caplog.text


# -- item 11 (c): a <freejoint> in a gripper file -----------------------------------------------------


@pytest.mark.parametrize(
    ("joint", "named"), [("<freejoint/>", "a free joint"), ('<joint name="float" type="free"/>', "the free joint 'float'")]
)
def test_a_free_joint_in_a_gripper_file_is_named_in_that_file(tmp_path, joint, named):
    """Before: the file was taken, and the mounted scene's compile failed naming
    models/scene_grasp.xml ("mass and inertia of moving bodies ... 'palm'")."""
    path = tmp_path / "floating_hand.xml"
    path.write_text(SLIDE_GRIPPER.format(actuators=SERVOS.format(force=30)).replace('<body name="hand">', f'<body name="hand">{joint}'))
    message = rf"gripper.mjcf '{path}': body 'hand' has {named} \(<freejoint>\).*remove the free joint"
    with pytest.raises(ValueError, match=message):
        scenarios.get("grasp", keys(path), "fast")


def test_the_command_line_names_the_gripper_file_with_a_free_joint(tmp_path, capsys):
    path = tmp_path / "floating_hand.xml"
    path.write_text(SLIDE_GRIPPER.format(actuators=SERVOS.format(force=30)).replace('<body name="hand">', '<body name="hand"><freejoint/>'))
    sets = [f"--set={k}={v}" for k, v in keys(path).items()]
    assert cli.main(["run", "grasp", "--preset", "fast", *sets, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"gripper.mjcf '{path}'" in err and "free joint" in err and "scene_grasp" not in err


def test_a_gripper_that_does_not_compile_mounted_names_its_file(tmp_path, monkeypatch):
    """Whatever else fails once the file is mounted names the gripper's file first, then what
    MuJoCo said of the scene.  Here a drive's force range turned inside out as it is mounted (the
    free joint this test once switched its check off for is now the arm's: the mount deletes the
    mounted body's own joints, cosim/gripper_parts.py::_mounted_body)."""
    as_drive = gripper_mount._as_drive

    def misaimed(actuator, found):
        as_drive(actuator, found)
        actuator.forcerange = [found.force_max, -found.force_max]

    monkeypatch.setattr(gripper_mount, "_as_drive", misaimed)
    path = tmp_path / "hand.xml"
    path.write_text(SLIDE_GRIPPER.format(actuators=SERVOS.format(force=30)))
    with pytest.raises(ValueError, match=rf"^gripper.mjcf '{path}' does not mount in the scene: MJCF file .*scene_grasp.xml"):
        CoSimulation(scenarios.get("grasp", keys(path), "fast"))

"""The recorder keeps a complete prefix on disk, whatever stops the run."""

import csv
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from piezotip.cosim.recorder import Recorder, read_recording

ROOT = Path(__file__).resolve().parent.parent


def test_rows_round_trip_through_npz_and_csv(tmp_path):
    with Recorder(tmp_path / "run", csv=True, flush_every=3, metadata={"units": {"time_s": "s"}}) as rec:
        for i in range(10):
            rec.append({"time_s": i * 0.1, "left_pressure_pa": i * i})
    data = np.load(tmp_path / "run.npz")
    np.testing.assert_allclose(data["time_s"], np.arange(10) * 0.1)
    np.testing.assert_allclose(data["left_pressure_pa"], np.arange(10) ** 2)
    assert "units" in str(data["metadata_json"])
    rows = list(csv.reader((tmp_path / "run.csv").open()))
    assert rows[0] == ["time_s", "left_pressure_pa"]
    assert len(rows) == 11


def test_an_exception_mid_run_keeps_what_was_recorded(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with Recorder(tmp_path / "run", flush_every=1000) as rec:
            for i in range(7):
                rec.append({"time_s": float(i)})
            raise KeyboardInterrupt
    assert len(np.load(tmp_path / "run.npz")["time_s"]) == 7


def test_chunks_on_disk_before_close_each_written_once(tmp_path):
    rec = Recorder(tmp_path / "run", flush_every=4)
    for i in range(13):
        rec.append({"time_s": float(i)})
    # Three chunks of 4 are on disk although the recorder was never closed, readable as a
    # recording; no NPZ is rewritten per flush (the cost of a flush is its own rows).
    chunks = sorted((tmp_path / "run.chunks").glob("chunk_*.npy"))
    assert len(chunks) == 3 and len({c.stat().st_size for c in chunks}) == 1
    assert not (tmp_path / "run.npz").exists()
    data, _ = read_recording(tmp_path / "run")
    np.testing.assert_array_equal(data["time_s"], np.arange(12.0))
    rec.close()
    assert len(np.load(tmp_path / "run.npz")["time_s"]) == 13
    assert not (tmp_path / "run.chunks").exists()
    data, meta = read_recording(tmp_path / "run.npz")
    assert len(data["time_s"]) == 13 and meta == {}


def test_a_killed_writer_leaves_every_completed_chunk_readable(tmp_path):
    """SIGKILL: no Python cleanup runs; the chunks written before it are whole and readable."""
    script = (
        "import os, signal, sys\n"
        "from cosim.recorder import Recorder\n"
        "rec = Recorder(sys.argv[1], flush_every=10, metadata={'units': 's'})\n"
        "for i in range(35):\n"
        "    rec.append({'time_s': float(i), 'x_m': 2.0 * i})\n"
        "os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    proc = subprocess.run([sys.executable, "-c", script, str(tmp_path / "run")], cwd=ROOT, timeout=60)
    assert proc.returncode == -signal.SIGKILL
    data, meta = read_recording(tmp_path / "run")
    np.testing.assert_array_equal(data["time_s"], np.arange(30.0))
    np.testing.assert_array_equal(data["x_m"], 2.0 * np.arange(30.0))
    assert meta == {"units": "s"}


def test_reading_nothing_names_the_path(tmp_path):
    with pytest.raises(FileNotFoundError, match="no recording"):
        read_recording(tmp_path / "missing")


def test_rows_must_keep_their_columns(tmp_path):
    rec = Recorder(tmp_path / "run")
    rec.append({"a": 1.0})
    with pytest.raises(ValueError, match="columns"):
        rec.append({"b": 1.0})


def test_rows_from_reads_any_tail_across_chunks_as_data_does(tmp_path):
    """A live reader (a video's strip) reads only the rows since its last read: for every start,
    across flushed chunks and the pending one, they equal the whole recording's tail."""
    rec = Recorder(tmp_path / "run", flush_every=4)
    assert rec.rows_from(0) == {}
    for i in range(11):  # chunks of 4, 4 and 3 pending
        rec.append_values([float(i), float(i * i)], ["time_s", "x"])
        whole = rec.data()
        for start in range(i + 3):
            tail = rec.rows_from(start)
            for column in ("time_s", "x"):
                np.testing.assert_array_equal(tail[column], whole[column][start:])
    rec.close()

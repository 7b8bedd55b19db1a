"""The recorder keeps a complete prefix on disk, whatever stops the run."""

import csv

import numpy as np
import pytest

from cosim.recorder import Recorder


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


def test_checkpoint_on_disk_before_close(tmp_path):
    rec = Recorder(tmp_path / "run", flush_every=4)
    for i in range(9):
        rec.append({"time_s": float(i)})
    # Two chunks of 4 are on disk although the recorder was never closed.
    assert len(np.load(tmp_path / "run.npz")["time_s"]) == 8
    rec.close()
    assert len(np.load(tmp_path / "run.npz")["time_s"]) == 9


def test_rows_must_keep_their_columns(tmp_path):
    rec = Recorder(tmp_path / "run")
    rec.append({"a": 1.0})
    with pytest.raises(ValueError, match="columns"):
        rec.append({"b": 1.0})

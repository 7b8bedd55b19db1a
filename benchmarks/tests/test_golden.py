"""The golden record's running hashes: how far two records that differ still agree."""

from __future__ import annotations

import numpy as np

from benchmarks import golden


def _record(rows: int, changed_from: int | None = None, changed_rows: int | None = None) -> dict:
    """A stand-in record at 5 ms a row: phase 5 (place) for the first 110 rows, then 6
    (release); a column changed from row ``changed_from`` on (for ``changed_rows`` rows, or to
    the end)."""
    t = np.arange(1, rows + 1) * 0.005
    x = np.sin(t)
    if changed_from is not None:
        x[changed_from : None if changed_rows is None else changed_from + changed_rows] += 1.0
    return {"time_s": t, "phase": np.where(np.arange(rows) < 110, 5.0, 6.0), "x": x}


def test_a_record_shares_its_running_hashes_up_to_its_first_changed_row():
    """Rows 0-129 alike, a change at row 130 (t = 0.655 s): checkpoints every 20 rows (0.1 s)
    agree through t = 0.6 s and none after; a record ending sooner agrees to its last whole block."""
    before = golden.prefix_hashes(_record(400))
    assert len(before) == 20 and [b[0] for b in before[:2]] == [0.1, 0.2]
    assert golden.agreement(before, golden.prefix_hashes(_record(400))) == (2.0, 6)
    shared = golden.agreement(before, golden.prefix_hashes(_record(400, changed_from=130)))
    assert shared == (0.6, 6)
    # one row changed: the records agree again after it, row for row, but not from their start,
    # and every hash after it says so (a running hash, not one per block)
    one_row = golden.prefix_hashes(_record(400, changed_from=130, changed_rows=1))
    assert golden.agreement(before, one_row) == (0.6, 6)
    assert all(b[2] != a[2] for b, a in zip(before[6:], one_row[6:], strict=True))
    assert golden.agreement(before, golden.prefix_hashes(_record(250, changed_from=None))) == (1.2, 6)
    assert golden.agreement(before, golden.prefix_hashes(_record(400, changed_from=0))) is None


def test_compare_says_how_far_two_differing_runs_agree():
    def entry(record):
        return {"x": golden._sha(record["x"].tobytes()), "outcome": "success", "prefix": golden.prefix_hashes(record)}

    before = {"grasp fast {}": entry(_record(400)), "grasp balanced {}": entry(_record(400))}
    after = {"grasp fast {}": entry(_record(400, changed_from=130)), "grasp balanced {}": entry(_record(400))}
    (line,) = golden.differences(before, after)
    assert line == "grasp fast {}: 1 columns differ (x); they agree for their first 0.600 s (into the release phase)"
    after["grasp fast {}"] = entry(_record(400, changed_from=0))
    assert golden.differences(before, after)[0].endswith("; the records differ from their start")
    del before["grasp fast {}"]["prefix"]  # a file written before the running hashes: the columns only
    assert golden.differences(before, after)[0] == "grasp fast {}: 1 columns differ (x)"

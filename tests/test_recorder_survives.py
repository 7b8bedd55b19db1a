"""A recording that survives (issue 30): torn temporaries, a full disk, reruns into a used stem,
and a close that streams the chunks into run.npz one column at a time."""

import json
import pickle
import re
import tracemalloc
import zipfile

import numpy as np
import pytest

from piezotip.cosim import recorder as recorder_module
from piezotip.cosim.recorder import Recorder, read_recording

COLUMNS = [f"c{i:02d}_pa" for i in range(12)]


def _table(rows: int, width: int = len(COLUMNS)) -> np.ndarray:
    return np.random.default_rng(7).standard_normal((rows, width))


def _record(stem, table, flush_every=50, **kwargs) -> Recorder:
    rec = Recorder(stem, flush_every=flush_every, **kwargs)
    for row in table.tolist():
        rec.append_values(row, COLUMNS[: table.shape[1]], owned=True)
    return rec


def test_a_torn_temporary_chunk_is_not_read(tmp_path):
    """A kill (or a full disk) in the middle of writing chunk 3 leaves chunk_000003.tmp.npy, half
    written: the completed chunks are the recording, the torn one is not read."""
    table = _table(170)
    _record(tmp_path / "run", table)  # chunks 0-2 on disk, 20 rows pending, never closed
    (tmp_path / "run.chunks" / "chunk_000003.tmp.npy").write_bytes(b"\x93NUMPY\x01\x00v\x00{'descr': '<f8', 'fortr")
    data, _ = read_recording(tmp_path / "run")
    np.testing.assert_array_equal(np.column_stack([data[c] for c in COLUMNS]), table[:150])


def test_reading_stops_at_a_missing_chunk(tmp_path, caplog):
    table = _table(200)
    _record(tmp_path / "run", table)
    (tmp_path / "run.chunks" / "chunk_000002.npy").unlink()
    data, _ = read_recording(tmp_path / "run")
    np.testing.assert_array_equal(data["c00_pa"], table[:100, 0])
    assert "chunk 000002 is missing" in caplog.text


def test_a_flush_that_fails_leaves_no_temporary_and_loses_no_row(tmp_path, monkeypatch):
    """A full disk while a chunk is written: the error reaches the caller, no torn temporary is
    left, the rows stay pending, and a later flush (the close) writes them."""
    real_save = np.save
    calls = {"n": 0}

    def disk_full_once(path, array, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 2:
            with open(path, "wb") as fh:
                fh.write(b"\x93NUMPY half")
            raise OSError(28, "No space left on device")
        return real_save(path, array, *args, **kwargs)

    monkeypatch.setattr(recorder_module.np, "save", disk_full_once)
    table = _table(120)
    rec = Recorder(tmp_path / "run", flush_every=50)
    with pytest.raises(OSError, match="No space"):
        for row in table.tolist():
            rec.append_values(row, COLUMNS, owned=True)
    assert sorted(p.name for p in (tmp_path / "run.chunks").iterdir()) == ["chunk_000000.npy", "meta.json"]
    assert len(rec) == 100
    rec.close()
    data = np.load(tmp_path / "run.npz")
    np.testing.assert_array_equal(data["c03_pa"], table[:100, 3])


def test_the_streamed_npz_is_the_one_np_savez_writes(tmp_path):
    """Same members in the same order, each the same bytes (so the same keys, dtypes, values)."""
    table = _table(1234)
    meta = {"units": "in names", "scenario": "grasp"}
    _record(tmp_path / "run", table, flush_every=100, metadata=meta).close()
    np.savez(tmp_path / "ref.npz", metadata_json=np.array(json.dumps(meta)), **{c: table[:, i] for i, c in enumerate(COLUMNS)})
    with zipfile.ZipFile(tmp_path / "run.npz") as ours, zipfile.ZipFile(tmp_path / "ref.npz") as ref:
        assert ours.namelist() == ref.namelist()
        for name in ref.namelist():
            assert ours.read(name) == ref.read(name), name
        assert [(i.compress_type, i.file_size) for i in ours.infolist()] == [(i.compress_type, i.file_size) for i in ref.infolist()]
    with np.load(tmp_path / "run.npz") as ours, np.load(tmp_path / "ref.npz") as ref:
        for key in ref.files:
            assert ours[key].dtype == ref[key].dtype
            np.testing.assert_array_equal(ours[key], ref[key])


def test_memory_held_is_one_chunk_while_recording_and_one_column_while_closing(tmp_path):
    """The recording's cost in memory does not grow with its length: the chunks on disk are not
    kept, and the close holds one column at a time, never the whole table."""
    rows, width = 20_000, len(COLUMNS)
    table_bytes = rows * width * 8
    column_bytes = rows * 8
    rec = Recorder(tmp_path / "run", flush_every=500)
    values = _table(rows).tolist()
    tracemalloc.start()
    try:
        start, _ = tracemalloc.get_traced_memory()
        for row in values:
            rec.append_values(row, COLUMNS)
        held, _ = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        rec.close()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert held - start < table_bytes / 8, (held - start, table_bytes)
    assert peak - held < 3 * column_bytes, (peak - held, column_bytes)


def test_after_close_data_reads_columns_from_the_npz_and_pickles_as_a_dict(tmp_path):
    table = _table(300)
    rec = _record(tmp_path / "run", table)
    rec.close()
    data = rec.data()
    assert list(data) == COLUMNS and "c01_pa" in data and "metadata_json" not in data and len(data) == len(COLUMNS)
    np.testing.assert_array_equal(data["c05_pa"], table[:, 5])
    with pytest.raises(KeyError):
        data["metadata_json"]
    np.testing.assert_array_equal(rec.rows_from(290)["c02_pa"], table[290:, 2])
    copy = pickle.loads(pickle.dumps(data))
    assert type(copy) is dict and copy.keys() == data.keys()
    (tmp_path / "run.npz").unlink()  # a run in a temporary folder: still readable (POSIX)
    np.testing.assert_array_equal(data["c11_pa"], table[:, 11])


def test_a_new_recording_removes_only_a_recordings_own_files(tmp_path):
    """A rerun into a stem a killed run left (chunks, a torn temporary, a stale NPZ and CSV)
    removes them by name and leaves nothing of the old run behind."""
    _record(tmp_path / "run", _table(170), csv=True)
    (tmp_path / "run.chunks" / "chunk_000009.tmp.npy").write_bytes(b"torn")
    (tmp_path / "run.npz").write_bytes(b"old")
    (tmp_path / "run.tmp.npz").write_bytes(b"old")
    (tmp_path / "notes.txt").write_text("mine")  # beside the recording: not the recorder's
    table = _table(30)
    _record(tmp_path / "run", table).close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt", "run.npz"]
    data, _ = read_recording(tmp_path / "run")
    np.testing.assert_array_equal(data["c00_pa"], table[:, 0])


@pytest.mark.parametrize("intruder", ["notes.txt", "chunk_1.npy", "subfolder"])
def test_a_file_no_recording_wrote_in_the_chunks_folder_stops_a_new_recording_before_it_removes_anything(tmp_path, intruder):
    """Chosen: refuse (FileExistsError naming the file), not delete it and not record beside it."""
    _record(tmp_path / "run", _table(120))
    chunks = tmp_path / "run.chunks"
    if intruder == "subfolder":
        (chunks / intruder).mkdir()
    else:
        (chunks / intruder).write_text("someone's")
    before = sorted(p.name for p in chunks.iterdir())
    with pytest.raises(FileExistsError, match=re.escape(intruder)):
        Recorder(tmp_path / "run")
    assert sorted(p.name for p in chunks.iterdir()) == before  # nothing removed, the old chunks included
    data, _ = read_recording(tmp_path / "run")
    assert len(data["c00_pa"]) == 100


def test_a_file_that_appears_in_the_chunks_folder_during_a_run_stays(tmp_path, caplog):
    rec = _record(tmp_path / "run", _table(120))
    (tmp_path / "run.chunks" / "notes.txt").write_text("someone's")
    rec.close()
    assert sorted(p.name for p in (tmp_path / "run.chunks").iterdir()) == ["notes.txt"]
    assert len(np.load(tmp_path / "run.npz")["c00_pa"]) == 120
    assert "holds files no recording wrote" in caplog.text


class _Interrupt(KeyboardInterrupt):
    """The test's Ctrl-C, raised by a tracer where a signal's handler could raise one."""


def _interrupt_at(step: int, codes: frozenset):
    """A tracer that raises :class:`_Interrupt` at the ``step``-th opcode run in a frame of one of
    ``codes`` (counted over them all), as a signal's handler could at any of Python's steps; it
    returns how many it saw, so a caller knows when ``step`` ran past the end."""
    seen = [0]

    def trace(frame, event, arg):
        if frame.f_code not in codes:
            return None
        frame.f_trace_opcodes = True

        def local(frame, event, arg):
            if event == "opcode":
                seen[0] += 1
                if seen[0] == step:
                    raise _Interrupt
            return local

        return local

    return trace, seen


@pytest.mark.parametrize("csv", [False, True])
def test_an_interrupt_at_any_step_of_a_flush_loses_no_row_and_doubles_none(tmp_path, csv):
    """A Ctrl-C between any two opcodes of ``flush`` (and of its CSV's append): the rows the
    recorder counts (``len``) are in the NPZ after the close, each once, in order, and the CSV
    is the same rows.  Before: a Ctrl-C just after the chunk's rename (where the handler runs,
    at the next call, ``len(chunk)``) lost its 50 rows; the loop's test saw a run of 1000 rows
    read back as 500 (test_interrupts, under load)."""
    import sys

    codes = frozenset(getattr(Recorder, name).__code__ for name in ("flush", "_append_csv") if hasattr(Recorder, name))
    table = _table(130)
    step, cases = 1, 0
    while True:
        stem = tmp_path / f"s{step}" / "run"
        rec = _record(stem, table, flush_every=50, csv=csv)  # two chunks on disk, 30 rows pending
        trace, seen = _interrupt_at(step, codes)
        sys.settrace(trace)
        try:
            rec.flush()
        except _Interrupt:
            pass
        finally:
            sys.settrace(None)
        if seen[0] < step:  # the flush ran whole: every step has been interrupted once
            break
        counted = len(rec)
        rec.append_values(table[counted].tolist() if counted < len(table) else table[0].tolist(), COLUMNS)
        rec.close()
        expected = np.vstack([table[:counted], (table[counted] if counted < len(table) else table[0])[None]])
        data, _ = read_recording(stem)
        got = np.column_stack([data[c] for c in COLUMNS])
        np.testing.assert_array_equal(got, expected, err_msg=f"interrupted at opcode {step} of the flush")
        if csv:
            np.testing.assert_array_equal(np.loadtxt(stem.with_suffix(".csv"), delimiter=",", skiprows=1), expected)
            assert stem.with_suffix(".csv").read_text().splitlines()[0] == ",".join(COLUMNS)
        assert not list(stem.with_suffix(".chunks").parent.glob("*.tmp*"))
        step, cases = step + 1, cases + 1
    assert cases > 40  # the tracer saw the flush's steps (a tracer that never fires would pass vacuously)

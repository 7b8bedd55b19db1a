"""A sweep journal that loses nothing (issue 30): every row on a line of its own, every line that
is not a row skipped with a warning naming the file and line, and a resumed sweep, whatever
was torn or written into its journal, with exactly the rows of an uninterrupted one."""

import math

import pytest

from piezotip.analysis import sweep as sweep_module
from piezotip.analysis import sweep_cluster
from piezotip.analysis.sweep import run_points
from piezotip.analysis.sweep_grid import grid_points
from piezotip.analysis.sweep_rows import error_row

#: A short, cheap scenario: the fast preset, the grasp cut at 3 s (as tests/test_sweep.py).
SHORT = ("duration_s=3.0",)

LOGGER = "piezotip.analysis.sweep"


@pytest.fixture(autouse=True)
def _spawned_workers_unless_started(monkeypatch):
    monkeypatch.setattr(sweep_cluster, "_worker_server", False)


def _comparable(rows: list[dict]) -> list[dict]:
    """Rows without what depends on the machine (time, process), NaN made comparable."""

    def same(v):
        return "nan" if isinstance(v, float) and math.isnan(v) else v

    return [{k: same(v) for k, v in r.items() if k not in ("wall_time_s", "pid")} for r in rows]


def _fake_point(scenario, overrides, preset, run_dir=None, options=None) -> dict:
    """A point's row at no cost, every column a row has (a resume takes no less): its numbers from its overrides."""
    mass = float(overrides[-1].partition("=")[2])
    return error_row("") | {"outcome": "success", "reason": "lifted", "success": True, "max_pressure_pa": 1e4 * mass, "wall_time_s": 0.0}


def _never(*args, **kwargs):
    raise AssertionError("a done point ran again")


POINTS = grid_points({"object.mass_kg": ["0.05", "0.2", "0.4"]}, SHORT)


def _journal_of_the_whole_sweep(tmp_path, monkeypatch) -> tuple[list[dict], list[bytes]]:
    monkeypatch.setattr(sweep_module, "run_point", _fake_point)
    whole = run_points("grasp", POINTS, "fast", tmp_path / "whole", workers=0, progress=False)
    return whole.rows, (tmp_path / "whole" / "points.jsonl").read_bytes().splitlines(keepends=True)


def _resume(out, monkeypatch, runner=_never):
    monkeypatch.setattr(sweep_module, "run_point", runner)
    return run_points("grasp", POINTS, "fast", out, workers=0, progress=False)


def test_a_row_appended_after_a_torn_line_starts_a_line_of_its_own(tmp_path, monkeypatch):
    """A kill tore the last row: the resume runs its point again, and that row must not be
    appended onto the fragment (the next resume would lose it and run the point a third time)."""
    rows, lines = _journal_of_the_whole_sweep(tmp_path, monkeypatch)
    out = tmp_path / "resumed"
    out.mkdir()
    (out / "points.jsonl").write_bytes(lines[0] + lines[1] + lines[2][:40])  # no newline: torn
    again = _resume(out, monkeypatch, _fake_point)
    assert again.skipped == 2 and _comparable(again.rows) == _comparable(rows)
    last = _resume(out, monkeypatch)  # before: the third row lost in the torn line, run again
    assert last.skipped == 3 and _comparable(last.rows) == _comparable(rows)


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        (b"\xff\xfe\x00garbage", "not UTF-8"),  # before: UnicodeDecodeError, naming no file
        (b"[1, 2]", "not a row"),  # before: AttributeError
        (b'"a string"', "not a row"),
        (b"null", "not a row"),
        (b'{"key": 5, "row": {}}', "not a row"),
        (b'{"row": {"outcome": "success"}}', "not a row"),  # before: KeyError
        (b'{"key": "k", "row": "success"}', "not a row"),
        (b"{not json at all", "not JSON"),  # before: skipped without a word
        (b'{"key": "k", "ro', "not JSON"),
    ],
)
def test_a_line_that_is_not_a_row_is_skipped_with_a_warning_naming_file_and_line(tmp_path, monkeypatch, caplog, line, problem):
    rows, lines = _journal_of_the_whole_sweep(tmp_path, monkeypatch)
    out = tmp_path / "resumed"
    out.mkdir()
    (out / "points.jsonl").write_bytes(lines[0] + line + b"\n" + lines[1] + lines[2])
    with caplog.at_level("WARNING", logger=LOGGER):
        again = _resume(out, monkeypatch)
    assert again.skipped == 3 and _comparable(again.rows) == _comparable(rows)
    warnings = [r.getMessage() for r in caplog.records if r.name == LOGGER]
    assert len(warnings) == 1 and warnings[0].startswith(f"{out / 'points.jsonl'}:2: skipped a line that is ") and problem in warnings[0]


def test_a_torn_last_line_is_named_torn(tmp_path, monkeypatch, caplog):
    _, lines = _journal_of_the_whole_sweep(tmp_path, monkeypatch)
    out = tmp_path / "resumed"
    out.mkdir()
    (out / "points.jsonl").write_bytes(lines[0] + lines[1] + lines[2][:30])
    with caplog.at_level("WARNING", logger=LOGGER):
        again = _resume(out, monkeypatch, _fake_point)
    assert again.skipped == 2
    expected = f"{out / 'points.jsonl'}:3: skipped a line that is not JSON (torn: the file ends inside it)"
    assert [r.getMessage() for r in caplog.records if r.name == LOGGER] == [expected]


def test_a_real_sweep_resumed_after_many_torn_and_garbage_lines_has_the_uninterrupted_rows(tmp_path, monkeypatch, caplog):
    """Three points of the fast grasp, run whole once; then a journal holding the first row, all
    sorts of damage and the second row torn, resumed, torn again, resumed: each time the rows are
    the uninterrupted sweep's, and the last resume runs nothing."""
    whole = run_points("grasp", POINTS, "fast", tmp_path / "whole", workers=0, progress=False)
    lines = (tmp_path / "whole" / "points.jsonl").read_bytes().splitlines(keepends=True)
    assert len(lines) == 3
    out = tmp_path / "resumed"
    out.mkdir()
    journal = out / "points.jsonl"
    damage = b"garbage\n\xc3\x28 not utf-8\n[1, 2]\n{}\n\n" + b'{"key": "x", "row": 3}\n'
    journal.write_bytes(lines[0] + damage + lines[1][: len(lines[1]) // 2])  # the second row torn
    with caplog.at_level("WARNING", logger=LOGGER):
        first = run_points("grasp", POINTS, "fast", out, workers=0, progress=False)
    assert first.skipped == 1 and _comparable(first.rows) == _comparable(whole.rows)
    assert sum(str(journal) in r.getMessage() for r in caplog.records) == 6
    # Torn again (the last row half written), and a fragment of garbage with no newline after it.
    text = journal.read_bytes()
    journal.write_bytes(text[: len(text) - len(text.splitlines(keepends=True)[-1]) // 2])
    second = run_points("grasp", POINTS, "fast", out, workers=0, progress=False)
    assert second.skipped == 2 and _comparable(second.rows) == _comparable(whole.rows)
    with journal.open("ab") as fh:
        fh.write(b'{"key": "half')
    last = _resume(out, monkeypatch)
    assert last.skipped == 3 and _comparable(last.rows) == _comparable(whole.rows)


def test_a_point_cut_by_ctrl_c_is_not_journaled_and_the_sweep_stops(tmp_path, monkeypatch):
    """One point after the other (workers=0), a Ctrl-C in the second point's run: the run ends
    as interrupted, and that is no row: before, it was journaled (resume then skipped it with a
    wrong row) and the sweep went on to the third point."""
    from piezotip.cosim.loop import CoSimulation

    whole = run_points("grasp", POINTS, "fast", tmp_path / "whole", workers=0, progress=False)
    advance, calls = CoSimulation.advance, {"runs": 0}
    init = CoSimulation.__init__

    def count_runs(self, *args, **kwargs):
        calls["runs"] += 1
        init(self, *args, **kwargs)

    def ctrl_c_in_the_second_run(self):
        if calls["runs"] == 2 and self.steps == 40:
            raise KeyboardInterrupt
        return advance(self)

    monkeypatch.setattr(CoSimulation, "__init__", count_runs)
    monkeypatch.setattr(CoSimulation, "advance", ctrl_c_in_the_second_run)
    out = tmp_path / "cut"
    with pytest.raises(KeyboardInterrupt):
        run_points("grasp", POINTS, "fast", out, workers=0, progress=False)
    assert calls["runs"] == 2 and len((out / "points.jsonl").read_bytes().splitlines()) == 1
    monkeypatch.undo()
    monkeypatch.setattr(sweep_cluster, "_worker_server", False)
    resumed = run_points("grasp", POINTS, "fast", out, workers=0, progress=False)
    assert resumed.skipped == 1 and _comparable(resumed.rows) == _comparable(whole.rows)

"""benchmarks/revisions.py: a benchmark of this checkout run against git revisions, and every
benchmark runnable by module and by file from the repository's root."""

import io
import subprocess
import sys

import pytest

from benchmarks import revisions

ROOT = revisions.REPO


def _git(*args: str) -> str:
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, check=True).stdout.strip()


def _has_history(commits: int) -> bool:
    proc = subprocess.run(["git", "-C", str(ROOT), "rev-list", "--count", "HEAD"], capture_output=True, text=True)
    return proc.returncode == 0 and int(proc.stdout or 0) >= commits


needs_history = pytest.mark.skipif(not _has_history(3), reason="needs a git checkout of piezotip with history")


@needs_history
def test_a_range_is_its_commits_oldest_first():
    head, one, two = _git("rev-parse", "HEAD"), _git("rev-parse", "HEAD~1"), _git("rev-parse", "HEAD~2")
    assert revisions.expand_revisions(["HEAD~2..HEAD"]) == [one, head]
    assert revisions.expand_revisions(["HEAD~2", "HEAD~2..HEAD~1"]) == [two, one]
    with pytest.raises(ValueError, match="no commit"):
        revisions.expand_revisions(["HEAD..HEAD~1"])
    with pytest.raises(ValueError, match="no-such-revision"):
        revisions.expand_revisions(["no-such-revision..HEAD"])


@needs_history
def test_a_benchmark_runs_against_a_revisions_code(tmp_path):
    """This checkout's stages benchmark against HEAD's package (its Python references): its
    output under a line naming the commit; a failing run is counted, not raised."""
    out = io.StringIO()
    args = ["--duration", "0.02", "--repeats", "1", "--set", "controller.kind=scripted"]
    assert revisions.run_at_revisions([_git("rev-parse", "HEAD")], "stages", args, build=False, out=out) == 0
    text = out.getvalue()
    assert text.startswith(f"== {_git('rev-parse', '--short', 'HEAD')} ") and "stages of one control step" in text
    out = io.StringIO()
    assert revisions.run_at_revisions([_git("rev-parse", "HEAD")], "stages", ["--repeats", "0"], build=False, out=out) == 1
    assert "error: stages failed" in out.getvalue()


def test_the_command_needs_a_known_benchmark_after_the_separator(capsys):
    for argv in (["HEAD"], ["HEAD", "--", "nope"], ["--", "stages"]):
        with pytest.raises(SystemExit) as stop:
            revisions.main(argv)
        assert stop.value.code == 2
    assert "stages, throughput" in capsys.readouterr().err


@pytest.mark.parametrize("name", [*revisions.BENCHMARKS, "revisions"])
def test_each_benchmark_runs_as_a_module_and_as_a_file(name):
    """From the repository's root, as the README says (--help: its imports and its parser)."""
    for how in (["-m", f"benchmarks.{name}"], [f"benchmarks/{name}.py"]):
        proc = subprocess.run([sys.executable, *how, "--help"], cwd=ROOT, capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        assert "usage:" in proc.stdout

"""Run a benchmark against git revisions of this repository: the benchmark's code from this
checkout, the measured ``piezotip`` from each revision (as asv does).

    python -m benchmarks.revisions REV [REV ...] [--pure-python] -- NAME [ARGS ...]

Each REV is a revision (``HEAD~3``, a commit id, a tag) or a range ``A..B`` (the commits after A
up to B, oldest first, as ``git rev-list --reverse A..B`` lists them).  For each commit, the
revision's files are extracted into a temporary folder (``git archive``) and installed there by
pip, its compiled twins built as a user's install builds them (about a minute a revision;
``--pure-python`` skips the build: the revision is laid out in links and runs its Python
references, ``PIEZOTIP_PURE_PYTHON=1``), see :func:`revision_tree`; its bytecode is compiled
(:func:`compile_bytecode`), and then this checkout's ``benchmarks/NAME.py ARGS`` runs with
``PYTHONPATH`` pointing at the revision's install, so that every ``import piezotip`` finds the
revision's code and none finds this checkout's.  Each run's output is printed after a line naming its commit.

A benchmark needs the API it calls to exist at the revision (``stages`` needs
``CoSimulation.wrap_stages``, for instance): a revision older than that fails with the
benchmark's own error, and the next one runs.  Nothing here changes the working tree, the index
or the installed environment.
"""

from __future__ import annotations

import argparse
import compileall
import importlib
import io
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
import tomllib
from pathlib import Path

#: The repository this code runs from (the checkout holding benchmarks/).
REPO = Path(__file__).resolve().parents[1]
#: The benchmarks runnable by name (``benchmarks/NAME.py``).
BENCHMARKS = ("stages", "throughput", "instructions", "gym_throughput")


def resolve_revision(rev: str, repo: Path = REPO) -> str:
    """The full commit id of revision ``rev`` of the git repository ``repo``; ValueError naming
    ``rev`` when it is not one.  A revision is never handed to git where it could be read as an
    option (``--output=F`` would make ``git archive`` write a file): one that starts with "-" is
    refused, and the rest are resolved after ``--end-of-options`` to a commit id, which is what
    the other git commands get."""
    if not rev or rev.startswith("-") or any(ch in rev for ch in "\0\n"):
        raise ValueError(f"{rev!r} is not a revision (a revision does not start with '-')")
    proc = subprocess.run(
        ["git", "-C", str(repo), "rev-parse", "--verify", "--quiet", "--end-of-options", f"{rev}^{{commit}}"],
        capture_output=True,
        text=True,
    )
    commit = proc.stdout.strip()
    if proc.returncode != 0 or len(commit) < 40:
        raise ValueError(f"{rev!r} is not a revision of the git repository at {repo}")
    return commit


def expand_revisions(revs: list[str], repo: Path = REPO) -> list[str]:
    """The commit ids that ``revs`` name, in order: a revision is its commit, a range ``A..B``
    the commits after A up to B, oldest first.  ValueError naming a revision git does not know,
    or a range with no commit in it."""
    commits: list[str] = []
    for rev in revs:
        if ".." not in rev:
            commits.append(resolve_revision(rev, repo))
            continue
        start, _, end = rev.partition("..")
        first, last = resolve_revision(start, repo), resolve_revision(end or "HEAD", repo)
        proc = subprocess.run(
            ["git", "-C", str(repo), "rev-list", "--reverse", f"{first}..{last}"], capture_output=True, text=True, check=True
        )
        listed = proc.stdout.split()
        if not listed:
            raise ValueError(f"{rev}: no commit after {start} up to {end or 'HEAD'}")
        commits += listed
    return commits


def revision_tree(rev: str, work: Path, repo: Path = REPO, build: bool = False) -> tuple[Path, dict[str, str]]:
    """Revision ``rev`` of the git repository ``repo``, ready to run: (the folder to run its
    ``run_sim.py`` from, the environment variables to run it with).

    The revision's files are extracted (``git archive``) into ``work``.  Without ``build``,
    where its pyproject maps packages to folders (``[tool.setuptools.package-dir]``, e.g.
    ``piezotip.sensor`` = ``sensor/``), a folder of symbolic links lays them out as an install
    would (:func:`_lay_out`), and ``run_sim.py`` runs from there, so that every import finds the
    revision's code and none finds this checkout's; its compiled twins are not built (an
    archive has their ``.pyx``, no extension): it runs with ``PIEZOTIP_PURE_PYTHON=1``, its
    Python references, since an import of an extension it lacks would otherwise find this
    checkout's, built for other code (the editable install's finder maps every ``piezotip.*``
    name here).  With ``build``, pip installs the revision into a folder of its own instead,
    its twins built as a user's install builds them (about a minute; pip fetches the build's
    own requirements, setuptools and Cython, as any install does).  A revision from before the
    twins (such as 2147039) runs as it did.  Raises ValueError naming ``rev`` when git cannot
    produce it, and RuntimeError when pip cannot install it.
    """
    commit = resolve_revision(rev, repo)
    proc = subprocess.run(["git", "-C", str(repo), "archive", "--format=tar", commit], capture_output=True)
    if proc.returncode != 0:
        raise ValueError(f"{rev!r}: git could not archive it from the repository at {repo} ({proc.stderr.decode().strip()})")
    tree = work / f"rev-{rev.replace('/', '_')}"
    tree.mkdir(parents=True)
    with tarfile.open(fileobj=io.BytesIO(proc.stdout)) as tar:
        tar.extractall(tree, filter="data")
    built = build and (tree / "pyproject.toml").exists()
    if built:
        run_from = work / f"{tree.name}-installed"
        _install(tree, run_from, rev)
    else:
        run_from = _lay_out(tree, work / f"{tree.name}-installed")
    if run_from != tree:
        # A copy, not a link: Python puts a script's folder first on sys.path with its links
        # resolved, and the extracted tree's piezotip/ (no subpackages in it) would shadow the
        # layout, its subpackages then found by this checkout's editable install.
        shutil.copy2(tree / "run_sim.py", run_from / "run_sim.py")
    env = {**os.environ, "PYTHONPATH": str(run_from), "MPLBACKEND": "Agg", "PIEZOTIP_CACHE_DIR": str(work / "cache")}
    env.pop("PIEZOTIP_PURE_PYTHON", None)
    if not built:
        env["PIEZOTIP_PURE_PYTHON"] = "1"
    return run_from, env


def _install(tree: Path, target: Path, rev: str) -> None:
    """The revision in ``tree`` installed into the folder ``target`` as a user's install lays it
    out (pip builds a wheel: its compiled twins built, its package-data included), without
    its dependencies (this environment's serve)."""
    cmd = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target), str(tree)]
    made = subprocess.run(cmd, capture_output=True, text=True)
    if made.returncode != 0:
        raise RuntimeError(f"{rev}: pip could not install it ({made.stderr.strip()[-500:]})")


def _lay_out(tree: Path, run_from: Path) -> Path:
    """The revision in ``tree`` laid out as its pyproject installs it, in symbolic links under
    ``run_from`` (``[tool.setuptools.package-dir]``: ``piezotip.sensor`` = ``sensor/``, ...);
    ``tree`` itself where it maps no folders."""
    mapping = {}
    if (tree / "pyproject.toml").exists():
        config = tomllib.loads((tree / "pyproject.toml").read_text())
        mapping = config.get("tool", {}).get("setuptools", {}).get("package-dir", {})
    if not mapping:
        return tree
    for package, folder in sorted(mapping.items(), key=lambda item: item[0].count(".")):
        target = run_from.joinpath(*package.split("."))
        target.mkdir(parents=True, exist_ok=True)
        for entry in (tree / folder).iterdir():
            if not (target / entry.name).exists():
                (target / entry.name).symlink_to(entry)
    return run_from


def compile_bytecode(*folders: Path) -> bool:
    """Compile the Python modules under ``folders`` into their ``__pycache__`` (what an import
    writes by default, and reads even under ``PYTHONDONTWRITEBYTECODE``); whether all compiled
    (a module that does not is compiled by each import, as before).  A folder reached through a
    symbolic link is compiled where it lies: give that folder too (compileall does not follow
    linked folders; linked files it compiles).

    Where ``PYTHONDONTWRITEBYTECODE`` is set (this project's own sandbox sets it), every process
    would otherwise compile the project's modules again (about 0.12 s a process), a cost no user
    with Python's defaults pays twice: a benchmark that times or counts whole processes compiles
    first."""
    return all([compileall.compile_dir(str(folder), quiet=2, workers=1) for folder in folders])


#: The installed package's modules whose folders hold its Python source (pyproject's package-dir).
SOURCE_PACKAGES = ("piezotip", "piezotip.sensor", "piezotip.cosim", "piezotip.scenarios", "piezotip.analysis")


def source_folders() -> list[Path]:
    """The folders of the ``piezotip`` this process imports: this checkout's under its editable
    install, a revision's under :func:`revision_tree`'s ``PYTHONPATH``."""
    return [Path(importlib.import_module(name).__file__).parent for name in SOURCE_PACKAGES]


def run_at_revisions(commits: list[str], name: str, args: list[str], build: bool = True, out=sys.stdout) -> int:
    """``benchmarks/NAME.py ARGS`` against each commit (the module docstring); how many failed."""
    script = REPO / "benchmarks" / f"{name}.py"
    failed = 0
    with tempfile.TemporaryDirectory(prefix="piezotip-revisions-") as tmp:
        for k, commit in enumerate(commits):
            work = Path(tmp) / str(k)
            subject = subprocess.run(
                ["git", "-C", str(REPO), "log", "-1", "--format=%h %s", commit], capture_output=True, text=True, check=True
            ).stdout.strip()
            print(f"== {subject[:100]}", file=out, flush=True)
            try:
                run_from, env = revision_tree(commit, work, build=build)
            except RuntimeError as err:
                print(f"error: {err}", file=out, flush=True)
                failed += 1
                continue
            compile_bytecode(work)  # its tree and its installed layout
            proc = subprocess.run([sys.executable, str(script), *args], cwd=run_from, env=env, capture_output=True, text=True)
            print(proc.stdout, end="", file=out, flush=True)
            if proc.returncode != 0:
                print(f"error: {name} failed at {commit[:12]} ({proc.returncode}): {proc.stderr.strip()[-500:]}", file=out, flush=True)
                failed += 1
    return failed


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if "--" not in argv:
        argv = [*argv, "--"]  # argparse then reports what is missing
    split = argv.index("--")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], usage="%(prog)s REV [REV ...] [--pure-python] -- NAME [ARGS ...]")
    parser.add_argument("revisions", nargs="+", metavar="REV", help="a revision, or a range A..B (the commits after A up to B)")
    parser.add_argument("--pure-python", action="store_true", help="do not build the revisions' compiled twins: run the references")
    args = parser.parse_args(argv[:split])
    rest = argv[split + 1 :]
    if not rest or rest[0] not in BENCHMARKS:
        parser.error(f"after '--': a benchmark name, one of {', '.join(BENCHMARKS)}, then its arguments")
    try:
        commits = expand_revisions(args.revisions)
    except ValueError as err:
        parser.error(str(err))
    return 1 if run_at_revisions(commits, rest[0], rest[1:], build=not args.pure_python) else 0


if __name__ == "__main__":
    raise SystemExit(main())

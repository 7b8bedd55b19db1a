"""Results record what made them (issue 30): the versions of piezotip and its numerical
libraries, Python's, and the git commit when run from a checkout."""

import json
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np

from piezotip import provenance
from piezotip.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_versions_name_the_installed_libraries_and_this_checkouts_commit():
    v = provenance.versions()
    assert v["mujoco"] == mujoco.__version__ and v["numpy"] == np.__version__
    assert v["python"] == ".".join(map(str, sys.version_info[:3]))
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    if head:  # run from a checkout (CI's clone is one)
        assert v["git_commit"].removesuffix("-dirty") == head


def test_outside_a_checkout_there_is_no_commit(tmp_path):
    assert provenance.git_commit(str(tmp_path)) is None


def test_summary_json_and_run_json_record_the_versions(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["run", "grasp", "--preset", "fast", "--set", "duration_s=0.2", "--no-plot", "--json", "--out", str(out)])
    assert code in (0, 1)
    printed = json.loads(capsys.readouterr().out)
    written = json.loads((out / "summary.json").read_text())
    assert printed["versions"] == written["versions"] == json.loads(json.dumps(provenance.versions()))


def test_sweep_json_records_the_versions(tmp_path, capsys):
    out = tmp_path / "sweep"
    argv = ["sweep", "grasp", "--grid", "object.mass_kg=0.05", "--preset", "fast", "--set", "duration_s=0.2"]
    code = main([*argv, "--workers", "0", "--no-plot", "--out", str(out)])
    assert code in (0, 1)
    assert json.loads((out / "sweep.json").read_text())["versions"]["mujoco"] == mujoco.__version__

"""benchmarks/instructions.py: the loop's instructions per control step, counted by callgrind."""

import os
import shutil
import subprocess
import sys

import pytest

from benchmarks import instructions

ANNOTATION = """\
--------------------------------------------------------------------------------
Ir
--------------------------------------------------------------------------------
3,022,699,853 (100.0%)  PROGRAM TOTALS

--------------------------------------------------------------------------------
Ir                   file:function
--------------------------------------------------------------------------------
2,500,000,000 (82.7%)  ???:_PyEval_EvalFrameDefault [/lib/libpython3.11.so.1.0]
1,209,244,008 (40.01%)  ???:mj_step [/site-packages/mujoco/libmujoco.so.4.0.0]
  700,000,000 (23.2%)  ???:mj_stepSomething [/site-packages/mujoco/libmujoco.so.4.0.0]
"""


def test_the_annotation_gives_the_total_and_mj_step():
    assert instructions.parse_annotation(ANNOTATION) == (3_022_699_853, 1_209_244_008)
    without = ANNOTATION.replace("mj_step [", "mj_forward [")
    assert instructions.parse_annotation(without) == (3_022_699_853, 0)
    with pytest.raises(ValueError, match="PROGRAM TOTALS"):
        instructions.parse_annotation("no totals here")


def test_bad_step_counts_and_a_missing_valgrind_are_errors_naming_them(monkeypatch):
    with pytest.raises(ValueError, match="at least 1"):
        instructions.instruction_counts(steps=0)
    monkeypatch.setattr(shutil, "which", lambda tool: None)
    with pytest.raises(RuntimeError, match="valgrind"):
        instructions.instruction_counts(steps=5, warmup_steps=2)


def test_the_text_names_each_count():
    counts = {"mj_step_per_step": 1.1e6, "loop_per_step": 1.8e5, "instruction_ratio": 1.1636}
    text = instructions.format_instructions({"scenario": "grasp", "steps": 1000, "warmup_steps": 200, **counts})
    assert "1,100,000" in text and "180,000" in text and "1.164" in text and "200 to 1200" in text


def test_the_counted_runs_environment_keeps_other_glibc_tunables_and_pads_the_heap_once():
    env = instructions.counted_env({"GLIBC_TUNABLES": "glibc.malloc.arena_max=2:glibc.malloc.top_pad=4096", "HOME": "/h"})
    assert env["GLIBC_TUNABLES"] == f"glibc.malloc.arena_max=2:glibc.malloc.top_pad={instructions.HEAP_TOP_PAD_BYTES}"
    assert env["HOME"] == "/h" and env["PYTHONHASHSEED"] == "0" and env["OPENBLAS_NUM_THREADS"] == "1"
    assert instructions.counted_env({})["GLIBC_TUNABLES"] == f"glibc.malloc.top_pad={instructions.HEAP_TOP_PAD_BYTES}"
    assert instructions.HEAP_TOP_PAD_BYTES > 8 << 20  # valgrind's cap on the brk segment


#: 24 MiB of 1 KiB mallocs, each with errno cleared first; prints how many left errno set (what
#: MuJoCo's XML reader reads as a number's error).
_GROWTH = """\
import ctypes
libc = ctypes.CDLL(None, use_errno=True)
libc.malloc.restype = ctypes.c_void_p
left = 0
for _ in range(24 * 1024):
    ctypes.set_errno(0)
    libc.malloc(1024)
    left += ctypes.get_errno() != 0
print(left)
"""


def _mallocs_leaving_errno_under_valgrind(env: dict[str, str]) -> int:
    cmd = ["valgrind", "-q", "--tool=none", sys.executable, "-c", _GROWTH]
    run = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    return int(run.stdout)


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="needs valgrind")
def test_no_malloc_in_a_counted_run_leaves_errno_set_as_valgrind_refuses_the_heaps_growth():
    """The CI's failure (2026-11-30): under valgrind, glibc's heap growth past the 8 MiB brk cap
    left errno at ENOMEM, and MuJoCo's XML reader failed scene_grasp.xml with "unknown error in
    attribute 'pos'".  The unpadded control shows the cause on this machine; the counted runs'
    environment shows none."""
    counted = instructions.counted_env(os.environ)
    plain = {k: v for k, v in counted.items() if k != "GLIBC_TUNABLES"}
    assert _mallocs_leaving_errno_under_valgrind(counted) == 0
    if _mallocs_leaving_errno_under_valgrind(plain) == 0:  # the control: the cause, shown
        pytest.skip("this valgrind does not cap the brk segment: no growth is refused, padded or not")


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("valgrind") is None or shutil.which("callgrind_annotate") is None, reason="needs valgrind")
def test_a_count_of_the_grasp_splits_mj_step_from_the_loop():
    """A few control steps of the grasp counted: MuJoCo's steps and the loop's own work both
    show (that two counts agree to about ten thousand instructions a run was checked by hand)."""
    counts = instructions.instruction_counts(steps=20, warmup_steps=2)
    assert counts["mj_step_per_step"] > 0 and counts["loop_per_step"] > 0
    # The loop's own work is a fraction of MuJoCo's (ratio 1.14-1.2, docs/performance.md); a part
    # that took in the set-up or the exit (1.4 and 0.08 billion instructions) would read tens.
    assert counts["instruction_ratio"] < 2.0
    assert counts["instruction_ratio"] == pytest.approx(1.0 + counts["loop_per_step"] / counts["mj_step_per_step"])


@pytest.mark.parametrize("fired", [1, 3])
def test_a_count_whose_marker_fired_other_than_twice_is_refused(tmp_path, monkeypatch, fired):
    """The counted steps are the part between the marker's two calls: were it called elsewhere,
    that part would hold only some of them, and the count would be silently wrong."""

    def run(cmd, **kwargs):
        for part in range(1, fired + 1):
            (tmp_path / f"callgrind.out.{part}").write_text("")
        return subprocess.CompletedProcess(cmd, 0, "", "")

    monkeypatch.setattr(subprocess, "run", run)
    with pytest.raises(RuntimeError, match=f"mj_version fired {fired} times"):
        instructions._counted_part(5, 2, "grasp", [], tmp_path, {})

"""benchmarks/instructions.py: the loop's instructions per control step, counted by callgrind."""

import shutil

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


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("valgrind") is None or shutil.which("callgrind_annotate") is None, reason="needs valgrind")
def test_a_count_of_the_grasp_splits_mj_step_from_the_loop():
    """A few control steps of the grasp counted: MuJoCo's steps and the loop's own work both
    show (that two counts agree to about ten thousand instructions a run was checked by hand,
    README: a second count here would double this test's minute).  Its two counted runs side by
    side, in half the time (which shifts the loop's count by about 3 %: the command line runs
    them one after the other)."""
    counts = instructions.instruction_counts(steps=20, warmup_steps=2, side_by_side=True)
    assert counts["mj_step_per_step"] > 0 and counts["loop_per_step"] > 0
    assert counts["instruction_ratio"] == pytest.approx(1.0 + counts["loop_per_step"] / counts["mj_step_per_step"])

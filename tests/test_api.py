"""The Python API: the same numbers as the command line; one installed top-level name."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import piezotip
from piezotip import cli

#: Keys of the summary that depend on the machine (timing) or on where files went.
MACHINE_KEYS = {"wall_time_s", "realtime_factor", "files"}


def test_the_api_result_equals_the_command_line(tmp_path, capsys):
    overrides = {"object.mass_kg": 0.2, "duration_s": 3.0}
    result = piezotip.run("grasp", overrides=overrides, preset="fast")
    argv = ["run", "grasp", "--set", "object.mass_kg=0.2", "--set", "duration_s=3.0", "--preset", "fast"]
    assert cli.main([*argv, "--no-plot", "--json", "--out", str(tmp_path)]) in (0, 1)
    printed = json.loads(capsys.readouterr().out)
    api = json.loads(json.dumps(piezotip.analysis.runner.json_safe(dict(result.summary))))
    assert {k: v for k, v in api.items() if k not in MACHINE_KEYS} == {k: v for k, v in printed.items() if k not in MACHINE_KEYS}
    recorded = np.load(tmp_path / "run.npz")
    for name, values in result.data.items():
        np.testing.assert_array_equal(values, recorded[name], err_msg=name)
    assert result.outcome == printed["outcome"] and result.success == printed["success"]
    assert result.overrides == ("object.mass_kg=0.2", "duration_s=3.0")
    assert result.out_dir is None and result.summary["files"] == []


def test_the_result_names_its_units_and_is_read_only():
    result = piezotip.run("grasp", overrides=["duration_s=0.5"], preset="fast")
    assert result.units["time_s"] == "s" and result.units["left_true_pressure_pa"] == "Pa"
    assert result.units["object_vz_m_s"] == "m/s" and result.units["left_mode"] == "1"
    assert set(result.units) == set(result.data)
    with pytest.raises(TypeError):
        result.data["time_s"] = None
    assert [e["kind"] for e in result.events] == [e["kind"] for e in result.summary["events"]] and result.events


def test_a_mapping_and_the_command_line_text_give_one_config():
    from piezotip import scenarios

    mapping = {"object.mass_kg": np.float64(0.4), "controller.modes": (1, 2), "sensor.dynamics": "steady", "sensor.quality_factor": None}
    text = ["object.mass_kg=0.4", "controller.modes=(1, 2)", "sensor.dynamics=steady", "sensor.quality_factor=None"]
    assert scenarios.get("grasp", mapping) == scenarios.get("grasp", text)
    assert scenarios.override_strings(mapping) == text


@pytest.mark.parametrize(
    "call, named",
    [
        (lambda: piezotip.run("nothere"), "nothere"),
        (lambda: piezotip.run("grasp", {"object.nope": 1}), "object.nope"),
        (lambda: piezotip.run("grasp", {"object.mass_kg": -1.0}), "object.mass_kg"),
        (lambda: piezotip.run("grasp", "object.mass_kg=1"), "object.mass_kg=1"),
        (lambda: piezotip.run("grasp", plot=True), "out="),
    ],
)
def test_bad_input_raises_the_command_lines_error(call, named):
    with pytest.raises(ValueError, match=None) as err:
        call()
    assert named in str(err.value)


def test_the_sensor_side_calls_match_the_loops_fingertip():
    from piezotip import scenarios
    from piezotip.cosim.loop import make_fingertip

    tip = piezotip.fingertip("grasp", {"sensor.coverage_mm": (6.0, 7.5)})
    assert tip.config_key() == make_fingertip(scenarios.get("grasp", ["sensor.coverage_mm=(6.0, 7.5)"])).config_key()
    report = piezotip.dynamic_range("grasp")
    assert report == make_fingertip(scenarios.get("grasp")).dynamic_range()
    assert report["dynamic_range"] > 1e4


def test_import_piezotip_is_cheap():
    """No MuJoCo, scipy or matplotlib until a run asks for them."""
    code = "import sys, piezotip; print(sorted(m for m in ('mujoco', 'scipy', 'matplotlib', 'numpy') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert json.loads(out.replace("'", '"')) == []


def test_a_figure_is_saved_without_pyplot(tmp_path):
    """The plots are Figure objects saved with Agg: pyplot (its import, its global figure
    registry) is never loaded, even with an interactive backend asked for."""
    code = (
        "import sys; from piezotip.analysis.plotting import new_figure, save_figure\n"
        "fig, axes = new_figure(1, 2, figsize=(4, 2)); axes[0][1].semilogy([1, 2], [1, 10])\n"
        f"save_figure(fig, {str(tmp_path / 'f.png')!r}, dpi=50)\n"
        "print('matplotlib.pyplot' in sys.modules)"
    )
    env = {**os.environ, "MPLBACKEND": "TkAgg"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout
    assert out.split() == ["False"]
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_saved_figure_reads_back_as_drawn(tmp_path):
    """The fast PNG compression loses nothing: the file holds the canvas's pixels exactly."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.image import imread

    from piezotip.analysis.plotting import new_figure, save_figure

    fig, axes = new_figure(1, 1, figsize=(3, 2))
    axes[0][0].plot([0, 1, 2], [2, 0, 1])
    path = save_figure(fig, tmp_path / "f.png", dpi=100)  # the canvas draws at the figure's 100 dpi
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    drawn = np.asarray(canvas.buffer_rgba())
    read = np.round(imread(path) * 255.0).astype(np.uint8)  # imread gives floats in [0, 1]
    assert read.shape == drawn.shape == (200, 300, 4)
    assert np.array_equal(read, drawn)


@pytest.mark.parametrize("name", ["sensor", "analysis", "reports", "cosim", "scenarios", "models", "run_sim"])
def test_only_piezotip_is_installed_at_the_top_level(name, tmp_path):
    """From a folder outside the checkout, the repository's folders are not importable by
    their own names (they would collide with a user's modules): only ``piezotip.<name>``."""
    probe = f"import importlib.util as u; print(u.find_spec({name!r}) is None, u.find_spec('piezotip') is not None)"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=tmp_path, check=True).stdout.split()
    assert out == ["True", "True"]


def test_the_subpackages_and_the_models_are_reachable_under_piezotip(tmp_path):
    probe = (
        "import piezotip.sensor, piezotip.cosim.control, piezotip.scenarios, piezotip.analysis.sweep;"
        "from piezotip.cosim.pad_model import MODELS_DIR; print((MODELS_DIR / 'scene_grasp.xml').is_file())"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=tmp_path, check=True).stdout
    assert out.strip() == "True"


@pytest.mark.slow
def test_the_readmes_script_runs(tmp_path):
    """The README's Python example, saved as a script exactly as printed and run as one (a sweep
    on the default local cluster, whose worker processes import the script: unguarded, each
    would run it again and the cluster failed to start)."""
    import pathlib
    import re
    import subprocess
    import sys

    readme = (pathlib.Path(__file__).resolve().parents[1] / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", readme, re.S)
    script = tmp_path / "example.py"
    script.write_text(next(b for b in blocks if "piezotip.run(" in b))
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.splitlines()
    assert lines[0].startswith("success ")
    outcomes = eval(lines[-1])  # the sweep's outcomes, printed as a list of strings
    assert len(outcomes) == 4 and "error" not in outcomes

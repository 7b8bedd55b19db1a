"""Numerics at the extremes of the co-simulation: timesteps, integrators, long holds, divergence."""

import json
import math

import numpy as np
import pytest

from piezotip import scenarios
from piezotip.analysis.runner import MujocoWarnings, run_scenario
from piezotip.cosim.loop import CoSimulation
from piezotip.cosim.recorder import Recorder


@pytest.mark.parametrize("timestep", [1e-6, 0.05])
def test_timesteps_outside_the_tested_range_are_refused_before_running(timestep):
    with pytest.raises(ValueError, match=r"physics\.timestep_s must be within"):
        scenarios.get("grasp", [f"physics.timestep_s={timestep}", f"physics.control_period_s={max(timestep, 0.005)}"])


@pytest.mark.parametrize("integrator", ["implicitfast", "Euler", "RK4", "implicit"])
def test_explicit_gel_stiffness_is_refused_before_running_with_the_step_it_needs(integrator):
    """Under these integrators the gel's stiff law is explicit: the bridge says which timestep it needs."""
    cfg = scenarios.get("grasp", [f"physics.integrator={integrator}"])
    with pytest.raises(ValueError, match=r"needs timestep <= [0-9.e+-]+ s"):
        CoSimulation(cfg)


@pytest.mark.slow
@pytest.mark.parametrize(("timestep", "control"), [(1e-4, 0.005), (0.0025, 0.005)])
def test_fine_and_coarse_timesteps_grasp(tmp_path, timestep, control):
    summary, _ = run_scenario(
        "grasp", [f"physics.timestep_s={timestep}", f"physics.control_period_s={control}"], tmp_path, plot=False, quiet=True
    )
    assert summary["error"] is None and summary["outcome"] == "success", summary["reason"]


@pytest.mark.slow
def test_the_largest_timestep_holds_numerically_and_is_judged_honestly(tmp_path):
    """At 20 ms the fingers' servo (660 rad/s) is not resolved and its jitter reaches the
    pascal-sensitive fingertip: no grasp, but no divergence either, and the referee says so."""
    summary, data = run_scenario("grasp", ["physics.timestep_s=0.02", "physics.control_period_s=0.02"], tmp_path, plot=False, quiet=True)
    assert summary["error"] is None
    nan_where_none = ("estimate_pa", "uncertainty_pa", "contact_tilt_rad")  # no estimate, no contact
    assert all(np.all(np.isfinite(v)) for k, v in data.items() if not k.endswith(nan_where_none))
    rise = data["object_height_m"].max() - data["object_height_m"][0]
    assert summary["outcome"] == ("success" if rise > 0.045 else "never_lifted"), summary["reason"]
    assert summary["sim_time_s"] < scenarios.get("grasp").duration_s  # it gave up instead of running out the clock


@pytest.mark.slow
@pytest.mark.parametrize("mass_kg", [0.001, 10.0])
def test_one_gram_and_ten_kilograms(tmp_path, mass_kg):
    size = 0.03 if mass_kg < 1 else 0.08
    summary, _ = run_scenario("grasp", [f"object.mass_kg={mass_kg}", f"object.size_m={size}"], tmp_path, plot=False, quiet=True)
    assert summary["success"], summary


@pytest.mark.slow
def test_a_minute_long_hold_does_not_drift(tmp_path):
    """10 kg held for 60 s (fast preset): no slip, the object's height and the estimate steady."""
    summary, data = run_scenario("grasp-10kg", ["controller.hold_s=60", "duration_s=70"], tmp_path, plot=False, quiet=True, preset="fast")
    assert summary["success"] and not summary["slipped"], summary
    hold = data["phase"] == 4.0
    t = data["time_s"][hold]
    assert t[-1] - t[0] > 59
    height = data["object_height_m"][hold]
    assert np.ptp(height[t > t[0] + 1]) < 1e-3  # creep under 1 mm in a minute
    est = data["left_estimate_pa"][hold]
    first, last = np.nanmedian(est[t < t[0] + 5]), np.nanmedian(est[t > t[-1] - 5])
    assert abs(last / first - 1) < 0.01


def test_a_divergence_stops_with_a_clear_message_and_keeps_the_recording(tmp_path):
    sim = CoSimulation(scenarios.get("grasp"))

    def poison(s):
        if s.steps == 40:
            s.data.qvel[0] = math.nan

    with MujocoWarnings() as warned:  # MuJoCo's text warning counted, not written to MUJOCO_LOG.TXT here
        result = sim.run(Recorder(tmp_path / "run"), on_step=poison)
    assert result.error is not None and "diverged" in result.error and "t = " in result.error
    assert [w["message"].split(".")[0] for w in warned.listed()] == ["Nan, Inf or huge value in QVEL at DOF 0"]
    kept = np.load(tmp_path / "run.npz")
    assert len(kept["time_s"]) == 40


def test_run_command_reports_a_divergence_and_exits_nonzero(tmp_path, monkeypatch, capsys):
    from piezotip import cli as run_sim
    from piezotip.cosim import loop

    original = loop.CoSimulation._physics

    def exploding(self):
        original(self)
        if self.steps == 10:
            self.data.qpos[0] = math.inf
            self._check_stable()

    monkeypatch.setattr(loop.CoSimulation, "_physics", exploding)
    code = run_sim.main(["run", "grasp", "--out", str(tmp_path), "--json"])
    assert code == 1
    out = capsys.readouterr().out
    assert '"error": "simulation diverged' in out
    assert (tmp_path / "run.npz").exists()


def test_mujocos_own_warnings_go_into_the_summary_not_a_log_file_in_the_users_directory(tmp_path, monkeypatch, capsys):
    """MuJoCo warns in text of a bad velocity (and resets the state); by default it prints that
    and appends it to MUJOCO_LOG.TXT in the current directory.  A run counts its warnings in the
    summary (``mujoco_warnings``) and the printed block, writes no such file, and puts back the
    handler it found."""
    import mujoco

    from piezotip import cli as run_sim
    from piezotip.cosim import loop

    original = loop.CoSimulation._physics

    def poisoned(self):
        if self.steps == 10:
            self.data.qvel[0] = math.nan  # mj_step's check warns, in text
        original(self)

    monkeypatch.setattr(loop.CoSimulation, "_physics", poisoned)
    monkeypatch.chdir(tmp_path)
    mine = []
    mujoco.set_mju_user_warning(mine.append)
    try:
        code = run_sim.main(["run", "grasp", "--out", str(tmp_path / "run"), "--preset", "fast", "--no-plot"])
        assert mine == []  # the run's warning went to the run...
        body = "<body><joint type='slide'/><geom size='0.1'/></body>"
        model = mujoco.MjModel.from_xml_string(f"<mujoco><worldbody>{body}</worldbody></mujoco>")
        data = mujoco.MjData(model)
        data.qvel[0] = math.nan
        mujoco.mj_step(model, data)
        assert len(mine) == 1 and "QVEL" in mine[0]  # ...and the user's handler is back for theirs
    finally:
        mujoco.set_mju_user_warning(None)
    assert code == 1  # the divergence it caused
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    [warned] = summary["mujoco_warnings"]
    assert "Nan, Inf or huge value in QVEL" in warned["message"] and warned["count"] >= 1
    assert "MuJoCo warned (" in capsys.readouterr().out
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


@pytest.mark.slow
def test_gel_law_linearized_per_control_period_matches_per_step(tmp_path):
    """The gel's law applied once per 5 ms period (linearized, MuJoCo integrates the tangent)
    against before every 1 ms step: the held 10 kg grip's pressure within 0.1 %."""
    held = {}
    for mode in ("control", "substep"):
        _, data = run_scenario("grasp-10kg", [f"physics.gel_update={mode}"], tmp_path / mode, plot=False, quiet=True)
        hold = data["phase"] == 4.0
        held[mode] = float(np.median(data["left_true_pressure_pa"][hold]))
    assert abs(held["control"] / held["substep"] - 1) < 1e-3

"""The loop's instrument hooks (what run_sim.py bench measures with, nothing patched) and the
MuJoCo sensors computed once per control period."""

import mujoco
import numpy as np
import pytest

from piezotip import scenarios
from piezotip.cosim import loop
from piezotip.cosim.loop import STAGE_METHODS, CoSimulation
from piezotip.cosim.rows import TRUTH_COLUMNS

STEPS = 120


@pytest.fixture(scope="module")
def config():
    return scenarios.get("grasp", ["duration_s=1.0"])


def test_wrap_stages_sees_every_stage_in_order(config):
    sim = CoSimulation(config)
    calls = []

    def wrap(stage, fn):
        def wrapped(*args, **kwargs):
            calls.append(stage)
            return fn(*args, **kwargs)

        return wrapped

    sim.wrap_stages(wrap)
    sim.advance()
    # gel_forces runs inside physics (once a period: the gel law linearized per period)
    assert calls == ["physics", "gel_forces", "pressure", "sensor", "readout", "controller", "controller", "actuators", "record"]
    assert set(calls) == set(STAGE_METHODS)


def test_watch_mj_step_sees_every_physics_step_and_changes_nothing(config):
    plain, watched = CoSimulation(config), CoSimulation(config)
    seen = []
    watched.watch_mj_step(lambda m, d: seen.append(d.time))
    rows_plain = [plain.advance() for _ in range(STEPS)]
    rows_watched = [watched.advance() for _ in range(STEPS)]
    assert len(seen) == STEPS * config.physics.substeps
    assert np.diff(seen) == pytest.approx(config.physics.timestep_s)
    np.testing.assert_array_equal(rows_watched, rows_plain)  # (NaN equal: a contact tilt where none touches)


def test_model_settings_round_trip(config):
    sim = CoSimulation(config)
    for _ in range(STEPS):
        sim.advance()
    settings = sim.model_settings()
    m = sim.model
    m.jnt_stiffness[sim.bridge.joint_ids] = 0.0
    m.actuator_forcerange[:] = 0.0
    sim.apply_model_settings(settings)
    again = sim.model_settings()
    assert np.array_equal(again[0], settings[0]) and np.array_equal(again[1], settings[1]) and again[2] == settings[2]


def test_sensors_once_a_period_record_what_every_substep_would(config, monkeypatch):
    """The referee's ground truth (MuJoCo's sensors) is computed in a period's last substep only:
    the rows equal those of a loop that computes it every substep."""
    once = CoSimulation(config)
    rows_once = [once.advance() for _ in range(STEPS)]
    monkeypatch.setattr(loop, "_NO_SENSORS", 0)
    every = CoSimulation(config)
    rows_every = [every.advance() for _ in range(STEPS)]
    np.testing.assert_array_equal(rows_once, rows_every)  # (NaN equal: a contact tilt where none touches)
    truth = [once.columns.index(c) for c in TRUTH_COLUMNS]
    assert any(row[i] != 0.0 for row in rows_once for i in truth)  # the sensors did read something


def test_the_models_own_disable_flags_are_kept(config):
    sim = CoSimulation(config)
    own = int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    before = int(sim.model.opt.disableflags)
    sim.model.opt.disableflags |= own  # set between periods: the loop keeps it
    seen = []
    sim.watch_mj_step(lambda m, d: seen.append(int(m.opt.disableflags)))
    sim.advance()
    sensors = int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
    assert all(flags & own for flags in seen)
    assert [bool(flags & sensors) for flags in seen] == [True] * (config.physics.substeps - 1) + [False]
    assert int(sim.model.opt.disableflags) == before | own


def test_the_robots_gravity_is_the_models(config):
    from piezotip.cosim.scene import robot_limits

    sim = CoSimulation(config)
    assert sim.robot.gravity_m_s2 == pytest.approx(-sim.model.opt.gravity[2])
    sim.model.opt.gravity[2] = -1.62
    assert robot_limits(sim.model, sim.home, sim.bridge.geometry).gravity_m_s2 == pytest.approx(1.62)

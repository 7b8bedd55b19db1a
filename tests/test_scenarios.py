"""The scenario registry and --set overrides."""

import pytest

from piezotip import scenarios
from piezotip.scenarios.config import valid_keys

#: The modules owning the configs (each config beside what it configures).
OWNERS = ("piezotip.cosim.config", "piezotip.cosim.control.config", "piezotip.sensor.config")


@pytest.mark.parametrize("name", scenarios.names())
def test_every_registered_scenario_is_valid(name):
    cfg = scenarios.get(name)
    assert cfg.name == name
    assert cfg.validate() is cfg


def test_overrides_from_the_issue_apply_with_types():
    cfg = scenarios.get(
        "grasp",
        ["object.mass_kg=0.4", "object.shape=cylinder", "object.size_m=0.04", "object.friction=0.8", "controller.modes=[1]"],
    )
    assert cfg.object.mass_kg == 0.4 and isinstance(cfg.object.mass_kg, float)
    assert cfg.object.shape == "cylinder"
    assert cfg.object.friction == 0.8
    assert cfg.controller.modes == (1,)


def test_optional_and_tuple_fields():
    cfg = scenarios.get("grasp", ["object.crush_force_n=12", "sensor.coverage_mm=[6.5, 7.5]", "sensor.quality_factor=None"])
    assert cfg.object.crush_force_n == 12.0
    assert cfg.sensor.coverage_mm == (6.5, 7.5)
    assert cfg.sensor.quality_factor is None


def test_unknown_scenario_lists_valid_ones():
    with pytest.raises(ValueError, match=r"valid scenarios: .*grasp"):
        scenarios.get("no-such-scene")


@pytest.mark.parametrize(
    ("assignments", "meant", "where"),
    [
        (["bogus.key=1"], None, "ScenarioConfig"),
        (["controller.grip_safty=1.3"], "controller.grip_safety", "GentleConfig"),
        (["object.mas=1"], "object.mass_kg", "ObjectConfig"),
        (["sensor.mass_kg=1"], "object.mass_kg", "SensorConfig"),  # the right name under the wrong part
        (["mass_kg=1"], "object.mass_kg", "ScenarioConfig"),
        (["physics.timestep=0.001"], "physics.timestep_s", "PhysicsConfig"),
        (["controller.kind=scripted", "controller.grip_forc_n=2"], "controller.grip_force_n", "ScriptedConfig"),
    ],
)
def test_an_unknown_key_is_a_short_line_with_what_it_may_have_meant(assignments, meant, where):
    """It was one line of every valid key (942 characters; 1,629 for a mistyped controller key)
    with no guess: now the key, the close matches, and the dataclass documenting them all."""
    with pytest.raises(ValueError) as err:
        scenarios.get("grasp", assignments)
    message = str(err.value)
    key = assignments[-1].partition("=")[0]
    assert message.startswith(f"unknown key '{key}'") and "\n" not in message
    assert len(message) <= 500, (len(message), message)
    # the dataclass documenting the keys, named with its own module (where a reader finds it)
    assert any(f"{where}'s docstring in {m}" in message for m in OWNERS) or f"docstrings of {where} and its parts, in " in message
    if meant is None:
        assert "did you mean" not in message and "object.*" in message and "controller.*" in message
    else:
        assert f"(did you mean {meant}?)" in message or f"(did you mean {meant} or" in message, message


def test_unknown_key_lists_valid_keys():
    with pytest.raises(ValueError, match=r"unknown key 'object\.mas'.*object\.mass_kg"):
        scenarios.get("grasp", ["object.mas=1"])
    with pytest.raises(ValueError, match="unknown key 'object'"):
        scenarios.get("grasp", ["object=3"])


@pytest.mark.parametrize(
    ("assignment", "message"),
    [
        ("object.mass_kg=-1", "object.mass_kg must be a positive number"),
        ("object.mass_kg=heavy", "object.mass_kg: expected a number"),
        ("object.shape=cube", "object.shape must be one of"),
        ("physics.pad_segments=2.5", "physics.pad_segments: expected an integer"),
        ("physics.control_period_s=0.0007", "whole multiple"),
        ("controller.modes=[5]", "modes the sensor lacks"),
        ("sensor.dynamics=magic", "sensor.dynamics must be one of"),
        ("object.size_m=0.5", "open gripper spans 90 mm"),
        ("nonsense", "key=value"),
    ],
)
def test_bad_values_name_the_key_and_value(assignment, message):
    with pytest.raises(ValueError, match=message):
        scenarios.get("grasp", [assignment])


def test_a_list_given_as_text_in_a_mapping_says_a_list_is_needed():
    with pytest.raises(ValueError, match=r"controller\.modes: .*a list of int values.*'\[2, 3\]'"):
        scenarios.get("grasp", {"controller.modes": "[2, 3]"})
    assert scenarios.get("grasp", {"controller.modes": [2, 3]}).controller.modes == (2, 3)


def test_valid_keys_cover_nested_fields():
    keys = valid_keys(scenarios.get("grasp"))
    assert {"object.mass_kg", "physics.timestep_s", "sensor.dynamics", "controller.modes"} <= set(keys)


@pytest.mark.parametrize(
    ("section", "values", "key"),
    [
        ("ObjectConfig", {"mass_kg": -0.1}, "object.mass_kg"),
        ("PhysicsConfig", {"timestep_s": 0.0015}, "physics.control_period_s"),  # 5 ms is no whole multiple of 1.5 ms
        ("SensorConfig", {"coverage_mm": (7.0, 7.1)}, "sensor.coverage_mm"),
        ("GripperConfig", {"fingertips": ("a", "b")}, "gripper.fingertips"),
    ],
)
def test_a_section_is_checked_when_it_is_made(section, values, key):
    """Validation on construction: a bad value cannot exist (it used to wait for validate())."""
    from piezotip.scenarios import config as config_module

    with pytest.raises(ValueError, match=key.replace(".", r"\.")):
        getattr(config_module, section)(**values)


def test_a_batch_of_overrides_is_checked_once_applied():
    """Assignments that are consistent only together (the timestep and the control period) are
    checked after the batch, not one by one."""
    cfg = scenarios.get("grasp", ["physics.timestep_s=0.0015", "physics.control_period_s=0.003"])
    assert cfg.physics.substeps == 2
    with pytest.raises(ValueError, match=r"physics\.control_period_s"):
        scenarios.get("grasp", ["physics.timestep_s=0.0015"])


def test_a_run_of_exactly_the_longest_recorded_duration_is_accepted():
    """duration_s = MAX_RECORDED_STEPS control periods, where duration / period rounds past the
    limit (hypothesis found it: 10739.908162665997 s of 0.010739908162665996 s periods)."""
    from piezotip.scenarios.config import MAX_RECORDED_STEPS

    period, step = 0.010739908162665996, 0.005369954081332998
    config = scenarios.get("grasp", [f"physics.timestep_s={step!r}", f"physics.control_period_s={period!r}", "duration_s=1.0"])
    longest = MAX_RECORDED_STEPS * period
    assert longest / period > MAX_RECORDED_STEPS  # the rounding the check must not trip on
    assert scenarios.with_overrides(config, [f"duration_s={longest!r}"]).duration_s == longest
    with pytest.raises(ValueError, match="control periods"):
        scenarios.with_overrides(config, [f"duration_s={longest * (1 + 1e-9)!r}"])

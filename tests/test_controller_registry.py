"""The controller registry (issue 31): controllers registered like scenarios, each with its own config.

A controller defined here, in the test, is registered as ``mytest`` and run through the API
exactly as the built-in ones are: ``controller.kind`` picks it, its own ``controller.*`` keys set
its config, and a key its config lacks is an error naming the key, the controller and its keys.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pytest

import piezotip
from piezotip import controllers, scenarios
from piezotip.cosim.control import Command, Phase, pad_names
from piezotip.scenarios.config import ControllerConfig, GentleConfig, MultimodeConfig, ScenarioConfig, ScriptedConfig


@dataclass(frozen=True)
class HoldOpenConfig(ControllerConfig):
    """The test controller's settings.

    Attributes
    ----------
    wait_s : how long it holds the gripper open at home before it is done, s.
    """

    wait_s: float = 0.2

    def validate(self) -> None:
        super().validate()
        if not self.wait_s > 0:
            raise ValueError(f"controller.wait_s must be positive, got {self.wait_s!r}")


@controllers.register("mytest", config=HoldOpenConfig)
class HoldOpen:
    """Holds the gripper open at home for ``wait_s``, then is done: it never touches the object."""

    def __init__(self, config: HoldOpenConfig, robot, pads: tuple[str, ...]) -> None:
        self.cfg, self.robot, self.pads = config, robot, pads
        self.phase = Phase.APPROACH
        self.events = []

    @classmethod
    def from_scenario(cls, config: ScenarioConfig, robot, fingertip) -> HoldOpen:
        return cls(config.controller, robot, pad_names(config.sensor.pads))

    def step(self, obs, dt_s: float) -> Command:
        if obs.time_s >= self.cfg.wait_s:
            self.phase = Phase.DONE
        modes = {pad: min(self.cfg.modes) for pad in self.pads}
        return Command(self.robot.home_lift_m, self.robot.home_opening_m, 1.0, modes, self.phase, "holding open")

    @property
    def finished(self) -> bool:
        return self.phase is Phase.DONE


def test_the_built_in_controllers_are_registered_with_their_configs():
    assert {"multimode", "gentle", "scripted", "mytest"} <= set(controllers.names())
    assert isinstance(controllers.names(), tuple)
    assert piezotip.controllers is controllers
    multimode, gentle, scripted = (controllers.get(name) for name in ("multimode", "gentle", "scripted"))
    assert (multimode.config, gentle.config, scripted.config) == (MultimodeConfig, GentleConfig, ScriptedConfig)
    assert issubclass(gentle.config, MultimodeConfig) and issubclass(gentle.controller, multimode.controller)
    assert (multimode.experiment, gentle.experiment, scripted.experiment) == (True, True, False)
    assert (multimode.senses, gentle.senses, scripted.senses) == (True, True, False)
    assert controllers.get("mytest").controller is HoldOpen and controllers.get("mytest").config is HoldOpenConfig


def test_an_unknown_controller_lists_the_valid_ones():
    with pytest.raises(ValueError, match=r"unknown controller 'nope'; valid controllers: multimode, gentle, scripted, .*mytest"):
        controllers.get("nope")
    with pytest.raises(ValueError, match=r"controller\.kind must be one of multimode, gentle, scripted.*; got 'nope'"):
        scenarios.get("grasp", ["controller.kind=nope"])


def test_registering_refuses_a_name_twice_a_bad_config_or_a_class_it_cannot_build():
    with pytest.raises(ValueError, match="'scripted' registered twice"):
        controllers.register("scripted", config=ScriptedConfig)(HoldOpen)
    with pytest.raises(ValueError, match="name must be non-empty"):
        controllers.register("a,b", config=HoldOpenConfig)
    with pytest.raises(TypeError, match="subclassing ControllerConfig"):
        controllers.register("plain", config=dict)
    with pytest.raises(TypeError, match="lacks from_scenario"):
        controllers.register("plain", config=HoldOpenConfig)(type("Plain", (), {"step": lambda self, obs, dt_s: None}))
    assert "plain" not in controllers.names()


def test_a_controller_registered_in_a_script_runs_through_the_api():
    short = piezotip.run("grasp", overrides={"controller.kind": "mytest"}, preset="fast")
    longer = piezotip.run("grasp", overrides={"controller.kind": "mytest", "controller.wait_s": 1.0}, preset="fast")
    for result, wait_s in ((short, 0.2), (longer, 1.0)):
        assert result.summary["error"] is None
        assert not result.success  # it never grasps
        done = np.flatnonzero(result.data["phase"] == int(Phase.DONE))
        assert result.data["time_s"][done[0]] == pytest.approx(wait_s, abs=0.01)  # its own key took effect
        # The fingers stayed open: no finger ever touched the object.
        assert np.all(result.data["left_finger_force_n"] <= 0) and np.all(result.data["right_finger_force_n"] <= 0)
    assert scenarios.get("grasp", {"controller.kind": "mytest", "controller.wait_s": 1.0}).controller == HoldOpenConfig(
        kind="mytest", wait_s=1.0
    )


def test_a_key_the_chosen_controller_lacks_names_the_key_the_controller_and_its_keys():
    with pytest.raises(ValueError) as err:
        scenarios.get("grasp", ["controller.kind=scripted", "controller.persist=4"])
    message = str(err.value)
    assert "'controller.persist'" in message and "scripted controller (ScriptedConfig)" in message
    assert "the multimode, gentle controllers have it" in message
    assert "controller.grip_force_n" in message and "controller.hysteresis" not in message.split("its valid keys:")[1]
    with pytest.raises(ValueError, match=r"'controller\.wait_s' for the gentle controller.*mytest controller has it"):
        piezotip.run("grasp", overrides={"controller.wait_s": 1.0}, preset="fast")
    with pytest.raises(ValueError, match=r"'controller\.friction_max' for the mytest controller"):
        scenarios.get("grasp", {"controller.kind": "mytest", "controller.friction_max": 1.0})


def test_controller_kind_applies_first_whatever_the_order():
    given = ["controller.persist=4", "controller.lift_height_m=0.04", "controller.kind=gentle", "controller.probe_speed_m_s=0.002"]
    first = scenarios.get("grasp", given)
    assert first == scenarios.get("grasp", [given[2], given[0], given[1], given[3]])
    assert first.controller == GentleConfig(persist=4, lift_height_m=0.04, probe_speed_m_s=0.002)


def test_a_kind_switch_keeps_what_the_scenario_gave_and_the_new_kinds_defaults():
    multimode = MultimodeConfig(lift_height_m=0.03, hold_s=2.0, persist=5)
    scripted = controllers.configure("scripted", like=multimode)
    assert scripted == ScriptedConfig(lift_height_m=0.03, hold_s=2.0)  # persist: no setting of the scripted one
    assert controllers.configure("gentle", like=multimode) == GentleConfig(lift_height_m=0.03, hold_s=2.0, persist=5)
    assert controllers.configure("mytest") == HoldOpenConfig(kind="mytest")


@pytest.mark.parametrize(
    ("config", "values", "message"),
    [
        (MultimodeConfig, {"grip_safety": 0.9}, "controller.grip_safety must be a number above 1"),
        (MultimodeConfig, {"persist": 0}, "controller.persist must be an integer >= 1"),
        (MultimodeConfig, {"modes": (1, 1)}, "controller.modes must name each mode once"),
        (GentleConfig, {"probe_speed_m_s": -1.0}, "controller.probe_speed_m_s must be a positive number"),
        (GentleConfig, {"hysteresis": 1.5}, "controller.hysteresis must be a fraction"),
        (ScriptedConfig, {"grip_force_n": 150.0}, "100 N force limit"),
        (ScriptedConfig, {"drive_margin": 0.5}, "controller.drive_margin must be a number >= 1"),
        (HoldOpenConfig, {"kind": "mytest", "hold_s": -1.0}, "controller.hold_s must be non-negative"),
    ],
)
def test_each_config_checks_its_values_when_made(config, values, message):
    with pytest.raises(ValueError, match=message):
        config(**values)


def test_a_config_of_another_kind_is_refused():
    wrong = dataclasses.replace(scenarios.get("grasp"), controller=MultimodeConfig(kind="gentle"))
    with pytest.raises(ValueError, match=r"controller\.kind 'gentle' takes a GentleConfig, got a MultimodeConfig"):
        wrong.validate()


def test_the_experiment_and_its_pass_rule_take_the_registered_controllers(monkeypatch):
    from piezotip.analysis import experiment

    assert experiment.CONTROLLERS == (
        ("multimode", ("controller.kind=multimode", "controller.modes=[1, 2, 3, 4]")),
        ("gentle", ("controller.modes=[1, 2, 3, 4]",)),
        ("mode 1 only", ("controller.modes=[1]",)),
        ("mode 2 only", ("controller.modes=[2]",)),
        ("mode 3 only", ("controller.modes=[3]",)),
        ("mode 4 only", ("controller.modes=[4]",)),
    )
    assert experiment.pass_rule_controllers() == ("multimode", "gentle")
    registration = dataclasses.replace(controllers.get("mytest"), name="mine", experiment=True)
    monkeypatch.setitem(controllers._REGISTRY, "mine", registration)
    assert ("mine", ("controller.kind=mine", "controller.modes=[1, 2, 3, 4]")) in experiment.CONTROLLERS
    assert experiment.pass_rule_controllers() == ("multimode", "gentle", "mine")


@pytest.mark.parametrize("kind", controllers.names())
def test_every_registered_controller_runs_the_default_grasp(kind):
    result = piezotip.run("grasp", overrides={"controller.kind": kind}, preset="fast")
    assert result.summary["error"] is None
    assert result.data["time_s"].size > 0
    if kind != "mytest":  # the built-in ones carry the default box
        assert result.success, result.reason

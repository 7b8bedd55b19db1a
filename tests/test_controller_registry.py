"""The controller registry (issue 31): controllers registered like scenarios, each with its own config.

A controller defined here, in the test, is registered as ``mytest`` and run through the API
exactly as the built-in ones are: ``controller.kind`` picks it, its own ``controller.*`` keys set
its config, and a key its config lacks is an error naming the key, the controller and its keys.

Issue 45: the registry lives below the controllers (``piezotip.cosim.control.registry``, re-exported
as ``piezotip.controllers``); ``controller.kind=MODULE:CLASS`` names a class any process imports (the
installed command, a sweep's workers); the ``piezotip.controllers`` entry points register by name.
"""

from __future__ import annotations

import ast
import dataclasses
import json
import os
import shutil
import subprocess
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import piezotip
from piezotip import controllers, scenarios
from piezotip.cosim.control import Command, Phase, pad_names, registry
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


# --- Issue 45: the registry below the controllers, MODULE:CLASS kinds and entry points ---------

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def registry_restored():
    """The registry as it was after the test (a MODULE:CLASS kind resolved, or an entry point
    loaded, stays in it otherwise), and the test's own modules forgotten."""
    saved, modules = dict(registry._REGISTRY), set(sys.modules)
    yield registry
    registry._REGISTRY.clear()
    registry._REGISTRY.update(saved)
    for name in set(sys.modules) - modules:
        if name.startswith("regtest_"):
            del sys.modules[name]


USER_MODULE = '''
from dataclasses import dataclass

from piezotip import controllers
from piezotip.cosim.control.gentle import GentleGrasp
from piezotip.cosim.control.scripted import ScriptedGrasp
from piezotip.scenarios.config import ControllerConfig


class Mine(GentleGrasp):
    """The gentle controller under another name: its registration is the gentle one's."""


class Outer:
    class Inner(ScriptedGrasp):
        pass


@dataclass(frozen=True)
class OwnConfig(ControllerConfig):
    wait_s: float = 0.5


@controllers.register("{own}", config=OwnConfig)
class Own(ScriptedGrasp):
    pass


class NotController:
    pass
'''


def _user_module(tmp_path: Path, name: str, own: str) -> str:
    (tmp_path / f"{name}.py").write_text(USER_MODULE.replace("{own}", own))
    return name


def _python(code: str, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300, env={**os.environ, **env})


def test_the_registry_lives_below_the_controllers_and_imports_nothing_above():
    # Its module-level imports: the standard library's and the configs' (no piezotip.controllers).
    tree = ast.parse(Path(registry.__file__).read_text())
    imported = {node.module for node in tree.body if isinstance(node, ast.ImportFrom)} | {
        alias.name for node in tree.body if isinstance(node, ast.Import) for alias in node.names
    }
    assert {name for name in imported if name.startswith("piezotip")} == {"piezotip.cosim.control.config"}
    # The built-ins register with the registry below them, never through the top-level package.
    for path in (ROOT / "cosim" / "control").glob("*.py"):
        assert "piezotip.controllers" not in {
            node.module for node in ast.walk(ast.parse(path.read_text())) if isinstance(node, ast.ImportFrom)
        }, path
    assert piezotip.controllers.register is registry.register and controllers._REGISTRY is registry._REGISTRY
    assert (controllers.Registration, controllers.get, controllers.names, controllers.configure) == (
        registry.Registration,
        registry.get,
        registry.names,
        registry.configure,
    )
    # In a fresh process, importing and asking the registry loads no top-level module beyond what
    # `import piezotip` does, and each way in (registry, a built-in, the public name) imports.
    code = (
        "import sys, piezotip; before = set(sys.modules)\n"
        "from piezotip.cosim.control import registry\n"
        "names = registry.names()\n"
        "top = sorted(m for m in set(sys.modules) - before if m.count('.') == 1 and m.startswith('piezotip.')\n"
        "             and m.split('.')[1] not in ('cosim', 'scenarios', 'sensor', 'analysis', 'models'))\n"
        "print(top, names)"
    )
    proc = _python(code)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["[]", "('multimode',", "'gentle',", "'scripted')"]
    for first in ("piezotip.cosim.control.gentle", "piezotip.controllers", "piezotip.cosim.control"):
        proc = _python(
            f"import importlib; importlib.import_module({first!r}); from piezotip import controllers; print(controllers.names())"
        )
        assert proc.returncode == 0 and proc.stdout.strip() == "('multimode', 'gentle', 'scripted')", (first, proc.stderr)


def test_a_module_class_kind_takes_its_own_registration_or_the_one_it_subclasses(tmp_path, monkeypatch, registry_restored):
    from piezotip.cosim.control import GentleGrasp

    monkeypatch.syspath_prepend(tmp_path)
    mod = _user_module(tmp_path, "regtest_usermod", own="regtest-own")
    mine = controllers.get(f"{mod}:Mine")  # an unregistered subclass of the gentle controller
    gentle = controllers.get("gentle")
    assert mine == controllers.Registration(f"{mod}:Mine", sys.modules[mod].Mine, GentleConfig, gentle.experiment, gentle.senses)
    assert issubclass(mine.controller, GentleGrasp) and mine.name in controllers.names()  # kept under its kind
    inner = controllers.get(f"{mod}:Outer.Inner")  # a dotted class: the scripted controller's
    assert (inner.controller, inner.config, inner.experiment, inner.senses) == (sys.modules[mod].Outer.Inner, ScriptedConfig, False, False)
    own = controllers.get(f"{mod}:Own")  # registered by its module as it was imported: its own config
    assert own.config is sys.modules[mod].OwnConfig and controllers.get("regtest-own").controller is own.controller
    assert controllers.configure(f"{mod}:Own") == sys.modules[mod].OwnConfig(kind=f"{mod}:Own")
    # The scenario's config records the kind as given, and every check of controller.kind takes it.
    config = scenarios.get("grasp", {"controller.kind": f"{mod}:Mine", "controller.persist": 4})
    assert config.controller == GentleConfig(kind=f"{mod}:Mine", persist=4)
    assert config.validate() is config
    with pytest.raises(ValueError, match=rf"'controller\.wait_s' for the {mod}:Mine controller \(GentleConfig\).*regtest-own"):
        scenarios.get("grasp", {"controller.kind": f"{mod}:Mine", "controller.wait_s": 1.0})


@pytest.mark.parametrize(
    ("kind", "message"),
    [
        (
            "regtest_usermod:NotController",
            r"controller\.kind 'regtest_usermod:NotController': regtest_usermod\.NotController must be a "
            r"registered controller or subclass one \(registered: multimode, gentle, scripted",
        ),
        ("regtest_usermod:Nope", r"controller\.kind 'regtest_usermod:Nope': module 'regtest_usermod' has no 'Nope'"),
        (
            "regtest_no_such_module:Mine",
            r"controller\.kind 'regtest_no_such_module:Mine': cannot import module 'regtest_no_such_module' "
            r"\(ModuleNotFoundError",
        ),
        ("regtest_broken:Mine", r"controller\.kind 'regtest_broken:Mine': cannot import module 'regtest_broken' \(ZeroDivisionError"),
        ("regtest_usermod:", r"controller\.kind 'regtest_usermod:': a controller class is given as MODULE:CLASS"),
    ],
)
def test_a_module_class_kind_that_names_no_controller_is_refused(tmp_path, monkeypatch, registry_restored, kind, message):
    monkeypatch.syspath_prepend(tmp_path)
    _user_module(tmp_path, "regtest_usermod", own="regtest-own")
    (tmp_path / "regtest_broken.py").write_text("1 / 0\n")
    before = controllers.names()
    with pytest.raises(ValueError, match=message):
        controllers.get(kind)
    with pytest.raises(ValueError, match=message):
        scenarios.get("grasp", {"controller.kind": kind})
    assert kind not in controllers.names()
    assert set(controllers.names()) - set(before) <= {"regtest-own"}  # the module's own registration, if it imported


def test_an_unknown_name_mentions_the_module_class_form_and_a_name_may_not_hold_a_colon():
    with pytest.raises(ValueError, match=r"controller\.kind must be one of multimode, gentle, scripted.*or MODULE:CLASS.*; got 'nope'"):
        scenarios.get("grasp", ["controller.kind=nope"])
    with pytest.raises(ValueError, match=r"name must be non-empty text without .*':'"):
        controllers.register("mine:x", config=HoldOpenConfig)


ENTRY_POINT_MODULE = (
    USER_MODULE
    + """

def not_a_class():
    pass
"""
)


def test_entry_points_register_controllers_and_a_broken_one_only_warns(tmp_path, monkeypatch, registry_restored):
    (tmp_path / "regtest_epmod.py").write_text(ENTRY_POINT_MODULE.replace("{own}", "regtest-epown"))
    dist = tmp_path / "regtest_fake_controllers-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: regtest-fake-controllers\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text(
        "[piezotip.controllers]\n"
        "regtest-epmine = regtest_epmod:Mine\n"
        "regtest-epown = regtest_epmod:Own\n"  # its module registers it under this name itself
        "regtest-missing = regtest_no_such_module:Mine\n"
        "regtest-notctl = regtest_epmod:not_a_class\n"
        "gentle = regtest_epmod:Mine\n"  # a built-in's name: refused
        "regtest-noclass = regtest_epmod\n"  # a module, no class
    )
    monkeypatch.syspath_prepend(tmp_path)
    monkeypatch.setattr(registry, "_builtins_loaded", False)  # as in a new process
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        found = controllers.names()
    skipped = sorted(str(w.message).split("'")[1] for w in caught)
    assert skipped == ["gentle", "regtest-missing", "regtest-noclass", "regtest-notctl"], [str(w.message) for w in caught]
    assert all(f"{registry.ENTRY_POINT_GROUP} entry point" in str(w.message) for w in caught)
    assert found[:3] == ("multimode", "gentle", "scripted")  # the built-ins first, untouched
    assert controllers.get("gentle").controller.__name__ == "GentleGrasp"
    epmine = controllers.get("regtest-epmine")
    assert (epmine.controller, epmine.config, epmine.experiment, epmine.senses) == (
        sys.modules["regtest_epmod"].Mine,
        GentleConfig,
        True,
        True,
    )
    assert controllers.get("regtest-epown").config is sys.modules["regtest_epmod"].OwnConfig
    assert controllers.configure("regtest-epmine") == GentleConfig(kind="regtest-epmine")


USERMOD = """
from piezotip.cosim.control.gentle import GentleGrasp


class Mine(GentleGrasp):
    pass
"""


def test_a_module_class_kind_runs_in_the_installed_command_and_a_sweeps_workers(tmp_path):
    script = shutil.which("piezotip", path=str(Path(sys.executable).parent))
    command = [script] if script is not None else [sys.executable, str(ROOT / "run_sim.py")]
    (tmp_path / "usermod.py").write_text(USERMOD)
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "MPLBACKEND": "Agg"}

    def piezotip_(*args: str) -> tuple[subprocess.Popen, dict]:
        proc = subprocess.Popen([*command, *args], cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        out, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err
        return proc, json.loads(out)

    kind = ["--set", "controller.kind=usermod:Mine", "--preset", "fast", "--json", "--no-plot"]
    _, run = piezotip_("run", "grasp", *kind, "--out", str(tmp_path / "run"))
    assert run["success"] and run["error"] is None
    assert run["config"]["controller"]["kind"] == "usermod:Mine"
    recorded = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert recorded["config"]["controller"]["kind"] == "usermod:Mine"
    proc, sweep = piezotip_(
        "sweep", "grasp", *kind, "--grid", "object.mass_kg=0.1,0.12", "--workers", "2", "--out", str(tmp_path / "sweep")
    )
    assert (sweep["points"], sweep["succeeded"], sweep["errors"], sweep["workers"]) == (2, 2, 0, 2)
    assert sweep["config"]["controller"]["kind"] == "usermod:Mine"
    assert all(row["success"] and row["pid"] != proc.pid for row in sweep["rows"])  # run by the workers


def test_a_module_class_kind_that_does_not_import_is_one_line_on_the_command_line(tmp_path):
    proc = subprocess.run(
        [
            sys.executable,
            "run_sim.py",
            "run",
            "grasp",
            "--set",
            "controller.kind=regtest_no_such_module:Mine",
            "--out",
            str(tmp_path / "o"),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert "controller.kind 'regtest_no_such_module:Mine': cannot import module 'regtest_no_such_module'" in proc.stderr

"""Issue 44, items 2, 5 and 11 (part): inputs that were silently wrong or crashed the interpreter.

* an episode of ``piezotip/Grasp-v0`` or ``piezotip/GraspFlat-v0`` that has ended (terminated
  or truncated) refuses another step until ``reset()``: no reward is paid twice;
* ``range --coverage`` with a coverage too short for any limit is exit 2, naming the value and
  what is needed (it printed every limit as null, or exit 3);
* a render size that is not a positive whole number of pixels is a ValueError naming it before
  MuJoCo's renderer is made (GLFW's assertion aborted the interpreter);
* without ``MUJOCO_GL`` and without a display the environment renders, again and again, through a
  headless backend (the second ``render()`` aborted the interpreter); a renderer that cannot be
  made is the same clear error every time;
* ``--scheduler`` addresses that cannot work (tls without certificates, ucx, inproc, no port, a
  port out of range, an unknown scheme, nobody there) and a scheduler lost in the middle of a
  sweep are exit 2 with one ``error:`` line naming the address;
* a Gym action is real numbers of the space's shape, or a ValueError naming it.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import gymnasium
import numpy as np
import pytest

import piezotip
from piezotip import cli
from piezotip.analysis import sweep_cluster
from piezotip.gym_env import GraspEnv
from piezotip.gym_flat import GraspFlatEnv

ROOT = Path(__file__).resolve().parent.parent


def _python(code: str, drop: tuple[str, ...] = (), timeout: float = 180, **env) -> subprocess.CompletedProcess:
    """``code`` in a fresh interpreter, with ``env`` added and the variables in ``drop`` unset."""
    base = {k: v for k, v in os.environ.items() if k not in drop}
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=timeout, env={**base, **env})


def _error_line(err: str) -> str:
    """The one line a failing command prints (a progress bar's carriage returns aside)."""
    lines = [line for line in err.replace("\r", "\n").splitlines() if line.strip() and not line.startswith("sweep")]
    assert len(lines) == 1, err
    assert lines[0].startswith("error: "), err
    return lines[0]


# -- 2a: no step past an episode's end ----------------------------------------------------------------


def _hold(env: GraspEnv) -> dict:
    return {"grip_force_n": [1.0], "opening_velocity_m_s": [0.0], "lift_velocity_m_s": [0.0], "mode": [0] * len(env.pads)}


def test_a_truncated_grasp_episode_refuses_another_step_until_reset():
    env = gymnasium.make("piezotip/Grasp-v0", overrides={"duration_s": 0.1}, preset="fast")
    env.reset(seed=0)
    action = _hold(env.unwrapped)
    for _ in range(env.unwrapped.total_steps):
        _, _, terminated, truncated, info = env.step(action)
    assert truncated and not terminated and info["ended"] == "duration"
    for _ in range(2):  # every time, not only once
        with pytest.raises(RuntimeError, match=r"ended .*duration.* call reset\(\)"):
            env.step(action)
    env.reset(seed=1)  # a new episode steps again
    _, _, terminated, truncated, _ = env.step(action)
    assert not (terminated or truncated)
    env.close()


def test_a_flat_episode_that_succeeded_pays_its_bonus_once_and_then_refuses_steps():
    env = gymnasium.make("piezotip/GraspFlat-v0", preset="fast")
    policy = piezotip.MultimodePolicy.for_env(env)
    env.reset(seed=0)
    paid = 0.0
    while True:
        action = env.unwrapped.action_from_grasp(policy(env.unwrapped.grasp_observation))
        _, _, terminated, truncated, info = env.step(action)
        paid += info.get("reward_success", 0.0)
        if terminated or truncated:
            break
    assert terminated and info["ended"] == "success" and paid == env.unwrapped.grasp_env.weights.success
    # Stepped on without a reset, it paid the bonus again within 20 steps; now it refuses.
    for _ in range(20):
        with pytest.raises(RuntimeError, match=r"ended .*success.* call reset\(\)"):
            env.step(action)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    env.step(env.unwrapped.action_from_grasp(policy(env.unwrapped.grasp_observation)))
    env.close()


def test_a_truncated_flat_episode_refuses_another_step():
    env = GraspFlatEnv(overrides={"duration_s": 0.1}, preset="fast")
    env.reset(seed=0)
    zero = np.zeros(env.action_space.shape, np.float32)
    for _ in range(env.grasp_env.total_steps):
        _, _, terminated, truncated, _ = env.step(zero)
    assert truncated and not terminated
    with pytest.raises(RuntimeError, match=r"call reset\(\)"):
        env.step(zero)
    env.close()


# -- 2b: range with a coverage too short for any limit ------------------------------------------------


@pytest.mark.parametrize(
    ("x1", "x2", "named"),
    [
        ("0", "1e-12", "at least 0.2 mm"),  # printed every limit as null, exit 0
        ("3", "3.001", "at least 0.2 mm"),  # exit 3: the stress model's beam saw no load (ZeroDivisionError)
        ("0", "0.2", "to at least 0.233 mm"),  # P_max null in every mode, exit 0
    ],
)
def test_a_coverage_too_short_for_limits_is_exit_2_naming_it_and_what_is_needed(capsys, x1, x2, named):
    for json_flag in ([], ["--json"]):
        assert cli.main(["range", "--coverage", x1, x2, *json_flag]) == 2
        out, err = capsys.readouterr()
        assert out == ""
        line = _error_line(err)
        assert f"--coverage {x1} {x2}" in line and named in line, line


def test_the_coverage_the_error_asks_for_has_a_range(capsys):
    assert cli.main(["range", "--coverage", "0", "0.2"]) == 2
    needed = _error_line(capsys.readouterr().err).split("--coverage 0 ")[-1].split(")")[0]
    assert cli.main(["range", "--json", "--coverage", "0", needed]) == 0
    report = json.loads(capsys.readouterr().out)
    assert math.isfinite(report["p_min_pa"]) and math.isfinite(report["p_max_pa"])


# -- 5a: render sizes ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("size", "named"),
    [
        ({"width": -1}, "width"),
        ({"height": 0}, "height"),
        ({"width": 64.5}, "width"),
        ({"width": "640"}, "width"),
        ({"height": True}, "height"),
        ({"width": 100_000}, "width"),
        ({"height": float("nan")}, "height"),
    ],
)
@pytest.mark.parametrize("cls", [GraspEnv, GraspFlatEnv])
def test_a_bad_render_size_is_a_value_error_naming_it(cls, size, named):
    with pytest.raises(ValueError, match=rf"^{named} must be a whole number of pixels in 1\.\.\d+, got "):
        cls(preset="fast", render_mode="rgb_array", **size)


def test_a_bad_render_size_never_reaches_glfw():
    """It aborted the interpreter (GLFW's assertion on a negative size), on a display or not."""
    code = (
        "import gymnasium, piezotip\n"
        "try:\n"
        "    env = gymnasium.make('piezotip/Grasp-v0', preset='fast', render_mode='rgb_array', width=-1)\n"
        "    env.reset(seed=0); env.render()\n"
        "except ValueError as err:\n"
        "    print('ValueError', err)\n"
    )
    result = _python(code, MUJOCO_GL="glfw")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("ValueError width must be"), result.stdout


# -- 5b: rendering without MUJOCO_GL on a machine without a display ------------------------------------

_NO_DISPLAY = ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY")

_RENDER_TWICE = (
    "import gymnasium, piezotip\n"
    "from gymnasium.utils.env_checker import check_env\n"
    "env = gymnasium.make('piezotip/Grasp-v0', overrides={'duration_s': 0.1}, preset='fast', render_mode='rgb_array',\n"
    "                     width=64, height=48)\n"
    "env.reset(seed=0)\n"
    "for _ in range(2):\n"
    "    try:\n"
    "        img = env.render(); print('image', img.shape, img.dtype, int(img.std() > 5))\n"
    "    except Exception as err:\n"
    "        print('raised', type(err).__name__, err)\n"
)


def _headless_backends() -> list[str]:
    """The headless OpenGL backends that render on this machine (MUJOCO_GL set explicitly)."""
    found = []
    for backend in ("egl", "osmesa"):
        result = _python(_RENDER_TWICE, drop=_NO_DISPLAY, MUJOCO_GL=backend)
        if result.returncode == 0 and result.stdout.count("image (48, 64, 3) uint8 1") == 2:
            found.append(backend)
    return found


def test_without_mujoco_gl_and_without_a_display_it_renders_again_and_again():
    if not _headless_backends():
        pytest.skip("neither MUJOCO_GL=egl nor MUJOCO_GL=osmesa renders on this machine")
    result = _python(_RENDER_TWICE + "check_env(env.unwrapped)\nprint('check_env passed')\n", drop=_NO_DISPLAY)
    assert result.returncode == 0, f"exit {result.returncode}: {result.stderr[-2000:]}"
    assert result.stdout.count("image (48, 64, 3) uint8 1") == 2, result.stdout
    assert "check_env passed" in result.stdout


def test_a_renderer_that_cannot_be_made_is_the_same_clear_error_every_time():
    """GLFW asked for explicitly, no display: the first render failed clearly, the second aborted."""
    result = _python(_RENDER_TWICE, drop=_NO_DISPLAY, MUJOCO_GL="glfw")
    assert result.returncode == 0, f"exit {result.returncode}: {result.stderr[-2000:]}"
    lines = result.stdout.strip().splitlines()
    assert len(lines) == 2 and lines[0] == lines[1], lines
    assert lines[0].startswith("raised RendererUnavailable") and "MUJOCO_GL='glfw'" in lines[0] and "MUJOCO_GL=egl" in lines[0]


def test_mujoco_imported_first_with_glfw_and_no_display_is_named_before_mujoco_is_asked():
    """MuJoCo imported before the environment has chosen GLFW for good: no headless backend can be
    chosen any more, and the error says why without trying (its failed try poisons the next)."""
    result = _python("import mujoco\n" + _RENDER_TWICE, drop=_NO_DISPLAY)
    assert result.returncode == 0, f"exit {result.returncode}: {result.stderr[-2000:]}"
    lines = result.stdout.strip().splitlines()
    assert len(lines) == 2 and lines[0] == lines[1], lines
    assert lines[0].startswith("raised RendererUnavailable cannot render: MuJoCo's OpenGL backend is GLFW, which needs a display"), lines[0]
    assert "MUJOCO_GL counts only before MuJoCo's first import" in lines[0]


def test_the_backend_is_chosen_only_where_there_is_no_display_and_none_is_named():
    from piezotip.analysis.video import headless_backend

    linux = sys.platform.startswith("linux")
    assert headless_backend({"MUJOCO_GL": "glfw"}, imported=False) is None  # the user's choice
    assert headless_backend({"DISPLAY": ":0"}, imported=False) is None  # a display: GLFW works
    assert headless_backend({"WAYLAND_DISPLAY": "wayland-0"}, imported=False) is None
    assert headless_backend({}, imported=True) is None  # MuJoCo has chosen already
    assert headless_backend({}, imported=False, find=lambda name: None) is None  # nothing headless here
    if linux:
        libraries = {"EGL": "libEGL.so.1", "GL": "libGL.so.1", "OSMesa": "libOSMesa.so.8"}

        def only(*names):
            return lambda name: libraries[name] if name in names else None

        assert headless_backend({}, imported=False, find=only("EGL", "GL", "OSMesa")) == "egl"
        assert headless_backend({}, imported=False, find=only("EGL")) is None  # PyOpenGL's EGL platform needs a GL too
        assert headless_backend({"PYOPENGL_PLATFORM": "osmesa"}, imported=False, find=only("EGL", "GL", "OSMesa")) == "osmesa"
        assert headless_backend({"PYOPENGL_PLATFORM": "glx"}, imported=False, find=only("EGL", "GL")) is None
        assert headless_backend({}, imported=False, find=lambda name: "libOSMesa.so.8" if name == "OSMesa" else None) == "osmesa"


# -- 5c: scheduler addresses --------------------------------------------------------------------------

_SWEEP = ["sweep", "grasp", "--grid", "object.mass_kg=0.05,0.2", "--preset", "fast", "--json"]


@pytest.mark.parametrize(
    ("address", "named"),
    [
        ("tls://127.0.0.1:1", "TLS"),  # exit 3: TypeError from Dask's TLS connector
        ("ucx://127.0.0.1:1", "distributed-ucxx"),  # exit 3: Dask's UCX stub
        ("inproc://x", "in-process"),  # "not enough values to unpack"
        ("wss://127.0.0.1:1", "TLS"),
        ("tcp://127.0.0.1", "port"),
        ("tcp://127.0.0.1:99999", "port"),
        ("tcp://:8786", "host"),
        ("foo://127.0.0.1:1", "scheme"),
    ],
)
def test_a_scheduler_address_that_cannot_work_is_one_error_line_at_once(capsys, tmp_path, address, named):
    start = time.perf_counter()
    assert cli.main([*_SWEEP, "--scheduler", address, "--out", str(tmp_path / "out")]) == 2
    elapsed = time.perf_counter() - start
    out, err = capsys.readouterr()
    line = _error_line(err)
    assert line.startswith(f"error: --scheduler {address}: ") and named in line, line
    assert out == "" and elapsed < 5.0  # refused before any connection is tried


def test_nobody_at_the_address_is_named_within_the_connect_timeout(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(sweep_cluster, "CONNECT_TIMEOUT_S", 1.0)
    start = time.perf_counter()
    assert cli.main([*_SWEEP, "--scheduler", "tcp://127.0.0.1:1", "--out", str(tmp_path / "out")]) == 2
    assert time.perf_counter() - start < 5.0
    line = _error_line(capsys.readouterr().err)
    assert line.startswith("error: --scheduler tcp://127.0.0.1:1: ") and "1 s" in line, line


def test_a_server_that_is_not_a_dask_scheduler_is_named_within_twice_the_timeout(capsys, tmp_path, monkeypatch):
    """A listening socket that never answers Dask's handshake (a web server, the dashboard's
    port) kept the client waiting for ever: Dask bounds the connection, not the handshake."""
    import socket

    monkeypatch.setattr(sweep_cluster, "CONNECT_TIMEOUT_S", 1.0)
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
        start = time.perf_counter()
        assert cli.main([*_SWEEP, "--scheduler", address, "--out", str(tmp_path / "out")]) == 2
        assert time.perf_counter() - start < 5.0
    line = _error_line(capsys.readouterr().err)
    assert line.startswith(f"error: --scheduler {address}: ") and "did not answer as a Dask scheduler within 2 s" in line, line


#: A Dask scheduler on loopback that dies (as a machine would) 0.2 s after it is given work.
_DYING_SCHEDULER = """
import asyncio, os
from distributed import Scheduler
from distributed.diagnostics.plugin import SchedulerPlugin

class DieOnWork(SchedulerPlugin):
    def update_graph(self, scheduler, **kwargs):
        asyncio.get_running_loop().call_later(0.2, os._exit, 0)

async def main():
    async with Scheduler(host="127.0.0.1", port=0, dashboard_address=None) as scheduler:
        scheduler.add_plugin(DieOnWork())
        print(scheduler.address, flush=True)
        await asyncio.sleep(120)

asyncio.run(main())
"""


def test_a_scheduler_lost_in_the_middle_of_a_sweep_is_one_error_line(tmp_path):
    command = [sys.executable, "-c", _DYING_SCHEDULER]
    server = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        address = server.stdout.readline().strip()
        assert address.startswith("tcp://127.0.0.1:"), address
        out = tmp_path / "out"
        argv = [sys.executable, "run_sim.py", *_SWEEP[:-1], "--scheduler", address, "--out", str(out)]
        start = time.perf_counter()
        result = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True, timeout=120)
        elapsed = time.perf_counter() - start
    finally:
        server.kill()
        server.wait()
    assert result.returncode == 2, result.stderr
    line = _error_line(result.stderr)  # not a 33-line asyncio traceback
    assert line.startswith(f"error: --scheduler {address}: lost the connection to the Dask scheduler"), line
    assert "resume" in line and elapsed < 30.0
    # The points it never ran are not journaled as failures: the same command runs them again.
    journal = out / "points.jsonl"
    assert not journal.exists() or not journal.read_text().strip()


# -- 11 (part): Gym actions are real numbers of the space's shape ------------------------------------


@pytest.fixture(scope="module")
def flat():
    env = GraspFlatEnv(preset="fast")
    env.reset(seed=0)
    yield env
    env.close()


@pytest.fixture(scope="module")
def grasp():
    env = GraspEnv(preset="fast")
    env.reset(seed=0)
    yield env
    env.close()


@pytest.mark.parametrize(
    "bad",
    [
        ["0.1", "0", "0", "0", "0"],  # strings were read as numbers
        np.array(["0.1", "0", "0", "0", "0"]),
        np.zeros(5, complex),  # complex numbers lost their imaginary part
        [0.5j, 0, 0, 0, 0],
        {"grip": 0.1},  # a dict was a TypeError
        [True, False, False, False, False],
        "0.1 0 0 0 0",
        [[0.1], [0], [0], [0], [0]],
        [0.1, 0, 0, 0],
        [0.1, 0, 0, 0, [0]],
        [0.1, 0, 0, 0, None],
        [0.1, 0, 0, 0, np.nan],
        [0.1, 0, 0, 0, -np.inf],
    ],
)
def test_a_flat_action_that_is_not_real_numbers_of_its_shape_is_a_value_error_naming_it(flat, bad):
    with pytest.raises(ValueError, match=r"^action must be .*, got ") as err:
        flat.step(bad)
    assert len(str(err.value)) < 600


def test_flat_actions_of_any_real_number_type_are_taken(flat):
    flat.reset(seed=0)
    for good in ([0, 0, 0, 0, 0], np.zeros(5, np.int8), np.zeros(5, np.float16), np.full(5, 2.0), [-1.0, 0.5, 0, 1, 1]):
        obs, *_ = flat.step(good)
        assert flat.observation_space.contains(obs)


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("grip_force_n", ["1.0"]),
        ("grip_force_n", "1.0"),
        ("grip_force_n", [1 + 1j]),
        ("grip_force_n", {"n": 1.0}),
        ("grip_force_n", [True]),
        ("lift_velocity_m_s", [None]),
        ("opening_velocity_m_s", np.array([0.0 + 0.0j])),
        ("mode", ["0", "0"]),
        ("mode", np.array([0, 1j])),
        ("mode", [True, False]),
        ("mode", {"left": 0, "right": 0}),
        ("mode", [0, 0.5]),
        ("mode", [0, np.nan]),
    ],
)
def test_a_grasp_action_part_that_is_not_real_numbers_is_a_value_error_naming_it(grasp, key, value):
    action = {**_hold(grasp), key: value}
    with pytest.raises(ValueError, match=rf"^action\['{key}'\] must be .*, got ") as err:
        grasp.step(action)
    assert len(str(err.value)) < 600


def test_a_grasp_action_that_is_not_a_dict_is_a_value_error(grasp):
    for bad in ([1.0, 0.0, 0.0, 0, 0], "grip", None, np.zeros(5)):
        with pytest.raises(ValueError, match=r"^action must be a dict with keys"):
            grasp.step(bad)


def test_grasp_actions_of_any_real_number_type_are_taken(grasp):
    grasp.reset(seed=0)
    for part in ([0.5], np.float32([0.5]), np.int64([1]), 0.5, 1):
        action = {**_hold(grasp), "grip_force_n": part, "mode": np.array([1.0, 0.0])}
        obs, *_ = grasp.step(action)
        assert grasp.observation_space.contains(obs)


# -- a gripper file's <include>: read from the file's own folder (issue 44, item 4) ----------------

_PART_XML = """<mujoco><worldbody><body name="{name}"><geom size=".01"/></body></worldbody></mujoco>"""


def test_a_gripper_files_include_is_read_from_its_own_folder_not_the_working_one(tmp_path, monkeypatch):
    """MuJoCo resolves a file's ``<include>`` against the file's folder; the mount read the file
    as a string, so the working folder's file of that name was merged in (or none found)."""
    from piezotip.cosim.gripper_mount import load_gripper_spec

    gripper = tmp_path / "gripper"
    (gripper / "parts").mkdir(parents=True)
    (gripper / "hand.xml").write_text('<mujoco model="hand"><include file="parts/finger.xml"/></mujoco>')
    # A nested include, named from the including file's folder (MuJoCo also takes it from the top file's).
    (gripper / "parts" / "finger.xml").write_text('<mujoco><include file="tip.xml"/>' + _PART_XML.format(name="finger")[8:])
    (gripper / "parts" / "tip.xml").write_text(_PART_XML.format(name="tip"))
    elsewhere = tmp_path / "elsewhere"
    (elsewhere / "parts").mkdir(parents=True)
    (elsewhere / "parts" / "finger.xml").write_text(_PART_XML.format(name="decoy"))  # a file of the same name where the user runs
    monkeypatch.chdir(elsewhere)
    names = {body.name for body in load_gripper_spec(gripper / "hand.xml").bodies}
    assert {"finger", "tip"} <= names and "decoy" not in names  # nested includes too, against the gripper file's folder
    (gripper / "parts" / "tip.xml").unlink()
    (gripper / "hand.xml").write_text('<mujoco model="hand2"><include file="parts/finger.xml"/></mujoco>')  # a new reading
    with pytest.raises(ValueError, match=r"hand\.xml.*tip\.xml.*cannot be read"):
        load_gripper_spec(gripper / "hand.xml")


def test_a_mounted_gripper_split_by_include_grasps_from_any_working_folder(tmp_path, monkeypatch):
    """robosuite's Panda as a file that includes its body from beside it, run from another folder."""
    from test_third_party_grippers import _robosuite_grippers  # found without importing robosuite

    source = _robosuite_grippers()
    wrapper_dir = tmp_path / "grippers"
    (wrapper_dir / "parts").mkdir(parents=True)
    (wrapper_dir / "parts" / "meshes").symlink_to(source / "meshes")  # an included file's meshes: its own folder's (MuJoCo's rule)
    (wrapper_dir / "parts" / "panda_gripper.xml").write_text((source / "panda_gripper.xml").read_text())
    wrapper = wrapper_dir / "panda_wrapper.xml"
    wrapper.write_text('<mujoco model="wrapped panda"><include file="parts/panda_gripper.xml"/></mujoco>')
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "panda_gripper.xml").write_text("<mujoco/>")  # a decoy where the user runs
    monkeypatch.chdir(tmp_path)
    overrides = {
        "gripper.mjcf": str(wrapper),
        "gripper.fingertips": ["finger_joint1_tip", "finger_joint2_tip"],
        "gripper.actuators": ["gripper_finger_joint1", "gripper_finger_joint2"],
    }
    result = piezotip.run("grasp", overrides=overrides, preset="fast")
    assert result.outcome == "success", result.reason

"""Packaging: the install without a C compiler, the typed public names, the package's files.

- setup.py's kernels are optional: a kernel whose C does not compile (no compiler, no Python
  headers) is left out with a warning and its ``.py`` runs (``CC=false pip install .``; .ci/run
  installs a fresh clone so and grasps with it).  Cython's ``cythonize()`` drops the
  ``optional=True`` it is given, so setup.py sets it again and its ``build_ext`` catches a
  failed compile itself.
- Type checkers see ``piezotip.run``, ``sweep``, ``attach``, ``GraspEnv``, ... as what they are
  (piezotip/__init__.py's ``TYPE_CHECKING`` block; the runtime loads them lazily), and the
  package ships ``py.typed``: mypy on a user's script resolves them.
"""

from __future__ import annotations

import ast
import importlib
import importlib.metadata
import importlib.resources
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tomllib
from pathlib import Path

import pytest

import piezotip

ROOT = Path(__file__).resolve().parents[1]
SETUP_PY = ROOT / "setup.py"
needs_setup_py = pytest.mark.skipif(not SETUP_PY.is_file(), reason="no setup.py beside the tests")


def pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


# -- setup.py: the kernels are optional -----------------------------------------------------


def load_setup():
    """setup.py as a module, without running ``setup()`` (it runs only as ``__main__``)."""
    spec = importlib.util.spec_from_file_location("piezotip_setup", SETUP_PY)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@needs_setup_py
def test_setup_py_declares_every_kernel_optional():
    from piezotip.sensor import compiled

    setup = load_setup()
    extensions = setup.kernel_extensions()
    c_only = [f"piezotip.{folder.replace('/', '.')}.{name}" for folder, name in setup.C_ONLY]
    assert sorted(e.name for e in extensions) == sorted([*compiled.KERNELS, *c_only])
    assert all(e.optional for e in extensions)


@needs_setup_py
def test_what_cythonize_returns_is_made_optional_again(monkeypatch):
    """``cythonize()`` returns new Extension objects, ``optional`` False (Cython 3.0-3.3): a
    stand-in that does the same shows setup.py marks them optional again."""
    import types

    from setuptools import Extension

    def cythonize(extensions, **options):  # as Cython's: new objects, C sources, optional dropped
        return [Extension(e.name, [s.rsplit(".", 1)[0] + ".c" for s in e.sources]) for e in extensions]

    monkeypatch.setitem(sys.modules, "Cython", types.ModuleType("Cython"))
    monkeypatch.setitem(sys.modules, "Cython.Build", types.SimpleNamespace(cythonize=cythonize))
    setup = load_setup()
    monkeypatch.setattr(setup, "stage_declarations", lambda: None)
    built = setup.compiled_extensions()
    assert len(built) == len(setup.KERNELS) + len(setup.C_ONLY) and all(e.sources[0].endswith(".c") for e in built)
    assert all(e.optional for e in built)
    assert not any(e.optional for e in cythonize(setup.kernel_extensions()))  # the stand-in drops it


@needs_setup_py
def test_the_real_cythonize_needs_the_flag_set_again(tmp_path, monkeypatch):
    """Where Cython is installed: its ``cythonize()`` really drops ``optional`` (why setup.py sets it again)."""
    pytest.importorskip("Cython")
    from Cython.Build import cythonize
    from setuptools import Extension

    monkeypatch.chdir(tmp_path)
    Path("probe.py").write_text("def f(x):\n    return x + 1\n")
    setup = load_setup()
    built = cythonize([Extension("probe", ["probe.py"], optional=True)], quiet=True)
    if built[0].optional:
        pytest.skip("this Cython keeps optional=True")
    assert all(e.optional for e in setup.optional(built))


def build_ext_with(tmp_path, monkeypatch, command_class, sources: dict[str, str], compiler: str | None):
    """Run ``command_class`` (a build_ext) on one extension per ``sources`` item (name: C code),
    none marked optional, with ``CC=compiler``; the command and the built files."""
    from setuptools import Distribution, Extension

    monkeypatch.chdir(tmp_path)
    if compiler is not None:
        monkeypatch.setenv("CC", compiler)
    extensions = []
    for name, code in sources.items():
        Path(f"{name}.c").write_text(code)
        extensions.append(Extension(name, [f"{name}.c"]))
    dist = Distribution({"name": "probe", "ext_modules": extensions, "cmdclass": {"build_ext": command_class}})
    command = dist.get_command_obj("build_ext")
    command.build_lib, command.build_temp = str(tmp_path / "lib"), str(tmp_path / "temp")
    dist.run_command("build_ext")
    return command, sorted(p.name.split(".")[0] for p in (tmp_path / "lib").glob("*.*"))


GOOD_C = """#include <Python.h>
static struct PyModuleDef def = {PyModuleDef_HEAD_INIT, "good", NULL, -1, NULL};
PyMODINIT_FUNC PyInit_good(void) { return PyModule_Create(&def); }
"""


@needs_setup_py
def test_a_build_without_a_compiler_goes_on_without_the_kernels(tmp_path, monkeypatch):
    """``CC=false``: every compile fails; the build finishes, names each kernel left out, builds none."""
    setup = load_setup()
    warnings = []
    monkeypatch.setattr(setup.OptionalBuildExt, "warn", lambda self, message: warnings.append(message))
    command, built = build_ext_with(tmp_path, monkeypatch, setup.OptionalBuildExt, {"good": GOOD_C, "other": GOOD_C}, "false")
    assert command.failed == ["good", "other"] and built == []
    assert any("good was not compiled" in w for w in warnings) and any("2 of 2 kernels not compiled" in w for w in warnings)


@needs_setup_py
def test_setuptools_own_build_ext_fails_there(tmp_path, monkeypatch):
    """The same build with setuptools' own build_ext stops (what setup.py's catches)."""
    from setuptools.command.build_ext import build_ext
    from setuptools.errors import CompileError

    with pytest.raises(CompileError):
        build_ext_with(tmp_path, monkeypatch, build_ext, {"good": GOOD_C}, "false")


@needs_setup_py
def test_with_a_compiler_each_kernel_that_compiles_is_built(tmp_path, monkeypatch):
    """A working compiler: what compiles is built, and only a broken one is left out."""
    if shutil.which(sysconfig.get_config_var("CC").split()[0]) is None:
        pytest.skip("no C compiler")
    if not (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file():
        pytest.skip("no Python headers")
    setup = load_setup()
    monkeypatch.setattr(setup.OptionalBuildExt, "warn", lambda self, message: None)
    command, built = build_ext_with(tmp_path, monkeypatch, setup.OptionalBuildExt, {"good": GOOD_C, "broken": "this is not C"}, None)
    assert command.failed == ["broken"] and built == ["good"]


# -- the package's files ----------------------------------------------------------------------


def installed_as_files() -> bool:
    """Whether ``piezotip`` is imported from an installed copy laid out as the package (a
    wheel's), not from the repository through an editable install's import hook."""
    return (Path(piezotip.__file__).parent / "sensor" / "__init__.py").is_file()


def test_py_typed_is_installed():
    """PEP 561's marker: in the package, and declared as its data (so every wheel carries it)."""
    assert importlib.resources.files("piezotip").joinpath("py.typed").is_file()
    assert "py.typed" in pyproject()["tool"]["setuptools"]["package-data"]["piezotip"]
    if installed_as_files():  # and listed in what the install wrote, with no C sources
        package = Path(piezotip.__file__).parent
        for dist in importlib.metadata.distributions(name="piezotip"):
            if Path(dist.locate_file("piezotip/__init__.py")).resolve() == Path(piezotip.__file__).resolve():
                installed = [str(f) for f in dist.files or []]
                assert "piezotip/py.typed" in installed
                assert not [f for f in installed if f.endswith(".c")], "the install carries Cython's C sources"
        assert not list(package.rglob("*.c"))


def test_the_license_is_the_one_declared():
    project = pyproject()["project"]
    assert project["license"] == "MIT" and project["license-files"] == ["LICENSE"]
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License\n") and "Copyright (c) 2026 piezotip developers" in text


def test_the_wheel_leaves_out_the_c_and_the_sdist_holds_the_docs():
    assert "*.c" in pyproject()["tool"]["setuptools"]["exclude-package-data"]["*"]
    manifest = (ROOT / "MANIFEST.in").read_text().split("\n")
    assert {"graft docs", "graft examples", "graft tests"} <= set(manifest)
    assert any(line.startswith("global-exclude") and "*.c" in line.split() for line in manifest)


# -- the public names, for type checkers --------------------------------------------------------


def type_checking_imports() -> dict[str, str]:
    """piezotip/__init__.py's ``if TYPE_CHECKING:`` block: name -> the module it is imported from."""
    tree = ast.parse(Path(piezotip.__file__).read_text())
    blocks = [n for n in tree.body if isinstance(n, ast.If) and isinstance(n.test, ast.Name) and n.test.id == "TYPE_CHECKING"]
    assert len(blocks) == 1
    names = {}
    for node in blocks[0].body:
        assert isinstance(node, ast.ImportFrom)
        for alias in node.names:
            assert alias.asname == alias.name, f"{alias.name}: re-export it as itself (import X as X)"
            names[alias.name] = f"{node.module}.{alias.name}" if node.module == "piezotip" else node.module
    return names


def test_type_checkers_and_the_runtime_see_the_same_names():
    """Each lazy export is in ``__all__`` and in the TYPE_CHECKING block, imported from the module
    that the runtime loads it from, and is that object at runtime."""
    lazy = {**piezotip._API, **{name: f"piezotip.{name}" for name in piezotip._SUBMODULES}}
    assert sorted(piezotip.__all__) == sorted([*lazy, "__version__"])
    assert type_checking_imports() == lazy
    for name, module in piezotip._API.items():
        assert getattr(piezotip, name) is getattr(importlib.import_module(module), name)
    assert piezotip.controllers is importlib.import_module("piezotip.controllers")
    with pytest.raises(AttributeError, match="no attribute 'rnu'"):
        piezotip.rnu  # noqa: B018


def test_the_type_checking_block_costs_no_import():
    """``TYPE_CHECKING`` is a literal False at runtime: ``import piezotip`` imports neither
    ``typing`` (about 2 ms) nor any module the block names, only itself and its Gymnasium hook."""
    code = "import sys; before = set(sys.modules); import piezotip; print(sorted(set(sys.modules) - before))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    imported = json.loads(out.stdout.replace("'", '"'))
    assert [m for m in imported if m.startswith("piezotip")] == ["piezotip", "piezotip.gym_registration"]
    assert "typing" not in imported


USER_SCRIPT = """\
import mujoco

import piezotip


def main() -> None:
    result = piezotip.run("grasp", overrides={"object.mass_kg": 0.4}, preset="fast")
    print(result.outcome, result.reason, result.summary["max_pressure_pa"])
    rows = piezotip.sweep("grasp", {"object.mass_kg": [0.05, 0.2]}, preset="fast")
    print([row["outcome"] for row in rows])
    tip = piezotip.fingertip("grasp")
    print(tip.dynamic_range()["dynamic_range"])
    spec = mujoco.MjSpec.from_file("my_robot.xml")
    tips = piezotip.attach(spec, sites=["left_pad", "right_pad"])
    model = spec.compile()
    sim = tips.bind(model, mujoco.MjData(model))
    sim.step()
    env = piezotip.GraspEnv(preset="fast")
    observation, info = env.reset(seed=0)
    env.close()
    print(piezotip.scenario_names(), piezotip.__version__, piezotip.controllers)


if __name__ == "__main__":
    main()
"""

#: What the public names reveal as, and two misuses a checker must catch (not ``Any``).
PROBE_SCRIPT = """\
import piezotip

reveal_type(piezotip.run)
reveal_type(piezotip.sweep)
reveal_type(piezotip.attach)
reveal_type(piezotip.GraspEnv)
reveal_type(piezotip.fingertip)
piezotip.run(42)
piezotip.rnu("grasp")
"""


def mypy_view(tmp_path: Path) -> Path | None:
    """Where mypy finds the package: None where it is installed as files (site-packages, with its
    py.typed); for an editable install (an import hook mypy cannot follow, and the repository's
    layout is not the package's), a folder laid out as the package, of links to its folders."""
    if installed_as_files():
        return None
    setuptools = pyproject()["tool"]["setuptools"]
    view = tmp_path / "view"
    for package, folder in sorted(setuptools["package-dir"].items()):  # "piezotip" first
        target = view.joinpath(*package.split("."))
        if package == "piezotip":
            target.mkdir(parents=True)
            for entry in (ROOT / folder).iterdir():
                (target / entry.name).symlink_to(entry)
        else:
            target.unlink(missing_ok=True)
            target.symlink_to(ROOT / folder, target_is_directory=True)
    assert all(view.joinpath(*package.split(".")).is_dir() for package in setuptools["packages"])
    return view


@pytest.mark.slow
def test_mypy_resolves_the_public_names(tmp_path):
    """mypy on a user's script: no "not callable", no missing attribute, the package not skipped;
    ``run``, ``sweep``, ``attach``, ``GraspEnv`` and ``fingertip`` are their signatures (not
    ``Any``, which hides every misuse), and a wrong argument or a misspelt name is reported."""
    if importlib.util.find_spec("mypy") is None:
        pytest.skip("mypy is not installed (pip install -e '.[dev]')")
    work = tmp_path / "work"
    work.mkdir()
    (work / "user.py").write_text(USER_SCRIPT)
    (work / "probe.py").write_text(PROBE_SCRIPT)
    (work / "mypy.ini").write_text("[mypy]\n[mypy-mujoco.*]\nignore_missing_imports = True\n")
    view = mypy_view(tmp_path)
    env = {k: v for k, v in os.environ.items() if k not in ("MYPYPATH", "PYTHONPATH")}
    args = [sys.executable, "-m", "mypy", "--config-file", "mypy.ini", "--cache-dir", str(tmp_path / "cache"), "--no-error-summary"]
    if view is not None:  # the package as source: its own modules' findings are not the user's
        env["MYPYPATH"] = str(view)
        args += ["--follow-imports", "silent"]
    result = subprocess.run([*args, "user.py", "probe.py"], capture_output=True, text=True, cwd=work, env=env, timeout=600)
    lines = result.stdout.splitlines()
    assert not result.stderr.strip(), result.stderr
    user = [line for line in lines if line.startswith("user.py")]
    bad = re.compile(r"not callable|has no attribute|Module|piezotip|import-untyped|import-not-found")
    assert not [line for line in user if bad.search(line)], "\n".join(user)
    assert not user, "\n".join(user)  # the whole script type-checks
    revealed = [line.split('Revealed type is "', 1)[1].removesuffix('"') for line in lines if "Revealed type is" in line]
    assert len(revealed) == 5 and all(r.startswith("def (") for r in revealed), "\n".join(lines)
    assert revealed[0].endswith("-> piezotip.api.Result") and revealed[3].endswith("-> piezotip.gym_env.GraspEnv")
    assert any(line.startswith("probe.py:8:") and "[arg-type]" in line for line in lines), "\n".join(lines)
    assert any(line.startswith("probe.py:9:") and '"rnu"' in line for line in lines), "\n".join(lines)


def test_auto_workers_are_the_cpus_this_process_may_use_within_a_containers_quota(tmp_path, monkeypatch):
    """`-n auto` (the repository's conftest.py): 1.5 CPUs of quota on a host of many cores is one
    worker; no quota, the affinity's CPUs, at most ten; the environment's count is left to xdist."""
    spec = importlib.util.spec_from_file_location("root_conftest", ROOT / "conftest.py")
    conftest = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conftest)

    cpu_max = tmp_path / "cpu.max"
    cpu_max.write_text("150000 100000\n")
    assert conftest.cgroup_cpus(cpu_max) == 1.5
    cpu_max.write_text("max 100000\n")
    assert conftest.cgroup_cpus(cpu_max) == float("inf")
    assert conftest.cgroup_cpus(tmp_path / "none") == float("inf")
    monkeypatch.setattr(conftest, "cgroup_cpus", lambda: 1.5)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(64)), raising=False)
    monkeypatch.delenv("PYTEST_XDIST_AUTO_NUM_WORKERS", raising=False)
    assert conftest.pytest_xdist_auto_num_workers(None) == 1
    monkeypatch.setattr(conftest, "cgroup_cpus", lambda: float("inf"))
    assert conftest.pytest_xdist_auto_num_workers(None) == conftest.MAX_AUTO_WORKERS
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    assert conftest.pytest_xdist_auto_num_workers(None) == 2
    monkeypatch.setenv("PYTEST_XDIST_AUTO_NUM_WORKERS", "3")
    assert conftest.pytest_xdist_auto_num_workers(None) is None


def test_auto_workers_are_counted_alike_for_the_benchmarks_tests_alone():
    """`pytest benchmarks/tests` alone also counts `-n auto`'s workers by the CPUs this process may
    use: one CPU's affinity, one worker (tests/conftest.py served tests/ only, and there xdist
    counted the host's cores)."""
    if not hasattr(os, "sched_setaffinity") or shutil.which("taskset") is None:
        pytest.skip("needs CPU affinity (Linux's taskset)")
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_XDIST_AUTO_NUM_WORKERS"}
    test = "benchmarks/tests/test_instructions.py"
    cmd = ["taskset", "-c", "0", sys.executable, "-m", "pytest", test, "-k", "annotation", "-p", "no:cacheprovider"]
    run = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    assert re.search(r"\b1 worker\b", run.stdout), run.stdout[-2000:]

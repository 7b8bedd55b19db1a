"""The compiled parts of piezotip (everything else is declared in pyproject.toml).

The per-step kernels (:data:`KERNELS`; :mod:`piezotip.sensor.compiled` says what each does) are
Python modules, each the one source of its kernel.  Cython compiles each in its pure-Python
mode, typed by the ``.pxd`` file beside it, into an extension module of the same name that
Python imports in the ``.py`` file's place.  They are optional: where one cannot be built the
package installs without it and its ``.py`` runs (slower, the same numbers).

- ``CYTHON_CCOMPLEX=0``: Cython's ``double complex`` is its own struct, whose sum, difference,
  product and negation are CPython's formulas (C99's complex product and its real-times-complex
  differ from them in signed zeros, infinities and NaN); what else differs is spelled out in
  ``sensor/_kernel_helpers.pxd``.
- ``-ffp-contract=off``: no fused multiply-adds, so the C rounds as Python does.
- ``annotation_typing=False``: the ``.py`` files' annotations document; the types are the ``.pxd``'s.
- Cython finds a module's ``.pxd`` by its full name (``piezotip/sensor/_sampler.pxd``), which the
  repository's layout (``sensor/`` installed as ``piezotip.sensor``) does not have: the
  ``.pxd`` files are copied into ``build/kernel-declarations/piezotip/...`` (their times kept, so
  an edited one recompiles what cimports it), which Cython searches.
- Optional, twice over: ``cythonize()`` returns new ``Extension`` objects without the
  ``optional=True`` they were given (Cython 3.0 to 3.3), so it is set again on what it returns,
  and :class:`OptionalBuildExt` catches a kernel's failed compile or link (no C compiler, no
  Python headers: ``CC=false pip install .``), warns, and goes on with the next; that kernel's
  ``.py`` is then installed alone and runs.  ``tests/test_packaging.py`` builds with a failing
  compiler.
- The wheel carries no ``.c`` files (pyproject.toml's ``exclude-package-data``); the sdist holds
  the sources, docs/, examples/ and the tests (MANIFEST.in), and the build makes the C again.
"""

import shutil
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext
from setuptools.errors import BaseError, CCompilerError

#: (folder, module): each ``folder/module.py`` with ``folder/module.pxd`` beside it.
KERNELS = (
    ("sensor", "_sampler"),
    ("sensor", "_estimator"),
    ("sensor", "_inference"),
    ("sensor", "_channel"),
    ("cosim", "_pad_kernels"),
    ("cosim", "_period"),
    ("cosim", "_readout"),
    ("cosim", "_rows"),
    ("cosim/control", "_control"),
)

#: (folder, module): C-only extension modules, each ``folder/module.pyx``: glue whose Python
#: twin is another module (``cosim/_mjcallbacks.pyx``: MuJoCo's callbacks in C; without it, or
#: without the compiled kernel it cimports, ``cosim/mjhooks.py``'s ctypes dispatchers run),
#: optional as the kernels are.
C_ONLY = (("cosim", "_mjcallbacks"),)

#: Where the ``.pxd`` files are found by their modules' full names.
DECLARATIONS = Path("build") / "kernel-declarations"


def stage_declarations() -> None:
    """Copy every ``.pxd`` of the kernels' folders to :data:`DECLARATIONS`, under its module's
    full name (``sensor/x.pxd`` as ``piezotip/sensor/x.pxd``)."""
    for folder in sorted({folder for folder, _ in KERNELS}):
        target = DECLARATIONS / "piezotip" / folder
        target.mkdir(parents=True, exist_ok=True)
        for pxd in sorted(Path(folder).glob("*.pxd")):
            shutil.copy2(pxd, target / pxd.name)


def kernel_extensions() -> list[Extension]:
    """One optional extension module per kernel, from its ``.py`` (before Cython), and one per
    :data:`C_ONLY` module, from its ``.pyx``."""
    return [
        Extension(
            f"piezotip.{folder.replace('/', '.')}.{name}",
            [f"{folder}/{name}.py"],
            depends=[f"{folder}/{name}.pxd", "sensor/_kernel_helpers.pxd"],  # (in an sdist too)
            define_macros=[("CYTHON_CCOMPLEX", "0")],
            extra_compile_args=["-O2", "-ffp-contract=off"],
            optional=True,
        )
        for folder, name in KERNELS
    ] + [
        Extension(
            f"piezotip.{folder.replace('/', '.')}.{name}",
            [f"{folder}/{name}.pyx"],
            depends=[f"{f}/{n}.pxd" for f, n in KERNELS if Path(f"{f}/{n}.pxd").exists()] + ["sensor/_kernel_helpers.pxd"],
            define_macros=[("CYTHON_CCOMPLEX", "0")],  # as the kernels it cimports (their types' layout)
            extra_compile_args=["-O2", "-ffp-contract=off"],
            optional=True,
        )
        for folder, name in C_ONLY
    ]


def optional(extensions: list[Extension]) -> list[Extension]:
    """``extensions``, each marked optional (what ``cythonize()`` drops)."""
    for extension in extensions:
        extension.optional = True
    return extensions


def compiled_extensions() -> list[Extension]:
    """The kernels as Cython makes them: C sources, each extension optional."""
    from Cython.Build import cythonize  # a build requirement (pyproject.toml), not the tests'

    stage_declarations()
    directives = {"language_level": 3, "annotation_typing": False}
    return optional(cythonize(kernel_extensions(), include_path=[str(DECLARATIONS)], compiler_directives=directives, quiet=True))


class OptionalBuildExt(build_ext):
    """``build_ext`` that builds each kernel it can: a kernel whose compile or link fails is
    left out with a warning naming it and the error, and its ``.py`` runs in its place."""

    def initialize_options(self) -> None:
        super().initialize_options()
        self.failed: list[str] = []  # the kernels not compiled, by name

    def run(self) -> None:
        super().run()
        if self.failed:
            self.warn(
                f"piezotip: {len(self.failed)} of {len(self.extensions)} kernels not compiled ({', '.join(self.failed)}); "
                "their .py files run instead: the same numbers, slower (docs/performance.md#compiled-twins)"
            )

    def build_extension(self, ext: Extension) -> None:
        try:
            super().build_extension(ext)
        except (CCompilerError, BaseError) as error:  # compile, link, no compiler, no headers
            self.failed.append(ext.name)
            self.warn(f"piezotip: the kernel {ext.name} was not compiled ({type(error).__name__}: {error}); its .py runs instead")


if __name__ == "__main__":  # setuptools' build backend runs this file as __main__; the tests import it
    setup(ext_modules=compiled_extensions(), cmdclass={"build_ext": OptionalBuildExt})

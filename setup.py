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
"""

import shutil
from pathlib import Path

from Cython.Build import cythonize
from setuptools import Extension, setup

#: (folder, module): each ``folder/module.py`` with ``folder/module.pxd`` beside it.
KERNELS = (
    ("sensor", "_sampler"),
    ("sensor", "_estimator"),
    ("sensor", "_inference"),
    ("cosim", "_pad_kernels"),
    ("cosim", "_period"),
    ("cosim", "_rows"),
    ("cosim/control", "_control"),
)

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


stage_declarations()
extensions = [
    Extension(
        f"piezotip.{folder.replace('/', '.')}.{name}",
        [f"{folder}/{name}.py"],
        depends=[f"{folder}/{name}.pxd", "sensor/_kernel_helpers.pxd"],  # (in an sdist too)
        define_macros=[("CYTHON_CCOMPLEX", "0")],
        extra_compile_args=["-O2", "-ffp-contract=off"],
        optional=True,
    )
    for folder, name in KERNELS
]
directives = {"language_level": 3, "annotation_typing": False}
setup(ext_modules=cythonize(extensions, include_path=[str(DECLARATIONS)], compiler_directives=directives, quiet=True))

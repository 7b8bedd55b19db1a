"""The compiled parts of piezotip (everything else is declared in pyproject.toml).

``sensor/_inference.pyx`` (the readout's steady-reading inference), ``sensor/_lookup.pyx``
(the pads' gel-law lookup), ``sensor/_sampler.pyx`` (a channel's reading),
``sensor/_estimator.pyx`` (the inverse of an inferred reading), ``cosim/_pad_kernels.pyx``
(the gel law on the pad joints, the pads' pressure read), ``cosim/_rows.pyx`` (a control
step's recorded row) and ``cosim/control/_control.pyx`` (the controller's mode selector,
touch detector and per-step records) are statement-for-statement C twins
of Python references (:mod:`piezotip.sensor.compiled` lists them).  They are optional: where
they cannot be built the package installs without them and the references run (slower, the
same numbers).
``-ffp-contract=off``: no fused multiply-adds, so the C arithmetic rounds as Python's does (the
twins agree bit for bit).
"""

from Cython.Build import cythonize
from setuptools import Extension, setup

extensions = [
    Extension(
        f"piezotip.{package.replace('/', '.')}.{name}",
        [f"{package}/{name}.pyx"],
        extra_compile_args=["-O2", "-ffp-contract=off"],
        optional=True,
    )
    for package, name in (
        ("sensor", "_inference"),
        ("sensor", "_lookup"),
        ("sensor", "_sampler"),
        ("sensor", "_estimator"),
        ("cosim", "_pad_kernels"),
        ("cosim", "_rows"),
        ("cosim/control", "_control"),
    )
]

# sensor/ on the include path: the twins cimport their shared inline helpers (_twin_helpers.pxd)
# by its own name (Cython would look for a relative cimport under piezotip/sensor/, which the
# repository's layout does not have).
setup(ext_modules=cythonize(extensions, include_path=["sensor"], compiler_directives={"language_level": 3}, quiet=True))

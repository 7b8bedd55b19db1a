"""The compiled parts of piezotip (everything else is declared in pyproject.toml).

``sensor/_inference.pyx`` is the readout's steady-reading inference in C, a statement-for-
statement twin of :class:`piezotip.sensor.inference.PySteadyInference` (the reference). It is
optional: where it cannot be built the package installs without it and the readout runs the
Python reference (slower, the same numbers).  ``-ffp-contract=off``: no fused multiply-adds,
so the C arithmetic rounds as Python's does (the twins agree bit for bit).
"""

from Cython.Build import cythonize
from setuptools import Extension, setup

extensions = [
    Extension(
        "piezotip.sensor._inference",
        ["sensor/_inference.pyx"],
        extra_compile_args=["-O2", "-ffp-contract=off"],
        optional=True,
    )
]

setup(ext_modules=cythonize(extensions, compiler_directives={"language_level": 3}, quiet=True))

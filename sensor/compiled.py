"""The compiled kernels of the per-step path, and when they run.

A few classes run on every reading of every pad, where Python's per-operation cost is most of
a control step's.  Each lives in one Python module, its one source, the one to read and change
(:data:`KERNELS`):

- ``sensor/_sampler.py``: :class:`sensor.sampler.ModeSampler`, a table-driven channel's reading
  (modal load, eq. 10, the envelope's step, the lock-in's noise);
- ``sensor/_estimator.py``: :class:`sensor.estimator.InverseCore`, the inverse of an inferred
  steady reading (:meth:`sensor.estimator.ModeInverse.inferred`);
- ``sensor/_inference.py``: :class:`sensor.inference.SteadyInference`, the readout's
  steady-reading inference;
- ``sensor/_channel.py``: ``ChannelCore``, a :class:`sensor.channel.SensorChannel`'s per-reading
  state and its per-step path (a reading through the sampler, its estimate through the
  inference and the inverse);
- ``cosim/_pad_kernels.py``: :class:`cosim.pad_kernels.GelForces`, ``PadPressures`` and the
  gel law's lookup ``UniformPairTable``: the gel law on the pad joints, the pads' pressure read;
- ``cosim/_period.py``: :class:`cosim.period.PeriodPhysics`, a control period's substeps (the
  servos' interpolated set-points, the gel law, ``mj_step``, the fingers' peak force, the
  stability check);
- ``cosim/_readout.py``: :class:`cosim._readout.ReadoutPass`, every attached fingertip's
  readout once a period (its pad's pressures, its channel's reading and estimate, its sensor
  values) and the values' write into ``sensordata`` at every step;
- ``cosim/_rows.py``: :class:`cosim.rows.RowBuilder` and ``stack_rows``, a control step's
  recorded row;
- ``cosim/control/_control.py``: :class:`cosim.control.selector.ModeSelector` and
  ``TouchDetector``, and the per-step records' makers of :mod:`cosim.control.interface`.

Each runs as Python as it is.  ``pip install`` also compiles it (setup.py) with Cython in its
pure-Python mode, typed by the ``.pxd`` file beside it (C fields, typed locals, C calls between
the kernel's own methods), into an extension module of the same name in the same folder, which
Python then imports in its place (the import system tries a folder's extension modules before
its ``.py`` files).  Where none was built (no C compiler at install), or with the environment
variable ``PIEZOTIP_PURE_PYTHON=1`` (:data:`PURE_PYTHON`: a finder then loads the kernels'
``.py`` files), the Python runs: slower, the same numbers.  tests/test_compiled_twins.py runs
every kernel both ways, the built module and the same source as Python
(:func:`source_module`), and asks for the same bits.

The few operations whose C must differ from what Cython makes of the Python, so that the
compiled kernel rounds and raises as Python does (complex division and magnitude through
CPython's own functions, ``cmath.exp`` and ``math``'s functions with Python's errors, a
record's slots written at once), and the table lookups the kernels share
(:func:`sensor.lookup.interp` and ``interp_pair`` on arrays of C doubles), are named
functions of ``sensor/_kernel_helpers.py``, whose ``.pxd`` holds their C.

The records a control step passes between stages (:class:`sensor.resonator.Reading`,
:class:`sensor.estimator.Estimate`, :class:`cosim.control.interface.PadSignal`,
``Observation``, ``Command``) are frozen dataclasses with ``__slots__``: one allocation each,
no instance dict.  The per-step path makes them with :func:`record_maker` (Python) or by
writing their slots in C (the compiled kernels), not through the constructor, whose
``object.__setattr__`` per field would cost more than the stage that fills them.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import os
import sys
from collections.abc import Callable
from dataclasses import fields
from pathlib import Path
from types import ModuleType

#: Whether the kernels run as Python even where they are compiled (``PIEZOTIP_PURE_PYTHON``).
PURE_PYTHON = os.environ.get("PIEZOTIP_PURE_PYTHON", "") not in ("", "0")

#: The kernel modules: each a ``.py`` beside a ``.pxd``, compiled by setup.py where it can be.
KERNELS = (
    "piezotip.sensor._sampler",
    "piezotip.sensor._estimator",
    "piezotip.sensor._inference",
    "piezotip.sensor._channel",
    "piezotip.cosim._pad_kernels",
    "piezotip.cosim._period",
    "piezotip.cosim._readout",
    "piezotip.cosim._rows",
    "piezotip.cosim.control._control",
)


def is_compiled(module: ModuleType) -> bool:
    """Whether ``module`` was imported from an extension module (not from its ``.py``)."""
    origin = getattr(module.__spec__, "origin", None) or ""
    return origin.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES))


class _KernelSources(importlib.abc.MetaPathFinder):
    """Under ``PIEZOTIP_PURE_PYTHON``: a kernel's ``.py``, never its extension module (the
    first finder on ``sys.meta_path``, for the names in :data:`KERNELS` only)."""

    def find_spec(self, name: str, path, target=None):
        if name not in KERNELS or path is None:
            return None
        for folder in path:
            source = Path(folder) / f"{name.rpartition('.')[2]}.py"
            if source.is_file():
                return importlib.util.spec_from_file_location(name, source)
        return None


if PURE_PYTHON and not any(isinstance(f, _KernelSources) for f in sys.meta_path):
    # Installed before any kernel is imported: each imports this module, through its package.
    sys.meta_path.insert(0, _KernelSources())


#: Each compiled kernel's source run as Python, loaded once (:func:`source_module`).
_SOURCE_RUNS: dict[str, ModuleType] = {}


def source_module(name: str) -> ModuleType:
    """The kernel ``name`` (one of :data:`KERNELS`) run as Python from its ``.py``: the module
    itself where that is what runs, else a second module made from the same source (not in
    ``sys.modules``; its instances cannot be pickled, the compiled classes own the name).  What
    the equivalence tests compare the compiled kernel with, and what the ``Py*`` names of the
    public modules (:data:`sensor.inference.PySteadyInference`, ...) are.

    Raises ValueError for a name that is not a kernel's."""
    if name not in KERNELS:
        raise ValueError(f"{name!r} is not a kernel module; the kernels are {KERNELS}")
    module = importlib.import_module(name)
    if not is_compiled(module):
        return module
    if name not in _SOURCE_RUNS:
        spec = importlib.util.spec_from_file_location(name, Path(module.__file__).with_name(f"{name.rpartition('.')[2]}.py"))
        run = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(run)
        _SOURCE_RUNS[name] = run
    return _SOURCE_RUNS[name]


def compiled_kernels() -> dict[str, bool]:
    """Each kernel's name and whether it runs compiled (False: its ``.py`` runs)."""
    return {name: is_compiled(importlib.import_module(name)) for name in KERNELS}


def slot_descriptors(cls: type, names: tuple[str, ...] = ()) -> list:
    """The slot descriptor of each field of the dataclass ``cls``, in the fields' order (or of
    each of the attributes ``names`` of a class with ``__slots__``): what :func:`record_maker`
    sets through, and where the compiled kernels read each slot's offset
    (``_kernel_helpers.pxd``: ``slot_offsets``).

    Raises TypeError where a field of ``cls`` is not a slot (a dataclass without ``slots=True``)."""
    slots = []
    for name in names or [f.name for f in fields(cls)]:
        slot = cls.__dict__.get(name)
        if type(slot).__name__ != "member_descriptor":
            raise TypeError(f"{cls.__name__}.{name} is not a slot: declare the dataclass with slots=True")
        slots.append(slot)
    return slots


def record_maker(cls: type) -> Callable[..., object]:
    """A function making a frozen slots dataclass ``cls`` from its fields' values, in their
    order, all given: each is set through its slot's descriptor (where the constructor goes
    through ``object.__setattr__``).  The result equals the constructor's (tests check it).

    Raises TypeError where a field of ``cls`` is not a slot (:func:`slot_descriptors`)."""
    names = [f.name for f in fields(cls)]
    setters = [slot.__set__ for slot in slot_descriptors(cls)]
    new = object.__new__

    def make(*values):
        record = new(cls)
        for put, value in zip(setters, values, strict=True):
            put(record, value)
        return record

    make.__qualname__ = make.__name__ = f"make_{cls.__name__}"
    make.__doc__ = f"{cls.__name__}({', '.join(names)}), every field given in this order (sensor.compiled.record_maker)."
    return make

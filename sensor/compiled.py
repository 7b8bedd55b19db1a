"""The compiled twins of the per-step path, and when they are used.

A few classes run on every reading of every pad, where Python's per-operation cost is most of
a control step's: each has a Python reference, which documents it and is the one to read, and
a Cython twin (``sensor/_*.pyx``: the same arithmetic in the same order, results equal bit for
bit, tested against the reference) that ``pip install`` builds (setup.py).  The twin is used
where it was built; where it was not (no C compiler at install), or with the environment
variable ``PIEZOTIP_PURE_PYTHON=1``, the reference is, slower and with the same numbers.

- :class:`sensor.inference.PySteadyInference` / ``sensor/_inference.pyx``: the readout's
  steady-reading inference;
- :class:`sensor.lookup.PyUniformPairTable` / ``sensor/_lookup.pyx``: the pads' gel-law lookup;
- :class:`sensor.sampler.PyModeSampler` / ``sensor/_sampler.pyx``: a table-driven channel's
  reading (modal load, eq. 10, the envelope's step, the lock-in's noise);
- :class:`sensor.estimator.PyInverseCore` / ``sensor/_estimator.pyx``: the inverse of an
  inferred steady reading (:meth:`sensor.estimator.ModeInverse.inferred`);
- :class:`cosim.pad_kernels.PyGelForces` and :class:`cosim.pad_kernels.PyPadPressures` /
  ``cosim/_pad_kernels.pyx``: the gel law on the pad joints, the pads' pressure read;
- :class:`cosim.rows.PyRowBuilder` / ``cosim/_rows.pyx``: a control step's recorded row;
- :class:`cosim.control.selector.PyModeSelector` and :class:`cosim.control.selector.PyTouchDetector`,
  and :func:`cosim.control.interface.py_make_pad_signal`, ``py_make_observation`` and
  ``py_make_command`` / ``cosim/control/_control.pyx``: the controller's mode selection and
  touch detection on every reading, and the records a control step passes between stages.

Their shared C (Python's float division and ``math.exp``, the uniform-grid lookup, bisection,
tables copied into C arrays, a record's slots filled) is in ``sensor/_twin_helpers.pxd``, inline.

The records a control step passes between stages (:class:`sensor.resonator.Reading`,
:class:`sensor.estimator.Estimate`, :class:`cosim.control.interface.PadSignal`,
``Observation``, ``Command``) are frozen dataclasses with ``__slots__``: one allocation each,
no instance dict.  The per-step path makes them with :func:`record_maker` (the references) or
by writing their slots in C (the twins), not through the constructor, whose
``object.__setattr__`` per field would cost more than the stage that fills them.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from dataclasses import fields

#: Whether the references are used even where the twins are built (``PIEZOTIP_PURE_PYTHON``).
PURE_PYTHON = os.environ.get("PIEZOTIP_PURE_PYTHON", "") not in ("", "0")


def twin(module: str, name: str, reference: type) -> tuple[type, bool]:
    """(the class to use, whether it is compiled): ``name`` from the compiled module ``module``
    (e.g. ``"piezotip.sensor._inference"``) where it is built and not refused, else ``reference``."""
    if PURE_PYTHON:
        return reference, False
    try:
        compiled = importlib.import_module(module)
    except ImportError:  # not built: the reference, slower
        return reference, False
    return getattr(compiled, name), True


def slot_descriptors(cls: type) -> list:
    """The slot descriptor of each field of the dataclass ``cls``, in the fields' order: what
    :func:`record_maker` sets through, and where the compiled twins read each slot's offset
    (``_twin_helpers.pxd``: ``slot_offsets``).

    Raises TypeError where a field of ``cls`` is not a slot (a dataclass without ``slots=True``)."""
    slots = []
    for f in fields(cls):
        slot = cls.__dict__.get(f.name)
        if type(slot).__name__ != "member_descriptor":
            raise TypeError(f"{cls.__name__}.{f.name} is not a slot: declare the dataclass with slots=True")
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

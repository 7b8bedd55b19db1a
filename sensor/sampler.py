"""One reading of a table-driven channel: the per-sample arithmetic of :class:`sensor.channel.SensorChannel`.

For a channel that reads the gel from its tables (not ``exact``) with "steady" or "envelope"
dynamics, a sample of the driven mode n is, in order (physics.md sections 3 and 6):

1. the modal load: each cell's (k_e, c_e) from the mode's :class:`FoundationTable` (log-log
   interpolation, linear in P below its first point), summed with the mode's cell weights
   (b times eq. 20's integrals per cell): kappa in N/m^2, gamma in N s/m^2;
2. eq. 10's steady envelope over the unloaded one, omega c / (omega (gamma + c) - j kappa)
   (:func:`sensor.equations.normalized_response`);
3. the envelope's rate lambda = (c + gamma) / (2 rho A) - j kappa / (2 omega rho A), 1/s, and
   its time constant tau = 1 / Re(lambda), s (:func:`sensor.resonator.envelope_rate`);
4. the envelope advanced exactly over the sample period, a + (a0 - a) exp(-lambda dt)
   (:func:`sensor.resonator.envelope_step`), or the steady envelope itself ("steady");
5. the lock-in's output, the envelope plus the readout's noise (a unit complex normal draw
   times the mode's sigma, dimensionless), its magnitude V_1 and the noise-free phase, rad.

A pad that carries no load (every cell at 0 Pa: a grasp's approach, its tail after the release)
puts no modal load on the mode (kappa = gamma = 0), and then steps 2 and 3 and the step's decay
factor exp(-lambda dt) are the unloaded resonator's, the same every sample: each sampler
computes them once, with the same arithmetic (``ModeSampler._response``), and an
unloaded sample reuses them (:data:`SKIP_UNLOADED`; counted in ``unloaded_samples``).  Those
are functions of (kappa, gamma) alone, and a zero of either sign gives the same ones, so the
readings are the same bit for bit (tests/test_unloaded_skip.py).  What follows them (the
envelope's step, the noise, the magnitudes) depends on the envelope and the noise, and is
computed every sample.

:class:`ModeSampler` is that, one instance per mode, a kernel: one source, ``sensor/_sampler.py``,
compiled where built (:mod:`sensor.compiled`; :data:`SAMPLER_COMPILED` says), the same
arithmetic in the same order either way (tests/test_compiled_twins.py runs both);
:class:`PyModeSampler` is that source run as Python.  The channel keeps the state (mode,
envelope, clocks, noise) and calls :meth:`ModeSampler.sample` once per reading.
"""

from __future__ import annotations

from . import _sampler
from ._sampler import ModeSampler
from .compiled import is_compiled, source_module

__all__ = ["SAMPLER_COMPILED", "SKIP_UNLOADED", "ModeSampler"]

#: Whether a sampler reuses the unloaded resonator's response for a sample without modal load
#: (the module's docstring), unless its constructor is told: read when it is built (a channel
#: builds its samplers with itself).  The readings are the same either way
#: (tests/test_unloaded_skip.py switches it off to show it).
SKIP_UNLOADED = True

#: Whether :class:`ModeSampler` runs compiled (sensor/_sampler.py built), not as Python.
SAMPLER_COMPILED = is_compiled(_sampler)


def __getattr__(name: str):
    if name == "PyModeSampler":  # the kernel's source run as Python, loaded when asked for
        return source_module(_sampler.__name__).ModeSampler
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

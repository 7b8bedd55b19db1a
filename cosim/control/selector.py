"""Per-fingertip parts of the multimode controller: the mode selector and the touch detector.

:class:`ModeSelector` (one per fingertip) drives the element in the mode best suited to the
current pressure estimate.  The switch pressures are the fingertip's own (the pressures at
which the per-mode resolution curves cross, ``Fingertip.switch_pressures`` for the allowed
modes), never typed-in constants.  It switches up past ``s (1 + h)`` and down below
``s (1 - h)`` (hysteresis ``h``), also up when the current mode reports saturation and down
when it reports below-detection, each only after ``persist`` consecutive readings say so, and
never while a ring-up is settling: a reading taken before the new mode has settled is not
trusted, the last trusted estimate is held meanwhile.

Why every switch waits for ``persist`` readings, the pressure switches too: a switch costs
the new mode's ring-up (readings "settling", the controller blind for tens of ms with Table
I's damping), so it only pays for a pressure that stays on the other side.  Pads that stick
and slip on an object still on the table make the true pressure swing past both edges of the
band from one 5 ms reading to the next while the grip ramps: a hysteresis band of +-h on single
readings then switches at every reading
(tests/test_grasp.py::test_no_chatter_when_the_pressure_swings_across_the_band_every_reading).

:class:`TouchDetector` is a one-sided CUSUM (Page 1954) on the drop of the most sensitive
mode's reading below its unloaded baseline, in sigmas of the reading, with a Shewhart limit on
single readings (Lucas 1982).

Both run on every reading of every pad: they are a kernel, one source,
``cosim/control/_control.py``, compiled where built (:mod:`piezotip.sensor.compiled`;
:data:`SELECTOR_COMPILED` says); :class:`PyModeSelector` and :class:`PyTouchDetector` are the
same source run as Python.
"""

from __future__ import annotations

import numpy as np

from piezotip.sensor import Fingertip
from piezotip.sensor.cache import disk_cached
from piezotip.sensor.cache import enabled as cache_enabled
from piezotip.sensor.compiled import is_compiled, source_module

__all__ = ["SELECTOR_COMPILED", "ModeSelector", "TouchDetector", "allowed_ranges"]

_RANGES: dict[tuple, tuple] = {}


def allowed_ranges(fingertip: Fingertip, modes: tuple[int, ...]) -> tuple[Fingertip, tuple, dict[int, float], dict[int, float]]:
    """The fingertip restricted to ``modes``, its mode bands and each mode's P_min and P_max, Pa.

    Computed once per fingertip configuration (element, boundary, gel, coverage, noise, rating,
    mounting: every parameter they depend on, all immutable, :meth:`Fingertip.config_key`) and
    set of modes: in a process, both pads of a grasp and every run of an experiment share them;
    across processes (a sweep's workers, the next command) the disk cache
    (:mod:`piezotip.sensor.cache`) does.  The results are immutable values (tuples; the dicts are
    copied for the caller).
    """
    key = (fingertip.config_key(), modes)
    if key not in _RANGES or not cache_enabled():
        allowed = Fingertip(
            element=fingertip.element,
            gel=fingertip.gel,
            coverage=fingertip.coverage,
            noise=fingertip.noise,
            modes=modes,
            rated_pressure_pa=fingertip.rated_pressure_pa,
            mounting=fingertip.mounting,
        )

        def compute() -> dict[str, np.ndarray]:
            return {
                "p_min_pa": np.array([allowed.detection_limit(m) for m in modes]),
                "p_max_pa": np.array([allowed.upper_limit(m) for m in modes]),
                "bands": np.array(allowed.mode_bands(), float).reshape(-1, 3),
            }

        numbers = disk_cached("allowed-ranges", key, compute, extra_modules=[__file__])
        bands = tuple((int(m), float(lo), float(hi)) for m, lo, hi in numbers["bands"])
        p_min = {m: float(v) for m, v in zip(modes, numbers["p_min_pa"], strict=True)}
        p_max = {m: float(v) for m, v in zip(modes, numbers["p_max_pa"], strict=True)}
        _RANGES[key] = (allowed, bands, p_min, p_max)
    allowed, bands, p_min, p_max = _RANGES[key]
    return allowed, bands, dict(p_min), dict(p_max)


def __getattr__(name: str):
    if name in ("PyModeSelector", "PyTouchDetector"):  # the kernel's source run as Python, loaded when asked for
        return getattr(source_module(_control.__name__), name[2:])
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# The selector and the detector (a kernel, cosim/control/_control.py, compiled where built):
# imported last, as their constructor reads allowed_ranges from here when called.
from . import _control  # noqa: E402
from ._control import ModeSelector, TouchDetector  # noqa: E402

#: Whether :class:`ModeSelector` and :class:`TouchDetector` run compiled, not as Python.
SELECTOR_COMPILED = is_compiled(_control)

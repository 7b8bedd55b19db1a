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
and slip on an object still on the table make the true pressure swing between, say, 0.2 and
1.7 times a switch pressure from one 5 ms reading to the next (the 60 g egg while its grip
ramps): a hysteresis band of +-h on single readings then switches at every reading.

:class:`TouchDetector` is a one-sided CUSUM (Page 1954) on the drop of the most sensitive
mode's reading below its unloaded baseline, in sigmas of the reading, with a Shewhart limit on
single readings (Lucas 1982).

Both run on every reading of every pad: :class:`PyModeSelector` and :class:`PyTouchDetector` are
the references, the ones to read; ``cosim/control/_control.pyx`` holds their compiled twins
(the same decisions, the same reasons, the same floats: tests/test_compiled_twins.py), used
where built (:mod:`piezotip.sensor.compiled`) under the names :class:`ModeSelector` and
:class:`TouchDetector`.
"""

from __future__ import annotations

import math

import numpy as np

from piezotip.sensor import Fingertip
from piezotip.sensor.cache import disk_cached
from piezotip.sensor.cache import enabled as cache_enabled
from piezotip.sensor.compiled import twin

from .interface import Why

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


class PyModeSelector:
    """Chooses one fingertip's drive mode from its readout, with hysteresis and settling
    (the reference of the compiled :class:`ModeSelector`).

    Parameters
    ----------
    fingertip : the fingertip model whose switch pressures and limits the selector uses.
    modes : the allowed modes (a subset of the fingertip's), ascending.
    hysteresis : fractional band around each switch pressure.
    persist : consecutive readings that call for the same switch (saturated, below detection,
        above the switch up, below the switch down) before it is made.
    """

    def __init__(self, fingertip: Fingertip, modes: tuple[int, ...], hysteresis: float = 0.25, persist: int = 3) -> None:
        self.modes = tuple(sorted(modes))
        self.fingertip, self.bands, self.p_min_pa, self.p_max_pa = allowed_ranges(fingertip, self.modes)
        # Switch pressure between consecutive allowed modes (the band edge), Pa.
        self.switch_pa = {(a[0], b[0]): a[2] for a, b in zip(self.bands, self.bands[1:], strict=False)}
        # Each allowed mode's neighbours (next mode up, next mode down; None past either end)
        # and its switch pressures up and down (Pa; inf and 0 past either end), looked up on
        # every reading rather than searched for.
        self._neighbours = {}
        for i, m in enumerate(self.modes):
            up = self.modes[i + 1] if i + 1 < len(self.modes) else None
            down = self.modes[i - 1] if i > 0 else None
            up_pa = self.switch_pa[(m, up)] if up is not None else math.inf
            down_pa = self.switch_pa[(down, m)] if down is not None else 0.0
            self._neighbours[m] = (up, down, up_pa, down_pa)
        self.hysteresis = hysteresis
        self.persist = persist
        self.mode = self.modes[0]
        self._saturated = 0  # consecutive saturated readings
        self._above_switch = 0  # consecutive readings past the switch up (saturated, or "ok" above it)
        self._under_switch = 0  # and past the switch down (below detection, or "ok" below it)
        self.blind = False  # saturated in the highest allowed mode
        self.estimate_pa = 0.0  # last trusted estimate
        self.uncertainty_pa = math.nan
        self.status = "below_detection"  # status of the last trusted estimate
        self.trusted = True

    def update(self, estimate) -> tuple[int, object]:
        """Take one readout estimate; return (mode to drive next, why).

        A "settling" estimate (the readout cannot yet tell the new mode's steady reading) is
        not used: the last trusted estimate is held and no switch is made.
        """
        if estimate.status == "settling":
            self.trusted = False
            return self.mode, Why("mode {}: settling, holding {:.3g} Pa", self.mode, self.estimate_pa)
        self.trusted = True
        self.blind = False
        status = estimate.status
        if status in ("ok", "below_detection") and math.isfinite(estimate.pressure_pa):
            self.estimate_pa, self.uncertainty_pa, self.status = estimate.pressure_pa, estimate.uncertainty_pa, status
        up, down, up_pa, down_pa = self._neighbours[self.mode]
        p = self.estimate_pa
        # A saturated reading is past the switch up (P_max lies above it), a below-detection
        # one past the switch down: one streak each, whatever mix of readings makes it.
        self._saturated = self._saturated + 1 if status == "saturated" else 0
        h = self.hysteresis
        above = up is not None and (status == "saturated" or (status == "ok" and p > up_pa * (1 + h)))
        under = down is not None and (status == "below_detection" or (status == "ok" and p < down_pa * (1 - h)))
        self._above_switch = self._above_switch + 1 if above else 0
        self._under_switch = self._under_switch + 1 if under else 0
        if up is None and self._saturated >= self.persist:
            self.blind = True
            why = Why("mode {}: saturated and no higher mode allowed (blind above {:.3g} Pa)", self.mode, self.p_max_pa[self.mode])
            return self.mode, why
        if self._above_switch >= self.persist:
            if status == "saturated":
                return self._switch(up, f"mode {self.mode} saturated (P > {self.p_max_pa[self.mode]:.3g} Pa)")
            return self._switch(up, f"P {p:.3g} Pa above switch {up_pa:.3g} Pa x {1 + h:g}")
        if self._under_switch >= self.persist:
            if status == "below_detection":
                return self._switch(down, f"mode {self.mode} below detection (P < {self.p_min_pa[self.mode]:.3g} Pa)")
            return self._switch(down, f"P {p:.3g} Pa below switch {down_pa:.3g} Pa x {1 - h:g}")
        return self.mode, Why("mode {}: {}, P {:.3g} Pa", self.mode, status, self.estimate_pa)

    def _switch(self, mode: int, why: str) -> tuple[int, str]:
        old, self.mode = self.mode, mode
        self._saturated = self._above_switch = self._under_switch = 0
        self.trusted = False
        return mode, f"switch {old} -> {mode}: {why}"

    @property
    def empty(self) -> bool:
        """The fingertip reads no load: below detection in its lowest allowed mode."""
        return self.trusted and self.status == "below_detection" and self.mode == self.modes[0]


class PyTouchDetector:
    """One-sided CUSUM on the drop of a reading below its unloaded baseline (in sigmas), with a
    Shewhart limit on single readings (the combined scheme of Lucas 1982): a slow drift alarms
    through the CUSUM, a sudden drop at once (the reference of the compiled :class:`TouchDetector`).

    Parameters
    ----------
    sigma : one reading's standard deviation, dimensionless (V_1 units).
    drift_sigma : the CUSUM's allowance k, sigmas (half the smallest shift to detect).
    alarm_sigma : the CUSUM's threshold h, sigmas.
    single_sigma : one reading's drop that alarms alone, sigmas.
    """

    def __init__(self, sigma: float, drift_sigma: float = 0.5, alarm_sigma: float = 8.0, single_sigma: float = 6.0) -> None:
        self.sigma = sigma
        self.drift_sigma, self.alarm_sigma, self.single_sigma = drift_sigma, alarm_sigma, single_sigma
        self.baseline = math.nan
        self._sum = 0.0
        self._count = 0
        self.score = 0.0
        self.touched = False

    def learn(self, v1: float) -> None:
        """Add an unloaded reading to the baseline."""
        self._sum += v1
        self._count += 1
        self.baseline = self._sum / self._count

    def rearm(self) -> None:
        """Forget an alarm (the baseline stays): the next significant drop alarms again."""
        self.score, self.touched = 0.0, False

    def update(self, v1: float) -> bool:
        """Take a reading; True once the drop is significant (latched)."""
        if not self.touched:
            drop = (self.baseline - v1) / self.sigma
            self.score = max(0.0, self.score + drop - self.drift_sigma)
            self.touched = self.score > self.alarm_sigma or drop > self.single_sigma
        return self.touched


#: The compiled twins of :class:`PyModeSelector` and :class:`PyTouchDetector` where built, else they.
ModeSelector, SELECTOR_COMPILED = twin("piezotip.cosim.control._control", "ModeSelector", PyModeSelector)
TouchDetector, _ = twin("piezotip.cosim.control._control", "TouchDetector", PyTouchDetector)

"""Self-sensing: the element tests itself (physics.md section 7).

One PZT layer drives and the other senses, so with nothing touching the pad the element
can measure its own unloaded frequency response.  A crack or a delamination changes it:

- a crack lowers the bending stiffness, so the resonance moves away from the drive
  frequency: the phase at the healthy resonance leaves 90 degrees;
- a delaminated or depolarized layer couples less: the amplitude at resonance drops with
  the resonance and its width unchanged;
- a delamination that rubs adds damping: the resonance widens (Q drops) and its peak drops.

The self-test drives each mode at the healthy resonance f_n and at its two half-power
points f_n (1 +- 1/(2 Q_n)), reads amplitude and phase (with noise), and from the three
readings estimates the resonance shift, the Q ratio and the coupling ratio.  The modal
frequency response of a single mode at drive omega (eq. 4 with the drive's generalized
force, per unit A_L) is

    H(omega) = G_n / (rho A (omega_n^2 - omega^2) + j omega c),   G_n = eq. 17's numerator / (4 C L)

so that |H(omega_n)| is eq. 17's V_0 and the phase lag -arg H is pi/2 at resonance (eq. 13).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .element import SensorElement
from .readout import NoiseParams


def frequency_response_v(element: SensorElement, freq_hz, mode: int) -> np.ndarray:
    """Complex sensed voltage (V, same measure as the drive) of the unloaded element at ``freq_hz``."""
    p = element.params
    omega_n = element.natural_angular_frequency(mode)
    omega = 2 * math.pi * np.asarray(freq_hz, float)
    gain = element.unloaded_voltage(mode) * omega_n * p.damping_n_s_per_m2  # G_n
    return gain / (p.mass_per_length_kg_m * (omega_n**2 - omega**2) + 1j * omega * p.damping_n_s_per_m2)


def damaged(element: SensorElement, stiffness: float = 1.0, coupling: float = 1.0, damping: float = 1.0) -> SensorElement:
    """A copy of ``element`` with injected damage, each a factor on the healthy value.

    stiffness : factor on both Young's moduli (a crack lowers EI; it lowers the layers'
        stress per strain, so the electromechanical gain too).
    coupling : factor on d31 (depolarization, or an electrode that has let go).
    damping : factor on the element's damping c (a delamination that rubs).
    """
    for name, v in (("stiffness", stiffness), ("coupling", coupling), ("damping", damping)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"damage factor {name} must be positive and finite, got {v!r}")
    p = element.params
    new = replace(
        p,
        substrate_youngs_pa=p.substrate_youngs_pa * stiffness,
        pzt_youngs_pa=p.pzt_youngs_pa * stiffness,
        d31_m_per_v=p.d31_m_per_v * coupling,
        damping_n_s_per_m2=p.damping_n_s_per_m2 * damping,
    )
    return SensorElement(new, element.boundary, dict(element.trims))


@dataclass(frozen=True)
class ModeCheck:
    """One mode's self-test readings and what they imply (ratios are measured / healthy).

    Attributes
    ----------
    mode : mode number.
    amplitude_ratio : |V| at the healthy resonance over the healthy V_0, dimensionless.
    phase_error_deg : phase lag at the healthy resonance minus 90 degrees.
    frequency_shift : estimated (f_resonance - f_healthy) / f_healthy, dimensionless
        (NaN when the resonance has left the measured band).
    q_ratio : estimated Q / healthy Q (NaN when the resonance has left the band).
    coupling_ratio : estimated amplitude at the element's own resonance, corrected for Q,
        over healthy (NaN when the resonance has left the band).
    findings : what looks wrong, in words (empty when healthy).
    """

    mode: int
    amplitude_ratio: float
    phase_error_deg: float
    frequency_shift: float
    q_ratio: float
    coupling_ratio: float
    findings: tuple[str, ...]


@dataclass(frozen=True)
class SelfTestReport:
    """Per-mode checks; ``passed`` when no mode has findings; ``message`` says what is wrong."""

    checks: tuple[ModeCheck, ...]

    @property
    def passed(self) -> bool:
        return all(not c.findings for c in self.checks)

    @property
    def message(self) -> str:
        if self.passed:
            return "self-test passed: " + ", ".join(f"mode {c.mode} amplitude {c.amplitude_ratio:.3f}" for c in self.checks)
        return "self-test FAILED: " + "; ".join(f"mode {c.mode}: {', '.join(c.findings)}" for c in self.checks if c.findings)


def _read(element: SensorElement, freq_hz: np.ndarray, mode: int, scale_v: float, noise: NoiseParams, rng) -> np.ndarray:
    """Noisy complex readings: in-phase and quadrature each get sigma = the readout's floor."""
    true = frequency_response_v(element, freq_hz, mode)
    sigma = math.hypot(noise.relative_floor * scale_v, noise.absolute_floor_v)
    return true + rng.normal(0, sigma, true.shape) + 1j * rng.normal(0, sigma, true.shape)


def self_test(
    element: SensorElement,
    healthy: SensorElement | None = None,
    modes: tuple[int, ...] = (1, 2, 3, 4),
    noise: NoiseParams | None = None,
    rng: np.random.Generator | None = None,
    tolerance: float = 0.05,
) -> SelfTestReport:
    """Test ``element`` against the ``healthy`` design (default: Table I, same boundary).

    ``tolerance`` is the fractional change of Q or coupling, and the shift of the resonance
    in units of the healthy half-bandwidth, accepted as manufacturing spread; with the
    default noise a healthy element passes with a margin of tens of standard deviations.
    Modes that a full-length electrode cannot excite (V_0 = 0) are skipped.
    """
    healthy = healthy or SensorElement(boundary=element.boundary)
    noise = noise or NoiseParams()
    rng = rng or np.random.default_rng()
    checks = []
    for mode in modes:
        v0 = healthy.unloaded_voltage(mode)
        if v0 <= 0:
            continue
        f_n = healthy.natural_frequency_hz(mode)
        q = healthy.quality_factor(mode)
        freqs = f_n * np.array([1 - 1 / (2 * q), 1.0, 1 + 1 / (2 * q)])
        lo, mid, hi = _read(element, freqs, mode, v0, noise, rng)
        lag = [-(np.angle(v)) for v in (lo, mid, hi)]  # phase lag, rad; pi/2 at resonance
        t_lo, t_mid, t_hi = (math.tan(phi - math.pi / 2) for phi in lag)
        amplitude_ratio = abs(mid) / v0
        phase_error = (math.degrees(lag[1] - math.pi / 2) + 180.0) % 360.0 - 180.0  # wrapped into [-180, 180)
        findings = []
        if abs(phase_error) > 60 or amplitude_ratio < 0.05:
            findings.append(
                f"no resonance at the healthy frequency (amplitude {amplitude_ratio:.2g}, "
                f"phase error {phase_error:.0f} deg): resonance moved, stiffness loss (crack?)"
            )
            checks.append(ModeCheck(mode, amplitude_ratio, phase_error, math.nan, math.nan, math.nan, tuple(findings)))
            continue
        # Near resonance tan(lag - pi/2) = 2 Q_d (omega - omega_r) / omega_r (second-order resonator).
        q_ratio = (t_hi - t_lo) / 2.0
        shift = -t_mid / (2 * q * q_ratio)
        coupling_ratio = amplitude_ratio * math.sqrt(1 + t_mid**2) / q_ratio
        half_bandwidth = 1 / (2 * q)
        if abs(shift) > tolerance * half_bandwidth * 2:
            findings.append(f"resonance moved by {100 * shift:+.3g} % (stiffness change: crack?)")
        if q_ratio < 1 - tolerance:
            findings.append(f"Q dropped to {q_ratio:.2f} of healthy (added damping: delamination?)")
        if q_ratio > 1 + tolerance:
            findings.append(f"Q rose to {q_ratio:.2f} of healthy (less damping than designed: gel detached or mount loose?)")
        if coupling_ratio < 1 - tolerance:
            findings.append(f"coupling dropped to {coupling_ratio:.2f} of healthy (depolarized layer or electrode delamination?)")
        checks.append(ModeCheck(mode, amplitude_ratio, phase_error, shift, q_ratio, coupling_ratio, tuple(findings)))
    return SelfTestReport(tuple(checks))


__all__ = ["ModeCheck", "SelfTestReport", "damaged", "frequency_response_v", "self_test"]

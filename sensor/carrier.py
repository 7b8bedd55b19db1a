"""The reference sensor dynamics: the modal equation through every drive cycle, and a lock-in.

Physics reference: ``shared/physics.md`` section 6 ("the reference integrates the carrier
itself").  Per unit A_L the driven mode obeys eq. 4 with the gel's load,

    rho A q'' + (c + gamma) q' + (rho A omega_n^2 + kappa) q = F cos(omega_n t),

a linear equation whose coefficients the gel changes once per control period.  Over a
period with (kappa, gamma) held it is solved exactly: the forced response
Re(a_p e^(j omega t)), a_p = F / (kappa + j omega (gamma + c)) at omega = omega_n (eq. 10),
plus the free response of the loaded oscillator, e^(-alpha t) (x0 cos w_d t + ...).  The
carrier q(t) is sampled ``samples_per_cycle`` times per drive cycle and demodulated as a
lock-in amplifier does: multiplied by cos and -sin of the drive, averaged over the last
``lockin_cycles`` whole cycles of the period (a boxcar output filter); the solution itself
is exact over every cycle of the period, so only the demodulated cycles need samples.  The output is normalized like the envelope
model's (1 + 0j when unloaded and settled), so the two compare directly; what the envelope
model leaves out (the free response's beat at the loaded frequency, the dropped a'' term,
the lock-in's averaging) is exactly what the benchmark measures.
"""

from __future__ import annotations

import cmath
import math

import numpy as np


class CarrierResonator:
    """One mode's carrier, stepped exactly and demodulated per control period.

    Parameters
    ----------
    mass_per_length_kg_m : rho A, kg/m.
    damping_n_s_m2 : c, N s/m^2.
    omega : the mode's natural (and drive) angular frequency, rad/s.
    samples_per_cycle : carrier samples per drive cycle for the demodulation (>= 4).
    lockin_cycles : the lock-in's averaging window, in drive cycles, at the end of each
        control period (4: a lock-in time constant of about 1 ms in mode 1 and 30 us in
        mode 4, short against the envelope's time constants, so the output is the envelope
        now, not a lagging average).
    """

    def __init__(
        self, mass_per_length_kg_m: float, damping_n_s_m2: float, omega: float, samples_per_cycle: int = 16, lockin_cycles: int = 4
    ) -> None:
        if samples_per_cycle < 4:
            raise ValueError(f"samples_per_cycle must be at least 4, got {samples_per_cycle!r}")
        self.m = mass_per_length_kg_m
        self.c = damping_n_s_m2
        self.omega = omega
        self.samples_per_cycle = int(samples_per_cycle)
        if lockin_cycles < 1:
            raise ValueError(f"lockin_cycles must be at least 1, got {lockin_cycles!r}")
        self.lockin_cycles = int(lockin_cycles)
        self.force = 1.0  # drive amplitude per unit A_L; the output is normalized by it
        self.period_s = 2 * math.pi / omega
        self.q = 0.0
        self.v = 0.0
        self.phase_time_s = 0.0  # time within the drive's cycle (kept < one period)

    def start_steady(self, detuning_n_m2: float = 0.0) -> None:
        """Put the resonator in its unloaded steady state (the instrument has been running).

        The forced response a_p = F / (K_d + j omega c) (eq. 10 unloaded), where the drive is
        detuned from the resonance by the stiffness K_d = rho A (omega_r^2 - omega^2), N/m^2 (a
        physical unit's, :meth:`sensor.unit_channel.UnitChannel._u_detuning`; 0 at resonance).
        """
        a_p = self.force / (detuning_n_m2 + 1j * self.omega * self.c)
        self.q, self.v = self._particular(a_p, self.phase_time_s)

    def _particular(self, a_p: complex, t: float) -> tuple[float, float]:
        e = cmath.exp(1j * self.omega * t)
        return (a_p * e).real, (1j * self.omega * a_p * e).real

    def step(self, kappa: float, gamma: float, dt_s: float) -> complex:
        """Advance ``dt_s`` under a load (kappa, gamma) held constant; return the lock-in output.

        The output is the complex envelope normalized by the unloaded steady one,
        j omega c a / F, averaged over the last ``lockin_cycles`` drive cycles of the step.
        """
        m, omega = self.m, self.omega
        damping = self.c + gamma
        stiffness = m * omega * omega + kappa
        a_p = self.force / (kappa + 1j * omega * damping)
        t0 = self.phase_time_s
        q_p0, v_p0 = self._particular(a_p, t0)
        x0, y0 = self.q - q_p0, self.v - v_p0  # the free response's initial state
        # Free response x = A1 e^(s1 t) + A2 e^(s2 t) with s1,2 the loaded oscillator's roots:
        # both have Re s < 0, so no term overflows, under- or overdamped.
        alpha = damping / (2 * m)
        root = cmath.sqrt(alpha * alpha - stiffness / m)
        s1, s2 = -alpha + root, -alpha - root
        if abs(s1 - s2) > 1e-9 * abs(s1):
            a1 = (y0 - s2 * x0) / (s1 - s2)
            a2 = x0 - a1

            def free(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                e1, e2 = np.exp(s1 * tau), np.exp(s2 * tau)
                return (a1 * e1 + a2 * e2).real, (a1 * s1 * e1 + a2 * s2 * e2).real
        else:  # critically damped: x = (x0 + (y0 - s x0) t) e^(s t)

            def free(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                e = np.exp(s1 * tau)
                b = y0 - s1 * x0
                return ((x0 + b * tau) * e).real, ((b + s1 * (x0 + b * tau)) * e).real

        cycles = min(math.floor(dt_s / self.period_s), self.lockin_cycles)
        if cycles >= 1:
            n = cycles * self.samples_per_cycle
            tau = dt_s - cycles * self.period_s + (np.arange(n) + 0.5) * (self.period_s / self.samples_per_cycle)
            x, _ = free(tau)
            phase = omega * (t0 + tau)
            q = x + (a_p * np.exp(1j * phase)).real
            demod = 2.0 * np.mean(q * np.exp(-1j * phase))  # = a for q = Re(a e^(j omega t))
        else:  # a period shorter than a cycle: the instantaneous complex amplitude
            x, y = free(np.array([dt_s]))
            phase = omega * (t0 + dt_s)
            q_end = float(x[0]) + (a_p * cmath.exp(1j * phase)).real
            v_end = float(y[0]) + (1j * omega * a_p * cmath.exp(1j * phase)).real
            demod = (q_end - 1j * v_end / omega) * cmath.exp(-1j * phase)
        xe, ye = free(np.array([dt_s]))
        t_end = t0 + dt_s
        q_pe, v_pe = self._particular(a_p, t_end)
        self.q, self.v = float(xe[0]) + q_pe, float(ye[0]) + v_pe
        self.phase_time_s = math.fmod(t_end, self.period_s)
        return complex(1j * omega * self.c * demod / self.force)

"""A physical unit's channel: the readout of a unit that is not the model it reads through.

:class:`UnitChannel` is a :class:`sensor.channel.SensorChannel` that simulates a physical unit
(:class:`sensor.calibration.SensorUnit`: its element, gel, coverage and temperature, drawn
apart from the nominal design by :mod:`sensor.variation`) while its readout and the controller
know only the unit's model (what calibration measured): the unit is driven at the readout's
drive frequencies and read against its references, its temperature drifts, and a calibrated
readout re-zeroes while unloaded (:meth:`UnitChannel._track`).  The nominal channel's per-step
path carries none of this.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .calibration import SensorUnit, detuning, reading_sigma_v
from .carrier import CarrierResonator
from .channel import SensorChannel, _modal_load
from .equations import normalized_response
from .estimator import _TABLE_P, CalibratedInverse, Estimate, foundation_table
from .fingertip import Fingertip
from .inference import GAIN_FLOOR
from .resonator import Reading, _rate, _reading
from .variation import REFERENCE_TEMPERATURE_C

#: A calibrated unit's readout re-zeroes after this long unloaded (below detection), s: longer
#: than the inference's settling after a release (0.17 to 0.37 s with Table I's damping, see
#: SteadyInference), so a re-zero takes the unloaded reading, not the tail of a load.
REZERO_S = 0.5
#: ...and corrects a drift only past this many sigmas of its unloaded reading's noise (a false
#: correction at 4 sigma: 6e-5 per look, one in 8 hours of unloaded readout).
REZERO_SIGMAS = 4.0


class UnitChannel(SensorChannel):
    """The channel of a physical unit (see the module's docstring).

    Parameters are :class:`SensorChannel`'s, with ``unit``, the physical unit and its
    calibration: ``fingertip`` must be the unit's ``model`` (the readout and the controller see
    nothing else); the cells default to the unit's own gel coverage.  A unit that is the
    nominal design itself (no variation, at 25 C, no calibration) runs as a SensorChannel.
    """

    def __init__(
        self,
        fingertip: Fingertip,
        unit: SensorUnit,
        edges_m: Sequence[float] | None = None,
        dynamics: str = "envelope",
        mode: int | None = None,
        noise: bool = True,
        rng: np.random.Generator | None = None,
        exact: bool = False,
        carrier_samples_per_cycle: int = 16,
    ) -> None:
        self._unit: SensorUnit | None = None  # set by _setup_unit (after the channel is built)
        super().__init__(
            fingertip,
            edges_m=edges_m if edges_m is not None else unit.coverage,
            dynamics=dynamics,
            mode=mode,
            noise=noise,
            rng=rng,
            exact=exact,
            carrier_samples_per_cycle=carrier_samples_per_cycle,
        )
        self.rezeros = 0  # re-zeroes while unloaded (a varied or warming unit's tracking)
        if not (unit.config.is_nominal and unit.config.level == "none"):
            self._setup_unit(unit)

    @property
    def _tracking(self) -> bool:
        return self._unit is not None and self._unit.tracking

    def _setup_unit(self, unit: SensorUnit) -> None:
        """Simulate ``unit`` (not the readout's model) from now on.

        The unit's mode n, driven at w_d (the readout's drive) with the gel's load, obeys eq. 4
        off resonance: its envelope a (normalized by G / (j w_d c), G the unit's gain) relaxes
        to a_ss = w_d c / (w_d (gamma + c) - j (kappa + K_d)) at the rate
        lambda = (c + gamma) / (2 rho A) - j (kappa + K_d) / (2 w_d rho A), where
        K_d = rho A (w_r^2 - w_d^2) is the detuning, a stiffness like the gel's: the same
        equations as the nominal path (eq. 10's normalized response, the envelope's rate) with kappa + K_d.  The lock-in's output
        is V_s over the readout's reference R: reading = a G / (j w_d c R).  Temperature moves
        w_r (sqrt(1 + beta dT)), G ((Y_p(T) / Y_p(25))^2) and the gel (its tables at T, to
        0.1 K).  See :mod:`sensor.calibration` for the drive and references.
        """
        if unit.model is not self.tip:
            raise ValueError("a channel with a physical unit must be given the unit's model as its fingertip")
        phys = unit.physical
        self._unit = unit
        tip = phys.fingertip_at(phys.temperature_c)
        el = tip.element
        used = list(self._fast)
        p25 = phys.fingertip_at(REFERENCE_TEMPERATURE_C).element
        self._u_rho_a = float(el.params.mass_per_length_kg_m)
        self._u_c = float(el.params.damping_n_s_per_m2)
        self._u_omega25 = {m: float(p25.natural_angular_frequency(m)) for m in used}
        self._u_gain25 = {m: float(p25.unloaded_voltage(m)) * self._u_omega25[m] * self._u_c for m in used}
        self._u_sigma_v = {m: reading_sigma_v(tip, m) for m in used}
        b = el.params.width_m
        self._u_weights = {m: (b * el.cell_ratios(m, self.edges_m)).tolist() for m in used}
        self._u_drive = {m: 2 * math.pi * unit.drive_hz[m] for m in used}
        self._u_ref = {m: complex(unit.reference_v[m]) for m in used}
        self._u_drifts = phys.drift_c_per_s != 0.0
        self._u_time_s = 0.0
        self._u_tables: dict[tuple[int, float], object] = {}
        self._u_temperature_c = phys.temperature_c
        # The readout: the model's inverses with calibration's error in their uncertainty.
        cache = unit.readout_cache
        for m in used:
            key = ("inverse", m, self.exact)
            if key not in cache:
                rel = unit.uncertainty_tables(_TABLE_P)[m]
                cache[key] = CalibratedInverse(self.tip, m, None if self.exact else self._tables[m], rel)
            self._inverse[m] = cache[key]
        # Unloaded and settled before the scene, at the start's drive.
        steady0 = self._u_steady(self.mode, 0.0, 0.0, phys.temperature_c)
        self.envelope = steady0
        self._seed_a = steady0 * self._u_scale(self.mode, phys.temperature_c)
        self._resonator.start(self, self._u_detuning(self.mode, phys.temperature_c))
        self._unloaded_from = math.nan
        self._unloaded_sum, self._unloaded_n = 0j, 0

    def _u_detuning(self, mode: int, temperature_c: float) -> float:
        """K_d = rho A (w_r(T)^2 - w_d^2), N/m^2: the unit's detuning from the drive, a stiffness."""
        w_r = self._u_omega25[mode] * self._unit.physical.resonance_ratio(temperature_c)
        w_d = self._u_drive[mode]
        return self._u_rho_a * (w_r * w_r - w_d * w_d)

    def _u_steady(self, mode: int, kappa: float, gamma: float, temperature_c: float) -> complex:
        return normalized_response(kappa + self._u_detuning(mode, temperature_c), gamma, self._u_drive[mode], self._u_c)

    def _u_scale(self, mode: int, temperature_c: float) -> complex:
        """Envelope to reading: G(T) / (j w_d c R)."""
        gain = self._u_gain25[mode] * self._unit.physical.gain_ratio(temperature_c)
        return gain / (1j * self._u_drive[mode] * self._u_c) / self._u_ref[mode]

    def _u_table(self, mode: int, temperature_c: float):
        """The unit's (k_e, c_e) lookup for ``mode`` at ``temperature_c`` (tables to 0.1 K), or
        None for the exact gel."""
        t_q = round(temperature_c * 10.0) / 10.0
        key = (mode, t_q)
        if key not in self._u_tables:
            tip = self._unit.physical.fingertip_at(t_q)
            self._u_tables[key] = None if self.exact else foundation_table(tip, mode).at
        return self._u_tables[key]

    def update_trusted(self, pressure_cells_pa: Sequence[float], dt_s: float) -> Reading:
        """:meth:`SensorChannel.update_trusted` for the physical unit (see :meth:`_setup_unit`)."""
        if self._unit is None:
            return super().update_trusted(pressure_cells_pa, dt_s)
        mode = self.mode
        self._u_time_s += dt_s
        temp = self._unit.physical.temperature_at(self._u_time_s) if self._u_drifts else self._u_temperature_c
        self._u_temperature_c = temp
        table_at = self._u_table(mode, temp)
        weights = self._u_weights[mode]
        self.evaluations += 1
        if table_at is None:
            tip = self._unit.physical.fingertip_at(round(temp * 10.0) / 10.0)
            k_e, c_e = tip.foundation(np.asarray(pressure_cells_pa, float), mode)
            kappa, gamma = float(k_e @ np.asarray(weights)), float(c_e @ np.asarray(weights))
        else:
            kappa, gamma = _modal_load(table_at, pressure_cells_pa, weights)
        c, rho_a, w_d = self._u_c, self._u_rho_a, self._u_drive[mode]
        k_eff = kappa + self._u_detuning(mode, temp)
        steady = normalized_response(k_eff, gamma, w_d, c)
        rate = _rate(rho_a, w_d, c, k_eff, gamma)
        envelope, settled, tau = self._resonate(steady, rate, k_eff, gamma, dt_s)
        out = envelope * self._u_scale(mode, temp)
        ref = self._u_ref[mode]
        sigma = self._u_sigma_v[mode] / math.hypot(ref.real, ref.imag)
        iq = out + self._iq_noise() * sigma if self.noise else out
        v1_true = abs(out)
        phase = -math.atan2(out.imag, out.real) if v1_true > 0 else 0.0
        return _reading(mode, abs(iq), v1_true, phase, self.time_in_mode_s, tau, settled, kappa, gamma, iq)

    def _track(self, t: float, est: Estimate, a_ss: complex, gain: float = 1.0) -> None:
        """Re-zero while unloaded (calibrated units): re-centre the drive, renormalize.

        While the estimate has been "below_detection" for REZERO_S, the steady reading a_ss
        (the inference's, or the mean reading with steady dynamics) is the unloaded response,
        g / (1 - j delta) (:func:`sensor.calibration.detuning`): the drive moves by
        delta / tau0 in this mode and by the same fraction in every mode (temperature moves
        them alike), every reference by g.  Only a drift of more than REZERO_SIGMAS times the
        steady reading's own noise (``gain`` times a reading's sigma; a reading's sigma over
        the square root of the readings averaged with steady dynamics) is corrected: below that
        a correction would add noise, not remove drift.  A load below the detection limit is zeroed with it.
        """
        if est.status != "below_detection":
            self._unloaded_from = math.nan
            return
        if not t >= self._unloaded_from:  # a new unloaded stretch
            self._unloaded_from, self._unloaded_sum, self._unloaded_n = t, 0j, 0
        self._unloaded_sum += a_ss
        self._unloaded_n += 1
        if t - self._unloaded_from < REZERO_S:
            return
        if self._resonator.steady_reading:  # the readings themselves, averaged
            z, sigma_z = self._unloaded_sum / self._unloaded_n, self._sigma[self.mode] / math.sqrt(self._unloaded_n)
        else:
            z, sigma_z = a_ss, gain * self._sigma[self.mode]
        self._unloaded_from, self._unloaded_sum, self._unloaded_n = t, 0j, 0
        delta, g = detuning(z)
        if not (math.isfinite(delta) and g > 0):
            return
        # Each part only where it is significant (delta ~ Im z and g - 1 ~ Re z - 1 near resonance,
        # each known to sigma_z): a correction of noise would add it to every later reading.
        if not abs(delta) > REZERO_SIGMAS * sigma_z:
            delta = 0.0
        # The gain drifts slowly (eq. 17's Y_p^2: 0.04 %/K) and its estimate is the noisier part
        # of a short window's a_ss: renormalized only from a settled window (gain <= GAIN_FLOOR).
        if not (abs(g - 1.0) > REZERO_SIGMAS * sigma_z and gain <= GAIN_FLOOR):
            g = 1.0
        if delta == 0.0 and g == 1.0:
            return
        w_d = self._u_drive[self.mode]
        frac = delta / (self._tau0 * w_d)
        for m in self._u_drive:
            old = self._u_drive[m]
            self._u_drive[m] = new = old * (1.0 + frac)
            self._u_ref[m] *= g * old / new
        # The envelope's normalization G / (j w_d c) moved with w_d: the same V_s, rescaled.
        self.envelope *= 1.0 + frac
        self._resonator.retune(self)  # a carrier keeps its motion at the new drive
        if self._inference is not None:
            # in the new normalization the envelope is where it was: z / g now, relaxing to 1
            self._inference.restart(t, z / g)
        self.rezeros += 1

    def _new_carrier(self, mode: int) -> CarrierResonator:
        if self._unit is None:
            return super()._new_carrier(mode)
        return CarrierResonator(self._u_rho_a, self._u_c, self._u_drive[mode], self._carrier_spc)

"""A mode driven deep past its range reads "saturated", not "settling" for as long as the load lasts.

Where a grip takes a pad far past its driven mode's P_max faster than the selector switches (a
10 kg block in mode 1 at the accurate preset: V_1 ~ 1e-3, at the readout's noise), the readout's
inference of the steady reading never gains the precision to trust, and the selector, which
waits out "settling", kept the mode for the whole hold: the fingertip blind while the referee
said success.  The readings themselves show the saturation (sensor.channel.SATURATION_TAUS): a
damped envelope relaxes at least as fast as unloaded, so readings that stay under half the
output at P_max for ln 3 unloaded time constants prove the steady reading lies past P_max.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import piezotip
from piezotip.cosim.rows import STATUS_CODES
from piezotip.sensor.channel import SATURATION_TAUS, SensorChannel

DT = 0.005


def _channel(seed: int = 0) -> SensorChannel:
    return SensorChannel(piezotip.fingertip("grasp"), dynamics="envelope", mode=1, rng=np.random.default_rng(seed))


def _statuses(ch: SensorChannel, pressure_pa: float, seconds: float) -> list[str]:
    return [ch.estimate(ch.update_trusted([pressure_pa], DT)).status for _ in range(round(seconds / DT))]


@pytest.mark.parametrize("factor", [10.0, 100.0])
def test_a_load_far_past_p_max_reads_saturated_within_the_proof_time(factor):
    ch = _channel()
    tau0 = ch._tau0
    p_max = ch.inverse(1).p_max_pa
    statuses = _statuses(ch, factor * p_max, 3.0)
    assert "ok" not in statuses  # never a wrong estimate
    first = statuses.index("saturated")
    # The proof needs ln 3 tau0 of readings under half V(P_max): they start once the envelope has
    # fallen there, within a few readings of the step for a load this deep.
    assert first * DT <= SATURATION_TAUS * tau0 + 0.1
    assert all(s == "saturated" for s in statuses[first:])  # and it stays so while the load lasts


def test_a_load_inside_the_range_never_reads_saturated():
    ch = _channel(1)
    p = 0.5 * ch.inverse(1).p_max_pa
    statuses = _statuses(ch, p, 3.0)
    assert "saturated" not in statuses and statuses[-1] == "ok"


def test_a_ring_up_into_a_mode_that_holds_the_load_never_reads_saturated():
    """A switch starts the new mode's envelope at 0 (under any threshold): the proof's bound holds
    from that start too, so a mode whose range holds the load reads settling, then ok."""
    ch = _channel(2)
    p = 0.3 * ch.inverse(2).p_max_pa  # past mode 1's P_max, inside mode 2's
    _statuses(ch, p, 1.0)
    ch.select_mode(2)
    statuses = _statuses(ch, p, 2.0)
    assert "saturated" not in statuses and statuses[-1] == "ok"


def test_the_proof_time_is_the_envelopes_bound():
    """ln 3 tau0: from |A(t)| >= |A_ss| - (V/2 + |A_ss|) e^(-t/tau0) > V/2 for |A_ss| >= V."""
    v = 1.0
    t = SATURATION_TAUS
    for a_ss in (v, 2 * v, 10 * v):
        assert a_ss - (v / 2 + a_ss) * math.exp(-t) >= v / 2 - 1e-12
    assert v - (v / 2 + v) * math.exp(-0.99 * t) < v / 2  # and no shorter time proves it


@pytest.mark.slow
def test_a_heavy_grip_at_the_accurate_preset_is_read_in_the_top_mode():
    """The case that was blind: both pads held the 10 kg block in mode 1, "settling" throughout."""
    result = piezotip.run("grasp-10kg", preset="accurate")
    hold = result.data["phase"] == 4.0
    # Read, not settling: past the model's end (the gel's valid strain) the record says
    # "outside_model" where the readout itself reads "ok" (tests/test_outside_model.py).
    read = [STATUS_CODES.index("ok"), STATUS_CODES.index("outside_model")]
    for side in ("left", "right"):
        assert np.mean(np.isin(result.data[f"{side}_status"][hold], read)) > 0.95
        assert set(np.unique(result.data[f"{side}_mode"][hold])) == {4.0}

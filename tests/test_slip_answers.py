"""A slip is answered once, then the grip's raise is let settle before the fingertips judge again.

A raised grip rings in the fingers: the pads' pressure overshoots and falls back, and a trough
of the ring read against the peak before it looked like a new slip, answered with another
raise, whose ring looked like the next: at the fast preset the egg's grip went 0.73 -> 1.42 N in
30 ms (three "slips"), the glass jar's 5.6 -> 27 N in 70 ms (seven).  The fingertips' slip check
now waits six load-filter time constants after an answer, as the load's check always did.
"""

from __future__ import annotations

import itertools

import pytest

import piezotip
from piezotip import scenarios


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["multimode", "gentle"])
@pytest.mark.parametrize("scenario", ["grasp-fragile", "grasp-slippery", "grasp-raspberry"])
def test_slip_answers_are_at_least_the_settling_time_apart(scenario, kind):
    result = piezotip.run(scenario, overrides={"controller.kind": kind}, preset="fast")
    settle_s = 6.0 * scenarios.get(scenario, {"controller.kind": kind}).controller.load_filter_s
    slips = [e["time_s"] for e in result.events if e["kind"] == "slip"]
    gaps = [b - a for a, b in itertools.pairwise(slips)]
    assert all(gap >= settle_s - 1e-9 for gap in gaps), (slips, settle_s)

"""Grip economy (issue 29): the gentle controller (``controller.kind=gentle``) finds the grip that
holds from what the fingertips and joints feel (the probe: the grip grows while the pads slide,
the friction is measured there, the weight is the load that stays), and holds objects no test
tunes it on with at most 1.5x the grip they need, without crushing the fragile ones."""

import dataclasses
import math
import re

import pytest

from piezotip import api, scenarios
from piezotip.analysis.referee import judge
from piezotip.cosim.control.gentle import (
    GRIP_OVER_READ,
    carried_at_cap,
    carried_nothing_at_first,
    carried_under_friction,
    contact_fades,
    fingers_closed_for,
    grip_read_n,
    least_carrying_grip_n,
    lifted_off_friction,
    load_is_steady,
    loaded_pad_stiffness_n_m,
    pad_contact_stiffness_n_m,
    probe_verdict,
    sliding_read,
)
from piezotip.cosim.loop import CoSimulation

SAFETY = 1.25


def _ramp(n=30, g0=0.01, rate=1.02):
    return [g0 * rate**k for k in range(n)]


def test_probe_verdict_reads_sliding_pads_as_load_proportional_to_grip():
    grips = _ramp()
    lag = 0.9  # a load lagging an exponential grip by a constant time is a constant factor of it
    e, err, _, load = probe_verdict([(gi, 2 * 0.8 * gi * lag) for gi in grips], SAFETY)
    # The thirds' means: exact proportionality gives exactly 1; the scatter about each third's mean
    # (the ramp within it) is the error, a few hundredths here.
    assert e == pytest.approx(1.0, abs=1e-12) and 0.0 < err < 0.1
    assert load == pytest.approx(2 * 0.8 * lag * sum(grips) / len(grips))


def test_probe_verdict_reads_a_carried_weight_as_a_load_that_does_not_follow_the_grip():
    e, _, _, load = probe_verdict([(gi, 0.98) for gi in _ramp()], SAFETY)
    assert e == pytest.approx(0.0, abs=1e-12) and load == pytest.approx(0.98)


def test_probe_verdict_waits_until_the_grip_has_grown_by_the_safety_factor():
    short = _ramp(n=9, rate=1.01)  # the thirds' grips 1.03x apart: too close to tell
    assert math.isinf(probe_verdict([(gi, gi) for gi in short], SAFETY)[1])
    assert math.isinf(probe_verdict([(0.01, 0.01)] * 3, SAFETY)[1])


def test_a_falling_grip_tells_a_weight_from_sliding_pads_only_where_the_contact_can_fall():
    """A drive with dry friction leaves the touch's contact above a lower command, and it creeps
    down to it (the Panda's, 0.088 to 0.055 N): over such a fall a weight's load stays
    (elasticity 0) and sliding pads' falls with the grip (elasticity 1), and the probe reads it
    (``falls``).  A drive without friction applies the command, which only grows: a falling
    reading there is the drive settling, and tells nothing (infinite error)."""
    falling = list(reversed(_ramp()))
    weight = [(gi, 0.0196) for gi in falling]
    sliding = [(gi, 2 * 0.5 * gi) for gi in falling]
    assert probe_verdict(weight, SAFETY, falls=True)[0] == pytest.approx(0.0, abs=1e-12)
    e, err, _, _ = probe_verdict(sliding, SAFETY, falls=True)
    assert e == pytest.approx(1.0, abs=1e-12) and 0.0 < err < 0.1
    assert math.isinf(probe_verdict(weight, SAFETY)[1]) and math.isinf(probe_verdict(sliding, SAFETY)[1])
    # The thirds' means must still be the safety factor apart, whichever way.
    short = list(reversed(_ramp(n=9, rate=1.01)))
    assert math.isinf(probe_verdict([(gi, 0.02) for gi in short], SAFETY, falls=True)[1])
    # A falling span whose first third carried nothing starts again, as a growing one does.
    n = len(falling) // 3
    offset = [(gi, -0.13 if k < n else 0.46) for k, gi in enumerate(falling)]
    assert carried_nothing_at_first(offset, SAFETY, falls=True) and not carried_nothing_at_first(offset, SAFETY)


def test_probe_verdict_error_grows_with_the_loads_scatter():
    grips = _ramp()
    clean = probe_verdict([(gi, 1.0) for gi in grips], SAFETY)[1]
    noisy = probe_verdict([(gi, 1.0 + (0.2 if k % 2 else -0.2)) for k, gi in enumerate(grips)], SAFETY)[1]
    assert clean == 0.0 and noisy > 0.1


def test_a_span_whose_first_third_carried_nothing_is_told_apart_from_one_too_short():
    """The lift's load tared on a ringing reading starts below zero: the verdict cannot read a
    ratio of loads over such a span (probe_verdict's error is infinite however far the grip
    grows), and the probe starts it again; a span too short, or loaded from its start, is not."""
    grips = _ramp()
    n = len(grips) // 3
    offset = [(gi, -0.13 if k < n else 0.46) for k, gi in enumerate(grips)]  # the egg on Robotiq's 2F-85
    assert math.isinf(probe_verdict(offset, SAFETY)[1])
    assert carried_nothing_at_first(offset, SAFETY)
    assert not carried_nothing_at_first([(gi, 0.46) for gi in grips], SAFETY)  # loaded throughout
    short = _ramp(n=9, rate=1.01)
    assert not carried_nothing_at_first([(gi, -0.13) for gi in short], SAFETY)  # too short to tell anyway
    mixed = [(gi, (-0.13 if k % 2 else 0.2) if k < n else 0.46) for k, gi in enumerate(grips)]
    assert not carried_nothing_at_first(mixed, SAFETY)  # a first third that carried some load on average


def test_a_load_the_safety_factor_under_the_friction_limit_is_carried():
    """Once the pads slid at mu = 0.4, a steady load L is carried where the last third's mean grip
    G3 holds it with the safety factor, 1.25 L <= 2 mu G3: the 2 g wafer's 19.6 mN is carried
    from G3 = 1.25 x 19.6 / 0.8 = 30.6 mN on, before the grip has grown by the safety factor
    between the thirds (probe_verdict: no verdict yet).  Sliding pads' load 2 mu' G is never
    called carried unless mu is read high by the safety factor; a load that scatters, or is
    under the least load read, is not a weight; on a linkage the grip the load adds on its arc
    (slope s) counts, 2 mu (G3 + s L)."""
    mu, weight_n, fraction = 0.4, 0.0196, 0.02
    need_n = weight_n / (2 * mu)
    ramp = _ramp(n=12, g0=need_n, rate=1.02)  # from lift-off on: the thirds 1.08x apart
    carried = [(g, weight_n) for g in ramp]
    assert math.isinf(probe_verdict(carried, SAFETY)[1])
    g3 = sum(ramp[-4:]) / 4
    assert g3 < SAFETY * need_n  # not yet the safety factor over the need
    assert not carried_under_friction(carried, mu, SAFETY, fraction, 1e-3)
    longer = [(g, weight_n) for g in _ramp(n=15, g0=need_n, rate=1.02)]  # the thirds 1.22x apart
    g3 = sum(g for g, _ in longer[-5:]) / 5
    assert g3 >= SAFETY * need_n and math.isinf(probe_verdict(longer, SAFETY)[1])
    assert carried_under_friction(longer, mu, SAFETY, fraction, 1e-3)
    # The limit itself: exactly the safety factor under it is carried, a hair over is not.
    at = [(g3, weight_n)] * 6
    assert carried_under_friction(at, weight_n * SAFETY / (2 * g3), SAFETY, fraction, 1e-3)
    assert not carried_under_friction(at, weight_n * SAFETY / (2 * g3) * (1 - 1e-9), SAFETY, fraction, 1e-3)
    # Sliding pads at the true friction, read right or read low: never carried.
    sliding = [(g, 2 * mu * g) for g in _ramp(n=24, g0=need_n / 2, rate=1.0)]
    for read in (mu, 0.85 * mu, mu * SAFETY * 0.99):
        assert not carried_under_friction(sliding, read, SAFETY, fraction, 1e-3)
    assert carried_under_friction(sliding, mu * SAFETY * 1.01, SAFETY, fraction, 1e-3)  # read high by the factor
    # A load that scatters (stick-slip) is not a weight; nor one under the least load read.
    chatter = [(g, weight_n * (1.3 if k % 2 else 0.7)) for k, (g, _) in enumerate(longer)]
    assert not carried_under_friction(chatter, mu, SAFETY, fraction, 1e-3)
    assert not carried_under_friction(longer, mu, SAFETY, fraction, weight_n)
    assert not carried_under_friction(longer[:5], mu, SAFETY, fraction, 1e-3)  # under two samples a third
    # A linkage whose load closes its fingers by s L: the grip to hold is less by it.
    slope = 0.1
    g_link = SAFETY * weight_n / (2 * mu) - slope * weight_n
    linked = [(g_link, weight_n)] * 6
    assert carried_under_friction(linked, mu, SAFETY, fraction, 1e-3, arc_slope=slope)
    assert not carried_under_friction(linked, mu, SAFETY, fraction, 1e-3)


def test_a_load_that_fell_as_the_grip_grew_is_pads_that_slipped_not_a_weight():
    """Pads on slides that carried 0.40 N and then 0.30 N, steady, as the grip grew (they slipped
    down the object): the weight is at least 0.40 N, and 0.30 N is not called carried, though it
    lies the safety factor under 2 mu G3 (robosuite's Panda called a 53 g cylinder carried at
    0.30 N of its 0.52 N and lost it).  The same span with its load steady at 0.30 N throughout,
    or a load that rose to 0.30 N (an object leaving the table within the span), is carried;
    a fall within the least load read and the steadiness is no fall; on a linkage's arc, whose
    levers swing the load the lift reads, the rule does not apply."""
    mu, fraction, least = 0.407, 0.002, 0.005
    grips = _ramp(n=9, g0=0.46, rate=1.02)
    fell = [(g, load) for g, load in zip(grips, [0.40, 0.40, 0.40, 0.33, 0.31, 0.30, 0.30, 0.30, 0.30], strict=True)]
    assert SAFETY * 0.30 <= 2 * mu * sum(grips[-3:]) / 3  # the friction limit alone would call it carried
    assert not carried_under_friction(fell, mu, SAFETY, fraction, least)
    assert carried_under_friction([(g, 0.30) for g in grips], mu, SAFETY, fraction, least)
    rose = [(g, load) for g, load in zip(grips, [0.20, 0.25, 0.28, 0.30, 0.30, 0.30, 0.30, 0.30, 0.30], strict=True)]
    assert carried_under_friction(rose, mu, SAFETY, fraction, least)
    within = [(g, 0.30 + (0.004 if k < 3 else 0.0)) for k, g in enumerate(grips)]  # 4 mN over, under the least read
    assert carried_under_friction(within, mu, SAFETY, fraction, least)
    assert carried_under_friction(fell, mu, SAFETY, fraction, least, arc_slope=1e-9)


def test_the_grip_read_is_the_inverse_variance_blend_of_the_drive_and_the_fingertips():
    """(G_d / s_d^2 + G_f / s_f^2) / (1 / s_d^2 + 1 / s_f^2), worked by hand: a drive read 0.30 N
    within 1 N of friction and fingertips 0.10 N within 10 mN give (0.3 + 1000) / 10001 =
    0.10002 N; equal errors the mean; a drive without friction, or no fingertip reading, the
    drive's alone; fingertips without error theirs alone."""
    assert grip_read_n(0.30, 1.0, 0.10, 0.01) == pytest.approx((0.30 + 0.10 * 1e4) / (1.0 + 1e4), rel=1e-12)
    assert grip_read_n(0.30, 1.0, 0.10, 0.01) == pytest.approx(0.100020, abs=1e-6)
    assert grip_read_n(0.30, 0.05, 0.10, 0.05) == pytest.approx(0.20)
    assert grip_read_n(0.30, 0.0, 0.10, 0.01) == 0.30
    assert grip_read_n(0.30, 1.0, None, 0.01) == 0.30
    assert grip_read_n(0.30, 1.0, 0.10, 0.0) == 0.10


def test_load_is_steady_only_within_the_fraction():
    assert load_is_steady([0.98] * 10, 0.0057)
    chatter = [0.012 * (1 + (0.03 if k % 2 else -0.03)) for k in range(10)]  # pads sticking and slipping
    assert not load_is_steady(chatter, 0.0057)
    assert load_is_steady(chatter, 0.05)
    assert not load_is_steady([0.0, 0.0], 0.5) and not load_is_steady([1.0], 0.5)


def test_the_carried_bound_is_the_least_grip_that_carried_the_weight():
    """A span that began while the pads slid (load = 2 mu G, the table holding the rest) and
    ended carrying the weight W: the friction is at least W / 2 G only at a grip that carried W.
    The pads slid at mu = 0.6 up to G = W / 2 mu; the bound at the span's first grip read mu
    1.5x high (Menagerie's 2F-85, its 1.1 g box: "at least 0.93", dropped)."""
    mu, weight_n = 0.6, 0.0108
    grips = [0.0045 * 1.03**k for k in range(30)]
    span = [(g, min(2.0 * mu * g, weight_n)) for g in grips]
    least = least_carrying_grip_n(span, weight_n, 0.005)
    assert weight_n / (2.0 * least) == pytest.approx(mu, rel=0.04)  # the first grip that carried it
    assert weight_n / (2.0 * span[0][0]) > 1.5 * mu  # the span's first grip: the old bound
    falling = [(g, weight_n) for g in reversed(grips)]  # a friction drive's contact creeping down, carried all along
    assert least_carrying_grip_n(falling, weight_n, 0.005) == min(grips)
    assert least_carrying_grip_n([(0.01, 0.004), (0.02, 0.006)], weight_n, 0.005) == 0.01  # none carried it: the least


def test_one_reading_under_both_its_neighbours_does_not_set_the_carried_bound():
    """robosuite's Panda read its 1 g tissue box (need 8.2 mN) carried at 6.59 mN: one reading
    between 8.86 and 7.70 mN, the fingertips' scatter.  Its friction "at least 0.744" for 0.6
    held the box at its need, and it slipped.  A dip under both neighbours counts as the lower of
    them; a dip of two readings is read at the higher of the two (each is the other's neighbour); the
    span's ends are read as they are."""
    weight_n = 0.00981
    mn = [8.861, 6.594, 7.698, 7.746, 7.819, 7.764, 7.927]  # the Panda's span, mN (the first not yet carrying)
    span = [(g * 1e-3, 0.0095 if k == 0 else weight_n) for k, g in enumerate(mn)]
    least = least_carrying_grip_n(span, weight_n, 0.005)
    assert least == pytest.approx(7.698e-3, rel=1e-12)  # the dip at 6.594 counts as 7.698 (its lower neighbour)
    assert weight_n / (2.0 * least) < 0.64  # the friction bound: 0.637 for the true 0.6, not 0.744
    two = [(g, weight_n) for g in (0.0080, 0.0065, 0.0066, 0.0079)]  # a dip of two readings
    assert least_carrying_grip_n(two, weight_n, 0.005) == pytest.approx(0.0066, rel=1e-12)
    ends = [(g, weight_n) for g in (0.0060, 0.0080, 0.0079, 0.0070)]  # dips at the ends are read
    assert least_carrying_grip_n(ends, weight_n, 0.005) == 0.0060


#: Objects no other test names, across the rating, with the fragile ones of issue 29's table
#: (each was crushed, or held at 4-7x its need, by the controller before the probe).
HOLDOUT = {
    "sphere-50g-crush-2n": {"shape": "sphere", "mass_kg": 0.05, "friction": 0.5, "crush_force_n": 2.0, "size_m": 0.05},
    "egg-60g-crush-3n": {"shape": "egg", "mass_kg": 0.06, "friction": 0.6, "crush_force_n": 3.0},
    "sphere-25g-crush-0.8n": {"shape": "sphere", "mass_kg": 0.025, "friction": 0.5, "crush_force_n": 0.8, "size_m": 0.04},
    "sphere-40g-crush-1.2n": {"shape": "sphere", "mass_kg": 0.04, "friction": 0.7, "crush_force_n": 1.2, "size_m": 0.045},
    "sphere-3g-crush-0.1n": {"shape": "sphere", "mass_kg": 0.003, "friction": 1.0, "crush_force_n": 0.1, "size_m": 0.03},
    "box-150g": {"shape": "box", "mass_kg": 0.15, "friction": 0.8, "size_m": 0.05},
    "cylinder-500g-mu-0.2": {"shape": "cylinder", "mass_kg": 0.5, "friction": 0.2, "size_m": 0.06},
    "cylinder-8kg": {"shape": "cylinder", "mass_kg": 8.0, "friction": 1.2, "size_m": 0.07},
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(HOLDOUT))
def test_holdout_objects_are_held_with_at_most_1_5x_their_grip_and_never_crushed(name):
    obj = HOLDOUT[name]
    result = api.run("grasp", overrides={"controller.kind": "gentle", **{f"object.{k}": v for k, v in obj.items()}}, plot=False)
    s = result.summary
    assert s["outcome"] == "success", s["reason"]
    assert 1.0 <= s["grip_margin"] <= 1.5, (s["hold_grip_n"], s["needed_grip_n"])
    crush = obj.get("crush_force_n")
    if crush is not None and crush >= 1.5 * s["needed_grip_n"]:
        assert s["peak_contact_n"] < crush


def _measured_friction(events) -> float:
    """The friction the probe measured, from its "carried" event ("... friction 0.383 measured ...")."""
    carried = [e for e in events if (e["kind"] if isinstance(e, dict) else e.kind) == "carried"]
    assert len(carried) == 1, carried
    message = carried[0]["message"] if isinstance(carried[0], dict) else carried[0].message
    found = re.search(r"friction ([0-9.eE+-]+) measured while the pads slid", message)
    assert found, message
    return float(found.group(1))


@pytest.mark.slow
@pytest.mark.parametrize(
    "overrides, friction",
    [
        # A 1 kg cylinder at friction 0.4 (the multimode controller assumes 0.8) ...
        ({"object.mass_kg": 1.0, "object.shape": "cylinder", "object.size_m": 0.07, "object.friction": 0.4}, 0.4),
        # ... and a 0.2 kg egg at 0.6.
        ({"object.mass_kg": 0.2, "object.shape": "egg", "object.size_m": 0.044, "object.friction": 0.6}, 0.6),
    ],
)
def test_the_probe_measures_the_friction_of_slippery_objects_and_carries_them(overrides, friction):
    s = api.run("grasp", overrides={"controller.kind": "gentle", **overrides}, plot=False).summary
    assert s["outcome"] == "success", s["reason"]
    assert _measured_friction(s["events"]) == pytest.approx(friction, rel=0.15)
    assert s["grip_margin"] <= 1.5


def test_the_friction_bound_from_the_carried_grip_applies_only_past_the_cap():
    """Carried over the span, the friction is at least W / 2 G at its mean grip G: a friction
    measured while the pads slid is raised to that bound only where the grip it asks is past the
    cap (stick-slip reads it low there).  Under the cap it stands: a light grip's bound is only as
    good as the drive's reading of it, and a linkage that reads the grip low would make it a
    higher friction and a grip that does not hold."""
    from types import SimpleNamespace

    obs = SimpleNamespace(time_s=5.0, lift_pos_m=0.05)
    light = CoSimulation(scenarios.get("grasp")).controller
    light._slid, light.friction = True, 0.5
    light._carry(obs, 5.0, 0.0196, 0.01, 0.012)  # the bound, 0.0196 / 0.024 = 0.82, is not taken
    assert light.friction == 0.5 and light._grip_goal_n == pytest.approx(SAFETY * 0.0196 / (2 * 0.5))
    heavy = CoSimulation(scenarios.get("grasp")).controller
    heavy._slid, heavy.friction = True, 0.5
    weight_n = heavy.grip_cap_n  # asks 1.25 x the cap at 0.5
    heavy._carry(obs, 5.0, weight_n, 0.5 * weight_n, weight_n / 1.5)  # carried at a mean grip of W / 1.5: at least 0.75
    assert heavy.friction == pytest.approx(0.75) and any(e.kind == "carried" for e in heavy.events)


def test_the_friction_read_over_the_lift_off_is_a_lower_bound():
    """A span whose load reached the weight carried the object over part of it: its load stopped
    at the weight while the grip grew on, so its load / 2 G is under the friction (a bound, by
    Coulomb's law); read over its samples under the weight, it is the friction.  Walking back
    from the last span, the object is carried at the largest read met up to the first span that
    slid all through (its load under the weight) or could be read over its sliding samples,
    never one from before that, where a lighter grip is read less surely and, on a sphere, at a
    contact tilted less."""
    from types import SimpleNamespace

    weight_n, fraction = 0.981, 0.006
    # robosuite's Panda on the 100 g box: 0.80 read over the lift-off, 0.99 before it
    assert lifted_off_friction([(1.2, 0.3), (0.99, 0.9), (0.80, 0.985)], weight_n, fraction) == 0.99
    # dm_robotics' 2F-85 on the box: the stick-slip's peaks reached the weight a span before the lift-off's
    assert lifted_off_friction([(1.2, 0.2), (0.97, 0.5), (0.86, 0.81), (0.84, 0.99), (0.60, 0.98)], weight_n, fraction) == 0.86
    assert lifted_off_friction([(1.2, 0.2), (0.97, 0.5), (0.86, 0.99), (0.84, 0.99), (0.60, 0.98)], weight_n, fraction) == 0.97
    assert lifted_off_friction([(0.9, 0.5), (1.01, 0.985)], weight_n, fraction) == 1.01  # the last read stands where it is the larger
    assert lifted_off_friction([(0.6, 0.98)], weight_n, fraction) == 0.6  # one slide only
    # the last slid all through: its read is the friction, at the grip nearest the hold's (the
    # Panda's raspberry read 0.58, then 0.49 as its contact tilted, and held at 0.58 it fell)
    assert lifted_off_friction([(1.1, 0.3), (0.9, 0.5), (0.8, 0.9), (0.7, 0.9)], weight_n, fraction) == 0.7
    # the last reached the weight: read over its samples under it, and no further back
    samples = ((0.4, 0.72), (0.45, 0.81), (0.5, 0.9), (0.6, 0.981), (0.7, 0.981), (0.8, 0.981))
    assert sliding_read(samples, weight_n, fraction) == pytest.approx((0.72 + 0.81 + 0.9) / (2 * (0.4 + 0.45 + 0.5)))
    assert lifted_off_friction([(0.99, 0.5), (0.8, 0.981, samples)], weight_n, fraction) == pytest.approx(0.9)
    # under a third of its samples under the weight: too short to read, a bound as before
    assert sliding_read(samples[2:], weight_n, fraction) is None
    assert lifted_off_friction([(0.99, 0.5), (0.8, 0.981, samples[2:])], weight_n, fraction) == 0.99
    obs = SimpleNamespace(time_s=5.0, lift_pos_m=0.05)
    c = CoSimulation(scenarios.get("grasp")).controller
    c._slid, c.friction, c._slides = True, 0.80, [(0.99, 0.5), (0.80, 0.981)]
    c._carry(obs, 5.0, 0.981, 0.3, 0.4)
    assert c.friction == 0.99 and c._grip_goal_n == pytest.approx(SAFETY * 0.981 / (2 * 0.99))
    assert "friction 0.99 measured while the pads slid" in c.events[-1].message


def test_a_friction_read_above_the_pads_highest_is_a_misread_said_and_read_again():
    """A probe that reads more friction than the pads can have (``controller.friction_max``) has
    misread the grip (a mounted drive reads light grips up to 2x off), not the object: it says so
    (a ``friction_misread`` event) and reads again, and never takes a reading past the bound as the
    friction.  With friction_max 0.5, every slide of the box of friction 1 is such a misread: it is
    carried at a friction of at least 0.5 and held at 1.25 x its weight over 2 x 0.5, twice the
    grip the measured friction would set, a margin of 2 x 1.25."""
    s = api.run("grasp", overrides={"controller.kind": "gentle", "controller.friction_max": 0.5}, preset="fast", plot=False).summary
    assert s["outcome"] == "success", s["reason"]
    misreads = [e["message"] for e in s["events"] if e["kind"] == "friction_misread"]
    assert misreads and all("reading again" in m for m in misreads)
    carried = next(e["message"] for e in s["events"] if e["kind"] == "carried")
    assert "friction at least 0.5" in carried and "measured while the pads slid" not in carried
    assert s["grip_margin"] == pytest.approx(2 * SAFETY, rel=0.05)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["tissue-box-1g", "paper-ball-2g", "cube-3g", "box-100g", "can-500g"])
def test_the_probe_says_carried_only_of_an_object_off_the_table(tmp_path, name):
    """The probe calls an object carried when the load stayed, and steady, while the grip grew
    (:func:`probe_verdict`, :func:`load_is_steady`).  At milli-newton grips the pads chatter on a
    100 g box and the load stays for the chatter's sake: the steady test keeps that from being
    called a weight (it was, and the box was left on the table).  Ground truth: at the verdict
    the table no longer touches the object, and the friction the probe measured while the pads
    slid is the object's within 15 %."""
    from piezotip.cosim.recorder import Recorder, read_recording

    config = scenarios.get("grasp", [*scenarios.object_overrides(name), "controller.kind=gentle"])
    sim = CoSimulation(config)
    c = sim.controller
    table = sim._table_i + 2
    verdicts, seen = [], [0]

    def watch(sim) -> None:
        if any(e.kind == "carried" for e in c.events[seen[0] :]):
            verdicts.append(abs(float(sim.data.sensordata[table])))
        seen[0] = len(c.events)

    result = sim.run(Recorder(tmp_path / "run"), on_step=watch)
    assert verdicts == [0.0], f"carried said with the table pressing the object by {verdicts} N"
    assert _measured_friction(c.events) == pytest.approx(config.object.friction, rel=0.15)
    data, _ = read_recording(result.files[0])
    ctrl = config.controller
    verdict = judge(data, ctrl.lift_height_m, ctrl.hold_s, config.object.crush_force_n, [dataclasses.asdict(e) for e in c.events], True)
    assert verdict.outcome == "success", verdict.reason


@pytest.mark.slow
def test_the_gentle_grasp_gives_up_when_the_fingers_close_on_nothing(tmp_path):
    """At a 20 ms step the fingers' servo is not resolved and its jitter reads as a touch far
    from the object: the probe then grows the grip on fingers that close on air.  The fingers
    shut past the object's width end it as a loss (never lifted), not a drop from a grip that
    finally caught the object's edge."""
    s = api.run("grasp", overrides={"controller.kind": "gentle", "physics.timestep_s": 0.02, "physics.control_period_s": 0.02}, plot=False)
    assert s.summary["outcome"] == "never_lifted", s.summary["reason"]
    assert "past the object's width" in s.summary["reason"]


@pytest.mark.slow
def test_the_gentle_grasp_holds_the_catalogue_gentler_than_the_multimode_one():
    """On the default grasp (100 g box, friction 1) the multimode controller holds 2.25x what it
    needs (assumed friction 0.8, a friction check's raise); the gentle one within 1.5x."""
    multimode = api.run("grasp", overrides={"controller.kind": "multimode"}, plot=False).summary
    gentle = api.run("grasp", overrides={"controller.kind": "gentle"}, plot=False).summary
    assert multimode["success"] and gentle["success"]
    assert gentle["grip_margin"] <= 1.5 < multimode["grip_margin"]


def _unnamed_objects(seed: int, n: int) -> list[dict]:
    """``n`` objects no test names, drawn from ``seed``: 1.5 g to 2 kg (log-uniform), four
    shapes, friction 0.4-1.3, 20-70 mm, each crushing at 0.03 N or more and at 1.6-6x the least
    grip that holds it (feasible with the hold's 1.25x and its sigma)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        shape = str(rng.choice(["box", "cylinder", "sphere", "egg"]))
        mass_kg = float(np.exp(rng.uniform(np.log(0.0015), np.log(2.0))))
        friction, size_m = float(rng.uniform(0.4, 1.3)), float(rng.uniform(0.02, 0.07))
        need_n = mass_kg * 9.81 / (2.0 * friction)
        crush_n = max(0.03, need_n * float(rng.uniform(1.6, 6.0)))
        out.append(
            {
                "object.shape": shape,
                "object.mass_kg": mass_kg,
                "object.friction": friction,
                "object.size_m": size_m,
                "object.crush_force_n": crush_n,
            }
        )
    return out


@pytest.mark.slow
@pytest.mark.parametrize("obj", _unnamed_objects(2026, 12), ids=lambda o: f"{o['object.shape']}-{1e3 * o['object.mass_kg']:.3g}g")
def test_objects_no_test_tunes_on_are_held_within_one_and_a_half_of_their_need_and_never_crushed(obj):
    """Issue 43's measure on the house gripper, at default settings: success (up, held, put back,
    as the referee judges it from the record), the hold within 1.5x of the least grip, and the
    fingers' force from the touch to the release under the object's crush force.  (Twenty such
    objects, drawn as here, held at 1.16-1.34x: docs/cosimulation.md, "Grip economy".)"""
    result = api.run("grasp", overrides=obj)
    s = result.summary
    assert result.outcome == "success", result.reason
    assert 1.0 < s["grip_margin"] <= 1.5
    assert s["peak_contact_n"] < obj["object.crush_force_n"]


def test_a_grip_read_to_rise_counts_only_where_the_fingers_closed():
    """fingers_closed_for: a rise of the grip read between a span's first and last thirds asks the
    fingers' mean opening to have fallen between them, by at least the rise over GRIP_OVER_READ
    times the pads' stiffness; a fall is never asked (the fingers open, or close on an object
    narrowing under the pads); a span too short for a verdict passes."""
    k = 768.0  # robosuite's Panda's pads on the opening, N/m

    def stiffness(grip_n: float) -> float:
        return k

    grips = [0.0096, 0.0097, 0.0102, 0.012, 0.0121, 0.0122]  # robosuite's Panda reading its can's creep
    rise = (0.0121 + 0.0122 - 0.0096 - 0.0097) / 2  # between the thirds' means (two samples each)
    opened = [(g, 0.0249, 0.059976 + (1e-6 if i >= 4 else 0.0)) for i, g in enumerate(grips)]
    assert not fingers_closed_for(opened, stiffness)
    still = [(g, 0.0249, 0.059976) for g in grips]
    assert not fingers_closed_for(still, stiffness)
    enough = rise / (GRIP_OVER_READ * k)  # the last third's mean opening that far under the first's
    closing = [(g, 0.0249, 0.059976 - (1.01 * enough if i >= 4 else 0.0)) for i, g in enumerate(grips)]
    assert fingers_closed_for(closing, stiffness)
    creeping = [(g, 0.0249, 0.059976 - (0.99 * enough if i >= 4 else 0.0)) for i, g in enumerate(grips)]
    assert not fingers_closed_for(creeping, stiffness)  # the Rethink's cube: 0.12 um for a 1.7 mN rise
    assert fingers_closed_for(creeping, lambda grip_n: 1.02 * k)  # pads stiffer under their load: enough
    falling = [(g, 0.0249, 0.059976 - 1e-5 * i) for i, g in enumerate(reversed(grips))]
    assert fingers_closed_for(falling, stiffness)
    assert fingers_closed_for(still[:5], stiffness)  # a third of one sample: no verdict is read from it


def test_the_pads_loaded_stiffness_is_gents_tangent_on_the_full_face():
    """loaded_pad_stiffness_n_m: E A / (2 h0) at no load, and a central difference of Gent's law
    (the pressure over the indentation, on the opening: two pads in series) under a grip."""
    from piezotip.sensor.gel import GelParams, gent_pressure_pa, stretch_from_pressure

    gel, area = GelParams(), 4e-4
    no_load = pad_contact_stiffness_n_m(gel.youngs_modulus_pa, gel.thickness_m, area)
    assert loaded_pad_stiffness_n_m(gel, area, 0.0) == pytest.approx(no_load, rel=1e-9)
    for grip_n in (0.5, 5.0, 20.0):
        lam = float(stretch_from_pressure(grip_n / area, gel))
        h = 1e-6
        dp_dlam = (float(gent_pressure_pa(lam - h, gel)) - float(gent_pressure_pa(lam + h, gel))) / (2 * h)
        # the opening closes by 2 h0 dlambda for a pad pressure dP: k = A dP / (2 h0 dlambda)
        assert loaded_pad_stiffness_n_m(gel, area, grip_n) == pytest.approx(area * dp_dlam / (2 * gel.thickness_m), rel=1e-6)
    assert loaded_pad_stiffness_n_m(gel, area, 20.0) > 5 * loaded_pad_stiffness_n_m(gel, area, 0.0)


def test_a_probe_at_its_cap_decides_on_the_span_it_has():
    """carried_at_cap: robosuite's Panda lifted its 2.2 kg block (0.9x friction) at 13 N of its
    20 N cap, and the load stayed at the weight while the grip grew 1.2x from the span's first
    third to its last: too little for the verdict below the cap (grip_safety, which the cap left
    no room for), and the probe gave up, "never lifted", with the block off the table.  At the
    cap the span decides as it is: a load that did not follow the grip (the elasticity's 2-sigma
    interval under 1/2) and is steady is carried; a load that followed it (pads sliding at the
    cap), a grip that did not change, a load that scatters (stick-slip) or nothing carried is not."""
    fraction, min_load_n = 0.006, 0.01
    grips = _ramp(30, 14.0, 1.01)  # 1.35x over the span, its thirds 1.22x apart
    carried = [(g, 21.58 * (1 + 1e-4 * (-1) ** k)) for k, g in enumerate(grips)]
    assert math.isinf(probe_verdict(carried, SAFETY)[1])  # below the cap: not yet told
    assert carried_at_cap(carried, fraction, min_load_n)
    assert not carried_at_cap([(g, 1.2 * g) for g in grips], fraction, min_load_n)  # sliding at the cap
    assert not carried_at_cap([(20.0, 21.58)] * 30, fraction, min_load_n)  # the grip never changed: nothing told
    assert not carried_at_cap([(g, 0.005) for g in grips], fraction, min_load_n)  # nothing carried
    chatter = [(g, 21.58 * (1 + 0.05 * (-1) ** k)) for k, g in enumerate(grips)]
    assert probe_verdict(chatter, 1.0)[0] < 0.5 and not carried_at_cap(chatter, fraction, min_load_n)  # not steady
    assert not carried_at_cap(carried[:5], fraction, min_load_n)  # under two samples a third: nothing to tell
    # a load that rose 0.3x as fast as a grip that grew by 2 %, within a scatter that leaves the
    # elasticity's 2-sigma interval across 1/2: not yet told apart from sliding
    barely = [(g, 21.58 * (g / 14.0) ** 0.3 * (1 + 0.005 * (-1) ** k)) for k, g in enumerate(_ramp(30, 14.0, 1.001))]
    elasticity, error, *_ = probe_verdict(barely, 1.0)
    assert elasticity < 0.5 <= elasticity + 2 * error and not carried_at_cap(barely, fraction, min_load_n)


def test_a_contact_fades_where_its_reading_and_the_load_fall_together():
    """contact_fades: pads sliding up a sphere that narrows under them carry 2 mu N, so the lift's
    load falls with the contact; robosuite's Panda's raspberry at the balanced preset read 9.0 mN,
    then 6.4 mN (sigma 0.4 mN) as the load fell from 39.7 to 29.3 mN while the probe's grip rose:
    fading.  Its 2 g wafer, off the table, read 27.7 mN, then 26.2 mN (sigma 0.45 mN) on both pads
    after a settling while its contact rose and its load stayed at 19.6 mN of a highest 19.9:
    not fading (a carried object's load is its weight).  Nor is a fall within 2 sigma, one
    while the grip did not rise, or one as the fingers opened (the touch's leftover creeping down
    to the drive's lower command, the fingers giving way in their friction band)."""
    assert contact_fades(0.0064, 0.0004, 0.0090, True, False, 0.0293, 0.0397)
    assert not contact_fades(0.0262, 0.00045, 0.0277, True, False, 0.0196, 0.0199)  # the wafer, carried
    assert not contact_fades(0.0064, 0.0004, 0.0090, False, False, 0.0293, 0.0397)  # the grip did not rise
    assert not contact_fades(0.0083, 0.0004, 0.0090, True, False, 0.0293, 0.0397)  # within 2 sigma
    # the tests' slide gripper's 3 g box early in its probe: 8.3 -> 7.3 mN, the load 49.7 -> 45.3 mN,
    # as the touch's leftover crept down and the fingers opened 3.5 um: no fade
    assert not contact_fades(0.0073, 0.0002, 0.0083, True, True, 0.0420, 0.0497)
    assert contact_fades(0.0073, 0.0002, 0.0083, True, False, 0.0420, 0.0497)
    # the load's fall must be at least the share 2 sigma is of the reading (0.8 / 9.0 mN: 8.9 %)
    top_load_n = 0.0397
    assert contact_fades(0.0064, 0.0004, 0.0090, True, False, 0.90 * top_load_n, top_load_n)
    assert not contact_fades(0.0064, 0.0004, 0.0090, True, False, 0.92 * top_load_n, top_load_n)

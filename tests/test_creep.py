"""reports/creep.py: the held-object creep measurement (issue 29, item 3).

The rig's lift profile against the closed form of a trapezoidal move, the needed grip against
m g / (2 mu), the contact variants' names and what they write, and real measurements: a 100 g box
held at 1.2x the needed grip within the creep limit, not held at 0.8x, and sliding when the grip
is dropped to 0.8x in the air; then the CLI's ``creep --quick --json``.
"""

import io
import json
import math
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pytest

from piezotip import cli, scenarios
from piezotip.reports import creep
from piezotip.reports.creep import CONTACT_VARIANTS, CREEP_LIMIT_MM_S, apply_contact, measure_creep, needed_grip_n, ramp_duration_s, ramp_m

# ---------------------------------------------------------------------------------------
# The lift's trapezoidal profile.
# ---------------------------------------------------------------------------------------

#: (distance m, top speed m/s, acceleration m/s^2): the rig's own lift (10 mm at 0.05 m/s and
#: 0.5 m/s^2: a trapezoid, cruise 0.1 s), a move too short to reach its speed (a triangle), the
#: boundary between them (D = v^2 / a: no cruise), and a long fast one.
PROFILES = [(0.01, 0.05, 0.5), (0.002, 0.05, 0.5), (0.005, 0.05, 0.5), (0.3, 0.2, 4.0)]


def closed_form(distance, speed, accel):
    """Duration and position of a trapezoidal move, written from scratch: accelerate at ``accel``
    to v = min(speed, sqrt(D a)), cruise, brake at ``accel``; x(t) piecewise."""
    v = min(speed, math.sqrt(distance * accel))
    t_acc = v / accel
    t_cruise = distance / v - v / accel  # D = v t_cruise + v^2 / a
    total = 2 * t_acc + t_cruise

    def x(t):
        if t <= 0:
            return 0.0
        if t <= t_acc:
            return 0.5 * accel * t * t
        if t <= t_acc + t_cruise:
            return 0.5 * v * t_acc + v * (t - t_acc)
        if t <= total:
            return distance - 0.5 * accel * (total - t) ** 2
        return distance

    return total, x


@pytest.mark.parametrize(("distance", "speed", "accel"), PROFILES)
def test_ramp_duration_is_the_trapezoids(distance, speed, accel):
    total, _ = closed_form(distance, speed, accel)
    expected = distance / speed + speed / accel if distance >= speed**2 / accel else 2 * math.sqrt(distance / accel)
    assert total == pytest.approx(expected, rel=1e-12)  # the test's own closed form, two ways
    assert ramp_duration_s(distance, speed, accel) == pytest.approx(expected, rel=1e-12)


def test_rig_lift_numbers():
    """10 mm at 0.05 m/s, 0.5 m/s^2: 0.1 s accelerating (2.5 mm), 0.1 s cruising (5 mm), 0.1 s braking."""
    assert ramp_duration_s(0.01, 0.05, 0.5) == pytest.approx(0.3, rel=1e-12)
    for t, x in [(0.05, 0.000625), (0.1, 0.0025), (0.15, 0.005), (0.2, 0.0075), (0.25, 0.009375), (0.3, 0.01)]:
        assert ramp_m(t, 0.01, 0.05, 0.5) == pytest.approx(x, rel=1e-9, abs=1e-15), t


@pytest.mark.parametrize(("distance", "speed", "accel"), PROFILES)
def test_ramp_follows_the_closed_form_continuously_and_ends_at_its_distance(distance, speed, accel):
    total, x = closed_form(distance, speed, accel)
    ts = np.linspace(-0.1 * total, 1.2 * total, 2601)
    got = np.array([ramp_m(t, distance, speed, accel) for t in ts])
    np.testing.assert_allclose(got, [x(t) for t in ts], rtol=0, atol=1e-12 * distance)
    # continuous, monotone, never faster than the top speed (the step's chord speed)
    steps = np.diff(got)
    assert steps.min() >= -1e-15
    assert steps.max() <= min(speed, math.sqrt(distance * accel)) * (ts[1] - ts[0]) * (1 + 1e-9)
    # at rest before, at the distance at its end and after
    assert ramp_m(0.0, distance, speed, accel) == 0.0
    assert ramp_m(total, distance, speed, accel) == pytest.approx(distance, rel=1e-12)
    assert ramp_m(2 * total, distance, speed, accel) == distance
    # symmetric: the second half mirrors the first
    for f in (0.1, 0.3, 0.45):
        mirrored = distance - ramp_m(total * f, distance, speed, accel)
        assert ramp_m(total * (1 - f), distance, speed, accel) == pytest.approx(mirrored, abs=1e-12 * distance)


# ---------------------------------------------------------------------------------------
# The needed grip and the contact variants.
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(("mass", "mu", "gravity", "grip"), [(0.1, 0.5, 9.81, 0.981), (2.0, 1.0, 10.0, 10.0), (0.001, 1.5, 9.81, 0.00327)])
def test_needed_grip_is_weight_over_two_pads_of_friction(mass, mu, gravity, grip):
    assert needed_grip_n(mass, mu, gravity) == pytest.approx(grip, rel=1e-12)


def test_needed_grip_defaults_to_standard_gravity():
    assert needed_grip_n(1.0, 1.0) == pytest.approx(9.81 / 2, rel=1e-12)


def test_unknown_contact_variant_is_named_with_the_valid_ones():
    for call in (lambda: apply_contact(None, "no-such-model"), lambda: measure_creep("box", 0.1, 1.0, 1.2, contact="no-such-model")):
        with pytest.raises(ValueError, match="no-such-model") as info:
            call()
        for name in CONTACT_VARIANTS:
            assert name in str(info.value)


def test_variants_write_their_settings_into_the_model(monkeypatch):
    """An option goes into ``opt``; a ``pad_`` parameter into the pad strips' geoms and no other."""
    import mujoco

    from piezotip.cosim.assembly import build_scene

    monkeypatch.setitem(
        CONTACT_VARIANTS, "probe", {"impratio": 3.0, "pad_solref": (0.002, 1.5), "pad_condim": 4, "enable": ["speculative"]}
    )
    model = build_scene(scenarios.get("grasp"))
    pads = [g for g in range(model.ngeom) if "_pad_" in model.geom(g).name]
    others = [g for g in range(model.ngeom) if g not in pads]
    assert len(pads) == 2 * (scenarios.get("grasp").physics.pad_segments + 2)  # two pads: segments and two guards each
    before = model.geom_solref[others].copy(), model.geom_condim[others].copy()
    apply_contact(model, "probe")
    assert model.opt.impratio == 3.0
    assert model.opt.enableflags & int(mujoco.mjtEnableBit.mjENBL_SPECULATIVE)
    np.testing.assert_array_equal(model.geom_solref[pads], [[0.002, 1.5]] * len(pads))
    assert set(model.geom_condim[pads]) == {4}
    np.testing.assert_array_equal(model.geom_solref[others], before[0])
    np.testing.assert_array_equal(model.geom_condim[others], before[1])


# ---------------------------------------------------------------------------------------
# Real measurements: the 100 g box (the grasp scenario's object), friction 1.
# ---------------------------------------------------------------------------------------


def test_box_at_1p2x_is_held_within_the_creep_limit():
    r = measure_creep("box", 0.1, 1.0, 1.2)
    assert r.needed_grip_n == pytest.approx(0.1 * 9.81 / 2, rel=1e-9)
    assert r.grip_n == pytest.approx(1.2 * r.needed_grip_n, rel=1e-12)
    assert r.outcome == "held" and r.stays_held
    assert 0 <= r.creep_mm_s <= CREEP_LIMIT_MM_S
    assert r.rise_mm > 5.0  # lifted (10 mm less the lift servo's sag)
    assert r.hold_s == pytest.approx(1.0, abs=0.01)


def test_box_at_0p8x_is_not_held():
    r = measure_creep("box", 0.1, 1.0, 0.8)
    assert r.outcome in ("never_lifted", "slid")
    assert not r.stays_held


def test_box_lifted_at_1p2x_slides_when_the_grip_drops_to_0p8x():
    r = measure_creep("box", 0.1, 1.0, 0.8, lift_grip_factor=1.2)
    assert r.grip_n == pytest.approx(0.8 * r.needed_grip_n, rel=1e-12)
    assert r.lift_grip_factor == 1.2
    assert r.rise_mm > 5.0  # it was lifted ...
    assert r.outcome == "slid"  # ... and slid out of the pads once the grip dropped
    assert r.creep_mm_s > 10 * CREEP_LIMIT_MM_S


# ---------------------------------------------------------------------------------------
# The command line.
# ---------------------------------------------------------------------------------------

SUMMARY_KEYS = {
    "objects",
    "held_1p2",
    "slid_0p8",
    "slid_in_air_0p8",
    "max_creep_1p2_mm_s",
    "max_creep_object",
    "wall_s_per_sim_s",
    "physics_wall_s_per_sim_s",
    "median_cost_ratio",
    "median_physics_cost_ratio",
    "meets_requirement",
    "cost_ratio",
    "physics_cost_ratio",
}


def _strict_json(text):
    def refuse(name):
        raise ValueError(f"non-strict JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def test_cli_creep_quick_json(tmp_path):
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        rc = cli.main(["creep", "--quick", "--json", "--out", str(tmp_path)])
    report = _strict_json(out.getvalue())
    assert {"creep_limit_mm_s", "slid_mm", "hold_s", "contact_variants", "rows", "summary", "files"} <= set(report)
    assert report["creep_limit_mm_s"] == CREEP_LIMIT_MM_S
    assert report["hold_s"] == creep.QUICK["hold_s"]
    assert set(report["summary"]) == set(CONTACT_VARIANTS)
    for name, entry in report["summary"].items():
        assert set(entry) == SUMMARY_KEYS, name
        assert entry["objects"] == len(creep.QUICK["masses_kg"])
    # every object at every grip under every variant
    assert len(report["rows"]) == len(creep.QUICK["masses_kg"]) * len(creep.GRIP_CASES) * len(CONTACT_VARIANTS)
    assert report["summary"]["current"]["cost_ratio"] == pytest.approx(1.0)
    assert rc == (0 if report["summary"]["current"]["meets_requirement"] else 1)
    assert report["files"] == [str(tmp_path / "creep.json")]
    written = _strict_json((tmp_path / "creep.json").read_text())
    assert written["summary"] == report["summary"]


# Sliding pads (models/README.md, "Sliding pads"): MuJoCo's convex contacts open a sliding hard
# contact within a step, the gel throws the strip and the pressure chatters; the compliant pad
# contact (physics.pad_contact=compliant) rests deep enough not to open.
@pytest.mark.parametrize("obj", [("box", 0.5, 0.5), ("sphere", 0.1, 1.0)])
def test_sliding_pads_chatter_with_hard_contacts_and_not_with_compliant_ones(obj):
    from piezotip.reports.creep import sliding_chatter

    assert sliding_chatter(*obj, contact="hard") > 0.1
    assert sliding_chatter(*obj) < 0.01  # the model's own (compliant) pad contact


def test_the_light_sphere_that_ratcheted_down_hard_pads_is_held_by_the_compliant_ones():
    # The hard contact's worst object on the creep grid (models/README.md): 1 g at mu 1, 1.2x.
    assert measure_creep("sphere", 0.001, 1.0, 1.2, contact="hard").outcome == "creeps"
    r = measure_creep("sphere", 0.001, 1.0, 1.2)
    assert r.outcome == "held" and r.creep_mm_s <= CREEP_LIMIT_MM_S


def test_an_unknown_pad_contact_is_refused_naming_the_key():
    from piezotip import scenarios

    with pytest.raises(ValueError, match=r"physics\.pad_contact"):
        scenarios.get("grasp", ["physics.pad_contact=soft"])

"""Objects no test names, drawn at random within the catalogue's own ranges, grasped on each
gripper: the check a user makes with objects of their own (issue 43: "hidden objects from 1.5 g
upwards that crush at 0.03 N or more").

Each object (:func:`draw`) is one of the catalogue's shapes, as wide as the catalogue's objects
are (20-80 mm, cut to what the gripper's open pads take), as dense as they are (log-uniform
between the catalogue's lightest and densest, 37-19,500 kg/m^3: a tissue box to a tungsten
block), as slippery as they are (uniform over the catalogue's frictions, 0.3-1.2), its mass
the density times the shape's volume within [1.5 g, 2 kg] (the issue's lightest hidden object;
the catalogue's 2 kg block, the heaviest every gripper here is rated for), and crushing at
1.5-4x the grip it needs flat-on, m g / (2 mu), never under 0.03 N.  Nothing is tuned to a
gripper.

A run is judged as the tables judge one (reports/gripper_tables.py): the referee's outcome, the
grip held over the least that holds (within 1.5x is the goal), the whole grasp's peak.  A round
object pinched above its centre needs more than m g / (2 mu) (the referee's need counts the
contacts' tilt), so its crush force can fall under 1.5x its need: crushing it breaks no goal,
and the table counts it apart.  An object no grip within the gripper's rating could hold is
infeasible, and not run.

    python -m piezotip.reports.random_objects --count 30 --seed 0 --grippers house Panda --preset balanced --out out/random-objects

Every run is appended to ``OUT/runs.jsonl`` as it ends (open it again to resume); the table goes
to ``OUT/table.md`` and is printed.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

#: The lightest hidden object issue 43 names, kg, and the heaviest the tables' grippers are rated
#: for (the catalogue's 2 kg block), kg.
MASS_RANGE_KG = (0.0015, 2.0)
#: The crush force's range over the flat-on need, -: issue 43 protects objects crushing at 1.5x
#: their need and up.
CRUSH_OVER_NEED = (1.5, 4.0)
#: The lightest crush force issue 43 protects, N.
LEAST_CRUSH_N = 0.03
#: The grip margin the runs are judged by, -.
GOAL_MARGIN = 1.5
#: The house gripper's label (no ``gripper.*`` keys).
HOUSE = "house"


def catalogue_ranges() -> dict[str, tuple[float, float]]:
    """The catalogue's ranges the draws keep to: ``size_m`` (m), ``density_kg_m3`` and
    ``friction``, each (least, most), over :data:`scenarios.OBJECTS`."""
    from piezotip import scenarios

    objects = list(scenarios.OBJECTS.values())
    densities = [obj.mass_kg / shape_volume_m3(obj.shape, obj.size_m) for obj in objects]
    return {
        "size_m": (min(o.size_m for o in objects), max(o.size_m for o in objects)),
        "density_kg_m3": (min(densities), max(densities)),
        "friction": (min(o.friction for o in objects), max(o.friction for o in objects)),
    }


def shape_volume_m3(shape: str, size_m: float) -> float:
    """The volume of a catalogue shape ``size_m`` (m) across, m^3, from its geom's half-sizes
    (:mod:`cosim.shapes`): a box's 8 a b c, an ellipsoid's 4/3 pi a b c, a sphere's 4/3 pi r^3,
    a cylinder's pi r^2 2h."""
    from piezotip.cosim.shapes import get_shape

    geom = get_shape(shape).geom(size_m)
    a, b, c = geom.size
    kind = geom.geom_type
    if kind == "box":
        return 8.0 * a * b * c
    if kind == "ellipsoid":
        return 4.0 / 3.0 * math.pi * a * b * c
    if kind == "sphere":
        return 4.0 / 3.0 * math.pi * a**3
    if kind == "cylinder":
        return math.pi * a * a * 2.0 * b
    raise ValueError(f"shape {shape!r}: no volume for a {kind!r} geom")


def draw(count: int, seed: int, widest_m: float | None = None, gravity_m_s2: float = 9.81) -> list[dict]:
    """``count`` objects (``object.*`` keys) drawn with ``seed`` (numpy's default generator)
    within :func:`catalogue_ranges`, no wider than ``widest_m`` (m, the gripper's open pads:
    None, the catalogue's widest) (the module's docstring has the rules)."""
    if count < 0:
        raise ValueError(f"count must be 0 or more, got {count!r}")
    from piezotip import scenarios

    ranges = catalogue_ranges()
    shapes = sorted({obj.shape for obj in scenarios.OBJECTS.values()})
    least_m, most_m = ranges["size_m"]
    if widest_m is not None:
        most_m = min(most_m, widest_m)
    if most_m <= least_m:
        raise ValueError(f"the gripper takes objects up to {widest_m!r} m, under the catalogue's narrowest, {least_m} m")
    rng = np.random.default_rng(seed)
    rho_lo, rho_hi = ranges["density_kg_m3"]
    mu_lo, mu_hi = ranges["friction"]
    drawn = []
    for _ in range(count):
        shape = str(rng.choice(shapes))
        size_m = float(rng.uniform(least_m, most_m))
        density = float(np.exp(rng.uniform(math.log(rho_lo), math.log(rho_hi))))
        friction = float(rng.uniform(mu_lo, mu_hi))
        mass_kg = min(MASS_RANGE_KG[1], max(MASS_RANGE_KG[0], density * shape_volume_m3(shape, size_m)))
        flat_need_n = mass_kg * gravity_m_s2 / (2.0 * friction)
        crush_n = max(LEAST_CRUSH_N, flat_need_n * float(rng.uniform(*CRUSH_OVER_NEED)))
        drawn.append(
            {
                "object.shape": shape,
                "object.size_m": round(size_m, 5),
                "object.mass_kg": round(mass_kg, 6),
                "object.friction": round(friction, 3),
                "object.crush_force_n": round(crush_n, 4),
            }
        )
    return drawn


def gripper_keys(label: str) -> dict:
    """The ``gripper.*`` keys of ``label``: none for :data:`HOUSE`, else the tables' gripper of
    that name (:func:`gripper_tables.grippers`)."""
    if label == HOUSE:
        return {}
    from piezotip.reports.gripper_tables import grippers

    found = grippers()
    if label not in found:
        raise ValueError(f"gripper {label!r}: not installed here, or not one of {[HOUSE, *found]}")
    return found[label]


def run_one(label: str, obj: dict, preset: str | None, controller: str = "gentle") -> dict:
    """Grasp ``obj`` (``object.*`` keys) with gripper ``label``: the row the table reads, as the
    gripper tables make one (:func:`gripper_tables.one`), with the object's keys (an object the
    gripper's rating or open pads cannot take: outcome ``infeasible``, not run)."""
    from piezotip import scenarios
    from piezotip.analysis.experiment import feasible, gripper_limits
    from piezotip.reports.gripper_tables import one

    keys = gripper_keys(label)
    limit_n, gravity, widest_m = gripper_limits(scenarios.get("grasp", keys, preset))
    candidate = scenarios.ObjectConfig(**{key.removeprefix("object."): value for key, value in obj.items()})
    ok, why = feasible(candidate, limit_n, gravity, widest_m)
    if not ok:
        return {"gripper": label, "controller": controller, "preset": preset, **obj, "outcome": "infeasible", "reason": why}
    run = {
        "gripper": label,
        "object": "random",
        "controller": controller,
        "scenario": "grasp",
        "friction_x": 1.0,
        "mass_x": 1.0,
        "overrides": {**keys, **obj, "controller.kind": controller},
    }
    return {**one(run, preset), **obj}


def protected(row: dict) -> bool:
    """Whether the goal protects ``row``'s object from crushing: its crush force at least 1.5x the
    referee's need; an unknown need (a run the referee could not judge it in) protects it, so
    that no crush goes uncounted."""
    need = row.get("needed_grip_n")
    return need is None or row["object.crush_force_n"] >= GOAL_MARGIN * need


def verdict(row: dict) -> str:
    """A run as the goal judges it: ``held`` (a success within 1.5x), ``over`` (a success over
    it), ``crushed (unprotected)`` (its crush force under 1.5x its need), ``infeasible``, or the
    referee's failing outcome."""
    outcome = row["outcome"]
    if outcome == "success":
        return "held" if (row.get("grip_margin") or math.inf) <= GOAL_MARGIN else "over"
    if outcome == "crushed" and not protected(row):
        return "crushed (unprotected)"
    return outcome


def table(rows: list[dict]) -> str:
    """Markdown: per gripper and preset, how many runs each verdict has; then every run that
    missed the goal."""
    labels = list(dict.fromkeys((row["gripper"], row.get("preset")) for row in rows))
    kinds = ["held", "over", "crushed (unprotected)", "infeasible"]
    failing = sorted({verdict(row) for row in rows} - set(kinds))
    columns = [*kinds, *failing]
    lines = [f"| gripper | runs | {' | '.join(columns)} |", "|" + " --- |" * (len(columns) + 2)]
    for label, preset in labels:
        mine = [row for row in rows if (row["gripper"], row.get("preset")) == (label, preset)]
        counts = [sum(verdict(row) == kind for row in mine) for kind in columns]
        lines.append(f"| {label} ({preset or 'balanced'}) | {len(mine)} | {' | '.join(str(n) for n in counts)} |")
    missed = [row for row in rows if verdict(row) not in ("held", "infeasible", "crushed (unprotected)")]
    if missed:
        lines += ["", "missed:"]
        for row in missed:
            need, crush = row.get("needed_grip_n"), row["object.crush_force_n"]
            over = f" ({crush / need:.2f}x its need)" if need else ""
            lines.append(
                f"- {row['gripper']}: {row['object.shape']} {1e3 * row['object.mass_kg']:.4g} g, {1e3 * row['object.size_m']:.3g} mm, "
                f"friction {row['object.friction']}, crush {crush:.3g} N{over}: {verdict(row)}, "
                f"margin {row.get('grip_margin') or math.nan:.2f}, peak {row.get('peak_contact_n') or math.nan:.3g} N; "
                f"{row.get('reason') or ''}"
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=30, help="objects per gripper (default 30)")
    parser.add_argument("--seed", type=int, default=0, help="the draw's seed (default 0): every gripper draws with it, within its pads")
    parser.add_argument(
        "--grippers", nargs="+", default=[HOUSE], help=f"{HOUSE!r} or the tables' grippers (Panda, Rethink, Robotiq, 'Menagerie 2F-85')"
    )
    parser.add_argument("--preset", default=None, help="the fidelity preset (default: the scenario's own, balanced)")
    parser.add_argument("--controller", default="gentle")
    parser.add_argument("--out", type=Path, default=Path("out/random-objects"))
    args = parser.parse_args(argv)
    try:
        keys = {label: gripper_keys(label) for label in args.grippers}
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    journal = args.out / "runs.jsonl"
    rows = [json.loads(line) for line in journal.read_text().splitlines()] if journal.exists() else []
    done = {
        json.dumps({k: v for k, v in row.items() if k.startswith(("object.", "gripper", "controller", "preset"))}, sort_keys=True)
        for row in rows
    }
    from piezotip import scenarios
    from piezotip.analysis.experiment import gripper_limits

    for label in args.grippers:
        widest_m = gripper_limits(scenarios.get("grasp", keys[label]))[2]
        for obj in draw(args.count, args.seed, widest_m):
            key = json.dumps({**obj, "gripper": label, "controller": args.controller, "preset": args.preset}, sort_keys=True)
            if key in done:
                continue
            row = run_one(label, obj, args.preset, args.controller)
            rows.append(row)
            with journal.open("a") as fh:
                fh.write(json.dumps(row) + "\n")
            print(f"{label}: {obj['object.shape']} {1e3 * obj['object.mass_kg']:.4g} g: {verdict(row)}", file=sys.stderr, flush=True)
    text = table(rows)
    (args.out / "table.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""What a skin of attached fingertips costs per ``mj_step``, against the same model without them.

The scene: a fixed palm carrying a ``rows`` x ``cols`` grid of 20 x 20 mm box sites (25 mm
apart), and a 200 g, 40 mm box resting on four of them.  The same model is stepped three ways,
side by side in one process, in a plain ``mujoco.mj_step`` loop at MuJoCo's default options
(Euler, 2 ms):

- ``bare``: the model as it is (no fingertips);
- ``rigid``: the sites made rigid 20 x 20 x 5 mm box geoms (the same model with rigid pads, the
  skin a model has without piezotip: the box rests on four pads instead of the palm);
- ``touch``: MuJoCo's own ``<touch>`` sensor on every site (the cheapest tactile reading MuJoCo
  has: the normal force of the contacts inside the site's volume; the sites are grown 5.5 mm
  along z so that they reach past the pads' surfaces);
- ``piezotip``: :func:`piezotip.attach` on every site, bound: the gel pads (strips, contacts,
  the gel law in ``mjcb_passive``) and every fingertip's readout once a period, written to
  ``data.sensordata`` (``mjcb_sensor``).  ``piezotip_mechanics`` is the same model with the
  readout unbound: the pads and the gel law alone;
- ``piezotip_lean``: the same with sites the size of the element (7.5 x 5 mm): one strip a pad
  instead of three (the guards, the pad beyond the element, go; docs/attach.md);
- ``piezotip_touch``: ``attach(..., pad="touch")`` on the bare model's sites: no pad geometry,
  the palm's own contacts in each site read by MuJoCo's ``touch`` and pressing the element
  (the model steps bit for bit as ``bare``): the readout's cost alone, over ``touch``'s.

Each variant is warmed up, then timed in ``repeats`` rounds that alternate the variants (so
that each sees the machine alike); the fastest round is kept (noise only ever adds time).
The ratios over ``bare`` are what to quote; absolute times drift with the machine.
"""

from __future__ import annotations

import time

import mujoco

from piezotip.cosim import mjhooks
from piezotip.cosim.attach import attach

#: The box on the pads: its mass (kg) and half-size (m).
BOX_KG, BOX_HALF_M = 0.2, 0.02
#: Pad pitch on the palm, m, and the pad sites' half-sizes (the house pad's 20 x 20 mm), m.
PITCH_M, PAD_HALF_M = 0.025, 0.01
#: The element's half-sizes (7.5 x 5 mm, the paper's), m: a site this size carries a lean pad.
ELEMENT_HALF_M = (0.00375, 0.0025)


def skin_xml(rows: int, cols: int, touch: bool = False, rigid: bool = False, lean: bool = False) -> str:
    """The skin scene (module docstring); ``touch`` adds a ``<touch>`` sensor on every site,
    ``rigid`` a rigid pad geom (the gel's thickness) on every site, ``lean`` makes the sites the
    element's size."""
    sites, sensors = [], []
    z_half = 0.0055 if touch else 0.001  # a touch site must enclose the contacts on the pad (5 mm of gel above it)
    site_x, site_y = ELEMENT_HALF_M if lean else (PAD_HALF_M, PAD_HALF_M)
    for i in range(rows):
        for j in range(cols):
            x, y = (i - (rows - 1) / 2) * PITCH_M, (j - (cols - 1) / 2) * PITCH_M
            sites.append(f'<site name="tip{i}_{j}" type="box" size="{site_x} {site_y} {z_half}" pos="{x} {y} 0.005"/>')
            if rigid:  # the gel's 5 mm as a rigid block on the palm, where piezotip's pad would be
                sites.append(f'<geom name="pad{i}_{j}" type="box" size="{site_x} {site_y} 0.0025" pos="{x} {y} 0.0075"/>')
            sensors.append(f'<touch name="touch{i}_{j}" site="tip{i}_{j}"/>')
    half_x, half_y = rows * PITCH_M / 2 + 0.005, cols * PITCH_M / 2 + 0.005
    box_x, box_y = -(rows - 2) / 2 * PITCH_M + PITCH_M / 2, -(cols - 2) / 2 * PITCH_M + PITCH_M / 2  # over the first 2 x 2 pads
    return f"""<mujoco model="skin {rows}x{cols}">
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="palm" pos="0 0 0.1">
      <geom name="palm_geom" type="box" size="{half_x} {half_y} 0.005"/>
      {"".join(sites)}
    </body>
    <body name="box" pos="{box_x - PITCH_M / 2} {box_y - PITCH_M / 2} {0.1 + 0.01 + 0.005 + BOX_HALF_M + 0.001}">
      <freejoint/>
      <geom name="box_geom" type="box" size="{BOX_HALF_M} {BOX_HALF_M} {BOX_HALF_M}" mass="{BOX_KG}"/>
    </body>
  </worldbody>
  {"<sensor>" + "".join(sensors) + "</sensor>" if touch else ""}
</mujoco>"""


def _variants(rows: int, cols: int) -> dict[str, tuple[mujoco.MjModel, mujoco.MjData]]:
    out = {}
    for name, options in (("bare", {}), ("rigid", {"rigid": True}), ("touch", {"touch": True})):
        model = mujoco.MjModel.from_xml_string(skin_xml(rows, cols, **options))
        out[name] = (model, mujoco.MjData(model))
    sites = [f"tip{i}_{j}" for i in range(rows) for j in range(cols)]
    for name, lean, pad in (
        ("piezotip", False, "gel"),
        ("piezotip_mechanics", False, "gel"),
        ("piezotip_lean", True, "gel"),
        ("piezotip_touch", False, "touch"),
    ):
        spec = mujoco.MjSpec.from_string(skin_xml(rows, cols, lean=lean))
        tips = attach(spec, sites=sites, pad=pad)
        model = spec.compile()
        data = mujoco.MjData(model)
        loop = tips.bind(model, data)
        if name == "piezotip_mechanics":  # the gel law stays, the readout goes
            mjhooks.unregister(data, loop._hook)
        out[name] = (model, data)
    return out


def _time_steps(model: mujoco.MjModel, data: mujoco.MjData, steps: int) -> float:
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return (time.perf_counter() - start) / steps


def skin_report(rows: int = 4, cols: int = 4, steps: int = 1000, repeats: int = 5) -> dict:
    """Per-step cost of each variant (us, fastest round), its ratios over ``bare`` and over
    ``rigid``, and the cost per pad over ``bare`` (us) of each variant."""
    variants = _variants(rows, cols)
    for model, data in variants.values():  # settle the box on the pads, warm caches
        _time_steps(model, data, 500)
    best = dict.fromkeys(variants, float("inf"))
    for _ in range(repeats):
        for name, (model, data) in variants.items():
            best[name] = min(best[name], _time_steps(model, data, steps))
    pads = rows * cols
    bare = best["bare"]
    return {
        "pads": pads,
        "timestep_s": float(variants["bare"][0].opt.timestep),
        "integrator": mujoco.mjtIntegrator(variants["bare"][0].opt.integrator).name,
        "step_us": {name: 1e6 * t for name, t in best.items()},
        "ratio_over_bare": {name: t / bare for name, t in best.items()},
        "ratio_over_rigid": {name: t / best["rigid"] for name, t in best.items()},
        "per_pad_us": {name: 1e6 * (t - bare) / pads for name, t in best.items() if name != "bare"},
        "contacts": {name: int(data.ncon) for name, (_, data) in variants.items()},
    }


def format_skin_report(report: dict) -> str:
    """The report as a few lines of text."""
    lines = [
        f"skin of {report['pads']} fingertips, mj_step at {report['integrator']} {1e3 * report['timestep_s']:g} ms "
        "(fastest round; ratios measured side by side):"
    ]
    for name, us in report["step_us"].items():
        per_pad = report["per_pad_us"].get(name)
        extra = f", {per_pad:6.2f} us per pad over bare" if per_pad is not None else ""
        ratio, contacts = report["ratio_over_bare"][name], report["contacts"][name]
        rigid = report["ratio_over_rigid"][name]
        lines.append(f"  {name:<19} {us:8.1f} us/step  {ratio:6.2f}x bare  {rigid:5.2f}x rigid{extra}  ({contacts} contacts)")
    return "\n".join(lines)


if __name__ == "__main__":
    print(format_skin_report(skin_report()))

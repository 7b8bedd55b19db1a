"""The fingertip as a component: gel pads and their sensors on any MuJoCo model, in the user's loop.

::

    spec = mujoco.MjSpec.from_file("my_robot.xml")
    tips = piezotip.attach(spec, sites=["left_pad", "right_pad"])
    model = spec.compile()
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)
    sim.step()                          # the gel law, physics, sensor and readout for one period
    sim.readings()["left_pad"]          # estimate_pa, sigma_pa, status, mode, voltage
    sim.set_mode("left_pad", 2)

MuJoCo's ``touch`` convention: a box site marks the sensing patch.  Its x/y half-sizes are the
pad's (x along the element's length, +x towards its clamped root), its +z points out of the
finger, and its origin is the centre of the pad's base: the gel stands ``h0`` (5 mm) out along
+z, with the element under its centre.  ``bodies=[...]`` puts the pad on the face of a body's
collision geometry towards the other fingertip(s) instead (docs/attach.md).

The pads are the house gripper's, built by the same code (:func:`cosim.pad_model.add_pad_strips`
with the class ``pad`` of models/gripper.xml, copied); the step runs the same pieces as the
co-simulation loop (:class:`cosim.pad_bridge.PadBridge`, the loop's coverage cells and weights,
:func:`cosim.instrument.make_fingertip`, :class:`sensor.channel.SensorChannel` or its physical unit's
``UnitChannel``).  Everything added is named with the prefix ``piezotip/``; the user's bodies,
geoms, options and contacts are otherwise left as they were.
"""

from __future__ import annotations

import dataclasses
import math
import typing
import warnings
import weakref
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.checks import _coerce
from piezotip.sensor.config import SensorConfig

from . import mjhooks
from ._readout import ReadoutPass
from .build_checks import check_buildable
from .config import INTEGRATORS, PhysicsConfig, ScenarioConfig
from .control.config import ScriptedConfig
from .instrument import make_channels, make_fingertip, make_unit
from .loop import SimulationDiverged, coverage_cells, coverage_weights
from .pad_bridge import PadBridge, PadReading
from .pad_geometry import PadGeometry
from .pad_model import COMPLIANT_PAD_SOLIMP, HARD_PAD_SOLIMP, PadPlacement, _remap_keys, add_pad_strips, copy_pad_class, pad_time_constant_s
from .pad_placement import _body_patches, _geometry, _Patch, _placement, _site_patch, fingertip_pads, open_pose_qpos
from .scene import finite_state

__all__ = [
    "PREFIX",
    "AttachedPad",
    "FingertipLoop",
    "Fingertips",
    "PadCollisionWarning",
    "TipReading",
    "attach",
    "fingertip_pads",
    "open_pose_qpos",
    "pad_collision_bits",
]

#: MuJoCo's warnings on which it resets the data and steps on (a diverged state).
_UNSTABLE = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)


def _unstable_counts(data: mujoco.MjData) -> tuple[int, ...]:
    """How many times each of :data:`_UNSTABLE` has been raised on ``data``."""
    return tuple(int(data.warning[w].number) for w in _UNSTABLE)


PREFIX = "piezotip/"
"""What every name ``attach`` adds to a spec starts with: ``piezotip/left_pad/seg0``, ..."""
PAD_CLASS = f"{PREFIX}pad"
GEL_MATERIAL = f"{PREFIX}gel"

#: The scenario keys a fingertip configuration takes besides ``sensor.*``: the pad's resolution
#: and the period ``step`` advances (the readout's sample and the gel law's update).
PHYSICS_KEYS = ("physics.pad_segments", "physics.control_period_s", "physics.gel_update")
#: Keys that are the model's own options (read from it, never set by attach).
MODEL_KEYS = ("physics.timestep_s", "physics.integrator")
#: The scenario the fingertips' configuration is made in (its name and description): the default
#: grasp's, ``piezotip.scenarios.get("grasp")`` (tests/test_attach.py holds them equal), its object,
#: gripper and the rest the config's defaults; only its sensor, physics and controller are attach's.
ATTACH_SCENARIO = ("grasp", "grasp a 100 g box, lift 5 cm, hold 1 s, put it back (the README's main job)")

#: The model options the pads cannot run without: disable flags, and why each is needed.
_NEEDED = {
    mujoco.mjtDisableBit.mjDSBL_CONSTRAINT: "the pads touch through contacts and stop at a joint limit",
    mujoco.mjtDisableBit.mjDSBL_CONTACT: "the pads touch through contacts",
    mujoco.mjtDisableBit.mjDSBL_LIMIT: "the housing stop behind the gel is a joint limit",
    mujoco.mjtDisableBit.mjDSBL_SPRING: "the gel's stiffness acts as the strip joints' spring",
    mujoco.mjtDisableBit.mjDSBL_DAMPER: "the gel's loss acts as the strip joints' damping",
}
#: What a ``"touch"`` pad needs of them: the contacts it reads.
_TOUCH_NEEDED = {
    mujoco.mjtDisableBit.mjDSBL_CONSTRAINT: "a touch pad reads the contacts' normal force",
    mujoco.mjtDisableBit.mjDSBL_CONTACT: "a touch pad reads the contacts' normal force",
}
#: What :func:`attach`'s ``pad`` takes: the house's gel pad, or the model's own contacts read as MuJoCo's ``touch``.
PAD_KINDS = ("gel", "touch")
#: ...and enable flags they cannot run with.
_REFUSED = {
    mujoco.mjtEnableBit.mjENBL_OVERRIDE: "it replaces the pads' hard contact parameters (the gel is the pads' compliance)",
}

#: The pads' contacts under an explicit integrator (Euler, RK4, implicit, implicitfast): the
#: house's compliant impedance (models/README.md, "Pad contacts": d ramps from 0.1 at first touch
#: to 0.9999 over 30 um, a loaded contact resting 12-25 um deep) and a time constant of 3 steps
#: (the house's 2 ms floor or 2 steps otherwise).  Measured at Euler 2 ms, hard contacts (0.9999
#: from first touch, resting 0.1 um deep) open for a step now and then under a resting load: a
#: 200 g box on a 16-pad skin bounced at 21 Hz, its pads' load swinging 86-114 %; and a 12 g
#: finger on a 20 N s/m slide pressing 0.5-5 N rang at 51-69 % of its grip (10 um ramp: 0-69 %;
#: the house's 30 um ramp at 2 steps: 0-17 %; at 3 steps: steady at all three).  What it costs:
#: the pad's contact is softer (a plate dropped on a pad follows the discrete reference 12 %
#: off at its worst, 6 % at 2 steps), and the friction of a held object creeps more at the
#: user's impratio than at the house's 1000 (docs/attach.md).
EXPLICIT_PAD_SOLIMP = COMPLIANT_PAD_SOLIMP
EXPLICIT_CONTACT_STEPS = 3


# ---------------------------------------------------------------------------------------
# Where the pads go.
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AttachedPad:
    """One pad ``attach`` added.

    Attributes
    ----------
    name : the pad's name (the site's or the body's): the key of its readings.
    source : what placed it, for messages: ``"site 'left_pad'"`` or ``"body 'finger'"``.
    body : the body it sits on (its strips are that body's children).
    placement : the pad frame in that body (:class:`cosim.pad_model.PadPlacement`).
    geometry : its layout (the site's or face's size, the fingertip's resolution).
    strips : its strips' body names, distal first (``piezotip/<name>/seg0``, ...); none for a
        ``"touch"`` pad.
    kind : ``"gel"`` (the house's strip pad) or ``"touch"`` (no pad geometry: the model's own
        contacts in the zone, read by MuJoCo's ``touch`` sensor; :func:`attach`'s ``pad``).
    zone : a ``"touch"`` pad's zone, the box site its ``touch`` sensor reads (the site given, or
        ``piezotip/<name>/zone`` on a body's face); "" for a gel pad.
    """

    name: str
    source: str
    body: str
    placement: PadPlacement
    geometry: PadGeometry
    strips: tuple[str, ...]
    kind: str = "gel"
    zone: str = ""

    @property
    def area_m2(self) -> float:
        """The pad's area, m^2 (the site's or face's x by y)."""
        return self.geometry.pad_length_m * self.geometry.pad_width_m


# ---------------------------------------------------------------------------------------
# What the pads touch.
# ---------------------------------------------------------------------------------------


class PadCollisionWarning(UserWarning):
    """:func:`attach`: geoms that the fingertips' bodies touch and their pads cannot (their
    contype and conaffinity bits do not meet the pads')."""


def _touch(a: tuple[int, int], b: tuple[int, int]) -> bool:
    """Whether geoms of (contype, conaffinity) ``a`` and ``b`` may touch: MuJoCo's rule."""
    return bool(a[0] & b[1] or b[0] & a[1])


def _collision_bits(model: mujoco.MjModel, body: int, geoms: Sequence[int] | None = None) -> list[tuple[int, int]]:
    """(contype, conaffinity) of each of the body's collision geoms (either nonzero), or of ``geoms``."""
    if geoms is None:
        geoms = range(model.body_geomadr[body], model.body_geomadr[body] + model.body_geomnum[body])
    bits = [(int(model.geom_contype[g]), int(model.geom_conaffinity[g])) for g in geoms]
    return [b for b in bits if b != (0, 0)]


def pad_collision_bits(model: mujoco.MjModel, body: int, geoms: Sequence[int] | None = None) -> tuple[int, int] | None:
    """The contype and conaffinity of the pads on ``body``: those of the geoms they sit on.

    MuJoCo lets two geoms touch where ``contype1 & conaffinity2`` or ``contype2 & conaffinity1``
    is nonzero.  The pads' contype is the OR of the contypes of the body's collision geoms
    (contype or conaffinity nonzero; ``geoms`` of it instead: a geom-named fingertip's own),
    their conaffinity the OR of those geoms' conaffinities without the contype's bits.  A pad's
    strips are sibling bodies, and strips whose contype meets their conaffinity touch each
    other: the neighbours would tie together the strips the gel law keeps independent.  On a
    finger of MuJoCo's default contype 1, conaffinity 1 that is the house class's 1 and 0.

    The pads so touch every geom the body's geoms touch through their contype, and every geom
    whose contype meets the rest of their conaffinity.  They miss a geom that meets the body's
    geoms only through a conaffinity bit the body also has as contype (a contype 1,
    conaffinity 0 geom against a 1/1 finger); :func:`attach` names those
    (:class:`PadCollisionWarning`).

    Returns
    -------
    (contype, conaffinity), or None where the body has no collision geom (a site on a body with
    visual geoms only): its pad keeps the house class's contype 1, conaffinity 0.
    """
    bits = _collision_bits(model, body, geoms)
    if not bits:
        return None
    contype = conaffinity = 0
    for geom_contype, geom_conaffinity in bits:
        contype, conaffinity = contype | geom_contype, conaffinity | geom_conaffinity
    return contype, conaffinity & ~contype


def _set_pad_collision(spec: mujoco.MjSpec, pad: AttachedPad, model: mujoco.MjModel, pads: Sequence[AttachedPad]) -> None:
    """Give ``pad``'s strip geoms in ``spec`` the collision bits of the body it sits on in
    ``model`` (the user's, compiled; :func:`pad_collision_bits`, or the house class's where the
    body has no collision geom).  At the last of ``pads``, warn once, at :func:`attach`'s caller
    (:class:`PadCollisionWarning`), of the model's geoms that the pads' bodies touch and no pad
    can.  Only the bits count: explicit ``<pair>`` elements are not considered (a geom that
    touches a finger only through one touches no pad, and is not named), nor ``<exclude>``s
    (the user's name the user's bodies, not the strips)."""
    bits = pad_collision_bits(model, model.body(pad.body).id)
    if bits is not None:
        for strip in pad.strips:
            geom = spec.geom(f"{strip}_geom")
            geom.contype, geom.conaffinity = bits
    if pad is pads[-1]:
        house = spec.find_default(PAD_CLASS).geom
        bodies = [model.body(p.body).id for p in pads]
        given = [pad_collision_bits(model, b) or (house.contype, house.conaffinity) for b in bodies]
        missed = _untouched_geoms(model, bodies, given)
        if missed:
            warnings.warn(_untouched_message(model, missed, given), PadCollisionWarning, stacklevel=3)


def _untouched_geoms(model: mujoco.MjModel, bodies: Sequence[int], pads: Sequence[tuple[int, int]]) -> list[int]:
    """The collision geoms of ``model`` that no pad can touch (``pads``: each pad's contype and
    conaffinity) and a collision geom of a pad's body can (any, for a body without one); the
    geoms of the pads' bodies left out (the pads never touch them)."""
    fingers = [_collision_bits(model, b) for b in set(bodies)]
    missed = []
    for g in range(model.ngeom):
        bits = (int(model.geom_contype[g]), int(model.geom_conaffinity[g]))
        if model.geom_bodyid[g] in bodies or bits == (0, 0) or any(_touch(bits, p) for p in pads):
            continue
        if any(not finger or any(_touch(bits, f) for f in finger) for finger in fingers):
            missed.append(g)
    return missed


def _untouched_message(model: mujoco.MjModel, geoms: Sequence[int], pads: Sequence[tuple[int, int]]) -> str:
    """What :func:`_set_pad_collision` warns: the geoms (up to 12), the pads' bits, what to change."""

    def label(g: int) -> str:
        name = model.geom(g).name or f"#{g} of body {model.body(model.geom_bodyid[g]).name!r}"
        return f"{name!r} (contype {model.geom_contype[g]}, conaffinity {model.geom_conaffinity[g]})"

    shown = ", ".join(label(g) for g in geoms[:12]) + (", ..." if len(geoms) > 12 else "")
    contype = conaffinity = 0
    for pad_contype, pad_conaffinity in pads:
        contype, conaffinity = contype | pad_contype, conaffinity | pad_conaffinity
    if contype:
        change = f"add a bit of the pads' contype to their conaffinity (bit value {contype & -contype})"
    else:
        change = f"add a bit of the pads' conaffinity to their contype (bit value {conaffinity & -conaffinity})"
    bits = ", ".join(sorted({f"{c}/{a}" for c, a in pads}))
    return (
        f"attach: the fingertips' bodies touch {len(geoms)} geom(s) that their pads cannot: {shown}. The pads' contype/conaffinity: "
        f"{bits} (their bodies' collision geoms', the conaffinity without the contype's bits, so that no strip touches another). "
        f"To let the pads touch those geoms, {change}"
    )


# ---------------------------------------------------------------------------------------
# The fingertip's configuration and the model's options.
# ---------------------------------------------------------------------------------------


def _positive(value: object) -> bool:
    """Whether ``value`` is a finite positive number (else the config's own check names it)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value) and value > 0


def _integrator_name(option) -> str:
    """The scenario config's name of ``option``'s integrator (``discrete``, ``Euler``, ...)."""
    names = {name.lower(): name for name in INTEGRATORS}
    return names[mujoco.mjtIntegrator(option.integrator).name.removeprefix("mjINT_").lower()]


def fingertip_config(config: Mapping[str, object] | SensorConfig | None, option) -> ScenarioConfig:
    """The fingertips' whole validated configuration: the scenario config's ``sensor.*`` keys
    (a mapping of them, or a :class:`SensorConfig`) and :data:`PHYSICS_KEYS`, at the model's
    timestep and integrator (``option``), in the default grasp's scenario (:data:`ATTACH_SCENARIO`)
    under the scripted controller over the sensor's modes.  Every check is the scenario config's
    own, and the build check's (:func:`piezotip.cosim.build_checks.check_buildable`): a bad value
    is a ValueError naming its key."""
    if config is None:
        given: dict[str, object] = {}
    elif isinstance(config, SensorConfig):  # its pads are the scenario's: here the sites and bodies are
        given = {f"sensor.{f.name}": getattr(config, f.name) for f in dataclasses.fields(config) if f.name != "pads"}
    elif isinstance(config, Mapping):
        given = dict(config)
    else:
        raise ValueError(f"attach: config must be a mapping of sensor.* keys or a SensorConfig, got {type(config).__name__}")
    keys = [f"sensor.{f.name}" for f in dataclasses.fields(SensorConfig) if f.name != "pads"] + list(PHYSICS_KEYS)
    for key in given:
        if key in MODEL_KEYS:
            raise ValueError(f"attach: {key} is the model's own option (its <option>), not the fingertip's")
        if key == "sensor.pads":
            raise ValueError("attach: sensor.pads does not apply: the fingertips are the sites and bodies given to attach")
        if key not in keys:
            raise ValueError(f"attach: unknown fingertip key {key!r}; valid keys: {', '.join(keys)}")
    # The period: a whole number of the model's steps (at least one), the nearest to the one asked.
    timestep = float(option.timestep)
    asked = given.get("physics.control_period_s", PhysicsConfig().control_period_s)
    period = {"physics.control_period_s": max(1, round(float(asked) / timestep)) * timestep} if _positive(asked) and timestep > 0 else {}
    model_options = {"physics.timestep_s": timestep, "physics.integrator": _integrator_name(option), **period}
    try:
        sections: dict[str, dict[str, object]] = {"sensor": {}, "physics": {}}
        for key, value in {**given, **model_options}.items():
            head, _, name = key.partition(".")
            hint = typing.get_type_hints(SensorConfig if head == "sensor" else PhysicsConfig)[name]
            sections[head][name] = _coerce(key, hint, _plain(value))  # each value's type, as the scenario keys take it
        physics, sensor = PhysicsConfig(**sections["physics"]), SensorConfig(**sections["sensor"])
        # No controller runs here: the scripted one (which reads no sensor) over the sensor's modes
        # keeps the scenario's checks to the fingertip's own.
        settings = ScenarioConfig(
            name=ATTACH_SCENARIO[0],
            description=ATTACH_SCENARIO[1],
            physics=physics,
            sensor=sensor,
            controller=ScriptedConfig(modes=sensor.modes),
        )
        return check_buildable(settings.validate())
    except ValueError as err:
        whose = " (physics.timestep_s is the model's option timestep)" if "physics.timestep_s" in str(err) else ""
        raise ValueError(f"attach: {err}{whose}") from None


def _plain(value):
    """``value`` with numpy scalars (alone or in a list) as Python numbers."""
    if hasattr(value, "item") and callable(value.item):
        return value.item()
    if isinstance(value, (list, tuple)):
        return type(value)(_plain(v) for v in value)
    return value


def _check_options(option, who: str = "attach", kind: str = "gel") -> None:
    """The model's options the pads of ``kind`` need (``option``: an MjSpec's or an MjModel's);
    ``who`` begins the messages.  Any integrator and timestep will do (:class:`cosim.mjhooks.GelPassive`)."""
    for flag, why in (_NEEDED if kind == "gel" else _TOUCH_NEEDED).items():
        if option.disableflags & flag:
            name = flag.name.removeprefix("mjDSBL_").lower()
            raise ValueError(f'{who}: the model disables {name!r} (<option><flag {name}="disable"/>): {why}')
    for flag, why in _REFUSED.items() if kind == "gel" else ():
        if option.enableflags & flag:
            name = flag.name.removeprefix("mjENBL_").lower()
            raise ValueError(f'{who}: the model enables {name!r} (<option><flag {name}="enable"/>): {why}')


# ---------------------------------------------------------------------------------------
# attach: the pads into the spec.
# ---------------------------------------------------------------------------------------


def attach(
    spec: mujoco.MjSpec,
    sites: Sequence[str] | None = None,
    bodies: Sequence[str] | None = None,
    config: Mapping[str, object] | SensorConfig | None = None,
    pose: str | None = None,
    pad: str = "gel",
) -> Fingertips:
    """Put a piezotip fingertip (gel pad, element, readout) on each site and body of ``spec``.

    Parameters
    ----------
    spec : the user's model, edited in place: the pads' strips are added (named ``piezotip/...``).
    sites : box sites marking the sensing patches: x/y half-sizes the pad's (x along the
        element, towards its clamped root), +z out of the finger, the origin the pad's base centre.
    bodies : bodies whose collision geometry's face towards the other fingertips (the other
        bodies' centre, in ``pose``) carries the pad: the house pad's 20 x 20 mm, or the face if
        smaller, its length along the face's longer side, its root towards the body's parent.
    config : the fingertips' configuration: the scenario config's ``sensor.*`` keys as a mapping
        (``{"sensor.quality_factor": 70}``) or a :class:`SensorConfig`, and ``physics.pad_segments``,
        ``physics.control_period_s`` (the period :meth:`FingertipLoop.step` advances) and
        ``physics.gel_update``.  The same for every fingertip of the call.
    pose : the name of a keyframe of the model whose qpos the bodies' faces are read in; None
        (default) for the open pose (:func:`open_pose_qpos`: qpos0 in the joints' ranges, the
        position servos at their open ends).  Only which face carries a pad, and which way it
        runs, come from it; the model and its keyframes are left as they are.
    pad : what carries the load, for every fingertip of the call (:data:`PAD_KINDS`):

        - ``"gel"`` (default): the house's gel pad, strips standing 5 mm out of the patch, the
          gel law on each (its compliance is in the model's dynamics);
        - ``"touch"``: no pad geometry, the price of a sensor: the model's own contacts in the
          zone (a site's own box, as MuJoCo's ``touch`` marks it; on a body's face, a box the
          face's size reaching the gel's thickness either side of it) press the element
          uniformly, the zone's normal force (MuJoCo's ``touch`` sensor,
          ``piezotip/TIP/touch_n``) over the pad's area.  The model steps bit for bit as it did
          without fingertips; what it gives up is the gel's compliance in the grasp and the
          pressure's profile along the element (docs/attach.md, "A skin").

    The strips' geoms touch what the geoms of the body they sit on touch: their contype and
    conaffinity are :func:`pad_collision_bits`'s (the house class's on a body without collision
    geoms).  A :class:`PadCollisionWarning` names the model's geoms that the fingertips' bodies
    touch and the pads cannot; explicit ``<pair>`` elements are not considered.

    Returns
    -------
    :class:`Fingertips`; compile the spec, then :meth:`Fingertips.bind` the model and its data.

    Raises
    ------
    ValueError
        naming the bad value: a site or body the model lacks, a site that is not a box, a patch
        smaller than the element, a ``pose`` that is no keyframe, bodies whose boxes coincide in
        it, a model option the pads cannot run under (a disabled contact, limit, spring or damper,
        contact override; any integrator and timestep will do), a bad fingertip key or value, a
        spec that already has fingertips (attach once, all of them), an unknown ``pad``.
    """
    if not isinstance(spec, mujoco.MjSpec):
        raise ValueError(f"attach: spec must be a mujoco.MjSpec, got {type(spec).__name__}")
    if pad not in PAD_KINDS:
        raise ValueError(f"attach: unknown pad {pad!r}; valid: {', '.join(PAD_KINDS)}")
    sites, bodies = _name_list("sites", sites), _name_list("bodies", bodies)
    if not sites and not bodies:
        raise ValueError("attach: give the fingertips' sites=[...] or bodies=[...]")
    names = [*sites, *bodies]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"attach: each fingertip is named once; {repeated} repeated")
    try:
        before = spec.compile()
    except Exception as err:  # MuJoCo raises ValueError; say it is the user's model as given
        raise ValueError(f"attach: the model does not compile as given: {err}") from err
    if spec.find_default(PAD_CLASS) is not None or any(e.name.startswith(PREFIX) for e in (*spec.bodies, *spec.sensors)):
        raise ValueError("attach: the spec already has piezotip fingertips: attach all of them in one call")

    settings = fingertip_config(config, spec.option)
    fingertip = make_fingertip(settings)
    gel = fingertip.gel
    patches = [_site_patch(before, s) for s in sites] + _body_patches(before, bodies, pose, whole_face=pad == "touch")
    pads = []
    for name, patch in zip(names, patches, strict=True):
        geometry = _geometry(patch, settings.physics.pad_segments, gel.params.thickness_m)
        placement = _placement(patch, gel.params.thickness_m)
        if pad == "touch":
            zone = name if name in sites else f"{PREFIX}{name}/zone"
            pads.append(AttachedPad(name, patch.source, patch.body, placement, geometry, (), "touch", zone))
        else:
            pads.append(AttachedPad(name, patch.source, patch.body, placement, geometry, geometry.strip_body_names(f"{PREFIX}{name}/")))
    if pad == "touch":
        _check_options(spec.option, kind="touch")
        return _attach_touch(spec, pads, patches, settings, fingertip)
    _check_options(spec.option)

    # The house's class `pad` (contacts, housing stop), its time constant at this model's step.
    # Hard contacts: the house's compliant ones need impratio 100 to hold without creep, and the
    # user's options are the user's (cosim.pad_model.resolve_pad_contact; models/README.md).
    # Under an explicit integrator, the house's compliant contact, 3 steps (EXPLICIT_PAD_SOLIMP).
    pad_class = copy_pad_class(spec, PAD_CLASS, GEL_MATERIAL)
    implicit = spec.option.integrator == mujoco.mjtIntegrator.mjINT_DISCRETE
    pad_class.geom.solimp = list(HARD_PAD_SOLIMP if implicit else EXPLICIT_PAD_SOLIMP)
    constant = pad_time_constant_s(spec.option.timestep)
    if not implicit:
        constant = max(constant, EXPLICIT_CONTACT_STEPS * spec.option.timestep)
    pad_class.geom.solref = [constant, pad_class.geom.solref[1]]
    pad_class.joint.solref_limit = [constant, pad_class.joint.solref_limit[1]]
    keyed = [(bool(len(key.qpos)), bool(len(key.qvel))) for key in spec.keys]
    for key in spec.keys:  # their lengths change with the strips: remapped by joint name below
        key.qpos, key.qvel = [], []
    for pad in pads:
        add_pad_strips(spec.body(pad.body), pad.geometry, gel.params, pad.strips, pad_class, pad.placement)
        # The strips never touch the body they sit on: MuJoCo's parent filter leaves out a body
        # welded to the world (a fixed finger), so the pair is excluded explicitly.
        for strip in pad.strips:
            spec.add_exclude(name=f"{strip}_exclude", bodyname1=pad.body, bodyname2=strip)
        _set_pad_collision(spec, pad, before, pads)
    _add_readout_sensors(spec, pads)  # filled by the readout inside mj_step, from the positions
    try:
        after = spec.compile()
    except Exception as err:
        raise ValueError(f"attach: the model does not compile with its fingertips: {err}") from err
    if any(qpos or qvel for qpos, qvel in keyed):
        _remap_keys(before, after)
        for key, k, (qpos, qvel) in zip(spec.keys, range(after.nkey), keyed, strict=True):
            key.qpos = after.key_qpos[k].tolist() if qpos else []
            key.qvel = after.key_qvel[k].tolist() if qvel else []
    return Fingertips(tuple(pads), settings, fingertip)


def _attach_touch(spec: mujoco.MjSpec, pads: list[AttachedPad], patches: list[_Patch], settings: ScenarioConfig, fingertip) -> Fingertips:
    """``attach(..., pad="touch")``: per fingertip, its zone (a body's: a site on the face), a
    ``touch`` sensor on it and the readout's user sensors; nothing else of the spec changes.

    The user sensors are of the position stage, as a gel pad's: the readout samples the zone's
    ``touch`` as the last step left it (the contact forces of the state that step started from,
    what piezotip's own loop reads at a period's end).  At the acceleration stage (after this
    step's contact forces) they would cost every step MuJoCo's ``mj_rnePostConstraint``, which
    MuJoCo runs for any acceleration-stage ``user`` sensor (engine_sensor.c, ``mj_sensorAcc``)."""
    for tip, patch in zip(pads, patches, strict=True):
        if tip.zone != tip.name:  # a body's face: the zone a box the pad's size, h0 either side of the face
            rotation = patch.axes.ravel().copy()
            quat = np.zeros(4)
            mujoco.mju_mat2Quat(quat, rotation)
            spec.body(tip.body).add_site(
                name=tip.zone,
                type=mujoco.mjtGeom.mjGEOM_BOX,
                pos=patch.origin_m.tolist(),
                quat=quat.tolist(),
                size=[patch.half_length_m, patch.half_width_m, fingertip.gel.params.thickness_m],
                group=5,  # out of MuJoCo's default visible groups: a zone, not a part
            )
        spec.add_sensor(
            name=sensor_name(tip.name, TOUCH_FIELD),
            type=mujoco.mjtSensor.mjSENS_TOUCH,
            objtype=mujoco.mjtObj.mjOBJ_SITE,
            objname=tip.zone,
            nsample=1,  # a history of one: bind gives it the readout's period as its interval (TouchReader)
        )
    _add_readout_sensors(spec, pads)
    try:
        spec.compile()
    except Exception as err:
        raise ValueError(f"attach: the model does not compile with its fingertips: {err}") from err
    return Fingertips(tuple(pads), settings, fingertip)


def _add_readout_sensors(spec: mujoco.MjSpec, pads: list[AttachedPad]) -> None:
    """Each fingertip's ``user`` sensors (:data:`SENSOR_FIELDS`, of the position stage) and the
    readout's ``clock`` (:data:`CLOCK_SENSOR`)."""
    for pad in pads:
        for field in SENSOR_FIELDS:
            spec.add_sensor(
                name=sensor_name(pad.name, field), type=mujoco.mjtSensor.mjSENS_USER, dim=1, needstage=mujoco.mjtStage.mjSTAGE_POS
            )
    spec.add_sensor(name=CLOCK_SENSOR, type=mujoco.mjtSensor.mjSENS_CLOCK)


def _name_list(what: str, names: Sequence[str] | None) -> list[str]:
    if names is None:
        return []
    if isinstance(names, str):
        names = [names]
    names = list(names)
    bad = [n for n in names if not isinstance(n, str) or not n]
    if bad:
        raise ValueError(f"attach: {what} must be names, got {bad[0]!r}")
    return names


class Fingertips:
    """The fingertips :func:`attach` put on a spec: bind them to the compiled model and its data.

    Attributes
    ----------
    pads : the :class:`AttachedPad` of each fingertip, in the order given (sites, then bodies).
    config : the whole validated configuration (a ScenarioConfig: its ``sensor`` and ``physics``
        are the fingertips'; the model's timestep and integrator are read from the model).
    fingertip : the sensor as the readout knows it (:class:`sensor.Fingertip`).
    """

    def __init__(self, pads: tuple[AttachedPad, ...], config: ScenarioConfig, fingertip) -> None:
        self.pads = pads
        self.config = config
        self.fingertip = fingertip

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(pad.name for pad in self.pads)

    def bind(self, model: mujoco.MjModel, data: mujoco.MjData) -> FingertipLoop:
        """The fingertips running on ``model`` (compiled from the spec given to :func:`attach`) and ``data``."""
        return FingertipLoop(self, model, data)

    def __repr__(self) -> str:
        return f"Fingertips({', '.join(p.source for p in self.pads)})"


# ---------------------------------------------------------------------------------------
# The loop: one period at a time.
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TipReading:
    """One fingertip's readout after a period (what a controller may use), and its ground truth.

    Attributes
    ----------
    estimate_pa : the readout's pressure estimate, Pa (NaN while settling or saturated).
    sigma_pa : its uncertainty, one standard deviation, Pa (NaN when unknown): where ``status``
        is "ok" the true pressure lies within estimate +- 3 sigma (the readout's contract).
    status : "ok", "below_detection", "saturated" or "settling" (the readout's own), or
        "outside_model": the truth was past where the model holds (the gel past its valid strain,
        the element on its backstop), whatever the readout said.
    mode : the vibration mode driven.
    voltage : the sensed amplitude, V (the drive's measure: V_1 times the mode's unloaded output).
    v1 : the normalized reading |V_s| / V_0, dimensionless.
    true_pressure_pa : the simulator's truth the readout never sees: the gel's mean pressure
        on the element's coverage, Pa (the channel's input).
    """

    estimate_pa: float
    sigma_pa: float
    status: str
    mode: int
    voltage: float
    v1: float
    true_pressure_pa: float


#: The readout's status as a number in ``piezotip/TIP/status`` (docs/attach.md): 0 is "ok".
STATUS_CODES = {"ok": 0, "below_detection": 1, "saturated": 2, "settling": 3, "outside_model": 4}
#: Each fingertip's MuJoCo sensors, ``piezotip/TIP/<field>``: the :class:`TipReading` field each holds.
SENSOR_FIELDS = ("pressure_pa", "sigma_pa", "status", "mode", "true_pressure_pa")
#: A ``"touch"`` pad's MuJoCo ``touch`` sensor, ``piezotip/TIP/touch_n``: its zone's normal force, N.
TOUCH_FIELD = "touch_n"
#: The readout's clock, a MuJoCo ``clock`` sensor (``data.time`` at the position stage, s): the
#: compiled readout pass reads the time there at every step, no Python object of the MjData made.
CLOCK_SENSOR = f"{PREFIX}clock"


def sensor_name(tip: str, field: str) -> str:
    """The name of fingertip ``tip``'s MuJoCo sensor ``field`` (:data:`SENSOR_FIELDS`)."""
    return f"{PREFIX}{tip}/{field}"


class _FingertipHook:
    """Attached fingertips on one model and its data, running inside every ``mj_step`` (the
    object MuJoCo's callbacks run: it holds the MjData weakly; :class:`FingertipLoop` is what
    :meth:`Fingertips.bind` returns).

    From :meth:`Fingertips.bind` on, MuJoCo's own stepping runs the fingertips (through its
    passive and sensor callbacks, :mod:`cosim.mjhooks`): the gel law on every strip at every
    physics step, and, once a period, every fingertip's pressures, sensor and readout, whose
    reading fills the fingertip's sensors in ``data.sensordata`` (``piezotip/TIP/pressure_pa``,
    ...; read them as any MuJoCo sensor).  A plain ``mujoco.mj_step(model, data)`` loop, or a
    framework's, is all it needs.  :meth:`step` is piezotip's own loop on top: one period of
    ``mj_step`` calls, then the checks MuJoCo leaves to its user (a diverged state) and the
    readings at the period's end (:meth:`readings`).

    The period is ``physics.control_period_s`` rounded to a whole number of the model's
    timesteps (at least one): :attr:`period_s`, :attr:`substeps`.  The readout samples when
    ``data.time`` reaches its next period; ``data.time`` going back (a reset) starts the
    readout afresh, as it was at bind (the same noise from the same seed).
    """

    #: The readout rides on MuJoCo's sensor callback alone (cosim.mjhooks.Hook); the gel law, on
    #: gel pads, is a hook of its own.
    callbacks = ("sensor",)

    def __init__(self, tips: Fingertips, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        if not isinstance(model, mujoco.MjModel) or not isinstance(data, mujoco.MjData):
            raise ValueError("bind: give the compiled mujoco.MjModel and its mujoco.MjData")
        if data.qpos.shape != (model.nq,) or data.qvel.shape != (model.nv,):
            raise ValueError("bind: data is not the model's (make it with mujoco.MjData(model))")
        config, fingertip = tips.config, tips.fingertip
        # The data weakly: MuJoCo's callbacks keep these fingertips registered for as long as the
        # MjData lives (cosim.mjhooks), so a strong reference here would keep it alive for good.
        self.model, self._data, self.tips = model, weakref.ref(data), tips
        kind = tips.pads[0].kind
        _check_options(model.opt, "bind", kind)
        self.timestep_s = float(model.opt.timestep)
        self.substeps = max(1, round(config.physics.control_period_s / self.timestep_s))
        self.period_s = self.substeps * self.timestep_s
        self._unit = make_unit(config)  # the physical unit the channels run, when not the nominal design
        self.bridges: dict[str, PadBridge] = {}
        self._layouts = {}
        # The readout runs at the position stage: a gel pad reads its strips' positions, a touch
        # pad the touch sensor as the last step left it (_attach_touch).
        # (A plain int: comparing MuJoCo's enum costs a microsecond at every step.)
        self._stage = int(mujoco.mjtStage.mjSTAGE_POS)
        for pad in tips.pads:
            if pad.kind == "touch":
                self._layouts[pad.name] = touch_layout(fingertip, self._unit)
                continue
            try:
                bridge = PadBridge(model, gel=fingertip.gel, geometry=pad.geometry, pads={pad.name: pad.strips}, check_integration=False)
            except ValueError as err:
                raise ValueError(f"bind: {pad.source}: {err} (is the model compiled from the spec given to attach?)") from None
            self.bridges[pad.name] = bridge
            self._layouts[pad.name] = coverage_layout(fingertip, self._unit, pad.geometry, config.sensor.load_spread)
        try:
            # Every fingertip's sensors' addresses, fingertips in order: one write of them all a step.
            self._sensor_adr = np.array(
                [int(model.sensor(sensor_name(pad.name, field)).adr[0]) for pad in tips.pads for field in SENSOR_FIELDS]
            )
            self._clock_adr = int(model.sensor(CLOCK_SENSOR).adr[0])
        except KeyError as err:
            raise ValueError(f"bind: the model lacks the fingertips' sensor {err} (compile the spec given to attach)") from None
        self._sensordata = data.sensordata
        try:
            self._readers = {
                pad.name: TouchReader.of(model, sensor_name(pad.name, TOUCH_FIELD), pad.area_m2, self.period_s)
                if pad.kind == "touch"
                else strip_reader(self.bridges[pad.name], pad.geometry, self._layouts[pad.name][1], data)
                for pad in tips.pads
            }
        except KeyError as err:
            raise ValueError(f"bind: the model lacks the fingertips' sensor {err} (compile the spec given to attach)") from None
        self._unloaded_v = {m: fingertip.element.unloaded_voltage(m) for m in fingertip.modes}
        # Where the model ends (Pa): readings past it are "outside_model" (_sample).
        backstop_pa = fingertip.backstop_pressure_pa()
        self._gel_valid_pa = fingertip.gel.params.max_valid_pressure_pa
        self._backstop_pa = math.inf if backstop_pa is None else backstop_pa
        hold_s = 0.0 if config.physics.gel_update == "substep" else self.period_s
        # The gel law on the strips (none on touch pads: the model's own contacts carry the load).
        self.gel = _gel_passive(model, self.bridges.values(), hold_s) if self.bridges else None
        self._start()
        if self.gel is not None:
            mjhooks.register(data, model, self.gel)
        mjhooks.register(data, model, self)

    def _start(self) -> None:
        """The readout as at bind: fresh channels (noise from ``sensor.seed``), no reading yet."""
        config, fingertip = self.tips.config, self.tips.fingertip
        edges = {name: layout[0] for name, layout in self._layouts.items()}
        self.channels: dict[str, SensorChannel] = make_channels(config, fingertip, self._unit, edges)
        self._readings: dict[str, TipReading] | None = None
        self._pass = self._new_pass(ReadoutPass)
        self._pass.set_clock(self._clock_adr, self._stage, self.period_s, self.timestep_s, self.data.time)
        self._readings_at = 0  # the pass's period _readings were made at
        if self in mjhooks.hooks_of(self.data):  # a reset: the dispatcher's fast path is the new pass's
            mjhooks.refresh(self.data)

    def _new_pass(self, kind: type) -> ReadoutPass:
        """Every fingertip's pad read, channel and sensor values in one pass a period (``kind``:
        cosim/_readout.py's, compiled where built: a touch pad's touch sensor read in C, a gel
        pad's strips through its reader), bound to this data's sensors."""
        readers = [self._readers[name] for name in self.channels]
        touch = [isinstance(r, TouchReader) for r in readers]
        first = [math.nan, math.nan, float(STATUS_CODES["settling"]), float(min(self.tips.config.sensor.modes)), math.nan]
        readout = kind(
            [channel.sample for channel in self.channels.values()],
            [None if t else r.read for r, t in zip(readers, touch, strict=True)],
            [r.adr if t else -1 for r, t in zip(readers, touch, strict=True)],
            [r.area_m2 if t else math.nan for r, t in zip(readers, touch, strict=True)],
            [self._layouts[name][2] for name in self.channels],
            self._sensor_adr,
            first * len(self.channels),
            self._gel_valid_pa,
            self._backstop_pa,
            STATUS_CODES,
            STATUS_CODES["outside_model"],
        )
        readout.bind(self._sensordata)
        if any(touch):
            readout.bind_history(self.data.history, [r.history_adr if t else -1 for r, t in zip(readers, touch, strict=True)])
        return readout

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.channels)

    @property
    def data(self) -> mujoco.MjData:
        """The MjData the fingertips run in (held weakly: dropping it unbinds them)."""
        data = self._data()
        if data is None:
            raise RuntimeError("the MjData these fingertips were bound to is gone")
        return data

    def unbind(self) -> None:
        """Stop running the fingertips in ``data``'s steps (the model's strips keep their last law)."""
        if self.gel is not None:
            mjhooks.unregister(self.data, self.gel)
        mjhooks.unregister(self.data, self)

    # -- the hook: inside mj_step ----------------------------------------------------------

    def passive(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        return None

    def sensor(self, model: mujoco.MjModel, data: mujoco.MjData, stage: int) -> None:
        # The pass keeps the clock: once a period every fingertip's pressures, sensor and
        # readout, at every step the sensors' values into sensordata (the TipReading objects
        # when readings() asks).
        if self._pass.tick(stage) < 0:  # time went back: a reset
            self._start()
            self._pass.tick(stage)

    def fast_sensor(self):
        """What MuJoCo's sensor callback may call at each step instead of :meth:`sensor` (the
        compiled pass's :meth:`~cosim._readout.ReadoutPass.tick`: no Python object of the MjData
        made; where it returns < 0, :meth:`sensor` runs: :mod:`cosim.mjhooks`)."""
        return self._pass.tick

    # -- piezotip's own loop ---------------------------------------------------------------

    def step(self) -> None:
        """One period: :attr:`substeps` ``mj_step`` calls, then the readout at the period's end
        (:meth:`readings`; ``data.sensordata`` holds it too).

        :class:`~cosim.loop.SimulationDiverged` if the state went non-finite, or if MuJoCo found
        a bad position, velocity or acceleration in the period: it then resets the data to the
        model's initial state, warns and steps on (``mj_checkPos``, ``mj_checkVel``,
        ``mj_checkAcc``), and the fingertips would read a reset scene as if nothing happened."""
        m, d, step = self.model, self.data, mujoco.mj_step
        if self not in mjhooks.hooks_of(d):
            raise RuntimeError("step: these fingertips were unbound (bind again)")
        mjhooks.raise_failure(d, "step")
        _check_controls(m, d)
        start_s, before = d.time, _unstable_counts(d)
        prepare = self.gel.prepare if self.gel is not None else None
        for _ in range(self.substeps):
            if prepare is not None:
                prepare(d)  # the discrete integrator's stiffness at this step's state (the hook's comes a step late)
            step(m, d)
        mjhooks.raise_failure(d, "step")
        warned = [w.name for w, n0, n1 in zip(_UNSTABLE, before, _unstable_counts(d), strict=True) if n1 != n0]
        if warned or d.time <= start_s:
            raise SimulationDiverged(
                f"simulation diverged in the period from t = {start_s:.4f} s: MuJoCo's {', '.join(warned) or 'reset'} "
                f"(it reset the data to the model's initial state; timestep {m.opt.timestep:g} s)"
            )
        if not finite_state(d):
            raise SimulationDiverged(f"simulation diverged at t = {d.time:.4f} s: non-finite state (timestep {m.opt.timestep:g} s)")
        # The period's end: sample now (the next step's sensor callback, at this same time, only writes).
        self._pass.sample_now(d.time)

    def readings(self) -> dict[str, TipReading]:
        """Each fingertip's :class:`TipReading` at the last sample (:meth:`step`'s end, or the
        last period ``mj_step`` reached), by name."""
        mjhooks.raise_failure(self.data, "readings")
        if not self._pass.periods:
            raise RuntimeError("no readings yet: call step() (or mj_step for one period) first")
        p = self._pass
        if self._readings is None or self._readings_at != p.periods:
            self._readings_at = p.periods
            self._readings = {
                name: TipReading(
                    estimate.pressure_pa,
                    estimate.uncertainty_pa,
                    "outside_model" if past else estimate.status,
                    reading.mode,
                    reading.v1 * self._unloaded_v[reading.mode],
                    reading.v1,
                    truth,
                )
                for name, reading, estimate, truth, past in zip(self.channels, p.readings, p.estimates, p.truths, p.pasts, strict=True)
            }
        return dict(self._readings)

    def set_mode(self, name: str, mode: int) -> None:
        """Drive fingertip ``name`` in ``mode`` from the next period (a switch rings the new mode
        up); in a plain ``mj_step`` loop too."""
        channel = self._channel(name)
        try:
            channel.select_mode(mode)
        except ValueError as err:
            raise ValueError(f"set_mode: fingertip {name!r}: {err}") from None

    def pad_state(self, name: str) -> PadReading:
        """Fingertip ``name``'s pad now (the simulator's truth: normal force, contact area, bottomed;
        a touch pad's: its zone's normal force over the whole pad, uniform, never bottomed)."""
        self._channel(name)
        if name in self.bridges:
            return self.bridges[name].read(self.data)[name]
        reader = self._readers[name]
        force_n = reader.force_n(self.data)
        pressure_pa = force_n / reader.area_m2
        loaded = force_n > 0.0
        return PadReading(
            name, force_n, force_n, reader.area_m2 if loaded else 0.0, np.array([pressure_pa]), pressure_pa, np.array([math.nan]), False
        )

    def _channel(self, name: str) -> SensorChannel:
        if name not in self.channels:
            raise ValueError(f"fingertip {name!r} is not attached; the fingertips: {', '.join(self.channels)}")
        return self.channels[name]


class FingertipLoop:
    """The running fingertips :meth:`Fingertips.bind` returns: their readings, modes and pads,
    and :meth:`step`, piezotip's own loop (every attribute and method of the fingertips running
    inside ``mj_step``, ``_FingertipHook``'s docstring).

    MuJoCo's callbacks keep the fingertips running for as long as the MjData lives, whether this
    object is kept or not (a plain loop that keeps its model and data keeps its fingertips); this
    object keeps the MjData alive (``data``), and nothing else of piezotip's does: dropped, an
    MjData and its fingertips go.
    """

    def __init__(self, tips: Fingertips, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self._hook = _FingertipHook(tips, model, data)
        self.data = data

    def __getattr__(self, name: str):
        if name == "_hook":  # not yet set (a failed __init__, a copy): no recursion
            raise AttributeError(name)
        return getattr(self._hook, name)


#: The largest control MuJoCo takes: past it (or NaN) it sets the control to 0 with a warning
#: (mjWARN_BADCTRL, engine_forward.c), and the fingertips would read an actuator that never pushed.
_MAX_CTRL = 1e10


def _check_controls(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """A ValueError naming each actuator whose control MuJoCo would zero (NaN, infinite, > 1e10)."""
    bad = np.flatnonzero(~(np.abs(data.ctrl) <= _MAX_CTRL))
    if bad.size:
        named = ", ".join(f"{model.actuator(int(a)).name or f'actuator {int(a)}'} = {data.ctrl[a]!r}" for a in bad[:8])
        raise ValueError(f"step: data.ctrl holds values MuJoCo would set to 0 (NaN, infinite or beyond {_MAX_CTRL:g}): {named}")


def _gel_passive(model: mujoco.MjModel, bridges, hold_s: float) -> mjhooks.GelPassive:
    """One gel law for every strip of ``bridges`` (all of a model's fingertips, one call a step)."""
    parts = [bridge.strip_arrays() for bridge in bridges]
    qadr, dof, joint, area = (np.concatenate([p[k] for p in parts]) for k in range(4))
    table = next(iter(bridges)).table
    return mjhooks.GelPassive(model, qadr, dof, joint, area, table.grid_m, table.pressure_pa, table.tangent_pa_m, hold_s=hold_s)


# ---------------------------------------------------------------------------------------
# The sensing pieces, as the co-simulation loop composes them (cosim/loop.py CoSimulation).
# ---------------------------------------------------------------------------------------


def coverage_layout(fingertip, unit, geometry: PadGeometry, load_spread: str) -> tuple[np.ndarray, list, list[float]]:
    """A pad's coverage cells (edges along the element, m), what each feels of the pad's strips
    (:func:`cosim.loop.coverage_weights`) and each cell's share of the coverage's length."""
    length = fingertip.element.params.length_m
    coverage = unit.coverage if unit is not None else fingertip.coverage  # where the gel touches
    edges, _ = coverage_cells(np.linspace(0.0, length, geometry.segments + 1), coverage)
    # With a spreading layer every coverage cell feels the whole pad's face (guards too).
    depth = fingertip.gel.params.thickness_m if load_spread == "layer" else 0.0
    weights = coverage_weights(geometry, length, edges, depth)
    return edges, weights, (np.diff(edges) / (edges[-1] - edges[0])).tolist()


def touch_layout(fingertip, unit) -> tuple[np.ndarray, list, list[float]]:
    """A touch pad's coverage cells as :func:`coverage_layout` gives them: one cell over the
    gel's coverage (the pressure is uniform), which feels the whole pad, its whole share."""
    coverage = unit.coverage if unit is not None else fingertip.coverage
    return np.asarray(coverage, float), [[(0, 1.0)]], [1.0]


class TouchReader:
    """Where a touch pad is read: its zone's normal force (MuJoCo's ``touch`` sensor at ``adr`` of
    ``sensordata``, N) over the pad's area ``area_m2`` (m^2) is the pressure pressing the element
    uniformly, Pa (the readout pass reads it in C once a period: cosim/_readout.py).

    ``history_adr``: where the sensor's history buffer starts in ``data.history`` (-1: it has
    none, and MuJoCo computes it at every step).  With one (attach gives it one sample), bind
    gives the sensor the readout's period as its ``interval``: MuJoCo computes it once a period,
    at the step before the readout samples it (the pass sees to that:
    ``ReadoutPass.bind_history``), and holds it between; its ray tests against every contact
    were a quarter of a 16-pad skin's cost at every step (``python run_sim.py bench --skin``)."""

    def __init__(self, adr: int, area_m2: float, history_adr: int = -1) -> None:
        self.adr, self.area_m2, self.history_adr = adr, float(area_m2), int(history_adr)

    @classmethod
    def of(cls, model: mujoco.MjModel, sensor: str, area_m2: float, period_s: float) -> TouchReader:
        """The reader of ``model``'s touch sensor ``sensor``, its interval set to ``period_s``
        where it has a history and the period is more than a step."""
        found = model.sensor(sensor)
        history = getattr(model, "sensor_history", None)  # (MuJoCo >= 3.5)
        if history is None or history[found.id, 0] < 1 or period_s < 1.5 * model.opt.timestep:
            return cls(int(found.adr[0]), area_m2)
        model.sensor_interval[found.id, 0] = period_s
        return cls(int(found.adr[0]), area_m2, int(model.sensor_historyadr[found.id]))

    def force_n(self, data: mujoco.MjData) -> float:
        """The zone's normal force now, N (``data``'s: the one bound, or another of the model's)."""
        return float(data.sensordata[self.adr])


def strip_reader(bridge: PadBridge, geometry: PadGeometry, cell_weights: list, data: mujoco.MjData):
    """The bridge's per-period read of its one pad, bound to ``data``: the element strips'
    pressures (root to tip) and the coverage cells' (:meth:`PadBridge.pressure_reader`)."""
    element = np.flatnonzero(geometry.on_element).tolist()[::-1]  # root to tip
    read = sorted({*element, *(i for row in cell_weights for i, _ in row)})
    at = {strip: k for k, strip in enumerate(read)}
    reader = bridge.pressure_reader(read, len(read), [at[i] for i in element], [[(at[i], w) for i, w in row] for row in cell_weights])
    reader.bind(data.qpos)
    return reader

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
:func:`cosim.loop.make_fingertip`, :class:`sensor.channel.SensorChannel` or its physical unit's
``UnitChannel``).  Everything added is named with the prefix ``piezotip/``; the user's bodies,
geoms, options and contacts are otherwise left as they were.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from piezotip import scenarios
from piezotip.scenarios.config import INTEGRATORS, ScenarioConfig, SensorConfig, valid_keys
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.gel import GelModel
from piezotip.sensor.unit_channel import UnitChannel

from .loop import SimulationDiverged, coverage_cells, coverage_weights, make_fingertip, make_unit
from .pad_bridge import PadBridge, PadReading, _GelTable, check_gel_integration
from .pad_geometry import PadGeometry
from .pad_model import HARD_PAD_SOLIMP, PadPlacement, _remap_keys, add_pad_strips, copy_pad_class, pad_time_constant_s
from .scene import finite_state

__all__ = ["PREFIX", "AttachedPad", "FingertipLoop", "Fingertips", "TipReading", "attach", "fingertip_pads"]

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

#: The model options the pads cannot run without: disable flags, and why each is needed.
_NEEDED = {
    mujoco.mjtDisableBit.mjDSBL_CONSTRAINT: "the pads touch through contacts and stop at a joint limit",
    mujoco.mjtDisableBit.mjDSBL_CONTACT: "the pads touch through contacts",
    mujoco.mjtDisableBit.mjDSBL_LIMIT: "the housing stop behind the gel is a joint limit",
    mujoco.mjtDisableBit.mjDSBL_SPRING: "the gel's stiffness acts as the strip joints' spring",
    mujoco.mjtDisableBit.mjDSBL_DAMPER: "the gel's loss acts as the strip joints' damping",
}
#: ...and enable flags they cannot run with.
_REFUSED = {
    mujoco.mjtEnableBit.mjENBL_OVERRIDE: "it replaces the pads' hard contact parameters (the gel is the pads' compliance)",
}

#: The element under the pad (the house gripper's: the paper's 7.5 x 5 mm element).
_ELEMENT = PadGeometry()


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
    strips : its strips' body names, distal first (``piezotip/<name>/seg0``, ...).
    """

    name: str
    source: str
    body: str
    placement: PadPlacement
    geometry: PadGeometry
    strips: tuple[str, ...]


@dataclass(frozen=True)
class _Patch:
    """A sensing patch in its body: origin (the pad's base centre, m), axes (columns: x along
    the element towards its root, y, z out of the finger) and the pad's half-sizes (m)."""

    source: str
    body: str
    origin_m: np.ndarray
    axes: np.ndarray
    half_length_m: float
    half_width_m: float


def _names(model: mujoco.MjModel, kind: str, count: int) -> str:
    names = [getattr(model, kind)(i).name for i in range(count)]
    shown = [n for n in names if n][:12]
    return ", ".join(shown) + (", ..." if len([n for n in names if n]) > 12 else "") or "none"


def _site_patch(model: mujoco.MjModel, name: str) -> _Patch:
    try:
        site = model.site(name)
    except KeyError:
        raise ValueError(f"attach: site {name!r} is not in the model (its named sites: {_names(model, 'site', model.nsite)})") from None
    if model.site_type[site.id] != mujoco.mjtGeom.mjGEOM_BOX:
        kind = mujoco.mjtGeom(model.site_type[site.id]).name.removeprefix("mjGEOM_").lower()
        raise ValueError(
            f"attach: site {name!r} is a {kind}; a pad's site must be a box (its x/y half-sizes are the pad's, its +z points out)"
        )
    body = int(model.site_bodyid[site.id])
    axes = np.zeros(9)
    mujoco.mju_quat2Mat(axes, model.site_quat[site.id])
    size = model.site_size[site.id]
    return _Patch(
        f"site {name!r}", _body_name(model, body, f"site {name!r}"), model.site_pos[site.id].copy(), axes.reshape(3, 3), size[0], size[1]
    )


def _body_name(model: mujoco.MjModel, body: int, source: str) -> str:
    if body == 0:
        # The world's geoms are not filtered from its children's: a strip pressed into the
        # surface under it would collide with that surface.
        raise ValueError(f"attach: {source} is on the world body; a pad sits on a body (a fixed one is a body without joints)")
    return model.body(body).name


#: The corners of a unit box about the origin (signs of its half-sizes).
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)


def _geom_points(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """Points in the geom's body frame whose bounding box is the geom's, m: a mesh's vertices
    (exact: a turned mesh's own bounding box, turned, would stand out past its surface), else
    the corners of its bounding box in its own frame."""
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, model.geom_quat[geom])
    if model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = model.geom_dataid[geom]
        local = model.mesh_vert[model.mesh_vertadr[mesh] : model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
    else:
        local = model.geom_aabb[geom, :3] + _CORNERS * model.geom_aabb[geom, 3:]
    return model.geom_pos[geom] + local @ rotation.reshape(3, 3).T


def _body_box(model: mujoco.MjModel, body: int, source: str, geoms: Sequence[int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The body's collision geometry (or ``geoms`` of it) as a box in its frame: (centre, half-sizes), m."""
    if geoms is None:
        geoms = range(model.body_geomadr[body], model.body_geomadr[body] + model.body_geomnum[body])
        geoms = [g for g in geoms if model.geom_contype[g] or model.geom_conaffinity[g]]
    if not geoms:
        raise ValueError(f"attach: {source} has no collision geom to put a pad on")
    for g in geoms:
        if not np.all(np.isfinite(model.geom_aabb[g, 3:])) or model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            raise ValueError(f"attach: {source} has an unbounded geom ({model.geom(g).name or g}); give a site for its pad")
    points = np.concatenate([_geom_points(model, g) for g in geoms])
    low, high = points.min(axis=0), points.max(axis=0)
    return 0.5 * (low + high), 0.5 * (high - low)


@dataclass(frozen=True)
class _Face:
    """Where a pad goes on a face: what names it (for messages), its body, and the geoms whose
    box has the face (None: the body's collision geoms)."""

    source: str
    body: int
    geoms: tuple[int, ...] | None = None


def _body_patches(model: mujoco.MjModel, names: Sequence[str]) -> list[_Patch]:
    """Each body's pad on the face of its collision box towards the other bodies' (their centre),
    in the model's reference configuration (qpos0)."""
    faces = []
    for name in names:
        try:
            faces.append(_Face(f"body {name!r}", model.body(name).id))
        except KeyError:
            raise ValueError(f"attach: body {name!r} is not in the model (its bodies: {_names(model, 'body', model.nbody)})") from None
    if len(faces) < 2:
        raise ValueError(f"attach: a pad on body {names[0]!r} faces the other fingertip: give two or more bodies, or a site")
    return _face_patches(model, faces)


def _face_patches(model: mujoco.MjModel, faces: Sequence[_Face]) -> list[_Patch]:
    """Each face's pad on the side of its box towards the other faces' boxes (their centre), in
    the model's reference configuration (qpos0): the house pad's 20 x 20 mm or the face if
    smaller, its length along the face's longer side (of a square face, the side nearer the
    direction of the body's parent: the finger's length), its root towards the body's parent."""
    for face in faces:
        _body_name(model, face.body, face.source)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    boxes = [_body_box(model, face.body, face.source, face.geoms) for face in faces]
    centres = [data.xpos[face.body] + data.xmat[face.body].reshape(3, 3) @ box[0] for face, box in zip(faces, boxes, strict=True)]
    patches = []
    for i, (face, (centre, half)) in enumerate(zip(faces, boxes, strict=True)):
        body = face.body
        rotation = data.xmat[body].reshape(3, 3)
        others = np.mean([c for j, c in enumerate(centres) if j != i], axis=0)
        towards = rotation.T @ (others - centres[i])  # in the body's frame
        if not np.linalg.norm(towards) > 0:
            raise ValueError(f"attach: {face.source} has its collision box where the other fingertips' are; give sites")
        out = int(np.argmax(np.abs(towards)))
        in_plane = [a for a in range(3) if a != out]
        # The element's clamped root towards the body's parent (the palm), as on the house gripper.
        parent = rotation.T @ (data.xpos[model.body_parentid[body]] - data.xpos[body])
        along = max(in_plane, key=lambda a: (half[a], abs(parent[a]), -a))  # the face's longer side: the finger's length
        across = in_plane[0] if along == in_plane[1] else in_plane[1]
        x = np.eye(3)[along] * (1.0 if parent[along] >= 0 else -1.0)
        z = np.eye(3)[out] * np.sign(towards[out])
        origin = centre + z * half[out]
        length = min(half[along], 0.5 * _ELEMENT.pad_length_m)
        width = min(half[across], 0.5 * _ELEMENT.pad_width_m)
        patches.append(_Patch(face.source, model.body(body).name, origin, np.column_stack((x, np.cross(z, x), z)), length, width))
    return patches


def fingertip_pads(
    model: mujoco.MjModel, fingertips: Sequence[str], segments: int, gel_thickness_m: float
) -> list[tuple[str, str, PadPlacement, PadGeometry]]:
    """The pad :func:`attach` puts on each of ``fingertips``, each named as a box site (the pad on
    it, as ``sites``), a body (on its collision geometry's face towards the other fingertips, as
    ``bodies``) or a geom (on its own face towards them), looked up in that order; two or more
    when any is not a site.  Per fingertip: (source, body name, pad placement, pad geometry), the
    strips ``segments`` per element, the gel ``gel_thickness_m`` thick (m)."""
    faces: list[_Face | None] = []
    for name in fingertips:
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name) >= 0:
            faces.append(None)
        elif (body := mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)) >= 0:
            faces.append(_Face(f"body {name!r}", body))
        elif (geom := mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)) >= 0:
            faces.append(_Face(f"geom {name!r}", int(model.geom_bodyid[geom]), (geom,)))
        else:
            kinds = f"its sites: {_names(model, 'site', model.nsite)}; its bodies: {_names(model, 'body', model.nbody)}"
            raise ValueError(f"attach: {name!r} is no site, body or geom of the model ({kinds})")
    placed = [f for f in faces if f is not None]
    if placed and len(placed) < len(faces):  # a face needs the other fingertips' boxes to know which way it faces
        sites = [n for n, f in zip(fingertips, faces, strict=True) if f is None]
        raise ValueError(f"attach: {', '.join(map(repr, sites))} named as sites with fingertips that are bodies or geoms: name all one way")
    if placed and len(placed) < 2:
        raise ValueError(f"attach: a pad on {placed[0].source} faces the other fingertip: give two or more fingertips, or a site")
    patches = _face_patches(model, placed) if placed else [_site_patch(model, name) for name in fingertips]
    return [(p.source, p.body, _placement(p, gel_thickness_m), _geometry(p, segments, gel_thickness_m)) for p in patches]


#: The pad frame (the house finger's: x out, z along the element) in the patch's axes: x_pad =
#: z_patch, y_pad = -y_patch, z_pad = x_patch (a rotation: determinant +1).
_PAD_IN_PATCH = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])


def _placement(patch: _Patch, gel_thickness_m: float) -> PadPlacement:
    """The pad frame for ``patch``: its origin on the unloaded gel's free surface, h0 out."""
    rotation = patch.axes @ _PAD_IN_PATCH
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rotation.ravel())
    origin = patch.origin_m + gel_thickness_m * patch.axes[:, 2]
    return PadPlacement(tuple(float(v) for v in origin), tuple(float(q) for q in quat))


def _geometry(patch: _Patch, segments: int, gel_thickness_m: float) -> PadGeometry:
    length, width = 2.0 * patch.half_length_m, 2.0 * patch.half_width_m
    if length < _ELEMENT.element_length_m or width < _ELEMENT.element_width_m:
        raise ValueError(
            f"attach: {patch.source}: its pad ({1e3 * length:.3g} x {1e3 * width:.3g} mm, x by y) is smaller than the sensor element "
            f"under it ({1e3 * _ELEMENT.element_length_m:g} x {1e3 * _ELEMENT.element_width_m:g} mm)"
        )
    return PadGeometry(segments=segments, pad_length_m=length, pad_width_m=width, gel_thickness_m=gel_thickness_m)


# ---------------------------------------------------------------------------------------
# The fingertip's configuration and the model's options.
# ---------------------------------------------------------------------------------------


def _integrator_name(option) -> str:
    """The scenario config's name of ``option``'s integrator (``discrete``, ``Euler``, ...)."""
    names = {name.lower(): name for name in INTEGRATORS}
    return names[mujoco.mjtIntegrator(option.integrator).name.removeprefix("mjINT_").lower()]


def fingertip_config(config: Mapping[str, object] | SensorConfig | None, option) -> ScenarioConfig:
    """The fingertips' whole validated configuration: the scenario config's ``sensor.*`` keys
    (a mapping of them, or a :class:`SensorConfig`) and :data:`PHYSICS_KEYS`, at the model's
    timestep and integrator (``option``).  Every check is the scenario config's own: a bad value
    is a ValueError naming its key."""
    if config is None:
        given: dict[str, object] = {}
    elif isinstance(config, SensorConfig):  # its pads are the scenario's: here the sites and bodies are
        given = {f"sensor.{f.name}": getattr(config, f.name) for f in dataclasses.fields(config) if f.name != "pads"}
    elif isinstance(config, Mapping):
        given = dict(config)
    else:
        raise ValueError(f"attach: config must be a mapping of sensor.* keys or a SensorConfig, got {type(config).__name__}")
    keys = [f"sensor.{k}" for k in valid_keys(SensorConfig()) if k != "pads"] + list(PHYSICS_KEYS)
    for key in given:
        if key in MODEL_KEYS:
            raise ValueError(f"attach: {key} is the model's own option (its <option>), not the fingertip's")
        if key == "sensor.pads":
            raise ValueError("attach: sensor.pads does not apply: the fingertips are the sites and bodies given to attach")
        if key not in keys:
            raise ValueError(f"attach: unknown fingertip key {key!r}; valid keys: {', '.join(keys)}")
    overrides = scenarios.override_strings(given)
    model_options = {"physics.timestep_s": float(option.timestep), "physics.integrator": _integrator_name(option)}
    # No controller runs here: the scripted one (which reads no sensor) over the sensor's modes
    # keeps the scenario's checks to the fingertip's own.
    controller = ["controller.kind=scripted"]
    controller += [f"controller.modes={text.partition('=')[2]}" for text in overrides if text.startswith("sensor.modes=")]
    try:
        return scenarios.get("grasp", [*controller, *overrides, *scenarios.override_strings(model_options)])
    except ValueError as err:
        whose = " (physics.timestep_s is the model's option timestep)" if "physics.timestep_s" in str(err) else ""
        raise ValueError(f"attach: {err}{whose}") from None


def _check_options(option, pads: Sequence[AttachedPad], gel: GelModel, who: str = "attach") -> None:
    """The model's options the gel pads need (``option``: an MjSpec's or an MjModel's); ``who``
    begins the messages."""
    for flag, why in _NEEDED.items():
        if option.disableflags & flag:
            name = flag.name.removeprefix("mjDSBL_").lower()
            raise ValueError(f'{who}: the model disables {name!r} (<option><flag {name}="disable"/>): {why}')
    for flag, why in _REFUSED.items():
        if option.enableflags & flag:
            name = flag.name.removeprefix("mjENBL_").lower()
            raise ValueError(f'{who}: the model enables {name!r} (<option><flag {name}="enable"/>): {why}')
    for pad in pads:
        # The stiffest strip at its stop, on its own gel column's mass (rho A h0).
        areas = pad.geometry.strip_areas_m2
        stiffness = areas * _GelTable.build(gel, pad.geometry).tangent_at_stop_pa_m(pad.geometry)
        mass = gel.params.density_kg_m3 * areas * pad.geometry.gel_thickness_m
        try:
            check_gel_integration(option, stiffness, mass)
        except ValueError as err:
            raise ValueError(f"{who}: {pad.source}: {err}") from None


# ---------------------------------------------------------------------------------------
# attach: the pads into the spec.
# ---------------------------------------------------------------------------------------


def attach(
    spec: mujoco.MjSpec,
    sites: Sequence[str] | None = None,
    bodies: Sequence[str] | None = None,
    config: Mapping[str, object] | SensorConfig | None = None,
) -> Fingertips:
    """Put a piezotip fingertip (gel pad, element, readout) on each site and body of ``spec``.

    Parameters
    ----------
    spec : the user's model, edited in place: the pads' strips are added (named ``piezotip/...``).
    sites : box sites marking the sensing patches: x/y half-sizes the pad's (x along the
        element, towards its clamped root), +z out of the finger, the origin the pad's base centre.
    bodies : bodies whose collision geometry's face towards the other fingertips (the other
        bodies' centre, at qpos0) carries the pad: the house pad's 20 x 20 mm, or the face if
        smaller, its length along the face's longer side, its root towards the body's parent.
    config : the fingertips' configuration: the scenario config's ``sensor.*`` keys as a mapping
        (``{"sensor.quality_factor": 70}``) or a :class:`SensorConfig`, and ``physics.pad_segments``,
        ``physics.control_period_s`` (the period :meth:`FingertipLoop.step` advances) and
        ``physics.gel_update``.  The same for every fingertip of the call.

    Returns
    -------
    :class:`Fingertips`; compile the spec, then :meth:`Fingertips.bind` the model and its data.

    Raises
    ------
    ValueError
        naming the bad value: a site or body the model lacks, a site that is not a box, a patch
        smaller than the element, a model option the pads cannot run under (a disabled contact,
        limit, spring or damper, contact override, an explicit integrator at a timestep the
        gel's stiffness is unstable at, a timestep the period is not a whole multiple of), a
        bad fingertip key or value, a spec that already has fingertips (attach once, all of them).
    """
    if not isinstance(spec, mujoco.MjSpec):
        raise ValueError(f"attach: spec must be a mujoco.MjSpec, got {type(spec).__name__}")
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
    if spec.find_default(PAD_CLASS) is not None or any(b.name.startswith(PREFIX) for b in spec.bodies):
        raise ValueError("attach: the spec already has piezotip fingertips: attach all of them in one call")

    settings = fingertip_config(config, spec.option)
    fingertip = make_fingertip(settings)
    gel = fingertip.gel
    patches = [_site_patch(before, s) for s in sites] + (_body_patches(before, bodies) if bodies else [])
    pads = []
    for name, patch in zip(names, patches, strict=True):
        geometry = _geometry(patch, settings.physics.pad_segments, gel.params.thickness_m)
        placement = _placement(patch, gel.params.thickness_m)
        pads.append(AttachedPad(name, patch.source, patch.body, placement, geometry, geometry.strip_body_names(f"{PREFIX}{name}/")))
    _check_options(spec.option, pads, gel)

    # The house's class `pad` (contacts, housing stop), its time constant at this model's step.
    # Hard contacts: the house's compliant ones need impratio 100 to hold without creep, and the
    # user's options are the user's (cosim.pad_model.resolve_pad_contact; models/README.md).
    pad_class = copy_pad_class(spec, PAD_CLASS, GEL_MATERIAL)
    pad_class.geom.solimp = list(HARD_PAD_SOLIMP)
    constant = pad_time_constant_s(spec.option.timestep)
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
    status : "ok", "below_detection", "saturated" or "settling".
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


class FingertipLoop:
    """Attached fingertips on one model and its data, stepped one period at a time.

    :meth:`step` runs one period (``physics.control_period_s``, a whole number of the model's
    timesteps): the gel law on every strip (once a period, or every step with
    ``physics.gel_update=substep``), ``mj_step`` over the period, then per fingertip its
    pressures, sensor and readout.  Set ``data.ctrl`` between steps as in any MuJoCo loop.
    """

    def __init__(self, tips: Fingertips, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        if not isinstance(model, mujoco.MjModel) or not isinstance(data, mujoco.MjData):
            raise ValueError("bind: give the compiled mujoco.MjModel and its mujoco.MjData")
        if data.qpos.shape != (model.nq,) or data.qvel.shape != (model.nv,):
            raise ValueError("bind: data is not the model's (make it with mujoco.MjData(model))")
        config, fingertip = tips.config, tips.fingertip
        self.model, self.data, self.tips = model, data, tips
        _check_options(model.opt, tips.pads, fingertip.gel, "bind")
        self.period_s = config.physics.control_period_s
        ratio = self.period_s / model.opt.timestep
        if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
            raise ValueError(
                f"bind: physics.control_period_s {self.period_s!r} s is not a whole number of the model's timestep {model.opt.timestep!r} s"
            )
        self.substeps = round(ratio)
        self._every_substep = config.physics.gel_update == "substep"
        unit = make_unit(config)  # the physical unit the channels run, when not the nominal design
        self.bridges: dict[str, PadBridge] = {}
        self.channels: dict[str, SensorChannel] = {}
        self._readers, self._fractions = {}, {}
        rng = np.random.default_rng(config.sensor.seed)
        for pad in tips.pads:
            try:
                bridge = PadBridge(model, gel=fingertip.gel, geometry=pad.geometry, pads={pad.name: pad.strips})
            except ValueError as err:
                raise ValueError(f"bind: {pad.source}: {err} (is the model compiled from the spec given to attach?)") from None
            edges, weights, fractions = coverage_layout(fingertip, unit, pad.geometry, config.sensor.load_spread)
            self.bridges[pad.name] = bridge
            self.channels[pad.name] = make_channel(config, fingertip, unit, edges, np.random.default_rng(rng.integers(2**63)))
            self._readers[pad.name] = strip_reader(bridge, pad.geometry, weights, data)
            self._fractions[pad.name] = fractions
        self._apply = [bridge.apply_gel_forces for bridge in self.bridges.values()]
        self._unloaded_v = {m: fingertip.element.unloaded_voltage(m) for m in fingertip.modes}
        self._readings: dict[str, TipReading] = {}

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.channels)

    def step(self) -> None:
        """One period: the gel law, physics, sensor and readout (then :meth:`readings`).

        :class:`~cosim.loop.SimulationDiverged` if the state went non-finite, or if MuJoCo found
        a bad position, velocity or acceleration in the period: it then resets the data to the
        model's initial state, warns and steps on (``mj_checkPos``, ``mj_checkVel``,
        ``mj_checkAcc``), and the fingertips would read a reset scene as if nothing happened."""
        m, d, step = self.model, self.data, mujoco.mj_step
        start_s, before = d.time, _unstable_counts(d)
        for k in range(self.substeps):
            if k == 0 or self._every_substep:
                for apply in self._apply:
                    apply(d)
            step(m, d)
        warned = [w.name for w, n0, n1 in zip(_UNSTABLE, before, _unstable_counts(d), strict=True) if n1 != n0]
        if warned or d.time <= start_s:
            raise SimulationDiverged(
                f"simulation diverged in the period from t = {start_s:.4f} s: MuJoCo's {', '.join(warned) or 'reset'} "
                f"(it reset the data to the model's initial state; timestep {m.opt.timestep:g} s)"
            )
        if not finite_state(d):
            raise SimulationDiverged(f"simulation diverged at t = {d.time:.4f} s: non-finite state (timestep {m.opt.timestep:g} s)")
        readings = {}
        for name, channel in self.channels.items():
            _, (cells,) = self._readers[name].read()
            reading = channel.update_trusted(cells, self.period_s)
            estimate = channel.estimate(reading)
            truth = math.fsum(p * f for p, f in zip(cells, self._fractions[name], strict=True))
            voltage = reading.v1 * self._unloaded_v[reading.mode]
            readings[name] = TipReading(
                estimate.pressure_pa, estimate.uncertainty_pa, estimate.status, reading.mode, voltage, reading.v1, truth
            )
        self._readings = readings

    def readings(self) -> dict[str, TipReading]:
        """Each fingertip's :class:`TipReading` after the last :meth:`step`, by name."""
        if not self._readings:
            raise RuntimeError("no readings yet: call step() first")
        return dict(self._readings)

    def set_mode(self, name: str, mode: int) -> None:
        """Drive fingertip ``name`` in ``mode`` from the next period (a switch rings the new mode up)."""
        channel = self._channel(name)
        try:
            channel.select_mode(mode)
        except ValueError as err:
            raise ValueError(f"set_mode: fingertip {name!r}: {err}") from None

    def pad_state(self, name: str) -> PadReading:
        """Fingertip ``name``'s pad now (the simulator's truth: normal force, contact area, bottomed)."""
        self._channel(name)
        return self.bridges[name].read(self.data)[name]

    def _channel(self, name: str) -> SensorChannel:
        if name not in self.channels:
            raise ValueError(f"fingertip {name!r} is not attached; the fingertips: {', '.join(self.channels)}")
        return self.channels[name]


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


def make_channel(config: ScenarioConfig, fingertip, unit, edges_m: np.ndarray, rng: np.random.Generator) -> SensorChannel:
    """One fingertip's sensor channel (the unit's own when it is not the nominal design),
    driven from the start in its lowest (most sensitive) mode, steady and settled."""
    s = config.sensor
    options = {
        "edges_m": edges_m,
        "dynamics": s.dynamics,
        "mode": min(s.modes),
        "noise": s.noise,
        "exact": s.exact_gel or s.gel_layer == "dynamic",  # tables need k_e > 0
        "carrier_samples_per_cycle": s.carrier_samples_per_cycle,
    }
    if unit is None:
        return SensorChannel(fingertip, rng=rng, **options)
    return UnitChannel(fingertip, unit, rng=rng, **options)


def strip_reader(bridge: PadBridge, geometry: PadGeometry, cell_weights: list, data: mujoco.MjData):
    """The bridge's per-period read of its one pad, bound to ``data``: the element strips'
    pressures (root to tip) and the coverage cells' (:meth:`PadBridge.pressure_reader`)."""
    element = np.flatnonzero(geometry.on_element).tolist()[::-1]  # root to tip
    read = sorted({*element, *(i for row in cell_weights for i, _ in row)})
    at = {strip: k for k, strip in enumerate(read)}
    reader = bridge.pressure_reader(read, len(read), [at[i] for i in element], [[(at[i], w) for i, w in row] for row in cell_weights])
    reader.bind(data.qpos)
    return reader

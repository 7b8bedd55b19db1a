"""The pads' MuJoCo model: scene files, and the pad strips built into a spec.

:func:`build_model` loads a scene (the house gripper in ``models/``) and regenerates its pads
for another resolution; :func:`add_pad_strips` builds one pad's strips into any body of any
spec at any pose (:class:`PadPlacement`), which the house gripper's fingers and
:func:`cosim.attach.attach` share; :func:`copy_pad_class` gives another spec the house's
class ``pad`` (the strips' hard contacts and housing stop).  The layout is
:mod:`cosim.pad_geometry`'s, the per-step gel law :mod:`cosim.pad_bridge`'s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from piezotip.sensor.gel import GelParams

from .pad_geometry import _GEL, DEFAULT_PAD_SEGMENTS, PAD_SIDES, PadGeometry, gel_damping_per_area, gel_stiffness_per_area

MODELS_DIR = Path(__file__).resolve().parent.parent / "models"
"""Where the MJCF files live (``gripper.xml``, ``table.xml``, ``scene_*.xml``)."""

#: The pad contacts' and housing stop's time constant, s (gripper.xml's, at its 1 ms step).
PAD_CONTACT_TIMECONST_S = 0.002


def scene_names() -> tuple[str, ...]:
    """Names of the scene files in ``models/`` (``scene_<name>.xml``), sorted."""
    return tuple(sorted(p.stem.removeprefix("scene_") for p in MODELS_DIR.glob("scene_*.xml")))


def scene_path(scene: str | Path) -> Path:
    """The MJCF file of ``scene``: an existing path, or a name from :func:`scene_names`."""
    path = Path(scene)
    if path.suffix == ".xml" or path.exists():
        if not path.is_file():
            raise ValueError(f"MJCF file {str(path)!r} does not exist")
        return path.resolve()
    candidate = MODELS_DIR / f"scene_{scene}.xml"
    if not candidate.is_file():
        raise ValueError(f"unknown scene {str(scene)!r}; valid scenes: {', '.join(scene_names())}")
    return candidate


def _load_spec(path: Path) -> mujoco.MjSpec:
    try:
        return mujoco.MjSpec.from_file(str(path))
    except Exception as err:  # MuJoCo raises ValueError; name the file whatever it raises.
        raise ValueError(f"MJCF file {str(path)!r} does not load: {err}") from err


def _compile(spec: mujoco.MjSpec, path: Path) -> mujoco.MjModel:
    try:
        return spec.compile()
    except Exception as err:
        raise ValueError(f"MJCF file {str(path)!r} does not compile: {err}") from err


def build_model(
    scene: str | Path,
    pad_segments: int | None = None,
    *,
    geometry: PadGeometry | None = None,
    gel: GelParams | None = None,
    timestep: float | None = None,
    edit: Callable[[mujoco.MjSpec], None] | None = None,
) -> mujoco.MjModel:
    """Load a scene, optionally with its pads regenerated for another resolution.

    Parameters
    ----------
    scene : a scene name (``"grasp"`` for ``models/scene_grasp.xml``, the one scene file, see
        :func:`scene_names`) or a path to any MJCF file that includes ``gripper.xml``.  A
        scenario's scene, with its object, is :func:`cosim.assembly.build_scene`'s.
    pad_segments : N, strips per element.  None keeps the file's pads (N = 5 in gripper.xml).
    geometry : the full pad geometry (overrides ``pad_segments``); None keeps the file's pads
        unless ``pad_segments`` or ``gel`` is given.
    gel : gel parameters for the strips' thickness, mass, stiffness and damping
        (default: ``GelParams()``).
    timestep : physics timestep, s; also sets the pads' contact and housing time constants to
        max(2 ms, 2 x timestep) (2 ms is the file's; 2 steps is MuJoCo's floor).  None keeps
        the file's 1 ms.
    edit : a function applied to the loaded MjSpec before anything else (a scenario uses it
        to replace the object); errors it raises are reported with the file's name.

    Returns
    -------
    The compiled model.  Keyframes are remapped by joint name when the pads change; new strip
    joints start unloaded.

    Raises
    ------
    ValueError
        naming the file, when it does not exist, does not parse or does not compile.
    """
    path = scene_path(scene)
    spec = _load_spec(path)
    if edit is not None:
        try:
            edit(spec)
        except (ValueError, KeyError, AttributeError) as err:
            raise ValueError(f"MJCF file {str(path)!r}: cannot apply the scenario's edits: {err}") from err
    if geometry is None and (pad_segments is not None or gel is not None):
        gel_params = gel or _GEL
        n = DEFAULT_PAD_SEGMENTS if pad_segments is None else pad_segments
        geometry = PadGeometry(segments=n, gel_thickness_m=gel_params.thickness_m)
    if geometry is not None:
        old = _compile(spec, path)
        try:
            _regenerate_pads(spec, geometry, gel or _GEL)
        except ValueError as err:
            raise ValueError(f"MJCF file {str(path)!r}: {err}") from err
        for key in spec.keys:  # their lengths change with the strips: remapped below
            key.qpos, key.qvel = [], []
        model = _compile(spec, path)
        _remap_keys(old, model)
    else:
        model = _compile(spec, path)
    if timestep is not None:
        _set_timestep(model, timestep)
    return model


def _regenerate_pads(spec: mujoco.MjSpec, geometry: PadGeometry, gel: GelParams) -> None:
    """Replace every pad strip in ``spec`` by the strips of ``geometry`` (class ``pad``)."""
    if abs(geometry.gel_thickness_m - gel.thickness_m) > 1e-12:
        raise ValueError(f"PadGeometry.gel_thickness_m {geometry.gel_thickness_m} differs from the gel's {gel.thickness_m}")
    pad = spec.find_default("pad")
    if pad is None:
        raise ValueError("the model has no default class 'pad' (is gripper.xml included?)")
    for side in PAD_SIDES:
        finger = spec.body(f"{side}_finger")
        if finger is None:
            raise ValueError(f"the model has no body '{side}_finger' (is gripper.xml included?)")
        for child in list(finger.bodies):
            if child.name.startswith(f"{side}_pad_"):
                spec.delete(child)
        add_pad_strips(finger, geometry, gel, geometry.strip_names(side), pad)


@dataclass(frozen=True)
class PadPlacement:
    """Where a pad sits in its parent body: the pad frame's pose there.

    The pad frame is the house gripper's finger frame (models/gripper.xml): its origin at the
    centre of the unloaded pad's free surface, +x out of the pad (towards what it touches), z
    along the pad's length (the element's, towards its clamped root), y across it.

    Attributes
    ----------
    pos_m : the frame's origin in the parent body's frame, m.
    quat : the frame's orientation there (w, x, y, z), unit.
    """

    pos_m: tuple[float, float, float]
    quat: tuple[float, float, float, float]

    def strip_pose(self, z_m: float) -> tuple[list[float], list[float]]:
        """(pos, quat) in the parent body of the strip body centred at ``z_m`` along the pad (m)."""
        offset = np.zeros(3)
        mujoco.mju_rotVecQuat(offset, np.array([0.0, 0.0, float(z_m)]), np.asarray(self.quat, float))
        return (np.asarray(self.pos_m, float) + offset).tolist(), [float(q) for q in self.quat]


def add_pad_strips(
    parent: mujoco.MjsBody,
    geometry: PadGeometry,
    gel: GelParams,
    names: tuple[str, ...],
    pad_class: mujoco.MjsDefault,
    placement: PadPlacement | None = None,
) -> None:
    """Add one pad's strips to ``parent``: per strip a body on a slide joint into the housing, its
    gel column as a box geom (``name``, ``name + "_joint"``, ``name + "_geom"``, distal first).

    Joint range, stiffness and damping come from ``geometry`` and ``gel`` (they scale with the
    strip's area); the contact and housing-stop parameters from ``pad_class`` (the house
    gripper's class ``pad``).  ``placement``: the pad frame in ``parent``; None is the parent's
    own frame (the house gripper's fingers).
    """
    h0, width = geometry.gel_thickness_m, geometry.pad_width_m
    k_area, c_area = gel_stiffness_per_area(gel), gel_damping_per_area(gel)
    for name, z, length, area in zip(names, geometry.strip_centers_m, geometry.strip_lengths_m, geometry.strip_areas_m2, strict=True):
        if placement is None:
            body = parent.add_body(name=name, pos=[0.0, 0.0, float(z)], gravcomp=1.0)
        else:
            pos, quat = placement.strip_pose(z)
            body = parent.add_body(name=name, pos=pos, quat=quat, gravcomp=1.0)
        body.add_joint(
            pad_class,
            name=f"{name}_joint",
            range=[-geometry.retain_m, geometry.stop_m],
            stiffness=[float(k_area * area), 0.0, 0.0],
            damping=[float(c_area * area), 0.0, 0.0],
        )
        body.add_geom(
            pad_class,
            name=f"{name}_geom",
            size=[0.5 * h0, 0.5 * width, 0.5 * float(length)],
            pos=[-0.5 * h0, 0.0, 0.0],
            density=gel.density_kg_m3,
        )


#: What a default class copies of the house's class ``pad`` (everything but its identity).
_NOT_COPIED = frozenset({"name", "classname", "id", "parent", "frame", "info", "signature", "compiler", "alt", "plugin", "userdata"})


def copy_pad_class(spec: mujoco.MjSpec, name: str, material: str) -> mujoco.MjsDefault:
    """Add to ``spec`` a default class ``name`` that is the house gripper's class ``pad``
    (models/gripper.xml: the strips' joint and the hard contact of their geoms), under the
    spec's root class, and the gel's material as ``material``; returns the class.

    Copied attribute by attribute from the file, so the file stays the one source of the pads'
    contact and housing-stop parameters.
    """
    house = _load_spec(MODELS_DIR / "gripper.xml")
    source = house.find_default("pad")
    gel_material = house.material(source.geom.material)
    target = spec.add_default(name, spec.default)
    for kind in ("joint", "geom"):
        src, dst = getattr(source, kind), getattr(target, kind)
        for attr in dir(src):
            value = None if attr.startswith("_") or attr in _NOT_COPIED else getattr(src, attr)
            if value is not None and not callable(value):
                setattr(dst, attr, value)
    spec.add_material(name=material, rgba=list(gel_material.rgba))
    target.geom.material = material
    return target


def pad_time_constant_s(timestep: float) -> float:
    """The pad contacts' and housing stop's time constant at ``timestep``, s.

    A physical time constant (the file's 2 ms), floored at MuJoCo's 2 timesteps: a finer step
    then resolves the same contact instead of a harder one, so results converge as the step
    shrinks (the reference preset's check).
    """
    return max(PAD_CONTACT_TIMECONST_S, 2 * timestep)


#: The pad contact's impedance (MuJoCo solimp: d0, dwidth, width m, midpoint, power), as
#: models/gripper.xml's class ``pad`` has it: d ramps from 0.1 at first touch to MuJoCo's maximum
#: 0.9999 over the first 30 um of depth (midpoint 0.1, power 3: 0.36 at 5 um, 0.67 at 10 um, 0.96 at
#: 20 um), so a contact carrying a milli-newton rests about 10 um deep and a loaded one 12-25 um.
#: That is deeper than one step of sliding can open: MuJoCo's convex contacts separate a sliding
#: contact at mu |v_t| (the velocity lies in the friction cone's dual); at the rating's mu 1.5, slip
#: bursts of 5 mm/s and a 1 ms step that is 7.5 um.  The shape was measured (models/README.md,
#: "Sliding pads"): from d0 0.8 (10 um) pads at grips under 0.3 N still chatter; from d0 0.1 over
#: 20 um a 1 g object squeezed at 80 N never comes to rest; a midpoint of 0.5 leaves it vibrating.
COMPLIANT_PAD_SOLIMP = (0.1, 0.9999, 3.0e-5, 0.1, 3.0)
#: The ratio of friction to normal impedance (MuJoCo impratio) with that contact: the ramp leaves
#: a loaded contact at d = 0.96-0.995, whose friction rows are 50-400x softer than at 0.9999
#: (regularization (1 - d) / d: 0.005-0.04 against 1e-4); impratio divides the friction rows'
#: regularization, and 100 brings a held object's creep under 0.1 mm/s of hold at 1.2x its needed
#: grip on the whole creep grid (reports/creep.py).
COMPLIANT_IMPRATIO = 1000.0
#: The hard pad contact (``physics.pad_contact=hard``, the model before): 0.9999 from first touch.
HARD_PAD_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
HARD_IMPRATIO = 1.0
PAD_CONTACT_SETTINGS = {"compliant": (COMPLIANT_PAD_SOLIMP, COMPLIANT_IMPRATIO), "hard": (HARD_PAD_SOLIMP, HARD_IMPRATIO)}


def pad_geom_ids(model: mujoco.MjModel) -> list[int]:
    """The ids of every pad strip's geom in a compiled model (``*_pad_*_geom``: the strips the
    class ``pad`` makes, on the house gripper, a mounted one or an attached fingertip)."""
    return [g for g in range(model.ngeom) if model.geom(g).name.endswith("_geom") and "_pad_" in model.geom(g).name]


def resolve_pad_contact(kind: str) -> str:
    """``physics.pad_contact`` made concrete: "auto" is "compliant" on every gripper, the house's
    and a mounted (``gripper.mjcf``) one alike.  The hard contact rests 0.14 um deep under a
    7.7 N grip, and MuJoCo's convex contact separates a sliding one at mu |v_t| a step: a pad
    that begins to slide lets go for a step (robosuite's Panda dropped its 330 g jar so; the compliant contact rests 12-25 um
    deep and keeps every contact: docs/grippers.md, models/README.md "Sliding pads")."""
    if kind == "auto":
        return "compliant"
    return kind


def apply_pad_contact(model: mujoco.MjModel, kind: str) -> None:
    """Write the pad contact ``kind`` (:data:`PAD_CONTACT_SETTINGS`) into a compiled model: the
    impedance of every pad strip's geom and the model's impratio.  "compliant" is
    models/gripper.xml's own; "hard" is MuJoCo's maximum impedance from first touch, the model
    before, kept for comparison (its sliding pads chatter, models/README.md).  The gel law and the
    pressure the element carries are the same with both in statics (the strip's gel force equals
    its contact force); "compliant" adds its few micrometres of depth to the object's position."""
    if kind not in PAD_CONTACT_SETTINGS:
        raise ValueError(f"physics.pad_contact must be one of {', '.join(PAD_CONTACT_SETTINGS)}; got {kind!r}")
    solimp, impratio = PAD_CONTACT_SETTINGS[kind]
    pad_geoms = pad_geom_ids(model)
    model.geom_solimp[pad_geoms] = solimp
    model.opt.impratio = impratio


def _remap_keys(old: mujoco.MjModel, new: mujoco.MjModel) -> None:
    """Write the keyframes of ``old`` into ``new`` joint by joint (joints new to ``new`` keep qpos0)."""
    for k in range(new.nkey):
        qpos_old, qvel_old = old.key_qpos[k], old.key_qvel[k]
        qpos, qvel = new.qpos0.copy(), np.zeros(new.nv)
        for j in range(new.njnt):
            name = new.joint(j).name
            try:
                jo = old.joint(name).id
            except KeyError:
                continue
            nq = _joint_nq(new.jnt_type[j])
            nv = _joint_nv(new.jnt_type[j])
            qpos[new.jnt_qposadr[j] : new.jnt_qposadr[j] + nq] = qpos_old[old.jnt_qposadr[jo] : old.jnt_qposadr[jo] + nq]
            qvel[new.jnt_dofadr[j] : new.jnt_dofadr[j] + nv] = qvel_old[old.jnt_dofadr[jo] : old.jnt_dofadr[jo] + nv]
        new.key_qpos[k] = qpos
        new.key_qvel[k] = qvel


def _joint_nq(jnt_type: int) -> int:
    return {mujoco.mjtJoint.mjJNT_FREE: 7, mujoco.mjtJoint.mjJNT_BALL: 4}.get(jnt_type, 1)


def _joint_nv(jnt_type: int) -> int:
    return {mujoco.mjtJoint.mjJNT_FREE: 6, mujoco.mjtJoint.mjJNT_BALL: 3}.get(jnt_type, 1)


def _set_timestep(model: mujoco.MjModel, timestep: float) -> None:
    if not (math.isfinite(timestep) and timestep > 0):
        raise ValueError(f"timestep must be positive and finite, got {timestep!r}")
    model.opt.timestep = timestep
    pad_geoms = pad_geom_ids(model)
    pad_joints = [j for j in range(model.njnt) if "_pad_" in model.joint(j).name]
    constant = pad_time_constant_s(timestep)
    model.geom_solref[pad_geoms, 0] = constant
    model.jnt_solref[pad_joints, 0] = constant

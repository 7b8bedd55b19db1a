"""A scenario's MuJoCo scene: the gripper, the table and the configured object.

The scene file ``models/scene_grasp.xml`` holds the gripper, the table and a placeholder
object; :func:`cosim.assembly.build_scene` replaces the object by the one a scenario configures (shape,
size, mass, friction), regenerates the pads for the configured resolution and sets the
timestep and integrator.  The home state (gripper open, pads centred on the object's grasp
height, object at rest) is computed here from the geometry instead of a typed keyframe, so it
holds for every object.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from piezotip.cosim.config import RATED_MASS_KG, ObjectConfig, ScenarioConfig
from piezotip.cosim.shapes import EGG_ASPECT, get_shape  # noqa: F401  (EGG_ASPECT: importable here, as it was)
from piezotip.sensor.gel import GelParams

from .control.interface import RobotLimits
from .pad_geometry import PadGeometry
from .pad_model import MODELS_DIR, apply_pad_contact, build_model, resolve_pad_contact

SCENE_FILE = MODELS_DIR / "scene_grasp.xml"
#: Height of the pad centres above the palm joint's zero, m (gripper.xml: palm at 0.35 m,
#: pad centres 70 mm below it).
PAD_CENTRE_AT_ZERO_LIFT_M = 0.28
#: How far the finger reaches below the pad centre, m (gripper.xml: the finger link's collision
#: box runs from 12 mm below the pad centre), and the clearance kept between it and the table, m.
FINGER_BELOW_PAD_CENTRE_M = 0.012
TABLE_CLEARANCE_M = 0.002
#: Opening between the unloaded pad surfaces at home, m (the fingers' stroke is 0-100 mm).
HOME_OPENING_M = 0.09

_INTEGRATORS = {
    "Euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "RK4": mujoco.mjtIntegrator.mjINT_RK4,
    "discrete": mujoco.mjtIntegrator.mjINT_DISCRETE,
}


@dataclass(frozen=True)
class ObjectShape:
    """The object's MuJoCo geom: type, half-sizes (m) and the height of its centre at rest (m)."""

    geom_type: mujoco.mjtGeom
    size: tuple[float, float, float]
    rest_height_m: float


def object_shape(obj: ObjectConfig) -> ObjectShape:
    """Geom type and half-sizes for ``obj``, as its registered shape builds them
    (:mod:`cosim.shapes`); ``size_m`` is always the width between the fingers."""
    geom = get_shape(obj.shape).geom(obj.size_m)
    geom_type = getattr(mujoco.mjtGeom, f"mjGEOM_{geom.geom_type.upper()}")  # a pybind11 enum: no mjtGeom[...]
    return ObjectShape(geom_type, geom.size, geom.rest_height_m)


def grasp_height_m(obj: ObjectConfig) -> float:
    """Height of the pad centres for the grasp, m: the object's centre, the finger clear of the table."""
    return max(object_shape(obj).rest_height_m, FINGER_BELOW_PAD_CENTRE_M + TABLE_CLEARANCE_M)


def _edit_object(obj: ObjectConfig):
    shape = object_shape(obj)

    def edit(spec: mujoco.MjSpec) -> None:
        geom = spec.geom("object_geom")
        body = spec.body("object")
        if geom is None or body is None:
            raise ValueError("the scene has no body 'object' with geom 'object_geom'")
        geom.type = shape.geom_type
        geom.size = list(shape.size)
        geom.mass = obj.mass_kg
        body.pos = [0.0, 0.0, shape.rest_height_m]
        # Pad-object contacts take the pads' parameters (class `pad` has priority): the pair's
        # friction is the object's, so it goes on the pads.
        pad = spec.find_default("pad")
        pad.geom.friction = [obj.friction, pad.geom.friction[1], pad.geom.friction[2]]
        for key in list(spec.keys):
            spec.delete(key)

    return edit


def build_house_scene(config: ScenarioConfig, gel: GelParams | None = None) -> mujoco.MjModel:
    """The house gripper's compiled scene for ``config``: its object, pad resolution, timestep
    and integrator (a scenario's model, a mounted gripper's too: :func:`cosim.assembly.build_scene`)."""
    phys = config.physics
    model = build_model(
        SCENE_FILE,
        pad_segments=phys.pad_segments,
        gel=gel,
        timestep=phys.timestep_s,
        edit=_edit_object(config.object),
    )
    model.opt.integrator = _INTEGRATORS[phys.integrator]
    apply_pad_contact(model, resolve_pad_contact(phys.pad_contact))
    return model


def finger_force_limit_n(model: mujoco.MjModel) -> float:
    """The fingers' force limit, N per finger, as the compiled model has it."""
    return float(model.actuator("fingers_actuator").forcerange[1])


def gravity_m_s2(model: mujoco.MjModel) -> float:
    """The magnitude of the model's gravity, m/s^2 (down is -z)."""
    return float(-model.opt.gravity[2])


def robot_limits(
    model: mujoco.MjModel,
    home: dict[str, float],
    geometry: PadGeometry,
    gel: GelParams | None = None,
    fingers: dict[str, float] | None = None,
    pad_rise_m: tuple[tuple[float, ...], tuple[float, ...]] = ((), ()),
    lift_coupling_kg: tuple[tuple[float, ...], tuple[float, ...]] = ((), ()),
    finger_reach_n: tuple[tuple[float, ...], tuple[float, ...]] = ((), ()),
) -> RobotLimits:
    """The gripper's limits and servo gains as the compiled model has them (never typed again).

    ``fingers``: a mounted gripper's finger fields of :class:`RobotLimits` by name (force limit,
    damping, dry friction, mass and joints' damping, on the opening), from its drive
    (cosim.gripper_drive.GripperDrive); None reads the house gripper's (no friction: its finger
    joints have none).  ``pad_rise_m``, ``lift_coupling_kg``, ``finger_reach_n``: :class:`RobotLimits`'
    (none on the house gripper: its fingers slide across the lift, and its servo's force range
    binds at every opening)."""
    lift = model.actuator("lift_actuator")
    kp, kv = float(lift.gainprm[0]), float(-lift.biasprm[2])
    if fingers is None:
        house, joint = model.actuator("fingers_actuator"), model.joint("left_finger_joint")
        # The tendon's speed is the opening's; each finger moves at half of it against its
        # joint's damping, and the servo's own kv acts on the tendon.
        joint_damping = float(0.5 * model.dof_damping[joint.dofadr[0]])
        fingers = {
            "finger_force_limit_n": finger_force_limit_n(model),
            "finger_damping_n_s_m": joint_damping - float(house.biasprm[2]),
            "finger_friction_n": 0.0,
            "finger_mass_kg": house_finger_mass_kg(model),
            "finger_joint_damping_n_s_m": joint_damping,
            "finger_servo_stiffness_n_m": float(house.gainprm[0]),  # on the tendon, whose length is the opening
        }
    return RobotLimits(
        lift_kp_n_m=kp,
        lift_kv_n_s_m=kv,
        lift_force_limit_n=float(lift.forcerange[1]),
        lift_range_m=(float(model.joint("lift_joint").range[0]), float(model.joint("lift_joint").range[1])),
        lift_moving_mass_kg=float(model.body_subtreemass[model.body("palm").id]),
        pad_area_m2=geometry.pad_area_m2,
        pad_travel_m=geometry.stop_m,
        pad_areal_mass_kg_m2=(gel or GelParams()).density_kg_m3 * geometry.gel_thickness_m,
        min_load_n=0.5 * RATED_MASS_KG[0] * gravity_m_s2(model),
        gravity_m_s2=gravity_m_s2(model),
        home_lift_m=home["lift_m"],
        home_opening_m=home["opening_m"],
        pad_rise_m=pad_rise_m,
        lift_coupling_kg=lift_coupling_kg,
        finger_reach_n=finger_reach_n,
        **{name: float(value) for name, value in fingers.items()},
    )


def house_finger_mass_kg(model: mujoco.MjModel) -> float:
    """The house fingers' inertia on the opening, kg: the opening is the sum of the two finger
    slides (the fingers tendon, coefficient 1 each) and each moves at half its speed, so
    m_o = v^T M v with v = (1/2, 1/2) on their dofs (M from mj_fullM: the fingers, their pads
    and the joints' armature)."""
    data, mass = mujoco.MjData(model), np.zeros((model.nv, model.nv))
    mujoco.mj_forward(model, data)
    mujoco.mj_fullM(model, data, mass)
    v = np.zeros(model.nv)
    for side in ("left", "right"):
        v[model.joint(f"{side}_finger_joint").dofadr[0]] = 0.5
    return float(v @ mass @ v)


def check_reach(config: ScenarioConfig, robot: RobotLimits) -> None:
    """Refuse a lift the lift joint cannot make, naming its range and the most it allows here."""
    lo, hi = robot.lift_range_m
    top = robot.home_lift_m + config.controller.lift_height_m
    if top > hi:
        raise ValueError(
            f"controller.lift_height_m {config.controller.lift_height_m!r} m takes the lift to {top:.3g} m, beyond the lift joint's "
            f"range [{lo:g}, {hi:g}] m: at most {hi - robot.home_lift_m:.3g} m for this object"
        )


def reset_home(model: mujoco.MjModel, data: mujoco.MjData, config: ScenarioConfig) -> dict[str, float]:
    """Put ``data`` in the home state; returns the home commands (lift_m, opening_m)."""
    mujoco.mj_resetData(model, data)
    lift = grasp_height_m(config.object) - PAD_CENTRE_AT_ZERO_LIFT_M
    half_opening = 0.5 * HOME_OPENING_M
    data.qpos[model.joint("lift_joint").qposadr[0]] = lift
    for side in ("left", "right"):
        data.qpos[model.joint(f"{side}_finger_joint").qposadr[0]] = half_opening
    adr = model.joint("object_joint").qposadr[0]
    data.qpos[adr : adr + 7] = [0.0, 0.0, object_shape(config.object).rest_height_m, 1.0, 0.0, 0.0, 0.0]
    data.ctrl[model.actuator("lift_actuator").id] = lift
    data.ctrl[model.actuator("fingers_actuator").id] = HOME_OPENING_M
    mujoco.mj_forward(model, data)
    return {"lift_m": lift, "opening_m": HOME_OPENING_M}


def object_height_m(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """The object's centre height, m (ground truth: for the recorder and the referee only)."""
    return float(data.xpos[model.body("object").id][2])


def finite_state(data: mujoco.MjData) -> bool:
    """Whether the state is finite (no NaN or inf in qpos, qvel)."""
    return bool(np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel)))


__all__ = ["build_house_scene", "grasp_height_m", "object_height_m", "object_shape", "reset_home"]

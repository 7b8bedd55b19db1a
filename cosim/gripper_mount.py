"""A gripper nobody here wrote, on the lift: its MJCF file, two fingertips and the actuators that close it.

``run grasp --set gripper.mjcf=PATH --set "gripper.fingertips=['a', 'b']" --set "gripper.actuators=['m']"``
(scenario keys: :class:`~cosim.config.GripperConfig`; docs/grippers.md) grasps with that
gripper in the house scene: its table, object, options (timestep, integrator, contacts) and lift
(the palm's slide joint and servo: the arm's stand-in).  :func:`mount_gripper` builds it:

1. The file is read as MuJoCo reads it, but as a part of a scene (:func:`load_gripper_spec`: the
   scene's angle unit where the file sets none; a repeated asset or an attribute this MuJoCo
   does not know left out, with a warning).
2. Each fingertip gets the gel pad :func:`piezotip.attach` would put on it
   (:func:`cosim.attach.fingertip_pads`), its strips named as the house gripper's
   (``left_pad_seg0``, ...), so every reader of the house's pads reads these.  A pad touches the
   object, the table and the other finger, never its own gripper's links; links the file models
   through each other in its reference pose (a linkage's bars) do not touch each other either.
3. The file's top body holding both fingertips (or, where an arm or a base in the file moves the
   gripper, the gripper under its last joint: :func:`cosim.gripper_parts._mounted_body`) hangs
   from the palm, turned so that its approach
   axis points down and its fingertips close along world x (the first at -x, as the house's left
   finger), the pads' centre 70 mm below the palm as the house's.  Every body of it is
   gravity-compensated (the arm holds the gripper's weight, as the house's ``gravcomp``).
4. The drive (:class:`GripperDrive`) is measured on the mounted model: the actuators are swept
   from open to closed with the object away (the fingers' free closing, :func:`_free_closing`),
   the actuator lengths, joint positions and the opening between the pads' surfaces recorded,
   starting from the open pose the actuators command (the file's ``qpos0`` may be no pose the
   gripper can take: closed, or outside its joints' ranges; :func:`reference_qpos`).
   From that path come the command for an opening, the grip each finger feels from the
   actuators' forces, the force limits that cap it, the grip rating and the damping the drive
   must overcome (:class:`~cosim.control.interface.RobotLimits`): nothing typed again.

A position servo (MuJoCo's ``position``, or a ``general`` actuator with an affine bias: it holds
the actuator length its command sets) keeps its own gains; a motor is made a position servo
(:func:`_motor_gains`: as stiff per rated grip as the house's finger servo, critically damped).
An actuator that cannot be either is refused with the reason (:func:`cosim.gripper_parts._drive_kind`).

Each job has its module: the file (:mod:`cosim.gripper_file`: step 1), its parts and what each
actuator can be (:mod:`cosim.gripper_parts`), the drive measured on the mounted model
(:mod:`cosim.gripper_drive`: step 4), and the mount itself, the scene and its assembly, here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from piezotip.cosim.config import ScenarioConfig
from piezotip.sensor.gel import GelParams

from .control.interface import RobotLimits
from .gripper_drive import MASS_POINTS, PREFIX, DrivePath, GripperDrive, _free_closing, hold_activations, opening_inertia_kg
from .gripper_file import GripperFileWarning, load_gripper_spec
from .gripper_parts import _ONE_DOF, GripperParts, _Actuator, check_gripper, gripper_parts, reference_qpos
from .pad_geometry import PAD_SIDES, PadGeometry
from .pad_model import add_pad_strips, apply_pad_contact, build_model, resolve_pad_contact
from .scene import (
    _INTEGRATORS,
    PAD_CENTRE_AT_ZERO_LIFT_M,
    SCENE_FILE,
    TABLE_CLEARANCE_M,
    _edit_object,
    object_shape,
    robot_limits,
)

# The mount's pieces, each in the module of its job (the file, its parts, the drive), named here too.
__all__ = [
    "MASS_POINTS",
    "PREFIX",
    "DrivePath",
    "GripperDrive",
    "GripperFileWarning",
    "GripperParts",
    "MountedGripper",
    "check_gripper",
    "gripper_parts",
    "hold_activations",
    "load_gripper_spec",
    "mount_gripper",
    "opening_inertia_kg",
    "reference_qpos",
]

#: The pads' centre below the palm's origin, m: the house gripper's (palm at 0.35 m, pads at 0.28 m
#: at lift 0), so a mounted gripper's lift has the house's range and home.
PADS_BELOW_PALM_M = 0.35 - PAD_CENTRE_AT_ZERO_LIFT_M
#: Room left on each side of the object between it and the open pads, m: the house's home opening
#: (90 mm) leaves its widest object (85 mm, ObjectConfig) 2.5 mm a side.
HOME_CLEARANCE_M = 0.0025
#: A motor made a position servo (_motor_gains) is as stiff per rated grip as the house's
#: finger servo: kp 1e4 N/m for its 100 N, the rating 10 mm inside the object (models/gripper.xml).
HOUSE_SERVO_TRAVEL_M = 0.01

#: The house gripper's parts in models/gripper.xml that a mounted gripper replaces, besides the
#: palm's geoms and finger bodies ...
_HOUSE_PARTS = {"actuator": ("fingers_actuator",), "tendon": ("fingers_tendon",), "equality": ("fingers_coupling",)}
#: ... and the sensors it keeps: the lift's, and the referee's (the object-contact ones re-aimed
#: at the mounted fingers); the others are the house fingers'.
_KEPT_SENSORS = (
    "lift_pos",
    "lift_force",
    "object_table_contact",
    "left_object_contact",
    "right_object_contact",
    "left_object_normal",
    "right_object_normal",
)
#: The referee's sensors on each finger (``{side}_{name}``), re-aimed at the mounted fingers.
_FINGER_SENSORS = ("object_contact", "object_normal")

# ---------------------------------------------------------------------------------------
# The scene.
# ---------------------------------------------------------------------------------------


def _mount_pose(parts: GripperParts) -> tuple[np.ndarray, np.ndarray]:
    """The frame (pos, quat) in the palm that carries the file's frame: approach down, closing
    along +x, the pads' centre PADS_BELOW_PALM_M under the palm."""
    closing, approach = np.asarray(parts.closing_axis), np.asarray(parts.approach_axis)
    rotation = np.stack([closing, np.cross(closing, approach), -approach])  # rows: the file's axes that become x, y, z
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rotation.ravel())
    pos = np.array([0.0, 0.0, -PADS_BELOW_PALM_M]) - rotation @ np.asarray(parts.pad_centre_m)
    return pos, quat


def _remove_house_gripper(spec: mujoco.MjSpec) -> dict[str, dict]:
    """Take the house gripper off the palm (the lift joint and its servo stay); returns the
    settings of the fingers' contact sensors on the object, which go with the fingers."""
    touch = {}
    for side in PAD_SIDES:
        for name in _FINGER_SENSORS:
            sensor = spec.sensor(f"{side}_{name}")
            settings = {k: getattr(sensor, k) for k in ("type", "objtype", "reftype", "refname")}
            touch[f"{side}_{name}"] = settings | {"intprm": list(sensor.intprm)}
    palm = spec.body("palm")
    for element in [*palm.geoms, *palm.bodies]:
        spec.delete(element)  # with the fingers go what refers to them: their joints' actuator, tendon, sensors
    for kind, names in _HOUSE_PARTS.items():
        for name in names:
            element = getattr(spec, kind)(name)
            if element is not None:
                spec.delete(element)
    for sensor in list(spec.sensors):
        if sensor.name not in _KEPT_SENSORS:
            spec.delete(sensor)
    return touch


def _mount_edit(config: ScenarioConfig, parts: GripperParts, geometry: PadGeometry, gel: GelParams):
    """The scene file's edit that puts the object in and replaces the house gripper by ``parts``'."""
    edit_object = _edit_object(config.object)

    def edit(spec: mujoco.MjSpec) -> None:
        edit_object(spec)  # the object, and its friction on the class `pad` the strips take
        touch = _remove_house_gripper(spec)
        gripper = load_gripper_spec(parts.path, warn=False)  # warned when its parts were checked
        for key in list(gripper.keys):  # its joints' reference poses are the scene's to set
            gripper.delete(key)
        for name in dir(spec.option):  # the scene's options (the pads need them), the file's dropped unsaid
            if not name.startswith("_"):
                setattr(gripper.option, name, getattr(spec.option, name))
        for actuator in parts.actuators:
            _as_drive(gripper.actuator(actuator.name), actuator)
        top = gripper.body(parts.top_body)
        for joint in list(top.joints):  # the arm's last joint, where it carries both fingers: the palm's now
            gripper.delete(joint)
        pos, quat = _mount_pose(parts)
        frame = spec.body("palm").add_frame(pos=pos.tolist(), quat=quat.tolist())
        frame.attach_body(top, PREFIX, "")
        for body in spec.bodies:
            if body.name.startswith(PREFIX):
                body.gravcomp = 1.0  # the arm carries the gripper, as the house's gravcomp
        pad_class = spec.find_default("pad")
        for side, (_, body, placement, _), own in zip(PAD_SIDES, parts.pads, parts.untouched, strict=True):
            finger = spec.body(PREFIX + body)
            strips = geometry.strip_names(side)
            add_pad_strips(finger, geometry, gel, strips, pad_class, placement)
            # The unloaded pad's surface centre: where the opening is measured from.
            finger.add_site(name=f"{side}_pad_surface", pos=list(placement.pos_m), quat=list(placement.quat), size=[0.001] * 3, group=4)
            # A pad touches the object, the table and the other finger (as the house's pads),
            # never the rest of the gripper: the finger it sits on, the palm, a linkage's links.
            for strip in strips:
                for link in own:
                    spec.add_exclude(name=f"{strip}_{link}_exclude", bodyname1=PREFIX + link, bodyname2=strip)
        for first, second in parts.overlapping:
            spec.add_exclude(name=f"{PREFIX}{first}_{second}_exclude", bodyname1=PREFIX + first, bodyname2=PREFIX + second)
        for side, branch in zip(PAD_SIDES, parts.branches, strict=True):  # each finger's push on the object (the referee's)
            for name in _FINGER_SENSORS:
                spec.add_sensor(name=f"{side}_{name}", objname=PREFIX + branch, **touch[f"{side}_{name}"])

    return edit


def _as_drive(actuator: mujoco.MjsActuator, found: _Actuator) -> None:
    """Make the file's actuator the drive the loop commands: force-limited at its rating (the loop
    sets the limit every period), a motor commanded in lengths (a servo: :func:`_motor_gains`)."""
    actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    actuator.forcerange = [-found.force_max, found.force_max]
    if found.kind == "motor":  # its gains are set on the compiled model (_motor_gains)
        actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.ctrlrange = list(found.ctrl_range)


# ---------------------------------------------------------------------------------------
# Mounted.
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MountedGripper:
    """The scene with a third-party gripper on the lift, and how to drive it.

    Attributes
    ----------
    model : the compiled scene.
    parts : the gripper file's parts (:class:`GripperParts`).
    geometry : the pad both fingertips carry.
    pads : per pad name, its strips' body names, distal first (PadBridge's ``pads``).
    drive : the finger drive (:class:`GripperDrive`).
    open_ctrl : the actuators' open commands (home).
    """

    model: mujoco.MjModel
    parts: GripperParts
    geometry: PadGeometry
    pads: dict[str, tuple[str, ...]]
    drive: GripperDrive
    open_ctrl: np.ndarray

    def grasp_height_m(self, config: ScenarioConfig) -> float:
        """Height of the pads' centre at home for the grasp, m: where, closed to the object's
        width, they meet its centre (as the house gripper's; a linkage's pads rise or fall along
        their arc on the way, :attr:`DrivePath.centre_rise_m`), but the gripper clear of the table
        wherever it closes down to the object's width less the pads' travel, and its palm clear of
        the object's top (a tall object is taken higher up); each TABLE_CLEARANCE_M clear."""
        path, rest = self.drive.path, object_shape(config.object).rest_height_m
        reach = float(np.interp(config.object.size_m - 2.0 * self.geometry.stop_m, path.opening_m, path.lowest_m))
        rise = float(np.interp(config.object.size_m, path.opening_m, path.centre_rise_m))
        return max(rest - rise, reach + TABLE_CLEARANCE_M, 2.0 * rest + TABLE_CLEARANCE_M - path.palm_above_m)

    def reset_home(self, data: mujoco.MjData, config: ScenarioConfig) -> dict[str, float]:
        """Put ``data`` in the home state (the fingers open, the pads' centre at the grasp
        height, the object at rest); returns the home commands (lift_m, opening_m)."""
        m = self.model
        mujoco.mj_resetData(m, data)
        data.qpos[self.drive.joint_qpos] = self.drive.path.qpos[-1]
        mujoco.mj_kinematics(m, data)
        centre = 0.5 * sum(data.site_xpos[m.site(f"{side}_pad_surface").id, 2] for side in PAD_SIDES)
        lift = self.grasp_height_m(config) - float(centre)  # the pads' centre at lift 0 is `centre`
        data.qpos[m.joint("lift_joint").qposadr[0]] = lift
        adr = m.joint("object_joint").qposadr[0]
        data.qpos[adr : adr + 7] = [0.0, 0.0, object_shape(config.object).rest_height_m, 1.0, 0.0, 0.0, 0.0]
        data.ctrl[m.actuator("lift_actuator").id] = lift
        data.ctrl[self.drive.actuators] = self.open_ctrl
        hold_activations(m, data, self.drive.actuators)
        mujoco.mj_forward(m, data)
        return {"lift_m": lift, "opening_m": self.drive.home_opening_m}

    def robot_limits(self, home: dict[str, float], gel: GelParams | None = None) -> RobotLimits:
        """The robot's limits as the scene's model has them: the lift's as the house's, the
        fingers' from the drive (:meth:`GripperDrive.rating_n`, :meth:`GripperDrive.damping_n_s_m`,
        the most of :attr:`GripperDrive.friction_n` along the path, the least of its
        :attr:`GripperDrive.mass_kg`, the most of its joints' damping and the median of its
        servos' stiffness)."""
        drive = self.drive
        fingers = {
            "finger_force_limit_n": drive.rating_n(),
            "finger_damping_n_s_m": drive.damping_n_s_m(),
            "finger_friction_n": float(drive.friction_n.max()),
            "finger_mass_kg": float(drive.mass_kg.min()),
            "finger_joint_damping_n_s_m": float(drive.joint_damping_n_s_m.max()),
            "finger_servo_stiffness_n_m": float(np.median(drive.servo_stiffness_n_m)),
        }
        path = drive.path
        rise = coupling = ((), ())
        if np.any(path.centre_rise_m):  # a linkage's arc (slides' pads keep their height exactly)
            rise = (tuple(path.opening_m.tolist()), tuple(path.centre_rise_m.tolist()))
        if np.any(drive.lift_coupling_kg):  # (exactly 0 for slides across the lift)
            coupling = (tuple(path.opening_m[list(MASS_POINTS)].tolist()), tuple(drive.lift_coupling_kg.tolist()))
        reach_n = drive.reach_n()
        reach = ((), ())
        if np.any(reach_n < fingers["finger_force_limit_n"]):  # a servo whose reach is less than its rating somewhere
            reach = (tuple(path.opening_m.tolist()), tuple(reach_n.tolist()))
        return robot_limits(
            self.model, home, self.geometry, gel, fingers=fingers, pad_rise_m=rise, lift_coupling_kg=coupling, finger_reach_n=reach
        )


def mount_gripper(config: ScenarioConfig, gel: GelParams | None = None) -> MountedGripper:
    """The scene of ``config`` with its ``gripper.mjcf`` on the lift (module docstring).

    Raises
    ------
    ValueError
        naming the key: a file that does not load or lacks what the config names
        (:func:`gripper_parts`; a free joint on the gripper), a file that does not compile mounted
        in the scene (the gripper's file named, not the scene's), actuators that do not close the
        gripper, an object wider than its open pads.
    """
    gel = gel or GelParams()
    parts = gripper_parts(config.gripper)
    geometry = parts.geometry(config.physics.pad_segments)
    phys = config.physics
    try:
        model = build_model(SCENE_FILE, timestep=phys.timestep_s, edit=_mount_edit(config, parts, geometry, gel))
    except ValueError as err:  # the house scene compiles alone: what fails is the gripper mounted in it
        raise ValueError(f"gripper.mjcf {parts.path!r} does not mount in the scene: {err}") from err
    model.opt.integrator = _INTEGRATORS[phys.integrator]
    apply_pad_contact(model, resolve_pad_contact(phys.pad_contact))
    actuators = [model.actuator(PREFIX + a.name).id for a in parts.actuators]
    joints = _gripper_joints(model)
    motors = [i for i, a in enumerate(parts.actuators) if a.kind == "motor"]
    for i in motors:  # until the path gives it its gains: its rating over its stroke, undamped
        found = parts.actuators[i]
        _set_gains(model, actuators[i], found.force_max / (found.ctrl_range[1] - found.ctrl_range[0]), 0.0)
    path, open_ctrl = _free_closing(model, parts, actuators, joints)
    if motors:
        _motor_gains(model, parts, actuators, joints, path)
        path, open_ctrl = _free_closing(model, parts, actuators, joints)  # the fingers as the servo moves them
    kv, kp = -model.actuator_biasprm[actuators, 2], -model.actuator_biasprm[actuators, 1]
    drive = GripperDrive(model, parts, path, joints, kv, kp)
    widest = widest_object_m(drive.home_opening_m)
    if config.object.size_m > widest:
        raise ValueError(
            f"object.size_m {config.object.size_m!r} m does not fit the gripper of gripper.mjcf {parts.path!r}: its pads open "
            f"{1e3 * drive.home_opening_m:.1f} mm, at most {1e3 * widest:.1f} mm with {1e3 * HOME_CLEARANCE_M:g} mm a side"
        )
    pads = {f"{side}_pad": geometry.strip_names(side) for side in PAD_SIDES}
    return MountedGripper(model, parts, geometry, pads, drive, open_ctrl)


def widest_object_m(home_opening_m: float) -> float:
    """The widest object a gripper whose pads open ``home_opening_m`` (m) takes, m: HOME_CLEARANCE_M
    left a side (the house's 90 mm takes 85 mm, ObjectConfig's widest), to the nanometre (so
    that 0.09 - 0.005 takes an object of 0.085)."""
    return round(home_opening_m - 2.0 * HOME_CLEARANCE_M, 9)


def _gripper_joints(model: mujoco.MjModel) -> list[int]:
    """The gripper file's joints: hinges and slides on its bodies (its fingers' and linkages')."""
    on_gripper = [j for j in range(model.njnt) if model.body(int(model.jnt_bodyid[j])).name.startswith(PREFIX)]
    return [j for j in on_gripper if int(model.jnt_type[j]) in _ONE_DOF]


def _set_gains(model: mujoco.MjModel, actuator: int, kp: float, kv: float) -> None:
    """Make ``actuator`` a position servo of stiffness ``kp`` and damping ``kv`` (its units)."""
    model.actuator_gaintype[actuator] = mujoco.mjtGain.mjGAIN_FIXED
    model.actuator_biastype[actuator] = mujoco.mjtBias.mjBIAS_AFFINE
    model.actuator_gainprm[actuator, 0] = kp
    model.actuator_biasprm[actuator, :3] = [0.0, -kp, -kv]


def _motor_gains(model: mujoco.MjModel, parts: GripperParts, actuators: list[int], joints: list[int], path: DrivePath) -> None:
    """Make each motor of the drive a position servo, in ``model``, as the house's finger servo
    is designed (models/gripper.xml): stiff enough on the opening to reach the drive's rated grip
    HOUSE_SERVO_TRAVEL_M = 10 mm inside the object (K_o = rating / 10 mm = sum_a kp_a (dl_a/do)^2,
    the motors' equal shares of what the servos the file has leave), and with the joints'
    damping critically damping the free fingers (C_o = 2 sqrt(K_o m_o), m_o their mass on the
    opening; the most any point of the path needs)."""
    slopes = path.slopes()
    motors = [i for i, a in enumerate(parts.actuators) if a.kind == "motor"]
    rating = float((np.array([a.force_max for a in parts.actuators])[:, None] * np.abs(slopes)).sum(axis=0).min())
    others = [i for i in range(len(actuators)) if i not in motors]
    own = float(np.median(sum((-model.actuator_biasprm[actuators[i], 1] * slopes[i] ** 2 for i in others), np.zeros(slopes.shape[1]))))
    share = max(rating / HOUSE_SERVO_TRAVEL_M - own, 0.0) / len(motors)
    kp = {i: share / float(np.median(slopes[i] ** 2)) for i in motors}
    dofs = [int(model.jnt_dofadr[j]) for j in joints]
    speeds = path.joint_rates()  # joint speed per opening speed, (points, joints)
    kv = dict.fromkeys(motors, 0.0)
    for k, mass_o in zip(MASS_POINTS, opening_inertia_kg(model, path, joints)[0], strict=True):
        stiffness = sum(-model.actuator_biasprm[actuators[i], 1] * slopes[i, k] ** 2 for i in others) + sum(
            kp[i] * slopes[i, k] ** 2 for i in motors
        )
        damped = model.dof_damping[dofs] @ speeds[k] ** 2 + sum(
            -model.actuator_biasprm[actuators[i], 2] * slopes[i, k] ** 2 for i in others
        )
        lacking = max(2.0 * math.sqrt(stiffness * mass_o) - damped, 0.0)
        for i in motors:
            kv[i] = max(kv[i], lacking / (len(motors) * max(slopes[i, k] ** 2, 1e-12)))
    for i in motors:
        _set_gains(model, actuators[i], kp[i], kv[i])

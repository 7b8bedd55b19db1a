"""A gripper file's parts: the fingertips and actuators a configuration names, checked on the
file alone (:func:`gripper_parts`, :func:`check_gripper`), its reference pose and what each
actuator can be as a drive (:func:`_drive_kind`).  The second of a mount's jobs
(:mod:`cosim.gripper_mount`)."""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from piezotip.cosim.config import GripperConfig
from piezotip.sensor.gel import GelParams

from .gripper_file import _file_key, load_gripper_spec
from .pad_geometry import PadGeometry
from .pad_model import PadPlacement
from .pad_placement import fingertip_pads

#: The joints a gripper's fingers move on (one coordinate each).
_ONE_DOF = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))

# ---------------------------------------------------------------------------------------
# Its parts: what the configuration names, checked on the file alone.
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Actuator:
    """One finger actuator of the file, as the drive commands it.

    Attributes
    ----------
    name : its name in the file.
    kind : ``position`` (a servo: MuJoCo's position, or a general actuator with an affine bias
        that holds a length) or ``motor`` (made a servo by the mount: :func:`_motor_gains`).
    joints : the joints it moves (ids in the file's model).
    force_max : its rating: the most force it closes with, its units (N, or N m on a hinge).
    ctrl_range : the commands it takes (the servo's; a motor's, once a servo: its lengths).
    length_per_ctrl : the actuator length a unit of command holds (1 for MuJoCo's position;
        a servo's gains are the file's, in the model).
    length_offset : the length a command of 0 holds (a servo's bias biasprm[0] over its kp; 0 for
        MuJoCo's position): a command c holds ``length_offset + length_per_ctrl c``.
    """

    name: str
    kind: str
    joints: tuple[int, ...]
    force_max: float
    ctrl_range: tuple[float, float]
    length_per_ctrl: float
    length_offset: float = 0.0


@dataclass(frozen=True)
class GripperParts:
    """A gripper file's parts that the configuration names, checked.

    Attributes
    ----------
    path : the file.
    top_body : the body mounted on the lift's palm: the top of the rigid chain that holds both
        fingertips (:func:`_mounted_body`), the file's top body unless an arm or a base moves it.
    branches : per fingertip, the body under the fingertips' common root that holds it: the
        finger, whose contacts with the object are its push (the referee's).
    untouched : per fingertip, the gripper's bodies its pad never touches: all but the other
        finger's (the pad sits on them, or they are the palm's and the linkages').
    pads : per fingertip, (source, the pad's body, its placement there, its geometry) as
        :func:`cosim.attach.fingertip_pads` gives them.
    actuators : the finger actuators.
    overlapping : pairs of the gripper's bodies in contact in the file's reference pose: a
        mechanism's links modelled as solids through each other (a linkage's bars), whose
        contacts the scene leaves out, as robot set-up tools leave out link pairs colliding in
        the default pose (MoveIt's setup assistant); the fingers never among them.
    closing_axis : unit vector from the first fingertip's pad to the second's, in the frame
        ``top_body`` hangs in (its parent's: the file's own for a top body of the file).
    approach_axis : unit vector of the approach, normal to ``closing_axis``, in that frame
        (``gripper.approach_axis`` is given in the file's).
    pad_centre_m : the middle between the pads' surfaces in the file's reference pose, m, in that frame.
    """

    path: str
    top_body: str
    branches: tuple[str, str]
    untouched: tuple[tuple[str, ...], tuple[str, ...]]
    pads: tuple[tuple[str, str, PadPlacement, PadGeometry], ...]
    actuators: tuple[_Actuator, ...]
    overlapping: tuple[tuple[str, str], ...]
    closing_axis: tuple[float, float, float]
    approach_axis: tuple[float, float, float]
    pad_centre_m: tuple[float, float, float]

    def geometry(self, segments: int) -> PadGeometry:
        """The pad both fingertips carry: the smaller face's, ``segments`` strips per element."""
        length = float(min(p[3].pad_length_m for p in self.pads))
        width = float(min(p[3].pad_width_m for p in self.pads))
        return dataclasses.replace(self.pads[0][3], segments=segments, pad_length_m=length, pad_width_m=width)


def check_gripper(config: GripperConfig) -> None:
    """Check that ``config``'s file loads and has what it names (:func:`gripper_parts`): a
    ValueError naming the key otherwise."""
    if config.mjcf is not None:
        gripper_parts(config)


def gripper_parts(config: GripperConfig) -> GripperParts:
    """The parts of ``config``'s gripper file, checked (cached by the file's path, time and size)."""
    axis = None if config.approach_axis is None else tuple(float(v) for v in config.approach_axis)
    return _parts(_file_key(config.mjcf), config.mjcf, tuple(config.fingertips), tuple(config.actuators), axis)


@functools.lru_cache(maxsize=32)
def _parts(key: tuple, given: str, fingertips: tuple[str, ...], actuators: tuple[str, ...], approach: tuple | None) -> GripperParts:
    spec = load_gripper_spec(given)
    try:
        model = spec.compile()
    except Exception as err:
        raise ValueError(f"gripper.mjcf {given!r} does not compile: {err}") from None
    try:
        pads = fingertip_pads(model, fingertips, 1, GelParams().thickness_m)
    except ValueError as err:
        raise ValueError(f"gripper.fingertips: {str(err).removeprefix('attach: ')} (gripper.mjcf {given!r})") from None
    bodies = [model.body(p[1]).id for p in pads]
    if bodies[0] == bodies[1]:
        raise ValueError(f"gripper.fingertips {list(fingertips)!r} are both on body {pads[0][1]!r}: one fingertip a finger")
    paths = [_path_from_world(model, b) for b in bodies]
    if paths[0][0] != paths[1][0]:
        raise ValueError(f"gripper.fingertips {list(fingertips)!r} hang from two top bodies of {given!r}: a gripper is one body tree")
    common = [a for a, b in zip(paths[0], paths[1], strict=False) if a == b]
    for i in range(2):
        if len(paths[i]) == len(common):
            # A fixed jaw: one fingertip on a body that carries the other's finger (robosuite's
            # Spot gripper, bd_gripper.xml, its jaw on the stator that carries the hinged mover).
            # The mount centres the object between the open pads and closes both onto it;
            # a fixed jaw's grasp must instead be placed beside the object by its width.
            raise ValueError(
                f"gripper.fingertips {list(fingertips)!r}: {fingertips[i]!r} is on body {model.body(bodies[i]).name!r}, which "
                f"carries the other fingertip's body {model.body(bodies[1 - i]).name!r}: a fixed jaw, which the mount does not "
                f"take (it centres the object between two fingers that each close on it from their own branch of the gripper; "
                f"gripper.mjcf {given!r})"
            )
    branches = tuple(model.body(p[len(common)]).name for p in paths)
    top = _mounted_body(model, common)
    tree = _subtree(model, top)
    _refuse_free_joints(model, tree, given)
    fingers = [_subtree(model, model.body(b).id) for b in branches]
    untouched = tuple(tuple(sorted(model.body(b).name for b in tree - fingers[1 - i])) for i in range(2))
    found = tuple(_actuator(model, name, tree, given) for name in actuators)
    moved = {b for p in paths for b in p}
    # Without equality constraints a joint moves a fingertip only from the fingertip's own chain;
    # with them (a closed linkage: Robotiq's four-bar, driven on the branch beside the fingertip's)
    # whether it does is measured on the free closing (GripperDrive: "do not open or close").
    for actuator in found:
        if model.neq == 0 and not any(int(model.jnt_bodyid[j]) in moved for j in actuator.joints):
            raise ValueError(
                f"gripper.actuators: {actuator.name!r} moves no joint between the gripper's top body and a fingertip "
                f"(gripper.mjcf {given!r})"
            )
    data = mujoco.MjData(model)
    data.qpos[:] = reference_qpos(model)
    mujoco.mj_forward(model, data)
    overlapping = _overlapping(model, data, tree, fingers)
    surfaces, normals = zip(*(_pad_frame(data, b, p[2]) for b, p in zip(bodies, pads, strict=True)), strict=True)
    closing = normals[0] - normals[1]
    closing /= np.linalg.norm(closing)
    centre = 0.5 * (surfaces[0] + surfaces[1])
    if approach is None:
        root = common[-1]
        towards, what = centre - data.xpos[root], f"from body {model.body(root).name!r} to the fingertips"
    else:
        towards, what = np.asarray(approach, float), f"gripper.approach_axis {list(approach)!r}"
    towards = towards - closing * (towards @ closing)
    if not np.linalg.norm(towards) > 1e-6 * max(1.0, np.linalg.norm(centre)):
        raise ValueError(f"{what} lies along the line between the fingertips: give gripper.approach_axis (gripper.mjcf {given!r})")
    parent = int(model.body_parentid[top])
    if parent != 0:
        # The mounted body's pose in the file is its parent's frame's (MuJoCo's body pos and quat),
        # and the mount hangs it from the palm by that: its axes and pads' centre go there too.
        to_parent = data.xmat[parent].reshape(3, 3).T
        closing, towards, centre = to_parent @ closing, to_parent @ towards, to_parent @ (centre - data.xpos[parent])
    return GripperParts(
        given,
        model.body(top).name,
        branches,
        untouched,
        tuple(pads),
        found,
        overlapping,
        tuple(closing.tolist()),
        tuple((towards / np.linalg.norm(towards)).tolist()),
        tuple(centre.tolist()),
    )


def reference_qpos(model: mujoco.MjModel) -> np.ndarray:
    """The file's reference pose as a pose the gripper can take: ``qpos0`` with every limited
    hinge and slide clamped into its range (the first step of :func:`cosim.attach.open_pose_qpos`).

    The mount reads the gripper's frames (:class:`GripperParts`: the closing and approach axes,
    the pads' centre) and the links modelled through each other in this pose, not in the open
    one: MuJoCo places no pose by solving the file's equality constraints, so a linkage's loops
    are closed only where its author assembled it, at ``qpos0``.  A file whose ``qpos0`` lies
    outside its joints' ranges has no such pose there: its joints come to their nearest ends
    (tests/test_gripper_natural_pose.py::
    test_fingers_whose_qpos0_is_outside_their_range_mount_in_it_and_grasp_the_box)."""
    qpos = model.qpos0.copy()
    for joint in range(model.njnt):
        if model.jnt_limited[joint] and int(model.jnt_type[joint]) in _ONE_DOF:
            adr = int(model.jnt_qposadr[joint])
            qpos[adr] = np.clip(qpos[adr], *model.jnt_range[joint])
    return qpos


def _refuse_free_joints(model: mujoco.MjModel, tree: set[int], given: str) -> None:
    """Raise ValueError naming the file, the body and the joint when a body of the mounted
    ``tree`` moves on a free joint (``<freejoint>``, ``<joint type="free">``): the mounted gripper
    hangs from the lift's palm, where MuJoCo takes no free joint (a file's top body may have one
    when it is a model alone, a floating hand).  Named, not dropped: a file that floats its hand
    is the user's to change (an arm's joints above the gripper, which the mount does drop, are the
    palm's stand-in's: :func:`_mounted_body`)."""
    for j in range(model.njnt):
        body = int(model.jnt_bodyid[j])
        if body in tree and int(model.jnt_type[j]) == mujoco.mjtJoint.mjJNT_FREE:
            joint = f"the free joint {model.joint(j).name!r}" if model.joint(j).name else "a free joint"
            raise ValueError(
                f"gripper.mjcf {given!r}: body {model.body(body).name!r} has {joint} (<freejoint>); the gripper is mounted "
                "on the lift's palm, which moves it: remove the free joint"
            )


def _overlapping(model: mujoco.MjModel, data: mujoco.MjData, tree: set[int], fingers: list[set[int]]) -> tuple:
    """The gripper's body pairs in contact in the reference pose (``data``), by name, sorted; not
    the two fingers' (a gripper closed on itself)."""
    pairs = set()
    for c in data.contact[: data.ncon]:
        a, b = sorted((int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])))
        across = (a in fingers[0] and b in fingers[1]) or (a in fingers[1] and b in fingers[0])
        if a in tree and b in tree and not across:  # fingers closed on each other still touch
            pairs.add((model.body(a).name, model.body(b).name))
    return tuple(sorted(pairs))


def _mounted_body(model: mujoco.MjModel, common: list[int]) -> int:
    """The body the mount hangs from the lift's palm, given ``common``, the bodies from the
    world's child down to the fingertips' lowest common one: the highest of them that reaches
    that one through no joint.  A gripper file's top body (robosuite's, dm_robotics' and
    Menagerie's grippers: nothing moves them); where the fingertips hang from an arm or a
    mobile base in the file (Gymnasium-Robotics' Fetch, ``fetch/pick_and_place.xml``: three
    slides under the base, seven joints in the arm), the gripper under its last joint, the palm
    standing in for what carried it: mounted whole, the file's base moved on its own joints
    under a palm with nothing fixed to it (MuJoCo refuses such a body: no mass).  Where the
    common body itself moves on a joint (the Franka kitchen's link 7, the arm's last joint
    carrying both fingers), that body, its joints left with the arm (the mount deletes them)."""
    top = len(common) - 1
    while top > 0 and not any(model.body_jntnum[b] for b in common[top:]):
        top -= 1
    if model.body_jntnum[common[top]] and top < len(common) - 1:
        top += 1
    return common[top]


def _path_from_world(model: mujoco.MjModel, body: int) -> list[int]:
    """The bodies from the world's child down to ``body``."""
    path = []
    while body != 0:
        path.append(body)
        body = int(model.body_parentid[body])
    return path[::-1]


def _subtree(model: mujoco.MjModel, body: int) -> set[int]:
    return {b for b in range(model.nbody) if body in _path_from_world(model, b)}


def _pad_frame(data: mujoco.MjData, body: int, placement: PadPlacement) -> tuple[np.ndarray, np.ndarray]:
    """The pad's unloaded surface centre and its normal out of the pad (towards what it touches), world."""
    rotation = data.xmat[body].reshape(3, 3)
    frame = np.zeros(9)
    mujoco.mju_quat2Mat(frame, np.asarray(placement.quat, float))
    return data.xpos[body] + rotation @ np.asarray(placement.pos_m), rotation @ frame.reshape(3, 3)[:, 0]


def _actuator(model: mujoco.MjModel, name: str, tree: set[int], given: str) -> _Actuator:
    """The finger actuator ``name`` of the file's model, checked: a position servo or a motor on
    joints (or a tendon of joints) of the gripper, with its rating."""
    where = f"(gripper.mjcf {given!r})"
    try:
        a = model.actuator(name).id
    except KeyError:
        names = ", ".join(model.actuator(i).name for i in range(model.nu)) or "none"
        raise ValueError(f"gripper.actuators: {name!r} is not an actuator of the file (its actuators: {names}) {where}") from None
    trn, target = model.actuator_trntype[a], int(model.actuator_trnid[a, 0])
    if trn == mujoco.mjtTrn.mjTRN_JOINT:
        joints = (target,)
    elif trn == mujoco.mjtTrn.mjTRN_TENDON and model.tendon_num[target] > 0:
        first = model.tendon_adr[target]
        wraps = range(first, first + model.tendon_num[target])
        if any(model.wrap_type[w] != mujoco.mjtWrap.mjWRAP_JOINT for w in wraps):
            raise ValueError(f"gripper.actuators: {name!r} pulls a spatial tendon; a finger actuator drives joints {where}")
        joints = tuple(int(model.wrap_objid[w]) for w in wraps)
    else:
        kind = mujoco.mjtTrn(trn).name.removeprefix("mjTRN_").lower()
        raise ValueError(f"gripper.actuators: {name!r} acts through a {kind}; a finger actuator drives joints {where}")
    for j in joints:
        if int(model.jnt_bodyid[j]) not in tree:
            raise ValueError(f"gripper.actuators: {name!r} drives joint {model.joint(j).name!r}, not the gripper's {where}")
        if int(model.jnt_type[j]) not in _ONE_DOF:
            raise ValueError(f"gripper.actuators: {name!r} drives joint {model.joint(j).name!r}, neither a hinge nor a slide {where}")
    kind, reason = _drive_kind(model, a)
    if kind is None:
        raise ValueError(f"gripper.actuators: {name!r} cannot close the fingers: {reason} {where}")
    gain, bias = model.actuator_gainprm[a], model.actuator_biasprm[a]
    limited = bool(model.actuator_ctrllimited[a])
    if kind == "position":
        # force = g ctrl + b0 - kp l - kv l': a servo holding the length (g ctrl + b0) / kp
        # (MuJoCo's position: g = kp, b0 = 0; Menagerie's 0-255 servos: g = kp x stroke / 255).
        kp, scale, offset = float(-bias[1]), float(gain[0] / -bias[1]), float(bias[0] / -bias[1])
        ctrl = (
            tuple(float(c) for c in model.actuator_ctrlrange[a])
            if limited
            else tuple((r - offset) / scale for r in _length_range(model, a, joints))
        )
        reach = kp * scale * (ctrl[1] - ctrl[0])  # the most it commands: its whole range off target
    else:
        scale, offset = 1.0, 0.0
        ctrl = _length_range(model, a, joints)
        reach = float(abs(gain[0]) * min(-model.actuator_ctrlrange[a, 0], model.actuator_ctrlrange[a, 1])) if limited else 0.0
    if model.actuator_forcelimited[a]:
        force_max = float(min(-model.actuator_forcerange[a, 0], model.actuator_forcerange[a, 1]))
    else:
        force_max = reach
    if not (math.isfinite(force_max) and force_max > 0):
        unbounded = "a motor with neither a force range nor a command range that bounds its force both ways"
        why = unbounded if kind == "motor" and not limited else "its force range or command range leaves it no force to close with"
        raise ValueError(f"gripper.actuators: {name!r} cannot close the fingers: {why} (the grip's rating) {where}")
    return _Actuator(name, kind, joints, force_max, (min(ctrl), max(ctrl)), scale, offset)


#: Activation dynamics a drive can have: none, or a first-order filter of the command (at rest its
#: activation is the command, so a command still sets a length; the filter's lag is the servo's).
_DRIVE_DYNAMICS = (int(mujoco.mjtDyn.mjDYN_NONE), int(mujoco.mjtDyn.mjDYN_FILTER), int(mujoco.mjtDyn.mjDYN_FILTEREXACT))


def _drive_kind(model: mujoco.MjModel, a: int) -> tuple[str | None, str]:
    """Whether actuator ``a`` can be the drive, as (``position``, ``motor`` or None, why not).

    The drive commands an opening as the actuator lengths along the free closing and reads the
    grip from the actuator's force through the path's levers (:class:`GripperDrive`), so an
    actuator must have, at rest, a force ``g ctrl + b0 - kp l - kv l'`` with fixed g, kp and kv:

    - a position servo (kp > 0: it holds the length ``(g ctrl + b0) / kp``, g > 0 so that a
      larger command holds a longer length), or a motor (no bias: the mount makes it a servo);
    - its activation the command at rest: no dynamics, or a filter of the command (not an
      integrator, whose command is a speed, nor a muscle's or a user's);
    - a gain and a bias MuJoCo computes from those numbers alone: not a muscle's length-force
      curves, not a user callback, not a gain that changes with the length or the speed.
    """
    dyn, gaintype, biastype = int(model.actuator_dyntype[a]), int(model.actuator_gaintype[a]), int(model.actuator_biastype[a])
    gain, bias = model.actuator_gainprm[a], model.actuator_biasprm[a]
    if dyn not in _DRIVE_DYNAMICS:
        what = mujoco.mjtDyn(dyn).name.removeprefix("mjDYN_").lower()
        if dyn == mujoco.mjtDyn.mjDYN_INTEGRATOR:
            return None, "its command is its activation's rate (dyntype integrator), where the drive commands a length"
        return None, f"its activation follows dynamics of its own (dyntype {what}), where the drive commands a length"
    fixed = gaintype == mujoco.mjtGain.mjGAIN_FIXED or (gaintype == mujoco.mjtGain.mjGAIN_AFFINE and gain[1] == gain[2] == 0)
    if not fixed:
        what = mujoco.mjtGain(gaintype).name.removeprefix("mjGAIN_").lower()
        if gaintype == mujoco.mjtGain.mjGAIN_AFFINE:
            return None, "its gain changes with its length or speed (gaintype affine, gainprm[1:3]): no command holds one length"
        return None, f"its force comes from a {what} gain (gaintype {what}), which the drive cannot invert into a length"
    if not gain[0] > 0:
        return None, f"its gain gainprm[0] = {gain[0]:g} is not positive: its command pushes no way or the wrong way"
    if biastype == mujoco.mjtBias.mjBIAS_NONE:
        return "motor", ""
    if biastype != mujoco.mjtBias.mjBIAS_AFFINE:
        what = mujoco.mjtBias(biastype).name.removeprefix("mjBIAS_").lower()
        return None, f"its bias is a {what}'s (biastype {what}), which the drive cannot invert into a length"
    if bias[1] < 0:
        return "position", ""
    if bias[1] > 0:
        return None, f"its bias pushes away from its target (biasprm[1] = {bias[1]:g} > 0): there is no length it holds"
    if bias[2] != 0:
        return None, "it is a velocity servo (biasprm[2] without biasprm[1]): it holds a speed, not a length"
    if bias[0] != 0:
        return None, f"its bias is a constant force (biasprm[0] = {bias[0]:g}) with no servo to hold a length"
    return "motor", ""


def _length_range(model: mujoco.MjModel, a: int, joints: tuple[int, ...]) -> tuple[float, float]:
    """The lengths the actuator can take, its units: its joint's range times its gear, or its
    tendon's range."""
    if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_TENDON and model.tendon_limited[model.actuator_trnid[a, 0]]:
        low, high = model.tendon_range[model.actuator_trnid[a, 0]]
        return float(low), float(high)
    if len(joints) == 1 and model.jnt_limited[joints[0]]:
        ends = sorted(float(model.actuator_gear[a, 0] * r) for r in model.jnt_range[joints[0]])
        return ends[0], ends[1]
    raise ValueError(f"gripper.actuators: {model.actuator(a).name!r} has neither a command range nor a limited joint to command")

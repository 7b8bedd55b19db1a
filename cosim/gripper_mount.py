"""A gripper nobody here wrote, on the lift: its MJCF file, two fingertips and the actuators that close it.

``run grasp --set gripper.mjcf=PATH --set "gripper.fingertips=['a', 'b']" --set "gripper.actuators=['m']"``
(scenario keys: :class:`~scenarios.config.GripperConfig`; docs/grippers.md) grasps with that
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
3. The file's top body holding both fingertips hangs from the palm, turned so that its approach
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
An actuator that cannot be either is refused with the reason (:func:`_drive_kind`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from piezotip.scenarios.config import GripperConfig, ScenarioConfig
from piezotip.sensor.gel import GelParams

from .attach import fingertip_pads, open_pose_qpos
from .control.interface import RobotLimits
from .pad_geometry import PAD_SIDES, PadGeometry
from .pad_model import PadPlacement, add_pad_strips, apply_pad_contact, build_model, resolve_pad_contact
from .scene import (
    _INTEGRATORS,
    PAD_CENTRE_AT_ZERO_LIFT_M,
    SCENE_FILE,
    TABLE_CLEARANCE_M,
    _edit_object,
    object_shape,
    robot_limits,
)

__all__ = ["PREFIX", "GripperDrive", "GripperFileWarning", "MountedGripper", "check_gripper", "load_gripper_spec", "mount_gripper"]

PREFIX = "gripper/"
"""What the names of the gripper file's parts start with in the scene (``gripper/finger_joint1``)."""

#: The pads' centre below the palm's origin, m: the house gripper's (palm at 0.35 m, pads at 0.28 m
#: at lift 0), so a mounted gripper's lift has the house's range and home.
PADS_BELOW_PALM_M = 0.35 - PAD_CENTRE_AT_ZERO_LIFT_M
#: Room left on each side of the object between it and the open pads, m: the house's home opening
#: (90 mm) leaves its widest object (85 mm, ObjectConfig) 2.5 mm a side.
HOME_CLEARANCE_M = 0.0025
#: The free closing's sweep (:func:`_free_closing`): first the actuators hold the open command
#: this long (the fingers reach it from the file's reference pose), s ...
SETTLE_S = 0.5
#: ... then their commands ramp from open to closed over this long, s: a gripper's whole stroke
#: in a second (the house gripper's fingers move at 0.05-0.15 m/s), slow enough that the
#: passive joints of a linkage follow as they do at rest.
STROKE_S = 1.0
#: Points of the drive's path tables (its opening grid).
PATH_POINTS = 201
#: The degree of the polynomials in the opening fitted to the sweep's actuator lengths and joint
#: positions: a linkage's are smooth over its stroke (a parallel gripper's linear), and a fit
#: averages out the fingers' ringing about them, which a table of samples would keep.
PATH_FIT_DEGREE = 5
#: A motor made a position servo (_motor_gains) is as stiff per rated grip as the house's
#: finger servo: kp 1e4 N/m for its 100 N, the rating 10 mm inside the object (models/gripper.xml).
HOUSE_SERVO_TRAVEL_M = 0.01

#: The house gripper's parts in models/gripper.xml that a mounted gripper replaces, besides the
#: palm's geoms and finger bodies ...
_HOUSE_PARTS = {"actuator": ("fingers_actuator",), "tendon": ("fingers_tendon",), "equality": ("fingers_coupling",)}
#: ... and the sensors it keeps: the lift's, and the referee's (the object-contact ones re-aimed
#: at the mounted fingers); the others are the house fingers'.
_KEPT_SENSORS = ("lift_pos", "lift_force", "object_table_contact", "left_object_contact", "right_object_contact")
#: The joints a gripper's fingers move on (one coordinate each).
_ONE_DOF = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


class GripperFileWarning(UserWarning):
    """A gripper file read otherwise than MuJoCo would read it alone (:func:`load_gripper_spec`)."""


# ---------------------------------------------------------------------------------------
# The file.
# ---------------------------------------------------------------------------------------


def load_gripper_spec(path: str | Path, warn: bool = True) -> mujoco.MjSpec:
    r"""The gripper file as an MjSpec, read as a part of the scene (a fresh spec each call).

    Rules for a file written as a part of a larger model (robosuite's grippers are merged into a
    world whose ``<compiler angle="radian">`` they rely on, by a merge that passes any XML):

    - a file that sets no ``<compiler angle>`` is read in the scene's unit, radians
      (models/gripper.xml's), as a file ``<include>``\ d in the scene would be; MuJoCo reads a
      file alone in degrees, which would shrink a joint range of 0.8 rad to 0.8 degrees;
    - an asset (mesh, texture, material, ...) named twice keeps its first definition, as
      robosuite's merge keeps it; MuJoCo refuses the second;
    - an attribute this MuJoCo does not know (robosuite's xarm7_gripper.xml puts ``group`` on a
      ``<default>``) is left out; MuJoCo refuses the file.

    Each repair comes with a :class:`GripperFileWarning` naming it (with ``warn``).

    Raises
    ------
    ValueError
        naming ``gripper.mjcf`` and the file: missing, not XML, or refused by MuJoCo.
    """
    text, repairs, has_angle, directory, includes = _read_file(*_file_key(path))
    for repair in repairs if warn else ():
        warnings.warn(f"gripper.mjcf {str(path)!r}: {repair}", GripperFileWarning, 2)
    spec = mujoco.MjSpec.from_string(text, include=dict(includes))
    spec.modelfiledir = directory
    if not has_angle:
        spec.compiler.degree = False
    return spec


def _file_key(path: str | Path) -> tuple[str, int, int]:
    """(resolved path, modification time, size): what the file's readings are cached by."""
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"gripper.mjcf: no file {str(path)!r}")
    stat = file.stat()
    return str(file.resolve()), stat.st_mtime_ns, stat.st_size


#: MuJoCo's words for an attribute it does not know: the attribute, the element and its line.
_UNKNOWN_ATTRIBUTE = re.compile(r"unrecognized attribute: '([^']+)'\s*Element '([^']+)', line (\d+)")
#: The most repairs a file gets before it counts as no MJCF at all.
_MAX_REPAIRS = 32


#: The most ``<include>`` files a gripper file may bring in (nested ones counted), a guard.
_MAX_INCLUDES = 64


def _included_files(path: str, root: ET.Element) -> dict[str, bytes]:
    """The files ``<include file=...>`` elements of the file at ``path`` (parsed: ``root``) bring
    in, nested ones too, read as MuJoCo reads them when it loads that file: from the including
    file's folder, else the gripper file's (a string parsed elsewhere would look in the working
    folder: the wrong file, or none).  Keyed by the name as written (MuJoCo looks a nested name
    up either way).  A ValueError names the gripper file and the include that cannot be read."""
    top = Path(path).parent
    found: dict[str, bytes] = {}
    pending = [(root, top)]
    while pending:
        element_root, folder = pending.pop()
        for element in element_root.iter("include"):
            name = element.get("file")
            if name is None or name in found:
                continue
            if len(found) >= _MAX_INCLUDES:
                raise ValueError(f"gripper.mjcf {path!r} includes more than {_MAX_INCLUDES} files")
            candidates = [folder / name, top / name] if folder != top else [top / name]
            file = next((c for c in candidates if c.is_file()), candidates[0])
            try:
                found[name] = file.read_bytes()
                pending.append((ET.fromstring(found[name]), file.parent))
            except (OSError, ET.ParseError) as err:
                raise ValueError(f"gripper.mjcf {path!r}: its <include file={name!r}> (in {str(folder)!r}) cannot be read: {err}") from None
    return found


@functools.lru_cache(maxsize=32)
def _read_file(path: str, mtime_ns: int, size: int) -> tuple[str, tuple[str, ...], bool, str, tuple[tuple[str, bytes], ...]]:
    """The file's text as MuJoCo takes it (load_gripper_spec's repairs made), the repairs, whether
    it sets its compiler's angle unit, its directory, and the files it includes (name, contents;
    read from its directory: :func:`_included_files`)."""
    try:
        text = Path(path).read_text()
        root = ET.fromstring(text)
    except (ET.ParseError, OSError, UnicodeDecodeError) as err:
        raise ValueError(f"gripper.mjcf {path!r} is no XML file: {err}") from None
    includes = _included_files(path, root)
    repairs: list[str] = []
    for _ in range(_MAX_REPAIRS):
        try:
            mujoco.MjSpec.from_string(text, include=includes)  # parsed only: its meshes are read when compiled
            break
        except Exception as err:  # MuJoCo raises ValueError; name the file whatever it raises
            message = str(err)
            unknown = _UNKNOWN_ATTRIBUTE.search(message)
            if unknown is not None and (fixed := _without_attribute(text, *unknown.groups())) is not None:
                text = fixed
                attribute, element, line = unknown.groups()
                repairs.append(
                    f"attribute {attribute!r} of <{element}> on line {line} left out (MuJoCo {mujoco.__version__} does not know it)"
                )
            elif "repeated name" in message and not any("defined twice" in r for r in repairs):
                text, repeated = _first_assets(text)
                repairs += [f"{what} is defined twice: the first kept (robosuite's rule)" for what in repeated]
                if not repeated:
                    raise ValueError(f"gripper.mjcf {path!r} does not load: {err}") from None
            else:
                raise ValueError(f"gripper.mjcf {path!r} does not load: {err}") from None
    else:
        raise ValueError(f"gripper.mjcf {path!r} does not load: more than {_MAX_REPAIRS} attributes MuJoCo does not know")
    roots = [root, *(ET.fromstring(contents) for contents in includes.values())]
    has_angle = any(c.get("angle") is not None for r in roots for c in r.iter("compiler"))
    return text, tuple(repairs), has_angle, str(Path(path).parent), tuple(includes.items())


def _without_attribute(text: str, attribute: str, element: str, line: str) -> str | None:
    """``text`` without ``attribute`` on line ``line`` (1-based) of an ``element`` tag, or None."""
    lines = text.splitlines(keepends=True)
    index = int(line) - 1
    if not 0 <= index < len(lines) or f"<{element}" not in lines[index]:
        return None
    fixed = re.sub(rf"\s{re.escape(attribute)}\s*=\s*(\"[^\"]*\"|'[^']*')", "", lines[index], count=1)
    if fixed == lines[index]:
        return None
    return "".join([*lines[:index], fixed, *lines[index + 1 :]])


def _first_assets(text: str) -> tuple[str, list[str]]:
    """``text`` with each asset named twice kept once (its first definition), and which."""
    root = ET.fromstring(text)
    repeated = []
    for assets in root.iter("asset"):
        seen = set()
        for element in list(assets):
            key = (element.tag, element.get("name"))
            if key[1] is not None and key in seen:
                assets.remove(element)
                repeated.append(f"{key[0]} {key[1]!r}")
            seen.add(key)
    return ET.tostring(root, encoding="unicode"), repeated


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
    top_body : the file's top body that holds both fingertips (what is mounted).
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
    closing_axis : unit vector from the first fingertip's pad to the second's, in the file's frame.
    approach_axis : unit vector of the approach, normal to ``closing_axis``, in the file's frame.
    pad_centre_m : the middle between the pads' surfaces in the file's reference pose, m.
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
    branches = tuple(model.body(p[len(common)]).name for p in paths)
    tree = _subtree(model, paths[0][0])
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
    return GripperParts(
        given,
        model.body(paths[0][0]).name,
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
    outside its joints' ranges (the ALOHA gripper's fingers at 0 on rails of 21-57 mm) has no
    such pose there: its joints come to their nearest ends."""
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
    when it is a model alone, a floating hand); left in, it fails the scene's compile, which names
    the scene file, not the gripper's."""
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
        sensor = spec.sensor(f"{side}_object_contact")
        touch[side] = {k: getattr(sensor, k) for k in ("type", "objtype", "reftype", "refname")} | {"intprm": list(sensor.intprm)}
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
        pos, quat = _mount_pose(parts)
        frame = spec.body("palm").add_frame(pos=pos.tolist(), quat=quat.tolist())
        frame.attach_body(gripper.body(parts.top_body), PREFIX, "")
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
            spec.add_sensor(name=f"{side}_object_contact", objname=PREFIX + branch, **touch[side])

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
# The drive.
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DrivePath:
    """The fingers' free closing on the mounted model (contacts off), on an opening grid.

    Attributes
    ----------
    opening_m : the opening between the unloaded pads' surfaces, m, increasing (PATH_POINTS).
    lengths : each actuator's length there, its units (m, or rad for a hinge), shape (actuators, points).
    qpos : the gripper's joints' positions there, shape (points, joints) (:attr:`GripperDrive.joint_qpos`).
    lowest_m : how far the gripper (pads included) reaches below the pads' centre at home while
        it closes from open down to there, m (the most over that part of the path).
    palm_above_m : how far above the pads' centre the rest of the gripper (what the fingers hang
        from) reaches down to, at home, m (inf: nothing).
    centre_rise_m : how far the pads' centre lies above its home height there, m (0 for fingers
        that slide; a linkage's fingertips swing along an arc: Robotiq's drop 9 mm from open to
        a 44 mm grip).
    static_force : the force each actuator needs to hold the free fingers there (their springs;
        :func:`_static_force`), its units, shape (actuators, points): the drive's no-load
        profile, which its grip reading leaves out (a linkage's springs are no grip).
    """

    opening_m: np.ndarray
    lengths: np.ndarray
    qpos: np.ndarray
    lowest_m: np.ndarray
    static_force: np.ndarray
    palm_above_m: float
    centre_rise_m: np.ndarray

    def slopes(self) -> np.ndarray:
        """d length / d opening of each actuator along the path, shape (actuators, points)."""
        return np.gradient(self.lengths, self.opening_m, axis=1)

    def joint_rates(self) -> np.ndarray:
        """d q / d opening of each joint along the path (its speed per opening speed), shape
        (points, joints)."""
        return np.gradient(self.qpos, self.opening_m, axis=0)


class GripperDrive:
    """The mounted gripper's finger drive, as the loop commands and reads it.

    The controller speaks of an opening (m) and a grip (N per finger); the file's actuators of
    their own lengths and forces.  Along the free closing path (:class:`DrivePath`) the
    actuators' virtual work on the fingers is the grip's on the opening: a grip G and the
    actuator forces f_a make G = -sum_a f_a dl_a/do (each actuator's share equal), and an
    opening command is the path's actuator lengths there.

    The grip the drive reads is its actuators' forces less what the free fingers take there
    (:attr:`DrivePath.static_force`, and their joints' damping at the speed they move: a
    linkage's changes along its stroke), as a gripper's force estimate leaves out its own
    no-load current: free fingers read their friction alone, as the house gripper's read their
    damping alone, constant at a constant pace.

    Attributes
    ----------
    actuators : the finger actuators' ids in the scene model.
    force_max : their ratings, in their units.
    path : the free closing (:class:`DrivePath`).
    joint_qpos : the qpos addresses of the gripper's joints (the path's ``qpos`` columns).
    home_opening_m : the opening with the actuators commanded open, m.
    joint_damping_n_s_m : the joints' damping on the opening along the path, N s/m:
        sum_d b_d (dq_d/do)^2.
    servo_damping_n_s_m : the servos' velocity gains on the opening along the path, N s/m:
        sum_a kv_a (dl_a/do)^2 (inside the servo: it lags, its force does not show it).
    friction_n : the joints' dry friction on the opening along the path, N: sum_d F_d |dq_d/do|.
    mass_kg : the fingers' inertia on the opening at :data:`MASS_POINTS` of the path, kg
        (:func:`opening_inertia_kg`).
    lift_coupling_kg : the fingers' inertia coupling the lift to the opening there, kg
        (:func:`opening_inertia_kg`).
    """

    def __init__(self, model: mujoco.MjModel, parts: GripperParts, path: DrivePath, joints: list[int], kv: np.ndarray) -> None:
        self.actuators = [model.actuator(PREFIX + a.name).id for a in parts.actuators]
        self.force_max = np.array([a.force_max for a in parts.actuators])
        self.ctrl_range = np.array([a.ctrl_range for a in parts.actuators])
        self._ctrl_per_length = [1.0 / a.length_per_ctrl for a in parts.actuators]
        self._length_offset = [a.length_offset for a in parts.actuators]
        self.path = path
        self.joint_qpos = [int(model.jnt_qposadr[j]) for j in joints]
        self._sites = [model.site(f"{side}_pad_surface").id for side in PAD_SIDES]
        self._grid = path.opening_m
        self._slopes = path.slopes()
        self.home_opening_m = float(path.opening_m[-1])
        idle = [a.name for a, row in zip(parts.actuators, self._slopes, strict=True) if not np.abs(row).max() > 0]
        if idle:
            raise ValueError(f"gripper.actuators: {idle!r} do not open or close the fingertips (gripper.mjcf {parts.path!r})")
        speeds = path.joint_rates()  # joint speed per opening speed, (points, joints)
        dofs = [int(model.jnt_dofadr[j]) for j in joints]
        self.joint_damping_n_s_m = speeds**2 @ model.dof_damping[dofs]
        self.servo_damping_n_s_m = (np.asarray(kv)[:, None] * self._slopes**2).sum(axis=0)
        self.friction_n = np.abs(speeds) @ model.dof_frictionloss[dofs]
        self.mass_kg, self.lift_coupling_kg = opening_inertia_kg(model, path, joints)

    def ctrl_for(self, opening_m: float) -> list[float]:
        """The actuators' commands for an opening target, m: those that hold the path's lengths
        there (a target past the path's ends commands its end), within their ranges."""
        lengths = [float(np.interp(opening_m, self._grid, row)) for row in self.path.lengths]
        commands = [(v - o) * c for v, o, c in zip(lengths, self._length_offset, self._ctrl_per_length, strict=True)]
        return [min(max(v, lo), hi) for v, (lo, hi) in zip(commands, self.ctrl_range, strict=True)]

    def opening_m(self, data: mujoco.MjData) -> float:
        """The opening between the unloaded pads' surfaces, m (their sites' world x: the mount
        closes the fingers along x), as the last physics step's kinematics had it."""
        left, right = self._sites
        return float(data.site_xpos[right, 0] - data.site_xpos[left, 0])

    def _at(self, table: np.ndarray, opening_m: float) -> np.ndarray:
        return np.array([np.interp(opening_m, self._grid, row) for row in table])

    def grip_force_n(self, data: mujoco.MjData) -> float:
        """The squeeze of each finger by the drive, N (positive squeezes), from the actuators'
        forces less the free fingers' need (the class docstring): the robot's own sensing, as
        the house's fingers_actuator force."""
        opening = self.opening_m(data)
        slopes = self._at(self._slopes, opening)
        forces = data.actuator_force[self.actuators] - self._at(self.path.static_force, opening)
        moving = np.abs(slopes) > 0
        speed = float(np.mean(data.actuator_velocity[self.actuators][moving] / slopes[moving]))  # d opening / dt
        damping = float(np.interp(opening, self._grid, self.joint_damping_n_s_m))
        return float(-(forces @ slopes) + damping * speed)

    def force_limits(self, grip_n: float, opening_m: float) -> tuple[np.ndarray, np.ndarray]:
        """Each actuator's force range (low, high; its units) for a grip of ``grip_n`` per finger
        at the opening ``opening_m``: what the free fingers need there at rest, plus or minus
        the actuator's equal share of the grip, within its rating."""
        slopes = np.abs(self._at(self._slopes, opening_m))
        share = grip_n / (len(self.actuators) * np.maximum(slopes, 1e-12))
        static = self._at(self.path.static_force, opening_m)
        return np.clip(static - share, -self.force_max, self.force_max), np.clip(static + share, -self.force_max, self.force_max)

    def rating_n(self) -> float:
        """The grip the drive is rated for, N per finger: sum_a F_a |dl_a/do|, the least along
        the path (a grip it holds at any width)."""
        return float((self.force_max[:, None] * np.abs(self._slopes)).sum(axis=0).min())

    def damping_n_s_m(self) -> float:
        """The damping the drive must overcome to move the fingers, on the opening, N s/m: the
        joints' and the servos' (a servo's force limit caps its kv term too), the most along
        the path (the house's: its joints' and its servo's kv)."""
        return float((self.joint_damping_n_s_m + self.servo_damping_n_s_m).max())


def _free_closing(model: mujoco.MjModel, parts: GripperParts, actuators: list[int], joints: list[int]) -> tuple[DrivePath, np.ndarray]:
    """The fingers' free closing: the object taken away, the actuators hold their open commands
    for SETTLE_S, then ramp to closed over STROKE_S and hold there for SETTLE_S, recorded every
    step until the fingers touch each other; returns the path (:class:`DrivePath`) and the open
    commands.

    The fingers start in the open pose (:func:`cosim.attach.open_pose_qpos`: the joints in their
    ranges, the servos at their open ends), not at the file's ``qpos0``: a hand closed there
    (Menagerie's Franka hand) starts with its pads pressed through each other, and one whose
    ``qpos0`` lies outside its joints' ranges (the ALOHA gripper) against its limits, both far
    past what the contacts and limits can push out in a step.  The settling closes what the open
    pose leaves open (a linkage's loops, which it does not solve)."""
    data = mujoco.MjData(model)
    left, right = (model.site(f"{side}_pad_surface").id for side in PAD_SIDES)
    ranges = np.array([a.ctrl_range for a in parts.actuators])
    data.qpos[:] = open_pose_qpos(model, [model.body(PREFIX + pad[1]).id for pad in parts.pads])
    mujoco.mj_forward(model, data)
    opens = _opening_grows(model, data, actuators, left, right)
    open_ctrl = np.where(opens, ranges[:, 1], ranges[:, 0])
    closed_ctrl = np.where(opens, ranges[:, 0], ranges[:, 1])
    geoms = _gripper_geoms(model)
    qadr = [int(model.jnt_qposadr[j]) for j in joints]
    fingers = [_subtree(model, model.body(PREFIX + b).id) for b in parts.branches]
    palm = geoms[[int(model.geom_bodyid[g]) not in fingers[0] | fingers[1] for g in geoms]]  # what the fingers hang from
    object_adr = model.joint("object_joint").qposadr[0]
    data.qpos[object_adr : object_adr + 3] = [0.0, 0.0, -1e3]  # far below the table: nothing to touch
    dt = model.opt.timestep
    settle, stroke = round(SETTLE_S / dt), round(STROKE_S / dt)
    data.ctrl[actuators] = open_ctrl
    hold_activations(model, data, actuators)
    for _ in range(settle):
        mujoco.mj_step(model, data)
    samples = []

    def sample(fraction: float) -> tuple:
        data.ctrl[actuators] = open_ctrl + (closed_ctrl - open_ctrl) * fraction
        mujoco.mj_step(model, data)
        mujoco.mj_fwdPosition(model, data)  # the state after the step: positions, lengths, contacts
        if not (np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.actuator_length))):
            raise ValueError(f"gripper.mjcf {parts.path!r}: the fingers' free closing diverged in the scene")
        return (
            data.site_xpos[right, 0] - data.site_xpos[left, 0],
            data.actuator_length[actuators].copy(),
            data.qpos[qadr].copy(),
            0.5 * (data.site_xpos[left, 2] + data.site_xpos[right, 2]),
            _lowest_z(model, data, geoms),
            _lowest_z(model, data, palm) if palm.size else math.inf,
        )

    for k in range(stroke + settle + 1):
        state = sample(min(k / stroke, 1.0))
        if _fingers_touch(model, data, fingers):
            break
        samples.append(state)
    opening = np.array([s[0] for s in samples])
    if len(samples) < 2 or opening.max() - opening.min() < 1e-3:
        names = [a.name for a in parts.actuators]
        moved = opening.max() - opening.min() if len(samples) else 0.0
        raise ValueError(
            f"gripper.actuators {names!r} move the pads {1e3 * moved:.2g} mm before the fingers touch: "
            f"they do not close this gripper (gripper.mjcf {parts.path!r})"
        )
    grid = np.linspace(opening.min(), opening.max(), PATH_POINTS)

    def smooth(values) -> np.ndarray:  # PATH_FIT_DEGREE: the fingers' ringing averaged out of a smooth linkage
        return np.polynomial.Polynomial.fit(opening, np.asarray(values), PATH_FIT_DEGREE)(grid)

    lengths = np.array([smooth([s[1][i] for s in samples]) for i in range(len(actuators))])
    qpos = np.column_stack([smooth([s[2][j] for s in samples]) for j in range(len(qadr))])
    # How far the gripper reaches below the pads' centre at home while it closes from open down
    # to each opening: the most of any sample at that opening or wider.
    home_centre = samples[0][3]
    order = np.argsort(-opening, kind="stable")
    ascending = order[::-1]  # the samples by opening, narrowest first (np.interp's order)
    reach = np.maximum.accumulate(np.array([home_centre - s[4] for s in samples])[order])
    lowest = np.interp(grid, opening[ascending], reach[::-1])
    palm_above = samples[0][5] - home_centre
    # Not smoothed: a slide's pads keep their height exactly (0.0), a linkage's follow its arc.
    rise = np.interp(grid, opening[ascending], np.array([s[3] - home_centre for s in samples])[ascending])
    path = DrivePath(grid, lengths, qpos, lowest, _static_force(model, joints, grid, lengths, qpos), palm_above, rise)
    return path, open_ctrl


def _static_force(model: mujoco.MjModel, joints: list[int], grid: np.ndarray, lengths: np.ndarray, qpos: np.ndarray) -> np.ndarray:
    """The force each actuator needs to hold the free fingers at each opening of ``grid``, its
    units, shape (actuators, points): the model's passive forces at rest there (joint and tendon
    springs, gravity less its compensation), by virtual work along the path, each actuator's
    share equal: sum_a f_a dl_a/do = -(dq/do) . (qfrc_passive - qfrc_bias)."""
    data = mujoco.MjData(model)
    slopes = np.gradient(lengths, grid, axis=1)
    speeds = np.gradient(qpos, grid, axis=0)
    qadr, dofs = [int(model.jnt_qposadr[j]) for j in joints], [int(model.jnt_dofadr[j]) for j in joints]
    need = np.zeros(grid.size)
    for k in range(grid.size):
        data.qpos[:] = model.qpos0
        data.qpos[qadr] = qpos[k]
        mujoco.mj_forward(model, data)
        need[k] = -speeds[k] @ (data.qfrc_passive[dofs] - data.qfrc_bias[dofs])
    return need / (len(lengths) * np.where(slopes == 0, np.inf, slopes))


def _fingers_touch(model: mujoco.MjModel, data: mujoco.MjData, fingers: list[set[int]]) -> bool:
    """Whether a contact joins the two fingers (their bodies, pads included)."""
    for c in data.contact[: data.ncon]:
        a, b = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        if (a in fingers[0] and b in fingers[1]) or (a in fingers[1] and b in fingers[0]):
            return True
    return False


def _opening_grows(model: mujoco.MjModel, data: mujoco.MjData, actuators: list[int], left: int, right: int) -> np.ndarray:
    """Per actuator, whether lengthening it opens the fingers (in the reference pose: the pads'
    x velocities from its joints' motion, through their Jacobians)."""
    jac_left, jac_right = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, data, jac_left, None, left)
    mujoco.mj_jacSite(model, data, jac_right, None, right)
    d_opening = jac_right[0] - jac_left[0]  # d opening / d qvel
    moment = np.zeros((model.nu, model.nv))
    mujoco.mju_sparse2dense(moment, data.actuator_moment, data.moment_rownnz, data.moment_rowadr, data.moment_colind)
    grows = moment[actuators] @ d_opening
    return grows > 0


def _gripper_geoms(model: mujoco.MjModel) -> np.ndarray:
    """The collision geoms of the gripper on the palm (the file's and the pads')."""
    palm = model.body("palm").id
    below = [b for b in range(model.nbody) if palm in _path_from_world(model, b) and b != palm]
    return np.array(
        [g for g in range(model.ngeom) if model.geom_bodyid[g] in below and (model.geom_contype[g] or model.geom_conaffinity[g])], int
    )


def _lowest_z(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray) -> float:
    """The lowest world z of the geoms' bounding boxes (turned with them), m."""
    xmat = data.geom_xmat[geoms].reshape(-1, 3, 3)[:, 2, :]  # each geom's axes' world z
    centre, half = model.geom_aabb[geoms, :3], model.geom_aabb[geoms, 3:]
    bottom = data.geom_xpos[geoms, 2] + (xmat * centre).sum(axis=1) - (np.abs(xmat) * half).sum(axis=1)
    return float(bottom.min())


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
        :attr:`GripperDrive.mass_kg` and the most of its joints' damping)."""
        drive = self.drive
        fingers = {
            "finger_force_limit_n": drive.rating_n(),
            "finger_damping_n_s_m": drive.damping_n_s_m(),
            "finger_friction_n": float(drive.friction_n.max()),
            "finger_mass_kg": float(drive.mass_kg.min()),
            "finger_joint_damping_n_s_m": float(drive.joint_damping_n_s_m.max()),
        }
        path = drive.path
        rise = coupling = ((), ())
        if np.any(path.centre_rise_m):  # a linkage's arc (slides' pads keep their height exactly)
            rise = (tuple(path.opening_m.tolist()), tuple(path.centre_rise_m.tolist()))
        if np.any(drive.lift_coupling_kg):  # (exactly 0 for slides across the lift)
            coupling = (tuple(path.opening_m[list(MASS_POINTS)].tolist()), tuple(drive.lift_coupling_kg.tolist()))
        return robot_limits(self.model, home, self.geometry, gel, fingers=fingers, pad_rise_m=rise, lift_coupling_kg=coupling)


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
    apply_pad_contact(model, resolve_pad_contact(phys.pad_contact, mounted=True))
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
    kv = -model.actuator_biasprm[actuators, 2]
    drive = GripperDrive(model, parts, path, joints, kv)
    widest = drive.home_opening_m - 2.0 * HOME_CLEARANCE_M
    if config.object.size_m > widest:
        raise ValueError(
            f"object.size_m {config.object.size_m!r} m does not fit the gripper of gripper.mjcf {parts.path!r}: its pads open "
            f"{1e3 * drive.home_opening_m:.1f} mm, at most {1e3 * widest:.1f} mm with {1e3 * HOME_CLEARANCE_M:g} mm a side"
        )
    pads = {f"{side}_pad": geometry.strip_names(side) for side in PAD_SIDES}
    return MountedGripper(model, parts, geometry, pads, drive, open_ctrl)


def hold_activations(model: mujoco.MjModel, data: mujoco.MjData, actuators: list[int]) -> None:
    """Set the activation of each of ``actuators`` that filters its command to the command in
    ``data.ctrl``, as if held there for long: a reset puts every activation at 0, which such a
    servo would first drive to (a closed hand, for Menagerie's 0-255 servos)."""
    for a in actuators:
        if model.actuator_actnum[a] and int(model.actuator_dyntype[a]) != mujoco.mjtDyn.mjDYN_NONE:
            data.act[model.actuator_actadr[a]] = data.ctrl[a]


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


#: The path's points at which the fingers' mass on the opening is computed (eleven, ends included).
MASS_POINTS = range(0, PATH_POINTS, (PATH_POINTS - 1) // 10)


def opening_inertia_kg(model: mujoco.MjModel, path: DrivePath, joints: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The fingers' inertia on the opening and its coupling to the lift at :data:`MASS_POINTS`
    of ``path``, kg, from the model's joint-space inertia M there (mj_fullM: the links' masses
    and inertias, the joints' armature) and v, the joints' speeds per opening speed (dq/do along
    the free closing):

    - m_o = v^T M v, so the fingers' kinetic energy is (1/2) m_o o'^2;
    - c = e_lift^T M v, the cross term of the kinetic energy (1/2) m_l z'^2 + c z' o' +
      (1/2) m_o o'^2, so by Lagrange a lift accelerating at z'' pushes the opening with -c z''
      (N).  0 for fingers that slide across the lift; a linkage whose pads rise as they open
      has c > 0: the lift braking at the top opens them (Robotiq's 2F-85: 13 g at a 30 mm
      opening, 6 mN at 0.5 m/s^2, a third of the 2 g paper ball's grip)."""
    dofs, qadr = [int(model.jnt_dofadr[j]) for j in joints], [int(model.jnt_qposadr[j]) for j in joints]
    lift = int(model.jnt_dofadr[model.joint("lift_joint").id])
    speeds = path.joint_rates()  # joint speed per opening speed, (points, joints)
    data, mass = mujoco.MjData(model), np.zeros((model.nv, model.nv))
    masses, couplings = [], []
    for k in MASS_POINTS:
        data.qpos[:] = model.qpos0
        data.qpos[qadr] = path.qpos[k]
        mujoco.mj_forward(model, data)
        mujoco.mj_fullM(model, data, mass)
        v = np.zeros(model.nv)
        v[dofs] = speeds[k]
        masses.append(float(v @ mass @ v))
        couplings.append(float(mass[lift] @ v))
    return np.array(masses), np.array(couplings)


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

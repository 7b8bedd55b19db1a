"""Where a fingertip's pad goes on a model: a box site's patch, or the face of a body's (or a
geom's) collision box towards the other fingertips, read in the open pose or a keyframe
(:func:`open_pose_qpos`, :func:`fingertip_pads`); the pad frame and layout on that patch.
What :func:`cosim.attach.attach` and the gripper mount (:mod:`cosim.gripper_parts`) place pads
with; models are read, never changed."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from .pad_geometry import PadGeometry
from .pad_model import PadPlacement

#: The element under the pad (the house gripper's: the paper's 7.5 x 5 mm element).
_ELEMENT = PadGeometry()


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


#: The joints a pose clamps and opens: a hinge's or slide's qpos is one number in its range.
_SCALAR_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
#: A position servo's activation follows its control (an integrator's control is a velocity).
_SERVO_DYNAMICS = (int(mujoco.mjtDyn.mjDYN_NONE), int(mujoco.mjtDyn.mjDYN_FILTER), int(mujoco.mjtDyn.mjDYN_FILTEREXACT))
#: How much further apart one end of a servo's range must put the fingertips to be the open one, m
#: (less is a tie: an arm's joint, which moves them together, keeps its place).
_OPEN_TOLERANCE_M = 1e-9
#: The open pose, for messages.
_OPEN_POSE = "the open pose (qpos0 in the joints' ranges, the position servos open)"


def open_pose_qpos(model: mujoco.MjModel, bodies: Sequence[int | str]) -> np.ndarray:
    """The hand's open pose: the configuration :func:`attach` reads its fingertips' faces in.

    A model's reference configuration (``qpos0``, every joint at 0) is often no pose the hand
    can take: fingers closed on each other, their collision boxes touching or overlapping, so
    that the face of one towards the other is undefined or reversed (Menagerie's Franka hand),
    or joints outside their ranges (ALOHA's gripper, the Jaco hand).  The open pose is where a
    controller opens the hand to:

    1. ``qpos0`` with every limited hinge and slide joint clamped into its range;
    2. then, actuator by actuator, each position servo set to the end of its control range
       that puts ``bodies`` furthest apart: the larger sum of the distances between their
       collision boxes' centres (``mj_kinematics``), both ends tried.  Where neither end is
       further by more than 1 nm (an arm's joint, moving the fingertips together), the pose
       stays as it was.

    A position servo is an actuator with a control range (``ctrllimited``), a fixed gain, an
    affine bias with position feedback (``biasprm[1] < 0``) and no integrator, on a hinge or
    slide joint or on a fixed tendon of them.  Its length settles where
    ``gainprm[0] ctrl + biasprm[0] + biasprm[1] length = 0``: at the control itself for MuJoCo's
    ``position`` (gain kp, bias -kp), at a scaled 0-255 command for Menagerie's ``general``
    servos.  The length is ``gear[0]`` times the joint's position, or times the tendon's length
    ``sum coef_i q_i``.  A joint goes to the length, clamped into its range; a tendon's joints
    move from where they are by ``coef_i (target - length) / sum coef^2`` (the least change
    that brings the tendon to its target, in proportion to the coefficients), each clamped into
    its range.  Equality constraints are not solved: a joint that only follows another through
    an ``<equality>`` stays where step 1 put it (a keyframe as ``pose=`` places such a hand).

    Parameters
    ----------
    model : the compiled model; not changed.
    bodies : the fingertips' bodies, ids or names; a body without collision geoms counts by its
        origin.

    Returns
    -------
    The open pose's qpos, (nq,).
    """
    ids = [int(b) if isinstance(b, int | np.integer) else mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in bodies]
    for given, body in zip(bodies, ids, strict=True):
        if not 0 <= body < model.nbody:
            raise ValueError(f"open_pose_qpos: body {given!r} is not in the model (its bodies: {_names(model, 'body', model.nbody)})")
    local = [_collision_centre(model, b) for b in ids]
    qpos = model.qpos0.copy()
    for joint in range(model.njnt):
        if model.jnt_limited[joint] and model.jnt_type[joint] in _SCALAR_JOINTS:
            adr = model.jnt_qposadr[joint]
            qpos[adr] = np.clip(qpos[adr], *model.jnt_range[joint])
    data = mujoco.MjData(model)

    def spread(q: np.ndarray) -> float:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        points = [data.xpos[b] + data.xmat[b].reshape(3, 3) @ c for b, c in zip(ids, local, strict=True)]
        return sum(float(np.linalg.norm(p - r)) for i, p in enumerate(points) for r in points[i + 1 :])

    for actuator in range(model.nu):
        ends = [_servo_at(model, qpos, actuator, float(ctrl)) for ctrl in model.actuator_ctrlrange[actuator]]
        if ends[0] is None:
            continue
        apart = [spread(q) for q in ends]
        if abs(apart[1] - apart[0]) > _OPEN_TOLERANCE_M:
            qpos = ends[int(np.argmax(apart))]
    return qpos


def _collision_centre(model: mujoco.MjModel, body: int) -> np.ndarray:
    """The centre of the body's collision box in its frame (its origin without collision geoms), m."""
    geoms = range(model.body_geomadr[body], model.body_geomadr[body] + model.body_geomnum[body])
    if not any(model.geom_contype[g] or model.geom_conaffinity[g] for g in geoms):
        return np.zeros(3)
    return _body_box(model, body, f"body {model.body(body).name!r}")[0]


def _servo_at(model: mujoco.MjModel, qpos: np.ndarray, actuator: int, ctrl: float) -> np.ndarray | None:
    """``qpos`` with the joints of a position servo at the length it holds at ``ctrl``, clamped
    into their ranges (:func:`open_pose_qpos`); None if ``actuator`` is no such servo."""
    gain, bias, gear = model.actuator_gainprm[actuator], model.actuator_biasprm[actuator], model.actuator_gear[actuator, 0]
    if not (
        model.actuator_ctrllimited[actuator]
        and model.actuator_gaintype[actuator] == mujoco.mjtGain.mjGAIN_FIXED
        and model.actuator_biastype[actuator] == mujoco.mjtBias.mjBIAS_AFFINE
        and model.actuator_dyntype[actuator] in _SERVO_DYNAMICS
        and bias[1] < 0
        and gear != 0
    ):
        return None
    kind, target = int(model.actuator_trntype[actuator]), int(model.actuator_trnid[actuator, 0])
    if kind in (mujoco.mjtTrn.mjTRN_JOINT, mujoco.mjtTrn.mjTRN_JOINTINPARENT):
        joints, coefs = [target], np.ones(1)
    elif kind == mujoco.mjtTrn.mjTRN_TENDON:
        wraps = range(model.tendon_adr[target], model.tendon_adr[target] + model.tendon_num[target])
        if any(model.wrap_type[w] != mujoco.mjtWrap.mjWRAP_JOINT for w in wraps):
            return None  # a spatial tendon: its length is no sum of joint positions
        joints, coefs = [int(model.wrap_objid[w]) for w in wraps], np.array([model.wrap_prm[w] for w in wraps], float)
    else:
        return None
    if any(model.jnt_type[j] not in _SCALAR_JOINTS for j in joints) or not coefs @ coefs > 0:
        return None
    length = (gain[0] * ctrl + bias[0]) / -bias[1] / gear
    adrs = model.jnt_qposadr[joints]
    q = qpos.copy()
    q[adrs] += coefs * (length - coefs @ q[adrs]) / (coefs @ coefs)
    for joint, adr in zip(joints, adrs, strict=True):
        if model.jnt_limited[joint]:
            q[adr] = np.clip(q[adr], *model.jnt_range[joint])
    return q


def _pose_qpos(model: mujoco.MjModel, pose: str | None, bodies: Sequence[int]) -> tuple[np.ndarray, str]:
    """The configuration the faces are read in, and its name for messages: keyframe ``pose``'s
    qpos, or (None) :func:`open_pose_qpos` of ``bodies``."""
    if pose is None:
        return (open_pose_qpos(model, bodies) if bodies else model.qpos0.copy()), _OPEN_POSE
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, pose) if isinstance(pose, str) and pose else -1
    if key < 0:
        raise ValueError(f"attach: pose {pose!r} is no keyframe of the model (its keyframes: {_names(model, 'key', model.nkey)})")
    return model.key_qpos[key].copy(), f"keyframe {pose!r}"


def _body_patches(model: mujoco.MjModel, names: Sequence[str], pose: str | None = None, whole_face: bool = False) -> list[_Patch]:
    """Each body's pad on the face of its collision box towards the other bodies' (their centre),
    in ``pose`` (a keyframe's name, or None: :func:`open_pose_qpos`); none for no names (the
    pose is checked all the same).  ``whole_face``: the patch is the whole face (a touch pad's
    zone), not the house pad's 20 x 20 mm on it."""
    faces = []
    for name in names:
        try:
            faces.append(_Face(f"body {name!r}", model.body(name).id))
        except KeyError:
            raise ValueError(f"attach: body {name!r} is not in the model (its bodies: {_names(model, 'body', model.nbody)})") from None
    if len(faces) == 1:
        raise ValueError(f"attach: a pad on body {names[0]!r} faces the other fingertip: give two or more bodies, or a site")
    return _face_patches(model, faces, pose, whole_face)


def _face_patches(model: mujoco.MjModel, faces: Sequence[_Face], pose: str | None = None, whole_face: bool = False) -> list[_Patch]:
    """Each face's pad on the side of its box towards the other faces' boxes (their centre), in
    ``pose`` (a keyframe's name, or None: :func:`open_pose_qpos`; only which face and which way
    come from it): the house pad's 20 x 20 mm or the face if smaller, its length along the
    face's longer side (of a square face, the side nearer the direction of the body's parent:
    the finger's length), its root towards the body's parent."""
    for face in faces:
        _body_name(model, face.body, face.source)
    qpos, described = _pose_qpos(model, pose, [face.body for face in faces])
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
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
            raise ValueError(
                f"attach: {face.source} has its collision box where the other fingertips' are in {described}; "
                "give sites, or the name of a keyframe with the hand open as pose="
            )
        out = int(np.argmax(np.abs(towards)))
        in_plane = [a for a in range(3) if a != out]
        # The element's clamped root towards the body's parent (the palm), as on the house gripper.
        parent = rotation.T @ (data.xpos[model.body_parentid[body]] - data.xpos[body])
        along = max(in_plane, key=lambda a: (half[a], abs(parent[a]), -a))  # the face's longer side: the finger's length
        across = in_plane[0] if along == in_plane[1] else in_plane[1]
        x = np.eye(3)[along] * (1.0 if parent[along] >= 0 else -1.0)
        z = np.eye(3)[out] * np.sign(towards[out])
        origin = centre + z * half[out]
        # A touch pad's zone must hold every contact on the face (a box's corners, for one), so
        # it is the whole face; a gel pad is the house's, or the face where that is smaller.
        length = half[along] if whole_face else min(half[along], 0.5 * _ELEMENT.pad_length_m)
        width = half[across] if whole_face else min(half[across], 0.5 * _ELEMENT.pad_width_m)
        patches.append(_Patch(face.source, model.body(body).name, origin, np.column_stack((x, np.cross(z, x), z)), length, width))
    return patches


def fingertip_pads(
    model: mujoco.MjModel, fingertips: Sequence[str], segments: int, gel_thickness_m: float, *, pose: str | None = None
) -> list[tuple[str, str, PadPlacement, PadGeometry]]:
    """The pad :func:`attach` puts on each of ``fingertips``, each named as a box site (the pad on
    it, as ``sites``), a body (on its collision geometry's face towards the other fingertips, as
    ``bodies``) or a geom (on its own face towards them), looked up in that order; two or more
    when any is not a site.  Per fingertip: (source, body name, pad placement, pad geometry), the
    strips ``segments`` per element, the gel ``gel_thickness_m`` thick (m).  ``pose``: the
    keyframe whose qpos the faces are read in, or None for :func:`open_pose_qpos` (as ``attach``)."""
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
    patches = _face_patches(model, placed, pose)  # none for sites: the pose is checked all the same
    if not placed:
        patches = [_site_patch(model, name) for name in fingertips]
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

"""A mounted gripper's drive: its fingers' free closing measured on the mounted model
(:class:`DrivePath`), and what comes of it (:class:`GripperDrive`: the command for an opening,
the grip the fingers feel, the force limits, the rating, the inertia on the opening).  The third
of a mount's jobs (:mod:`cosim.gripper_mount`)."""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from .gripper_parts import GripperParts, _path_from_world, _subtree
from .pad_geometry import PAD_SIDES
from .pad_placement import open_pose_qpos

PREFIX = "gripper/"
"""What the names of the gripper file's parts start with in the scene (``gripper/finger_joint1``)."""

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
        that slide; a linkage's fingertips swing along an arc: tests/test_third_party_grippers.py::
        test_robotiqs_pads_swing_down_their_arc_and_the_lift_braking_opens_them).
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
    servo_stiffness_n_m : the servos' stiffness on the opening along the path, N/m:
        sum_a kp_a (dl_a/do)^2, kp_a the servo's -biasprm[1] (0 for an actuator with no position
        feedback: a motor the mount has not made a servo).
    friction_n : the joints' dry friction on the opening along the path, N: sum_d F_d |dq_d/do|.
    mass_kg : the fingers' inertia on the opening at :data:`MASS_POINTS` of the path, kg
        (:func:`opening_inertia_kg`).
    lift_coupling_kg : the fingers' inertia coupling the lift to the opening there, kg
        (:func:`opening_inertia_kg`).
    """

    def __init__(
        self, model: mujoco.MjModel, parts: GripperParts, path: DrivePath, joints: list[int], kv: np.ndarray, kp: np.ndarray
    ) -> None:
        self.actuators = [model.actuator(PREFIX + a.name).id for a in parts.actuators]
        self.force_max = np.array([a.force_max for a in parts.actuators])
        self._force_max = self.force_max.tolist()
        self.ctrl_range = np.array([a.ctrl_range for a in parts.actuators])
        self._kp = np.asarray(kp, dtype=float)
        # The length each actuator's command holds at the closing end of its range: of the two
        # ends, the one past the path's home length toward its closed end.
        held = np.array([[a.length_offset + a.length_per_ctrl * c for c in a.ctrl_range] for a in parts.actuators])
        closing = np.sign(path.lengths[:, 0] - path.lengths[:, -1])[:, None]
        closed_end = np.argmax(closing * (held - path.lengths[:, -1:]), axis=1)
        self._closed_length = held[np.arange(len(held)), closed_end]
        #: The commands that close the fingers as far as their servos go (each range's closing end).
        self.closed_ctrl = [float(self.ctrl_range[a, end]) for a, end in enumerate(closed_end)]
        self._ctrl_per_length = [1.0 / a.length_per_ctrl for a in parts.actuators]
        self._length_offset = [a.length_offset for a in parts.actuators]
        self.path = path
        self.joint_qpos = [int(model.jnt_qposadr[j]) for j in joints]
        self._sites = [model.site(f"{side}_pad_surface").id for side in PAD_SIDES]
        self._slopes = path.slopes()
        self._lengths_at = PathTable(path.opening_m, path.lengths)
        # what the command that holds the pads touching presses with along the path (ctrl_for)
        self._touching_reach_at = PathTable(path.opening_m, self._servo_grip_n(np.asarray(self._lengths_at(0.0)))[None, :])
        self._slopes_at = PathTable(path.opening_m, self._slopes)
        self._static_at = PathTable(path.opening_m, path.static_force)
        self.home_opening_m = float(path.opening_m[-1])
        idle = [a.name for a, row in zip(parts.actuators, self._slopes, strict=True) if not np.abs(row).max() > 0]
        if idle:
            raise ValueError(f"gripper.actuators: {idle!r} do not open or close the fingertips (gripper.mjcf {parts.path!r})")
        speeds = path.joint_rates()  # joint speed per opening speed, (points, joints)
        dofs = [int(model.jnt_dofadr[j]) for j in joints]
        self.joint_damping_n_s_m = speeds**2 @ model.dof_damping[dofs]
        self._damping_at = PathTable(path.opening_m, self.joint_damping_n_s_m)
        self.servo_damping_n_s_m = (np.asarray(kv)[:, None] * self._slopes**2).sum(axis=0)
        self.servo_stiffness_n_m = (np.maximum(np.asarray(kp, dtype=float), 0.0)[:, None] * self._slopes**2).sum(axis=0)
        self.friction_n = np.abs(speeds) @ model.dof_frictionloss[dofs]
        self.mass_kg, self.lift_coupling_kg = opening_inertia_kg(model, path, joints)

    def ctrl_for(self, opening_m: float, grip_n: float = 0.0, now_m: float = math.inf) -> list[float]:
        """The actuators' commands for an opening target, m: those that hold the path's lengths
        there (a target past the path's ends commands its end), within their ranges; but a
        target at the pads touching or past them (an opening of 0 or less: the controllers'
        "close, within the force limit") for a grip of ``grip_n`` (N per finger) more than the
        command that holds the pads touching presses with at the opening now (``now_m``, m)
        commands the servos' closed end (:attr:`closed_ctrl`).  Held to the pads touching, a
        position servo presses an object with kp times the stroke to there, less than its range
        reaches (:meth:`reach_n`): robosuite's Panda (kp 1000 N/m) stopped at 9.5 N a finger on a
        24 mm cylinder its range reaches 15 N on (tests/test_third_party_grippers.py::
        test_a_servo_closing_on_an_object_is_commanded_to_its_ranges_closed_end).  Only past
        that grip: the servo presses there with its force limit either way, and a lighter grip's
        commands stay those of the fingers' touch (the catalogue's runs the same)."""
        if opening_m <= 0.0 and grip_n > self._touching_reach_at(now_m)[0]:
            return list(self.closed_ctrl)
        lengths = self._lengths_at(opening_m)
        commands = [(v - o) * c for v, o, c in zip(lengths, self._length_offset, self._ctrl_per_length, strict=True)]
        return [min(max(v, lo), hi) for v, (lo, hi) in zip(commands, self.ctrl_range, strict=True)]

    def opening_m(self, data: mujoco.MjData) -> float:
        """The opening between the unloaded pads' surfaces, m (their sites' world x: the mount
        closes the fingers along x), as the last physics step's kinematics had it."""
        left, right = self._sites
        return float(data.site_xpos[right, 0] - data.site_xpos[left, 0])

    def grip_force_n(self, data: mujoco.MjData) -> float:
        """The squeeze of each finger by the drive, N (positive squeezes), from the actuators'
        forces less the free fingers' need (the class docstring): the robot's own sensing, as
        the house's fingers_actuator force."""
        opening = self.opening_m(data)
        slopes, static = self._slopes_at(opening), self._static_at(opening)
        force, velocity = data.actuator_force, data.actuator_velocity
        forces = [force[a] - s for a, s in zip(self.actuators, static, strict=True)]
        rates = [velocity[a] / s for a, s in zip(self.actuators, slopes, strict=True) if abs(s) > 0]
        # d opening / dt: their mean as np.mean takes it (add.reduce over the count), bit for bit
        speed = float(np.add.reduce(np.array(rates)) / len(rates)) if rates else math.nan
        damping = self._damping_at(opening)[0]
        return float(-(np.array(forces) @ np.array(slopes)) + damping * speed)

    def force_limits(self, grip_n: float, opening_m: float) -> tuple[np.ndarray, np.ndarray]:
        """Each actuator's force range (low, high; its units) for a grip of ``grip_n`` per finger
        at the opening ``opening_m``: what the free fingers need there at rest, plus or minus
        the actuator's equal share of the grip, within its rating."""
        count, low, high = len(self.actuators), [], []
        for slope, static, most in zip(self._slopes_at(opening_m), self._static_at(opening_m), self._force_max, strict=True):
            share = grip_n / (count * max(abs(slope), 1e-12))
            low.append(min(max(static - share, -most), most))
            high.append(min(max(static + share, -most), most))
        return np.array(low), np.array(high)

    def rating_n(self) -> float:
        """The grip the drive is rated for, N per finger: sum_a F_a |dl_a/do|, the least along
        the path (a grip it holds at any width)."""
        return float((self.force_max[:, None] * np.abs(self._slopes)).sum(axis=0).min())

    def reach_n(self) -> np.ndarray:
        """The most grip the drive gives at each opening of its path, N per finger, its commands
        at their closing end: a position servo's force there is kp_a |l_a - l*_a| (l*_a the length
        that command holds; MuJoCo's affine bias, force = g ctrl + b0 - kp l at rest), within its
        rating F_a, so the grip is sum_a min(F_a, kp_a |l_a - l*_a|) |dl_a/do| plus what the
        free fingers' springs give there (:attr:`DrivePath.static_force`, as :meth:`grip_force_n`
        reads them).  A servo whose closed command holds a length far past the fingers touching
        (the 2F-85s') gives its rating at any width; robosuite's grippers' (kp 1000 N/m, closed
        at their joints' zero) give less under about 30 mm (10 N of their 20 N at 10 mm); one
        whose closed command holds the fingers just touching gives a grip that vanishes as they
        close, and little anywhere: Menagerie's Franka hand, kp 100 N/m
        on a tendon of the fingers' mean, 1.75 N a finger on a 60 mm jar for the 50 N its force
        range rates it at (tests/test_gripper_natural_pose.py::
        test_a_servos_reach_caps_the_grip_at_each_width_and_the_controller_says_so)."""
        return self._servo_grip_n(self._closed_length) + (self.path.static_force * self._slopes).sum(axis=0)

    def _servo_grip_n(self, held_lengths: np.ndarray) -> np.ndarray:
        """The grip the servos press with along the path, N per finger, commanded to hold
        ``held_lengths`` (one an actuator, its units): sum_a min(F_a, kp_a |l_a - l*_a|) |dl_a/do|,
        F_a for an actuator without position feedback (:meth:`reach_n`)."""
        kp = np.maximum(self._kp, 0.0)[:, None]
        reach = np.abs(self.path.lengths - held_lengths[:, None]) * kp
        force = np.where(kp > 0.0, np.minimum(self.force_max[:, None], reach), self.force_max[:, None])
        return (force * np.abs(self._slopes)).sum(axis=0)

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
    starts with its pads pressed through each other, and one whose ``qpos0`` lies outside its
    joints' ranges against its limits, both far past what the contacts and limits can push out
    in a step (tests/test_gripper_natural_pose.py::test_jaws_closed_at_qpos0_mount_open_and_grasp_the_box
    and test_fingers_whose_qpos0_is_outside_their_range_mount_in_it_and_grasp_the_box).  The
    settling closes what the open pose leaves open (a linkage's loops, which it does not solve)."""
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


class PathTable:
    """Rows of a drive's path table (shape (rows, points) on the path's openings), read at an
    opening as ``np.interp(x, grid, row)`` reads each row, bit for bit (numpy's formula,
    (y1 - y0) / (x1 - x0) * (x - x0) + y0 on the interval x0 <= x < x1, its other end where that
    is NaN; the ends held past them), in Python floats: the drive reads its tables at the opening
    several times a period, and numpy's per-call cost on a table of two rows was most of a
    mounted gripper's Python (robosuite's Panda: 51 us a period, 20 us so; tests/
    test_third_party_grippers.py::test_the_drives_tables_are_read_as_numpy_interpolates_them)."""

    __slots__ = ("_grid", "_rows")

    def __init__(self, grid: np.ndarray, table: np.ndarray) -> None:
        self._grid = [float(g) for g in grid]
        self._rows = [[float(v) for v in row] for row in np.atleast_2d(table)]

    def __call__(self, x: float) -> list[float]:
        """Each row at the opening ``x``, m."""
        grid, x = self._grid, float(x)
        if not x > grid[0]:  # at or below the first point (np.interp's left value), or NaN
            return [row[0] if x <= grid[0] else math.nan for row in self._rows]
        if not x < grid[-1]:
            return [row[-1] for row in self._rows]
        j = bisect.bisect_right(grid, x) - 1
        x0, x1 = grid[j], grid[j + 1]
        out = []
        for row in self._rows:
            slope = (row[j + 1] - row[j]) / (x1 - x0)
            value = slope * (x - x0) + row[j]
            out.append(value if value == value else slope * (x - x1) + row[j + 1])
        return out


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


def hold_activations(model: mujoco.MjModel, data: mujoco.MjData, actuators: list[int]) -> None:
    """Set the activation of each of ``actuators`` that filters its command to the command in
    ``data.ctrl``, as if held there for long: a reset puts every activation at 0, which such a
    servo would first drive to (a closed hand, for Menagerie's 0-255 servos)."""
    for a in actuators:
        if model.actuator_actnum[a] and int(model.actuator_dyntype[a]) != mujoco.mjtDyn.mjDYN_NONE:
            data.act[model.actuator_actadr[a]] = data.ctrl[a]


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
      has c > 0: the lift braking at the top opens them, by a good share of a light object's
      grip (tests/test_third_party_grippers.py::
      test_robotiqs_pads_swing_down_their_arc_and_the_lift_braking_opens_them)."""
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

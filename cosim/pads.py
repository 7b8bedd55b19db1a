"""The gel pads in MuJoCo: the gripper's pad strips follow the gel model, not a contact softness.

Design (models/README.md, "Pad compliance", says why):

* Each fingertip's 20 x 20 mm, 5 mm thick gel pad is cut into strips along the sensor
  element's length (the finger's z axis): ``segments`` strips tile the 7.5 mm element, two
  *guards* cover the rest of the pad.  Each strip is a body on a slide joint normal to the
  pad, ``q`` = indentation into the housing (m).
* Contacts between the strips and objects are hard (solimp at MuJoCo's maximum impedance),
  so the contact adds no compliance of its own, whatever the object's mass.
* :class:`PadBridge` applies the gel's force law to every strip joint before each
  ``mj_step``:  F = -A P(q), with P from :meth:`sensor.gel.GelModel.pressure_from_indentation`
  (Gent's law).  The law is stiff (the tangent grows 180x between 0 and 80 % strain), so it
  is integrated implicitly: the bridge writes the tangent stiffness A dP/dq into the joint's
  ``jnt_stiffness`` and the remainder into ``qfrc_applied``, so that the explicit force is
  exactly -A P(q) and MuJoCo's ``discrete`` integrator folds the stiffness into its
  effective metric M + h D + h^2 K, solved jointly with the contacts.  Statics are exact.
* The joint's upper limit is the rigid housing: past 80 % compression (before Gent's lock at
  91 %) the limit takes the load and :class:`PadReading` reports ``bottomed``.

Frames: strip order is from the finger's distal end (low z) up; pressures along the element
are ordered the same way, and :attr:`PadGeometry.segment_centers_m` gives their positions
(m, from the element's centre, + towards the palm).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from piezotip.sensor.gel import GelModel, GelParams, gent_pressure_pa, modulus_ratio
from piezotip.sensor.lookup import UniformPairTable

from .pad_kernels import GelForces, PadPressures

MODELS_DIR = Path(__file__).resolve().parent.parent / "models"
"""Where the MJCF files live (``gripper.xml``, ``table.xml``, ``scene_*.xml``)."""

PAD_SIDES = ("left", "right")
PAD_NAMES = tuple(f"{side}_pad" for side in PAD_SIDES)
"""Pad names, in the order of every per-pad array: ``("left_pad", "right_pad")``."""

DEFAULT_PAD_SEGMENTS = 5
#: The pad contacts' and housing stop's time constant, s (gripper.xml's, at its 1 ms step).
PAD_CONTACT_TIMECONST_S = 0.002
"""Strips per element in the static ``models/gripper.xml``."""

_GEL = GelParams()


@dataclass(frozen=True)
class PadGeometry:
    """One fingertip pad: its size, the element under it, and how it is cut into strips.

    Attributes
    ----------
    segments : N, strips tiling the element's length (the pad resolution), >= 1.
    pad_length_m : pad face along the finger's z axis (the element's length direction), m.
    pad_width_m : pad face across the finger (y), m.
    element_length_m : the element's active face along z, m (7.5 mm: the paper's element).
    element_width_m : the element's active face along y, m (5 mm).
    gel_thickness_m : unloaded gel thickness h0, m; must equal the gel model's.
    stop_strain : compression at which the housing stops a strip (the joint's upper limit),
        as a fraction of h0.  0.8: Gent's law (J_m = 20) locks at 0.913; at 0.8 the gel
        carries 383 kPa, 153 N over the whole pad, more than the gripper's 100 N grip.
    retain_m : how far a strip may be pulled out of the pad (the joint's lower limit), m.
        The gel is bonded to the housing and the film, so it pulls back in tension.
    """

    segments: int = DEFAULT_PAD_SEGMENTS
    pad_length_m: float = 0.020
    pad_width_m: float = 0.020
    element_length_m: float = 7.5e-3
    element_width_m: float = 5e-3
    gel_thickness_m: float = _GEL.thickness_m
    stop_strain: float = 0.8
    retain_m: float = 0.5e-3

    def __post_init__(self) -> None:
        if not isinstance(self.segments, int | np.integer) or self.segments < 1:
            raise ValueError(f"PadGeometry.segments must be an integer >= 1, got {self.segments!r}")
        for name in ("pad_length_m", "pad_width_m", "element_length_m", "element_width_m", "gel_thickness_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"PadGeometry.{name} must be positive and finite, got {v!r}")
        if self.element_length_m > self.pad_length_m or self.element_width_m > self.pad_width_m:
            raise ValueError("PadGeometry: the element must fit under the pad")
        if not 0 < self.stop_strain < 1:
            raise ValueError(f"PadGeometry.stop_strain must be in (0, 1), got {self.stop_strain!r}")
        if not (math.isfinite(self.retain_m) and 0 < self.retain_m < self.gel_thickness_m):
            raise ValueError(f"PadGeometry.retain_m must be in (0, gel_thickness_m), got {self.retain_m!r}")

    @property
    def segment_length_m(self) -> float:
        """Length of one element strip along z, m."""
        return self.element_length_m / self.segments

    @property
    def guard_length_m(self) -> float:
        """Length of each guard strip (pad beyond the element's ends), m; 0 when there are none."""
        return 0.5 * (self.pad_length_m - self.element_length_m)

    @property
    def has_guards(self) -> bool:
        return self.guard_length_m > 1e-12

    @property
    def stop_m(self) -> float:
        """Indentation at which the housing takes the load (the joint's upper limit), m."""
        return self.stop_strain * self.gel_thickness_m

    @property
    def pad_area_m2(self) -> float:
        return self.pad_length_m * self.pad_width_m

    @property
    def element_area_m2(self) -> float:
        return self.element_length_m * self.element_width_m

    @property
    def strip_lengths_m(self) -> np.ndarray:
        """Lengths of all strips, distal guard first, m."""
        seg = np.full(self.segments, self.segment_length_m)
        if not self.has_guards:
            return seg
        return np.concatenate(([self.guard_length_m], seg, [self.guard_length_m]))

    @property
    def strip_edges_m(self) -> np.ndarray:
        """z of the strips' edges from the pad's centre (the element's centre), m, distal first."""
        edges = np.concatenate(([0.0], np.cumsum(self.strip_lengths_m))) - 0.5 * self.pad_length_m
        if not self.has_guards:
            edges = edges + 0.5 * (self.pad_length_m - self.element_length_m)
        return edges

    @property
    def strip_centers_m(self) -> np.ndarray:
        """z of each strip's centre from the pad's centre, m."""
        edges = self.strip_edges_m
        return 0.5 * (edges[:-1] + edges[1:])

    @property
    def strip_areas_m2(self) -> np.ndarray:
        """Face area of each strip, m^2 (length x pad width: a strip spans the pad's width)."""
        return self.strip_lengths_m * self.pad_width_m

    @property
    def on_element(self) -> np.ndarray:
        """Boolean mask over the strips: True for the ``segments`` strips over the element."""
        mask = np.ones(len(self.strip_lengths_m), dtype=bool)
        if self.has_guards:
            mask[[0, -1]] = False
        return mask

    @property
    def segment_centers_m(self) -> np.ndarray:
        """z of each element strip's centre from the element's centre, m (+ towards the palm)."""
        return self.strip_centers_m[self.on_element]

    def strip_names(self, side: str) -> tuple[str, ...]:
        """Body names of one pad's strips, distal first (joint = name + "_joint", geom = name + "_geom")."""
        segs = tuple(f"{side}_pad_seg{i}" for i in range(self.segments))
        if not self.has_guards:
            return segs
        return (f"{side}_pad_guard_lower", *segs, f"{side}_pad_guard_upper")


def gel_stiffness_per_area(gel: GelParams) -> float:
    """Small-strain Winkler stiffness of the gel, E / h0, N/m^3 (the XML's joint stiffness per m^2)."""
    return gel.youngs_modulus_pa / gel.thickness_m


def gel_damping_per_area(gel: GelParams) -> float:
    """Viscous term of a strip per unit area, N s/m^3.

    A Kelvin-Voigt equivalent of the gel's loss at the strip's own small-strain frequency
    omega_s = sqrt(E / (rho h0^2)) (the gel column on its own stiffness, 1095 rad/s for the
    default gel): c = (E / h0) Im R(omega_s) / omega_s, with R the Prony modulus ratio of
    sensor/gel.py.  It damps a strip's ringing at the ratio Im R / 2 (0.047).  Stability needs
    no damping (the stiffness is implicit); this is the gel's own loss, not a numerical fix.
    """
    omega = math.sqrt(gel.youngs_modulus_pa / (gel.density_kg_m3 * gel.thickness_m**2))
    loss = float(np.imag(modulus_ratio(omega / (2 * math.pi), gel)))
    return gel_stiffness_per_area(gel) * loss / omega


# ---------------------------------------------------------------------------------------
# Scene files and model building.
# ---------------------------------------------------------------------------------------


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
        scenario's scene, with its object, is :func:`cosim.scene.build_scene`'s.
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
    h0, width = geometry.gel_thickness_m, geometry.pad_width_m
    k_area, c_area = gel_stiffness_per_area(gel), gel_damping_per_area(gel)
    for side in PAD_SIDES:
        finger = spec.body(f"{side}_finger")
        if finger is None:
            raise ValueError(f"the model has no body '{side}_finger' (is gripper.xml included?)")
        for child in list(finger.bodies):
            if child.name.startswith(f"{side}_pad_"):
                spec.delete(child)
        for name, z, length, area in zip(
            geometry.strip_names(side), geometry.strip_centers_m, geometry.strip_lengths_m, geometry.strip_areas_m2, strict=True
        ):
            body = finger.add_body(name=name, pos=[0.0, 0.0, float(z)], gravcomp=1.0)
            body.add_joint(
                pad,
                name=f"{name}_joint",
                range=[-geometry.retain_m, geometry.stop_m],
                stiffness=[float(k_area * area), 0.0, 0.0],
                damping=[float(c_area * area), 0.0, 0.0],
            )
            body.add_geom(
                pad,
                name=f"{name}_geom",
                size=[0.5 * h0, 0.5 * width, 0.5 * float(length)],
                pos=[-0.5 * h0, 0.0, 0.0],
                density=gel.density_kg_m3,
            )


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
    pad_geoms = [g for g in range(model.ngeom) if model.geom(g).name.endswith("_geom") and "_pad_" in model.geom(g).name]
    pad_joints = [j for j in range(model.njnt) if "_pad_" in model.joint(j).name]
    # A physical time constant (the file's 2 ms), floored at MuJoCo's 2 timesteps: a finer
    # step then resolves the same contact instead of a harder one, so results converge as the
    # step shrinks (the reference preset's check).
    constant = max(PAD_CONTACT_TIMECONST_S, 2 * timestep)
    model.geom_solref[pad_geoms, 0] = constant
    model.jnt_solref[pad_joints, 0] = constant


# ---------------------------------------------------------------------------------------
# The bridge: gel law -> joint forces, joint state -> pad readings.
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PadReading:
    """What one pad feels at one instant.

    Attributes
    ----------
    name : ``"left_pad"`` or ``"right_pad"``.
    normal_force_n : the pad's normal load, N: the gel's force plus, when bottomed, what the
        housing carries (its joint-limit forces).  In static equilibrium it equals the sum of
        the contact normal forces on the pad (:meth:`PadBridge.strip_contact_forces`).
    gel_force_n : the gel's share, sum over strips of A P(q), N.
    contact_area_m2 : area of the loaded strips (compressed by more than 1 um), m^2; a strip is
        rigid across the pad's width, so a loaded strip counts whole (Winkler contact area).
    segment_pressure_pa : gel pressure over each element strip, Pa, shape (segments,), from the
        distal end up; the element sits under the pad, so this is the pressure it carries.
        Compressive only (the gel rests unbonded on the element: tension reads 0).
    mean_pressure_pa : mean of ``segment_pressure_pa`` over the element, Pa (strips are equal).
    indentation_m : indentation of each element strip, m, shape (segments,).
    bottomed : True when any strip of the pad is on the housing stop: the gel law no longer
        describes the pad's load, and pressures there are the gel's maximum, not the load.
    """

    name: str
    normal_force_n: float
    gel_force_n: float
    contact_area_m2: float
    segment_pressure_pa: np.ndarray
    mean_pressure_pa: float
    indentation_m: np.ndarray
    bottomed: bool


@dataclass(frozen=True)
class _GelTable:
    """P(q) and dP/dq of the gel on a fine grid, for a fast np.interp every step.

    Compression (q >= 0) comes from :meth:`GelModel.pressure_from_indentation`; tension
    (q < 0, down to -retain) from the same Gent law stretched (P < 0).  2049 points on 4.5 mm:
    linear interpolation is within 1e-5 relative of the law (tests/test_models.py checks).
    """

    grid_m: np.ndarray
    pressure_pa: np.ndarray
    tangent_pa_m: np.ndarray

    @classmethod
    def build(cls, gel: GelModel, geometry: PadGeometry, points: int = 2049) -> _GelTable:
        grid = np.linspace(-geometry.retain_m, geometry.stop_m, points)
        compression = gel.pressure_from_indentation(np.clip(grid, 0.0, None))
        tension = gent_pressure_pa(1.0 - np.clip(grid, None, 0.0) / gel.params.thickness_m, gel.params)
        pressure = np.where(grid >= 0, compression, tension)
        return cls(grid, pressure, np.gradient(pressure, grid))


class PadBridge:
    """Applies the gel law to the pad joints and reads the pads, every step.

    Parameters
    ----------
    model : a model built by :func:`build_model` (any scene including ``gripper.xml``).  The
        bridge takes over its pad joints: it writes their ``jnt_stiffness`` (the gel's tangent)
        every step, so one bridge per model.  Use the ``discrete`` integrator (gripper.xml's):
        under the other integrators the stiffness is explicit and the bridge refuses timesteps
        past the explicit stability limit of the stiffest strip at its stop.
    gel : the gel model (default ``GelModel()``); its thickness must match the model's pads.
    geometry : the pad geometry; default: inferred from the model (strip count) and checked
        against it.

    Use::

        bridge = PadBridge(model)
        for _ in range(steps):
            bridge.apply_gel_forces(data)
            mujoco.mj_step(model, data)
            left, right = bridge.read(data).values()
    """

    def __init__(self, model: mujoco.MjModel, gel: GelModel | None = None, geometry: PadGeometry | None = None) -> None:
        self.model = model
        self.gel = gel or GelModel()
        if geometry is None:
            n = sum(1 for j in range(model.njnt) if model.joint(j).name.startswith("left_pad_seg"))
            if n == 0:
                raise ValueError("the model has no pad joints (left_pad_seg0_joint, ...): is gripper.xml included?")
            geometry = PadGeometry(segments=n, gel_thickness_m=self.gel.params.thickness_m)
        self.geometry = geometry
        if abs(geometry.gel_thickness_m - self.gel.params.thickness_m) > 1e-12:
            raise ValueError(f"PadGeometry.gel_thickness_m {geometry.gel_thickness_m} differs from the gel's {self.gel.params.thickness_m}")

        names = [name for side in PAD_SIDES for name in geometry.strip_names(side)]
        self._check_model(names)
        self.n_pads, self.n_strips = len(PAD_SIDES), len(geometry.strip_lengths_m)
        self._jnt = np.array([model.joint(f"{n}_joint").id for n in names])
        self._qadr = model.jnt_qposadr[self._jnt].copy()
        self._dof = model.jnt_dofadr[self._jnt].copy()
        self._qspring = model.qpos_spring[self._qadr].copy()
        self._area = np.tile(geometry.strip_areas_m2, self.n_pads)
        self._on_element = geometry.on_element
        self._table = _GelTable.build(self.gel, geometry)
        self._bottom_m = geometry.stop_m - 1e-7  # at the stop: within 0.1 um of it
        self._touch_m = 1e-6  # loaded: compressed by more than 1 um (about 6 Pa)
        self._qadr_element = self._qadr.reshape(self.n_pads, self.n_strips)[:, self._on_element].ravel()
        n_flat = self.n_pads * self.n_strips
        element = np.tile(self._on_element, self.n_pads)
        self._weights = np.stack((self._area, self._area, element / geometry.segments, np.ones(n_flat)))
        self._pad_sum = np.kron(np.eye(self.n_pads), np.ones((self.n_strips, 1)))  # (flat strips, pads)
        self._rows = np.empty((4, n_flat))  # scratch for read()
        self._element_slice = slice(1, -1) if geometry.has_guards else slice(None)  # element strips of one pad
        # joint id -> flat strip index (-1: not a pad joint), for the housing's limit forces.
        self._joint_strip = np.full(model.njnt, -1)
        self._joint_strip[self._jnt] = np.arange(n_flat)
        # geom id -> flat strip index (-1: not a pad strip), for contacts.
        self._geom_strip = np.full(model.ngeom, -1)
        for i, n in enumerate(names):
            self._geom_strip[model.geom(f"{n}_geom").id] = i
        self._elliptic = model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
        model.jnt_stiffnesspoly[self._jnt] = 0.0
        self._check_stability()
        # The per-step path: the gel law on every strip joint (cosim/pad_kernels.py, compiled
        # where built), bound to the arrays of the MjData it last saw; scalar reads on lists and
        # memoryviews (item access on them costs a fraction of a numpy scalar's).
        self._columns = (self._table.grid_m, self._table.pressure_pa, self._table.tangent_pa_m)
        self._lookup = UniformPairTable(*self._columns)
        self._gel_forces = GelForces(self._columns, self._qadr, self._dof, self._jnt, self._area, self._qspring)
        self._element_qadr = self._qadr_element.tolist()
        self._qadr_list = self._qadr.tolist()
        self._views_of: mujoco.MjData | None = None

    # -- set-up checks -------------------------------------------------------------------

    def _check_model(self, names: list[str]) -> None:
        m, g = self.model, self.geometry
        lengths = np.tile(g.strip_lengths_m, len(PAD_SIDES))
        for name, length in zip(names, lengths, strict=True):
            try:
                j, geom = m.joint(f"{name}_joint"), m.geom(f"{name}_geom")
            except KeyError as err:
                raise ValueError(f"the model's pads do not match {g}: missing {err}") from err
            if m.jnt_type[j.id] != mujoco.mjtJoint.mjJNT_SLIDE or not m.jnt_limited[j.id]:
                raise ValueError(f"pad joint {name}_joint must be a limited slide joint")
            expected = [-g.retain_m, g.stop_m]
            if not np.allclose(m.jnt_range[j.id], expected, rtol=0, atol=1e-9):
                raise ValueError(f"pad joint {name}_joint has range {m.jnt_range[j.id]}, the geometry needs {expected}")
            size = [0.5 * g.gel_thickness_m, 0.5 * g.pad_width_m, 0.5 * float(length)]
            if not np.allclose(m.geom_size[geom.id], size, rtol=0, atol=1e-9):
                raise ValueError(f"pad geom {name}_geom has size {m.geom_size[geom.id]}, the geometry needs {size}")

    def _check_stability(self) -> None:
        if self.model.opt.integrator == mujoco.mjtIntegrator.mjINT_DISCRETE:
            return
        k_max = self._area * np.interp(self.geometry.stop_m, self._table.grid_m, self._table.tangent_pa_m)
        omega = np.sqrt(k_max / self.model.dof_M0[self._dof])
        dt_max = float(2.0 / omega.max())
        if self.model.opt.timestep > dt_max:
            raise ValueError(
                f"the gel's stiffness is explicit under this integrator and needs timestep <= {dt_max:.2e} s "
                f"(have {self.model.opt.timestep:.2e}); use integrator 'discrete' (gripper.xml's)"
            )

    # -- every step ----------------------------------------------------------------------

    def apply_gel_forces(self, data: mujoco.MjData) -> None:
        """Write the gel's force on every strip joint; call before each ``mj_step``.

        Sets ``jnt_stiffness`` = A dP/dq (the tangent, so the integrator treats the law
        implicitly) and ``qfrc_applied`` = -A P(q) + A dP/dq (q - q_spring), so that the
        explicit force on the joint is exactly -A P(q).  Touches only the pad joints' entries.
        """
        if data is not self._views_of:
            self._data_views(data)
        self._gel_forces.apply()

    def __getstate__(self) -> dict:  # views are not copied: a copy makes its own
        return {k: v for k, v in self.__dict__.items() if k not in ("_views", "_views_of")}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._views_of = None  # the gel-force kernel (copied unbound) is bound at its first use

    @property
    def joint_ids(self) -> np.ndarray:
        """The ids of the pad strip joints whose stiffness :meth:`apply_gel_forces` writes."""
        return self._jnt

    def _data_views(self, data: mujoco.MjData) -> tuple[memoryview, memoryview]:
        """memoryviews of ``data.qpos`` and ``data.qfrc_applied`` (kept while the same MjData comes back)."""
        if data is not self._views_of:
            self._views = memoryview(data.qpos), memoryview(data.qfrc_applied)
            self._gel_forces.bind(data.qpos, data.qfrc_applied, self.model.jnt_stiffness)
            self._views_of = data
        return self._views

    def element_pressures(self, data: mujoco.MjData) -> np.ndarray:
        """Gel pressure over each element strip, Pa, shape (pads, segments); the sensor's input.

        Compressive only (tension reads 0: the gel rests unbonded on the element).  The cheapest
        read (about 2 us); :meth:`read` gives everything else.
        """
        return np.array(self.element_pressure_values(data)).reshape(self.n_pads, -1)

    def element_pressure_values(self, data: mujoco.MjData) -> list[float]:
        """:meth:`element_pressures` as a flat list of Python floats (pads in ``PAD_NAMES`` order,
        strips distal first): the co-simulation's per-step read, without numpy's overhead."""
        qpos = self._data_views(data)[0]
        lookup = self._lookup.at
        return [max(lookup(qpos[a])[0], 0.0) for a in self._element_qadr]

    def pressure_reader(self, strips: list[int], per_pad: int, element: list[int], weights: list[list[tuple[int, float]]]) -> PadPressures:
        """The co-simulation's per-step pressure read (:class:`cosim.pad_kernels.PyPadPressures`,
        compiled where built), unbound: the gel pressure of ``strips`` (flat indices: pads in
        ``PAD_NAMES`` order, strips distal first, guards included; ``per_pad`` a pad), Pa,
        compressive only, as each pad's element profile (``element``: positions among a pad's
        strips read) and coverage cells (``weights``).  Bind it to ``data.qpos``."""
        qadr = [self._qadr_list[i] for i in strips]
        return PadPressures(self._columns, qadr, per_pad, element, weights)

    def strip_pressures(self, data: mujoco.MjData) -> np.ndarray:
        """Gel pressure of every strip, guards included, Pa, shape (pads, strips); tension < 0."""
        q = data.qpos[self._qadr]
        return np.interp(q, self._table.grid_m, self._table.pressure_pa).reshape(self.n_pads, self.n_strips)

    def read(self, data: mujoco.MjData) -> dict[str, PadReading]:
        """Every pad's :class:`PadReading`, keyed by pad name (``PAD_NAMES`` order).

        Everything comes from the strips' indentation (the gel's state now), except the
        housing's share of the load when a pad is bottomed, which comes from the joint-limit
        forces of the last constraint solve.  No loop over contacts.
        """
        q = data.qpos[self._qadr]
        pressure = np.interp(q, self._table.grid_m, self._table.pressure_pa)
        compressive = np.maximum(pressure, 0.0)
        at_stop = q >= self._bottom_m
        # One weighted sum per pad for four quantities; rows: gel force N, loaded area m^2,
        # mean element pressure Pa, strips at the stop.
        rows = self._rows
        rows[0], rows[1], rows[2], rows[3] = pressure, q > self._touch_m, compressive, at_stop
        gel_force, area, mean, stops = (rows * self._weights) @ self._pad_sum
        normal = gel_force
        if at_stop.any():
            normal = gel_force + self._housing_forces(data, at_stop)
        segment = compressive.reshape(self.n_pads, self.n_strips)[:, self._element_slice]
        indentation = q.reshape(self.n_pads, self.n_strips)[:, self._element_slice]
        return {
            name: PadReading(
                name, float(normal[i]), float(gel_force[i]), float(area[i]), segment[i], float(mean[i]), indentation[i], bool(stops[i] > 0)
            )
            for i, name in enumerate(PAD_NAMES)
        }

    def _housing_forces(self, data: mujoco.MjData, at_stop: np.ndarray) -> np.ndarray:
        """Load carried by each pad's housing (its strips' upper joint limits), N, shape (pads,)."""
        rows = np.flatnonzero(data.efc_type == mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)
        strip = self._joint_strip[data.efc_id[rows]]
        keep = strip >= 0
        keep[keep] = at_stop[strip[keep]]  # the upper stop only, not the tension retainer
        per_strip = np.bincount(strip[keep], weights=data.efc_force[rows[keep]], minlength=self.n_pads * self.n_strips)
        return per_strip.reshape(self.n_pads, self.n_strips).sum(axis=1)

    def strip_contact_forces(self, data: mujoco.MjData) -> np.ndarray:
        """Contact normal force on every strip, N, shape (pads, strips), from the last constraint solve.

        A diagnostic (it reads ``data.contact``): divided by :attr:`PadGeometry.strip_areas_m2`
        it is the contact pressure, which equals :meth:`strip_pressures` in static equilibrium
        (tests/test_models.py checks).
        """
        n = self.n_pads * self.n_strips
        if data.ncon == 0:
            return np.zeros((self.n_pads, self.n_strips))
        contact = data.contact
        strip = self._geom_strip[contact.geom].max(axis=1)  # strip index, or -1; strips never touch strips
        efc = contact.efc_address
        keep = (strip >= 0) & (efc >= 0)  # efc < 0: detected but inactive (e.g. in the margin)
        if self._elliptic:  # the first row of an elliptic contact is its normal force
            force = data.efc_force[efc[keep]]
        else:  # pyramidal cones: let MuJoCo convert the edge forces
            f6 = np.zeros(6)
            force = np.empty(int(keep.sum()))
            for k, i in enumerate(np.flatnonzero(keep)):
                mujoco.mj_contactForce(self.model, data, int(i), f6)
                force[k] = f6[0]
        return np.bincount(strip[keep], weights=force, minlength=n).reshape(self.n_pads, self.n_strips)

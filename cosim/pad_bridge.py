"""The pads' per-step bridge: the gel law as joint forces, and the pads' state read back.

:class:`PadBridge` applies the gel's force law to every strip joint before each ``mj_step``
(models/README.md, "Pad compliance", says how: the law's tangent as the joint's stiffness, the
remainder as an applied force, so the ``discrete`` integrator treats it implicitly) and reads
the pads: pressures along the element, normal force, contact area, whether a pad is bottomed.
The strips are :mod:`cosim.pad_model`'s, their layout :mod:`cosim.pad_geometry`'s.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from piezotip.sensor.gel import GelModel, gent_pressure_pa

from .pad_geometry import PAD_SIDES, PadGeometry
from .pad_kernels import GelForces, PadPressures, UniformPairTable


@dataclass(frozen=True)
class PadReading:
    """What one pad feels at one instant.

    Attributes
    ----------
    name : the pad's name (``"left_pad"`` or ``"right_pad"`` on the house gripper).
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

    def tangent_at_stop_pa_m(self, geometry: PadGeometry) -> float:
        """The law's tangent dP/dq at the housing stop, Pa/m: the stiffest the gel gets."""
        return float(np.interp(geometry.stop_m, self.grid_m, self.tangent_pa_m))


def explicit_timestep_limit_s(stiffness_n_m, mass_kg) -> float:
    """The largest timestep at which an explicit integrator keeps springs of ``stiffness_n_m``
    on masses ``mass_kg`` stable, s: 2 / omega of the fastest (the central-difference limit)."""
    omega = np.sqrt(np.asarray(stiffness_n_m, float) / np.asarray(mass_kg, float))
    return float(2.0 / omega.max())


def check_gel_integration(option, stiffness_n_m, mass_kg) -> None:
    """Refuse integrating the gel at ``option``'s timestep when its integrator makes the gel's
    stiffness explicit and the stiffest strip (``stiffness_n_m`` on ``mass_kg``, at its stop)
    is unstable there; ``option`` is an ``MjModel.opt`` or an ``MjSpec.option``.  The
    ``discrete`` integrator folds the stiffness into its implicit step: stable at any step."""
    if option.integrator == mujoco.mjtIntegrator.mjINT_DISCRETE:
        return
    dt_max = explicit_timestep_limit_s(stiffness_n_m, mass_kg)
    if option.timestep > dt_max:
        name = mujoco.mjtIntegrator(option.integrator).name
        raise ValueError(
            f"the gel's stiffness is explicit under integrator {name} and needs timestep <= {dt_max:.2e} s "
            f"(have {option.timestep:.2e}); use integrator 'discrete' (gripper.xml's)"
        )


class PadBridge:
    """Applies the gel law to the pad joints and reads the pads, every step.

    Parameters
    ----------
    model : a model built by :func:`build_model` (any scene including ``gripper.xml``), or any
        model whose pads :func:`cosim.pad_model.add_pad_strips` built (``pads``).  The bridge
        takes over its pads' joints: it writes their ``jnt_stiffness`` (the gel's tangent) every
        step, so no two bridges may share a pad.  Use the ``discrete``
        integrator (gripper.xml's): under the other integrators the stiffness is explicit and
        the bridge refuses timesteps past the explicit stability limit of the stiffest strip at
        its stop (:func:`explicit_timestep_limit_s`).
    gel : the gel model (default ``GelModel()``); its thickness must match the model's pads.
    geometry : the pad geometry, one for every pad; default: inferred from the house gripper's
        pads (their strip count) and checked against the model.
    pads : per pad name, its strips' body names, distal first (:meth:`PadGeometry.strip_body_names`);
        default the house gripper's two pads (``PAD_NAMES``).  Needs ``geometry``.
    check_integration : refuse an explicit integrator at a step the stiffest strip is unstable
        at (True); False where the law is applied otherwise (``piezotip.attach``'s
        :class:`cosim.mjhooks.GelPassive`, which scales the strips' masses instead).

    Use::

        bridge = PadBridge(model)
        for _ in range(steps):
            bridge.apply_gel_forces(data)
            mujoco.mj_step(model, data)
            left, right = bridge.read(data).values()
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        gel: GelModel | None = None,
        geometry: PadGeometry | None = None,
        pads: Mapping[str, Sequence[str]] | None = None,
        check_integration: bool = True,
    ) -> None:
        self.model = model
        self.gel = gel or GelModel()
        if pads is not None and geometry is None:
            raise ValueError("PadBridge: pads given without their geometry")
        if geometry is None:
            n = sum(1 for j in range(model.njnt) if model.joint(j).name.startswith("left_pad_seg"))
            if n == 0:
                raise ValueError("the model has no pad joints (left_pad_seg0_joint, ...): is gripper.xml included?")
            geometry = PadGeometry(segments=n, gel_thickness_m=self.gel.params.thickness_m)
        self.geometry = geometry
        if abs(geometry.gel_thickness_m - self.gel.params.thickness_m) > 1e-12:
            raise ValueError(f"PadGeometry.gel_thickness_m {geometry.gel_thickness_m} differs from the gel's {self.gel.params.thickness_m}")

        if pads is None:
            pads = {f"{side}_pad": geometry.strip_names(side) for side in PAD_SIDES}
        self.pad_names = tuple(pads)
        """The pads, in the order of every per-pad array and reading."""
        self.n_pads, self.n_strips = len(self.pad_names), len(geometry.strip_lengths_m)
        for pad, strips in pads.items():
            if len(strips) != self.n_strips:
                raise ValueError(f"PadBridge: pad {pad!r} names {len(strips)} strips, the geometry has {self.n_strips}")
        names = [name for strips in pads.values() for name in strips]
        self._check_model(names)
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
        if check_integration:
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
        lengths = np.tile(g.strip_lengths_m, self.n_pads)
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
        k_max = self._area * self._table.tangent_at_stop_pa_m(self.geometry)
        check_gel_integration(self.model.opt, k_max, self.model.dof_M0[self._dof])

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

    def gel_forces_on(self, data: mujoco.MjData) -> Callable[[], None]:
        """:meth:`apply_gel_forces` on ``data`` as a call without arguments, for a loop that
        calls it every period (cosim/_period.py): a gel-force kernel of its own, bound to
        ``data`` for good (whatever MjData :meth:`apply_gel_forces` is given later)."""
        kernel = copy.copy(self._gel_forces)  # unbound (GelForces.__reduce__)
        kernel.bind(data.qpos, data.qfrc_applied, self.model.jnt_stiffness)
        return kernel.apply

    def __getstate__(self) -> dict:  # views are not copied: a copy makes its own
        return {k: v for k, v in self.__dict__.items() if k not in ("_views", "_views_of")}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._views_of = None  # the gel-force kernel (copied unbound) is bound at its first use

    @property
    def table(self) -> _GelTable:
        """The gel law on its grid (P(q), dP/dq), as every step reads it."""
        return self._table

    def strip_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every strip's qpos address, dof address, joint id and area (m^2), pads in
        :attr:`pad_names` order, strips distal first."""
        return self._qadr.copy(), self._dof.copy(), self._jnt.copy(), self._area.copy()

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
        """:meth:`element_pressures` as a flat list of Python floats (pads in :attr:`pad_names` order,
        strips distal first): the co-simulation's per-step read, without numpy's overhead."""
        qpos = self._data_views(data)[0]
        lookup = self._lookup.at
        return [max(lookup(qpos[a])[0], 0.0) for a in self._element_qadr]

    def pressure_reader(self, strips: list[int], per_pad: int, element: list[int], weights: list[list[tuple[int, float]]]) -> PadPressures:
        """The co-simulation's per-step pressure read (:class:`cosim.pad_kernels.PyPadPressures`,
        compiled where built), unbound: the gel pressure of ``strips`` (flat indices: pads in
        :attr:`pad_names` order, strips distal first, guards included; ``per_pad`` a pad), Pa,
        compressive only, as each pad's element profile (``element``: positions among a pad's
        strips read) and coverage cells (``weights``).  Bind it to ``data.qpos``."""
        qadr = [self._qadr_list[i] for i in strips]
        return PadPressures(self._columns, qadr, per_pad, element, weights)

    def strip_pressures(self, data: mujoco.MjData) -> np.ndarray:
        """Gel pressure of every strip, guards included, Pa, shape (pads, strips); tension < 0."""
        q = data.qpos[self._qadr]
        return np.interp(q, self._table.grid_m, self._table.pressure_pa).reshape(self.n_pads, self.n_strips)

    def read(self, data: mujoco.MjData) -> dict[str, PadReading]:
        """Every pad's :class:`PadReading`, keyed by pad name (:attr:`pad_names` order).

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
            for i, name in enumerate(self.pad_names)
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

"""The fingertips inside a plain ``mujoco.mj_step``: MuJoCo's callbacks, dispatched by MjData.

MuJoCo calls ``mjcb_passive`` (extra passive forces) and ``mjcb_sensor`` (``user`` sensors)
from inside ``mj_step``/``mj_forward``, for every model in the process: the callbacks are
process-global.  :func:`register` installs one dispatcher for each, once, and runs a hook only
for the MjData it was registered with; for any other MjData the dispatchers return at once, so
a model without fingertips steps bit for bit as it did (``tests/test_attach_sensordata.py``).
A C callback (a ctypes function pointer) set before the first :func:`register` (yours) is kept and
called first, for every model; a Python callable there is refused (MuJoCo cannot call it for the
models it compiles); one set after it replaces the dispatcher (set yours first).

Two hooks ride on this (:class:`GelPassive`, and the readout of :class:`cosim.attach.FingertipLoop`):

- the gel law on every pad strip joint, in ``mjcb_passive``, one vectorized call for all the
  fingertips of a model (models/README.md, "Pad compliance");
- the sensor readout, in ``mjcb_sensor`` at the position stage, writing the fingertips'
  ``user`` sensors (``piezotip/TIP/pressure_pa``, ...) into ``data.sensordata``.

Python callbacks hold the GIL: a model stepped from several threads (``mujoco.rollout``) runs
its hooks one thread at a time.
"""

from __future__ import annotations

import ctypes
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import mujoco
import numpy as np

__all__ = ["EXPLICIT_OMEGA_H", "GelPassive", "Hook", "hooks_of", "raise_failure", "register", "unregister"]

#: The strips' ring frequency times the step under an explicit integrator (:class:`GelPassive`'s
#: mass scaling): a quarter of the explicit stability limit omega h < 2.  Measured at 2 ms on a
#: pressed pad and on a 20 g finger pressing 1-10 N: omega h = 1 with the damping below still
#: rang at 10-50 % of the load; 0.5 holds the load to 1e-8 under Euler, RK4, implicit and
#: implicitfast.
EXPLICIT_OMEGA_H = 0.5


#: The callbacks a hook can ride on.
CALLBACKS = ("passive", "sensor")


class Hook(Protocol):
    """What :func:`register` runs for one MjData: the methods of the callbacks it names in an
    attribute ``callbacks`` (a subset of :data:`CALLBACKS`; without it, both).  A callback no
    registered hook needs is not installed: the steps of every model in the process skip it."""

    def passive(self, model: mujoco.MjModel, data: mujoco.MjData) -> None: ...

    def sensor(self, model: mujoco.MjModel, data: mujoco.MjData, stage: int) -> None: ...


#: MuJoCo's callback signatures.  The dispatchers are C function pointers (ctypes), called with
#: the raw mjModel* and mjData* addresses: MuJoCo also calls the callbacks on models and data
#: that have no Python object (``MjSpec.compile``, ``MjModel.from_xml_*`` run ``mj_setConst``),
#: where a Python callable fails ("Python exception raised"), so the dispatch is by address.
_PASSIVE_T = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)
_SENSOR_T = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int)


@dataclass
class _Bound:
    """One registered MjData (weakly held: a dropped MjData takes its hooks along), its hooks in
    order, and those of each callback."""

    data: weakref.ref
    model: mujoco.MjModel
    hooks: list[Hook]
    passive: list[Hook]
    sensor: list[Hook]
    #: The first exception a hook raised inside MuJoCo's step, until :func:`raise_failure` takes it.
    error: BaseException | None = None


def _callbacks(hook: Hook) -> tuple[str, ...]:
    needs = tuple(getattr(hook, "callbacks", CALLBACKS))
    if not set(needs) <= set(CALLBACKS):
        raise ValueError(f"a hook's callbacks must be among {CALLBACKS}, got {needs}")
    return needs


def _failed(bound: _Bound, err: BaseException) -> None:
    """A hook raised inside ``mj_step``, whose C cannot take a Python exception: ctypes prints it
    and MuJoCo steps on.  The first is kept for :func:`raise_failure` (piezotip's own loop raises
    it: a Ctrl-C that landed in the callback too); a plain loop sees it printed."""
    if bound.error is None:
        bound.error = err
    raise err


def raise_failure(data: mujoco.MjData, who: str) -> None:
    """Raise, once, the exception a hook of ``data`` raised inside MuJoCo's step (RuntimeError
    naming ``who`` and the exception, chained to it), if one did."""
    bound = _bound(data._address)
    if bound is not None and bound.error is not None:
        err, bound.error = bound.error, None
        if isinstance(err, KeyboardInterrupt):  # Ctrl-C (or SIGTERM, as piezotip raises it) in the callback
            raise err
        raise RuntimeError(f"{who}: the fingertips failed inside mj_step: {type(err).__name__}: {err}") from err


#: The registered MjData by their mjData* address.
_BOUND: dict[int, _Bound] = {}
#: Of the registered MjData whose sensor hooks are one hook with a fast path (its
#: ``fast_sensor()``: a callable of the stage, compiled, that reads the time itself and returns
#: < 0 where the hook's own ``sensor`` must run), that path by address: the sensor dispatcher
#: calls it before anything else of the MjData is looked up or made (no Python object of it).
_FAST: dict[int, Callable[[int], int]] = {}
#: The callbacks found before the dispatchers were installed (C function pointers, called first,
#: for every model).
_PREVIOUS: dict[str, Callable | None] = {"passive": None, "sensor": None}


def _bound(data_address: int) -> _Bound | None:
    bound = _BOUND.get(data_address)
    if bound is not None and bound.data() is None:  # freed: the address may be another MjData's now
        del _BOUND[data_address]
        _FAST.pop(data_address, None)
        _sync()
        return None
    return bound


def _run_passive(data_address: int) -> None:
    bound = _bound(data_address)
    if bound is not None:
        data = bound.data()
        try:
            for hook in bound.passive:
                hook.passive(bound.model, data)
        except BaseException as err:
            _failed(bound, err)


def _run_sensor(data_address: int, stage: int) -> None:
    bound = _bound(data_address)
    if bound is not None:
        data = bound.data()
        try:
            for hook in bound.sensor:
                hook.sensor(bound.model, data, stage)
        except BaseException as err:
            _failed(bound, err)


@_PASSIVE_T
def _passive(model_address: int, data_address: int) -> None:
    previous = _PREVIOUS["passive"]
    if previous is not None:
        previous(model_address, data_address)
    _run_passive(data_address)


@_SENSOR_T
def _sensor(model_address: int, data_address: int, stage: int) -> None:
    previous = _PREVIOUS["sensor"]
    if previous is not None:
        previous(model_address, data_address, stage)
    fast = _FAST.get(data_address)
    if fast is not None:
        try:
            if fast(stage) >= 0:
                return
        except BaseException as err:
            _failed(_BOUND[data_address], err)
    _run_sensor(data_address, stage)


# What the C dispatchers (cosim/_mjcallbacks.pyx) call into Python for a bound MjData: its
# hooks, nothing before them (the C calls the previous callbacks itself).
_passive_hooks = _PASSIVE_T(lambda model_address, data_address: _run_passive(data_address))
_sensor_hooks = _SENSOR_T(lambda model_address, data_address, stage: _run_sensor(data_address, stage))


def _failed_at(data_address: int, err: BaseException) -> None:
    _failed(_BOUND[data_address], err)


def _c_dispatchers():
    """The compiled dispatchers (cosim/_mjcallbacks.pyx) as ctypes function pointers
    ({name: pointer}) and their module, or None where they were not built (or under
    ``PIEZOTIP_PURE_PYTHON``): the Python ones run then, the same hooks in the same order."""
    from piezotip.sensor import compiled

    if compiled.PURE_PYTHON:
        return None
    try:
        from . import _mjcallbacks
    except (ImportError, ValueError, TypeError):  # not built, or its kernel (cosim._readout) not compiled
        return None
    passive_at, sensor_at = _mjcallbacks.addresses()
    return {"passive": _PASSIVE_T(passive_at), "sensor": _SENSOR_T(sensor_at)}, _mjcallbacks


#: The Python dispatchers by callback, and the compiled ones with their module (None where not built).
_PYTHON: dict[str, ctypes._CFuncPtr] = {"passive": _passive, "sensor": _sensor}
_C = _c_dispatchers()
#: The dispatchers in use: {name: the ctypes function pointer MuJoCo is given}, the C ones
#: where built, else the Python ones (:func:`use_compiled`).
_DISPATCHERS: dict[str, ctypes._CFuncPtr] = dict(_C[0] if _C is not None else _PYTHON)
#: Every dispatcher of this module's, C or Python (one of them is never another's previous callback).
_OURS = {id(f) for f in (*_PYTHON.values(), *(_C[0].values() if _C is not None else ()))}


def compiled_dispatch() -> bool:
    """Whether MuJoCo's callbacks are dispatched in C (cosim/_mjcallbacks.pyx) for the hooks
    registered from now on."""
    return _DISPATCHERS["sensor"] is not _PYTHON["sensor"]


def use_compiled(flag: bool) -> None:
    """Dispatch in C (where built: ValueError otherwise) or in Python from the next
    :func:`register` on (tests run both; the hooks run the same either way)."""
    global _DISPATCHERS
    if flag and _C is None:
        raise ValueError("use_compiled: the C dispatchers (cosim/_mjcallbacks.pyx) were not built")
    _DISPATCHERS = dict(_C[0] if flag else _PYTHON)


def _address(pointer) -> int:
    return ctypes.cast(pointer, ctypes.c_void_p).value or 0 if pointer is not None else 0


def _sync() -> None:
    """Tell the C dispatchers which MjData have hooks (after any change of :data:`_BOUND` or
    :data:`_FAST`)."""
    if _C is None:
        return
    passive = [a for a, b in _BOUND.items() if b.passive]
    sensor = [a for a, b in _BOUND.items() if b.sensor]
    _C[1].set_tables(passive, sensor, [a in _FAST for a in sensor], [_tick_owner(_FAST.get(a)) for a in sensor])


def _tick_owner(fast: Callable | None) -> object | None:
    """The readout pass whose tick the fast path is (the C dispatcher takes its steps in C:
    ``cosim._readout.ReadoutPass.quick_state``), else None."""
    return getattr(fast, "__self__", None) if getattr(fast, "__name__", "") == "tick" else None


def _install(needs: tuple[str, ...] = CALLBACKS) -> None:
    """Set the dispatchers of the callbacks ``needs`` as MuJoCo's, chaining a C one set before.

    Each only once a hook needs it: an installed Python dispatcher costs every ``mj_step`` of
    every model in the process a Python call (about 0.45 us), fingertips or not; the C one a
    scan of the bound MjData's addresses."""
    for name, get, put in (
        ("passive", mujoco.get_mjcb_passive, mujoco.set_mjcb_passive),
        ("sensor", mujoco.get_mjcb_sensor, mujoco.set_mjcb_sensor),
    ):
        if name not in needs:
            continue
        dispatcher, current = _DISPATCHERS[name], get()
        if current is dispatcher:
            continue
        if id(current) not in _OURS:  # (ours, the other kind: replaced, not chained)
            if current is not None and not isinstance(current, ctypes._CFuncPtr):
                raise ValueError(
                    f"bind: MuJoCo's mjcb_{name} is already set to {current!r}, a Python callable, which the fingertips' "
                    f"callback cannot call for models that have no Python object; set it as a ctypes function pointer "
                    f"(it is then called first), or clear it (mujoco.set_mjcb_{name}(None))"
                )
            _PREVIOUS[name] = current
        put(dispatcher)
    if _C is not None:
        previous = (_address(_PREVIOUS["passive"]), _address(_PREVIOUS["sensor"]))
        _C[1].configure(*previous, _address(_passive_hooks), _address(_sensor_hooks), _FAST, _failed_at)


def register(data: mujoco.MjData, model: mujoco.MjModel, hook: Hook) -> None:
    """Run ``hook`` inside every ``mj_step``/``mj_forward`` of ``data`` (``model``'s), after any
    earlier hook of it, for as long as ``data`` lives (held weakly; the hook strongly, so that a
    loop that keeps only its model and data keeps its fingertips: hooks must not hold ``data``)."""
    needs = _callbacks(hook)
    _install(needs)
    address = data._address
    bound = _bound(address)
    if bound is None:

        def forget(ref: weakref.ref, address: int = address) -> None:  # the MjData is gone: so are its hooks
            if (entry := _BOUND.get(address)) is not None and entry.data is ref:
                del _BOUND[address]
                _FAST.pop(address, None)
                _sync()

        bound = _BOUND[address] = _Bound(weakref.ref(data, forget), model, [], [], [])
    bound.hooks.append(hook)
    for name in needs:
        getattr(bound, name).append(hook)
    _refresh(address)


def unregister(data: mujoco.MjData, hook: Hook) -> None:
    """Stop running ``hook`` for ``data`` (nothing if it is not registered)."""
    bound = _bound(data._address)
    if bound is not None and hook in bound.hooks:
        bound.hooks.remove(hook)
        for hooks in (bound.passive, bound.sensor):
            if hook in hooks:
                hooks.remove(hook)
        _refresh(data._address)


def refresh(data: mujoco.MjData) -> None:
    """Take the fast path of ``data``'s sensor hook anew (a hook whose ``fast_sensor()`` changed
    calls it: :data:`_FAST`)."""
    _refresh(data._address)


def _refresh(address: int) -> None:
    bound = _bound(address)
    fast = None
    if bound is not None and len(bound.sensor) == 1:
        make = getattr(bound.sensor[0], "fast_sensor", None)
        fast = make() if make is not None else None
    if fast is None:
        _FAST.pop(address, None)
    else:
        _FAST[address] = fast
    _sync()


def hooks_of(data: mujoco.MjData) -> tuple[Hook, ...]:
    """The hooks registered for ``data``, in the order they run."""
    bound = _bound(data._address)
    return tuple(bound.hooks) if bound is not None else ()


class GelPassive:
    """The gel's force law on pad strip joints as MuJoCo passive forces, every physics step.

    For each strip of area A (m^2) and indentation q (m), the joint's spring force (whatever
    ``jnt_stiffness`` made it) is replaced by the gel's, -A P(q) (N; P the gel law, Pa:
    models/README.md, "Pad compliance"), so every static state is exact under any integrator.
    How the law's stiffness A dP/dq (N/m, up to 180x the small-strain one near the housing
    stop) stays stable at the model's step depends on the integrator:

    - ``discrete`` (implicit in position): ``jnt_stiffness`` = A dP/dq, folded into the step's
      metric M + h D + h^2 K: a Newton-linearized backward Euler, stable at any step.
    - ``Euler``, ``RK4``, ``implicit``, ``implicitfast`` (the stiffness is explicit), two
      devices on the strip's own slide, each written every step from the tangent k = A dP/dq:

      * *mass scaling*, as explicit finite-element codes do it (mass added where an element's
        stable time step is below the analysis step): the armature that brings the strip's ring
        frequency to omega = sqrt(k / m) <= :data:`EXPLICIT_OMEGA_H` / h (m the strip's gel mass
        plus armature, kg: armature = max(0, k (h / 0.5)^2 - m_gel));
      * the *numerical damping backward Euler has*: damping c = h k (N s/m) beside the gel's own
        loss.  Backward Euler (the ``discrete`` step) dissipates a spring's ringing at a damping
        ratio omega h / 2, i.e. c = omega h sqrt(k m) = h k; the explicit integrators do not,
        and a strip on a hard contact then rings in a limit cycle (measured: the pressed pad of
        tests/test_attach.py at 2 ms under Euler swung 10-123 % of its load without it).

      Armature is inertia on the strip's slide only and damping acts on its velocity: neither
      has weight nor any effect on a static state, which the law gives exactly.  MuJoCo reads
      both for the next step (it builds the mass matrix and passive forces before this hook).
      What they change is the pad's dynamics above 1 / (2 h) (the strip's ring-up, faster than
      a step resolves): tests/test_attach_sensordata.py measures a touch against the
      ``discrete`` reference.

    Parameters
    ----------
    model : the compiled model (its ``jnt_stiffness`` or ``dof_armature`` entries of the strip
        joints are written every step).
    qadr, dof, joint : the strip joints' qpos addresses, dof addresses and joint ids.
    area_m2 : each strip's area, m^2.
    grid_m, pressure_pa, tangent_pa_m : the gel law P(q) (Pa) and dP/dq (Pa/m) on a grid of q (m).
    hold_s : 0 (the law at every step, ``physics.gel_update=substep``), or a period, s, over which
        the law is linearized once, at the period's first step (``control``: P(q0) + dP/dq (q - q0),
        as the house loop holds it; the periods counted from t = 0 on ``data.time``).
    """

    #: The gel law rides on the passive callback alone (:class:`Hook`).
    callbacks = ("passive",)

    def __init__(
        self,
        model: mujoco.MjModel,
        qadr: np.ndarray,
        dof: np.ndarray,
        joint: np.ndarray,
        area_m2: np.ndarray,
        grid_m: np.ndarray,
        pressure_pa: np.ndarray,
        tangent_pa_m: np.ndarray,
        hold_s: float = 0.0,
    ) -> None:
        from .pad_kernels import PassiveGelForces

        self.model = model
        self._qadr, self._dof, self._jnt = np.asarray(qadr), np.asarray(dof), np.asarray(joint)
        self._area = np.asarray(area_m2, float)
        self._grid, self._pressure, self._tangent = grid_m, pressure_pa, tangent_pa_m
        self.implicit = model.opt.integrator == mujoco.mjtIntegrator.mjINT_DISCRETE
        self._h = float(model.opt.timestep)
        self._hold_s, self._held_period, self._last_s = float(hold_s), None, -np.inf
        # The arithmetic, all strips in one call (cosim/_pad_kernels.py, compiled where built).
        self._kernel = PassiveGelForces(
            (grid_m, pressure_pa, tangent_pa_m),
            self._qadr.tolist(),
            self._dof.tolist(),
            self._jnt.tolist(),
            self._area.tolist(),
            model.body_mass[model.jnt_bodyid[self._jnt]].tolist(),  # the strips' gel, kg
            model.dof_damping[self._dof].tolist(),  # the gel's own loss, N s/m
            self._h,
            EXPLICIT_OMEGA_H,
        )
        model.jnt_stiffnesspoly[self._jnt] = 0.0
        self._views_of = None  # a weak reference to the MjData the kernel is bound to (the hooks must not keep it alive)
        if not self.implicit:
            model.jnt_stiffness[self._jnt] = 0.0  # the law is all in the passive force
            # The masses at qpos0, before any MjData: the kernel on the model's arrays alone (its
            # force arrays, zeros, are not written by scale_masses; the first step binds a data's).
            nowhere = np.zeros(model.nv)
            self._kernel.bind(model.qpos0, nowhere, nowhere, model.jnt_stiffness, model.dof_armature, model.dof_damping)
            self._kernel.scale_masses(self._area * np.interp(model.qpos0[self._qadr], grid_m, tangent_pa_m))

    def _bind(self, data: mujoco.MjData) -> None:
        """The kernel on ``data``'s arrays (kept while the same MjData comes back)."""
        if self._views_of is None or data is not self._views_of():
            m = self.model
            self._kernel.bind(data.qpos, data.qfrc_passive, data.qfrc_spring, m.jnt_stiffness, m.dof_armature, m.dof_damping)
            self._views_of = weakref.ref(data)

    def armature_kg(self) -> np.ndarray:
        """The strips' armature now, kg (zero under ``discrete``)."""
        return self.model.dof_armature[self._dof].copy()

    def _held(self, data: mujoco.MjData) -> bool:
        """Whether the law is held linearized at this step (``hold_s``), linearizing it afresh at
        a period's first step; the same for every call at one time."""
        if self._hold_s <= 0.0:
            return False
        period = int((data.time + 0.5 * self._h) // self._hold_s)
        changed = self._kernel.changed()
        # Time going back, or the state changed at the same time (a reset or an edited state
        # forwarded again): linearize afresh.
        if data.time < self._last_s - 0.5 * self._h or (data.time == self._last_s and changed):
            self._held_period = None
        self._last_s = data.time
        if period != self._held_period:  # a new period: linearize the law at q
            self._held_period = period
            self._kernel.linearize()
        return True

    def prepare(self, data: mujoco.MjData) -> None:
        """Before an ``mj_step`` of ``data``: the ``discrete`` integrator's stiffness at the
        step's own state.  MuJoCo reads ``jnt_stiffness`` for the step's implicit metric before
        the passive callback, so in a plain loop the hook's tangent is one step old (the force,
        the law's own, is not); a loop that can call this first (:meth:`FingertipLoop.step`)
        linearizes at the step's state, as the house loop does."""
        if self.implicit:
            self._bind(data)
            self._kernel.stiffness(self._held(data))

    def passive(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self._bind(data)
        self._kernel.apply(self.implicit, self._held(data))

    def sensor(self, model: mujoco.MjModel, data: mujoco.MjData, stage: int) -> None:
        return None

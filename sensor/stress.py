"""Static bending of the element under pressure, against the ceramic's strength.

Physics reference: ``shared/physics.md`` section 7.  The element must survive 1 MPa (the
paper's proof load was 1.3 MPa).  A uniform pressure P over the coverage [x1, x2] is a line
load q = P b (N/m).  The bending moment follows from statics (and, for the statically
indeterminate clamped-clamped beam, from zero end slope and deflection); the outer fibre of
a PZT layer, at y = t_s + t_p from the neutral axis, carries

    sigma = Y_p (t_s + t_p) |M| / EI        [Pa]

Two mountings are modelled, and the report says which:

- ``free-span``: the beam bends freely, however far; a cantilever under 1 MPa over its
  whole length would see ~0.8 GPa, ten times what PZT survives.
- ``backed`` (default): a rigid backstop sits ``backstop_gap_m`` behind the beam (the
  housing).  The beam bends freely until its largest deflection reaches the gap; beyond
  that the housing carries the extra load and the bending stress stays at its value at
  contact.  That is how an element survives a 1.3 MPa proof load.  While the beam rests on
  the backstop its vibration is not that of the free beam: readings there are outside the
  model, which the report flags (``on_backstop``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .element import SensorElement, _require_positive
from .modes import Boundary

_MOUNTINGS = ("backed", "free-span")
_GRID = 2001


@dataclass(frozen=True)
class Mounting:
    """How the element is held.

    Attributes
    ----------
    kind : "backed" (a backstop behind the beam) or "free-span".
    backstop_gap_m : gap between the unloaded beam and the backstop, m.  20 um: a lapped
        shim; the first mode's free vibration at 10 V drive is well under a micrometre, so
        the gap never touches in operation, and it caps the cantilever's stress near 20 MPa.
    pzt_strength_pa : allowed tensile (bending) stress in the PZT, Pa.  70 MPa: soft PZT
        ceramics' flexural strength is 60-100 MPa in manufacturers' data; the low end, as a
        ceramic's strength scatters (Weibull).
    """

    kind: str = "backed"
    backstop_gap_m: float = 20e-6
    pzt_strength_pa: float = 70e6

    def __post_init__(self) -> None:
        if self.kind not in _MOUNTINGS:
            raise ValueError(f"unknown mounting {self.kind!r}; valid: {', '.join(_MOUNTINGS)}")
        _require_positive(self)


@dataclass(frozen=True)
class StressReport:
    """Bending stress at each pressure (arrays shaped like the pressure).

    Attributes
    ----------
    pressure_pa : Pa.
    stress_pa : largest PZT bending stress, Pa (capped at backstop contact when backed).
    max_deflection_m : largest static deflection, m (at most the gap when backed).
    on_backstop : True where a backed beam rests on its backstop.
    overstressed : True where stress_pa exceeds the mounting's strength.
    mounting : the Mounting the numbers are for.
    """

    pressure_pa: np.ndarray
    stress_pa: np.ndarray
    max_deflection_m: np.ndarray
    on_backstop: np.ndarray
    overstressed: np.ndarray
    mounting: Mounting

    @property
    def ok(self) -> bool:
        """True when no pressure overstresses the ceramic."""
        return not bool(np.any(self.overstressed))


def unit_load_response(
    length_m: float, boundary: Boundary, coverage: tuple[float, float], bending_stiffness: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, M(x), w(x)) for a unit line load (1 N/m) over ``coverage``; M in N m, w in m.

    M(x) = M0 + V0 x - Q(x) with Q(x) = integral_0^x q(s) (x - s) ds; the two constants come
    from the boundary: clamped-free M(L) = M'(L) = 0; simply supported M(0) = M(L) = 0;
    clamped-clamped zero slope and deflection at L.  w'' = M / EI integrated from x = 0.
    """
    x = np.linspace(0.0, length_m, _GRID)
    q = ((x >= coverage[0]) & (x <= coverage[1])).astype(float)
    dx = x[1] - x[0]

    def cumint(f: np.ndarray) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * dx)])

    shear = cumint(q)  # integral_0^x q
    load_moment = cumint(shear)  # Q(x), since Q' = integral_0^x q
    if boundary is Boundary.CLAMPED_FREE:
        v0 = shear[-1]
        m0 = load_moment[-1] - v0 * length_m
    elif boundary is Boundary.SIMPLY_SUPPORTED:
        m0, v0 = 0.0, load_moment[-1] / length_m
    else:
        # Slope and deflection at L from M = m0 * 1 + v0 * x - Q, each integrated from 0.
        cols = [np.ones_like(x), x, -load_moment]
        slope = [cumint(c) for c in cols]
        defl = [cumint(s) for s in slope]
        a = np.array([[slope[0][-1], slope[1][-1]], [defl[0][-1], defl[1][-1]]])
        rhs = -np.array([slope[2][-1], defl[2][-1]])
        m0, v0 = np.linalg.solve(a, rhs)
    moment = m0 + v0 * x - load_moment
    slope = cumint(moment / bending_stiffness)
    if boundary is Boundary.SIMPLY_SUPPORTED:
        w_no_rotation = cumint(slope)
        slope = slope - w_no_rotation[-1] / length_m  # pick w'(0) so that w(L) = 0
    deflection = cumint(slope)
    return x, moment, deflection


def stress_report(element: SensorElement, pressure_pa: np.ndarray, coverage: tuple[float, float], mounting: Mounting) -> StressReport:
    """The element's :class:`StressReport` under uniform ``pressure_pa`` (Pa) over ``coverage``."""
    p = element.params
    _, moment, deflection = unit_load_response(p.length_m, element.boundary, coverage, p.bending_stiffness_n_m2)
    per_pa_stress = (
        p.pzt_youngs_pa * (p.substrate_half_thickness_m + p.pzt_thickness_m) * np.max(np.abs(moment)) / p.bending_stiffness_n_m2 * p.width_m
    )
    per_pa_deflection = np.max(np.abs(deflection)) * p.width_m
    pressure = np.asarray(pressure_pa, float)
    stress = per_pa_stress * pressure
    deflection_m = per_pa_deflection * pressure
    on_backstop = np.zeros(pressure.shape, bool)
    if mounting.kind == "backed":
        on_backstop = deflection_m > mounting.backstop_gap_m
        cap = mounting.backstop_gap_m / per_pa_deflection
        stress = per_pa_stress * np.minimum(pressure, cap)
        deflection_m = np.minimum(deflection_m, mounting.backstop_gap_m)
    return StressReport(pressure, stress, deflection_m, on_backstop, stress > mounting.pzt_strength_pa, mounting)

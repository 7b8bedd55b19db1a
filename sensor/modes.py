"""Euler-Bernoulli bending modes of a uniform beam, numerically stable to high order.

Physics reference: ``shared/physics.md`` section 2.

The textbook mode shape ``cosh(bx) - cos(bx) - sigma (sinh(bx) - sin(bx))`` cancels two
numbers of size ``e^(bL)`` and loses every digit by mode 12 or so.  Here every mode is
written on the bounded basis

    Z(x) = a1 cos(bx) + a2 sin(bx) + a3 exp(-bx) + a4 exp(-b (L - x)),

whose four functions never exceed 1 on [0, L].  The boundary conditions give a 4x4 system
in (a1..a4) with entries of order one; its null vector (from an SVD) is the mode.  The
characteristic roots are found from the equally well-conditioned forms
``cos z + 1/cosh z = 0`` (clamped-free) and ``cos z - 1/cosh z = 0`` (clamped-clamped), and
``z = n pi`` exactly for the simply supported beam.

Everything here is dimensionless in ``xi = x / L`` except where a function says otherwise.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from .cache import disk_cached
from .numerics import brentq

#: Gauss-Legendre nodes per panel used for every modal integral (exact for polynomials of
#: degree 2*12-1 = 23 on each panel).
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(12)

#: Largest mode number accepted; far beyond any drive frequency of interest (mode 200 of
#: the Table I cantilever is near 1.5 GHz), and the stable basis stays exact there.
MAX_MODE = 200


class Boundary(StrEnum):
    """Support conditions of the beam at x = 0 and x = L."""

    CLAMPED_FREE = "clamped-free"
    SIMPLY_SUPPORTED = "simply-supported"
    CLAMPED_CLAMPED = "clamped-clamped"

    @classmethod
    def parse(cls, value: str | Boundary) -> Boundary:
        """Return the boundary named by ``value``; a ValueError lists the valid names."""
        if isinstance(value, Boundary):
            return value
        try:
            return cls(str(value).strip().lower())
        except ValueError:
            valid = ", ".join(repr(b.value) for b in cls)
            raise ValueError(f"unknown boundary {value!r}; valid boundaries: {valid}") from None


def check_mode(mode: int) -> int:
    """Return ``mode`` as an int in 1..MAX_MODE, or raise a ValueError naming it."""
    if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)):
        raise ValueError(f"mode must be a positive integer, got {mode!r}")
    if not 1 <= int(mode) <= MAX_MODE:
        raise ValueError(f"mode must be in 1..{MAX_MODE}, got {mode}")
    return int(mode)


def _characteristic(boundary: Boundary, z: float) -> float:
    """Frequency equation in a form without cancellation (dimensionless z = beta L)."""
    if boundary is Boundary.CLAMPED_FREE:
        # cos z cosh z = -1, divided by cosh z
        return math.cos(z) + 1.0 / math.cosh(z) if z < 700 else math.cos(z)
    if boundary is Boundary.CLAMPED_CLAMPED:
        # cos z cosh z = 1, divided by cosh z
        return math.cos(z) - 1.0 / math.cosh(z) if z < 700 else math.cos(z)
    return math.sin(z)


def characteristic_root(boundary: Boundary | str, mode: int) -> float:
    """Root ``beta_n L`` (dimensionless) of the boundary condition's frequency equation.

    physics.md section 2: clamped-free ``cos z cosh z = -1`` (1.8751, 4.6941, 7.8548, ...),
    clamped-clamped ``cos z cosh z = 1`` (4.7300, 7.8532, ...), simply supported
    ``sin z = 0`` (n pi).  Root n of the clamped-free equation lies in ((n-1) pi, n pi) and
    of the clamped-clamped one in (n pi, (n+1) pi); each interval holds exactly one root.
    """
    return _characteristic_root(Boundary.parse(boundary), check_mode(mode))


@functools.cache
def _characteristic_root(boundary: Boundary, mode: int) -> float:
    if boundary is Boundary.SIMPLY_SUPPORTED:
        return mode * math.pi
    lo, hi = ((mode - 1) * math.pi, mode * math.pi)
    if boundary is Boundary.CLAMPED_CLAMPED:
        lo, hi = mode * math.pi, (mode + 1) * math.pi

    def solve() -> dict[str, np.ndarray]:
        root = brentq(lambda z: _characteristic(boundary, z), lo, hi, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=200)
        return {"root": np.array(root)}

    # Kept on disk (exact float64): a run with cached tables then never imports scipy.optimize.
    return float(disk_cached("characteristic-root", (boundary.value, mode), solve)["root"])


def _basis(z: float, xi: np.ndarray, order: int) -> np.ndarray:
    """The four bounded basis functions' ``order``-th derivatives with respect to (beta x).

    Returns shape ``xi.shape + (4,)``; columns: cos, sin, exp(-z xi), exp(-z (1 - xi)).
    """
    s = z * np.asarray(xi, dtype=float)
    c, si = np.cos(s), np.sin(s)
    trig = [(c, si), (-si, c), (-c, -si), (si, -c)][order % 4]
    decay = np.exp(-s) * (-1.0) ** order
    grow = np.exp(-(z - s))
    return np.stack([trig[0], trig[1], decay, grow], axis=-1)


# Which derivative orders vanish at a support: clamped (Z, Z'), pinned (Z, Z''), free (Z'', Z''').
_END_CONDITIONS = {
    Boundary.CLAMPED_FREE: ((0, 1), (2, 3)),
    Boundary.SIMPLY_SUPPORTED: ((0, 2), (0, 2)),
    Boundary.CLAMPED_CLAMPED: ((0, 1), (0, 1)),
}


@dataclass(frozen=True)
class ModeShape:
    """One bending mode ``Z_n(x)`` of a beam of length ``length_m``.

    Normalized so that ``integral_0^L Z^2 dx = L`` (so A_L = L, in metres) and, for a
    deterministic sign, so that Z'(0) > 0 (simply supported) or Z''(0) > 0 (clamped at x = 0).
    Z is dimensionless; ``derivative(x, k)`` has units m^-k.
    """

    boundary: Boundary
    mode: int
    beta_l: float
    length_m: float
    coeffs: tuple[float, float, float, float]

    @property
    def beta_per_m(self) -> float:
        """Wavenumber beta_n in 1/m."""
        return self.beta_l / self.length_m

    def derivative(self, x_m: np.ndarray | float, order: int = 0) -> np.ndarray:
        """``d^order Z / dx^order`` at positions ``x_m`` (metres), units m^-order."""
        xi = np.asarray(x_m, dtype=float) / self.length_m
        return (_basis(self.beta_l, xi, order) @ np.asarray(self.coeffs)) * self.beta_per_m**order

    def __call__(self, x_m: np.ndarray | float) -> np.ndarray:
        return self.derivative(x_m, 0)

    def square_integral(self, x1_m: np.ndarray | float, x2_m: np.ndarray | float) -> np.ndarray:
        """``integral_{x1}^{x2} Z(x)^2 dx`` in metres, for arrays of interval ends (signed: x2 < x1 gives <= 0).

        Composite Gauss-Legendre with panels no wider than a quarter of the mode's
        half-wavelength, so the quadrature error is at rounding level for every mode.
        """
        a = np.asarray(x1_m, dtype=float)
        b = np.asarray(x2_m, dtype=float)
        a, b = np.broadcast_arrays(a, b)
        # Integrate over [min, max] and give the result the interval's orientation.
        x1, x2, sign = np.minimum(a, b), np.maximum(a, b), np.where(b >= a, 1.0, -1.0)
        panels = 4 * (self.mode + 2)
        # Fixed panel grid over [0, L]; whole panels come from a running sum (monotone, so
        # never negative), the two partial panels from direct quadrature (positive weights):
        # the result is >= 0 for every x2 >= x1, however narrow the interval.
        edges = np.linspace(0.0, self.length_m, panels + 1)
        cum = np.concatenate([[0.0], np.cumsum(_panel_integrals(self, edges[:-1], edges[1:]))])
        k1 = np.clip(np.searchsorted(edges, x1, side="right") - 1, 0, panels - 1)
        k2 = np.clip(np.searchsorted(edges, x2, side="right") - 1, 0, panels - 1)
        same = k1 == k2
        head = _panel_integrals(self, x1, np.where(same, x2, edges[np.minimum(k1 + 1, panels)]))
        middle = np.where(same, 0.0, cum[k2] - cum[np.minimum(k1 + 1, panels)])
        tail = np.where(same, 0.0, _panel_integrals(self, edges[k2], x2))
        return sign * (head + np.maximum(middle, 0.0) + tail)


def _panel_integrals(shape: ModeShape, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Gauss-Legendre integral of Z^2 over each [a_i, b_i] (each narrower than a panel)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    half = 0.5 * (b - a)
    mid = 0.5 * (b + a)
    x = mid[..., None] + half[..., None] * _GL_NODES
    return half * (shape(x) ** 2 @ _GL_WEIGHTS)


def mode_shape(boundary: Boundary | str, mode: int, length_m: float) -> ModeShape:
    """The normalized mode ``mode`` of a beam of length ``length_m`` (m) with ``boundary``."""
    if not (isinstance(length_m, (int, float)) and math.isfinite(length_m) and length_m > 0):
        raise ValueError(f"length_m must be positive and finite, got {length_m!r}")
    return _mode_shape(Boundary.parse(boundary), check_mode(mode), float(length_m))


@functools.cache
def _mode_shape(boundary: Boundary, mode: int, length_m: float) -> ModeShape:
    z = _characteristic_root(boundary, mode)
    (left, right) = _END_CONDITIONS[boundary]
    rows = [_basis(z, np.array(0.0), k) for k in left] + [_basis(z, np.array(1.0), k) for k in right]
    _, _, vt = np.linalg.svd(np.stack(rows))
    coeffs = vt[-1]
    # Normalize: integral of Z^2 over [0, L] equals L, and the lowest-order derivative that
    # the support at x = 0 leaves free is positive (Z'' for a clamped end, Z' for a pinned one):
    # the textbook sign, and decided for every mode (a largest-excursion rule is not, when
    # the peaks are equal, as in every simply supported mode).
    trial = ModeShape(boundary, mode, z, length_m, tuple(float(c) for c in coeffs))
    norm = math.sqrt(float(trial.square_integral(0.0, length_m)) / length_m)
    free_order = 1 if boundary is Boundary.SIMPLY_SUPPORTED else 2
    sign = 1.0 if float(trial.derivative(0.0, free_order)) > 0 else -1.0
    return ModeShape(boundary, mode, z, length_m, tuple(float(c) * sign / norm for c in coeffs))

"""How the gel layer spreads a pressure on its face over the element beneath it.

The pad is a gel layer h0 thick (5 mm).  What presses on its face does not reach the element
only straight below: an elastic layer spreads a surface load over a width of the order of its
own thickness, as a tactile sensor's skin blurs what it touches (Fearing and Hollerbach,
"Basic solid mechanics for tactile sensing", IJRR 4(3), 1985).  With the gel touching the
element only over its coverage (the distal 1 mm by default), that spread decides what the
element feels of a contact elsewhere on the pad.

The model: plane strain along the element's length (the pad's strips span its width), the
layer an elastic half-space, the element at depth ``depth_m`` = h0.  A line load P (N/m) on
the face at x = 0 puts a normal stress at depth z and offset u

    sigma_z(u) = P k(u),   k(u) = 2 z^3 / (pi (u^2 + z^2)^2)    (1/m)           (eq. S1)

(Flamant's solution; K. L. Johnson, *Contact Mechanics*, 1985, section 2.2).  k integrates to
1 over the line (the load is all carried at depth), and its closed integrals are

    K(u) = int k du     = (atan(u / z) + u z / (u^2 + z^2)) / pi                (eq. S2)
    G(u) = int K du     = u atan(u / z) / pi    (+ a constant)                   (eq. S3)

so a strip [a, b] of face pressure p gives a cell [c1, c2] of the element the mean pressure

    p (G(c2 - a) - G(c1 - a) - G(c2 - b) + G(c1 - b)) / (c2 - c1)               (eq. S4)

without quadrature.  The pad has ends: the half-space's share of a load that would reach past
them stays in the pad instead (each cell's weights are scaled to sum to 1), so a uniform face
pressure reaches every cell exactly as it is (physics.md section 3: a uniform load gives the
uniform-load result).

As z -> 0, G(u) -> |u| / 2 and eq. S4 becomes the overlap of cell and strip over the cell's
length: each cell feels only the strip above it (``depth_m=0``, a Winkler layer without
spread).

Limits, said: a layer bonded to a rigid base concentrates the load under a contact more than
a half-space does (the spread is narrower than k's, markedly so for a nearly incompressible
gel); the depth is the unloaded thickness (a compressed layer spreads less); the spread does
not change how the pad moves in MuJoCo (its strips stay independent Winkler columns), only
where their pressure lands on the element.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["flamant_kernel", "spread_weights"]


def flamant_kernel(offset_m, depth_m: float) -> np.ndarray:
    """k(u) of eq. S1, 1/m: normal stress at depth ``depth_m`` (m) and lateral offset
    ``offset_m`` (m) under a unit line load on an elastic half-space's face."""
    z = _checked_depth(depth_m)
    if z == 0.0:
        raise ValueError("flamant_kernel needs depth_m > 0 (at the face the load is a delta)")
    u = np.asarray(offset_m, float)
    return 2.0 * z**3 / (math.pi * (u * u + z * z) ** 2)


def _second_integral(u: np.ndarray, z: float) -> np.ndarray:
    """G(u) of eq. S3, m (z > 0)."""
    return u * np.arctan(u / z) / math.pi


def spread_weights(source_edges_m, target_edges_m, depth_m: float) -> np.ndarray:
    """Weights W (targets x sources) so that the targets' mean pressures are W @ p.

    Parameters
    ----------
    source_edges_m : increasing edges of the strips on the layer's face, m (the whole pad:
        sources beyond it carry nothing).
    target_edges_m : increasing edges of the cells on the element, m, in the same frame.
    depth_m : the layer's thickness above the element, m (>= 0; 0: no spread).

    Returns
    -------
    W, shape (cells, strips): eq. S4 for each pair, each row scaled to sum to 1 (the pad keeps
    its load).  Dimensionless.

    Raises
    ------
    ValueError
        for edges that are not finite and strictly increasing, a negative or non-finite depth,
        or a cell that no strip reaches (a cell off the pad with ``depth_m=0``).
    """
    z = _checked_depth(depth_m)
    src = _checked_edges("source_edges_m", source_edges_m)
    dst = _checked_edges("target_edges_m", target_edges_m)
    a, b = src[:-1], src[1:]
    c1, c2 = dst[:-1, None], dst[1:, None]
    if z == 0.0:  # eq. S4's limit, the overlaps, computed exactly
        w = np.clip(np.minimum(c2, b) - np.maximum(c1, a), 0.0, None) / (c2 - c1)
    else:
        g = _second_integral
        w = (g(c2 - a, z) - g(c1 - a, z) - g(c2 - b, z) + g(c1 - b, z)) / (c2 - c1)
        w = np.clip(w, 0.0, None)  # rounding of nearly cancelling terms, never physics
    total = w.sum(axis=1, keepdims=True)
    if not np.all(total > 0):
        bad = dst[:-1][total[:, 0] <= 0]
        raise ValueError(f"cells starting at {bad.tolist()} m lie off the pad's strips {src[0]}..{src[-1]} m")
    return w / total


def _checked_depth(depth_m: float) -> float:
    z = float(depth_m)
    if not (math.isfinite(z) and z >= 0):
        raise ValueError(f"depth_m must be finite and >= 0, got {depth_m!r}")
    return z


def _checked_edges(name: str, edges) -> np.ndarray:
    e = np.asarray(edges, float)
    if e.ndim != 1 or e.size < 2 or not np.all(np.isfinite(e)) or not np.all(np.diff(e) > 0):
        raise ValueError(f"{name} must be at least two finite, strictly increasing values, got {np.asarray(edges).tolist()!r}")
    return e

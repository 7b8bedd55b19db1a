"""A fingertip pad's layout: its size, the element under it, its strips, and the gel's per-area terms.

The pad is cut into strips along the sensor element's length: ``segments`` strips tile the
element, two *guards* cover the rest of the pad (models/README.md, "The pads", says why).
Everything here is geometry and the gel's small-strain numbers, no MuJoCo: :mod:`cosim.pad_model`
builds the strips into a model from it, :mod:`cosim.pad_bridge` steps them.

Frames: strip order is from the pad's distal end (the pad frame's low z; the element's free
tip) up; :attr:`PadGeometry.segment_centers_m` gives the element strips' positions (m, from the
element's centre, + towards the palm, where the element is clamped).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from piezotip.sensor.gel import GelParams, modulus_ratio

PAD_SIDES = ("left", "right")
PAD_NAMES = tuple(f"{side}_pad" for side in PAD_SIDES)
"""The house gripper's pad names, in the order of every per-pad array: ``("left_pad", "right_pad")``."""

DEFAULT_PAD_SEGMENTS = 5
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
        """Body names of the house gripper's ``side`` pad's strips (``left_pad_seg0``, ...), distal first."""
        return self.strip_body_names(f"{side}_pad_")

    def strip_body_names(self, prefix: str) -> tuple[str, ...]:
        """Body names of one pad's strips, distal first: ``prefix`` + ``guard_lower``, ``seg0``, ...,
        ``guard_upper`` (joint = name + "_joint", geom = name + "_geom")."""
        segs = tuple(f"{prefix}seg{i}" for i in range(self.segments))
        if not self.has_guards:
            return segs
        return (f"{prefix}guard_lower", *segs, f"{prefix}guard_upper")


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

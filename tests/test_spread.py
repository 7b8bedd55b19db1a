"""The gel layer's load spread (sensor/spread.py), checked against numbers it does not compute."""

import math

import numpy as np
import pytest
from scipy import integrate

from piezotip import scenarios
from piezotip.cosim.loop import CoSimulation, coverage_cells, coverage_weights
from piezotip.cosim.pad_geometry import PadGeometry
from piezotip.sensor.spread import flamant_kernel, spread_weights

H0 = 5e-3  # the default gel's thickness, m


def test_the_kernel_carries_the_whole_line_load_to_depth():
    total, _ = integrate.quad(lambda u: float(flamant_kernel(u, H0)), -np.inf, np.inf)
    assert total == pytest.approx(1.0, rel=1e-10)
    # Flamant's sigma_z directly below a line load P at depth z is 2 P / (pi z)
    assert float(flamant_kernel(0.0, H0)) == pytest.approx(2.0 / (math.pi * H0), rel=1e-14)


def test_the_closed_form_double_integral_matches_quadrature():
    """eq. S4 against the kernel integrated numerically over strip and cell, row by row."""
    strips = np.array([-10e-3, -3.75e-3, -2.0e-3, 0.5e-3, 3.75e-3, 10e-3])
    cells = np.array([-3.75e-3, -3.1e-3, -2.75e-3])
    w = spread_weights(strips, cells, H0)
    numeric = np.empty_like(w)
    for c in range(len(cells) - 1):
        for s in range(len(strips) - 1):
            val, _ = integrate.dblquad(
                lambda xi, x: float(flamant_kernel(x - xi, H0)),
                cells[c],
                cells[c + 1],
                strips[s],
                strips[s + 1],
                epsabs=1e-13,
                epsrel=1e-11,
            )
            numeric[c, s] = val / (cells[c + 1] - cells[c])
    numeric /= numeric.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(w, numeric, rtol=1e-7, atol=1e-12)


def test_a_narrow_strip_weighs_as_the_kernel_at_its_offset():
    """Finite difference: a strip of width d at offset u gives a point cell d k(u) (unnormalized;
    the pad here is so wide that normalization changes nothing measurable)."""
    d, u = 1e-6, 3e-3
    strips = np.array([-1.0, u - d / 2, u + d / 2, 1.0])
    cell = np.array([-1e-6, 1e-6])
    w = spread_weights(strips, cell, H0)
    assert w[0, 1] == pytest.approx(d * float(flamant_kernel(u, H0)), rel=1e-5)


def test_a_uniform_face_pressure_reaches_every_cell_as_it_is():
    strips = np.linspace(-10e-3, 10e-3, 8)
    cells = np.linspace(-3.75e-3, 3.75e-3, 6)
    w = spread_weights(strips, cells, H0)
    np.testing.assert_allclose(w @ np.full(7, 250.0), 250.0, rtol=1e-14)


def test_without_depth_each_cell_feels_only_the_strip_above_it():
    strips = np.linspace(0.0, 7.5e-3, 6)
    edges, index = coverage_cells(strips, (6.5e-3, 7.5e-3))
    w = spread_weights(strips, edges, 0.0)
    expected = np.zeros_like(w)
    expected[np.arange(len(index)), index] = 1.0
    np.testing.assert_array_equal(w, expected)
    # and the limit is continuous: a very thin layer is nearly that
    np.testing.assert_allclose(spread_weights(strips, edges, 1e-9), expected, atol=1e-6)


def test_the_spread_widens_with_the_layers_thickness():
    """A cell at the element's tip under a thin, a default and a thick layer: the strip above it
    gives less and less, the guard beside it and the far guard more and more."""
    strips = np.array([-10e-3, -3.75e-3, 3.75e-3, 10e-3])
    cell = np.array([-3.75e-3, -2.75e-3])
    beside, own, far = np.array([spread_weights(strips, cell, h)[0] for h in (0.2e-3, 5e-3, 20e-3)]).T
    assert own[0] > 0.9 and beside[0] < 0.1  # nearly no spread: the strip above
    assert own[0] > own[1] > own[2]
    assert beside[0] < beside[1] and far[0] < far[1] < far[2]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (([0.0, 1e-3], [0.0, 1e-3], -1e-3), "depth_m"),
        (([0.0, 1e-3], [0.0, 1e-3], math.nan), "depth_m"),
        (([0.0, 0.0, 1e-3], [0.0, 1e-3], H0), "source_edges_m"),
        (([0.0, 1e-3], [1e-3, 0.0], H0), "target_edges_m"),
        (([0.0, math.nan], [0.0, 1e-3], H0), "source_edges_m"),
        (([0.0, 1e-3], [2e-3, 3e-3], 0.0), "off the pad"),
    ],
)
def test_bad_input_is_named(args, message):
    with pytest.raises(ValueError, match=message):
        spread_weights(*args)


def test_the_coverage_at_the_tip_feels_the_distal_guard_and_at_the_root_the_palm_one():
    """Orientation: the element's tip (x = L) is the pad's distal end (low z), where the strips
    begin; a coverage at the root feels the palm-side guard instead."""
    g = PadGeometry(segments=1)
    tip = coverage_weights(g, g.element_length_m, np.array([6.5e-3, 7.5e-3]), H0)
    root = coverage_weights(g, g.element_length_m, np.array([0.0, 1e-3]), H0)
    distal, element, palm = 0, 1, 2  # the strips as the pad lists them
    tip_w, root_w = dict(tip[0]), dict(root[0])
    assert tip_w[distal] > 0.3 > tip_w[palm]
    assert root_w[palm] == pytest.approx(tip_w[distal], rel=1e-12)  # mirror images
    assert root_w[element] == pytest.approx(tip_w[element], rel=1e-12)


def test_the_loop_feeds_the_sensor_what_the_weights_say_and_records_it():
    """Step a grasp until the pads touch; the channel's input is the weighted strips (numpy path),
    and the recorded coverage pressure is its mean over the cells."""
    sim = CoSimulation(scenarios.get("grasp", ["physics.pad_segments=5"]))
    rows = [sim.step() for _ in range(700)]
    touched = [r for r in rows if r["left_true_pressure_pa"] > 0.0]
    assert touched, "the fingers never touched the box in 3.5 s"
    cells = sim.coverage_pressures()
    strips = np.maximum(sim.bridge.strip_pressures(sim.data), 0.0)
    assert cells[0, 0] == pytest.approx(
        float(np.dot([w for _, w in sim._cell_weights[0]], strips[0][[i for i, _ in sim._cell_weights[0]]]))
    )
    assert rows[-1]["left_coverage_pressure_pa"] == pytest.approx(float(cells[0].mean()), rel=1e-12)

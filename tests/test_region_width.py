"""The local width of a planar graph's regions and the graded size cap
(polygen.mesh2d.region_width), used by the combination of chapter 3's lines with
chapter 4's sizes: oracles are strips, wedges and corners whose chords are known."""

import numpy as np
import pytest

from polygen.mesh2d import planar_graph
from polygen.mesh2d.region_width import graded_minimum, region_width, width_capped_size


def _strip():
    """A 4 x 1 rectangle cut by a line at v = 0.3: a strip 0.3 wide and one 0.7 wide."""
    outer = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [0.0, 1.0]])
    g = planar_graph(outer, (), np.array([[[0.0, 0.3], [4.0, 0.3]]]), "D0")
    low = int(g.region_of(np.array([[2.0, 0.1]]))[0])
    return g, low, 1 - low


def test_strip_width_is_its_width_inside_and_on_its_edges():
    g, low, high = _strip()
    rng = np.random.default_rng(0)
    inside = np.column_stack([rng.uniform(0.5, 3.5, 50), rng.uniform(0.01, 0.29, 50)])
    np.testing.assert_allclose(region_width(g, low, inside), 0.3, rtol=1e-9)
    above = np.column_stack([rng.uniform(0.5, 3.5, 50), rng.uniform(0.31, 0.99, 50)])
    np.testing.assert_allclose(region_width(g, high, above), 0.7, rtol=1e-9)
    # on the strip's own edges (the wall below, the line above) the chord into the strip
    edge = np.array([[1.0, 0.0], [2.5, 0.0], [1.0, 0.3], [3.0, 0.3]])
    np.testing.assert_allclose(region_width(g, low, edge), 0.3, rtol=1e-9)


def test_right_angle_corner_is_not_narrow_and_a_wedge_narrows_as_r_tan_phi():
    sq = planar_graph(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]))
    # near a 90-degree corner the chord runs parallel to the other edge: the far side
    np.testing.assert_allclose(region_width(sq, 0, np.array([[0.1, 0.2], [0.0, 0.0]])), 10.0)
    phi = np.radians(30.0)
    wedge = planar_graph(np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 5.0 * np.tan(phi)]]))
    r = np.array([0.5, 1.0, 2.0, 3.0])
    for v in (0.0, 1e-3):   # on the bottom edge, and just above it
        np.testing.assert_allclose(region_width(wedge, 0, np.column_stack([r, np.full(4, v)])),
                                   r * np.tan(phi), rtol=1e-9, atol=2e-3)


def test_width_capped_size_is_min_of_size_and_floored_width():
    g, low, high = _strip()
    f = width_capped_size(2.0, g, low, floor=0.05)
    np.testing.assert_allclose(f(np.array([[2.0, 0.1], [2.0, 0.2]])), 0.3, rtol=1e-9)
    np.testing.assert_allclose(width_capped_size(2.0, g, low, floor=0.5)(np.array([[2.0, 0.1]])),
                               0.5)
    np.testing.assert_allclose(width_capped_size(0.1, g, high, floor=0.05)(
        np.array([[2.0, 0.6]])), 0.1)   # the size below the width stays
    with pytest.raises(ValueError, match="floor"):
        width_capped_size(2.0, g, low, floor=0.0)


def test_graded_minimum_brute_force():
    rng = np.random.default_rng(3)
    x, y = rng.uniform(-1, 1, (40, 3)), rng.uniform(-1, 1, (7, 3))
    c = rng.uniform(0.1, 1.0, 7)
    ref = np.min(c[None, :] + 0.5 * np.linalg.norm(x[:, None] - y[None], axis=2), axis=1)
    np.testing.assert_allclose(graded_minimum(x, y, c, beta=0.5), ref, rtol=1e-12)
    # slope at most beta: between any two points the field changes by <= beta * distance
    v = graded_minimum(x, y, c, beta=0.5)
    dist = np.linalg.norm(x[:, None] - x[None], axis=2)
    assert np.all(np.abs(v[:, None] - v[None]) <= 0.5 * dist + 1e-12)
    assert np.all(np.isinf(graded_minimum(x, y[:0], c[:0], beta=0.5)))
    with pytest.raises(ValueError, match="beta"):
        graded_minimum(x, y, c, beta=0.0)

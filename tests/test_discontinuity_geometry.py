"""``clip_polygon`` (Sutherland-Hodgman on one plane) against closed-form areas, in the plane and in space."""

import numpy as np
import pytest

from polygen.discontinuity import _geometry as geo


def _area(poly):
    """Shoelace area of a polygon (k, 2), or of a planar one (k, 3) by the cross products' sum."""
    if poly.shape[1] == 2:
        x, y = poly.T
        return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    return 0.5 * np.linalg.norm(np.cross(poly, np.roll(poly, -1, axis=0)).sum(axis=0))


SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


@pytest.mark.parametrize("c, area", [(1.0, 0.5), (0.5, 0.125), (1.5, 0.875), (2.0, 1.0), (0.0, 0.0)])
def test_a_square_cut_by_x_plus_y(c, area):
    # x + y <= c cuts the unit square into a triangle (c <= 1) or a pentagon (1 < c < 2)
    n = np.array([1.0, 1.0])
    for poly in (SQUARE, np.c_[SQUARE, np.full(4, 2.0)]):  # in the plane, and lifted to z = 2 in space
        nn = n if poly.shape[1] == 2 else np.r_[n, 0.0]
        out = geo.clip_polygon(poly, nn, c)
        assert out.shape[1] == poly.shape[1]
        assert (len(out) == 0 and area == 0.0) or _area(out) == pytest.approx(area, abs=1e-12)
        assert np.all(out @ nn <= c + 1e-12)
    assert np.array_equal(geo.clip_polygon_2d(SQUARE, n, c), geo.clip_polygon(SQUARE, n, c))
    lifted = np.c_[SQUARE, np.zeros(4)]
    assert np.array_equal(geo.clip_polygon_3d(lifted, np.r_[n, 0.0], c), geo.clip_polygon(lifted, np.r_[n, 0.0], c))


def test_within_tol_is_returned_as_it_is():
    # every vertex at most tol outside: the polygon itself, not a clipped copy
    assert geo.clip_polygon(SQUARE, np.array([1.0, 0.0]), 1.0 - 1e-3, tol=1e-2) is SQUARE
    assert geo.clip_polygon(SQUARE, np.array([1.0, 0.0]), 1.0 - 1e-3).shape == (4, 2)
    empty = np.zeros((0, 2))
    assert geo.clip_polygon(empty, np.array([1.0, 0.0]), 0.0) is empty

"""The bubble mesh's optional quality improvement (``improve``): insertion at the
circumcentres of skinny triangles and Laplacian smoothing of the face bubbles, a round kept
only if it is better."""

import numpy as np
import pytest

from polygen.mesh2d import bubble_mesh, triangle_quality

OUTER = np.array([[-5.0, -5.0], [5.0, -5.0], [5.0, 5.0], [-5.0, 5.0]])
HOLE = np.array([[-1.0, -1.0], [-1.0, 1.0], [1.0, 1.0], [1.0, -1.0]])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_never_worse_and_boundary_kept(seed):
    """A channel narrower than the size (the ceiling around the light at Table 4.1's sizes):
    the result is better by the acceptance rule -- a larger smallest angle, or one at least
    min(before, improve_angle) with a larger mean radius ratio -- and the vertex and edge
    bubbles are where they were."""
    before = bubble_mesh(OUTER, [HOLE], 3.3, seed=seed)
    after = bubble_mesh(OUTER, [HOLE], 3.3, seed=seed, improve=3)
    a0, q0 = triangle_quality(before.nodes, before.triangles)
    a1, q1 = triangle_quality(after.nodes, after.triangles)
    assert a1.min() > a0.min() or (a1.min() >= min(a0.min(), 30.0) - 1e-9
                                  and q1.mean() > q0.mean())
    fixed = before.kind < 2
    np.testing.assert_array_equal(after.nodes[:fixed.sum()], before.nodes[fixed])
    np.testing.assert_array_equal(after.kind[:fixed.sum()], before.kind[fixed])
    # the area is still covered, once
    area = 100.0 - 4.0
    p = after.nodes[after.triangles]
    u, v = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    tri_area = 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    assert tri_area.sum() == pytest.approx(area, rel=1e-12)
    assert np.all(tri_area > 0)


def test_skinny_triangle_at_the_hole_is_removed():
    """Without improvement every seed leaves a triangle joining a hole side (2 long, no
    edge bubble: shorter than the size) to a node of the outer wall 4 away (24.5 degrees
    measured); relaxation pushes the face bubbles of the 4-wide channel out of the way.
    With it, no triangle is below 25 degrees (the issue's bound; the insertion angle is 30)."""
    for seed in (0, 1, 2):
        a0, _ = triangle_quality(*_mesh(seed, 0))
        a1, _ = triangle_quality(*_mesh(seed, 3))
        assert a0.min() < 25.0 <= a1.min()


def _mesh(seed, improve):
    bm = bubble_mesh(OUTER, [HOLE], 3.3, seed=seed, improve=improve)
    return bm.nodes, bm.triangles


def test_default_is_off():
    a = bubble_mesh(OUTER, [HOLE], 3.3, seed=0)
    b = bubble_mesh(OUTER, [HOLE], 3.3, seed=0, improve=0)
    np.testing.assert_array_equal(a.nodes, b.nodes)
    assert not any(h[0] == "improve" for h in a.history)

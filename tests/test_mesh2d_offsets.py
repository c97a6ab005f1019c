"""2-D meshing far from the origin (issue 19, item 9): a unit square offset by 1e9 was rejected as
"zero area", and at 1e12 38 of its 58 bubble-mesh nodes were in no triangle. Meshing works relative
to ``local_origin`` (an exact translation), so a shifted domain meshes as the unshifted one does,
up to the shift."""

import numpy as np
import pytest

from polygen.mesh2d import bubble_mesh, constrained_delaunay, signed_area, validate_domain
from polygen.mesh2d.domain import local_origin

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
HOLE = np.array([[0.375, 0.375], [0.375, 0.625], [0.625, 0.625], [0.625, 0.375]])  # clockwise
OFFSETS = [1e6, 1e9, 1e12]  # multiples of 2**0: the shifted corners are exact


def _used(mesh):
    used = np.zeros(len(mesh.nodes), bool)
    used[mesh.triangles.ravel()] = True
    return used


@pytest.fixture(scope="module")
def base():
    m = bubble_mesh(SQUARE, [HOLE], size=0.2, seed=3)
    a, b, c = (m.nodes[m.triangles[:, k]] for k in range(3))
    area = 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]).sum()
    assert _used(m).all() and area == pytest.approx(1.0 - 0.25**2, rel=1e-12)
    return m


@pytest.mark.parametrize("off", OFFSETS)
def test_shifted_square_with_a_hole_is_the_same_bubble_mesh(base, off):
    m = bubble_mesh(SQUARE + off, [HOLE + off], size=0.2, seed=3)
    assert _used(m).all()  # every node in a triangle
    np.testing.assert_array_equal(m.triangles, base.triangles)
    np.testing.assert_array_equal(m.kind, base.kind)
    np.testing.assert_array_equal(m.sizes, base.sizes)
    # node = local node + offset, rounded once: within half a unit in the last place of the offset
    np.testing.assert_allclose(m.nodes - off, base.nodes, rtol=0, atol=0.5 * np.spacing(off))
    np.testing.assert_allclose(m.initial - off, base.initial, rtol=0, atol=0.5 * np.spacing(off))


@pytest.mark.parametrize("off", OFFSETS)
def test_size_function_sees_the_callers_coordinates(off):
    seen = []

    def size(xy):
        seen.append(np.array(xy))
        return np.full(len(xy), 0.25)

    m = bubble_mesh(SQUARE + off, size=size, seed=0)
    assert _used(m).all() and len(m.nodes) > 4
    xy = np.concatenate(seen)
    # the mesher probes a little outside the domain, never at the local frame's (0, 0)
    assert np.all(np.abs(xy - (off + 0.5)) < 2.0)


@pytest.mark.parametrize("off", [0.0] + OFFSETS)
def test_shifted_domain_is_valid_with_the_same_area(off):
    dom = validate_domain(SQUARE + off, [HOLE + off])
    assert dom.area == 1.0 - 0.25**2  # exact: the corners are exact binary fractions
    assert signed_area(SQUARE[::-1] + off) == -1.0


@pytest.mark.parametrize("off", OFFSETS)
def test_constrained_delaunay_far_from_the_origin(off):
    rng = np.random.default_rng(7)
    pts = np.unique(rng.integers(1, 1023, size=(80, 2)), axis=0) / 1024.0  # exact after the shift
    pts = np.concatenate([SQUARE, pts])
    ring = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    a = constrained_delaunay(pts, ring)
    b = constrained_delaunay(pts + off, ring)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    np.testing.assert_array_equal(b.nodes, pts + off)  # the caller's points, unchanged


def test_local_origin_is_exact_and_zero_near_the_origin():
    assert not local_origin(SQUARE).any() and not local_origin(SQUARE * 1e-9).any()
    assert not local_origin(SQUARE + 1000.0).any()  # within 1024 sizes: meshed as given
    np.testing.assert_array_equal(local_origin(SQUARE + [0.0, 1e6]), [0.0, 1e6])  # per axis
    rng = np.random.default_rng(1)
    for scale in (1e-6, 1.0, 1e3):
        for off in (1e7, -3.3e9, 7.7e14):
            xy = off + scale * rng.random((50, 2))
            o = local_origin(xy)
            assert o.all()
            local = xy - o
            # exact: adding the origin back gives every input bit for bit, and the frame is near 0
            np.testing.assert_array_equal(local + o, xy)
            assert np.abs(local).max() <= 2 * scale


@pytest.fixture(scope="module")
def graph_base():
    from polygen.mesh2d import mesh_planar_graph, planar_graph

    g = planar_graph(SQUARE, [HOLE], SEGMENTS, "D0")
    return g, {m: mesh_planar_graph(g, SIZES, method=m, seed=1) for m in ("lattice", "bubble")}


SEGMENTS = np.array([[[0.0, 0.5], [0.375, 0.5]], [[0.625, 0.5], [1.0, 0.5]]])  # cut into two regions
SIZES = [0.15, 0.25]


@pytest.mark.parametrize("off", OFFSETS)
@pytest.mark.parametrize("method", ["lattice", "bubble"])
def test_shifted_planar_graph_meshes_the_same(graph_base, off, method):
    from polygen.mesh2d import mesh_planar_graph, planar_graph

    g0, meshes = graph_base
    g = planar_graph(SQUARE + off, [HOLE + off], SEGMENTS + off, "D0")
    assert g.n_regions == g0.n_regions == 2
    np.testing.assert_array_equal(g.edges, g0.edges)
    np.testing.assert_array_equal(g.region_area, g0.region_area)
    np.testing.assert_array_equal(g.vertices - off, g0.vertices)  # exact: binary fractions
    m, m0 = mesh_planar_graph(g, SIZES, method=method, seed=1), meshes[method]
    used = np.zeros(len(m.nodes), bool)
    used[m.triangles.ravel()] = True
    assert used.all()
    np.testing.assert_array_equal(m.triangles, m0.triangles)
    np.testing.assert_allclose(m.nodes - off, m0.nodes, rtol=0, atol=0.5 * np.spacing(off))

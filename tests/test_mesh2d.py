"""Tests for polygen.mesh2d: domains, constrained Delaunay, bubble mesh, quality, subdivision."""

import math

import numpy as np
import pytest
import shapely
from scipy.spatial import Delaunay

from polygen.mesh2d import (
    GridSize,
    InvalidDomainError,
    adaptive_subdivision,
    bubble_force,
    bubble_mesh,
    bubble_subdivide_patches,
    constrained_delaunay,
    edge_bubbles,
    find_t_vertices,
    is_t_vertex_free,
    locate_in_triangles,
    mesh_edges,
    quality_histogram,
    refine_marked,
    subdivide_patches,
    triangle_areas,
    triangle_quality,
    triangulate_domain,
    validate_domain,
)
from polygen.mesh2d.bubble import BoundaryLocator

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def circle(cx, cy, r, k, cw=True):
    th = np.linspace(0.0, 2.0 * np.pi, k, endpoint=False)
    ring = np.c_[cx + r * np.cos(th), cy + r * np.sin(th)]
    return ring[::-1] if cw else ring


def hole_for(h):
    """A circular hole of radius 0.25 whose polygon edges are about h long."""
    return circle(0.5, 0.5, 0.25, int(round(2 * np.pi * 0.25 / h)))


def edge_set(tri):
    return {tuple(e) for e in mesh_edges(tri).tolist()}


def incircle(a, b, c, d):
    """> 0 when d is strictly inside the circumcircle of CCW (a, b, c) (brute force)."""
    m = np.array([[a[0] - d[0], a[1] - d[1], (a[0] - d[0]) ** 2 + (a[1] - d[1]) ** 2],
                  [b[0] - d[0], b[1] - d[1], (b[0] - d[0]) ** 2 + (b[1] - d[1]) ** 2],
                  [c[0] - d[0], c[1] - d[1], (c[0] - d[0]) ** 2 + (c[1] - d[1]) ** 2]])
    return np.linalg.det(m)


def check_conforming_mesh(nodes, tri, domain):
    """Invariants every mesh of a domain must satisfy."""
    area = triangle_areas(nodes, tri)
    assert area.min() > 0, "a triangle is clockwise or degenerate"
    assert abs(area.sum() - domain.polygon.area) < 1e-9
    cen = nodes[tri].mean(axis=1)
    assert shapely.contains_xy(domain.polygon, cen[:, 0], cen[:, 1]).all(), "a triangle in a hole"
    assert is_t_vertex_free(nodes, tri)


# ---------------------------------------------------------------------------
# inter-bubble force (2.12)
# ---------------------------------------------------------------------------

def test_force_properties_we_rely_on():
    k0 = 2.5
    assert bubble_force(1.0, k0) == pytest.approx(0.0, abs=1e-14)  # stable at r0
    assert bubble_force(1.5, k0) == 0.0  # r1 = 1.5 r0
    w = np.linspace(0.0, 0.999, 200)
    assert np.all(bubble_force(w, k0) > 0)  # repulsive below r0
    w = np.linspace(1.001, 1.499, 200)
    assert np.all(bubble_force(w, k0) < 0)  # attractive between r0 and 1.5 r0
    assert np.all(bubble_force(np.linspace(1.5, 5, 50), k0) == 0)
    eps = 1e-6
    d1 = (bubble_force(1 + eps, k0) - bubble_force(1 - eps, k0)) / (2 * eps)
    assert d1 == pytest.approx(-k0, rel=1e-6)  # f'(1) = -k0
    d0 = (bubble_force(eps, k0) - bubble_force(0.0, k0)) / eps
    assert abs(d0) < 1e-4 * k0  # f'(0) = 0
    # the cubic is continuous at the cut-off (the unclipped cubic vanishes there)
    assert k0 * (1.25 * 1.5**3 - 2.375 * 1.5**2 + 1.125) == pytest.approx(0.0, abs=1e-12)


def test_printed_conditions_over_determine_a_cubic():
    # (2.12) as printed: f(r0) = f'(r0) = f''(r0) = 0 and f(r1) = 0 for a cubic
    # a r^3 + b r^2 + c r + d: only the zero function satisfies all four.
    r0, r1 = 1.0, 1.5
    rows = [[r0**3, r0**2, r0, 1], [3 * r0**2, 2 * r0, 1, 0], [6 * r0, 2, 0, 0], [r1**3, r1**2, r1, 1]]
    assert np.linalg.matrix_rank(np.array(rows)) == 4


# ---------------------------------------------------------------------------
# domains and bad input
# ---------------------------------------------------------------------------

@pytest.mark.parametrize(
    "outer, holes, match",
    [
        (np.array([[0, 0], [1, 1], [1, 0], [0, 1]], float), (), "self-intersecting"),
        (np.array([[0, 0], [1, 0], [2, 0]], float), (), "zero area"),
        (SQUARE, [circle(3.0, 3.0, 0.2, 12)], "hole 0: not strictly inside"),
        (SQUARE, [circle(1.0, 0.5, 0.2, 12)], "hole 0: not strictly inside"),
        (np.array([[0, 0], [1, 0], [np.nan, 1], [0, 1]], float), (), "non-finite"),
        (np.array([[0, 0], [1, 0], [np.inf, 1]], float), (), "non-finite"),
        (SQUARE, [circle(0.4, 0.5, 0.2, 12), circle(0.6, 0.5, 0.2, 12)], "hole 1: overlaps"),
        (np.array([[0, 0], [1, 0]], float), (), "at least 3"),
        (np.zeros((4, 3)), (), "shape"),
    ],
)
def test_bad_domains_raise(outer, holes, match):
    with pytest.raises(InvalidDomainError, match=match):
        validate_domain(outer, holes)
    with pytest.raises(ValueError, match=match):  # InvalidDomainError is a ValueError
        bubble_mesh(outer, holes, 0.1)
    with pytest.raises(ValueError, match=match):
        triangulate_domain(outer, holes)


def test_domain_is_normalised():
    dom = validate_domain(SQUARE[::-1], [circle(0.5, 0.5, 0.2, 16, cw=False)])
    assert dom.area == pytest.approx(1 - 16 * 0.5 * 0.2**2 * math.sin(2 * math.pi / 16))
    assert dom.area == pytest.approx(dom.polygon.area, abs=1e-14)
    closed = np.vstack([SQUARE, SQUARE[:1]])
    assert len(validate_domain(closed).outer) == 4


def test_bad_size_and_points_raise():
    with pytest.raises(ValueError, match="size"):
        bubble_mesh(SQUARE, (), -1.0)
    with pytest.raises(ValueError, match="size function"):
        bubble_mesh(SQUARE, (), lambda xy: np.zeros(len(xy)))
    with pytest.raises(InvalidDomainError, match="interior: 1 nodes outside"):
        triangulate_domain(SQUARE, interior=[[0.5, 0.5], [2.0, 2.0]])
    with pytest.raises(ValueError, match="duplicate"):
        constrained_delaunay([[0, 0], [1, 0], [0, 1], [1, 0]])
    with pytest.raises(ValueError, match="constraint"):  # crossing constraints
        constrained_delaunay([[0, 0], [1, 0], [1, 1], [0, 1]], [[0, 2], [1, 3]])


# ---------------------------------------------------------------------------
# boundary locator against shapely
# ---------------------------------------------------------------------------

def test_boundary_locator_matches_shapely():
    outer = np.array([[0, 0], [2, 0], [2, 2], [1, 0.8], [0, 2]], float)  # concave, reflex vertex
    dom = validate_domain(outer, [circle(0.5, 0.5, 0.2, 9)])
    loc = BoundaryLocator.build(dom, 0.1)
    xy = np.random.default_rng(1).uniform(-0.3, 2.3, (20000, 2))
    inside, dist = loc.locate(xy)
    ref_in = shapely.contains_xy(dom.polygon, xy[:, 0], xy[:, 1])
    ref_d = shapely.distance(dom.polygon.boundary, shapely.points(xy))
    clear = ref_d > 1e-9
    np.testing.assert_array_equal(inside[clear], ref_in[clear])
    fin = np.isfinite(dist)
    np.testing.assert_allclose(dist[fin], ref_d[fin], atol=1e-12)
    assert np.all(ref_d[~fin] > 0.1 - 1e-12)  # 'no boundary within a cell' is true


# ---------------------------------------------------------------------------
# constrained Delaunay
# ---------------------------------------------------------------------------

def test_cdt_square_with_hole():
    dom = validate_domain(SQUARE, [hole_for(0.05)])
    rng = np.random.default_rng(7)
    p = rng.random((600, 2))
    ins = shapely.contains_xy(dom.polygon, p[:, 0], p[:, 1])
    d = shapely.distance(dom.polygon.boundary, shapely.points(p))
    p = p[ins & (d > 1e-3)]
    mesh = triangulate_domain(dom.outer, dom.holes, interior=p)
    nodes, tri = mesh.nodes, mesh.triangles
    check_conforming_mesh(nodes, tri, dom)
    assert len(nodes) == dom.n_vertices + len(p)
    edges = edge_set(tri)
    cons = {tuple(sorted(e)) for e in mesh.constrained_edges.tolist()}
    assert cons <= edges, "a constraint edge is missing"
    # empty circumcircle across every unconstrained interior edge
    owner = {}
    n_checked = 0
    for t in range(len(tri)):
        for k in range(3):
            e = tuple(sorted((tri[t, k], tri[t, (k + 1) % 3])))
            if e in owner and e not in cons:
                o = owner[e]
                d_opp = [v for v in tri[o] if v not in e][0]
                a, b, c = nodes[tri[t]]
                scale = np.ptp(nodes[tri[t]], axis=0).max() ** 4
                assert incircle(a, b, c, nodes[d_opp]) <= 1e-12 * scale
                n_checked += 1
            owner[e] = t
    assert n_checked > 500


def test_cdt_matches_scipy_delaunay_on_convex_input():
    # no constraint but the convex hull: the Delaunay triangulation is unique
    rng = np.random.default_rng(3)
    p = np.vstack([SQUARE, 0.02 + 0.96 * rng.random((300, 2))])
    mesh = constrained_delaunay(p, [[0, 1], [1, 2], [2, 3], [3, 0]])
    ref = Delaunay(p).simplices
    ours = {tuple(sorted(t)) for t in mesh.triangles.tolist()}
    theirs = {tuple(sorted(t)) for t in ref.tolist()}
    # the square's corners are co-circular with nothing else, so only boundary ties could differ
    assert ours == theirs


# ---------------------------------------------------------------------------
# bubble mesh
# ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def uniform_bubbles():
    h = 0.025
    dom = validate_domain(SQUARE, [hole_for(h)])
    return h, dom, bubble_mesh(dom, (), h, seed=0)


def jittered_delaunay(bm, dom, seed):
    """Delaunay of the same boundary nodes and as many jittered interior nodes."""
    nb = int((bm.kind < 2).sum())
    nf = len(bm.nodes) - nb
    rng = np.random.default_rng(seed)
    s = math.sqrt(dom.area / nf)
    gx, gy = np.meshgrid(np.arange(0, 1, s) + s / 2, np.arange(0, 1, s) + s / 2)
    p = np.c_[gx.ravel(), gy.ravel()] + rng.uniform(-0.5 * s, 0.5 * s, (gx.size, 2))
    d = shapely.distance(dom.polygon.boundary, shapely.points(p))
    p = p[shapely.contains_xy(dom.polygon, p[:, 0], p[:, 1]) & (d > 0.1 * s)]
    extra = []
    while len(p) + len(extra) < nf:  # top up with uniform points if the grid fell short
        q = rng.random(2)
        if dom.polygon.contains(shapely.Point(q)) and dom.polygon.boundary.distance(shapely.Point(q)) > 0.1 * s:
            extra.append(q)
    p = np.vstack([p] + ([np.array(extra)] if extra else []))
    p = p[rng.permutation(len(p))[:nf]]
    return constrained_delaunay(np.vstack([bm.nodes[:nb], p]), bm.constrained_edges)


def test_bubble_mesh_uniform_quality(uniform_bubbles):
    h, dom, bm = uniform_bubbles
    check_conforming_mesh(bm.nodes, bm.triangles, dom)
    assert edge_set(bm.triangles) >= {tuple(sorted(e)) for e in bm.constrained_edges.tolist()}
    ang, q = triangle_quality(bm.nodes, bm.triangles)
    assert q.mean() >= 0.95
    assert ang.min() >= 30.0
    jit = jittered_delaunay(bm, dom, seed=11)
    assert len(jit.nodes) == len(bm.nodes)
    jang, jq = triangle_quality(jit.nodes, jit.triangles)
    assert q.mean() > jq.mean() + 0.05
    assert ang.min() > jang.min()
    counts, _ = quality_histogram(q, bins=10)
    jcounts, _ = quality_histogram(jq, bins=10)
    assert counts[-1] > jcounts[-1]  # more elements with q in [0.9, 1]


def test_bubble_mesh_node_count(uniform_bubbles):
    h, dom, bm = uniform_bubbles
    # An equilateral packing of edge h gives each node a hexagonal Voronoi cell
    # of area (sqrt(3)/2) h^2, so N ~ A / ((sqrt(3)/2) h^2) = 2 A / (sqrt(3) h^2).
    target = 2.0 * dom.area / (math.sqrt(3.0) * h * h)
    assert abs(len(bm.nodes) - target) <= 0.10 * target
    # Euler's formula sharpens it: with F = A / ((sqrt(3)/4) h^2) triangles and
    # B = P / h boundary edges, N = F/2 + B/2 + chi (chi = 1 - holes = 0).
    perimeter = dom.polygon.length
    refined = target + perimeter / (2 * h) + (1 - len(dom.holes))
    assert abs(len(bm.nodes) - refined) <= 0.03 * refined


def test_bubble_mesh_kinds_and_boundary(uniform_bubbles):
    h, dom, bm = uniform_bubbles
    nv = dom.n_vertices
    assert np.all(bm.kind[:nv] == 0)
    np.testing.assert_array_equal(bm.nodes[:nv], np.concatenate(dom.rings))  # vertex bubbles fixed
    edge_nodes = bm.nodes[bm.kind == 1]
    d = shapely.distance(dom.polygon.boundary, shapely.points(edge_nodes))
    assert np.all(d < 1e-12)  # edge bubbles stay on their edges
    face = bm.nodes[bm.kind == 2]
    assert shapely.contains_xy(dom.polygon, face[:, 0], face[:, 1]).all()


def test_bubble_mesh_graded_follows_size():
    fn = lambda xy: 0.015 + 0.045 * xy[:, 0]  # noqa: E731
    grid = GridSize.from_function(fn, (0, 0, 1, 1), (5, 5))
    probe = np.random.default_rng(0).random((100, 2))
    np.testing.assert_allclose(grid(probe), fn(probe), rtol=1e-12)  # bilinear is exact on linear fields
    dom = validate_domain(SQUARE, [circle(0.5, 0.5, 0.25, 56)])
    bm = bubble_mesh(dom, (), grid, seed=2)
    check_conforming_mesh(bm.nodes, bm.triangles, dom)
    e = mesh_edges(bm.triangles)
    length = np.linalg.norm(bm.nodes[e[:, 0]] - bm.nodes[e[:, 1]], axis=1)
    ratio = length / fn(0.5 * (bm.nodes[e[:, 0]] + bm.nodes[e[:, 1]]))
    assert np.mean((ratio >= 0.7) & (ratio <= 1.4)) >= 0.90
    # the mesh is finer where the size is smaller
    left = bm.nodes[:, 0] < 0.25
    right = bm.nodes[:, 0] > 0.75
    assert left.sum() > 3 * right.sum()


def test_bubble_mesh_deterministic_and_relaxation_helps():
    a = bubble_mesh(SQUARE, (), 0.08, init="random", seed=5)
    b = bubble_mesh(SQUARE, (), 0.08, init="random", seed=5)
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    c = bubble_mesh(SQUARE, (), 0.08, init="random", seed=6)
    assert len(c.initial) != len(a.initial) or not np.array_equal(c.initial, a.initial)
    # Fig. 2.7: Delaunay of the initial (random) bubbles vs of the relaxed ones
    nb = int((a.kind < 2).sum())
    raw = constrained_delaunay(a.initial, a.constrained_edges)
    _, q_raw = triangle_quality(raw.nodes, raw.triangles)
    _, q = triangle_quality(a.nodes, a.triangles)
    assert len(a.initial) > nb
    assert q.mean() > q_raw.mean() + 0.1


def test_edge_bubbles_uniform_spacing():
    xy, seg = edge_bubbles(SQUARE, 0.1)
    assert len(xy) == 4 * 9
    np.testing.assert_array_equal(np.bincount(seg), [9, 9, 9, 9])
    np.testing.assert_allclose(xy[:9, 0], np.arange(1, 10) / 10, atol=1e-12)
    np.testing.assert_allclose(xy[:9, 1], 0.0, atol=1e-12)


# ---------------------------------------------------------------------------
# quality
# ---------------------------------------------------------------------------

def test_quality_closed_forms():
    nodes = np.array([[0, 0], [1, 0], [0.5, math.sqrt(3) / 2], [0, 1], [0.5, 1e-3]], float)
    tri = np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4]])
    ang, q = triangle_quality(nodes, tri)
    assert q[0] == pytest.approx(1.0) and ang[0] == pytest.approx(60.0)
    # right isosceles: r_in = (2 - sqrt 2)/2, R = sqrt(2)/2
    assert q[1] == pytest.approx(2 * (2 - math.sqrt(2)) / 2 / (math.sqrt(2) / 2))
    assert ang[1] == pytest.approx(45.0)
    assert q[2] < 0.01
    # random triangles against the textbook formulas (Heron-free: area from the cross product)
    p = np.random.default_rng(0).random((50, 3, 2))
    nodes2 = p.reshape(-1, 2)
    tri2 = np.arange(150).reshape(50, 3)
    ar = triangle_areas(nodes2, tri2)
    tri2[ar < 0] = tri2[ar < 0][:, ::-1]
    ang2, q2 = triangle_quality(nodes2, tri2)
    la = np.linalg.norm(p[:, 1] - p[:, 2], axis=1)
    lb = np.linalg.norm(p[:, 2] - p[:, 0], axis=1)
    lc = np.linalg.norm(p[:, 0] - p[:, 1], axis=1)
    area = np.abs(triangle_areas(nodes2, tri2))
    s = 0.5 * (la + lb + lc)
    np.testing.assert_allclose(q2, 2 * (area / s) / (la * lb * lc / (4 * area)), rtol=1e-10)
    cosines = [(lb**2 + lc**2 - la**2) / (2 * lb * lc), (la**2 + lc**2 - lb**2) / (2 * la * lc),
               (la**2 + lb**2 - lc**2) / (2 * la * lb)]
    np.testing.assert_allclose(ang2, np.degrees(np.arccos(np.clip(cosines, -1, 1))).min(axis=0), atol=1e-9)
    counts, edges = quality_histogram(q2, bins=5)
    assert counts.sum() == 50 and edges[0] == 0 and edges[-1] == 1


# ---------------------------------------------------------------------------
# patches, elements, adaptive subdivision, T-vertices
# ---------------------------------------------------------------------------

def barycentric_inside(p, tri_pts, tol=1e-12):
    a, b, c = tri_pts[:, 0], tri_pts[:, 1], tri_pts[:, 2]
    def cross(u, v):
        return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    return (cross(b - a, p - a) >= -tol) & (cross(c - b, p - b) >= -tol) & (cross(a - c, p - c) >= -tol)


@pytest.fixture(scope="module")
def coarse():
    dom = validate_domain(SQUARE, [circle(0.5, 0.5, 0.2, 12)])
    return dom, bubble_mesh(dom, (), 0.12, seed=1)


def test_subdivide_patches(coarse):
    dom, bm = coarse
    pe = subdivide_patches(bm.nodes, bm.triangles, levels=2)
    assert len(pe.elements) == 16 * len(bm.triangles)
    np.testing.assert_array_equal(pe.nodes[: len(bm.nodes)], bm.nodes)
    np.testing.assert_array_equal(np.bincount(pe.element_patch), np.full(len(bm.triangles), 16))
    cen = pe.nodes[pe.elements].mean(axis=1)
    assert barycentric_inside(cen, pe.nodes[pe.patches[pe.element_patch]]).all()
    check_conforming_mesh(pe.nodes, pe.elements, dom)
    # shared nodes: V - E + F = chi = 1 - holes for a conforming mesh of the domain
    n_edges = len(mesh_edges(pe.elements))
    assert len(pe.nodes) - n_edges + len(pe.elements) == 1 - len(dom.holes)
    np.testing.assert_allclose(
        np.bincount(pe.element_patch, weights=triangle_areas(pe.nodes, pe.elements)),
        triangle_areas(bm.nodes, bm.triangles), rtol=1e-12)


def test_bubble_subdivide_patches(coarse):
    dom, bm = coarse
    pe = bubble_subdivide_patches(bm.nodes, bm.triangles, 0.04, seed=3)
    np.testing.assert_array_equal(pe.nodes[: len(bm.nodes)], bm.nodes)
    check_conforming_mesh(pe.nodes, pe.elements, dom)
    assert pe.element_patch.min() >= 0
    # every element lies in one patch: per-patch element areas add up to the patch area
    np.testing.assert_allclose(
        np.bincount(pe.element_patch, weights=triangle_areas(pe.nodes, pe.elements),
                    minlength=len(bm.triangles)),
        triangle_areas(bm.nodes, bm.triangles), rtol=1e-9)
    ang, q = triangle_quality(pe.nodes, pe.elements)
    assert ang.min() > 20.0 and q.mean() > 0.9
    assert np.bincount(pe.element_patch).min() >= 3


def test_locate_in_triangles_matches_brute_force(coarse):
    dom, bm = coarse
    xy = np.random.default_rng(4).random((3000, 2))
    xy = xy[shapely.contains_xy(dom.polygon, xy[:, 0], xy[:, 1])]
    got = locate_in_triangles(xy, bm.nodes, bm.triangles)
    tri_pts = bm.nodes[bm.triangles]
    for k in range(0, len(xy), 7):
        inside = barycentric_inside(np.repeat(xy[k:k + 1], len(tri_pts), axis=0), tri_pts)
        assert inside[got[k]]


def test_t_vertex_detector_finds_hanging_node():
    nodes = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]], float)
    # left: triangle (0, 1, 2) split at the diagonal midpoint 4; right: (0, 2, 3) not split
    tri = np.array([[0, 1, 4], [4, 1, 2], [0, 2, 3]])
    tv, over = find_t_vertices(nodes, tri)
    assert tv.tolist() == [4]
    assert not is_t_vertex_free(nodes, tri)
    tri_ok = np.array([[0, 1, 4], [4, 1, 2], [0, 4, 3], [4, 2, 3]])
    assert is_t_vertex_free(nodes, tri_ok)
    over_tri = np.array([[0, 1, 2], [0, 2, 3], [2, 0, 4]])
    assert len(find_t_vertices(nodes, over_tri)[1]) == 1


def test_red_split_without_closure_is_caught_and_with_closure_is_not(coarse):
    dom, bm = coarse
    interior = np.flatnonzero((bm.kind[bm.triangles] == 2).all(axis=1))[0]
    marked = np.zeros(len(bm.triangles), bool)
    marked[interior] = True
    n2, t2, parent, _ = refine_marked(bm.nodes, bm.triangles, marked, method="red-green")
    check_conforming_mesh(n2, t2, dom)
    assert np.bincount(parent, minlength=len(bm.triangles))[interior] == 4
    # naive: four children, neighbours untouched -> three T-vertices
    naive = np.vstack([bm.triangles[~marked], t2[parent == interior]])
    assert len(find_t_vertices(n2, naive)[0]) == 3


@pytest.mark.parametrize("per", ["node", "element"])
def test_adaptive_subdivision_refines_at_jump(coarse, per):
    dom, bm = coarse
    step = lambda xy: (xy[:, 0] > 0.37).astype(float)  # noqa: E731
    if per == "node":
        values = step(bm.nodes)
    else:
        values = step(bm.nodes[bm.triangles].mean(axis=1))
    res = adaptive_subdivision(bm.nodes, bm.triangles, values, 0.5, levels=3, per=per, value_fn=step)
    check_conforming_mesh(res.nodes, res.triangles, dom)
    assert len(res.triangles) > len(bm.triangles)
    assert res.n_marked[0] > 0
    # children lie in their parents
    cen = res.nodes[res.triangles].mean(axis=1)
    assert barycentric_inside(cen, bm.nodes[bm.triangles[res.parent]]).all()
    # refined where the value jumps, untouched far from it
    area = triangle_areas(res.nodes, res.triangles)
    near = np.abs(cen[:, 0] - 0.37) < 0.03
    far = np.abs(cen[:, 0] - 0.37) > 0.3
    assert np.median(area[near]) < 0.1 * np.median(area[far])
    orig_far = np.abs(bm.nodes[bm.triangles].mean(axis=1)[:, 0] - 0.37) > 0.3
    assert np.median(area[far]) == pytest.approx(np.median(triangle_areas(bm.nodes, bm.triangles)[orig_far]), rel=0.3)


def test_adaptive_subdivision_interpolates_and_rgb(coarse):
    dom, bm = coarse
    rgb = np.stack([bm.nodes[:, 0], np.zeros(len(bm.nodes)), 3 * bm.nodes[:, 1]], axis=1)
    res = adaptive_subdivision(bm.nodes, bm.triangles, rgb, 0.2, levels=2)
    # linear values: the interpolated values are exact at the new nodes
    np.testing.assert_allclose(res.values[:, 0], res.nodes[:, 0], atol=1e-12)
    np.testing.assert_allclose(res.values[:, 2], 3 * res.nodes[:, 1], atol=1e-12)
    check_conforming_mesh(res.nodes, res.triangles, dom)
    with pytest.raises(ValueError, match="values"):
        adaptive_subdivision(bm.nodes, bm.triangles, rgb[:-1], 0.2)


def test_bubble_subdivide_patches_slanted_edges():
    # A quadrilateral whose sides are nearly but not exactly axis-parallel (like the published
    # Cornell floor): patch nodes on a side are collinear only up to round-off, and the convex
    # hull of the element bubbles leaves zero-area slivers there; none may survive as elements.
    quad = np.array([[-277.2, -279.6], [275.6, -279.6], [275.6, 279.6], [-274.0, 279.6]])
    bm = bubble_mesh(quad, (), 80.0, seed=0)
    pe = bubble_subdivide_patches(bm.nodes, bm.triangles, 40.0, seed=0)
    dom = validate_domain(quad)
    check_conforming_mesh(pe.nodes, pe.elements, dom)
    ang, q = triangle_quality(pe.nodes, pe.elements)
    assert ang.min() > 20.0
    np.testing.assert_allclose(triangle_areas(pe.nodes, pe.elements).sum(), dom.area, rtol=1e-12)

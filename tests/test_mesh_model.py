"""The radiosity mesh model of chapters 3 and 4 (issue 13, part 4).

Constrained D0/D1 segments honoured by both meshers, regions with their own
sizes, holes that touch, conforming nodes between regions and between
polygons, two-sided polygons and convex pieces.
"""

import functools

import numpy as np
import pytest
import shapely

from polygen.mesh2d import GridSize, planar_graph
from polygen.radiosity import (
    Polygon,
    RegionSize,
    Scene,
    Segments,
    polygon_layout,
)
from polygen.radiosity.mesh import (
    bubble_element_mesher,
    bubble_mesher,
    lattice_delaunay_mesher,
    mesh_scene,
)
from polygen.radiosity.raster import node_intensities

MESHERS = {"lattice": lattice_delaunay_mesher, "bubble": bubble_mesher}


def square(side=4.0, z=0.0, name="square", **kw):
    return Polygon([[0, 0, z], [side, 0, z], [side, side, z], [0, side, z]], name=name, **kw)


def _edge_set(mesh, el):
    e = mesh.node_site[mesh.elements[el]]
    e = np.sort(np.concatenate([e[:, [0, 1]], e[:, [1, 2]], e[:, [2, 0]]]), axis=1)
    return {tuple(x) for x in e.tolist()}


# ----------------------------------------------------------------------------
# D0 and D1 segments
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("mesher", ["lattice", "bubble", "bubble+bubble"])
@pytest.mark.parametrize("kind", ["D0", "D1"])
def test_segment_across_square(kind, mesher):
    s = Scene([square()])
    em = bubble_element_mesher if mesher == "bubble+bubble" else None
    m = mesh_scene(s, 1.0, mesher=MESHERS[mesher.split("+")[0]], element_mesher=em,
                   segments={0: Segments([[[2.0, 0.0, 0.0], [2.0, 4.0, 0.0]]], kind)})
    x = m.element_centroid[:, 0]
    # no element crosses the segment
    ex = m.nodes[m.elements][:, :, 0]
    assert np.all((ex.max(axis=1) <= 2.0 + 1e-12) | (ex.min(axis=1) >= 2.0 - 1e-12))
    right = x > 2.0
    assert 0 < right.sum() < m.n_elements
    # the mesh knows each element's region
    assert m.layouts[0].n_regions == 2
    reg = m.element_region
    assert set(reg[right].tolist()) != set(reg[~right].tolist())
    assert len(set(reg[right].tolist())) == len(set(reg[~right].tolist())) == 1
    nodes_i = node_intensities(m, right.astype(float))
    on = np.abs(m.nodes[:, 0] - 2.0) < 1e-9
    sites, count = np.unique(m.node_site[on], return_counts=True)
    assert len(sites) >= 5  # the 4-long line split at size 1 at least
    if kind == "D0":
        # every point on the line has two nodes, one per side, never averaged across
        assert np.all(count == 2)
        off, ne = m.node_elements
        for n in np.flatnonzero(on):
            side = right[ne[off[n]:off[n + 1]]]
            assert side.all() or not side.any()
            assert nodes_i[n] == float(side[0])
        # nodes off the line keep their side's value exactly
        assert np.all(nodes_i[m.nodes[:, 0] < 2.0 - 1e-9] == 0.0)
        assert np.all(nodes_i[m.nodes[:, 0] > 2.0 + 1e-9] == 1.0)
    else:
        assert np.all(count == 1)
        # shared nodes: the mean (2.8) over elements of both sides (brute force)
        off, ne = m.node_elements
        for n in np.flatnonzero(on):
            adj = right[ne[off[n]:off[n + 1]]]
            assert 0 < adj.mean() < 1
            assert nodes_i[n] == pytest.approx(adj.mean())
        if mesher == "lattice":  # the lattice mesh is mirror-symmetric about the line
            np.testing.assert_allclose(nodes_i[on], 0.5)
    assert len(m.t_vertices()) == 0
    # elements tile the square, and each patch's corners are nodes of its own elements
    assert m.element_area.sum() == pytest.approx(16.0)
    used = {(p, n) for p, row in zip(m.element_patch.tolist(), m.elements.tolist()) for n in row}
    assert all((p, n) in used for p, row in enumerate(m.patches.tolist()) for n in row)


def test_d0_loop_and_dangling_end():
    # a closed D0 loop (an umbra) and a D0 line ending inside the polygon
    loop = np.array([[1, 1], [2, 1], [2, 2], [1, 2]], dtype=float)
    ends = np.concatenate([np.stack([loop, np.roll(loop, -1, axis=0)], axis=1),
                           [[[3.0, 0.0], [3.0, 2.5]]]])
    ends = np.concatenate([ends, np.zeros(ends.shape[:2] + (1,))], axis=2)  # 3-D, z = 0
    m = mesh_scene(Scene([square()]), 0.5, segments=[Segments(ends, "D0")])
    xy = m.nodes[:, :2]
    on_loop = shapely.dwithin(shapely.LinearRing(loop), shapely.points(xy), 1e-9)
    _, cnt = np.unique(m.node_site[on_loop], return_counts=True)
    assert np.all(cnt == 2)
    # the interior end of the dangling line keeps one node, its other nodes two
    tip = np.flatnonzero(np.hypot(xy[:, 0] - 3.0, xy[:, 1] - 2.5) < 1e-9)
    assert len(tip) == 1
    line = (np.abs(xy[:, 0] - 3.0) < 1e-9) & (xy[:, 1] < 2.5 - 1e-9)
    _, cnt = np.unique(m.node_site[line], return_counts=True)
    assert np.all(cnt == 2)
    assert len(m.t_vertices()) == 0


def test_t_vertices_across_a_d0_line_are_not_reported():
    # [0, 2] x [0, 1] cut by a D0 line at x = 1; the right side has a node (1, 0.5)
    # on the line that the left side lacks (e.g. after refining the right side only)
    from polygen.radiosity import RadiosityMesh

    s = Scene([Polygon([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]])])
    nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],            # left
                      [1, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 0.5, 0]], float)
    left = [[0, 1, 2], [0, 2, 3]]
    right = [[4, 5, 8], [8, 5, 6], [8, 6, 7]]
    m = RadiosityMesh(s, nodes, left + right, [0, 0, 1, 1, 1], [[0, 1, 2], [4, 5, 6]], [0, 0])
    assert len(m.t_vertices()) == 0
    # the same right side sharing the left side's nodes: (1, 0.5) is a T-vertex
    joined = [[1, 5, 8], [8, 5, 6], [8, 6, 2]]
    m2 = RadiosityMesh(s, nodes, left + joined, [0, 0, 1, 1, 1], [[0, 1, 2], [1, 5, 6]], [0, 0])
    assert m2.t_vertices().tolist() == [8]


# ----------------------------------------------------------------------------
# regions: shared edges, sizes, holes that touch
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("mesher", sorted(MESHERS))
def test_regions_share_nodes_and_follow_sizes(mesher):
    """An 8 x 8 square cut by a D1 line into two regions of sizes 0.25 and 1.0.

    Tolerance 25 %: a constant-size lattice has every interior edge exactly
    h, but edges touching a region's boundary range over [h/2, 3h/2] (edge
    nodes at most h apart, face nodes at least h/2 from an edge), and the
    bubble packing settles at r0 = h only in the bulk (2.11), at the mean
    of the two sizes next to a finer edge; the regions are many sizes wide
    (4 x 8 at h = 1) so that this boundary layer does not dominate the mean.
    The common edge takes the smaller size (3.3.6), so its edges count for
    the finer region only.
    """
    s = Scene([square(8.0)])
    sizes = RegionSize([0.25, 1.0], at=[[2.0, 4.0, 0.0], [6.0, 4.0, 0.0]])
    seg = Segments([[[4.0, 0.0, 0.0], [4.0, 8.0, 0.0]]], "D1")
    m = mesh_scene(s, sizes, mesher=MESHERS[mesher], element_levels=0, segments=[seg])
    x = m.element_centroid[:, 0]
    left, right = np.flatnonzero(x < 4.0), np.flatnonzero(x > 4.0)
    # every node on the common edge is a node of both regions, with the same edges along it
    on = set(np.flatnonzero(np.abs(m.nodes[:, 0] - 4.0) < 1e-9).tolist())
    assert on <= set(m.elements[left].ravel().tolist())
    assert on <= set(m.elements[right].ravel().tolist())
    along = {e for e in _edge_set(m, left) if set(e) <= on}
    assert along == {e for e in _edge_set(m, right) if set(e) <= on}
    assert len(along) == len(on) - 1
    # the common edge takes the smaller size (3.3.6)
    ys = np.sort(m.nodes[list(on), 1])
    assert np.diff(ys).max() <= 0.25 * 1.25
    for el, h in ((left, 0.25), (right, 1.0)):
        e = np.array(sorted(_edge_set(m, el) - (along if h == 1.0 else set())))
        ln = np.linalg.norm(m.nodes[e[:, 0]] - m.nodes[e[:, 1]], axis=1)
        assert abs(ln.mean() / h - 1.0) < 0.25, (h, ln.mean())
    assert len(m.t_vertices()) == 0


@pytest.mark.parametrize("mesher", sorted(MESHERS))
def test_grid_size_per_polygon_reaches_the_mesher(mesher):
    # chapter 4 hands a size grid per polygon: 0.2 at u = 0 growing to 0.8 at u = 4;
    # the edge lengths follow it within the 25 % of the region test, in every quarter
    poly = square()
    lo = poly.to_2d(np.array([[0, 0, 0], [4, 4, 0]], dtype=float)).min(axis=0)
    grid = GridSize.from_function(lambda xy: 0.2 + 0.15 * (xy[:, 0] - lo[0]),
                                  (lo[0], lo[1], lo[0] + 4, lo[1] + 4), (5, 5))
    m = mesh_scene(Scene([poly]), [grid], mesher=MESHERS[mesher], element_levels=0)
    e = np.array(sorted(_edge_set(m, np.arange(m.n_elements))))
    mid = poly.to_2d(0.5 * (m.nodes[e[:, 0]] + m.nodes[e[:, 1]]))
    ratio = np.linalg.norm(m.nodes[e[:, 0]] - m.nodes[e[:, 1]], axis=1) / grid(mid)
    quarter = np.clip(((mid[:, 0] - lo[0]) // 1.0).astype(int), 0, 3)
    for q in range(4):
        assert abs(ratio[quarter == q].mean() - 1.0) < 0.25, (q, ratio[quarter == q].mean())
    assert m.element_area.sum() == pytest.approx(16.0)
    assert len(m.t_vertices()) == 0


@pytest.mark.parametrize("mesher", sorted(MESHERS))
def test_holes_touching_ring_and_each_other(mesher):
    holes = [[[0, 0, 0], [1, 2, 0], [2, 1, 0]],          # touches the outer ring at a corner
             [[2, 2, 0], [3, 2, 0], [3, 3, 0]],          # touches the next hole at (2, 2)
             [[2, 2, 0], [2, 3, 0], [1.5, 3, 0]],
             [[4, 2, 0], [3.5, 2.5, 0], [3.5, 1.5, 0]]]  # touches the outer ring mid-edge
    poly = Polygon([[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0]], holes, name="holed")
    m = mesh_scene(Scene([poly]), 0.3, mesher=MESHERS[mesher],
                   element_mesher=bubble_element_mesher if mesher == "bubble" else None)
    assert m.element_area.sum() == pytest.approx(poly.area, rel=1e-12)
    c = poly.to_2d(m.element_centroid)
    assert np.all(shapely.contains_xy(poly._shape2d, c[:, 0], c[:, 1]))
    # elements face the front: no overlap, since their areas add up to the polygon's
    e = m.nodes[m.elements]
    assert np.all(np.cross(e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]) @ poly.normal > 0)
    assert len(m.t_vertices()) == 0


def test_layout_regions_faces_with_holes():
    # a loop inside a loop: three regions, the middle one a face with a hole
    def ring(a, b):
        r = np.array([[a, a], [b, a], [b, b], [a, b]], dtype=float)
        return np.stack([r, np.roll(r, -1, axis=0)], axis=1)

    poly = square()
    ends = np.concatenate([ring(0.5, 3.5), ring(1.5, 2.5)])
    ends = np.concatenate([ends, np.zeros(ends.shape[:2] + (1,))], axis=2)  # 3-D, z = 0
    g = polygon_layout(poly, Segments(ends, "D0"))
    assert g.n_regions == 3
    np.testing.assert_allclose(np.sort(g.region_area), [1.0, 7.0, 8.0])
    mid = g.region_of(poly.to_2d(np.array([[1.0, 2.0, 0.0]])))[0]
    assert g.region_area[mid] == pytest.approx(8.0)
    assert len(g.region_polygon(mid).interiors) == 1
    # region points are inside their regions
    assert np.all(g.region_of(g.region_point) == np.arange(3))


# ----------------------------------------------------------------------------
# conforming nodes between polygons
# ----------------------------------------------------------------------------
def _on_line(m, poly_index, a, b, tol=1e-9):
    pts = m.nodes[np.unique(m.elements[m.element_polygon == poly_index])]
    d = b - a
    t = (pts - a) @ d / (d @ d)
    off = np.linalg.norm(pts - (a + t[:, None] * d), axis=1)
    return pts[(off < tol) & (t > -tol) & (t < 1 + tol)]


def _same_points(p, q, tol=1e-9):
    if len(p) != len(q):
        return False
    d = np.linalg.norm(p[:, None] - q[None], axis=2)
    return bool(np.all(d.min(axis=1) < tol) and np.all(d.min(axis=0) < tol))


@pytest.mark.parametrize("mesher,elements", [("lattice", "split"), ("bubble", "split"),
                                             ("bubble", "bubble")])
def test_polygons_sharing_an_edge_conform(mesher, elements):
    # a floor and a narrower wall standing on part of its front edge, sizes 1.0 and 0.3
    floor = square(name="floor")
    wall = Polygon([[1, 0, 0], [1, 0, 2], [3, 0, 2], [3, 0, 0]], name="wall")
    s = Scene([floor, wall])
    em = bubble_element_mesher if elements == "bubble" else None
    m = mesh_scene(s, [1.0, 0.3], mesher=MESHERS[mesher], element_mesher=em)
    a, b = np.array([1.0, 0, 0]), np.array([3.0, 0, 0])
    pf, pw = _on_line(m, 0, a, b), _on_line(m, 1, a, b)
    assert len(pw) >= 2 / (0.3 / 2) * 0.8
    assert _same_points(pf, pw)  # both directions
    assert len(m.t_vertices()) == 0
    # without conforming, the floor's coarser nodes do not match the wall's
    m2 = mesh_scene(s, [1.0, 0.3], mesher=MESHERS[mesher], element_mesher=em, conforming=False)
    assert not _same_points(_on_line(m2, 0, a, b), _on_line(m2, 1, a, b))


def test_block_on_floor_hole_ring_conforms():
    # a block's side faces meeting the floor's hole ring (the floor cut where the block stands)
    hole = np.array([[1, 1, 0], [1, 3, 0], [3, 3, 0], [3, 1, 0]], dtype=float)
    floor = Polygon([[0, 0, 0], [5, 0, 0], [5, 5, 0], [0, 5, 0]], [hole], name="floor")
    sides = []
    for k in range(4):
        p, q = hole[(k + 1) % 4], hole[k]
        sides.append(Polygon([p, q, q + [0, 0, 1], p + [0, 0, 1]], name=f"side{k}"))
    s = Scene([floor] + sides)
    m = mesh_scene(s, [1.0, 0.35, 0.35, 0.35, 0.35], mesher=bubble_mesher)
    for k in range(4):
        a, b = hole[k], hole[(k + 1) % 4]
        assert _same_points(_on_line(m, 0, a, b), _on_line(m, k + 1, a, b))
    assert len(m.t_vertices()) == 0


# ----------------------------------------------------------------------------
# two-sided polygons and convex pieces
# ----------------------------------------------------------------------------
def test_two_sided_polygon_has_two_faces():
    occ = Polygon([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], name="occluder", two_sided=True)
    m = mesh_scene(Scene([occ]), 0.4)
    one = mesh_scene(Scene([square(1.0, 1.0)]), 0.4)
    assert m.n_patches == 2 * one.n_patches and m.n_elements == 2 * one.n_elements
    side = m.element_side
    np.testing.assert_array_equal(np.unique(side), [-1, 1])
    np.testing.assert_allclose(m.element_normal, side[:, None] * occ.normal)
    np.testing.assert_allclose(m.patch_normal, m.patch_side[:, None] * occ.normal)
    # each face's elements are counter-clockwise seen from that face
    e = m.nodes[m.elements]
    cr = np.cross(e[:, 1] - e[:, 0], e[:, 2] - e[:, 0])
    assert np.all(np.einsum("ij,ij->i", cr, m.element_normal) > 0)
    for sd in (1, -1):
        assert m.element_area[side == sd].sum() == pytest.approx(1.0)
    # patch frames: right-handed, the third axis the face's normal
    fr = m.patch_frame
    np.testing.assert_allclose(np.linalg.det(fr), 1.0)
    np.testing.assert_allclose(fr[:, 2], m.patch_normal)
    # nodes are not shared between the faces
    assert not set(m.elements[side == 1].ravel()) & set(m.elements[side == -1].ravel())
    assert len(m.t_vertices()) == 0


def _star(n, seed):
    rng = np.random.default_rng(seed)
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = rng.uniform(0.3, 1.0, n)
    return np.stack([r * np.cos(ang), r * np.sin(ang), np.zeros(n)], axis=1)


@pytest.mark.parametrize("case", ["L", "hole", "star0", "star1", "star2"])
def test_convex_pieces(case):
    if case == "L":
        poly = Polygon([[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0]])
    elif case == "hole":
        poly = Polygon([[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0]],
                       [[[1, 1, 0], [3, 1, 0], [2, 3, 0]]], reflectance=0.3)
    else:
        poly = Polygon(_star(12, int(case[-1])))
    pieces = poly.convex_pieces()
    assert all(p.is_convex for p in pieces)
    assert sum(p.area for p in pieces) == pytest.approx(poly.area, rel=1e-12)
    # the pieces tile the polygon: each inside it, no two overlapping, areas summing to its area
    # (not by shapely.union_all: GEOS 3.14's union of these edge-sharing pieces lost one, 0.18 of 1.05)
    shapes = [shapely.Polygon(poly.to_2d(p.vertices)) for p in pieces]
    assert all(s.difference(poly._shape2d).area < 1e-9 * poly.area for s in shapes)
    assert sum(shapes[i].intersection(shapes[j]).area
               for i in range(len(shapes)) for j in range(i + 1, len(shapes))) < 1e-9 * poly.area
    for p in pieces:
        np.testing.assert_allclose(p.normal, poly.normal, atol=1e-9)
        np.testing.assert_array_equal(p.reflectance, poly.reflectance)
    if case == "L":
        assert len(pieces) <= 3  # Hertel-Mehlhorn: at most 4 x the optimum (2)


def test_planar_graph_noding():
    # a T-junction, a segment ending on the ring, and collinear overlapping segments
    sq = np.array([[0, 0], [4, 0], [4, 4], [0, 4]], dtype=float)
    segs = [[[0, 2], [4, 2]], [[2, 2], [2, 4]], [[1, 2], [3, 2]]]
    g = planar_graph(sq, [], segs, ["D1", "D0", "D0"])
    assert g.n_regions == 3
    assert sorted(np.round(g.region_area, 12).tolist()) == [4.0, 4.0, 8.0]
    # the overlap takes the stronger kind (D0) between x = 1 and x = 3
    mid = g.vertices[g.edges].mean(axis=1)
    on = np.abs(mid[:, 1] - 2.0) < 1e-12
    assert set(g.edge_kind[on & (mid[:, 0] > 1) & (mid[:, 0] < 3)].tolist()) == {1}
    assert set(g.edge_kind[on & ((mid[:, 0] < 1) | (mid[:, 0] > 3))].tolist()) == {2}


def test_seeded_and_partial_meshers_deterministic():
    seg = Segments([[[2.0, 0.0, 0.0], [2.0, 4.0, 0.0]]], "D0")
    mk = functools.partial(bubble_mesher, seed=3)
    a = mesh_scene(Scene([square()]), 0.7, mesher=mk, segments=[seg])
    b = mesh_scene(Scene([square()]), 0.7, mesher=mk, segments=[seg])
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_array_equal(a.elements, b.elements)


@pytest.mark.parametrize("two_sided", [True, False])
def test_two_sided_plate_in_the_furnace(two_sided):
    """A plate inside the furnace box, emitting and reflecting like the walls.

    With both faces meshed every element's hemisphere is covered by surfaces
    of radiosity E / (1 - rho) = 2, so B = 2 everywhere (the furnace test of
    issue 13, within its 1 %).  One-sided, the plate's bare back face is
    dark, and the walls below it fall short of 2.
    """
    from polygen.radiosity import progressive_refinement, scenes

    plate = Polygon([[0.25, 0.5, 0.25], [0.75, 0.5, 0.25], [0.75, 0.5, 0.75], [0.25, 0.5, 0.75]],
                    emission=1.0, reflectance=0.5, two_sided=two_sided, name="plate")
    s = Scene(scenes.furnace_box().polygons + [plate])
    m = mesh_scene(s, 0.25, element_levels=1)
    r = progressive_refinement(m, tol=1e-6)   # the default factors, k x k visibility rays
    b = np.asarray(r.radiosity).reshape(m.n_elements, -1)[:, 0]
    if two_sided:
        np.testing.assert_allclose(b, 2.0, rtol=0.01)
        on_plate = m.element_polygon == len(s.polygons) - 1
        assert set(m.element_side[on_plate].tolist()) == {-1, 1}
    else:
        assert b.min() < 1.9


def _block_sides(hole, height=1.0):
    out = []
    for k in range(len(hole)):
        p, q = hole[(k + 1) % len(hole)], hole[k]
        out.append(Polygon([p, q, q + [0, 0, height], p + [0, 0, height]], name=f"side{k}"))
    return out


def test_contact_lines_are_d0_and_conform():
    # a block standing on an uncut floor: its bottom edges become D0 segments of the floor
    from polygen.radiosity import contact_segments

    foot = np.array([[1, 1, 0], [1, 3, 0], [3, 3, 0], [3, 1, 0]], dtype=float)
    floor = Polygon([[0, 0, 0], [5, 0, 0], [5, 5, 0], [0, 5, 0]], name="floor")
    s = Scene([floor] + _block_sides(foot))
    segs = contact_segments(s)
    assert list(segs) == [0] and len(segs[0]) == 4
    m = mesh_scene(s, [1.0] + [0.35] * 4, mesher=bubble_mesher, segments=segs)
    for k in range(4):
        a, b = foot[k], foot[(k + 1) % 4]
        on_floor = _on_line(m, 0, a, b)
        uniq = np.unique(on_floor.round(9), axis=0)
        assert len(on_floor) == 2 * len(uniq)  # D0: one node per side
        assert _same_points(uniq, _on_line(m, k + 1, a, b))
    assert len(m.t_vertices()) == 0


def test_region_numbers_survive_neighbour_vertices():
    # a wall adds vertices to the floor's edge; RegionSize by region number still
    # means the regions of polygon_layout(floor, segments)
    floor = square(name="floor")
    wall = Polygon([[1, 0, 0], [1, 0, 2], [3, 0, 2], [3, 0, 0]], name="wall")
    seg = Segments([[[2.0, 0.0, 0.0], [2.0, 4.0, 0.0]]], "D1")
    lay = polygon_layout(floor, seg)
    left = int(lay.region_of(floor.to_2d(np.array([[1.0, 2.0, 0.0]])))[0])
    sizes = [0.25 if r == left else 1.0 for r in range(lay.n_regions)]
    m = mesh_scene(Scene([floor, wall]), [RegionSize(sizes), 0.5], element_levels=0,
                   segments={"floor": seg})
    el = np.flatnonzero(m.element_polygon == 0)
    x = m.element_centroid[el, 0]
    n_left, n_right = (x < 2).sum(), (x > 2).sum()
    # equal areas, sizes 1 : 4 -> element counts about 16 : 1
    assert n_left > 8 * n_right

"""Chapter 4's intensity-based bubble mesh: intensity variation (4.1), size function
(4.2-4.4), per-polygon size grids (4.3.2) and the two-pass loop (Fig. 4.3)."""

import numpy as np
import pytest

from polygen.mesh2d import GridSize
from polygen.radiosity import MeshError, Scene, bubble_mesher, mesh_scene, scenes
from polygen.radiosity.intensity import (
    PHASES,
    check_size_parameters,
    error_at_elements,
    intensity_bubble_mesh,
    intensity_variation,
    match_element_count,
    polygon_size_grids,
    remesh_polygon,
    size_function,
)

# Table 4.1 (elements): first mesh, conventional adaptive re-mesh, this method
THESIS_TABLE_4_1 = {"first": 1976, "adaptive": 3205, "intensity": 1396}


@pytest.fixture(scope="module")
def coarse():
    """The scene of Fig. 4.8 with coarse patches (a few hundred elements)."""
    return mesh_scene(scenes.three_rectangles_box(), 4.0, mesher=bubble_mesher)


def test_intensity_variation_brute_force(coarse):
    rng = np.random.default_rng(0)
    vals = rng.uniform(0.0, 2.0, size=(coarse.n_nodes, 3))
    got = intensity_variation(coarse, vals)
    ref = np.zeros(coarse.n_nodes)
    for tri in coarse.elements:
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            g = np.abs(vals[a] - vals[b]).max() / np.linalg.norm(coarse.nodes[a] - coarse.nodes[b])
            ref[a] = max(ref[a], g)
            ref[b] = max(ref[b], g)
    np.testing.assert_allclose(got, ref, rtol=1e-12)


def test_intensity_variation_linear_field(coarse):
    """I = g . x on one flat polygon: |dI| / dist = |g . e| / |e| <= |g|, = for an edge along g."""
    g = np.array([0.3, 0.0, 0.4])
    vals = coarse.nodes @ g
    d = intensity_variation(coarse, vals)
    assert d.max() <= np.linalg.norm(g) * (1 + 1e-12)
    np.testing.assert_array_equal(intensity_variation(coarse, np.ones(coarse.n_nodes)), 0.0)


def test_intensity_variation_bad_input(coarse):
    with pytest.raises(MeshError, match="rows"):
        intensity_variation(coarse, np.zeros(coarse.n_nodes + 1))
    with pytest.raises(MeshError, match="NaN"):
        intensity_variation(coarse, np.full(coarse.n_nodes, np.nan))


def test_size_function_is_the_line_of_4_4():
    d = np.array([0.2, 1.0, 0.6, 0.2, 0.4])
    f = size_function(d, size_min=3.0, size_max=0.5)
    assert f[0] == pytest.approx(3.0) and f[1] == pytest.approx(0.5)  # (4.2)
    # linear, decreasing: f(0.6) is halfway, f(0.4) a quarter of the way
    assert f[2] == pytest.approx(1.75) and f[4] == pytest.approx(2.375)
    np.testing.assert_array_equal(size_function(np.full(4, 0.3), size_min=3.0, size_max=0.5), 3.0)
    with pytest.raises(MeshError, match="size_max < size_min"):
        size_function(d, size_min=0.5, size_max=3.0)
    with pytest.raises(MeshError, match="variation"):
        size_function(-d, size_min=3.0, size_max=0.5)


@pytest.mark.parametrize("args,name", [
    ((1.0, 2.0, 1.5), "size_max"),   # size_max not below size_initial
    ((1.0, 0.9, 0.5), "size_min"),   # size_min not above size_initial
    ((1.0, 2.0, 0.0), "size_max"),
    ((-1.0, 2.0, 0.5), "size_initial"),
    ((1.0, np.inf, 0.5), "size_min"),
    ((1.0, "big", 0.5), "size_min"),
])
def test_size_parameters_checked(args, name):
    with pytest.raises(MeshError, match=name):
        check_size_parameters(*args)
    sc = scenes.three_rectangles_box()
    with pytest.raises(MeshError, match=name):
        intensity_bubble_mesh(sc, size_initial=args[0], size_min=args[1], size_max=args[2])


def test_size_grids_per_polygon(coarse):
    rng = np.random.default_rng(1)
    sizes = rng.uniform(0.5, 3.0, size=coarse.n_nodes)
    grids = polygon_size_grids(coarse, sizes, grid=0.5)
    assert len(grids) == len(coarse.scene.polygons)
    for k, (poly, g) in enumerate(zip(coarse.scene.polygons, grids)):
        assert isinstance(g, GridSize)
        ext = poly.exterior_2d
        np.testing.assert_allclose(g.origin, ext.min(axis=0))
        np.testing.assert_allclose(g.origin + g.spacing * (np.array(g.values.shape[::-1]) - 1),
                                   ext.max(axis=0))
        _, _, _, nodes = coarse.polygon_elements(k)
        assert g.values.min() >= sizes[nodes].min() - 1e-12
        assert g.values.max() <= sizes[nodes].max() + 1e-12


def test_two_sided_polygon_takes_the_finer_face(coarse):
    """Front nodes coarse, back nodes fine: a two-sided polygon's grid is the fine size."""
    sizes = np.full(coarse.n_nodes, 3.0)
    back = np.unique(coarse.elements[coarse.element_side == -1])
    sizes[back] = 0.5
    grids = polygon_size_grids(coarse, sizes, grid=0.5)
    for poly, g in zip(coarse.scene.polygons, grids):
        np.testing.assert_allclose(g.values, 0.5 if poly.two_sided else 3.0, rtol=1e-12)


@pytest.fixture(scope="module")
def small_loop():
    return intensity_bubble_mesh(scenes.three_rectangles_box(), size_initial=4.0, size_min=8.0,
                                 size_max=2.0, solve={"tol": 0.05}, adaptive_threshold=0.1)


def test_two_pass_loop_pieces(small_loop):
    r = small_loop
    assert set(PHASES) <= set(r.seconds) and r.total_seconds > 0
    assert r.first_radiosity.shape == (r.first_mesh.n_elements, 3)
    assert r.second_radiosity.shape == (r.second_mesh.n_elements, 3)
    assert r.variation.shape == r.node_size.shape == (r.first_mesh.n_nodes,)
    # f(D_min) = size_min, f(D_max) = size_max (4.2)
    assert r.node_size[np.argmin(r.variation)] == pytest.approx(8.0)
    assert r.node_size[np.argmax(r.variation)] == pytest.approx(2.0)
    # the default grid step is the finest element's size
    assert r.parameters["grid"] == pytest.approx(1.0)
    assert all(g.spacing.max() <= 1.0 + 1e-12 for g in r.size_grids)
    # the second mesh is the bubble mesh of the size grids, deterministically
    again = mesh_scene(r.first_mesh.scene, r.size_grids, mesher=bubble_mesher)
    np.testing.assert_array_equal(again.nodes, r.second_mesh.nodes)
    # the adaptive re-mesh refines the first mesh (same patches, more elements)
    assert r.adaptive_mesh.n_patches == r.first_mesh.n_patches
    assert r.adaptive_mesh.n_elements > r.first_mesh.n_elements
    # light is conserved in both solutions: every emitting element keeps its emission
    lit = (r.second_mesh.element_emission > 0).any(axis=1)
    assert np.all(r.second_radiosity[lit] >= r.second_mesh.element_emission[lit] - 1e-9)


def test_reuse_first_solution(small_loop):
    r = small_loop
    again = intensity_bubble_mesh(r.first_mesh.scene, size_initial=4.0, size_min=8.0,
                                  size_max=2.0, solve={"tol": 0.05}, first=r)
    assert again.first_mesh is r.first_mesh
    np.testing.assert_array_equal(again.second_mesh.nodes, r.second_mesh.nodes)
    other = intensity_bubble_mesh(r.first_mesh.scene, size_initial=4.0, size_min=5.0,
                                  size_max=2.0, solve={"tol": 0.05}, first=r)
    np.testing.assert_array_equal(other.variation, r.variation)
    assert other.node_size.max() == pytest.approx(5.0)
    with pytest.raises(MeshError, match="differ"):
        intensity_bubble_mesh(r.first_mesh.scene, size_initial=3.0, size_min=8.0, size_max=2.0,
                              solve={"tol": 0.05}, first=r)


def test_remesh_polygon_is_the_loops_grid(small_loop):
    """The sliders' step: with the run's own sizes the polygon's grid is the run's grid, and the
    polygon meshed alone covers its area; sizes out of (4.3)'s order raise."""
    r = small_loop
    sc = r.first_mesh.scene
    floor = next(k for k, p in enumerate(sc.polygons) if p.name == "box_y0")
    grid, mesh = remesh_polygon(r, floor, size_min=8.0, size_max=2.0)
    np.testing.assert_array_equal(grid.values, r.size_grids[floor].values)
    assert mesh.element_area.sum() == pytest.approx(Scene([sc.polygons[floor]]).total_area, rel=1e-9)
    assert set(np.unique(mesh.element_polygon)) == {0}
    with pytest.raises(MeshError, match="size_min"):
        remesh_polygon(r, floor, size_min=3.0, size_max=2.0)   # size_min < size_initial 4
    with pytest.raises(MeshError, match="polygon"):
        remesh_polygon(r, len(sc.polygons), size_min=8.0, size_max=2.0)


def test_error_at_elements_is_log_log_interpolation():
    """On a power law e = 3 n^-0.7 the log-log interpolation is exact; no extrapolation."""
    n = np.array([100.0, 400.0, 1600.0])
    curve = np.stack([n, 3.0 * n ** -0.7], axis=1)
    for x in (100.0, 250.0, 800.0, 1600.0):
        assert error_at_elements(curve, x) == pytest.approx(3.0 * x ** -0.7, rel=1e-12)
    assert error_at_elements(curve, 99.0) is None and error_at_elements(curve, 1601.0) is None
    with pytest.raises(MeshError, match="increasing"):
        error_at_elements(curve[::-1], 800.0)


def test_second_mesh_follows_the_size_grid(coarse):
    """Grids built in each polygon's own frame reach the mesher in that frame.

    Node sizes 0.8 on the half u < mid of every wall and 2.4 on the other half:
    about (2.4 / 0.8)^2 = 9 times more elements on the fine half; at least 3.
    """
    sc = coarse.scene
    sizes = np.empty(coarse.n_nodes)
    walls = [k for k, p in enumerate(sc.polygons) if p.name.startswith("box_")]
    for k, poly in enumerate(sc.polygons):
        xy, _, _, nodes = coarse.polygon_elements(k)
        mid = poly.exterior_2d[:, 0].mean()
        sizes[nodes] = np.where(xy[:, 0] < mid, 0.8, 2.4)
    second = mesh_scene(sc, polygon_size_grids(coarse, sizes, grid=0.4), mesher=bubble_mesher)
    for k in walls:
        poly = sc.polygons[k]
        sel = second.element_polygon == k
        u = poly.to_2d(second.element_centroid[sel])[:, 0]
        fine = np.sum(u < poly.exterior_2d[:, 0].mean())
        assert fine > 3 * (sel.sum() - fine), poly.name


def test_element_quality_measures_each_face_from_its_own_side(coarse):
    """Back faces are clockwise in the polygon's frame: measured reversed, they score as the front.

    Oracle: the angles and radius ratios from the elements' 3-D edge lengths, which know
    no orientation; and the two faces of a two-sided polygon are the same triangles.
    """
    ang, q = coarse.element_quality()
    t = coarse.nodes[coarse.elements]
    a, b, c = np.linalg.norm(t[:, [1, 2, 0]] - t[:, [2, 0, 1]], axis=2).T
    cosines = np.stack([(b * b + c * c - a * a) / (2 * b * c), (a * a + c * c - b * b) / (2 * a * c),
                        (a * a + b * b - c * c) / (2 * a * b)], axis=1)
    np.testing.assert_allclose(ang, np.degrees(np.arccos(np.clip(cosines, -1, 1))).min(axis=1),
                               atol=1e-7)
    area = coarse.element_area
    np.testing.assert_allclose(q, 4 * area / (a + b + c) / (a * b * c / (4 * area)), rtol=1e-9)
    two = [k for k, p in enumerate(coarse.scene.polygons) if p.two_sided]
    assert two
    for k in two:
        sel = coarse.element_polygon == k
        front = np.sort(q[sel & (coarse.element_side == 1)])
        back = np.sort(q[sel & (coarse.element_side == -1)])
        np.testing.assert_allclose(back, front, rtol=1e-12)
        assert back.min() > 0


@pytest.fixture(scope="module")
def cut():
    """The scene of Fig. 4.8 meshed along its simplified discontinuity lines (chapter 3)."""
    from polygen.discontinuity import simplified_discontinuity

    sc = scenes.three_rectangles_box()
    sd = simplified_discontinuity(sc)
    return sd, mesh_scene(sc, 4.0, mesher=bubble_mesher, segments=sd.segments)


def test_size_grids_per_region_do_not_cross_the_lines(cut):
    """Node sizes constant per region, a different constant in every region: each region's
    grid is its own constant (the plate does not smooth across a discontinuity line)."""
    from polygen.radiosity.layout import RegionSize

    sd, m = cut
    reg = m.element_region
    # a value per (polygon, region), from the elements' regions
    value = {}
    sizes = np.full(m.n_nodes, np.inf)
    for e in range(m.n_elements):
        key = (int(m.element_polygon[e]), int(reg[e]))
        v = value.setdefault(key, 0.5 + 0.37 * (len(value) % 7))
        sizes[m.elements[e]] = np.minimum(sizes[m.elements[e]], v)
    # (a node on a D1 line, shared by two regions, takes the finer of their values)
    grids = polygon_size_grids(m, sizes, grid=0.5)
    n_cut = 0
    for k in range(len(m.scene.polygons)):
        regions = np.unique(reg[m.element_polygon == k])
        if len(regions) == 1:
            continue
        n_cut += 1
        assert isinstance(grids[k], RegionSize)
        assert len(grids[k].sizes) == len(regions)
        for r, g, at in zip(regions, grids[k].sizes, grids[k].at):
            sel = (m.element_polygon == k) & (reg == r)
            ns = sizes[np.unique(m.elements[sel])]
            vals = np.asarray(g.values if isinstance(g, GridSize) else [g])
            # every grid value lies within the sizes of this region's own nodes
            assert vals.min() >= ns.min() - 1e-12 and vals.max() <= ns.max() + 1e-12
            assert m.layouts[k].region_of(at[None])[0] == r
    assert n_cut >= 3  # the floor and the rectangles under the light are cut by shadow lines


@pytest.mark.slow
def test_combined_loop_keeps_the_lines(cut):
    from polygen.discontinuity.combined import combined_bubble_mesh

    sd, _ = cut
    r = combined_bubble_mesh(sd.scene, size_initial=4.0, size_min=8.0, size_max=2.0,
                             solve={"tol": 0.05}, discontinuity=sd, lines="all")
    lines = r.parameters["segments"]
    # merged at half the finest element (size_max 2 / 2 / 2): fewer or as many lines
    assert r.parameters["merge_gap"] == 0.5 and set(lines) <= set(sd.segments)
    assert sum(len(s) for s in lines.values()) < sum(len(s) for s in sd.segments.values())
    for m in (r.first_mesh, r.second_mesh):
        assert m.element_region is not None and len(m.t_vertices()) == 0
        # every polygon with lines left is cut into regions in both meshes
        for k in lines:
            assert len(np.unique(m.element_region[m.element_polygon == k])) > 1
    with pytest.raises(TypeError, match="segments"):
        combined_bubble_mesh(sd.scene, size_initial=4.0, size_min=8.0, size_max=2.0,
                             discontinuity=sd, segments={})


@pytest.mark.slow
def test_combined_loop_narrow_lines(cut):
    """lines="narrow": the first mesh keeps all the merged lines, the second only the chosen
    pieces (fewer, none outside the merged lines' polygons), with its regions cut by them."""
    from polygen.discontinuity.combined import combined_bubble_mesh
    from polygen.radiosity.mesh import MeshError as _ME

    sd, _ = cut
    r = combined_bubble_mesh(sd.scene, size_initial=4.0, size_min=8.0, size_max=2.0,
                             solve={"tol": 0.05}, discontinuity=sd, lines="narrow")
    lines, kept = r.parameters["segments"], r.parameters["second_segments"]
    assert r.parameters["lines"] == "narrow" and set(kept) <= set(lines)
    assert 0 < sum(len(s) for s in kept.values())

    def length(d):
        return sum(float(np.linalg.norm(s.ends[:, 1] - s.ends[:, 0], axis=-1).sum())
                   for s in d.values())

    assert length(kept) < length(lines)
    for k in lines:
        n1 = len(np.unique(r.first_mesh.element_region[r.first_mesh.element_polygon == k]))
        n2 = len(np.unique(r.second_mesh.element_region[r.second_mesh.element_polygon == k]))
        assert n1 > 1 and n2 <= n1
    with pytest.raises(_ME, match="lines"):
        combined_bubble_mesh(sd.scene, size_initial=4.0, size_min=8.0, size_max=2.0,
                             discontinuity=sd, lines="some")


#: Table 4.1's size_min, anchored to the thesis before measuring quality or error: the
#: bisection of ``benchmarks/intensity_mesh.py --calibrate`` (results/intensity_mesh_calibrate.md)
#: on the thesis's second / first element ratio, 1396 / 1976 = 0.706, rounded to 0.05.
TABLE_4_1 = {"size_initial": 1.7, "size_min": 2.2, "size_max": 0.85}


@pytest.fixture(scope="module")
def table_4_1():
    """The loop at Table 4.1's parameters, the second mesh with the bubble mesh's improvement,
    and the conventional adaptive re-mesh from the same first solution (threshold 0.1)."""
    return intensity_bubble_mesh(scenes.three_rectangles_box(), **TABLE_4_1, improve=3,
                                 adaptive_threshold=0.1)


@pytest.mark.slow
def test_table_4_1_pattern(table_4_1):
    """Table 4.1 on the scene of Fig. 4.8: this method < first mesh < adaptive re-mesh.

    Parameters: size_initial 1.7 (the first bubble mesh nearest the thesis's 1976 elements
    among 1.4-1.75), size_max = size_initial / 2, size_min 2.2 from the thesis's ratio (above),
    the adaptive threshold 0.1 of the bright surfaces' radiosity (benchmarks/radiosity_error.py's).
    Measured: 1448 < 2056 < 3109 (thesis 1396 < 1976 < 3205).
    """
    r = table_4_1
    n1, n2, na = r.first_mesh.n_elements, r.second_mesh.n_elements, r.adaptive_mesh.n_elements
    assert n2 < n1 < na


@pytest.mark.slow
def test_graded_mesh_smallest_angle(table_4_1):
    """Issue 15: smallest angle >= 25 degrees on the second mesh, at Table 4.1's parameters.

    Measured 30.5 degrees.  Without ``improve`` it was 24.4 degrees at the earlier size_min
    3.4, whatever the seed: the ceiling around the light is a channel 4 wide where the size grid
    asked for 3.3, the light's sides (2) got no edge bubble and a triangle joined a light side
    to a wall node (tests/test_bubble_improve.py); every polygon corner of the scene is 90
    degrees, so the bound can hold everywhere.
    """
    ang, _ = table_4_1.second_mesh.element_quality()
    assert ang.min() >= 25.0


@pytest.mark.slow
def test_graded_mesh_quality(table_4_1):
    """Issue 15: mean radius ratio >= 0.93 on the second mesh, at Table 4.1's parameters.

    Measured 0.946 (1448 elements; walls 0.951-0.961, the light and the small rectangles
    0.77-0.87), at size_min 2.2 fixed from the thesis's element ratio before q was measured.
    At the earlier setting size_min = 2 size_initial = 3.4 (fixed before measuring too, 632
    elements, 31 % of the first mesh where the thesis keeps 71 %) it was 0.888: sizes 2.6-3.4
    on 10 x 10 walls put three patches across, every 90-degree wall corner a right triangle
    (q <= 0.828), and the polygons smaller than their size two right triangles each (below).
    """
    _, q = table_4_1.second_mesh.element_quality()
    assert q.mean() >= 0.93


@pytest.fixture(scope="module")
def size_min_2x():
    """The loop at the earlier setting size_min = 2 size_initial (3.4), with the improvement."""
    return intensity_bubble_mesh(scenes.three_rectangles_box(), size_initial=1.7, size_min=3.4,
                                 size_max=0.85, improve=3)


@pytest.mark.slow
def test_polygons_smaller_than_their_size_are_two_right_triangles(size_min_2x):
    """Where the size grid is everywhere at least the polygon's longer side (the light, two of
    the rectangles at size_min 3.4) the bubble mesh has its corners only: two right
    triangles per face, radius ratio 2 (a + b - c) / c for legs a, b and hypotenuse c (0.828
    for a square) -- the best any mesh of a rectangle by its corners alone can have, and what
    held that setting's mean q to 0.888."""
    r = size_min_2x
    m = r.second_mesh
    _, q = m.element_quality()
    n_small = 0
    for k, (poly, g) in enumerate(zip(m.scene.polygons, r.size_grids)):
        a, b = np.ptp(poly.exterior_2d, axis=0)
        if len(poly.holes) or g.values.min() < max(a, b):
            continue
        n_small += 1
        assert np.sum(m.patch_polygon == k) == 2 * (2 if poly.two_sided else 1)
        c = np.hypot(a, b)
        np.testing.assert_allclose(q[m.element_polygon == k], 2 * (a + b - c) / c, rtol=1e-9)
    assert n_small >= 2


def _smallest_line_angle(graph):
    """Degrees: the smallest angle between two graph edges at a common vertex (brute force)."""
    v = graph.vertices
    best = 180.0
    for i in range(len(v)):
        inc = np.flatnonzero((graph.edges == i).any(axis=1))
        if len(inc) < 2:
            continue
        other = np.where(graph.edges[inc, 0] == i, graph.edges[inc, 1], graph.edges[inc, 0])
        a = np.sort(np.arctan2(v[other, 1] - v[i, 1], v[other, 0] - v[i, 0]))
        best = min(best, float(np.degrees(np.diff(np.concatenate([a, [a[0] + 2 * np.pi]])).min())))
    return best


@pytest.mark.xfail(strict=True, reason="measured: 12.3 degrees with the local-width cap "
                   "(6.91 without) against the bound 21.4 (half of 42.9, the smallest angle "
                   "between lines after merging): the regions narrower than their size are "
                   "gone; left are single triangles where a node that a neighbouring polygon "
                   "puts on a shared edge lies next to a line's end on that edge (box_x1, "
                   "box_z1)")
def test_combination_mesh_smallest_angle():
    """The combination's mesh (its first, uniform one at patch size 2.4: the lines are the
    same in both) has no angle below half the smallest angle between two lines at a vertex.

    The bound from the geometry, fixed before measuring: a conforming mesh cannot beat the
    smallest angle phi between two lines (or a line and an edge) at a common vertex, and a
    node inside that wedge bisects it at worst; merging (half the finest element, 0.3 here)
    leaves no two lines closer than that except at such vertices, and the local-width cap
    (floor: the finest element, 0.6; slope 0.5) sizes what is left no larger than it is wide.
    Without merging the mesh had 2.05 degrees (bands 0.036-0.042 wide between penumbra
    lines), merged 6.91, merged and capped 12.3 (1288 -> 2440 elements).
    """
    from polygen.discontinuity import simplified_discontinuity
    from polygen.discontinuity.combined import merged_lines
    from polygen.mesh2d import planar_graph
    from polygen.radiosity.intensity import width_capped_sizes

    sc = scenes.three_rectangles_box()
    lines = merged_lines(sc, simplified_discontinuity(sc).segments, gap=2.4 / 2 / 2 / 2)
    phi = min(_smallest_line_angle(planar_graph(sc.polygons[k].exterior_2d,
                                                sc.polygons[k].holes_2d, *s.in_plane(sc.polygons[k])))
              for k, s in lines.items())
    sizes = width_capped_sizes(sc, [2.4] * len(sc.polygons), lines, floor=2.4 / 2 / 2)
    m = mesh_scene(sc, sizes, mesher=bubble_mesher, segments=lines)
    ang, _ = m.element_quality()
    assert ang.min() >= phi / 2


@pytest.mark.slow
def test_fewer_elements_than_adaptive_subdivision_for_its_error():
    """The thesis's claim (4.4): this method reaches adaptive subdivision's error with fewer
    elements -- from a fine first mesh, as Requirement 4.1 asks.

    The setting of ``benchmarks/intensity_mesh.py --fine-first`` (fixed there before any error
    was measured): this method from a first mesh of patch size 1.2, size_min 1.25 x 1.2,
    size_max 0.6; against the conventional adaptive re-mesh of Table 4.1 (from the uniform
    1.7 mesh and its solution, threshold 0.1 of the bright radiosity), the adaptive mesh with
    as many elements as ours.  Error: the benchmark's yardstick (RMS of a 160^2 Gouraud image
    against a uniform mesh of patch size 1.1, 16 elements per patch, 19328 elements).
    Measured there: 3088 elements, error 0.0145, against 3109 and 0.0148.
    """
    from polygen.radiosity import Camera, adaptive_refine, progressive_refinement
    from polygen.radiosity.error import image_error, shade
    from polygen.radiosity.intensity import bright_scale

    sc = scenes.three_rectangles_box()
    solve = {"tol": 0.01, "ambient": True}
    cam = Camera([5.0, 6.0, 0.3], [5.0, 3.5, 6.0], fov=75.0, width=160, height=160, near=0.01)
    ref_mesh = mesh_scene(sc, 1.1, element_levels=2)
    reference = shade(ref_mesh, progressive_refinement(ref_mesh, **solve).display_radiosity(
        ref_mesh), cam)
    ours = intensity_bubble_mesh(sc, size_initial=1.2, size_min=1.25 * 1.2, size_max=0.6,
                                 solve=solve)
    first = mesh_scene(sc, 1.7, element_levels=1, mesher=bubble_mesher)
    b1 = progressive_refinement(first, **solve).display_radiosity(first)
    ada = adaptive_refine(first, b1, 0.1 * bright_scale(first, b1)).mesh
    b_ada = progressive_refinement(ada, **solve).display_radiosity(ada)
    e_ours = image_error(shade(ours.second_mesh, ours.second_radiosity, cam), reference)
    e_ada = image_error(shade(ada, b_ada, cam), reference)
    assert ours.second_mesh.n_elements <= ada.n_elements
    assert e_ours <= e_ada


def test_width_floor_checked():
    with pytest.raises(MeshError, match="width_floor"):
        intensity_bubble_mesh(scenes.three_rectangles_box(), size_initial=4.0, size_min=8.0,
                              size_max=2.0, width_floor=0.0, segments={})


def test_narrow_lines_keep_d0_and_narrow_penumbrae():
    """A square with a D0 line, a penumbra band 0.3 wide, one 3 wide and a wedge 0.1 -> 1.5
    wide; patch size 1, elements 0.5: the D0 line and the narrow band's lines kept whole, the
    wide band's dropped, the wedge's straight side kept where the wedge is narrower than 0.5
    (the chord across it, 0.1 + 0.14 y, is under 0.5 for y < 2.857), up to one piece."""
    from polygen.discontinuity.combined import narrow_lines
    from polygen.radiosity.layout import Segments
    from polygen.radiosity.scene import Polygon

    poly = Polygon(np.array([[0, 0, 0], [20, 0, 0], [20, 10, 0], [0, 10, 0]], float), name="sq")

    def seg(x0, y0, x1, y1):
        return [[x0, y0, 0.0], [x1, y1, 0.0]]

    ends = [seg(1, 0, 1, 10), seg(2, 0, 2, 10), seg(2.3, 0, 2.3, 10), seg(6, 0, 6, 10),
            seg(9, 0, 9, 10), seg(12, 0, 12, 10), seg(12.1, 0, 13.5, 10)]
    kinds = ["D0", "D1", "D1", "D1", "D1", "D1", "D1"]
    found = Segments(np.array(ends), kinds)
    pen = poly.to_2d(np.array([[2.15, 5, 0], [7.5, 5, 0], [12.3, 5, 0]]))
    step = 0.25
    kept = narrow_lines(poly, found, found, pen, 1.0, step=step, element_levels=1)
    e3 = poly.to_3d(kept.ends.reshape(-1, 2)).reshape(-1, 2, 3)
    x = e3[..., 0]
    kinds = np.asarray(kept.kinds)
    length = np.linalg.norm(e3[:, 1] - e3[:, 0], axis=1)

    def total(x0, kind="D1"):
        on = np.all(np.abs(x - x0) < 1e-9, axis=1) & (kinds == kind)
        return length[on].sum(), e3[on]

    assert total(1.0, "D0")[0] == pytest.approx(10.0)
    assert total(2.0)[0] == pytest.approx(10.0) and total(2.3)[0] == pytest.approx(10.0)
    assert total(6.0)[0] == 0.0 and total(9.0)[0] == 0.0
    wedge, pieces = total(12.0)
    assert abs(wedge - (0.5 - 0.1) / 0.14) <= step
    assert pieces[..., 1].min() == pytest.approx(0.0)
    # a piece of the wedge's slanted side is kept only where the chord is narrow too
    slanted = ~np.any(np.abs(x - np.round(x, 1)) < 1e-9, axis=1)
    assert np.all(e3[slanted][..., 1] < 3.6)
    # nothing narrow: nothing kept but D0
    wide = narrow_lines(poly, found, found, pen, 0.1, step=step)
    assert list(np.asarray(wide.kinds)) == ["D0"]
    with pytest.raises(MeshError, match="step"):
        narrow_lines(poly, found, found, pen, 1.0, step=0.0)


def test_single_lines_keep_one_of_two_close_lines():
    """A 20 x 10 rectangle; gap 0.5, pieces 0.25: a D0 line kept whole even next to a longer
    D1 line (that line drops the stretch within 0.5 of it); of two D1 lines 0.3 apart the
    longer kept whole and the shorter dropped; a line 1 away kept whole; a line 0.2 from the
    polygon's edge dropped; a line converging on a kept one kept until it comes within 0.5
    (up to one piece); every kept piece a stretch of an input line (no end moved)."""
    from polygen.discontinuity.combined import single_lines
    from polygen.radiosity.layout import Segments
    from polygen.radiosity.scene import Polygon

    poly = Polygon(np.array([[0, 0, 0], [20, 0, 0], [20, 10, 0], [0, 10, 0]], float), name="sq")

    def seg(x0, y0, x1, y1):
        return [[x0, y0, 0.0], [x1, y1, 0.0]]

    ends = np.array([seg(4.0, 2, 4.0, 8), seg(4.3, 1, 4.3, 9),       # D0 (short), D1 0.3 away
                     seg(8.0, 2, 8.0, 7), seg(8.3, 1, 8.3, 9),       # two D1 0.3 apart
                     seg(9.3, 1, 9.3, 9),                            # 1 from the longer
                     seg(0.2, 1, 0.2, 9),                            # 0.2 from the edge
                     seg(14.0, 1, 14.0, 9), seg(16.0, 1, 14.1, 7)])  # converging on x = 14
    kinds = ["D0", "D1", "D1", "D1", "D1", "D1", "D1", "D1"]
    step, gap = 0.25, 0.5
    out = single_lines(poly, Segments(ends, kinds), gap=gap, step=step)
    e3 = poly.to_3d(out.ends.reshape(-1, 2)).reshape(-1, 2, 3)
    k = np.asarray(out.kinds)
    length = np.linalg.norm(e3[:, 1] - e3[:, 0], axis=1)

    def on(i):
        """Kept pieces lying on input line i, and their total length."""
        a, b = ends[i, 0], ends[i, 1]
        d = (b - a) / np.linalg.norm(b - a)
        rel = e3 - a
        off = np.linalg.norm(rel - (rel @ d)[..., None] * d, axis=-1)
        m = np.all(off < 1e-9, axis=1)
        return m, length[m].sum()

    m0, l0 = on(0)
    assert l0 == pytest.approx(6.0) and set(k[m0]) == {"D0"}
    # within 0.5 of the D0 line's ends (0.3 across) for |dy| < 0.4: kept y < 1.6 and y > 8.4
    assert abs(on(1)[1] - 1.2) <= 2 * step
    assert on(3)[1] == pytest.approx(8.0) and on(2)[1] == 0.0
    assert on(4)[1] == pytest.approx(8.0)
    assert on(5)[1] == 0.0
    assert on(6)[1] == pytest.approx(8.0)
    mc, lc = on(7)
    # the converging line (shorter, so after x = 14): 0.5 from it at y = 1 + 6 * 1.5 / 1.9
    assert abs(lc - np.hypot(1.5, 6 * 1.5 / 1.9)) <= step + 1e-9
    # every piece lies on an input line
    assert sum(on(i)[0].sum() for i in range(len(ends))) == len(e3)
    assert single_lines(poly, Segments(ends[5:6], "D1"), gap=gap, step=step) is None
    with pytest.raises(MeshError, match="gap"):
        single_lines(poly, Segments(ends, kinds), gap=-1.0, step=step)
    with pytest.raises(MeshError, match="step"):
        single_lines(poly, Segments(ends, kinds), gap=gap, step=0.0)


@pytest.mark.slow
def test_combined_loop_single_lines(cut):
    """lines="single": the second mesh's lines are single_lines of "narrow"'s, with the
    largest element (size_min / 2) as the gap and the finest (size_max / 2) as the step."""
    from polygen.discontinuity.combined import combined_bubble_mesh, single_lines

    sd, _ = cut
    kw = dict(size_initial=4.0, size_min=8.0, size_max=2.0, solve={"tol": 0.05},
              discontinuity=sd)
    narrow = combined_bubble_mesh(sd.scene, lines="narrow", **kw)
    single = combined_bubble_mesh(sd.scene, first=narrow, **kw)   # the default
    assert single.parameters["lines"] == "single"
    a, b = narrow.parameters["second_segments"], single.parameters["second_segments"]
    assert set(b) <= set(a)
    assert sum(len(x) for x in b.values()) > 0
    for k, sg in a.items():
        poly = sd.scene.polygons[k]
        want = single_lines(poly, sg, gap=8.0 / 2, step=2.0 / 2)
        if want is None:
            assert k not in b
            continue
        got = b[k]
        assert list(np.asarray(got.kinds)) == list(np.asarray(want.kinds))
        np.testing.assert_allclose(got.in_plane(poly)[0], want.ends)


def test_size_grids_per_region_of_other_layouts(cut):
    """``layouts=``: the mesh's own layouts give the same grids; no layouts (every line
    dropped) one grid per polygon; a subset of the lines one grid per region of the subset,
    within the sizes of the nodes of the mesh's regions inside it."""
    from polygen.radiosity.layout import RegionSize, Segments, polygon_layout

    sd, m = cut
    sizes = 0.5 + (np.arange(m.n_nodes) % 5) * 0.3
    own = polygon_size_grids(m, sizes, grid=0.5)
    same = polygon_size_grids(m, sizes, grid=0.5, layouts=m.layouts)
    for a, b in zip(own, same):
        if isinstance(a, RegionSize):
            assert len(a.sizes) == len(b.sizes) and np.array_equal(a.at, b.at)
            for ga, gb in zip(a.sizes, b.sizes):
                assert np.array_equal(np.asarray(getattr(ga, "values", ga)),
                                      np.asarray(getattr(gb, "values", gb)))
    none = polygon_size_grids(m, sizes, grid=0.5, layouts=[None] * len(m.scene.polygons))
    assert not any(isinstance(g, RegionSize) for g in none)
    k = max(sd.segments, key=lambda k: len(sd.segments[k]))   # the floor: most lines
    poly = m.scene.polygons[k]
    ends, kinds = sd.segments[k].in_plane(poly)
    kinds = list(np.broadcast_to(np.asarray(kinds), (len(ends),)))
    for j in range(1, len(ends)):   # the fewest first lines that cut the floor in two or more
        sub = polygon_layout(poly, Segments(ends[:j], kinds[:j]))
        if sub.n_regions >= 2:
            break
    assert 2 <= sub.n_regions < m.layouts[k].n_regions
    lays = [None] * len(m.scene.polygons)
    lays[k] = sub
    g = polygon_size_grids(m, sizes, grid=0.5, layouts=lays)[k]
    assert isinstance(g, RegionSize) and len(g.sizes) == sub.n_regions
    xy, tris, el, nodes = m.polygon_elements(k)
    reg = sub.region_of(m.layouts[k].region_point)[m.element_region[el]]
    for gr, at in zip(g.sizes, g.at):
        r = sub.region_of(at[None])[0]
        ns = sizes[nodes[np.unique(tris[reg == r])]]
        vals = np.asarray(getattr(gr, "values", [gr]))
        assert vals.min() >= ns.min() - 1e-12 and vals.max() <= ns.max() + 1e-12


def test_match_element_count_bisects_to_the_target():
    # a count falling with x: 1000 / x elements; the target 250 is x = 4
    x, n, trail = match_element_count(lambda x: int(1000 / x), 1.0, 8.0, 250, tol=0.01)
    assert abs(n - 250) <= 2.5 and abs(x - 4.0) < 0.05 and trail[-1] == (round(x, 6), n)
    x, n, trail = match_element_count(lambda x: 7, 1.0, 8.0, 250, steps=5)  # never reached
    assert x is None and n is None and len(trail) == 5
    with pytest.raises(MeshError):
        match_element_count(lambda x: 1, 2.0, 1.0, 10)


@pytest.mark.slow
def test_combination_beats_both_parents_at_equal_element_count():
    """Issue 15's claim, measured in the run by the protocol of ``benchmarks/intensity_mesh.py
    --only equal`` (fixed there before any error was computed): at each of the combination's
    four points (``lines="single"``; size_initial 1.7 with size_min 2.2/1.7, 1.5 and 2 times
    size_initial, and 2.4), this method (from its own uniform first pass at that size_initial)
    and simplified DM (patch size s, s/2 in the penumbra) are bisected on element counts alone
    to within 2 % of the combination's, then all three are solved; the combination's image
    error is below both (the benchmark's yardstick: a 160^2 Gouraud image against a uniform
    mesh of 19328 elements). Measured there: 1576 el. 0.0270 against 0.0279 / 0.0365, 1216
    0.0383 / 0.0405 / 0.0431, 856 0.0495 / 0.0506 / 0.0535, 728 0.0479 / 0.0561 / 0.0768.
    """
    from polygen.discontinuity import simplified_discontinuity
    from polygen.discontinuity.combined import combined_bubble_mesh
    from polygen.radiosity import Camera, progressive_refinement
    from polygen.radiosity.error import image_error, shade
    from polygen.radiosity.intensity import _seeded

    sc = scenes.three_rectangles_box()
    solve = {"tol": 0.01, "ambient": True}
    cam = Camera([5.0, 6.0, 0.3], [5.0, 3.5, 6.0], fov=75.0, width=160, height=160, near=0.01)
    ref_mesh = mesh_scene(sc, 1.1, element_levels=2)
    reference = shade(ref_mesh, progressive_refinement(ref_mesh, **solve).display_radiosity(ref_mesh), cam)
    sd = simplified_discontinuity(sc)
    ratio = 2.2 / 1.7

    def ours_count(base, size_min):
        p = base.parameters
        sizes = size_function(base.variation, size_min=size_min, size_max=p["size_max"])
        grids = polygon_size_grids(base.first_mesh, sizes, grid=p["grid"], nu=p["nu"])
        return mesh_scene(sc, grids, element_levels=p["element_levels"],
                          mesher=_seeded(p["seed"], improve=3)).n_elements

    def dm_mesh(s):
        return mesh_scene(sc, sd.region_sizes(s, s / 2), segments=sd.segments, mesher=bubble_mesher)

    combo_first, ours_first, verdicts = {}, {}, []
    for si, f in ((1.7, ratio), (1.7, 1.5), (2.4, ratio), (1.7, 2.0)):
        q = combined_bubble_mesh(sc, size_initial=si, size_min=f * si, size_max=si / 2, solve=solve,
                                 discontinuity=sd, improve=3, lines="single", first=combo_first.get(si))
        combo_first.setdefault(si, q)
        target = q.second_mesh.n_elements
        e_comb = image_error(shade(q.second_mesh, q.second_radiosity, cam), reference)
        if si not in ours_first:
            ours_first[si] = intensity_bubble_mesh(sc, size_initial=si, size_min=ratio * si, size_max=si / 2,
                                                   solve=solve, improve=3)
        base = ours_first[si]
        smin, n_ours, _ = match_element_count(lambda x: ours_count(base, x), si, 3 * si, target)
        s_dm, n_dm, _ = match_element_count(lambda x: dm_mesh(x).n_elements, 1.0, 8.0, target)
        assert smin is not None and s_dm is not None, (si, f, target)  # both parents matched
        r = intensity_bubble_mesh(sc, size_initial=si, size_min=smin, size_max=si / 2, solve=solve,
                                  first=base, improve=3)
        e_ours = image_error(shade(r.second_mesh, r.second_radiosity, cam), reference)
        m = dm_mesh(s_dm)
        e_dm = image_error(shade(m, progressive_refinement(m, **solve).display_radiosity(m), cam), reference)
        verdicts.append((target, e_comb, r.second_mesh.n_elements, e_ours, m.n_elements, e_dm))
    assert all(e_comb < e_ours and e_comb < e_dm for _, e_comb, _, e_ours, _, e_dm in verdicts), verdicts

"""Chapter 4's intensity-based bubble mesh: intensity variation (4.1), size function
(4.2-4.4), per-polygon size grids (4.3.2) and the two-pass loop (Fig. 4.3)."""

import numpy as np
import pytest

from polygen.mesh2d import GridSize
from polygen.radiosity import MeshError, bubble_mesher, mesh_scene, scenes
from polygen.radiosity.intensity import (
    PHASES,
    check_size_parameters,
    intensity_bubble_mesh,
    intensity_variation,
    polygon_size_grids,
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
    assert r.adaptive_mesh.n_elements >= r.first_mesh.n_elements
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


@pytest.mark.slow
def test_table_4_1_pattern():
    """Table 4.1 on the scene of Fig. 4.8: this method < first mesh < adaptive re-mesh.

    Parameters fixed before measuring: size_initial 1.7 (the first bubble mesh
    nearest the thesis's 1976 elements among 1.4-1.75), size_min = 2 size_initial,
    size_max = size_initial / 2, the adaptive threshold 0.1 of the bright
    surfaces' radiosity (benchmarks/radiosity_error.py's).
    """
    r = intensity_bubble_mesh(scenes.three_rectangles_box(), size_initial=1.7, size_min=3.4,
                              size_max=0.85, adaptive_threshold=0.1)
    n1, n2, na = r.first_mesh.n_elements, r.second_mesh.n_elements, r.adaptive_mesh.n_elements
    assert n2 < n1 < na


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
                             solve={"tol": 0.05}, discontinuity=sd)
    for m in (r.first_mesh, r.second_mesh):
        assert m.element_region is not None and len(m.t_vertices()) == 0
        # every polygon with lines is cut into regions in both meshes
        for k in sd.segments:
            assert len(np.unique(m.element_region[m.element_polygon == k])) > 1
    assert r.parameters["segments"] is sd.segments
    with pytest.raises(TypeError, match="segments"):
        combined_bubble_mesh(sd.scene, size_initial=4.0, size_min=8.0, size_max=2.0,
                             discontinuity=sd, segments={})


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="measured: mean q 0.926 at size_initial 1.2, 0.872 at 1.7 "
                   "(issue 15 asks 0.93): the second mesh is as coarse as size_min allows, and a "
                   "uniform bubble mesh that coarse is no better (see the docstring)")
def test_graded_mesh_quality():
    """Issue 15: mean radius ratio >= 0.93 and smallest angle >= 25 degrees on the second mesh.

    Not met, and kept as a strict xfail so that it is noticed when it is.  At Table 4.1's
    parameters (size_initial 1.7, size_min 3.4, size_max 0.85) the second mesh has q 0.872
    and 24.4 degrees, and a *uniform* bubble mesh of its wall size (3.3) has the same (0.861,
    24.2); uniform bubble meshes of this scene reach q 0.935 only at patch size 2.4 (3.0:
    0.921), and its small polygons (the light, the rectangles: 2-3 units) meshed by one or
    two patches score about 0.81.  So the limit is the coarse packing that a large size_min
    asks for, not the size grid's variation: the binary-tree/quadtree placement gives
    0.869 / 24.4, capping the size at a quarter of each polygon's side 0.909 / 11.0.  At
    size_initial 1.2 (size_min 2.4, size_max 0.6) the second mesh has q 0.926.
    """
    r = intensity_bubble_mesh(scenes.three_rectangles_box(), size_initial=1.2, size_min=2.4,
                              size_max=0.6, solve={"tol": 0.05})
    ang, q = r.second_mesh.element_quality()
    assert q.mean() >= 0.93
    assert ang.min() >= 25.0


@pytest.mark.slow
def test_graded_mesh_quality_with_a_finer_size_min():
    """Issue 15's thresholds where size_min is not coarse for the scene's polygons.

    Not parameters fixed in advance: the benchmark's size_min sweep (size_initial 1.7,
    size_max 0.85, size_min 1.25 x 1.7 = 2.125) measured q 0.9355 and 33.1 degrees on its
    second mesh (1520 elements), the point where size_min is near the patch size at which a
    uniform bubble mesh of this scene reaches q 0.935 (2.4).  A regression guard for that
    explanation of the xfail above, not evidence for the thresholds in general.
    """
    sc = scenes.three_rectangles_box()
    r = intensity_bubble_mesh(sc, size_initial=1.7, size_min=1.25 * 1.7, size_max=0.85)
    ang, q = r.second_mesh.element_quality()
    assert q.mean() >= 0.93
    assert ang.min() >= 25.0
    assert r.second_mesh.n_elements < r.first_mesh.n_elements

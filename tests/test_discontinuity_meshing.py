"""Discontinuity meshing end to end (3.3.6, Figs 3.11, 3.14): polygen.discontinuity.meshing."""

import numpy as np
import pytest
import shapely

from polygen.discontinuity import PENUMBRA, scene_sections, section_segments
from polygen.discontinuity.conventional import conventional_bsp
from polygen.discontinuity.meshing import MeshingError, discontinuity_mesh
from polygen.radiosity import mesh_scene, scenes
from polygen.radiosity.scene import PointLight, Polygon, Scene


def _point_light_scene():
    floor = Polygon([[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0]], name="floor")
    block = Polygon([[1.5, 1.5, 1], [1.5, 2.5, 1], [2.5, 2.5, 1], [2.5, 1.5, 1]], name="block")
    return Scene([floor, block], [PointLight([2.2, 1.9, 3.0], 10.0)])


def _nodes_on(mesh, k, ends, tol):
    """Node indices of polygon k's elements lying on one of the 2-D segments ``ends``."""
    xy, _, _, nodes = mesh.polygon_elements(k, side=1)
    pts = shapely.points(xy)
    lines = shapely.multilinestrings(list(shapely.linestrings(ends)))
    return nodes[shapely.dwithin(lines, pts, tol)]


def test_d0_lines_get_a_node_copy_per_side():
    # Fig. 3.11: a point light's shadow boundary is D0: every node on it (corners excepted,
    # where more than two sides meet) exists twice at one position, one copy per side
    sc = _point_light_scene()
    m = discontinuity_mesh(sc, patch_size=0.5, element_levels=1)
    seg = m.discontinuity.segments[0]
    assert len(seg) == 4 and set(seg.kinds) == {"D0"}
    tol = 1e-9 * sc.polygons[0].diameter
    on = _nodes_on(m, 0, seg.ends, tol)
    _, counts = np.unique(np.round(m.nodes[on], 9), axis=0, return_counts=True)
    assert len(counts) > 8 and np.all(counts >= 2)


def test_d1_lines_share_their_nodes():
    # Fig. 3.11: an area light's lines are D1: one node per position along them
    sc = scenes.two_rectangles_room()
    m = discontinuity_mesh(sc, patch_size=2.0, penumbra_patch_size=0.7, element_levels=1)
    checked = 0
    for k, seg in m.discontinuity.segments.items():
        assert set(seg.kinds) == {"D1"}
        on = _nodes_on(m, k, seg.ends, 1e-9 * sc.polygons[k].diameter)
        _, counts = np.unique(np.round(m.nodes[on], 9), axis=0, return_counts=True)
        assert np.all(counts == 1)
        checked += len(on)
    assert checked > 50


@pytest.mark.parametrize("method", ["simplified", "conventional"])
def test_penumbra_only_refinement_uses_fewer_elements_than_uniform(method):
    # Table 3.1: N_e1 (fine in penumbra only) < N_e2 (fine everywhere): 3485 < 6090
    sc = scenes.two_rectangles_room()
    fine, coarse = 0.7, 2.0
    m = discontinuity_mesh(sc, patch_size=coarse, penumbra_patch_size=fine, element_levels=1,
                           method=method)
    uniform = mesh_scene(sc, fine, element_levels=1)
    assert m.n_elements < uniform.n_elements
    # and the penumbra regions really are meshed finer: mean patch area there below the rest's
    rec = m.discontinuity.penumbra_points
    assert sum(len(p) for p in rec.values()) > 0
    area = m.patch_area
    for k, pts in rec.items():
        if not len(pts):
            continue
        lay = m.layouts[k]
        pen_regions = set(lay.region_of(pts).tolist())
        sel = np.flatnonzero(m.patch_polygon == k)
        in_pen = np.isin(m.patch_region[sel], list(pen_regions))
        if in_pen.any() and (~in_pen).any():
            assert area[sel][in_pen].mean() < area[sel][~in_pen].mean()


def test_simplified_penumbra_regions_are_the_complex_penumbra_faces():
    sc = scenes.two_rectangles_room()
    m = discontinuity_mesh(sc, patch_size=2.0, penumbra_patch_size=0.7)
    sd = m.discontinuity.discontinuity
    for k, cx in sd.complexes.items():
        n_pen = int(np.any(cx.face_states() == PENUMBRA, axis=1).sum())
        assert len(m.discontinuity.penumbra_points[k]) == n_pen


def test_edge_and_region_counts_of_figure_3_4():
    # Fig. 3.3: per (light, occluder, receiver) 2 Ns No conventional critical surfaces against
    # Ns + 2 No simplified edges; Fig. 3.4: regions by loops <= regions by BSP
    sc = scenes.figure_3_4_scene()
    simp = discontinuity_mesh(sc, patch_size=1.0, method="simplified")
    conv = discontinuity_mesh(sc, patch_size=1.0, method="conventional")
    Ns = No = 4
    pairs = 2
    assert conv.discontinuity.counters["critical_surfaces"] == pairs * 2 * Ns * No
    floor = sc.polygons[0]
    ss, _ = section_segments(floor, scene_sections(sc).of(0))
    assert len(ss) == pairs * (Ns + 2 * No) < pairs * 2 * Ns * No
    loops = len(simp.discontinuity.discontinuity.complexes[0].alive_faces)
    assert loops == 6
    assert loops <= conventional_bsp(floor, ss).n_regions


def test_bad_arguments_are_named():
    sc = scenes.figure_3_4_scene()
    with pytest.raises(MeshingError, match="method"):
        discontinuity_mesh(sc, patch_size=1.0, method="bsp")
    with pytest.raises(MeshingError, match="penumbra_patch_size"):
        discontinuity_mesh(sc, patch_size=1.0, penumbra_patch_size=-1.0)
    with pytest.raises(MeshingError, match="patch_size"):
        discontinuity_mesh(sc, patch_size="big")
    other = scenes.two_rectangles_room()
    from polygen.discontinuity import simplified_discontinuity
    with pytest.raises(MeshingError, match="discontinuity"):
        discontinuity_mesh(sc, patch_size=1.0, discontinuity=simplified_discontinuity(other))


def test_conventional_mesh_follows_every_critical_segment():
    # 2.4.3: the conventional mesh has all EV/VE segments as patch edges: no patch's interior
    # meets one (the segments are noded where they cross, so the mesh model takes them)
    from polygen.discontinuity import conventional_segments

    sc = scenes.figure_3_4_scene()
    m = discontinuity_mesh(sc, patch_size=2.0, penumbra_patch_size=0.7, method="conventional")
    floor = sc.polygons[0]
    cs = conventional_segments(sc, 0)
    assert len(cs.segments) == 64
    lines = shapely.multilinestrings(list(shapely.linestrings(cs.segments)))
    sel = np.flatnonzero(m.patch_polygon == 0)
    tri = floor.to_2d(m.nodes[m.patches[sel]])
    eps = 1e-7 * floor.diameter
    inner = [shapely.Polygon(t).buffer(-eps) for t in tri]
    assert max(p.intersection(lines).length for p in inner) < 1e-6 * floor.diameter
    # penumbra regions (in some light's penumbra, in none of its umbrae) were meshed finer
    assert m.n_patches > discontinuity_mesh(sc, patch_size=2.0, method="conventional").n_patches


def test_conventional_lines_of_a_point_light_are_d0():
    # a point light's critical surfaces are its shadow volume's sides (No per pair): D0 lines,
    # node copies on both sides as in the simplified mesh
    sc = _point_light_scene()
    m = discontinuity_mesh(sc, patch_size=0.5, method="conventional")
    seg = m.discontinuity.segments[0]
    assert m.discontinuity.counters["critical_surfaces"] == 4
    assert len(seg) == 4 and set(seg.kinds) == {"D0"}
    on = _nodes_on(m, 0, seg.ends, 1e-9 * sc.polygons[0].diameter)
    _, counts = np.unique(np.round(m.nodes[on], 9), axis=0, return_counts=True)
    assert len(counts) > 8 and np.all(counts >= 2)


def test_conventional_mesh_of_the_chair():
    # the chair's floor has holes under the legs and critical segments ending a hair short of
    # others: the noding still gives the mesh model a planar graph
    sc = scenes.chair_scene()
    m = discontinuity_mesh(sc, patch_size=3.3, penumbra_patch_size=1.1, method="conventional")
    c = m.discontinuity.counters
    assert c["critical_segments"] > 500 and c["discontinuity_edges"] > 0
    assert m.n_elements > mesh_scene(sc, 3.3).n_elements


def test_state_boundaries_only_drops_exactly_the_equal_state_edges():
    """Issue 41, item 2: with every sphere face its own occluder most floor edges part two faces of
    one state; ``state_boundaries_only`` leaves those out and keeps every edge between states."""
    from polygen.discontinuity import simplified_discontinuity
    from polygen.discontinuity.states import discontinuity_segments

    sc = scenes.sphere_scene(n_lat=6, n_lon=8)
    sd = simplified_discontinuity(sc, solids=False)
    k = [i for i, p in enumerate(sc.polygons) if p.name == "room_y0"][0]
    cx = sd.complexes[k]
    every = discontinuity_segments(cx, min_length=0.0)
    kept = discontinuity_segments(cx, min_length=0.0, state_boundaries_only=True)
    assert 0 < len(kept) < len(every)
    # each kept segment has different states on its two sides, each dropped one the same
    faces = [shapely.Polygon(*cx.face_rings(f)) for f in cx.alive_faces]
    st = cx.face_states()
    tree = shapely.STRtree(faces)

    def sides_differ(seg):
        mid, d = seg.mean(axis=0), seg[1] - seg[0]
        nrm = np.array([-d[1], d[0]]) / np.hypot(*d) * 1e-6 * cx.extent
        out = []
        for p in (mid + nrm, mid - nrm):
            hit = [i for i in tree.query(shapely.Point(p)) if faces[i].contains(shapely.Point(p))]
            out.append(tuple(st[hit[0]]) if hit else None)
        return out[0] != out[1]

    kept_set = {tuple(np.round(s, 9).ravel()) for s in kept.ends}
    differ = np.array([sides_differ(s) for s in every.ends])
    is_kept = np.array([tuple(np.round(s, 9).ravel()) in kept_set for s in every.ends])
    assert np.array_equal(differ, is_kept)

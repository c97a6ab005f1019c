"""Conventional discontinuity meshing (thesis 2.4.3) and the 2-D BSP tree (Figs 2.10, 3.4)."""

import numpy as np
import pytest
import shapely
from shapely.ops import polygonize, unary_union

from polygen.discontinuity import scene_sections
from polygen.discontinuity.bsp import bsp_split
from polygen.discontinuity.conventional import (
    conventional_bsp,
    conventional_segments,
    critical_surfaces,
    section_segments,
)
from polygen.discontinuity.shadow import scene_lights
from polygen.radiosity import scenes


@pytest.fixture(scope="module")
def fig34():
    sc = scenes.figure_3_4_scene()
    return sc, scene_sections(sc)


def _loop_regions(receiver, segments):
    """Faces of the arrangement of the segments and the receiver's rings (what loops give)."""
    rings = [shapely.LinearRing(receiver.exterior_2d)] + [shapely.LinearRing(h) for h in receiver.holes_2d]
    lines = unary_union([shapely.LineString(s) for s in segments] + rings)
    return [p for p in polygonize(lines) if p.area > 1e-9 * receiver.area
            and receiver._shape2d.contains(p.representative_point())]


def test_edge_counts_of_figure_3_3(fig34):
    # Fig. 3.3: per receiver, 2 Ns No conventional edges against Ns + 2 No simplified ones
    sc, sh = fig34
    floor = sc.polygons[0]
    cs = conventional_segments(sc, 0, shadows=sh)
    Ns, No, pairs = 4, 4, 2
    assert len(cs.pairs) == pairs
    assert cs.surfaces == pairs * 2 * Ns * No
    assert cs.surfaces_reaching == pairs * 2 * Ns * No  # the receiver is large: all reach it
    assert cs.kinds.count("EV") == cs.kinds.count("VE") == pairs * Ns * No
    ss, kinds = section_segments(floor, sh.of(0))
    assert len(ss) == pairs * (Ns + 2 * No)
    assert kinds.count("umbra") == pairs * No


def test_segments_lie_on_their_critical_surfaces(fig34):
    # Def. 2.9: each point of an EV segment is on a ray from the light vertex through the
    # occluder edge, past the edge; of a VE segment, on a ray from the light edge through the
    # occluder vertex, past the vertex
    sc, sh = fig34
    floor = sc.polygons[0]
    cs = conventional_segments(sc, 0, shadows=sh)
    for seg, kind, (li, k, j), (sid, oid) in zip(cs.segments, cs.kinds, cs.sources, cs.generators):
        S = scene_lights(sc)[li][1].vertices
        O = sc.polygons[k].convex_pieces()[j].vertices
        for t in (0.1, 0.5, 0.9):
            P = floor.to_3d(seg[0] + t * (seg[1] - seg[0]))
            if kind == "EV":
                s, (a, b) = S[sid[0]], O[list(oid)]
                n = np.cross(b - a, s - a)
                assert abs((P - a) @ n) / np.linalg.norm(n) < 1e-9
                # the ray s -> P crosses the edge's line between a and b, before P
                lam = np.linalg.lstsq(np.c_[P - s, a - b], a - s, rcond=None)[0]
                assert 0 < lam[0] < 1 and -1e-9 <= lam[1] <= 1 + 1e-9
            else:
                (s0, s1), o = S[list(sid)], O[oid[0]]
                n = np.cross(s1 - s0, o - s0)
                assert abs((P - o) @ n) / np.linalg.norm(n) < 1e-9
                # the line P -> o meets the light edge at s0 + mu (s1 - s0) = o + kappa (o - P)
                mu, kappa = np.linalg.lstsq(np.c_[s1 - s0, P - o], o - s0, rcond=None)[0]
                assert -1e-9 <= mu <= 1 + 1e-9 and kappa > 0


@pytest.mark.parametrize("name", ["figure_3_4_scene", "two_rectangles_room"])
def test_simplified_edges_are_some_of_the_conventional_ones(name):
    # Theorem 3.2: the umbra/penumbra boundaries are D1 discontinuity lines, so each simplified
    # edge lies on conventional ones
    sc = getattr(scenes, name)()
    sh = scene_sections(sc)
    for r in sh.sections:
        R = sc.polygons[r]
        cs = conventional_segments(sc, r, shadows=sh)
        ss, _ = section_segments(R, sh.of(r))
        tol = 1e-7 * R.diameter
        for a, b in ss:
            # the conventional segments on the same line cover [a, b] (parallel light and occluder
            # edges make several EV/VE wedges share a plane, each covering a part)
            e = (b - a) / np.linalg.norm(b - a)
            cover = []
            for c, d in cs.segments:
                dist = [abs(e[0] * (x - a)[1] - e[1] * (x - a)[0]) for x in (c, d)]
                if max(dist) < tol:
                    cover.append(sorted([(c - a) @ e, (d - a) @ e]))
            reach = 0.0
            for lo, hi in sorted(cover):
                if lo <= reach + tol:
                    reach = max(reach, hi)
            assert reach >= np.linalg.norm(b - a) - tol, (R.name, a, b)


def test_bsp_splits_whole_cells_by_supporting_lines():
    square = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    # a segment from the centre to the right side splits the whole square (its line runs across)
    b = bsp_split([square], [[[0.5, 0.5], [1.0, 0.5]]])
    assert b.n_regions == 2 and b.splits == 1
    # a vertical segment across both halves: four; one in the upper half only: three
    assert bsp_split([square], [[[0.5, 0.5], [1.0, 0.5]], [[0.3, 0.0], [0.3, 1.0]]]).n_regions == 4
    assert bsp_split([square], [[[0.5, 0.5], [1.0, 0.5]], [[0.3, 0.6], [0.3, 1.0]]]).n_regions == 3
    # a segment along the boundary or outside splits nothing
    assert bsp_split([square], [[[0.0, 0.0], [1.0, 0.0]], [[2.0, 0.0], [3.0, 1.0]]]).n_regions == 1


@pytest.mark.parametrize("which", ["simplified", "conventional"])
def test_bsp_regions_partition_the_receiver(fig34, which):
    sc, sh = fig34
    floor = sc.polygons[0]
    segs = (section_segments(floor, sh.of(0))[0] if which == "simplified"
            else conventional_segments(sc, 0, shadows=sh).segments)
    b = conventional_bsp(floor, segs)
    areas = [shapely.Polygon(r).area for r in b.regions]
    assert np.isclose(sum(areas), floor.area, rtol=1e-12)
    union = unary_union([shapely.Polygon(r) for r in b.regions])
    assert np.isclose(union.area, floor.area, rtol=1e-9)  # no overlaps
    for r in b.regions:  # convex, counter-clockwise
        d1 = np.roll(r, -1, axis=0) - r
        d2 = np.roll(d1, -1, axis=0)
        assert np.all(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] > 0)
    # no segment crosses a region's interior
    for a, c in segs:
        line = shapely.LineString([a, c])
        for r in b.regions:
            assert shapely.Polygon(r).buffer(-1e-9).intersection(line).length < 1e-9
    # the thesis's claim (Fig. 3.4, Table 3.1): loops give no more regions than the BSP
    assert len(_loop_regions(floor, segs)) <= b.n_regions
    assert b.n_nodes == 1 + 2 * b.splits


def test_figure_3_4_counts(fig34):
    # Fig. 3.4: the simplified edges split the receiver into 6 regions by loops, 29 by BSP in the
    # thesis; the loop count follows from the configuration the text describes, the BSP count
    # from insertion order and geometry the text does not give (ours, 36: benchmarks/results/shadow.md)
    sc, sh = fig34
    floor = sc.polygons[0]
    ss, _ = section_segments(floor, sh.of(0))
    assert len(_loop_regions(floor, ss)) == 6
    assert conventional_bsp(floor, ss).n_regions > 6


def test_critical_surfaces_of_a_point_light_are_the_volume_sides():
    O = np.array([[0.0, 1, 0], [1, 1, 0], [0, 1, 1]])
    w = critical_surfaces(np.array([[0.2, 3, 0.2]]), O, reach=10.0)
    assert [k for k, *_ in w] == ["EV"] * 3
    w = critical_surfaces(np.array([[0.0, 3, 0], [1, 3, 0], [1, 3, 1], [0, 3, 1]]), O, reach=10.0)
    assert len(w) == 2 * 4 * 3


def test_ev_ve_planes_classify_the_polyhedra_sides():
    """The brute-force EV/VE planes (notebook 03's check of Figs 3.6, 3.7): the penumbra's sides
    are exactly the separating ones, the umbra's sides support light and occluder."""
    from polygen.discontinuity import ev_ve_planes, plane_roles, shadow_polyhedron, unique_planes
    from polygen.discontinuity.shadow import scene_lights

    sc = scenes.figure_3_4_scene()
    k = [i for i, p in enumerate(sc.polygons) if p.name.startswith("occluder_a")][0]
    ph = shadow_polyhedron(scene_lights(sc)[0][1], sc.polygons[k], bounds=sc.bounds)
    S, O = ph.light_vertices, ph.occluder_vertices
    planes, role = ev_ve_planes(S, O)
    assert len(planes) == 2 * 4 * 4 and set(np.unique(role)) <= {-1, 0, 1}
    sep = planes[role == 1]
    wrapped = unique_planes(ph.penumbra.planes[1:])
    assert len(wrapped) == len(sep) == 8
    assert all(np.abs(sep - w).max(axis=1).min() < 1e-7 for w in wrapped)
    assert np.all(plane_roles(S, O, ph.umbra.planes[1:]) == 0)
    # a plane and its flip are one plane
    assert len(unique_planes(np.vstack([planes, -planes]))) == len(planes)

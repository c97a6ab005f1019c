"""The receiver complex of chapter 3: the walk (3.3.3), loop rebuilding (3.3.4), states (3.3.5).

Oracles: the topology invariants of :meth:`ReceiverComplex.check` after
every loop update (Euler-Poincare, two loop sides per discontinuity edge,
orientations, areas); illumination states against brute force (a sample
point's state from direct point-in-convex-polygon tests of all sections,
compared with the state of the face it falls in, located with shapely
independently of the complex); hand-counted configurations (Figs 3.9, 3.13).
"""

import numpy as np
import pytest
import shapely

from polygen.discontinuity.complex import ComplexError, ReceiverComplex
from polygen.discontinuity.states import (BRIGHT, PENUMBRA, UMBRA, discontinuity_segments, receiver_complex,
                                          region_points, region_size)

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def rect(x0, y0, x1, y1):
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)


def convex_hull(p):
    from shapely.geometry.polygon import orient

    return np.asarray(orient(shapely.convex_hull(shapely.multipoints(p))).exterior.coords)[:-1]


def random_sections(rng, n, n_lights, *, grid=False):
    """n (light, umbra, penumbra, kind): random convex penumbrae, umbrae shrunk inside them."""
    out = []
    for _ in range(n):
        light = int(rng.integers(n_lights))
        if grid:
            # axis-aligned on a 0.1 grid: shared vertices, collinear overlaps, edges on the ring
            x0, x1 = np.sort(rng.choice(np.arange(-2, 13), 2, replace=False)) / 10
            y0, y1 = np.sort(rng.choice(np.arange(-2, 13), 2, replace=False)) / 10
            pen = rect(x0, y0, x1, y1)
            if x1 - x0 > 0.2 and y1 - y0 > 0.2 and rng.random() < 0.7:
                um = rect(x0 + 0.1, y0 + 0.1, x1 - 0.1, y1 - 0.1)
            else:
                um = np.zeros((0, 2))
        else:
            c = rng.uniform(-0.2, 1.2, 2)
            pen = convex_hull(c + rng.uniform(-0.35, 0.35, (int(rng.integers(3, 9)), 2)))
            f = rng.uniform(0.0, 0.9)
            um = np.zeros((0, 2)) if f < 0.15 else pen.mean(axis=0) + f * (pen - pen.mean(axis=0))
        kind = "point" if rng.random() < 0.2 else "area"
        if kind == "point":
            um = pen.copy()
        out.append((light, um, pen, kind))
    return out


def brute_state(p, sections, n_lights):
    """(K, n_lights) states of points by direct tests against every section."""
    st = np.full((len(p), n_lights), BRIGHT, np.int8)
    pts = shapely.points(p)
    for light, um, pen, _ in sections:
        for ring, val in ((pen, PENUMBRA), (um, UMBRA)):
            if len(ring) >= 3:
                inside = shapely.contains(shapely.Polygon(ring), pts)
                st[inside, light] = np.maximum(st[inside, light], val)
    return st


def near_lines(p, sections, outer, holes, band):
    lines = [shapely.LinearRing(outer)] + [shapely.LinearRing(h) for h in holes]
    for _, um, pen, _ in sections:
        lines += [shapely.LinearRing(r) for r in (um, pen) if len(r) >= 3]
    return shapely.dwithin(shapely.multilinestrings(lines), shapely.points(p), band)


def face_of(cx, p):
    """Index into alive_faces of the face each point lies in (shapely, not the complex's locator)."""
    polys = [shapely.Polygon(*cx.face_rings(f)) for f in cx.alive_faces]
    tree = shapely.STRtree(polys)
    pi, fi = tree.query(shapely.points(p), predicate="within")
    out = np.full(len(p), -1)
    out[pi] = fi
    return out


RECEIVERS = {
    "square": (SQUARE, []),
    "square_with_hole": (SQUARE, [rect(0.3, 0.35, 0.6, 0.7)]),
    "hexagon": (np.array([[0.5, -0.1], [1.1, 0.2], [1.1, 0.8], [0.5, 1.1], [-0.1, 0.8], [-0.1, 0.2]]), []),
    "far_from_origin": (SQUARE * 3 + 1e6, []),
}


@pytest.mark.parametrize("grid", [False, True], ids=["generic", "grid"])
@pytest.mark.parametrize("name", list(RECEIVERS))
def test_topology_and_states_on_random_sections(name, grid):
    outer, holes = RECEIVERS[name]
    rng = np.random.default_rng(14 + 2 * list(RECEIVERS).index(name) + grid)
    n_lights = 2
    sec = random_sections(rng, 40, n_lights, grid=grid)
    lo = outer.min(axis=0)
    scale = np.ptp(outer, axis=0).max()
    sec = [(l_, lo + scale * u if len(u) else u, lo + scale * p, k) for l_, u, p, k in sec]
    cx = receiver_complex(outer, holes, sec, n_lights=n_lights, tol=1e-11, check=True)
    assert cx.counters.get("fallback", 0) == 0, cx.fallback_reason  # the walk itself is under test
    cx.check()
    V, E, F, L = cx.euler()
    assert F > 10 and E > 4 * len(outer)
    # states against brute force on random points, away from every line by 1e-9 x extent
    p = rng.uniform(outer.min(axis=0), outer.max(axis=0), (4000, 2))
    p = p[shapely.contains(shapely.Polygon(outer, holes), shapely.points(p))]
    p = p[~near_lines(p, sec, outer, holes, 1e-9 * scale)]
    assert len(p) > 1000
    f = face_of(cx, p)
    assert np.all(f >= 0), "a point inside the receiver lies in no face"
    got = cx.face_states()[f]
    want = brute_state(p, sec, n_lights)
    bad = np.flatnonzero(np.any(got != want, axis=1))
    assert not len(bad), f"{len(bad)} points with wrong states, e.g. {p[bad[0]]}: {got[bad[0]]} vs {want[bad[0]]}"


def test_point_light_umbra_is_d0_and_one_polygon():
    """Point light: umbra = penumbra, one set of D0 edges, states umbra / bright only."""
    sh = rect(0.2, -0.5, 0.7, 0.6)  # crosses the bottom ring edge
    cx = receiver_complex(SQUARE, (), [(0, sh, sh, "point")], check=True)
    assert "fallback" not in cx.counters
    seg = discontinuity_segments(cx)
    assert len(seg) == 3 and set(seg.kinds) == {"D0"}  # the three sides inside the square
    assert sorted(cx.face_states()[:, 0].tolist()) == [BRIGHT, UMBRA]


def test_d0_wins_over_d1_along_a_shared_line():
    area = (0, rect(0.4, 0.4, 0.6, 0.6), rect(0.2, 0.2, 0.8, 0.8), "area")
    point = (1, rect(0.2, 0.2, 0.8, 0.5), rect(0.2, 0.2, 0.8, 0.5), "point")
    cx = receiver_complex(SQUARE, (), [area, point], check=True)
    assert "fallback" not in cx.counters
    seg = discontinuity_segments(cx)
    for e, k in zip(seg.ends, seg.kinds):
        horizontal_d0 = np.allclose(e[:, 1], 0.2) or np.allclose(e[:, 1], 0.5)
        side_d0 = np.allclose(e[:, 0], 0.2) or np.allclose(e[:, 0], 0.8)
        d0 = horizontal_d0 or (side_d0 and e[:, 1].max() <= 0.5 + 1e-12)
        assert k == ("D0" if d0 else "D1"), (e, k)


def test_fig_3_9_walk():
    """Fig. 3.9: a triangle V1 V4 V5 walked from V1 in loop L1 across E1 into L2, across E2 into L3.

    The receiver is the unit square cut into three strips L1 | L2 | L3 by the
    lines x = 0.4 (E1) and x = 0.7 (E2).  V1 and V5 lie in L1, V4 in L3.
    Counted by hand: V1 is located by one point-in-loop test (the other
    loops' boxes miss it) and checked against L1's 4 edges; V1 -> V4 tests
    L1 (4 edges), crosses E1 at V2 (split: L1 and L2 get 5), tests L2 (5),
    crosses E2 at V3 (split: L2 6, L3 5), tests L3 (5), ends inside it;
    V4 -> V5 tests L3 (5), crosses E2 (L3 6, L2 7), tests L2 (7), crosses E1
    (L1 6), tests L1 (6), ends inside; V5 -> V1 tests L1 (6).  That is 4 + 4
    + 5 + 5 + 5 + 7 + 6 + 6 = 42 edge tests and 4 splits; all edges of the
    complex against all three section edges would be more once it grows.
    """
    from polygen.discontinuity.loops import rebuild_loops
    from polygen.discontinuity.walk import clean_ring, insert_section

    strips = (0, rect(0.4, -1, 0.7, 2), rect(0.4, -1, 0.7, 2), "point")
    cx = receiver_complex(SQUARE, (), [strips], check=True)
    assert len(cx.alive_faces) == 3
    before = dict(cx.counters)
    tri = np.array([[0.2, 0.3], [0.9, 0.5], [0.2, 0.7]])  # V1, V4, V5
    new, edge_face, snapped = insert_section(cx, clean_ring(tri - cx.origin, cx.eps), 1)
    assert snapped == []
    c = {k: cx.counters[k] - before[k] for k in before}
    assert (c["point_in_loop"], c["edge_tests"], c["splits"]) == (1, 42, 4)
    # new edges V1V2, V2V3, V3V4, V4V6, V6V7, V7V5, V5V1, drawn in L1, L2, L3, L3, L2, L1, L1
    assert len(new) == 7
    faces = [edge_face[e] for e in new]
    assert faces[0] == faces[5] == faces[6] and faces[1] == faces[4] and faces[2] == faces[3]
    assert len(set(faces)) == 3
    table, created, deleted = rebuild_loops(cx, new, edge_face)
    cx.check()
    # all three strips' loops are superseded; left strip -> 2 loops, middle -> 3, right -> 2
    assert len(deleted) == 3 and len(created) == 7 and len(cx.alive_faces) == 7
    assert all(min(v) >= 0 for v in table.values())


def test_fig_3_13_loops_replaced_by_traced_ones():
    """Loop rebuilding (Fig. 3.13): only loops an inserted section touches are deleted, the
    left/right table of every new edge is filled, outer loops CCW, holes CW.

    The thesis's figure (8 loops, 9 after O_3) cannot be rebuilt from the text
    alone; this is the same operation on a configuration counted by hand.
    O_1 and O_2 leave two islands (penumbra square around an umbra square):
    5 faces, 9 loops (the square's outer loop, 2 island holes in it, and per
    island a penumbra ring with its hole and an umbra).  O_3 (a rectangle
    from inside O_1's umbra to past O_2) crosses O_1's two squares twice each
    its top edge crosses both of O_2's squares twice: 20 + 4 +
    8 = 32 vertices, 20 + 12 + 8 = 40 edges, one component inside the square
    (H = 1 hole loop), so V - E + F - H = 1 gives F = 10 and L = F + H = 11.
    """
    o1 = (0, rect(0.15, 0.15, 0.3, 0.3), rect(0.1, 0.1, 0.35, 0.35), "area")
    o2 = (0, rect(0.65, 0.65, 0.8, 0.8), rect(0.6, 0.6, 0.85, 0.85), "area")
    cx = receiver_complex(SQUARE, (), [o1, o2], check=True)
    _, _, F, L = cx.euler()
    # faces: the square minus two islands, two penumbra rings, two umbrae; loops: 1 + 4 holes + 4 outers
    assert (F, L) == (5, 9)
    from polygen.discontinuity.loops import rebuild_loops
    from polygen.discontinuity.walk import clean_ring, insert_section

    o3 = clean_ring(rect(0.2, 0.25, 0.9, 0.7) - cx.origin, cx.eps)
    alive_before = set(cx.alive_loops)
    new, ef, _ = insert_section(cx, o3, 2)
    table, created, deleted = rebuild_loops(cx, new, ef)
    cx.check()
    assert all(l_ >= 0 and r >= 0 for l_, r in table.values())
    assert set(cx.alive_loops) == (alive_before - deleted) | set(created)
    # O_3 cuts both islands: their rings merge with it, the square's outer loop survives untouched
    assert 0 in set(cx.alive_loops) and 0 not in deleted
    _, _, F2, L2 = cx.euler()
    assert (F2, L2) == (10, 11)
    # the two island holes of the square's face are superseded by one hole around all three
    assert len(cx.face_holes[cx.loop_face[0]]) == 1


def test_outputs_feed_the_mesh_model():
    from polygen.radiosity.layout import polygon_layout
    from polygen.radiosity.scene import Polygon

    rng = np.random.default_rng(3)
    sec = random_sections(rng, 8, 2)
    cx = receiver_complex(SQUARE, (), sec)
    seg = discontinuity_segments(cx)
    poly = Polygon(np.c_[SQUARE, np.zeros(4)])
    frame = poly.to_2d(np.c_[SQUARE, np.zeros(4)])
    # the receiver in the polygon's own frame, sections moved with it
    m = np.linalg.lstsq(np.c_[SQUARE, np.ones(4)], frame, rcond=None)[0]
    sec2 = [(l_, np.c_[u, np.ones(len(u))] @ m if len(u) else u, np.c_[p, np.ones(len(p))] @ m, k)
            for l_, u, p, k in sec]
    cx = receiver_complex(frame, (), sec2)
    seg = discontinuity_segments(cx)
    lay = polygon_layout(poly, seg)
    assert lay.n_regions == len(cx.alive_faces)
    rs = region_size(cx, 0.2, 0.05)
    sizes = rs.resolve(poly, lay)
    pen = np.any(cx.face_states() == PENUMBRA, axis=1)
    reg = lay.region_of(region_points(cx))
    assert sorted(reg.tolist()) == list(range(lay.n_regions))
    assert [sizes[r] for r in reg] == [0.05 if p else 0.2 for p in pen]


@pytest.mark.parametrize("bad, match", [
    ((0, np.array([[0, 0], [1, 0], [0.5, 0.2], [1, 1], [0, 1.0]]), np.zeros((0, 2))), "section 0 .*convex"),
    ((0, np.array([[0, 0], [1, 0], [np.nan, 1.0]]), np.zeros((0, 2))), "section 0 .*non-finite"),
    ((5, rect(0, 0, 1, 1), rect(0, 0, 1, 1)), "section 0: light 5"),
    ((0, rect(0, 0, 1, 1)), "section 0: expected"),
])
def test_bad_sections_are_named(bad, match):
    with pytest.raises(ComplexError, match=match):
        receiver_complex(SQUARE, (), [bad], n_lights=1)


def test_bad_receiver():
    with pytest.raises(ComplexError, match="receiver"):
        ReceiverComplex(np.array([[0, 0], [1, 1], [1, 0], [0, 1.0]]))


@pytest.mark.parametrize("noise, fallback", [(1e-12, 0), (1e-10, 1)])
@pytest.mark.parametrize("name", ["square_with_hole", "hexagon"])
def test_near_degenerate_sections(name, noise, fallback):
    """Sections on a 0.1 grid moved by Gaussian noise: well below the tolerance (1e-11 here) the
    walk snaps them consistently; at 10x the tolerance (lines closer than it without meeting,
    crossings at angles ~ tol / length) it cannot, and the receiver is rebuilt by snap-rounded
    noding.  Either way the complex is valid and the states are right."""
    outer, holes = RECEIVERS[name]
    rng = np.random.default_rng(7)
    sec = random_sections(rng, 30, 2, grid=True)
    sec = [(l_, u + noise * rng.standard_normal(u.shape) if len(u) else u,
            p + noise * rng.standard_normal(p.shape), k) for l_, u, p, k in sec]
    cx = receiver_complex(outer, holes, sec, n_lights=2, tol=1e-11)
    assert cx.counters.get("fallback", 0) == fallback
    cx.check()
    p = rng.uniform(outer.min(axis=0), outer.max(axis=0), (3000, 2))
    p = p[shapely.contains(shapely.Polygon(outer, holes), shapely.points(p))]
    p = p[~near_lines(p, sec, outer, holes, 1e-9 + 10 * noise)]
    f = face_of(cx, p)
    assert np.all(f >= 0)
    np.testing.assert_array_equal(cx.face_states()[f], brute_state(p, sec, 2))


# -- the three scenes of chapter 3: states against ray casting ------------------------------------
@pytest.fixture(scope="module")
def scene_discontinuity():
    from polygen.discontinuity.simplified import simplified_discontinuity
    from polygen.radiosity import scenes

    cache = {}

    def get(name):
        if name not in cache:
            sc = getattr(scenes, name)()
            cache[name] = (sc, simplified_discontinuity(sc))
        return cache[name]
    return get


@pytest.mark.parametrize("name", ["two_rectangles_room", "sphere_scene", "chair_scene"])
def test_illumination_states_agree_with_ray_casting(name, scene_discontinuity):
    """Issue 14, "Illumination states are right": on every receiver, 10^4 points; the light's
    visible fraction by ray casting (4 x 4 light samples, tests/naive.py) is 0 where the region's
    state is umbra and 1 where it is bright, except within 1e-6 x scene size of a discontinuity
    line.  Penumbra regions are only counted: the per-occluder rule (3.3.5) calls penumbra a
    region two occluders darken jointly, whatever its visible fraction."""
    from naive import visible_fraction

    from polygen.discontinuity.shadow import scene_lights

    sc, sd = scene_discontinuity(name)
    rng = np.random.default_rng(14)
    band = 1e-6 * float(np.linalg.norm(np.ptp(sc.bounds, axis=0)))
    lights = scene_lights(sc)
    seen = dict(umbra=0, penumbra=0, bright=0, penumbra_dark=0, penumbra_lit=0)
    assert sd.complexes
    for r, cx in sd.complexes.items():
        R = sc.polygons[r]
        shp = shapely.Polygon(R.exterior_2d, R.holes_2d)
        lo, hi = R.exterior_2d.min(axis=0), R.exterior_2d.max(axis=0)
        uv = rng.uniform(lo, hi, (20_000, 2))
        uv = uv[shapely.contains_xy(shp, uv[:, 0], uv[:, 1])][:10_000]
        lines = [shapely.LinearRing(R.exterior_2d)] + [shapely.LinearRing(h) for h in R.holes_2d]
        seg = discontinuity_segments(cx, min_length=0.0)
        lines += list(shapely.linestrings(seg.ends))
        far = ~shapely.dwithin(shapely.multilinestrings(lines), shapely.points(uv), band)
        f = face_of(cx, uv)
        assert np.all(f[far] >= 0)
        st = cx.face_states()[np.maximum(f, 0)]
        X = R.to_3d(uv)
        for side in ((1, -1) if R.two_sided else (1,)):
            for li, (kind, light, lpoly) in enumerate(lights):
                frac = visible_fraction(sc, light, X, normals=np.broadcast_to(side * R.normal, X.shape),
                                        samples=4, skip=[r])
                s = st[:, li + (len(lights) if side < 0 else 0)]
                sel = far & ~np.isnan(frac)
                bad_u = np.flatnonzero(sel & (s == UMBRA) & (frac != 0.0))
                bad_b = np.flatnonzero(sel & (s == BRIGHT) & (frac != 1.0))
                assert not len(bad_u), (R.name, side, li, uv[bad_u[:3]], frac[bad_u[:3]])
                assert not len(bad_b), (R.name, side, li, uv[bad_b[:3]], frac[bad_b[:3]])
                seen["umbra"] += int((sel & (s == UMBRA)).sum())
                seen["bright"] += int((sel & (s == BRIGHT)).sum())
                pen = sel & (s == PENUMBRA)
                seen["penumbra"] += int(pen.sum())
                seen["penumbra_dark"] += int((pen & (frac == 0.0)).sum())
                seen["penumbra_lit"] += int((pen & (frac == 1.0)).sum())
    assert min(seen["umbra"], seen["penumbra"], seen["bright"]) > 100, seen


def test_scene_mesh_follows_the_lines_and_refines_penumbra(scene_discontinuity):
    """3.3.6: mesh_scene takes the driver's segments and region sizes as they are; every patch
    of a receiver lies in one region of its complex, and patches in penumbra regions are
    smaller (penumbra size a third of the others) than the others on the same receiver."""
    from polygen.radiosity import mesh_scene

    sc, sd = scene_discontinuity("two_rectangles_room")
    m = mesh_scene(sc, sd.region_sizes(1.0, 1.0 / 3), segments=sd.segments)
    for r, cx in sd.complexes.items():
        R = sc.polygons[r]
        sel = np.flatnonzero(m.patch_polygon == r)
        tri = m.nodes[m.patches[sel]]
        uv = R.to_2d(tri.mean(axis=1))
        f = face_of(cx, uv)
        assert np.all(f >= 0)
        # no patch straddles a discontinuity line: its corners lie in (or on) its centroid's face
        polys = [shapely.Polygon(*cx.face_rings(g)) for g in cx.alive_faces]
        corners = R.to_2d(tri.reshape(-1, 3)).reshape(-1, 3, 2)
        for k in range(len(sel)):
            assert shapely.dwithin(polys[f[k]], shapely.points(corners[k]), 1e-7 * R.diameter).all()
        pen = np.any(cx.face_states() == PENUMBRA, axis=1)[f]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        if pen.any() and (~pen).any():
            assert area[pen].mean() < area[~pen].mean() / 3


def _fig_3_9_records():
    strips = (0, rect(0.4, -1, 0.7, 2), rect(0.4, -1, 0.7, 2), "point")
    tri = (0, np.zeros((0, 2)), np.array([[0.2, 0.3], [0.9, 0.5], [0.2, 0.7]]), "area")
    return receiver_complex(SQUARE, (), [strips, tri], n_lights=1, record=True, check=True)


def test_records_off_by_default():
    cx = receiver_complex(SQUARE, (), [(0, rect(0.2, 0.2, 0.5, 0.5), rect(0.1, 0.1, 0.6, 0.6))])
    assert cx.records is None


def test_fig_3_9_walk_recorded_step_by_step():
    """The recorded walk of Fig. 3.9 agrees with the counters, the hand count and the complex."""
    cx = _fig_3_9_records()
    rec = cx.records[-1]
    steps = rec.walk
    # as counted by hand in test_fig_3_9_walk: 1 point-in-loop test, 42 edge tests
    assert sum(len(s.loops_tested) for s in steps) == rec.counters["point_in_loop"] == 1
    assert sum(len(s.tested) for s in steps) == rec.counters["edge_tests"] == 42
    assert [s.kind for s in steps] == ["locate"] + ["segment"] * 7
    # V1 located in L1; then L1, L2 (across E1), L3 (across E2), L3, L2, L1, L1
    assert steps[0].hit == "face" and [len(s.tested) for s in steps] == [4, 4, 5, 5, 5, 7, 6, 6]
    assert [s.hit for s in steps[1:]] == ["edge", "edge", "none", "edge", "edge", "none", "none"]
    faces = [s.face for s in steps[1:]]
    assert faces[0] == faces[5] == faces[6] == steps[0].face and faces[1] == faces[4] and faces[2] == faces[3]
    # every crossing lies on the line it was found on (E1: x = 0.4, E2: x = 0.7)
    xs = [s.crossing[0] for s in steps[1:] if s.hit == "edge"]
    assert np.allclose(xs, [0.4, 0.7, 0.7, 0.4])
    # the edges drawn are the section's new edges, in order, as they stand in the final complex
    drawn = np.array([s.drawn for s in steps if s.drawn is not None])
    V = cx.vertices
    final = np.array([V[cx.edges[e]] for e in rec.new_edges])
    assert len(drawn) == len(rec.new_edges) == 7
    assert np.allclose(drawn, final, atol=1e-12)
    # the edges tested in each step are the edges of the face the step lies in, at that moment
    for s in steps[1:]:
        lo = np.minimum(s.tested_segments[:, 0], s.tested_segments[:, 1]).min(axis=0)
        assert np.all(lo >= -1e-12) and len(s.tested) == len(s.tested_segments)


def test_loop_rebuilding_recorded():
    """The recorded loop traces (Fig. 3.13): table, deletions and loops agree with the final complex."""
    o1 = (0, rect(0.15, 0.15, 0.3, 0.3), rect(0.1, 0.1, 0.35, 0.35), "area")
    o2 = (0, rect(0.65, 0.65, 0.8, 0.8), rect(0.6, 0.6, 0.85, 0.85), "area")
    o3 = (0, np.zeros((0, 2)), rect(0.2, 0.2, 0.75, 0.7), "area")
    cx = receiver_complex(SQUARE, (), [o1, o2, o3], record=True, check=True)
    for rec in cx.records:
        c = rec.counters
        assert len(rec.loops) == c["loops_traced"]
        assert len(set(rec.deleted)) == c["loops_deleted"] == sum(len(s.deleted) for s in rec.loops)
        # every table cell filled, each by the loop that traced that side of the edge
        assert set(rec.table) == set(rec.new_edges)
        for s in rec.loops:
            for h in s.half_edges:
                if (h >> 1) in rec.table:
                    assert rec.table[h >> 1][h & 1] == s.loop
        assert all(min(v) >= 0 for v in rec.table.values())
        assert rec.loops[-1].table == rec.table
        # the seed cell was empty before its loop was traced
        for i, s in enumerate(rec.loops):
            before = rec.loops[i - 1].table if i else {e: [-1, -1] for e in rec.table}
            assert before[s.seed[0]][s.seed[1]] == -1
        # a loop's path is its polygon: shoelace area as recorded, sign = orientation
        for s in rec.loops:
            x, y = s.path[:, 0], s.path[:, 1]
            area = 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
            assert area == pytest.approx(s.area, abs=1e-12)
            # each turn's options are the far ends of the junction's edges: the path's next point is one
            for v, deg, opts in s.turns:
                assert deg == len(opts) >= 3
                i = int(np.argmin(np.hypot(*(s.path - v).T)))
                assert np.min(np.hypot(*(opts - s.path[(i + 1) % len(s.path)]).T)) < 1e-12
    # the last ring's new loops are alive in the final complex (unless a later ring superseded them)
    last = cx.records[-1]
    alive = set(cx.alive_loops)
    assert {s.loop for s in last.loops} <= alive
    assert not (set(last.deleted) & alive)


def test_step_drawings_one_panel_per_step():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from polygen.plotting.discontinuity import plot_loop_steps, plot_walk_steps

    rec = _fig_3_9_records().records[-1]
    fig = plot_walk_steps(rec, ncols=4)
    assert sum(ax.axison for ax in fig.axes) == len(rec.walk) == 8
    fig2 = plot_loop_steps(rec, ncols=4)
    # one panel per loop traced, and the table's
    assert len([ax for ax in fig2.axes if ax.axison]) == len(rec.loops) == 7
    assert len(fig2.axes[len(rec.loops)].tables[0].get_celld()) == 3 * (len(rec.table) + 1)
    plt.close("all")


def test_plot_complex_with_light_at_moves_the_light():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from polygen.discontinuity import simplified_discontinuity
    from polygen.plotting.discontinuity import plot_complex_with_light_at
    from polygen.radiosity import scenes

    sc = scenes.figure_3_4_scene()
    n0 = len(simplified_discontinuity(sc).complexes[0].alive_faces)
    fig = plot_complex_with_light_at(sc, 0.0)
    assert fig.axes[0].get_title() == f"light moved by +0.0: {n0} regions"
    # the light moved by hand: the drawing shows that scene's complex
    from polygen.radiosity.scene import AreaLight, Scene

    moved = Scene([AreaLight(p.vertices + [3.0, 0.0, 0.0], emission=p.emission, name=p.name)
                   if isinstance(p, AreaLight) else p for p in sc.polygons])
    cx3 = simplified_discontinuity(moved).complexes[0]
    fig = plot_complex_with_light_at(sc, 3.0)
    assert fig.axes[0].get_title() == f"light moved by +3.0: {len(cx3.alive_faces)} regions"

    def drawn(f):
        return sorted(tuple(np.round(np.c_[ln.get_xdata(), ln.get_ydata()].ravel(), 9)) for ln in f.axes[0].lines)

    V = cx3.vertices
    assert drawn(fig) == sorted(tuple(np.round(V[[a, b]].ravel(), 9)) for a, b in cx3.edges)
    assert drawn(fig) != drawn(plot_complex_with_light_at(sc, 0.0))
    assert plot_complex_with_light_at(sc, 0.0, show=True) is None
    plt.close("all")


def test_recording_changes_nothing():
    """Records on or off: the same complex, states and counters (random sections, fixed seed)."""
    secs = random_sections(np.random.default_rng(7), 12, 2)
    a = receiver_complex(SQUARE, (), secs, n_lights=2)
    b = receiver_complex(SQUARE, (), secs, n_lights=2, record=True)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.edges, b.edges)
    assert np.array_equal(a.face_states(), b.face_states()) and a.counters == b.counters
    assert sum(r.counters["edge_tests"] for r in b.records) == b.counters["edge_tests"]
    assert sum(len(s.tested) for r in b.records for s in r.walk) == b.counters["edge_tests"]

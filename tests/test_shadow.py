"""Shadow polyhedra (thesis 3.3.1) and their sections, against independent constructions and ray casting."""

import warnings

import numpy as np
import pytest
import shapely
from scipy.spatial import ConvexHull

from naive import visible_fraction
from polygen.discontinuity import (
    ShadowError,
    ShadowWarning,
    scene_sections,
    shadow_polyhedron,
    shadow_sections,
    simplified_discontinuity,
)
from polygen.discontinuity.shadow import scene_lights
from polygen.radiosity import scenes
from polygen.radiosity.scene import AreaLight, ParallelLight, PointLight, Polygon, Scene, SceneError


# -- random configurations ----------------------------------------------------------------------
def _convex(rng, centre, radius, k, tilt):
    """A random convex k-gon (points on an ellipse) in a plane tilted from horizontal."""
    while True:  # no slivers: neighbouring vertices at least 0.4 rad apart
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        if np.diff(np.r_[ang, ang[0] + 2 * np.pi]).min() > 0.4:
            break
    r = radius * np.array([1.0, rng.uniform(0.5, 1.0)])
    pts = np.stack([r[0] * np.cos(ang), np.zeros(k), r[1] * np.sin(ang)], axis=1)
    a, b = rng.uniform(-tilt, tilt, 2)
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Rz = np.array([[np.cos(b), -np.sin(b), 0], [np.sin(b), np.cos(b), 0], [0, 0, 1]])
    return pts @ (Rz @ Rx).T + centre


def _configs(n, seed=1):
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        S = _convex(rng, [rng.uniform(-1, 1), 10.0, rng.uniform(-1, 1)], rng.uniform(0.5, 2.5),
                    int(rng.integers(3, 7)), 0.3)
        O = _convex(rng, [rng.uniform(-2, 2), rng.uniform(4, 7), rng.uniform(-2, 2)],
                    rng.uniform(0.5, 3.0), int(rng.integers(3, 7)), 0.6)
        n_o = np.cross(O[1] - O[0], O[2] - O[0])
        s = (S - O[0]) @ n_o
        if s.min() * s.max() <= 0:  # the light must lie on one side of the occluder's plane
            continue
        out.append((S, O))
    return out


def _light_seen_through_occluder_plane(P, S, O):
    """From P (beyond the occluder's plane), the light projected centrally on the occluder's plane.

    Every segment from P to a light point crosses that plane (they lie on its two sides), so
    the map is a perspective on a half-space: convex in, convex out.  Returns (occluder 2D,
    light 2D) in a frame of the occluder's plane.
    """
    c = O.mean(axis=0)
    n = np.cross(O[1] - O[0], O[2] - O[0])
    n /= np.linalg.norm(n)
    u = (O[0] - c) / np.linalg.norm(O[0] - c)
    v = np.cross(n, u)
    t = ((c - P) @ n) / ((S - P) @ n)
    Y = P + t[:, None] * (S - P)
    return np.stack([(O - c) @ u, (O - c) @ v], 1), np.stack([(Y - c) @ u, (Y - c) @ v], 1)


def _all_planes(S, O):
    """Every EV and VE plane and the occluder's, as (n, d) rows (for the exclusion band)."""
    rows = []
    m, n = len(S), len(O)
    for i in range(n):
        for k in range(m):
            rows.append((O[i], np.cross(O[(i + 1) % n] - O[i], S[k] - O[i])))
    for k in range(m):
        for i in range(n):
            rows.append((O[i], np.cross(S[(k + 1) % m] - S[k], O[i] - S[k])))
    rows.append((O[0], np.cross(O[1] - O[0], O[2] - O[0])))
    out = []
    for p, nv in rows:
        nv = nv / np.linalg.norm(nv)
        out.append(np.r_[nv, nv @ p])
    return np.array(out)


@pytest.mark.parametrize("config", range(12))
def test_polyhedra_against_the_occluder_seen_from_each_point(config):
    # the oracle: from P beyond the occluder, the light's central projection on the occluder's
    # plane; P is in the umbra iff the occluder covers it, in the penumbra iff it meets it
    S, O = _configs(12)[config]
    sp = shadow_polyhedron(S, O)
    rng = np.random.default_rng(config)
    lo = np.r_[O.min(axis=0)[0] - 6, -6.0, O.min(axis=0)[2] - 6]
    hi = np.r_[O.max(axis=0)[0] + 6, 9.0, O.max(axis=0)[2] + 6]
    P = lo + rng.random((1500, 3)) * (hi - lo)
    planes = _all_planes(S, O)
    far = np.all(np.abs(P @ planes[:, :3].T - planes[:, 3]) > 1e-6, axis=1)
    n_o = planes[-1, :3]
    beyond = np.sign((P - O[0]) @ n_o) != np.sign((S.mean(axis=0) - O[0]) @ n_o)
    want_u = np.zeros(len(P), bool)
    want_p = np.zeros(len(P), bool)
    for q in np.flatnonzero(beyond):
        o2, s2 = _light_seen_through_occluder_plane(P[q], S, O)
        occluder, light = shapely.Polygon(o2), shapely.Polygon(s2)
        want_u[q] = occluder.contains(light)
        want_p[q] = occluder.intersects(light)
    got_u = sp.umbra.contains(P)
    got_p = sp.penumbra.contains(P)
    assert far.sum() > 1000
    assert np.array_equal(got_u[far], want_u[far])
    assert np.array_equal(got_p[far], want_p[far])
    assert want_p[far].sum() > 50  # the sample reaches into the penumbra


@pytest.mark.parametrize("config", range(12))
def test_penumbra_planes_are_the_hull_of_the_extruded_occluder(config):
    # an independent construction: the convex hull of the occluder's vertices and of each
    # vertex pushed away from each light vertex; its facets through an occluder vertex and a
    # light vertex are the penumbra's side planes (Fig. 3.7), its facet through all occluder
    # vertices the occluder's plane
    S, O = _configs(12)[config]
    sp = shadow_polyhedron(S, O)
    X = np.vstack([O] + [O + 5.0 * (O - s) for s in S])
    hull = ConvexHull(X)
    eq = hull.equations  # n . x + c <= 0 inside
    scale = np.ptp(X, axis=0).max()
    on_o = np.abs(eq[:, :3] @ O.T + eq[:, 3:4]) < 1e-9 * scale
    on_s = np.abs(eq[:, :3] @ S.T + eq[:, 3:4]) < 1e-9 * scale
    want = {tuple(np.round(np.r_[e[:3], -e[3]], 6)) for e, a, b in zip(eq, on_o, on_s)
            if a.any() and b.any() and not a.all()}
    got = {tuple(np.round(p, 6)) for p in sp.penumbra.planes[1:]}
    assert got == want
    occ = [e for e, a in zip(eq, on_o) if a.all()]
    assert len(occ) >= 1 and np.allclose(np.r_[occ[0][:3], -occ[0][3]], sp.penumbra.planes[0])
    assert sp.candidate_planes == 2 * len(S) * len(O)
    assert not sp.penumbra.bounded


def test_umbra_planes_are_the_smallest_angle_ones():
    # Fig. 3.6: with a light larger than the occluder the umbra closes (a bounded polyhedron)
    S = np.array([[-2.0, 10, -2], [2, 10, -2], [2, 10, 2], [-2, 10, 2]])
    O = np.array([[-1.0, 6, -1], [1, 6, -1], [1, 6, 1], [-1, 6, 1]])
    sp = shadow_polyhedron(S, O)
    assert sp.umbra.bounded
    # apex: lines from (2, 10) through (1, 6) and from (-2, 10) through (-1, 6) meet at y = 2
    assert np.isclose(sp.umbra.vertices[:, 1].min(), 2.0)
    assert len(sp.umbra.planes) == 1 + 4
    # the penumbra of two parallel squares: the EV and VE planes of parallel edges coincide,
    # so four side faces
    assert len(sp.penumbra.planes) == 1 + 4
    # at y = 0 the penumbra is |x|, |z| <= 1 + 6 * 3/4 (the line from (-2, 10) through (1, 6))
    assert sp.penumbra.contains([[5.49, 0.0, 5.49]])[0] and not sp.penumbra.contains([[5.51, 0, 0]])[0]


@pytest.mark.parametrize("kind", ["point", "parallel"])
def test_point_and_parallel_lights_cast_one_volume(kind):
    O = np.array([[-1.0, 6, -1], [1, 6, -1], [1, 6, 1], [-1, 6, 1]])
    light = PointLight([0, 10, 0], 1.0) if kind == "point" else ParallelLight([0, -1, 0], 1.0)
    sp = shadow_polyhedron(light, O)
    assert sp.umbra is sp.penumbra and sp.kind == kind
    assert len(sp.umbra.planes) == 5
    # the shadow on y = 0: the square scaled by 10/4 from the point light, or the square itself
    half = 2.5 if kind == "point" else 1.0
    assert sp.umbra.contains([[half - 1e-6, 0, half - 1e-6]])[0]
    assert not sp.umbra.contains([[half + 1e-6, 0, 0]])[0]
    assert not sp.umbra.contains([[0, 7, 0]])[0]  # not on the light's side of the occluder


def test_light_in_the_occluders_plane_casts_nothing():
    S = np.array([[-2.0, 6, -2], [2, 6, -2], [2, 6, 2]])
    O = np.array([[3.0, 6, 3], [4, 6, 3], [4, 6, 4]])
    sp = shadow_polyhedron(S, O)
    assert sp.umbra.empty and sp.penumbra.empty


def test_bad_lights_and_occluders_are_named():
    concave = Polygon([[0, 10, 0], [4, 10, 0], [4, 10, 4], [2, 10, 1], [0, 10, 4]], name="vee")
    occ = np.array([[-1.0, 6, -1], [1, 6, -1], [1, 6, 1]])
    with pytest.raises(ShadowError, match="vee"):
        shadow_polyhedron(concave, occ)
    with pytest.raises(ShadowError, match="vee"):
        shadow_polyhedron(np.array([[0, 12.0, 0], [1, 12, 0], [1, 12, 1]]), concave)
    with pytest.raises(SceneError, match="convex"):
        AreaLight(concave.vertices, emission=1.0, name="vee_light")
    # a light across the occluder's plane: the driver splits it, the function refuses
    with pytest.raises(ShadowError, match="both sides"):
        shadow_polyhedron(np.array([[0, 5.0, 0], [1, 7, 0], [1, 7, 1]]), occ)


# -- sections on the thesis's scenes against ray casting ------------------------------------------
def _lamps_room():
    """The two-rectangles room lit by a point light and a parallel light (through the ceiling's
    hole) instead of its area light: D0 shadows, and the ceiling's convex pieces as occluders."""
    sc = scenes.two_rectangles_room()
    polys = [p for p in sc.polygons if not p.is_emitter]
    return Scene(polys, [PointLight([5.0, 9.0, 5.0], 10.0), ParallelLight([0.05, -1.0, 0.1], 1.0)],
                 name="lamps_room")


SCENES = {"two_rectangles_room": scenes.two_rectangles_room, "sphere_scene": scenes.sphere_scene,
          "chair_scene": scenes.chair_scene, "lamps_room": _lamps_room}


def _sample_in(poly, n, rng):
    shp = shapely.Polygon(poly.exterior_2d, poly.holes_2d)
    lo, hi = poly.exterior_2d.min(axis=0), poly.exterior_2d.max(axis=0)
    out = np.zeros((0, 2))
    while len(out) < n:
        uv = lo + rng.random((2 * n, 2)) * (hi - lo)
        out = np.vstack([out, uv[shapely.contains_xy(shp, uv[:, 0], uv[:, 1])]])
    return out[:n]


def _inside_convex(uv, ring):
    out = np.zeros(len(uv), bool)
    if len(ring) < 3:
        return out
    box = np.all((uv >= ring.min(axis=0)) & (uv <= ring.max(axis=0)), axis=1)
    q = uv[box]
    a, b = ring, np.roll(ring, -1, axis=0)
    cross = ((b[:, 0] - a[:, 0]) * (q[:, None, 1] - a[:, 1])
             - (b[:, 1] - a[:, 1]) * (q[:, None, 0] - a[:, 0]))
    out[box] = np.all(cross > 0, axis=1)
    return out


def _near_ring(uv, ring, band):
    out = np.zeros(len(uv), bool)
    if len(ring) < 3:
        return out
    box = np.all((uv >= ring.min(axis=0) - band) & (uv <= ring.max(axis=0) + band), axis=1)
    q = uv[box]
    a, b = ring, np.roll(ring, -1, axis=0)
    d = b - a
    t = np.clip(((q[:, None, :] - a) * d).sum(-1) / (d * d).sum(-1), 0, 1)
    dist = np.linalg.norm(q[:, None, :] - (a + t[..., None] * d), axis=-1)
    out[box] = dist.min(axis=1) <= band
    return out


@pytest.fixture(scope="module")
def scene_shadows():
    cache = {}

    def get(name):
        if name not in cache:
            sc = SCENES[name]()
            cache[name] = (sc, scene_sections(sc))
        return cache[name]
    return get


def _check_against_rays(sc, sh, receivers, rng, n_points, *, exact_umbra=False):
    """Visible fraction 0 in umbra sections and 1 outside penumbra sections; counts of each state.

    ``exact_umbra``: also, for area lights, a point lies in an umbra section iff every light
    vertex is hidden from it (point lights at the vertices), the whole light's umbra for one
    convex occluder; counts the points hidden from every vertex outside every umbra section
    (``understated``) instead of failing when it is ``"count"``.
    """
    band = 1e-6 * float(np.linalg.norm(np.ptp(sc.bounds, axis=0)))
    seen = dict(umbra=0, penumbra=0, bright=0)
    if exact_umbra == "count":
        seen["understated"] = 0
    for r in receivers:
        R = sc.polygons[r]
        uv = _sample_in(R, n_points(r), rng)
        X = R.to_3d(uv)
        for side in ((1, -1) if R.two_sided else (1,)):
            for li, (kind, light, lpoly) in enumerate(scene_lights(sc)):
                if r == lpoly:
                    continue
                secs = [s for s in sh.of(r) if s.light == li and s.side == side]
                frac = visible_fraction(sc, light, X, normals=np.broadcast_to(side * R.normal, X.shape),
                                        samples=4, skip=[r])
                near = np.zeros(len(uv), bool)
                umbra = np.zeros(len(uv), bool)
                pen = np.zeros(len(uv), bool)
                for s in secs:
                    near |= _near_ring(uv, s.penumbra, band) | _near_ring(uv, s.umbra, band)
                    umbra |= _inside_convex(uv, s.umbra)
                    pen |= _inside_convex(uv, s.penumbra)
                sel = ~np.isnan(frac) & ~near
                bad_u = np.flatnonzero(sel & umbra & (frac != 0.0))
                bad_b = np.flatnonzero(sel & ~pen & (frac != 1.0))
                assert len(bad_u) == 0, (R.name, side, li, X[bad_u[:3]], frac[bad_u[:3]])
                assert len(bad_b) == 0, (R.name, side, li, X[bad_b[:3]], frac[bad_b[:3]])
                if exact_umbra and kind == "area":
                    # a hair inside the light's corners: rays to a corner graze the ceiling's hole
                    c = light.vertices.mean(axis=0)
                    hid = np.ones(len(uv), bool)
                    for v in light.vertices:
                        f = visible_fraction(sc, PointLight(v + 1e-9 * (c - v), 1.0), X,
                                             normals=np.broadcast_to(side * R.normal, X.shape), skip=[r])
                        hid &= f == 0.0
                    over = np.flatnonzero(sel & umbra & ~hid)
                    under = np.flatnonzero(sel & ~umbra & hid)
                    assert len(over) == 0, (R.name, X[over[:3]])
                    if exact_umbra == "count":
                        seen["understated"] += len(under)
                    else:
                        assert len(under) == 0, (R.name, X[under[:3]])
                seen["umbra"] += int((sel & umbra).sum())
                seen["penumbra"] += int((sel & pen & ~umbra).sum())
                seen["bright"] += int((sel & ~pen).sum())
    return seen


@pytest.mark.parametrize("name", list(SCENES))
def test_sections_agree_with_ray_casting(name, scene_shadows):
    # issue 14: on every receiver, 10^4 points; the light's visible fraction by ray casting is 0
    # in an umbra section and 1 outside every penumbra section, except within 1e-6 x scene size
    # of a section's boundary
    sc, sh = scene_shadows(name)
    rng = np.random.default_rng(14)
    others = [k for k in range(len(sc)) if k not in sh.sections]
    if len(sc) > 40:  # the sphere: its floor and a sample of the 180 faces
        others = list(rng.choice(others, 16, replace=False))
    seen = _check_against_rays(sc, sh, sorted(sh.sections) + others, rng,
                               lambda r: 10_000 if r in sh.sections else 1000)
    # the test reaches all three states (point and parallel lights: no penumbra)
    if not sc.area_lights:
        assert seen.pop("penumbra") == 0
    assert min(seen.values()) > 100, seen


def test_the_sphere_as_one_solid_has_the_exact_umbra(scene_shadows):
    # issue 14: with the sphere one convex occluder, a floor point is in an umbra section iff
    # every light vertex is hidden from it (ray casting); with every face its own occluder the
    # umbra is under-stated: points the sphere hides from the whole light fall in no face's umbra
    sc, sh = scene_shadows("sphere_scene")
    assert sh.counters["solids"] == 1
    floor = [k for k, p in enumerate(sc.polygons) if p.name == "room_y0"]
    seen = _check_against_rays(sc, sh, floor, np.random.default_rng(141), lambda r: 10_000,
                               exact_umbra=True)
    assert min(seen.values()) > 100, seen
    faces = _check_against_rays(sc, scene_sections(sc, solids=False), floor,
                                np.random.default_rng(141), lambda r: 10_000, exact_umbra="count")
    assert faces["understated"] > 100, faces


# -- awkward input ------------------------------------------------------------------------------
def _floor_scene(*extra, light_centre=(5.0, 10.0, 3.0), light_size=2.0):
    floor = Polygon([[0, 0, 0], [0, 0, 10], [10, 0, 10], [10, 0, 0]], name="floor")
    c = np.asarray(light_centre, float)
    h = 0.5 * light_size
    light = AreaLight(c + np.array([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]]), emission=1.0,
                      name="light")
    if light.normal[1] > 0:
        light = light.flipped("light")
    return Scene([floor, light, *extra], name="floor_scene")


def test_occluder_touching_the_receiver():
    # a wall standing on the floor: its umbra section reaches the contact line
    wall = Polygon([[4, 0, 5], [6, 0, 5], [6, 4, 5], [4, 4, 5]], name="wall", two_sided=True)
    sc = _floor_scene(wall, light_size=1.0)
    sh = scene_sections(sc)
    (s,) = sh.of(0)
    floor = sc.polygons[0]
    contact = floor.to_2d(np.array([[4.0, 0, 5], [6, 0, 5]]))
    e = contact[1] - contact[0]
    w = s.umbra - contact[0]
    d = np.abs(w[:, 0] * e[1] - w[:, 1] * e[0]) / np.linalg.norm(e)
    assert np.sum(d < 1e-9) == 2  # two umbra vertices on the contact line: the umbra meets it
    assert np.isclose(sorted(np.linalg.norm(s.umbra - contact[0], axis=1))[0], 0.0, atol=1e-9)
    seen = _check_against_rays(sc, sh, [0], np.random.default_rng(0), lambda r: 10_000)
    assert min(seen.values()) > 100


def test_coplanar_occluder_and_receiver_give_no_section():
    rug = Polygon([[3, 0, 3], [3, 0, 6], [6, 0, 6], [6, 0, 3]], name="rug")
    sc = _floor_scene(rug)
    sh = scene_sections(sc)
    assert sh.of(0) == [] and sh.of(2) == []


def test_light_behind_the_receiver_gives_no_section():
    # one-sided, facing down (away from the light): nothing; two-sided: only its upper face
    down = Polygon([[3, 5, 3], [6, 5, 3], [6, 5, 6], [3, 5, 6]], name="down")
    top = Polygon([[3.5, 7, 3.5], [5.5, 7, 3.5], [5.5, 7, 5.5], [3.5, 7, 5.5]], name="top")
    assert down.normal[1] < 0
    sc = _floor_scene(down, top, light_centre=(5.0, 10.0, 5.0))
    sh = scene_sections(sc)
    assert sh.of(2) == []
    sc2 = _floor_scene(Polygon(down.vertices, name="down2", two_sided=True), top,
                       light_centre=(5.0, 10.0, 5.0))
    sides = {s.side for s in scene_sections(sc2).of(2)}
    assert sides == {-1}


def test_light_across_an_occluders_plane_is_split():
    # a vertical occluder whose plane cuts the light in two: penumbra on both sides, no umbra
    blade = Polygon([[5, 5, 3], [5, 5, 7], [5, 8, 7], [5, 8, 3]], name="blade", two_sided=True)
    sc = _floor_scene(blade, light_centre=(5.0, 10.0, 5.0))
    sh = scene_sections(sc)
    secs = sh.of(0)
    assert len(secs) == 2 and all(len(s.umbra) == 0 for s in secs)
    seen = _check_against_rays(sc, sh, [0], np.random.default_rng(1), lambda r: 10_000)
    assert seen["penumbra"] > 100 and seen["umbra"] == 0


def test_shadow_sections_of_one_receiver_and_bad_index():
    sc = _floor_scene(Polygon([[4, 3, 4], [6, 3, 4], [6, 3, 6], [4, 3, 6]], name="sq", two_sided=True))
    (s,) = shadow_sections(sc, 0)
    assert s.receiver == 0 and s.occluder == 2 and s.light == 0 and s.kind == "area"
    assert len(s.umbra) >= 3 and len(s.penumbra) >= 3
    # the polyhedra it was cut from hold its points
    floor = sc.polygons[0]
    assert s.polyhedra.umbra.contains(floor.to_3d(s.umbra.mean(axis=0)))[0]
    assert s.polyhedra.penumbra.contains(floor.to_3d(s.penumbra), tol=1e-9).all()
    with pytest.raises(ShadowError, match="receiver_index"):
        shadow_sections(sc, 7)


def test_index_finds_what_testing_every_pair_finds():
    # the bounding-volume hierarchy only prunes: the same sections as every polyhedron against
    # every receiver, with fewer receiver tests
    sc = scenes.chair_scene()
    a, b = scene_sections(sc), scene_sections(sc, use_index=False)
    key = lambda s: (s.receiver, s.light, s.occluder, s.piece, s.side)  # noqa: E731
    sa = sorted(((key(s), s) for v in a.sections.values() for s in v), key=lambda t: t[0])
    sb = sorted(((key(s), s) for v in b.sections.values() for s in v), key=lambda t: t[0])
    assert [k for k, _ in sa] == [k for k, _ in sb]
    for (_, x), (_, y) in zip(sa, sb):
        assert np.array_equal(x.penumbra, y.penumbra) and np.array_equal(x.umbra, y.umbra)
    assert a.counters["receiver_tests"] < b.counters["receiver_tests"]


def test_section_edges_name_their_faces():
    # a wall standing on the floor: the umbra's edge along the contact line lies on the
    # occluder's own plane (0), the others on side planes; none on the clipping box inside
    wall = Polygon([[4, 0, 5], [6, 0, 5], [6, 4, 5], [4, 4, 5]], name="wall", two_sided=True)
    sc = _floor_scene(wall, light_size=1.0)
    (s,) = scene_sections(sc).of(0)
    assert len(s.umbra_edges) == len(s.umbra) and len(s.penumbra_edges) == len(s.penumbra)
    assert list(s.umbra_edges).count(0) == 1 and list(s.penumbra_edges).count(0) == 1
    assert np.all(s.umbra_edges >= 0) and np.all(s.penumbra_edges >= 0)
    # a floating square: no contact, all side planes
    sq = Polygon([[4, 3, 4], [6, 3, 4], [6, 3, 6], [4, 3, 6]], name="sq", two_sided=True)
    (s,) = scene_sections(_floor_scene(sq)).of(0)
    assert np.all(s.umbra_edges >= 1) and np.all(s.penumbra_edges >= 1)


def test_light_across_the_receivers_plane_is_clipped():
    # a one-sided wall whose plane cuts the light: only the light's part in front of the wall
    # lights it, and the sections are those of that part
    wall = Polygon([[5, 0, 2], [5, 0, 8], [5, 6, 8], [5, 6, 2]], name="wall")
    if wall.normal[0] < 0:
        wall = wall.flipped("wall")
    tile = Polygon([[5.2, 7, 4.5], [6.2, 7, 4.5], [6.2, 7, 5.5], [5.2, 7, 5.5]], name="tile",
                   two_sided=True)
    sc = _floor_scene(wall, tile, light_centre=(5.0, 10.0, 5.0))
    sh = scene_sections(sc)
    secs = [s for s in sh.of(2) if s.occluder == 3]
    assert len(secs) == 1 and sh.counters["rebuilt"] >= 1
    seen = _check_against_rays(sc, sh, [2], np.random.default_rng(2), lambda r: 10_000)
    assert seen["penumbra"] > 100 and seen["bright"] > 100


# -- bad input through the scene driver (issue 41, item 5) ----------------------------------------
def _floor_and_plate():
    floor = Polygon([[0, 0, 0], [10, 0, 0], [10, 0, 10], [0, 0, 10]][::-1], name="floor")
    plate = Polygon([[4, 3, 4], [6, 3, 4], [6, 3, 6], [4, 3, 6]], name="plate", two_sided=True)
    return floor, plate


def test_concave_emitting_polygon_is_refused_naming_it():
    floor, plate = _floor_and_plate()
    # an L-shaped emitter facing down: Scene accepts it (only AreaLight insists on convexity)
    ell = Polygon([[3, 8, 3], [3, 8, 7], [4, 8, 7], [4, 8, 4], [7, 8, 4], [7, 8, 3]][::-1],
                  emission=5.0, name="ell_lamp")
    assert ell.is_emitter and not ell.is_convex and ell.normal[1] < 0
    sc = Scene([floor, plate, ell])
    with pytest.raises(ShadowError, match=r"ell_lamp .*convex"):
        scene_sections(sc)
    with pytest.raises(ShadowError, match="ell_lamp"):
        simplified_discontinuity(sc)
    # the same ring as an array reaching shadow_polyhedron directly is refused too
    with pytest.raises(ShadowError, match="convex"):
        shadow_polyhedron(ell.vertices, plate)
    # its convex pieces as separate lights are fine
    pieces = [Polygon(pc.vertices, emission=5.0, name=f"ell_{i}") for i, pc in enumerate(ell.convex_pieces())]
    sh = scene_sections(Scene([floor, plate] + pieces))
    assert {s.light for s in sh.of(0)} == set(range(len(pieces)))


def test_light_facing_away_from_every_receiver_warns_naming_it():
    floor, plate = _floor_and_plate()
    up = Polygon([[4, 8, 4], [4, 8, 6], [6, 8, 6], [6, 8, 4]], emission=5.0, name="up_lamp")
    assert up.normal[1] > 0  # faces the (absent) ceiling: nothing is in front of it
    with pytest.warns(ShadowWarning, match="up_lamp"):
        sh = scene_sections(Scene([floor, plate, up]))
    assert sh.n_sections == 0
    # below the floor and a one-sided plate facing up (the two-sided plate's underside would be lit)
    plate = Polygon(plate.vertices[::-1], name="plate_up")
    assert plate.normal[1] > 0 and not plate.two_sided
    with pytest.warns(ShadowWarning, match="low_lamp"):
        scene_sections(Scene([floor, plate], [PointLight([5.0, -1.0, 5.0], 1.0, name="low_lamp")]))
    with pytest.warns(ShadowWarning, match="sun"):
        scene_sections(Scene([floor, plate], [ParallelLight([0.0, 1.0, 0.0], 1.0, name="sun")]))
    # a light that faces a receiver but has no occluder: no warning, no sections
    down = Polygon([[4, 8, 4], [4, 8, 6], [6, 8, 6], [6, 8, 4]][::-1], emission=5.0, name="down_lamp")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert scene_sections(Scene([floor, down])).n_sections == 0

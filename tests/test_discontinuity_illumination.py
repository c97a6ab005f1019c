"""``illumination``: each point's state per light against rays cast to the light (issue 41, item 4).

The rays decide exactly in one direction each: a point with some rays blocked and some not is in
penumbra; a point the method calls umbra must have every ray blocked, one it calls bright none.
A point the method calls penumbra must have part of the light hidden (``light_fraction``, the
occluders projected onto the light).  Points within 1e-6 x the scene's size of a discontinuity
line are left out (either state is right there).
"""

import numpy as np
import pytest
import shapely

from naive import visible_fraction
from polygen.discontinuity import (
    BRIGHT,
    PENUMBRA,
    UMBRA,
    UNPROCESSED,
    ShadowError,
    illumination,
    simplified_discontinuity,
)
from polygen.discontinuity.shadow import scene_lights
from polygen.radiosity import scenes
from polygen.radiosity.scene import ParallelLight, PointLight, Scene

N_POINTS = 10_000
BAND = 1e-6


def _lamps_room():
    sc = scenes.two_rectangles_room()
    polys = [p for p in sc.polygons if not p.is_emitter]
    return Scene(polys, [PointLight([5.0, 9.0, 5.0], 10.0, name="lamp"),
                         ParallelLight([0.05, -1.0, 0.1], 1.0, name="sun")], name="lamps_room")


def _points(sd, n, seed):
    """n points on the receivers (by area), fixed seed: (points, polygons, distance to a line)."""
    sc = sd.scene
    rng = np.random.default_rng(seed)
    recv = sorted(sd.complexes)
    area = np.array([sc.polygons[k].area for k in recv])
    counts = rng.multinomial(n, area / area.sum())
    pts, poly, dist = [], [], []
    for k, c in zip(recv, counts):
        if not c:
            continue
        R = sc.polygons[k]
        shp = shapely.Polygon(R.exterior_2d, R.holes_2d)
        lo, hi = R.exterior_2d.min(axis=0), R.exterior_2d.max(axis=0)
        uv = np.zeros((0, 2))
        while len(uv) < c:
            q = lo + rng.random((2 * c, 2)) * (hi - lo)
            uv = np.vstack([uv, q[shapely.contains_xy(shp, q[:, 0], q[:, 1])]])
        uv = uv[:c]
        cx = sd.complexes[k]
        lines = shapely.MultiLineString([cx.xy[list(e)] + cx.origin for e in cx.edges])
        dist.append(shapely.distance(shapely.points(uv), lines))
        pts.append(R.to_3d(uv))
        poly.append(np.full(c, k))
    return np.vstack(pts), np.concatenate(poly), np.concatenate(dist)


@pytest.mark.parametrize("make", [scenes.two_rectangles_room, _lamps_room], ids=["room", "lamps_room"])
def test_illumination_against_rays(make):
    sc = make()
    sd = simplified_discontinuity(sc)
    pts, poly, dist = _points(sd, N_POINTS, seed=0)
    size = float(np.linalg.norm(np.ptp(sc.bounds, axis=0)))
    states, frac = illumination(sd, pts, polygons=poly, fraction=True)
    assert states.shape == (N_POINTS, len(scene_lights(sc)))
    # the same answer without the polygons given, and from the scene
    assert np.array_equal(illumination(sd, pts[:500]), states[:500])
    assert np.array_equal(sd.illumination(pts[:50], polygons=poly[:50]), states[:50])
    keep = dist > BAND * size
    seen = {}
    for j, (kind, light, _) in enumerate(scene_lights(sc)):
        rays = np.full(N_POINTS, np.nan)
        for k in np.unique(poly):
            sel = poly == k
            rays[sel] = visible_fraction(sc, light, pts[sel], normals=np.broadcast_to(
                sc.polygons[k].normal, (sel.sum(), 3)), samples=8, skip=(k,), seed=j)
        st = states[:, j]
        bad = keep & (
            ((rays > 0) & (rays < 1) & (st != PENUMBRA))       # partly seen: penumbra
            | ((st == UMBRA) & ~(rays == 0))                   # umbra: every ray blocked
            | ((st == BRIGHT) & ~(rays == 1))                  # bright: none blocked
            | ((st == UNPROCESSED) != np.isnan(rays)))         # light behind the face
        assert not bad.any(), (kind, np.flatnonzero(bad)[:10], st[bad][:10], rays[bad][:10])
        # penumbra: part of the light hidden, and not all of it where some ray gets through
        pen = keep & (st == PENUMBRA)
        if kind == "area":
            assert np.all(frac[pen, j] < 1.0)
            assert np.all(frac[pen & (rays > 0), j] > 0.0)
        assert np.array_equal(frac[st == BRIGHT, j], np.ones((st == BRIGHT).sum()))
        assert np.array_equal(frac[st == UMBRA, j], np.zeros((st == UMBRA).sum()))
        seen[kind] = np.bincount(st[keep], minlength=4)
    # every state occurs (the test exercises them all)
    for kind, c in seen.items():
        assert c[BRIGHT] > 0 and c[UMBRA] > 0, (kind, c)
        if kind == "area":
            assert c[PENUMBRA] > 0, c


def test_illumination_fraction_matches_rays_in_penumbra():
    """The projected fraction against many rays, on the room's penumbra points."""
    sc = scenes.two_rectangles_room()
    sd = simplified_discontinuity(sc)
    pts, poly, dist = _points(sd, 400, seed=1)
    states, frac = illumination(sd, pts, polygons=poly, fraction=True)
    pen = states[:, 0] == PENUMBRA
    light = scene_lights(sc)[0][1]
    rays = np.concatenate([visible_fraction(sc, light, pts[pen & (poly == k)], normals=np.broadcast_to(
        sc.polygons[k].normal, ((pen & (poly == k)).sum(), 3)), samples=32, skip=(k,))
        for k in np.unique(poly[pen])])
    order = np.concatenate([np.flatnonzero(pen & (poly == k)) for k in np.unique(poly[pen])])
    # a 32 x 32 stratified count of a region bounded by a few straight edges: within 2 / 32
    assert pen.sum() > 20
    assert np.abs(rays - frac[order, 0]).max() <= 2.0 / 32


def test_illumination_bad_input():
    sc = scenes.two_rectangles_room()
    sd = simplified_discontinuity(sc)
    with pytest.raises(ShadowError, match=r"\(N, 3\)"):
        illumination(sd, np.zeros((3, 2)))
    with pytest.raises(ShadowError, match="polygons"):
        illumination(sd, np.zeros((3, 3)), polygons=[0, 1])
    with pytest.raises(ShadowError, match="sides"):
        illumination(sd, np.zeros((1, 3)), polygons=[0], sides=[2])
    # a point on no polygon has no state
    assert np.array_equal(illumination(sd, [[5.0, 5.0, 5.0]]), np.zeros((1, 1), np.int8))

"""Which lights a point sees: the illumination state (3.3.5) of any point on a receiver.

:func:`point_states` (public as :func:`polygen.discontinuity.illumination`, which takes a
scene or its phase) answers the first question a reader asks of the
discontinuity phase -- is this point in umbra, penumbra or light, for each
light? -- without the receiver complex's internals: each point is placed on
its polygon, in the polygon's (u, v) frame, and located among the faces of
that polygon's complex, whose state table
(:meth:`~polygen.discontinuity.complex.ReceiverComplex.face_states`) holds
the answer.  A polygon with no section is bright for every light in front
of it.

With ``fraction=True`` it also returns the visible fraction of each light:
1 in a bright region, 0 in umbra, and in a penumbra region the part of the
light's area that no occluder hides, from the occluders projected from the
point onto the light's plane (exact up to round-off; not weighted by the
cosines: the geometric fraction of the light seen).
"""

from __future__ import annotations

import numpy as np

from polygen.discontinuity import _geometry as geo
from polygen.discontinuity.complex import BRIGHT, PENUMBRA, UMBRA, UNPROCESSED
from polygen.discontinuity.shadow import ShadowError, scene_lights

__all__ = ["point_states", "light_fraction", "visible_part"]


def _locate_polygons(scene, points, tol):
    """Per point the first polygon it lies on (within ``tol`` of its plane and inside), -1 if none."""
    import shapely

    out = np.full(len(points), -1, np.int64)
    for k, p in enumerate(scene.polygons):
        todo = np.flatnonzero(out < 0)
        if not len(todo):
            break
        d = np.abs(points[todo] @ p.normal - float(p.normal @ p.origin))
        near = todo[d <= tol]
        if not len(near):
            continue
        uv = p.to_2d(points[near])
        shp = shapely.Polygon(p.exterior_2d, p.holes_2d).buffer(tol)
        out[near[shapely.contains_xy(shp, uv[:, 0], uv[:, 1])]] = k
    return out


def _faces_of(cx):
    import shapely

    polys = []
    for f in cx.alive_faces:
        outer, holes = cx.face_rings(f)
        polys.append(shapely.Polygon(outer, holes))
    return polys, cx.face_states()


def light_fraction(scene, light_index, points, polygons, *, sides=None):
    """The visible fraction of one area light from points on receivers, by projecting occluders.

    Every other polygon (its convex pieces) is clipped to the slab between
    the point and the light's plane and projected from the point onto that
    plane; the fraction is the part of the light (clipped to the front of
    the receiver's face) that the union of the projections leaves
    uncovered.

    Parameters
    ----------
    scene : Scene
    light_index : int
        In :func:`~polygen.discontinuity.shadow.scene_lights` order; an area light.
    points : (N, 3) float64
    polygons : (N,) int64
        The polygon each point lies on.
    sides : (N,) int, optional
        +1 front face, -1 back face of a two-sided polygon.

    Returns
    -------
    (N,) float64
        In [0, 1]; NaN where no part of the light is in front of the face.
    """
    import shapely

    kind, L, lpoly = scene_lights(scene)[light_index]
    if kind != "area":
        raise ShadowError(f"light {light_index} ({kind}): light_fraction takes an area light")
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    polygons = np.asarray(polygons, dtype=np.int64).reshape(-1)
    sides = np.ones(len(points), np.int64) if sides is None else np.asarray(sides).reshape(-1)
    pieces = _pieces(scene, lpoly)
    out = np.full(len(points), np.nan)
    for i, (x, r, s) in enumerate(zip(points, polygons, sides)):
        lit2, hidden = visible_part(scene, lpoly, x, int(r), s * scene.polygons[r].normal, pieces=pieces)
        if lit2 is None:
            continue
        out[i] = min(max(1.0 - (hidden.area if hidden is not None else 0.0) / lit2.area, 0.0), 1.0)
    return out


def _pieces(scene, lpoly):
    return [(k, pc.vertices) for k, p in enumerate(scene.polygons) if k != lpoly for pc in p.convex_pieces()]


def visible_part(scene, lpoly, x, receiver, normal, *, pieces=None):
    """The part of an emitting polygon in front of a point's face, and the part of it hidden.

    Every other polygon's convex pieces are clipped to the pyramid from ``x``
    over the light (only parts inside it can hide anything; parts outside
    would project to far-away points) and projected from ``x`` onto the
    light's plane.

    Returns
    -------
    lit : shapely Polygon or None
        The light in front of the face, in the light's (u, v) frame; None if
        none of it is (or ``x`` is not in front of the light).
    hidden : shapely geometry or None
        The union of the projections inside ``lit``; None if nothing hides it.
    """
    import shapely

    L = scene.polygons[lpoly]
    nL, dL = L.normal, float(L.normal @ L.origin)
    if pieces is None:
        pieces = _pieces(scene, lpoly)
    d_r = float(normal @ x)
    lit = geo.clip_polygon_3d(L.vertices, -normal, -d_r)  # the light in front of the face
    if len(lit) < 3:
        return None, None
    lit2 = shapely.Polygon(L.to_2d(lit))
    hx = float(nL @ x) - dL
    if lit2.area <= 0.0 or hx <= 0.0:
        return None, None
    c = lit.mean(axis=0)
    planes = []
    for a, b in zip(lit, np.roll(lit, -1, axis=0)):
        nv = np.cross(a - x, b - x)
        if nv @ (c - x) > 0:
            nv = -nv
        planes.append((nv, float(nv @ x)))
    shadows = []
    for k, O in pieces:
        if k == receiver:
            continue
        O = geo.clip_polygon_3d(O, -nL, -dL)                      # in front of the light
        if len(O) >= 3:
            O = geo.clip_polygon_3d(O, nL, dL + hx * (1.0 - 1e-12))  # nearer the light than x
        for nv, dv in planes:
            if len(O) < 3:
                break
            O = geo.clip_polygon_3d(O, nv, dv)
        if len(O) < 3:
            continue
        h = O @ nL - dL
        q = x + (O - x) * (hx / (hx - h))[:, None]
        sh = shapely.Polygon(L.to_2d(q))
        if sh.is_valid and sh.area > 0.0:
            shadows.append(sh)
    if not shadows:
        return lit2, None
    return lit2, shapely.union_all(shadows).intersection(lit2)


def point_states(sd, points, *, polygons=None, sides=None, fraction=False, tol=1e-9):
    """The illumination state of points on receivers, per light (umbra, penumbra or bright).

    Parameters
    ----------
    sd : SimplifiedDiscontinuity
        A scene's discontinuity phase (:func:`~polygen.discontinuity.simplified_discontinuity`;
        :func:`~polygen.discontinuity.simplified.illumination` takes a scene).
    points : (N, 3) float64
        Points on the scene's polygons.
    polygons : (N,) int64, keyword-only, optional
        The polygon each point lies on; default: the first polygon whose
        plane is within ``tol`` times the scene's size and that contains the
        point.
    sides : (N,) int, keyword-only, optional
        +1 (default) the front face, -1 the back face of a two-sided polygon.
    fraction : bool, keyword-only
        Also return the visible fraction of each light.
    tol : float, keyword-only
        Relative tolerance (to the scene's size) of placing points on polygons.

    Returns
    -------
    states : (N, n_lights) int8
        ``UMBRA`` (3), ``PENUMBRA`` (2) or ``BRIGHT`` (1) per point and light
        (:func:`~polygen.discontinuity.shadow.scene_lights` order), by the
        thesis's rule (umbra of some occluder: umbra; in some penumbra:
        penumbra; a concave occluder's umbra the whole polygon's with
        ``simplified_discontinuity(..., concave="exact")``, the default); ``UNPROCESSED`` (0) where the light lies wholly behind
        the point's face or in its plane, and for points on no polygon.
    fractions : (N, n_lights) float64
        With ``fraction=True``: 1 bright, 0 umbra; in penumbra the visible
        part of an area light's area (:func:`light_fraction`); NaN with
        state 0.

    Raises
    ------
    ShadowError
        ``points`` not (N, 3), ``polygons`` or ``sides`` of another length
        or out of range.
    """
    import shapely

    scene = sd.scene
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ShadowError(f"points must be (N, 3), got {pts.shape}")
    lo, hi = scene.bounds
    size = float(np.linalg.norm(hi - lo))
    if polygons is None:
        poly = _locate_polygons(scene, pts, tol * size * 10.0)
    else:
        poly = np.asarray(polygons, dtype=np.int64).reshape(-1)
        if len(poly) != len(pts) or (len(poly) and (poly.min() < -1 or poly.max() >= len(scene.polygons))):
            raise ShadowError(f"polygons must be {len(pts)} indices in [-1, {len(scene.polygons)})")
    side = np.ones(len(pts), np.int64) if sides is None else np.asarray(sides, dtype=np.int64).reshape(-1)
    if len(side) != len(pts) or not np.all(np.abs(side) == 1):
        raise ShadowError(f"sides must be {len(pts)} values of +1 or -1")
    lights = scene_lights(scene)
    nl = len(lights)
    states = np.zeros((len(pts), nl), np.int8)
    for k in np.unique(poly[poly >= 0]):
        sel = np.flatnonzero(poly == k)
        R = scene.polygons[k]
        cx = sd.complexes.get(int(k))
        st = np.full((len(sel), cx.n_lights if cx is not None else nl), BRIGHT, np.int8)
        if cx is not None:
            uv = R.to_2d(pts[sel])
            found = np.zeros(len(sel), bool)
            faces, fst = _faces_of(cx)
            for f, shp in enumerate(faces):
                hit = ~found & shapely.intersects_xy(shp.buffer(tol * R.diameter), uv[:, 0], uv[:, 1])
                st[hit] = fst[f]
                found |= hit
        if st.shape[1] == 2 * nl:  # a two-sided receiver: the back face's columns after the front's
            st = np.where((side[sel] < 0)[:, None], st[:, nl:], st[:, :nl])
        states[sel] = st[:, :nl]
        # a light behind the point's face, or in its plane, lights nothing there
        for j, (kind, light, lpoly) in enumerate(lights):
            if lpoly == k:
                states[sel, j] = UNPROCESSED
                continue
            n_r = side[sel][:, None] * R.normal[None, :]
            d_r = (n_r * pts[sel]).sum(axis=1)
            atol = tol * size
            if kind == "area":
                front = (light.vertices @ n_r.T - d_r[None, :] > atol).any(axis=0)
            elif kind == "point":
                front = n_r @ light.position - d_r > atol
            else:
                front = n_r @ light.direction < -1e-12
            states[sel[~front], j] = UNPROCESSED
    if not fraction:
        return states
    frac = np.where(states == BRIGHT, 1.0, np.where(states == UMBRA, 0.0, np.nan))
    for j, (kind, _, _) in enumerate(lights):
        pen = np.flatnonzero(states[:, j] == PENUMBRA)
        if len(pen) and kind == "area":
            frac[pen, j] = light_fraction(scene, j, pts[pen], poly[pen], sides=side[pen])
    return states, frac

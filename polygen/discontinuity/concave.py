"""Concave occluders, exact: the umbra of a whole planar polygon under an area light.

The thesis splits a concave occluder into convex pieces and builds shadow
polyhedra per piece (3.3.1: "concave ones pre-split").  For point and
parallel lights the union of the pieces' shadows is the occluder's shadow,
exactly.  For an area light it is not: a point that the whole occluder
hides from the whole light, though no single piece does (the light's rays
pass behind one piece and then another), is called penumbra by the
per-piece rule -- on an L-shaped occluder under an area light about a
tenth of the true umbra.

The exact umbra of a planar occluder ``O`` (simple, possibly concave, with
holes) under a convex light ``L`` on one side of its plane: a receiver
point ``x`` beyond the plane is hidden from all of ``L`` iff ``P(x)``, the
light projected through ``x`` onto the occluder's plane (a convex polygon),
lies inside ``O``.  ``P(x)`` is connected, so that holds iff one point of
it is in ``O`` and ``P(x)`` meets no edge of ``O``'s boundary::

    umbra(O) = shadow of O from one light point  minus  union over O's edges e of pen(e, L)

where ``pen(e, L)``, the points from which some ray to the light crosses
``e``, is the convex polyhedron ``conv(e) + cone{p - s}`` (``p`` the edge's
ends, ``s`` the light's vertices: ``p + t (p - s)`` with ``p`` on ``e`` and
``s`` on ``L`` is every such point, and every point of the Minkowski sum is
of that form).  The point-light shadow of ``O`` is, likewise, the union
over ``O``'s convex pieces of ``conv(piece) + cone{q - s0}``.  Each is cut
by the receiver's plane (a convex polygon, clipped to the receiver's box as
the per-piece sections are); shapely does the union and the difference.

The region is in general not convex (an L's umbra is an L).  The receiver
complex's state test assumes convex sections (:mod:`~polygen.discontinuity.states`:
a face is wholly inside or outside a convex ring), so :func:`umbra_pieces`
hands it convex pieces (Hertel-Mehlhorn over a constrained triangulation,
:func:`polygen.mesh2d.pslg.convex_partition`): each internal diagonal of
the partition becomes a discontinuity edge with umbra on both sides, one
line per diagonal, left out of the mesh model's lines with
``state_boundaries_only=True``.  What it costs, measured on the floor of
:func:`~polygen.radiosity.scenes.concave_occluder_scene` (segments split at
vertices, per-piece rule -> exact): the L 20 -> 25 lines (umbra in 2 convex
pieces), the U 32 -> 48 (5 pieces: the light's edges cut the umbra's inner
corners), the frame 48 -> 71 (5 pieces around its hole); with
``state_boundaries_only=True`` 16 -> 18, 24 -> 32 and 32 -> 42, the
difference being the umbra's true boundary.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

from polygen.discontinuity import _geometry as geo

__all__ = ["cone_planes", "planes_section", "umbra_region", "umbra_pieces"]


def cone_planes(points, directions):
    """The half-spaces of the convex polyhedron ``conv(points) + cone(directions)``.

    Parameters
    ----------
    points : (P, 3) float64
    directions : (D, 3) float64
        Pointing away from the points (the light -> occluder rays).

    Returns
    -------
    (F, 4) float64
        Rows ``(n, c)``, unit ``n``, the polyhedron being ``n . x <= c`` for
        all rows.  Every facet is among them (a facet's plane is spanned by
        three of the generators, at least one a point); some rows may be
        supporting planes that are not facets, which changes nothing.
    """
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    D = geo.unit(np.asarray(directions, dtype=np.float64).reshape(-1, 3))
    c0 = P.mean(axis=0)
    Q = P - c0  # about the points' centre: round-off relative to their size
    scale = float(np.ptp(Q, axis=0).max()) or 1.0
    # spanning vectors of each candidate plane, and a point on it
    normals = []
    for a, b in combinations(range(len(Q)), 2):
        e = Q[b] - Q[a]
        for c in range(b + 1, len(Q)):
            normals.append(geo.cross(e, Q[c] - Q[a]) / scale ** 2)
        for d in D:
            normals.append(geo.cross(e, d) / scale)
    for d1, d2 in combinations(D, 2):
        normals.append(geo.cross(d1, d2))
    N = np.asarray(normals).reshape(-1, 3)
    ln = np.linalg.norm(N, axis=1)
    N = N[ln > 1e-10] / ln[ln > 1e-10, None]
    N = np.vstack([N, -N])
    # a half-space holds the polyhedron iff every direction points into it (n . d <= 0)
    ok = np.all(N @ D.T <= 1e-12, axis=1) if len(D) else np.ones(len(N), bool)
    N = N[ok]
    C = (N @ Q.T).max(axis=1)
    return np.concatenate([N, (C + N @ c0)[:, None]], axis=1)


def planes_section(planes, receiver, box, *, tol=1e-9):
    """A convex polyhedron ``planes (F, 4)`` cut by a receiver's plane, in its (u, v) frame.

    As :func:`~polygen.discontinuity.shadow.polyhedron_section`, from the
    planes alone: the 2-D box ``(2, 2)`` clipped by each plane; (0, 2)
    when empty.
    """
    box = np.asarray(box, dtype=np.float64)
    size = float(np.max(box[1] - box[0]))
    poly = np.array([[box[0, 0], box[0, 1]], [box[1, 0], box[0, 1]], [box[1, 0], box[1, 1]],
                     [box[0, 0], box[1, 1]]])
    N = planes[:, :3]
    A = np.stack([N @ receiver.u, N @ receiver.v], axis=1)
    C = planes[:, 3] - N @ receiver.origin
    for a, c in zip(A, C):
        na = float(np.hypot(*a))
        if na <= 1e-12:  # parallel to the receiver: all of its plane or none
            if c < -tol * size:
                return np.zeros((0, 2))
            continue
        poly = geo.clip_polygon_2d(poly, a / na, c / na)
        if len(poly) < 3:
            return np.zeros((0, 2))
    poly = geo.clean_ring(poly, tol * size)
    if len(poly) < 3 or abs(geo.area_2d(poly)) <= (tol * size) ** 2:
        return np.zeros((0, 2))
    return poly if geo.area_2d(poly) > 0 else poly[::-1].copy()


def _half_plane(occluder, n, d, far):
    """The half-space ``n . x <= d`` on the occluder's plane, as a big shapely polygon in its frame
    (None: all of the plane; an empty polygon: none of it)."""
    import shapely

    a = np.array([n @ occluder.u, n @ occluder.v])
    c = d - float(n @ occluder.origin)
    na = float(np.hypot(*a))
    if na <= 1e-12:
        return None if c >= 0.0 else shapely.Polygon()
    sq = np.array([[-far, -far], [far, -far], [far, far], [-far, far]])
    ring = geo.clip_polygon_2d(sq, a / na, c / na)
    return shapely.Polygon(ring) if len(ring) >= 3 else shapely.Polygon()


def umbra_region(light, occluder, receiver, box, *, clip=(), tol=1e-9):
    """The exact umbra of a planar (possibly concave) occluder on a receiver's plane.

    Parameters
    ----------
    light : (m, 3) float64
        A convex area light (or the part of one acting here), on one side
        of the occluder's plane.
    occluder : Polygon
        Planar, simple, possibly concave and with holes.
    receiver : Polygon
        The section is in its (u, v) frame.
    box : (2, 2) float64
        The 2-D box the region is clipped to (as the per-piece sections).
    clip : sequence of ((3,) float64, float), keyword-only
        Half-spaces ``n . x <= d`` the occluder is cut to first (the
        light's front, the receiver's lit side).
    tol : float, keyword-only
        Relative to the box's size.

    Returns
    -------
    shapely geometry
        Polygon or MultiPolygon (possibly empty) in the receiver's frame;
        empty when a light vertex lies in the occluder's plane.

    Raises
    ------
    ShadowError
        An occluder that is not a :class:`~polygen.radiosity.scene.Polygon`
        (a self-intersecting or non-planar ring is refused by that class,
        naming it), a light that is not a convex polygon, or one on both
        sides of the occluder's plane.
    """
    import shapely

    from polygen.mesh2d.pslg import convex_partition

    from polygen.discontinuity._polyhedra import ShadowError, convex_ring_3d
    from polygen.radiosity.scene import Polygon

    if not isinstance(occluder, Polygon):
        raise ShadowError(f"occluder: expected a Polygon (planar, simple: its constructor checks), "
                          f"got {type(occluder).__name__}")
    L = np.asarray(light, dtype=np.float64)
    if L.ndim != 2 or L.shape[1] != 3 or len(L) < 3 or not convex_ring_3d(L):
        raise ShadowError(f"light: expected a convex polygon (m>=3, 3), got shape {L.shape}")
    ext2 = occluder.exterior_2d
    far = 10.0 * float(np.ptp(ext2, axis=0).max())
    side = L @ occluder.normal - float(occluder.normal @ occluder.origin)
    if np.any(np.abs(side) <= tol * far):
        # a light vertex in the occluder's plane is never hidden (as shadow_polyhedron's umbra)
        return shapely.Polygon()
    if side.min() < 0.0 < side.max():
        raise ShadowError(f"light: lies on both sides of the plane of {occluder.name}; split it "
                          "by that plane first")
    G = shapely.Polygon(ext2, occluder.holes_2d)
    for n, d in clip:
        h = _half_plane(occluder, np.asarray(n, dtype=np.float64), float(d), far)
        if h is not None:
            G = G.intersection(h)
    s0 = L.mean(axis=0)
    region = []
    for comp in getattr(G, "geoms", [G]):
        if comp.geom_type != "Polygon" or comp.area <= (tol * far) ** 2:
            continue
        comp = shapely.orient_polygons(comp)
        ext = np.asarray(comp.exterior.coords)[:-1]
        holes = [np.asarray(r.coords)[:-1] for r in comp.interiors]
        # the shadow of the whole component from one light point: its convex pieces' shadows
        lit = []
        for piece in convex_partition(ext, holes):
            Q = occluder.to_3d(piece)
            sec = planes_section(cone_planes(Q, Q - s0), receiver, box, tol=tol)
            if len(sec) >= 3:
                lit.append(shapely.Polygon(sec))
        if not lit:
            continue
        # minus every boundary edge's penumbra: where some ray to the light crosses the edge
        pen = []
        for ring in [ext] + holes:
            R3 = occluder.to_3d(ring)
            for a, b in zip(R3, np.roll(R3, -1, axis=0)):
                E = np.stack([a, b])
                dirs = (E[:, None, :] - L[None, :, :]).reshape(-1, 3)
                sec = planes_section(cone_planes(E, dirs), receiver, box, tol=tol)
                if len(sec) >= 3:
                    pen.append(shapely.Polygon(sec))
        u = shapely.union_all(lit)
        if pen:
            u = u.difference(shapely.union_all(pen))
        region.append(u)
    if not region:
        return shapely.Polygon()
    return shapely.union_all(region)


def umbra_pieces(region, *, min_area=0.0, tol=1e-9):
    """Convex pieces of a region (shapely geometry): counter-clockwise rings (k, 2) for the walk.

    Components with area ``<= min_area`` (round-off slivers of the
    Boolean operations) are left out; collinear and repeated vertices
    (closer than ``tol`` times the region's size) are removed first.
    """
    from polygen.mesh2d.pslg import convex_partition

    if region.is_empty:
        return []
    size = max(float(np.max(np.ptp(np.asarray(region.envelope.exterior.coords), axis=0))), 1e-300)
    region = region.simplify(tol * size, preserve_topology=True)
    out = []
    for comp in getattr(region, "geoms", [region]):
        if comp.geom_type != "Polygon" or comp.area <= min_area:
            continue
        ext = np.asarray(comp.exterior.coords)[:-1]
        holes = [np.asarray(r.coords)[:-1] for r in comp.interiors
                 if abs(_ring_area(np.asarray(r.coords)[:-1])) > min_area]
        for ring in convex_partition(ext, holes):
            ring = geo.clean_ring(np.asarray(ring, dtype=np.float64), tol * size)
            if len(ring) >= 3 and abs(geo.area_2d(ring)) > min_area:
                out.append(ring if geo.area_2d(ring) > 0 else ring[::-1].copy())
    return out


def _ring_area(r):
    x, y = r[:, 0], r[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))

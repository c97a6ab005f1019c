"""Conventional discontinuity meshing (thesis 2.4.3, Defs 2.9-2.10, Figs 2.9, 2.10, 3.1), the baseline.

Every critical surface of a (convex light, convex occluder) pair: for each
light vertex and occluder edge the EV wedge ``O_i I_i I_j O_j`` (the
half-infinite strip swept by the rays from the vertex through the edge,
beyond the edge), for each light edge and occluder vertex the VE wedge
``O_i I_m I_n``.  That is ``2 Ns No`` surfaces per pair (Fig. 3.3(a)),
against the ``Ns + 2 No`` edges of the shadow polyhedra (Fig. 3.3(b)).
Each wedge cut by a receiver's plane and clipped to the receiver is a
discontinuity segment; :func:`~polygen.discontinuity.bsp.bsp_split` then
splits the receiver by them (Fig. 2.10).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from polygen.discontinuity import _geometry as geo
from polygen.discontinuity.bsp import BSPRegions, bsp_split
from polygen.discontinuity.shadow import ShadowError, scene_lights, scene_sections

__all__ = ["critical_surfaces", "CriticalSegments", "conventional_segments", "conventional_bsp",
           "section_segments", "ev_ve_planes", "plane_roles", "unique_planes"]


def critical_surfaces(light_vertices, occluder_vertices, *, reach):
    """The EV and VE wedges of a light and an occluder, truncated at distance ``reach``.

    Parameters
    ----------
    light_vertices : (m, 3) float64
        A convex area light (m >= 3), or one point (1, 3) (then only the
        EV wedges: a point light's shadow-volume sides).
    occluder_vertices : (n, 3) float64
        A convex occluder.
    reach : float, keyword-only
        Length of the wedges' rays past the occluder (beyond the scene).

    Returns
    -------
    list of (kind, wedge (k, 3) float64, light vertex ids, occluder vertex ids)
        ``kind`` is ``"EV"`` (a light vertex, an occluder edge: a
        quadrilateral) or ``"VE"`` (a light edge, an occluder vertex: a
        triangle).  ``m n`` EV then ``m n`` VE wedges (Def. 2.9).
    """
    S = np.asarray(light_vertices, dtype=np.float64).reshape(-1, 3)
    O = np.asarray(occluder_vertices, dtype=np.float64).reshape(-1, 3)
    m, n = len(S), len(O)

    def far(x, s):
        d = x - s
        return x + reach * d / np.linalg.norm(d)

    out = []
    for k in range(m):
        for i in range(n):
            a, b = O[i], O[(i + 1) % n]
            out.append(("EV", np.array([a, b, far(b, S[k]), far(a, S[k])]), (k,), (i, (i + 1) % n)))
    if m >= 2:
        for k in range(m):
            s0, s1 = S[k], S[(k + 1) % m]
            for i in range(n):
                out.append(("VE", np.array([O[i], far(O[i], s0), far(O[i], s1)]),
                            (k, (k + 1) % m), (i,)))
    return out


def ev_ve_planes(light_vertices, occluder_vertices, *, tol=1e-9):
    """Every EV and VE plane of a convex light and a convex occluder, each classified by brute force.

    The check of the gift-wrapping (Fig. 3.7) and of the umbra's planes (Fig. 3.6) from
    scratch: a side of the penumbra polyhedron *separates* light and occluder (each on one
    side of it), a side of the umbra polyhedron *supports* both (both on one side).

    Parameters
    ----------
    light_vertices : (m, 3) float64
    occluder_vertices : (n, 3) float64
    tol : float, keyword-only
        A vertex within ``tol`` of a plane is on it; planes equal within ``tol`` are one.

    Returns
    -------
    planes : (P, 4) float64
        The distinct planes through an edge of one and a vertex of the other (``2 m n``
        before duplicates are merged), unit normals, the sign fixed by :func:`unique_planes`.
    role : (P,) int8
        :func:`plane_roles` of each plane: 1 separating, 0 supporting, -1 neither.
    """
    S = np.asarray(light_vertices, dtype=np.float64).reshape(-1, 3)
    O = np.asarray(occluder_vertices, dtype=np.float64).reshape(-1, 3)
    out = []
    for A, B in ((O, S), (S, O)):  # EV (occluder edge, light vertex), then VE
        for i in range(len(A)):
            for b in B:
                nv = np.cross(A[(i + 1) % len(A)] - A[i], b - A[i])
                nv /= np.linalg.norm(nv)
                out.append(np.r_[nv, nv @ A[i]])
    planes = unique_planes(out, tol=tol)
    return planes, plane_roles(S, O, planes, tol=tol)


def plane_roles(light_vertices, occluder_vertices, planes, *, tol=1e-9):
    """(P,) int8: per plane ``(n, d)``, 1 when light and occluder lie on opposite sides of it
    (on it allowed), 0 when both lie on one side, -1 when either has vertices on both sides."""
    S = np.asarray(light_vertices, dtype=np.float64).reshape(-1, 3)
    O = np.asarray(occluder_vertices, dtype=np.float64).reshape(-1, 3)
    P = np.asarray(planes, dtype=np.float64).reshape(-1, 4)
    ds, do = S @ P[:, :3].T - P[:, 3], O @ P[:, :3].T - P[:, 3]
    s_up, s_dn = (ds > tol).any(axis=0), (ds < -tol).any(axis=0)
    o_up, o_dn = (do > tol).any(axis=0), (do < -tol).any(axis=0)
    sep = (~s_dn & ~o_up) | (~s_up & ~o_dn)
    sup = (~s_up & ~o_up) | (~s_dn & ~o_dn)
    return np.where(sep, 1, np.where(sup, 0, -1)).astype(np.int8)


def unique_planes(planes, *, tol=1e-9):
    """(P, 4) float64: the distinct planes of rows ``(n, d)``, orientation dropped: each row's
    sign makes its largest normal component positive; rows within ``tol`` are one."""
    out = []
    for pl in np.asarray(planes, dtype=np.float64).reshape(-1, 4):
        pl = pl * np.sign(pl[np.argmax(np.abs(pl[:3]))])
        if not any(np.allclose(pl, q, atol=tol) for q in out):
            out.append(pl)
    return np.asarray(out, dtype=np.float64).reshape(-1, 4)


def _cut(wedge, n, d, tol):
    """The segment where a planar convex wedge meets the plane n . x = d (3D), or None."""
    s = wedge @ n - d
    pts = [wedge[i] for i in range(len(wedge)) if abs(s[i]) <= tol]
    k = len(wedge)
    for i in range(k):
        j = (i + 1) % k
        if (s[i] < -tol and s[j] > tol) or (s[i] > tol and s[j] < -tol):
            pts.append(wedge[i] + (wedge[j] - wedge[i]) * (s[i] / (s[i] - s[j])))
    if len(pts) < 2:
        return None
    P = np.array(pts)
    if np.all(np.abs(s) <= tol):
        return None  # the wedge lies in the plane
    axis = P[-1] - P[0] if np.linalg.norm(P[-1] - P[0]) > 0 else P[1] - P[0]
    t = P @ axis
    a, b = P[int(np.argmin(t))], P[int(np.argmax(t))]
    if np.linalg.norm(b - a) <= tol:
        return None
    return np.array([a, b])


@dataclass(frozen=True, eq=False)
class CriticalSegments:
    """The conventional discontinuity segments on one receiver.

    Attributes
    ----------
    receiver : int
    segments : (K, 2, 2) float64
        In the receiver's (u, v) frame, clipped to the receiver polygon (a
        wedge crossing a concave receiver gives several).
    kinds : list of str
        ``"EV"`` or ``"VE"`` per segment.
    sources : list of (light, occluder, piece)
        The pair each segment comes from.
    generators : list of ((int, ...), (int, ...))
        The light vertices and occluder vertices of each segment's
        surface (ids in the light's and the occluder piece's rings).
    surfaces : int
        Critical surfaces generated for the receiver's pairs (``2 Ns No``
        per area-light pair, ``No`` per point or parallel light pair).
    surfaces_reaching : int
        Of those, the ones that meet the receiver.
    pairs : list of (light, occluder, piece)
        The (light, occluder) pairs whose penumbra reaches the receiver.
    """

    receiver: int
    segments: np.ndarray
    kinds: list
    sources: list
    generators: list
    surfaces: int
    surfaces_reaching: int
    pairs: list


def conventional_segments(scene, receiver_index, *, shadows=None):
    """All EV and VE discontinuity segments on one receiver (2.4.3, Figs 2.9(b), 3.1(a)).

    The (light, occluder) pairs are those whose penumbra polyhedron reaches
    the receiver (:func:`~polygen.discontinuity.shadow.scene_sections`);
    for each, every critical surface is cut by the receiver's plane and
    clipped to the wedge (beyond the occluder, between the rays through the
    occluder's edge or vertex) and to the receiver.

    Parameters
    ----------
    scene : Scene
    receiver_index : int
    shadows : SceneShadows, keyword-only, optional
        ``scene_sections(scene, solids=False)``, computed when not given.

    Returns
    -------
    CriticalSegments
    """
    import shapely

    r = int(receiver_index)
    if not 0 <= r < len(scene.polygons):
        raise ShadowError(f"receiver_index {receiver_index} out of range (scene has "
                          f"{len(scene.polygons)} polygons)")
    if shadows is None:
        shadows = scene_sections(scene, solids=False)
    R = scene.polygons[r]
    lights = scene_lights(scene)
    lo, hi = scene.bounds
    diam = float(np.linalg.norm(hi - lo))
    tol = 1e-9 * diam
    shape = shapely.Polygon(R.exterior_2d, R.holes_2d)
    if any(s.solid >= 0 for s in shadows.of(r)):
        raise ShadowError("conventional_segments: the conventional method takes every polygon as "
                          "its own occluder; pass scene_sections(scene, solids=False)")
    # piece -1: a concave occluder's exact umbra, no pair of its own (its pieces give the pairs)
    pairs = sorted({(s.light, s.occluder, s.piece) for s in shadows.of(r) if s.piece >= 0})
    segs, kinds, sources, gens = [], [], [], []
    n_surf = n_reach = 0
    for li, k, j in pairs:
        kind, light, _ = lights[li]
        O = scene.polygons[k].convex_pieces()[j].vertices
        if kind == "area":
            S = light.vertices
            O = geo.clip_polygon_3d(O, -light.normal, -float(light.normal @ light.origin))
        elif kind == "point":
            S = light.position[None, :]
        else:  # a parallel light: a point far up-light
            S = (O.mean(axis=0) - 100.0 * diam * light.direction)[None, :]
        O = geo.clean_ring(O, tol)
        if len(O) < 3:
            continue
        for wk, wedge, sid, oid in critical_surfaces(S, O, reach=4.0 * diam):
            n_surf += 1
            cut = _cut(wedge, R.normal, float(R.normal @ R.origin), tol)
            if cut is None:
                continue
            line = shapely.LineString(R.to_2d(cut))
            part = shape.intersection(line)
            pieces = [g for g in getattr(part, "geoms", [part]) if g.geom_type == "LineString"
                      and g.length > tol]
            if pieces:
                n_reach += 1
            for g in pieces:
                c = np.asarray(g.coords, dtype=np.float64)
                segs.append([c[0], c[-1]])
                kinds.append(wk)
                sources.append((li, k, j))
                gens.append((sid, oid))
    return CriticalSegments(receiver=r, segments=np.asarray(segs, dtype=np.float64).reshape(-1, 2, 2),
                            kinds=kinds, sources=sources, generators=gens, surfaces=n_surf,
                            surfaces_reaching=n_reach, pairs=pairs)


def section_segments(receiver, sections, *, tol=1e-9):
    """The simplified discontinuity segments: umbra and penumbra section edges on the receiver.

    Parameters
    ----------
    receiver : Polygon
    sections : sequence of ShadowSection
        On this receiver.

    Returns
    -------
    segments : (K, 2, 2) float64
        Each section edge clipped to the receiver (edges on the clipping
        box, outside the receiver, vanish).
    kinds : list of str
        ``"umbra"`` or ``"penumbra"``.
    """
    import shapely

    shape = shapely.Polygon(receiver.exterior_2d, receiver.holes_2d)
    t = tol * receiver.diameter
    segs, kinds = [], []
    for s in sections:
        for name, ring in (("umbra", s.umbra), ("penumbra", s.penumbra)):
            if s.kind != "area" and name == "penumbra":
                continue  # the same polygon
            for i in range(len(ring)):
                line = shapely.LineString([ring[i], ring[(i + 1) % len(ring)]])
                part = shape.intersection(line)
                for g in getattr(part, "geoms", [part]):
                    if g.geom_type == "LineString" and g.length > t:
                        c = np.asarray(g.coords, dtype=np.float64)
                        segs.append([c[0], c[-1]])
                        kinds.append(name)
    return np.asarray(segs, dtype=np.float64).reshape(-1, 2, 2), kinds


def conventional_bsp(receiver, segments, *, tol=1e-9) -> BSPRegions:
    """A receiver split by segments with a 2-D BSP tree (Fig. 2.10(b), 3.4(b)).

    The roots are the receiver's convex pieces (``Polygon.convex_pieces``)
    in its (u, v) frame; segments are inserted in the given order.
    """
    roots = []
    for pc in receiver.convex_pieces():
        ring = receiver.to_2d(pc.vertices)
        if geo.area_2d(ring) < 0:
            ring = ring[::-1].copy()
        roots.append(ring)
    return bsp_split(roots, segments, tol=tol)

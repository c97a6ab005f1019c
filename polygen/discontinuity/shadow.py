"""Shadow polyhedra (thesis 3.3.1, Defs 3.2-3.4) and their sections on receivers.

A light and a convex occluder bound two convex, half-infinite polyhedra
(Def. 3.2): the *umbra* polyhedron, inside which the occluder hides the
whole light, and the *penumbra* polyhedron, inside which it hides some of
it.  A point or a parallel light casts one (umbra = penumbra, D0
boundaries; Theorem 3.1).

The interface with the loop code of :mod:`polygen.discontinuity` is the
:class:`ShadowSection`: for one receiver polygon, one light and one convex
occluder, the two polyhedra cut by the receiver's plane, as convex polygons
in the receiver's own (u, v) frame (:meth:`Polygon.to_2d`, the frame of
:func:`~polygen.radiosity.layout.polygon_layout`).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from polygen.discontinuity import _geometry as geo
from polygen.discontinuity._polyhedra import (Polyhedron, ShadowError, ShadowPolyhedra, ShadowWarning,
                                              _cap_and_tol, _empty_pair, _light_arrays)
from polygen.discontinuity.concave import planes_section
from polygen.radiosity.scene import PointLight, Polygon

__all__ = [
    "ShadowError",
    "ShadowWarning",
    "Polyhedron",
    "ShadowPolyhedra",
    "shadow_polyhedron",
    "polyhedron_section",
    "section_edge_planes",
    "ShadowSection",
    "SceneShadows",
    "scene_lights",
    "shadow_sections",
    "scene_sections",
]


def _occluder_array(occluder):
    if isinstance(occluder, Polygon):
        if not occluder.is_convex:
            raise ShadowError(f"{occluder.name}: an occluder must be convex; split it with "
                              "Polygon.convex_pieces() first")
        return occluder.vertices.copy(), occluder.name
    v = np.asarray(occluder, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or len(v) < 3:
        raise ShadowError(f"occluder: expected a convex polygon (n>=3, 3), got shape {v.shape}")
    return v.copy(), "occluder"


def _newell(ring):
    return geo.cross(ring, np.roll(ring, -1, axis=0)).sum(axis=0)


# -- the polyhedra ------------------------------------------------------------------------------
def _polyhedron(planes, generators, cap, tol):
    planes = np.asarray(planes, dtype=np.float64).reshape(-1, 4)
    capped = np.vstack([planes, geo.box_planes(cap[0], cap[1])])
    V, E, on = geo.polytope_vertices(capped, tol)
    if len(V) >= 4:
        c = V - V.mean(axis=0)
        if np.linalg.svd(c, compute_uv=False)[2] <= tol:
            V = np.zeros((0, 3))
    if len(V) < 4:
        V, E, on = np.zeros((0, 3)), np.zeros((0, 2), np.int64), np.zeros((0, len(capped)), bool)
    return Polyhedron(planes=planes, generators=tuple(generators), vertices=V, edges=E,
                      on_cap=on[:, len(planes):].any(axis=1), cap=np.asarray(cap, dtype=np.float64))


def _ray_hinges(S, O, Sf, Of, normal):
    """The two extreme rays (light vertex -> occluder vertex) of a face, as index pairs."""
    pairs = [(a, b) for a in Sf for b in Of]
    d = geo.unit(np.array([O[b] - S[a] for a, b in pairs]))
    t1 = geo.unit(d.sum(axis=0))
    t2 = geo.cross(normal, t1)
    ang = np.arctan2(d @ t2, d @ t1)
    return pairs[int(np.argmin(ang))], pairs[int(np.argmax(ang))]


def _gift_wrap(S, O, cands, F0, n_o, tol, flat):
    """The penumbra's side planes by gift-wrapping over the EV/VE planes (Fig. 3.7).

    ``cands`` are rows (n, d) oriented with the occluder inside; ``flat``
    marks those lying in the occluder's plane.  From F0, across the face's
    hinge ray (one light vertex, one occluder vertex), the next face is the
    candidate through that ray with the largest interior angle to the
    current face; it stops back at F0.  A light touching the occluder's
    plane leaves the band open at rays in that plane (the occluder's plane
    closes it): then it wraps from F0 both ways.
    """
    m, n = len(S), len(O)
    onS = np.abs(cands[:, :3] @ S.T - cands[:, 3:4]) <= tol   # (C, m)
    onO = np.abs(cands[:, :3] @ O.T - cands[:, 3:4]) <= tol   # (C, n)
    in_occ_plane = np.abs((S - O[0]) @ n_o) <= tol

    def coplanar(i, j):
        return np.abs(cands[i] - cands[j]).max() <= tol

    # every candidate's two extreme rays (light vertex -> occluder vertex) at once
    d = O[None, :, :] - S[:, None, :]
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)                      # (m, n, 3)
    mask = onS[:, :, None] & onO[:, None, :]                               # (C, m, n)
    t1 = np.einsum("cmn,mnk->ck", mask.astype(np.float64), d)
    t1 /= np.maximum(np.linalg.norm(t1, axis=-1, keepdims=True), 1e-300)
    t2 = geo.cross(cands[:, :3], t1)
    ang = np.arctan2(np.einsum("mnk,ck->cmn", d, t2), np.einsum("mnk,ck->cmn", d, t1))
    lo_i = np.argmin(np.where(mask, ang, np.inf).reshape(len(cands), -1), axis=1)
    hi_i = np.argmax(np.where(mask, ang, -np.inf).reshape(len(cands), -1), axis=1)
    lo_p = np.stack(np.unravel_index(lo_i, (m, n)), axis=1)
    hi_p = np.stack(np.unravel_index(hi_i, (m, n)), axis=1)

    def hinges(g):
        return (int(lo_p[g, 0]), int(lo_p[g, 1])), (int(hi_p[g, 0]), int(hi_p[g, 1]))

    def wrap(hinge, other):
        cur, faces = F0, []
        for _ in range(2 * m * n + 2):
            a, b = hinge
            if in_occ_plane[a]:
                return faces, False
            h = geo.unit(O[b] - S[a])

            def perp(x, a=a, b=b, h=h):
                x = x - O[b]
                return x - (x @ h) * h

            def off_line(hg):  # how far a hinge ray is from the current one
                return max(geo.norm(perp(S[hg[0]])), geo.norm(perp(O[hg[1]])))

            f = geo.unit(perp(O[other[1]] + (O[other[1]] - S[other[0]])))
            nF = cands[cur, :3]
            best, best_ang, best_next = -1, -np.inf, None
            for g in np.flatnonzero(onS[:, a] & onO[:, b] & ~flat):
                if coplanar(g, cur):
                    continue
                glo, ghi = hinges(g)
                nxt = glo if off_line(glo) > off_line(ghi) else ghi
                gv = perp(O[nxt[1]] + (O[nxt[1]] - S[nxt[0]]))
                if geo.norm(gv) <= tol:
                    continue
                gv = geo.unit(gv)
                ang = np.arctan2(gv @ (-nF), gv @ f)  # interior dihedral angle to the current face
                if ang > best_ang + 1e-12:
                    best, best_ang, best_next = g, ang, nxt
            if best < 0 or not (0.0 < best_ang <= np.pi + 1e-9):
                raise ShadowError("penumbra gift-wrapping found no next face (degenerate light or "
                                  "occluder)")
            if coplanar(best, F0):
                return faces, True
            faces.append(best)
            cur, other, hinge = best, hinge, best_next
        raise ShadowError("penumbra gift-wrapping did not close")

    lo, hi = hinges(F0)
    faces, closed = wrap(hi, lo)
    if not closed:
        back, _ = wrap(lo, hi)
        faces = back[::-1] + faces
    return [F0] + faces


def _hull_faces(S, O, cands, flat, tol):
    """The candidate planes that are facets of the hull of the occluder pushed away from the light.

    For a light touching the occluder's plane, where the band of penumbra
    faces is open (the gift-wrapping's degenerate case): the convex hull
    of the occluder's vertices and of each pushed away from each light
    vertex has the penumbra's side planes as its facets through a light
    vertex and an occluder vertex.
    """
    from scipy.spatial import ConvexHull

    X = np.vstack([O] + [O + 4.0 * (O - s) for s in S])
    eq = ConvexHull(X).equations
    faces = []
    for g in np.flatnonzero(~flat):
        c = cands[g]
        if any(np.abs(e[:3] - c[:3]).max() < 1e-9 and abs(-e[3] - c[3]) <= tol for e in eq):
            if not any(np.abs(cands[f] - c).max() <= tol for f in faces):
                faces.append(int(g))
    return faces


def shadow_polyhedron(light, occluder, *, bounds=None, tol=1e-9):
    """The umbra and penumbra polyhedra of a light and a convex occluder (3.3.1, Figs 3.6, 3.7).

    Parameters
    ----------
    light : AreaLight, PointLight, ParallelLight, (3,) or (m, 3) float64
        An area light must be convex and lie on one side of the
        occluder's plane (the scene driver splits it when it does not).
    occluder : Polygon or (n, 3) float64
        Convex, planar.  A thin two-sided occluder is one polygon and gives
        one pair (the polyhedra do not depend on its orientation).
    bounds : (2, 3) float64, keyword-only, optional
        The far cap: the box the polyhedra's vertices and edges are cut by.
        Default: the light's and occluder's box, 10 times its size.
    tol : float, keyword-only
        Coplanarity tolerance relative to the size of light and occluder.

    Returns
    -------
    ShadowPolyhedra

    Notes
    -----
    Umbra (Fig. 3.6): for each occluder edge, of the planes through the
    edge and one light vertex, the one with the smallest angle to the
    occluder (angle between the occluder's inward direction at the edge
    and the plane's half beyond the edge), plus the occluder's plane.
    Penumbra (Fig. 3.7): all EV planes (light vertex, occluder edge) and
    VE planes (light edge, occluder vertex); the EV plane with the
    largest angle to the occluder is F0; from F_i, among the planes
    sharing its light vertex and occluder vertex on one side, the one with
    the largest angle to F_i; until F0 comes back.  Point and parallel
    lights: the planes through the light (its direction) and each
    occluder edge, umbra = penumbra.  A light in the occluder's plane casts
    no shadow: both polyhedra are empty.

    Raises
    ------
    ShadowError
        A non-convex light or occluder, or an area light on both sides of
        the occluder's plane; the message names it.
    """
    kind, S, dvec, lname = _light_arrays(light)
    O, oname = _occluder_array(occluder)
    bounds, size, atol = _cap_and_tol(S, O, bounds, tol)
    n_o = geo.unit(_newell(O))
    d_o = float(n_o @ O.mean(axis=0))
    if kind == "parallel":
        side = np.array([-(n_o @ dvec)])
        side_tol = 1e-12
    else:
        side = S @ n_o - d_o
        side_tol = tol * size
    if np.all(np.abs(side) <= side_tol):
        return _empty_pair(kind, S, O, bounds)
    if side.min() < -side_tol and side.max() > side_tol:
        raise ShadowError(f"{lname}: lies on both sides of the plane of {oname}; split it by "
                          "that plane first")
    if side.sum() < 0:
        n_o, d_o = -n_o, -d_o
    if _newell(O) @ n_o < 0:  # counter-clockwise seen from the light
        O = O[::-1].copy()
    occ_plane = np.concatenate([n_o, [d_o]])  # beyond the occluder: n_o . x <= d_o
    n = len(O)
    e = geo.unit(np.roll(O, -1, axis=0) - O)   # edge i: O_i -> O_i+1
    w = geo.cross(n_o, e)                       # inward, in the occluder's plane
    allO = tuple(range(n))
    if kind in ("point", "parallel"):
        planes, gens = [occ_plane], [((), allO)]
        for i in range(n):
            through = (S[0] - O[i]) if kind == "point" else -dvec
            nv = geo.cross(e[i], through)
            if nv @ w[i] > 0:
                nv = -nv
            planes.append(geo.plane_through(nv, O[i]))
            gens.append(((0,) if kind == "point" else (), (i, (i + 1) % n)))
        P = _polyhedron(planes, gens, bounds, atol)
        return ShadowPolyhedra(P, P, kind, S, O, candidate_planes=n)
    m = len(S)
    # EV planes: light vertex k, occluder edge i (row i * m + k); theta = angle to the occluder
    # (Fig. 3.6): between the inward direction w_i and the plane's half beyond the edge, b
    r = S[None, :, :] - O[:, None, :]                                  # (n, m, 3)
    rp = r - (r * e[:, None, :]).sum(-1, keepdims=True) * e[:, None, :]
    bvec = -rp / np.linalg.norm(rp, axis=-1, keepdims=True)
    theta = np.arccos(np.clip((bvec * w[:, None, :]).sum(-1), -1.0, 1.0))   # (n, m)
    nv = geo.cross(np.broadcast_to(e[:, None, :], bvec.shape), bvec)
    nv *= np.where((nv * w[:, None, :]).sum(-1) > 0, -1.0, 1.0)[..., None]
    nv /= np.linalg.norm(nv, axis=-1, keepdims=True)
    ev = np.concatenate([nv, (nv * O[:, None, :]).sum(-1)[..., None]], axis=-1).reshape(-1, 4)
    ev_gen = [((k,), (i, (i + 1) % n)) for i in range(n) for k in range(m)]
    umbra_planes, umbra_gen = [occ_plane], [((), allO)]
    for i in range(n):
        k = int(np.argmin(theta[i]))
        umbra_planes.append(ev[i * m + k])
        umbra_gen.append(ev_gen[i * m + k])
    # VE planes: light edge (k, k+1), occluder vertex i (row k * n + i); the occluder inside
    se = np.roll(S, -1, axis=0) - S                                    # (m, 3)
    nv = geo.cross(np.broadcast_to(se[:, None, :], (m, n, 3)), O[None, :, :] - S[:, None, :])
    small = np.linalg.norm(nv, axis=-1) <= 1e-12 * size * size
    if small.any():  # a light edge through O_i: the plane through it along the occluder's normal
        nv[small] = geo.cross(np.broadcast_to(se[:, None, :], (m, n, 3))[small], n_o)
    nv /= np.linalg.norm(nv, axis=-1, keepdims=True)
    dv = (nv * O[None, :, :]).sum(-1)
    flip = (nv @ O.mean(axis=0)) > dv
    nv[flip] *= -1.0
    dv[flip] *= -1.0
    ve = np.concatenate([nv, dv[..., None]], axis=-1).reshape(-1, 4)
    ve_gen = [((k, (k + 1) % m), (i,)) for k in range(m) for i in range(n)]
    cands = np.vstack([ev, ve])
    # planes through a light vertex or edge lying in the occluder's plane are that plane itself:
    # not a side of the penumbra (a light touching the occluder's plane)
    flat = np.abs(cands[:, :3] @ n_o) > 1.0 - 1e-12
    th = np.where(flat[:m * n].reshape(n, m), -np.inf, theta)
    if not np.isfinite(th).any():
        return _empty_pair(kind, S, O, bounds)
    if np.any(np.abs(side) <= side_tol):
        faces = _hull_faces(S, O, cands, flat, atol)
    else:
        F0 = int(np.argmax(th.ravel()))
        faces = _gift_wrap(S, O, cands, F0, n_o, atol, flat)
    pen_planes = [occ_plane] + [cands[f] for f in faces]
    gens = ev_gen + ve_gen
    pen_gen = [((), allO)] + [gens[f] for f in faces]
    if np.any(np.abs(side) <= side_tol):
        # a light vertex in the occluder's plane is never hidden (its rays meet the plane there)
        U = _empty_pair(kind, S, O, bounds).umbra
    else:
        U = _polyhedron(umbra_planes, umbra_gen, bounds, atol)
    Pn = _polyhedron(pen_planes, pen_gen, bounds, atol)
    return ShadowPolyhedra(U, Pn, "area", S, O, candidate_planes=len(cands), wrap_steps=len(faces))


# -- sections on a receiver ---------------------------------------------------------------------
def polyhedron_section(polyhedron, receiver, box, *, tol=1e-9):
    """A polyhedron cut by a receiver's plane: a convex polygon in the receiver's (u, v) frame.

    Parameters
    ----------
    polyhedron : Polyhedron
    receiver : Polygon
    box : (2, 2) float64
        The 2-D box (min, max corner in the receiver's frame) the section
        is clipped to; stands for the unbounded rest of the plane.
    tol : float, keyword-only
        Relative to the box's size.

    Returns
    -------
    (k, 2) float64
        Counter-clockwise; (0, 2) when empty or of zero area.
    """
    if polyhedron.empty:
        return np.zeros((0, 2))
    return planes_section(polyhedron.planes, receiver, box, tol=tol)


def section_edge_planes(polyhedron, receiver, ring, *, tol=1e-9):
    """Which face of the polyhedron each edge of its section ``ring (k, 2)`` lies on.

    Returns
    -------
    (k,) int64
        Row of ``polyhedron.planes`` holding both ends of edge ``i`` (the
        first such), -1 when none (an edge on the clipping box).
    """
    if len(ring) == 0:
        return np.zeros(0, np.int64)
    X = receiver.to_3d(ring)
    P = polyhedron.planes
    size = float(np.max(np.ptp(X, axis=0))) or 1.0
    on = np.abs(X @ P[:, :3].T - P[:, 3]) <= 1e3 * tol * max(size, receiver.diameter)
    both = on & np.roll(on, -1, axis=0)
    return np.where(both.any(axis=1), np.argmax(both, axis=1), -1).astype(np.int64)


@dataclass(frozen=True, eq=False)
class ShadowSection:
    """The umbra and penumbra polyhedra of one (light, occluder) pair cut by one receiver's plane.

    Attributes
    ----------
    light : int
        Index of the light: ``0 .. A-1`` are the scene's area lights in
        ``scene.area_lights`` order, then ``scene.lights`` (point and
        parallel lights) in their order.
    occluder : int
        Index of the occluding polygon in ``scene.polygons``.
    receiver : int
        Index of the receiving polygon in ``scene.polygons``.
    umbra : (k, 2) float64
        Convex polygon, counter-clockwise in the receiver's (u, v) frame;
        ``(0, 2)`` when the umbra polyhedron misses the receiver's plane.
    penumbra : (k, 2) float64
        Convex polygon, counter-clockwise, containing ``umbra``; both are
        clipped to the receiver's 2-D bounding box enlarged by ``margin``
        (so a boundary of either lying on that box is not a shadow edge).
    side : int
        +1 when the light reaches the receiver's front face, -1 its back
        face (a two-sided receiver).
    piece : int
        Which convex piece of the occluder (``Polygon.convex_pieces``); 0
        for a convex occluder.  -1: a convex piece of the exact umbra of a
        concave occluder under an area light (``scene_sections(...,
        concave="exact")``): ``penumbra`` is then empty (the occluder's
        pieces give the penumbra sections, whose own umbrae are then
        empty), ``polyhedra`` None and ``umbra_edges`` all -1.
    kind : str
        ``"area"`` (D1 boundaries), ``"point"`` or ``"parallel"`` (D0:
        umbra and penumbra are the same polygon).
    umbra_edges, penumbra_edges : (k,) int64
        For edge ``i`` (vertex ``i`` to ``i + 1``) of each polygon, the
        polyhedron face it lies on: 0 the occluder's own plane (a contact
        line, where the occluder touches the receiver: D0), ``>= 1`` a side
        plane (``polyhedron.planes`` row; D1 for an area light, D0 for a
        point or parallel light), -1 the clipping box (not a shadow edge).
    polyhedra : ShadowPolyhedra or None
        The polyhedra the sections were cut from (their edges for the
        intersection walk of 3.3.3, their faces for the in/out tests of
        3.3.5); built from the light and occluder parts that act on this
        receiver face.
    solid : int
        -1 for a polygon occluder; for a closed convex solid cast as one
        occluder, its index in :attr:`SceneShadows.solids` (``occluder`` is
        then the solid's first polygon, ``piece`` 0, and the edge indices
        name rows of :func:`~polygen.discontinuity.solids.solid_shadow_polyhedron`'s
        planes: the solid's faces first, then the side planes).
    """

    light: int
    occluder: int
    receiver: int
    umbra: np.ndarray
    penumbra: np.ndarray
    side: int = 1
    piece: int = 0
    kind: str = "area"
    umbra_edges: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    penumbra_edges: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    polyhedra: object = None
    solid: int = -1


def scene_lights(scene):
    """The scene's lights in :attr:`ShadowSection.light` order.

    Returns
    -------
    list of (kind, light, polygon index or -1)
        Area lights (``scene.area_lights``, emitting polygons) first, then
        ``scene.lights``.
    """
    out = [("area", scene.polygons[k], k) for k in scene.area_lights]
    for light in scene.lights:
        out.append(("point" if isinstance(light, PointLight) else "parallel", light, -1))
    return out


@dataclass(frozen=True, eq=False)
class SceneShadows:
    """Every receiver's shadow sections, with the work counters and timings of the driver.

    Attributes
    ----------
    sections : dict of int -> list of ShadowSection
        Per receiver polygon index (receivers without sections absent).
    counters : dict of str -> int
        ``polyhedra`` (shadow-polyhedra pairs built, rebuilt ones
        included), ``rebuilt`` (pairs rebuilt for a light or occluder
        clipped by a receiver's plane), ``receiver_tests``
        (receiver-polyhedron pairs tested against the polyhedron's faces),
        ``candidates`` (pairs the index returned, all pairs without it), ``node_tests`` (index
        nodes visited), ``sections``, ``concave_umbrae`` (the umbra-only sections of
        concave occluders' exact umbrae, ``piece == -1``; among ``sections``).
    timings : dict of str -> float
        Seconds: ``t_sdw`` (shadow polyhedra), ``t_isr`` (index queries,
        receiver tests and sections), as Table 3.2's phases.
    solids : tuple of tuple of int
        The polygon groups cast as one convex solid each
        (:attr:`ShadowSection.solid` indexes it); empty with ``solids=False``.
    """

    sections: dict
    counters: dict
    timings: dict = field(default_factory=dict)
    solids: tuple = ()

    def of(self, receiver):
        """The sections on one receiver (a list, empty when none)."""
        return list(self.sections.get(int(receiver), []))

    @property
    def n_sections(self):
        return sum(len(v) for v in self.sections.values())


def _area(poly3, n):
    return 0.5 * abs(float(_newell(poly3) @ n)) if len(poly3) >= 3 else 0.0


def _side_of(points, n, d, tol):
    s = points @ n - d
    return bool(np.any(s > tol)), bool(np.any(s < -tol))


def _lights_face(kind, light, R, atol):
    """Whether a light lights some face of polygon R: R has a point strictly in front of an area
    light, and the light a point strictly in front of that face (either face if two-sided)."""
    if kind == "area" and not np.any(R.vertices @ light.normal > float(light.normal @ light.origin) + atol):
        return False
    for side in ((1, -1) if R.two_sided else (1,)):
        n_r, d_r = side * R.normal, side * float(R.normal @ R.origin)
        if kind == "area":
            ok = np.any(light.vertices @ n_r > d_r + atol)
        elif kind == "point":
            ok = float(n_r @ light.position) > d_r + atol
        else:
            ok = float(n_r @ light.direction) < -1e-12
        if ok:
            return True
    return False


def scene_sections(scene, *, solids=True, concave="exact", use_index=True, margin=0.05, tol=1e-9):
    """Shadow polyhedra of every (light, occluder) pair and their sections on every receiver.

    The driver of Fig. 3.5: for each light and each convex piece of each
    polygon (each closed convex solid as one occluder, see ``solids``),
    the shadow polyhedra; then the receivers the penumbra
    polyhedron can reach, from a bounding-volume hierarchy over the
    polygons' boxes (:class:`~polygen.discontinuity.scene_index.PolygonIndex`),
    and for each the sections.

    Parameters
    ----------
    scene : Scene
    solids : bool or sequence of sequence of int, keyword-only
        True (default): the polygons that form a closed convex solid
        (:func:`~polygen.discontinuity.solids.convex_solids`, found from the
        geometry) are one occluder, whose shadow polyhedra come from its
        silhouette (:func:`~polygen.discontinuity.solids.solid_shadow_polyhedron`),
        and its own faces receive no section from it.  A sequence declares
        the groups (polygon indices; each checked by
        :func:`~polygen.discontinuity.solids.check_solid`).  False: every
        polygon is its own occluder (3.3.1's rule, the thesis's method).
    concave : {"exact", "pieces"}, keyword-only
        How a concave (or holed) polygon occludes an area light.
        ``"exact"`` (default): its convex pieces give the penumbra sections
        (``piece >= 0``, with empty umbrae), and the umbra of the whole
        polygon (:func:`~polygen.discontinuity.concave.umbra_region`: hidden
        from all of the light by the polygon, though perhaps by no single
        piece) is added as convex umbra-only sections, ``piece == -1``
        (:func:`~polygen.discontinuity.concave.umbra_pieces`; each internal
        diagonal of that partition is one more line, umbra on both sides).
        ``"pieces"``: every convex piece with its own umbra (the thesis's
        3.3.1, "concave ones pre-split"), which calls penumbra the points
        hidden by the polygon but by no one piece (about a tenth of the
        umbra of an L).  Point and parallel lights are the same either way
        (the pieces' shadows' union is exact), and so are scenes without a
        concave occluder.
    use_index : bool, keyword-only
        False tests every polyhedron against every receiver (the thesis's
        O(n^2) T_isr), for comparison.
    margin : float, keyword-only
        The sections are clipped to each receiver's 2-D box enlarged by
        ``margin`` times its diameter.
    tol : float, keyword-only
        Relative to the scene's size: a vertex closer than this to a plane
        is on it.

    Returns
    -------
    SceneShadows

    Notes
    -----
    Which pairs give sections, and how (each rule is a statement about
    the rays from a receiver point to the light, which run in the open
    half-space on the lit side of the receiver and in front of an area
    light):

    * a light lights a receiver's front face (both faces if two-sided)
      when some of it is strictly in front of that face; an area light
      partly behind it is clipped to the front, and a light behind it or
      in its plane gives no section;
    * an occluder acts only on the light's front side (an area light's
      plane clips it) and on the receiver's lit side (clipped there:
      an occluder touching the receiver is kept, one behind it dropped);
    * an area light on both sides of an occluder's plane is split by that
      plane: each part shadows the other side;
    * a section is kept when the penumbra section overlaps the receiver
      with positive area; the umbra section is emptied when it does not;
    * a solid is clipped, like a polygon occluder, to the area light's
      front and to the receiver's lit side; the light is never split by a
      solid's face (its polyhedra are exact for any convex light outside
      it).

    Raises
    ------
    ShadowError
        ``concave`` not "exact" or "pieces"; a declared solid that is not a closed convex solid (naming it), a
        light meeting a solid, a concave emitting polygon (naming it: an area
        light must be convex, as :class:`~polygen.radiosity.AreaLight` requires).

    Warns
    -----
    ShadowWarning
        A light that faces away from every receiver (naming it): no polygon
        has a face it lights, so it casts nothing and lights nothing.
    """
    import shapely

    from polygen.discontinuity import concave as _concave
    from polygen.discontinuity import solids as _solids
    from polygen.discontinuity.scene_index import PolygonIndex

    if concave not in ("exact", "pieces"):
        raise ShadowError(f'concave: expected "exact" or "pieces", got {concave!r}')
    polys = scene.polygons
    lo, hi = scene.bounds
    diam = float(np.linalg.norm(hi - lo))
    atol = tol * diam
    cap = np.stack([lo - 0.01 * diam, hi + 0.01 * diam])
    t_sdw = t_isr = 0.0
    cnt = dict(polyhedra=0, rebuilt=0, candidates=0, receiver_tests=0, node_tests=0, sections=0,
               solids=0, concave_umbrae=0)
    t0 = time.perf_counter()  # finding the solids counts in T_sdw
    if solids is True:
        groups = tuple(_solids.convex_solids(scene, tol=tol))
    elif solids is False or solids is None:
        groups = ()
    else:
        groups = tuple(_solids.check_solid(scene, g, tol=tol) for g in solids)
    solid_of = {k: i for i, g in enumerate(groups) for k in g}
    if len(solid_of) != sum(len(g) for g in groups):
        raise ShadowError("solids: a polygon is declared in two solids")
    cnt["solids"] = len(groups)
    solid_vertices = [np.vstack([polys[k].vertices for k in g]) for g in groups]
    t_sdw += time.perf_counter() - t0
    lights = scene_lights(scene)
    for kind, light, lpoly in lights:
        # an emitting Polygon passes Scene's checks (only AreaLight insists on convexity), and a
        # concave one would reach the gift-wrapping as an array and fail there, or silently
        if kind == "area" and not light.is_convex:
            raise ShadowError(f"{light.name} (polygon {lpoly}): an area light must be a convex "
                              "polygon; split it into convex emitting polygons "
                              "(Polygon.convex_pieces())")
    for li, (kind, light, lpoly) in enumerate(lights):
        if not any(_lights_face(kind, light, p, atol) for k, p in enumerate(polys) if k != lpoly):
            name = getattr(light, "name", None) or f"{kind} light {li}"
            warnings.warn(f"{name}: faces away from every receiver (no polygon has a face it "
                          "lights): it casts no shadow and lights nothing", ShadowWarning,
                          stacklevel=2)
    pieces = [[pc.vertices for pc in p.convex_pieces()] for p in polys]
    # polygons whose umbra under an area light is the whole polygon's, not its pieces'
    exact = {k for k, p in enumerate(polys) if concave == "exact" and len(pieces[k]) > 1}
    rboxes = np.array([[p.vertices.min(axis=0) - atol, p.vertices.max(axis=0) + atol]
                       for p in polys])
    index = PolygonIndex(rboxes, points=[p.vertices for p in polys]) if use_index else None
    shapes = [shapely.Polygon(p.exterior_2d, p.holes_2d) for p in polys]
    boxes2 = [np.stack([p.exterior_2d.min(axis=0) - margin * p.diameter,
                        p.exterior_2d.max(axis=0) + margin * p.diameter]) for p in polys]
    out = {}

    def build(light_arr, O, solid=-1):
        nonlocal t_sdw
        t0 = time.perf_counter()
        if solid >= 0:
            sp = _solids.solid_shadow_polyhedron(light_arr, O, bounds=cap, tol=tol)
        else:
            sp = shadow_polyhedron(light_arr, O, bounds=cap, tol=tol)
        t_sdw += time.perf_counter() - t0
        cnt["polyhedra"] += 1
        return sp

    for li, (kind, light, lpoly) in enumerate(lights):
        # the light as build() takes it, and its front half-space (area lights only)
        if kind == "area":
            L = light.vertices
            nL, dL = light.normal, float(light.normal @ light.origin)
        elif kind == "point":
            L = light.position
        else:
            L = light
        queries = []  # (polygon, piece, light part, occluder, polyhedra, solid, part index)
        for g, V in enumerate(solid_vertices):
            if kind == "area":
                V = _solids.clip_solid(V, -nL, -dL, tol=tol)  # in front of the light's plane
                if not len(V):
                    continue
            sp = build(L, V, g)
            if not sp.penumbra.empty:
                queries.append((groups[g][0], 0, L, V, sp, g, 0))
        for k, p in enumerate(polys):
            if k == lpoly or k in solid_of:
                continue
            for j, O in enumerate(pieces[k]):
                if kind == "area":
                    O = geo.clip_polygon_3d(O, -nL, -dL)  # in front of the light's plane
                    if _area(O, p.normal) <= atol * diam:
                        continue
                    n_o = geo.unit(_newell(O))
                    d_o = float(n_o @ O.mean(axis=0))
                    above, below = _side_of(L, n_o, d_o, atol)
                    if not (above or below):
                        continue  # light in the occluder's plane: no shadow
                    parts = [L]
                    if above and below:
                        parts = [q for q in (geo.clip_polygon_3d(L, n_o, d_o),
                                             geo.clip_polygon_3d(L, -n_o, -d_o))
                                 if _area(q, nL) > atol * diam]
                else:
                    parts = [L]
                for pi, part in enumerate(parts):
                    sp = build(part, O)
                    if not sp.penumbra.empty:
                        queries.append((k, j, part, O, sp, -1, pi))
        t0, sdw0 = time.perf_counter(), t_sdw
        if use_index:
            before, before_items = index.node_tests, index.item_tests
            pairs = index.query([q[4].penumbra.planes for q in queries],
                                np.array([[q[4].penumbra.vertices.min(axis=0),
                                           q[4].penumbra.vertices.max(axis=0)] for q in queries]
                                         ).reshape(-1, 2, 3), tol=atol)
            cnt["node_tests"] += index.node_tests - before
            cnt["receiver_tests"] += index.item_tests - before_items
        else:
            pairs = np.array([(q, r) for q in range(len(queries)) for r in range(len(polys))],
                             dtype=np.int64).reshape(-1, 2)
        cnt["candidates"] += len(pairs)
        whole = {}  # (polygon, light part, receiver, side) -> the light part there: exact umbrae to add
        for q, r in pairs:
            k, j, part, O, sp, g, pi = queries[q]
            if r == k or r == lpoly or (g >= 0 and solid_of.get(int(r)) == g):
                continue  # a convex solid does not shadow its own faces
            R = polys[r]
            if not use_index:  # the index made this test already
                cnt["receiver_tests"] += 1
                pl = sp.penumbra.planes
                if np.any(np.all(R.vertices @ pl[:, :3].T > pl[:, 3] + atol, axis=0)):
                    continue  # a face of the penumbra polyhedron separates the receiver from it
            for side in ((1, -1) if R.two_sided else (1,)):
                n_r = side * R.normal
                d_r = float(n_r @ R.origin)
                # the light part that reaches this face, the occluder part on its lit side
                if kind == "area":
                    lit = geo.clip_polygon_3d(part, -n_r, -d_r - atol)
                    if _area(lit, nL) <= atol * diam:
                        continue
                elif kind == "point":
                    if float(n_r @ L) - d_r <= atol:
                        continue
                elif float(n_r @ light.direction) >= -1e-12:
                    continue
                front, back = _side_of(O, n_r, d_r, atol)
                if not front:
                    continue
                this = sp
                if back:
                    O2 = (_solids.clip_solid(O, -n_r, -d_r, tol=tol) if g >= 0
                          else geo.clip_polygon_3d(O, -n_r, -d_r))
                    if not len(O2):
                        continue
                else:
                    O2 = O
                lit_changed = kind == "area" and (len(lit) != len(part) or
                                                  np.abs(lit - part).max() > atol)
                if back or lit_changed:
                    this = build(lit if kind == "area" else part, O2, g)
                    cnt["rebuilt"] += 1
                    if this.penumbra.empty:
                        continue
                box = boxes2[r]
                pen = polyhedron_section(this.penumbra, R, box, tol=tol)
                if len(pen) == 0:
                    continue
                tiny = 1e-12 * R.area  # touching, not overlapping (round-off of a contact)
                if shapes[r].intersection(shapely.Polygon(pen)).area <= tiny:
                    continue
                umb = polyhedron_section(this.umbra, R, box, tol=tol) if kind == "area" else pen
                if kind == "area" and k in exact:
                    # the whole polygon's umbra comes below; a piece's would only add lines inside it
                    whole.setdefault((int(k), pi, int(r), side), lit)
                    umb = np.zeros((0, 2))
                if len(umb) and shapes[r].intersection(shapely.Polygon(umb)).area <= tiny:
                    umb = np.zeros((0, 2))
                pe = section_edge_planes(this.penumbra, R, pen, tol=tol)
                ue = (section_edge_planes(this.umbra, R, umb, tol=tol) if kind == "area"
                      else pe)
                out.setdefault(int(r), []).append(ShadowSection(
                    light=li, occluder=int(k), receiver=int(r), umbra=umb, penumbra=pen,
                    side=side, piece=int(j), kind=kind, umbra_edges=ue, penumbra_edges=pe,
                    polyhedra=this, solid=int(g)))
                cnt["sections"] += 1
        for (k, pi, r, side), lit in whole.items():
            R = polys[r]
            n_r, d_r = side * R.normal, side * float(R.normal @ R.origin)
            region = _concave.umbra_region(lit, polys[k], R, boxes2[r], tol=tol,
                                           clip=[(-nL, -dL), (-n_r, -d_r)])
            tiny = 1e-12 * R.area
            for umb in _concave.umbra_pieces(region.intersection(shapely.box(*boxes2[r].ravel())),
                                             min_area=tiny, tol=tol):
                if shapes[r].intersection(shapely.Polygon(umb)).area <= tiny:
                    continue
                out.setdefault(int(r), []).append(ShadowSection(
                    light=li, occluder=int(k), receiver=int(r), umbra=umb, penumbra=np.zeros((0, 2)),
                    side=side, piece=-1, kind="area", umbra_edges=np.full(len(umb), -1, np.int64),
                    penumbra_edges=np.zeros(0, np.int64), polyhedra=None, solid=-1))
                cnt["sections"] += 1
                cnt["concave_umbrae"] += 1
        t_isr += time.perf_counter() - t0 - (t_sdw - sdw0)  # rebuilt polyhedra count in t_sdw
    return SceneShadows(sections=out, counters=cnt, timings=dict(t_sdw=t_sdw, t_isr=t_isr),
                        solids=groups)


def shadow_sections(scene, receiver_index, **kwargs):
    """The :class:`ShadowSection` list of one receiver (all lights, all occluders).

    Same keyword arguments as :func:`scene_sections` (which it runs on the
    whole scene: call that once when several receivers are needed).
    """
    if not 0 <= int(receiver_index) < len(scene.polygons):
        raise ShadowError(f"receiver_index {receiver_index} out of range (scene has "
                          f"{len(scene.polygons)} polygons)")
    return scene_sections(scene, **kwargs).of(receiver_index)

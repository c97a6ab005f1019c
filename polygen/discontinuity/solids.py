"""Closed convex solids as one occluder: their shadow polyhedra from the silhouette.

A closed convex polyhedron made of several scene polygons (the 180 faces
of :func:`~polygen.radiosity.scenes.sphere_scene`'s sphere) casts *one*
shadow.  Taking each face as its own convex occluder (3.3.1's rule for a
polygon) gives every face's shadow polyhedra and so thousands of
discontinuity lines where a few dozen bound the real shadow, and it
under-states the umbra: a point hidden by the solid but by no single face
is called penumbra.

For a convex light ``L`` and a convex solid ``O`` not meeting it, with
planes written ``n . x <= d`` (``O`` inside):

* a point ``x`` outside ``O`` sees part of the light hidden iff ``x`` lies
  on ``O``'s side of every plane separating ``L`` from ``O``; over that
  family of planes the bound is piecewise linear in the normal, and the
  planes that matter are the *separating supporting* planes through a light
  vertex and a solid edge (EV) or a light edge and a solid vertex (VE), and
  the solid's faces with the whole light in front of them (the near cap:
  the penumbra polyhedron never reaches in front of the solid).  So the
  **penumbra polyhedron** is the intersection of those half-spaces, convex
  and exact;
* the whole light is hidden iff every light vertex is (the solid's view
  from ``x`` is a convex cone holding the directions of the vertices, so
  of all the light): the **umbra polyhedron** is the intersection over
  the light vertices ``l`` of the point light's shadow volume: the
  supporting planes through ``l`` and a solid edge (its silhouette from
  ``l``) and the faces facing ``l``;
* a point or a parallel light: that shadow volume, umbra = penumbra.

For a polygon occluder these are 3.3.1's polyhedra (its plane is the near
cap); only the solid's silhouette enters the side planes.  A receiver that
is a face of the solid gets no section from it: a convex solid does not
shadow its own faces (those facing away from the light are unlit by their
orientation, not by a shadow).

Which polygons form a solid is found from the geometry
(:func:`convex_solids`: polygons sharing edges into a closed, consistently
oriented surface with every vertex on or behind every face's plane) or
declared (:func:`check_solid`, which names a group that is not one).
"""

from __future__ import annotations

import numpy as np

from polygen.discontinuity import _geometry as geo
from polygen.discontinuity._polyhedra import (Polyhedron, ShadowError, ShadowPolyhedra, _cap_and_tol,
                                              _empty_pair, _light_arrays)

__all__ = ["convex_solids", "check_solid", "solid_shadow_polyhedron", "clip_solid"]


# -- which polygons are one solid ----------------------------------------------------------------
def _merged_vertices(rings, atol):
    """Per ring, an id per vertex; vertices closer than ``atol`` share an id."""
    from scipy.spatial import cKDTree

    X = np.vstack(rings)
    parent = np.arange(len(X))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in cKDTree(X).query_pairs(atol):
        a, b = find(i), find(j)
        if a != b:
            parent[max(a, b)] = min(a, b)
    ids = np.array([find(i) for i in range(len(X))])
    out, s = [], 0
    for r in rings:
        out.append(ids[s:s + len(r)])
        s += len(r)
    return out


def _solid_problem(polys, group, ids, atol):
    """Why the polygons ``group`` are not a closed convex solid (None when they are)."""
    for k in group:
        p = polys[k]
        if p.is_emitter:
            return f"{p.name} is a light"
        if p.two_sided:
            return f"{p.name} is two-sided (a thin occluder, not the face of a solid)"
        if len(p.holes):
            return f"{p.name} has a hole"
    if len(group) < 4:
        return f"{len(group)} polygons cannot close a solid"
    uses = {}
    for k in group:
        r = ids[k]
        for a, b in zip(r, np.roll(r, -1)):
            if a == b:
                continue
            uses.setdefault((min(a, b), max(a, b)), []).append((k, a < b))
    for (a, b), u in uses.items():
        if len(u) != 2:
            names = ", ".join(polys[k].name for k, _ in u)
            return f"not closed: an edge is used by {len(u)} polygon(s) ({names}), not 2"
        if u[0][1] == u[1][1]:
            return (f"not consistently oriented: {polys[u[0][0]].name} and {polys[u[1][0]].name} "
                    "run their shared edge the same way")
    V = np.vstack([polys[k].vertices for k in group])
    for k in group:
        p = polys[k]
        s = V @ p.normal - float(p.normal @ p.origin)
        if s.max() > atol:
            return (f"not convex: a vertex lies {s.max():.3g} in front of {p.name}'s plane "
                    "(or its faces point inward)")
    c = V - V.mean(axis=0)
    if np.linalg.svd(c, compute_uv=False)[2] <= atol:
        return "flat (no volume)"
    return None


def _tol(scene, tol):
    lo, hi = scene.bounds
    return tol * float(np.linalg.norm(hi - lo))


def convex_solids(scene, *, tol=1e-9):
    """The groups of the scene's polygons that form closed convex solids.

    Polygons are joined when they share an edge (vertices closer than
    ``tol`` times the scene's size are one); a connected group is a solid
    when every edge of it is used by exactly two of its polygons, in
    opposite directions (a closed surface, consistently oriented), and
    every vertex lies on or behind every face's plane (convex, faces
    pointing out).  Lights, two-sided polygons and polygons with holes
    are never faces of a solid.  Faces must meet edge to edge: a face
    whose edge is split by a neighbour's vertex (a T-junction), or two
    solids sharing an edge, leave their polygons to the per-polygon rule.

    Parameters
    ----------
    scene : Scene
    tol : float, keyword-only
        Relative to the scene's size.

    Returns
    -------
    list of tuple of int
        Polygon indices per solid, ascending; the solids ordered by their
        first polygon.
    """
    polys = scene.polygons
    atol = _tol(scene, tol)
    cand = [k for k, p in enumerate(polys)
            if not p.is_emitter and not p.two_sided and not len(p.holes)]
    if len(cand) < 4:
        return []
    ids = dict(zip(cand, _merged_vertices([polys[k].vertices for k in cand], atol)))
    # connected components over shared edges
    parent = {k: k for k in cand}

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    first = {}
    for k in cand:
        r = ids[k]
        for a, b in zip(r, np.roll(r, -1)):
            e = (min(a, b), max(a, b))
            if e in first:
                x, y = find(first[e]), find(k)
                if x != y:
                    parent[max(x, y)] = min(x, y)
            else:
                first[e] = k
    groups = {}
    for k in cand:
        groups.setdefault(find(k), []).append(k)
    return [tuple(g) for _, g in sorted(groups.items())
            if len(g) >= 4 and _solid_problem(polys, g, ids, atol) is None]


def check_solid(scene, group, *, tol=1e-9, name=None):
    """A declared solid: its polygon indices, checked to be a closed convex solid.

    Parameters
    ----------
    scene : Scene
    group : sequence of int
        Indices into ``scene.polygons``.
    tol : float, keyword-only
        Relative to the scene's size.
    name : str, keyword-only, optional
        How the error message names the group (default: its first
        polygon's name).

    Returns
    -------
    tuple of int
        The indices, ascending, without repeats.

    Raises
    ------
    ShadowError
        An index out of range, or a group that is not closed, not
        consistently oriented, not convex or flat; the message names the
        group and says which.
    """
    polys = scene.polygons
    try:
        g = sorted({int(k) for k in group})
    except (TypeError, ValueError):
        raise ShadowError(f"solid {name or group!r}: expected polygon indices") from None
    label = name or (f"solid of {polys[g[0]].name} ({len(g)} polygons)" if g and
                     0 <= g[0] < len(polys) else f"solid {list(g)}")
    bad = [k for k in g if not 0 <= k < len(polys)]
    if bad or not g:
        raise ShadowError(f"{label}: polygon indices {bad or '[]'} outside 0..{len(polys) - 1}")
    atol = _tol(scene, tol)
    ids = dict(zip(g, _merged_vertices([polys[k].vertices for k in g], atol)))
    why = _solid_problem(polys, g, ids, atol)
    if why is not None:
        raise ShadowError(f"{label}: not a closed convex solid: {why}")
    return tuple(g)


# -- the solid as a convex hull ------------------------------------------------------------------
def _hull(V, atol):
    """Face planes (F, 4) (outward, deduplicated), edges (E, 2) and the vertex set of conv(V)."""
    from scipy.spatial import ConvexHull

    h = ConvexHull(V)
    P = np.c_[h.equations[:, :3], -h.equations[:, 3]]
    # coplanar triangles of one face give one plane
    same = ((np.abs(P[:, None, :3] - P[None, :, :3]).max(-1) <= 1e-9)
            & (np.abs(P[:, None, 3] - P[None, :, 3]) <= atol))
    P = P[~np.triu(same, 1).any(axis=0)]
    tri = h.simplices
    e = np.sort(np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    e = np.unique(e, axis=0)
    used = np.unique(e)
    remap = np.full(len(V), -1)
    remap[used] = np.arange(len(used))
    return P, remap[e], V[used]


def clip_solid(V, n, d, *, tol=1e-9):
    """The convex solid conv(V) cut to the half-space ``n @ x <= d``: its vertices (k, 3).

    Parameters
    ----------
    V : (k, 3) float64
    n : (3,) float64
    d : float
    tol : float, keyword-only
        Relative to the solid's size.

    Returns
    -------
    (k', 3) float64
        The cut solid's vertices (with points on its faces), ``V`` itself
        when the whole solid is kept, (0, 3) when nothing of volume is.
    """
    V = np.asarray(V, dtype=np.float64)
    size = float(np.max(np.ptp(V, axis=0))) or 1.0
    s = V @ n - d
    if np.all(s <= tol * size):
        return V
    if np.all(s >= -tol * size):
        return np.zeros((0, 3))
    _, E, W = _hull(V, tol * size)
    s = W @ n - d
    a, b = E[:, 0], E[:, 1]
    cross = (s[a] < 0) != (s[b] < 0)
    t = s[a[cross]] / (s[a[cross]] - s[b[cross]])
    X = np.vstack([W[s <= 0], W[a[cross]] + t[:, None] * (W[b[cross]] - W[a[cross]])])
    if len(X) < 4 or np.linalg.svd(X - X.mean(axis=0), compute_uv=False)[2] <= tol * size:
        return np.zeros((0, 3))
    return X


# -- the polyhedra --------------------------------------------------------------------------------
def _dedupe(planes, gens, atol):
    P = np.asarray(planes, dtype=np.float64).reshape(-1, 4)
    if not len(P):
        return P, []
    same = ((np.abs(P[:, None, :3] - P[None, :, :3]).max(-1) <= 1e-9)
            & (np.abs(P[:, None, 3] - P[None, :, 3]) <= atol))
    keep = np.flatnonzero(~np.triu(same, 1).any(axis=0))
    return P[keep], [gens[k] for k in keep]


def _hs_polyhedron(planes, generators, cap, inside, atol):
    """A :class:`Polyhedron` from its planes by half-space intersection (qhull).

    ``polytope_vertices`` solves every triple of planes, too many for the
    near cap of a 180-face solid; ``inside`` is a point strictly inside.
    """
    from scipy.spatial import HalfspaceIntersection, cKDTree

    capped = np.vstack([planes, geo.box_planes(cap[0], cap[1])])
    hs = HalfspaceIntersection(np.c_[capped[:, :3], -capped[:, 3]], inside)
    X = hs.intersections
    scale = float(np.max(cap[1] - cap[0]))
    vtol = max(atol, 1e-9 * scale)
    keep = np.ones(len(X), bool)
    for i, j in sorted(cKDTree(X).query_pairs(vtol)):
        if keep[i]:
            keep[j] = False
    V = X[keep]
    on = np.abs(V @ capped[:, :3].T - capped[:, 3]) <= 10 * vtol
    shared = on.astype(np.int64) @ on.T.astype(np.int64)
    i, j = np.nonzero(np.triu(shared >= 2, k=1))
    return Polyhedron(planes=planes, generators=tuple(generators), vertices=V,
                      edges=np.stack([i, j], axis=1).astype(np.int64),
                      on_cap=on[:, len(planes):].any(axis=1), cap=np.asarray(cap, dtype=np.float64))


def _supporting(n, p, V, c, atol):
    """Planes (k, 4) of normals ``n`` (k, 3) through points ``p`` (k, 3), oriented with ``c``
    inside, and whether each supports ``conv(V)`` (every vertex inside within ``atol``)."""
    L = np.linalg.norm(n, axis=1)
    ok = L > 1e-12 * max(1.0, float(np.max(L, initial=0.0)))
    n = n / np.where(ok, L, 1.0)[:, None]
    d = np.einsum("ij,ij->i", n, p)
    flip = n @ c > d
    n[flip] *= -1.0
    d[flip] *= -1.0
    sup = ok & np.all(V @ n.T <= d + atol, axis=0)
    return np.c_[n, d], sup


def _volume_from(S, dvec, F, E, W, c, atol, lid=(0,)):
    """The shadow volume of a point light ``S`` (3,) (or a parallel light ``dvec``) and conv(W):
    planes through the light and a silhouette edge, and the faces facing the light."""
    a, b = W[E[:, 0]], W[E[:, 1]]
    through = (S - a) if dvec is None else np.broadcast_to(-dvec, a.shape)
    side, sup = _supporting(geo.cross(b - a, through), a, W, c, atol)
    side = side[sup]
    gens = [(lid, tuple(int(i) for i in e)) for e in E[sup]]
    faces = F[(F[:, :3] @ S - F[:, 3] > atol) if dvec is None else (F[:, :3] @ -dvec > 1e-12)]
    return (np.vstack([faces, side]), [((), ("face",))] * len(faces) + gens)


def solid_shadow_polyhedron(light, solid, *, bounds=None, tol=1e-9):
    """The umbra and penumbra polyhedra of a light and a closed convex solid.

    Parameters
    ----------
    light : AreaLight, PointLight, ParallelLight, (3,) or (m, 3) float64
        A convex area light, or a point, or a parallel light.
    solid : (k, 3) float64 or sequence of Polygon
        The solid's vertices (it is their convex hull), or its faces.
    bounds : (2, 3) float64, keyword-only, optional
        The far cap, as for :func:`~polygen.discontinuity.shadow_polyhedron`.
    tol : float, keyword-only
        Relative to the size of light and solid.

    Returns
    -------
    ShadowPolyhedra
        ``occluder_vertices`` the hull's vertices; the polyhedra's planes
        are the near cap (the solid's faces, generators ``((), ("face",))``)
        then the side planes (generators: light vertices, solid hull edge
        or vertex); ``candidate_planes`` the EV and VE planes tried.

    Raises
    ------
    ShadowError
        A non-convex light, a flat solid, or a light meeting the solid.

    Notes
    -----
    See the module's docstring for why these planes bound the exact
    umbra and penumbra.  The light must not meet the solid: clip the solid
    to the light's front side first (:func:`clip_solid`), as
    :func:`~polygen.discontinuity.scene_sections` does.
    """
    kind, S, dvec, lname = _light_arrays(light)
    if len(solid) and hasattr(solid[0], "vertices"):
        V = np.vstack([p.vertices for p in solid])
    else:
        V = np.asarray(solid, dtype=np.float64).reshape(-1, 3)
    bounds, size, atol = _cap_and_tol(S, V, bounds, tol)
    if len(V) < 4 or np.linalg.svd(V - V.mean(axis=0), compute_uv=False)[2] <= atol:
        raise ShadowError("solid: its vertices are flat (no volume); a flat occluder is a polygon")
    F, E, W = _hull(V, atol)
    c = W.mean(axis=0)
    if kind != "parallel":
        # the light must lie outside the solid: some face plane with all of it in front
        front = S @ F[:, :3].T - F[:, 3] > atol    # (m, F)
        if not np.all(front.any(axis=1)):
            raise ShadowError(f"{lname}: meets the solid (clip the solid to the light's front "
                              "side first)")
    if kind in ("point", "parallel"):
        planes, gens = _volume_from(S[0] if kind == "point" else None, dvec, F, E, W, c, atol,
                                    lid=(0,) if kind == "point" else ())
        planes, gens = _dedupe(planes, gens, atol)
        P = _hs_polyhedron(planes, gens, bounds, c, atol)
        return ShadowPolyhedra(P, P, kind, S, W, candidate_planes=len(E))
    m = len(S)
    # umbra: the shadow volumes of the light's vertices, intersected
    up, ug = [], []
    for j in range(m):
        p, g = _volume_from(S[j], None, F, E, W, c, atol, lid=(j,))
        up.append(p)
        ug += g
    # penumbra: EV (light vertex, solid edge) and VE (light edge, solid vertex) planes that
    # support the solid and have the whole light on their other side, and the near cap
    a, b = W[E[:, 0]], W[E[:, 1]]
    ev_n = geo.cross(np.broadcast_to((b - a)[None], (m, len(E), 3)), S[:, None, :] - a[None])
    ev, ev_sup = _supporting(ev_n.reshape(-1, 3), np.broadcast_to(a[None], ev_n.shape).reshape(-1, 3),
                             W, c, atol)
    se = np.roll(S, -1, axis=0) - S
    ve_n = geo.cross(np.broadcast_to(se[:, None, :], (m, len(W), 3)), W[None] - S[:, None, :])
    ve, ve_sup = _supporting(ve_n.reshape(-1, 3),
                             np.broadcast_to(W[None], ve_n.shape).reshape(-1, 3), W, c, atol)
    cands = np.vstack([ev, ve])
    sup = np.r_[ev_sup, ve_sup]
    sep = sup & np.all(S @ cands[:, :3].T >= cands[:, 3] - atol, axis=0)
    gens = ([((j,), tuple(int(x) for x in E[i])) for j in range(m) for i in range(len(E))]
            + [((j, (j + 1) % m), (i,)) for j in range(m) for i in range(len(W))])
    cap = F[np.all(S @ F[:, :3].T - F[:, 3] >= -atol, axis=0)]
    pp, pg = _dedupe(np.vstack([cap, cands[sep]]),
                     [((), ("face",))] * len(cap) + [gens[k] for k in np.flatnonzero(sep)], atol)
    uu, ugg = _dedupe(np.vstack(up), ug, atol)
    U = _hs_polyhedron(uu, ugg, bounds, c, atol)
    Pn = _hs_polyhedron(pp, pg, bounds, c, atol)
    if Pn.empty:
        return _empty_pair(kind, S, W, bounds)
    return ShadowPolyhedra(U, Pn, "area", S, W, candidate_planes=len(cands),
                           wrap_steps=int(sep.sum()))

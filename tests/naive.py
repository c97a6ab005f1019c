"""Slow, obviously correct reference implementations the tests compare polygen against (as stumpy's).

Brute force over all nodes, cells or pairs with numpy and scipy; for small inputs only.
"""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


def brute_extrema(cells, s):
    """Defs 6.3/6.4 (ties allowed), one representative (lowest id candidate) per flat group."""
    n = s.shape[0]
    k = cells.shape[1]
    rows = np.repeat(cells, k, axis=1).ravel()
    cols = np.tile(cells, (1, k)).ravel()
    star_max = np.full(n, -np.inf)
    star_min = np.full(n, np.inf)
    np.maximum.at(star_max, rows, s[cols])
    np.minimum.at(star_min, rows, s[cols])
    eq = s[rows] == s[cols]
    g = coo_matrix((np.ones(eq.sum()), (rows[eq], cols[eq])), shape=(n, n))
    _, group = connected_components(g, directed=False)
    out = {}
    for kind, cand in (("max", s >= star_max), ("min", s <= star_min)):
        reps = {}
        for v in np.flatnonzero(cand):
            reps.setdefault(group[v], v)
        out[kind] = np.array(sorted(reps.values()), np.int64)
    return out


def cell_graph_components(vol, alive):
    """Face-connected components of the cells where ``alive``; -1 elsewhere."""
    nb = vol.face_neighbors
    c, f = np.nonzero(nb >= 0)
    keep = alive[c] & alive[nb[c, f]]
    m = vol.n_cells
    _, lab = connected_components(coo_matrix((np.ones(keep.sum()), (c[keep], nb[c, f][keep])), shape=(m, m)),
                                  directed=False)
    return np.where(alive, lab, -1)


def intersected_components(vol, s, value):
    """Cells the surface ``S = value`` crosses (``S_min < C <= S_max``) and their face-connected parts (-1 elsewhere)."""
    cmin = s[vol.cells].min(axis=1)
    cmax = s[vol.cells].max(axis=1)
    hit = (cmin < value) & (value <= cmax)
    return hit, cell_graph_components(vol, hit)


def one_seed_per_component(vol, iso):
    """One intersected cell in each face-connected group of intersected cells (brute force)."""
    cells = np.unique(iso.triangle_cells)
    inside = np.zeros(vol.n_cells, bool)
    inside[cells] = True
    nb = vol.face_neighbors
    c, f = np.nonzero((nb >= 0) & inside[:, None])
    keep = inside[nb[c, f]]
    g = coo_matrix((np.ones(keep.sum()), (c[keep], nb[c, f][keep])), shape=(vol.n_cells,) * 2)
    _, labels = connected_components(g, directed=False)
    _, first = np.unique(labels[cells], return_index=True)
    return cells[first]


def light_samples(light, samples, *, seed=0):
    """Stratified points on a light: ``samples x samples`` jittered cells of a convex area light
    (those inside it), the position of a point light; ``None`` for a parallel light."""
    from polygen.radiosity.scene import ParallelLight, PointLight

    if isinstance(light, PointLight):
        return light.position[None, :]
    if isinstance(light, ParallelLight):
        return None
    import shapely

    rng = np.random.default_rng(seed)
    lo, hi = light.exterior_2d.min(axis=0), light.exterior_2d.max(axis=0)
    i, j = np.meshgrid(np.arange(samples), np.arange(samples), indexing="ij")
    uv = (np.stack([i.ravel(), j.ravel()], axis=1) + rng.random((samples * samples, 2))) / samples
    uv = lo + uv * (hi - lo)
    uv = uv[shapely.contains_xy(shapely.Polygon(light.exterior_2d), uv[:, 0], uv[:, 1])]
    return light.to_3d(uv)


def visible_fraction(scene, light, points, *, normals, samples=4, skip=(), seed=0, chunk=4096):
    """Fraction of a light seen from each point, by casting rays against every scene polygon.

    Parameters
    ----------
    scene : Scene
    light : AreaLight, PointLight or ParallelLight
    points : (N, 3) float64
    normals : (N, 3) float64
        The receiving face's normal at each point: light samples not
        strictly in front of it are left out of the fraction (the light
        part a point can see at all).
    samples : int
        ``samples x samples`` stratified light samples.
    skip : sequence of int
        Polygons not tested (the receiver the points lie on).

    Returns
    -------
    (N,) float64
        1 bright, 0 umbra; NaN where no light sample is in front of the point.
    """
    import shapely

    from polygen.radiosity.scene import ParallelLight

    points = np.asarray(points, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    S = light_samples(light, samples, seed=seed)
    far = 10.0 * float(np.linalg.norm(np.ptp(scene.bounds, axis=0)))
    skip = set(int(k) for k in skip)
    for k, p in enumerate(scene.polygons):
        if p is light:
            skip.add(k)
    occ = [(p, shapely.Polygon(p.exterior_2d, p.holes_2d)) for k, p in enumerate(scene.polygons)
           if k not in skip]
    out = np.full(len(points), np.nan)
    for s0 in range(0, len(points), chunk):
        P = points[s0:s0 + chunk]
        Nn = normals[s0:s0 + chunk]
        if isinstance(light, ParallelLight):
            Q = (P - far * light.direction)[:, None, :]  # (n, 1, 3): one ray per point
        else:
            Q = S[None, :, :]                            # (1, s, 3)
        front = np.einsum("nsc,nc->ns", Q - P[:, None, :], Nn) > 0.0
        blocked = np.zeros(front.shape, bool)
        for p, shp in occ:
            d = float(p.normal @ p.origin)
            da = (P @ p.normal - d)[:, None]             # (n, 1)
            db = Q @ p.normal - d                        # (1, s) or (n, 1)
            cross = ((da > 0) & (db < 0)) | ((da < 0) & (db > 0))
            cross &= ~blocked & front
            if not cross.any():
                continue
            i, j = np.nonzero(cross)
            qa = np.broadcast_to(da, cross.shape)[i, j]
            qb = np.broadcast_to(db, cross.shape)[i, j]
            A = P[i]
            B = Q[np.minimum(i, len(Q) - 1), np.minimum(j, Q.shape[1] - 1)]
            X = A + (qa / (qa - qb))[:, None] * (B - A)
            lo, hi = p.vertices.min(axis=0) - 1e-9, p.vertices.max(axis=0) + 1e-9
            box = np.all((X >= lo) & (X <= hi), axis=1)  # only these can be inside the polygon
            uv = p.to_2d(X[box])
            hit = np.zeros(len(X), bool)
            hit[box] = shapely.contains_xy(shp, uv[:, 0], uv[:, 1])
            blocked[i[hit], j[hit]] = True
        nf = front.sum(axis=1)
        vis = (front & ~blocked).sum(axis=1)
        out[s0:s0 + chunk] = np.where(nf > 0, vis / np.maximum(nf, 1), np.nan)
    return out


def edge_cell_lists(cells, cell_edges, n_edges, os_, ost, width):
    """The edge-centred records and cell lists by numpy: ``(ec, starts, rec)``.

    Each edge's id, then its cells in increasing order as ``cell << 5 | last << 4 | local``
    (:mod:`polygen.volume._edge_centred_kernels`); ``rec`` rows: stamp and state 0, nodes, slots -1,
    where each local edge's list starts, padding 0.
    """
    m, ne = cell_edges.shape
    key = cell_edges.ravel().astype(np.int64)
    order = np.argsort(key, kind="stable")
    offsets = np.r_[0, np.cumsum(np.bincount(key, minlength=n_edges))]
    starts = offsets[:-1] + np.arange(n_edges) + 1
    ec = np.empty(offsets[-1] + n_edges, np.int64)
    ec[starts - 1] = np.arange(n_edges)
    sk = key[order]
    last = np.r_[sk[1:] != sk[:-1], True]
    ec[np.arange(order.size) + sk + 1] = (order // ne) << 5 | last.astype(np.int64) << 4 | order % ne
    rec = np.zeros((m, width), np.int64)
    rec[:, 2:2 + cells.shape[1]] = cells
    rec[:, os_:ost] = -1
    rec[:, ost:ost + ne] = starts[cell_edges]
    return ec, starts, rec


def occluder_states(light, occluder, points):
    """The exact illumination state of points against one planar occluder, by geometry alone.

    A point light or a parallel light: the ray from the point to the light
    crosses the occluder (UMBRA 3) or not (BRIGHT 1).  A convex area light
    on one side of the occluder's plane: the light projected through the
    point onto that plane, ``P(x)``, lies inside the occluder (UMBRA 3:
    every ray hidden), shares no interior point with it (BRIGHT 1), else
    PENUMBRA 2 -- the definitions of 3.3, decided exactly (shapely's
    containment of one polygon in another), not by sampling.

    Parameters
    ----------
    light : AreaLight, PointLight or ParallelLight
    occluder : Polygon
        Planar, possibly concave, with holes.
    points : (N, 3) float64
        In front of the light (not checked).

    Returns
    -------
    (N,) int8
    """
    import shapely

    from polygen.radiosity.scene import ParallelLight, PointLight

    X = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n, d = occluder.normal, float(occluder.normal @ occluder.origin)
    shape = shapely.Polygon(occluder.exterior_2d, occluder.holes_2d)
    hx = X @ n - d
    if isinstance(light, (PointLight, ParallelLight)):
        if isinstance(light, PointLight):
            far = np.broadcast_to(light.position, X.shape)
        else:
            far = X - 1e6 * light.direction[None, :]
        hf = far @ n - d
        cross = hx * hf < 0.0
        t = np.where(cross, hx / np.where(cross, hx - hf, 1.0), 0.0)
        uv = occluder.to_2d(X + t[:, None] * (far - X))
        hit = cross & shapely.contains_xy(shape, uv[:, 0], uv[:, 1])
        return np.where(hit, 3, 1).astype(np.int8)
    S = light.vertices
    hs = S @ n - d
    if not (np.all(hs > 0) or np.all(hs < 0)):
        raise ValueError("occluder_states: the area light must lie on one side of the occluder's plane")
    out = np.ones(len(X), np.int8)
    beyond = np.flatnonzero(hx * hs[0] < 0.0)   # the plane between the point and the light
    if not len(beyond):
        return out
    Xb = X[beyond]
    t = hx[beyond][:, None] / (hx[beyond][:, None] - hs[None, :])        # (N, m) in (0, 1)
    P = Xb[:, None, :] + t[..., None] * (S[None, :, :] - Xb[:, None, :])  # (N, m, 3)
    uv = occluder.to_2d(P.reshape(-1, 3)).reshape(len(Xb), len(S), 2)
    polys = shapely.polygons(uv)
    inside = shapely.contains(shape, polys)
    meets = shapely.relate_pattern(shape, polys, "T********")              # interiors meet
    out[beyond] = np.where(inside, 3, np.where(meets, 2, 1))
    return out


def occluder_states_near(light, occluder, points, frame, delta):
    """Whether :func:`occluder_states` changes within ``delta`` of each point (8 directions in the
    receiver's plane, ``frame`` its (u, v) unit vectors (2, 3)): the band around the true state
    boundaries where either state is right."""
    X = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    s0 = occluder_states(light, occluder, X)
    near = np.zeros(len(X), bool)
    for a in np.arange(8) * np.pi / 4:
        off = delta * (np.cos(a) * frame[0] + np.sin(a) * frame[1])
        near |= occluder_states(light, occluder, X + off) != s0
    return near

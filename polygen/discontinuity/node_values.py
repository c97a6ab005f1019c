"""Node radiosities for display with each area light's direct part evaluated at the node.

Gouraud display (2.9, 2.10) interpolates node intensities, and (2.8) makes
a node's intensity the mean of its elements' values.  On a mesh whose edges
follow the discontinuity lines (3.3.6) that mean undoes the meshing: a node
on the line between bright and penumbra averages the bright elements on one
side with the penumbra elements on the other, so the interpolated shadow
starts too dark on the bright side and too bright inside, by an amount set
by the elements' values across the line and not by their size.  Under a
small light the penumbra is a band narrower than any element, one element
across, and both of its lines' nodes get such means: the error does not
fall as the elements shrink (the measurement in
``benchmarks/results/discontinuity.md``).

:func:`node_radiosity` keeps (2.8) for what varies smoothly -- the light
reflected by other surfaces, the ambient term -- and evaluates each area
light's direct part at the node itself: Lambert's exact point-to-polygon
factor times the light's visible fraction from the node (``samples**2``
rays, weighted by the point-to-point kernel, as the solver's own
visibility estimate), and where those rays find the light partly hidden,
Lambert's factor of the light's visible part itself (exact).  A node on a line then carries the value of the
shadow's corner there, and linear interpolation between such nodes follows
the penumbra's ramp, whose second derivative is bounded inside each region.
"""

from __future__ import annotations

import numpy as np

from polygen.discontinuity.shadow import ShadowError

__all__ = ["node_radiosity", "light_direct", "element_direct", "exact_direct_image", "node_image", "pixel_states"]


def _light_points(light, samples, *, corners=False):
    """Cell centres of a ``samples x samples`` grid over the light's 2-D box, those inside it;
    with ``corners`` the grid's corners instead (the boundary included, pulled inside by 1e-9 of
    the box), and the light's vertices (pulled likewise towards its centre)."""
    import shapely

    lo, hi = light.exterior_2d.min(axis=0), light.exterior_2d.max(axis=0)
    if corners:
        t = np.linspace(1e-9, 1.0 - 1e-9, samples + 1)
        i, j = np.meshgrid(t, t, indexing="ij")
        uv = lo + np.stack([i.ravel(), j.ravel()], axis=1) * (hi - lo)
        c = light.exterior_2d.mean(axis=0)
        uv = np.vstack([uv, light.exterior_2d + 1e-9 * (c - light.exterior_2d)])
    else:
        i, j = np.meshgrid(np.arange(samples), np.arange(samples), indexing="ij")
        uv = lo + (np.stack([i.ravel(), j.ravel()], axis=1) + 0.5) / samples * (hi - lo)
    uv = uv[shapely.contains_xy(shapely.Polygon(light.exterior_2d), uv[:, 0], uv[:, 1])]
    return light.to_3d(uv)


def light_direct(scene, light_polygon, points, normals, polygons, *, samples=8, exact=True,
                 packed=None, chunk=2048):
    """Direct irradiance factor E F(x -> light) V(x) of one emitting polygon at points.

    Parameters
    ----------
    scene : Scene
    light_polygon : int
        Index of an emitting polygon.
    points, normals : (N, 3) float64
        Points on surfaces and their unit normals.
    polygons : (N,) int64
        The polygon each point lies on (its rays skip it).
    samples : int, keyword-only
        ``samples**2`` rays per point to the light (cell centres of a grid).
    exact : bool, keyword-only
        Where the rays find the light partly hidden, Lambert's factor of the
        visible part itself (the occluders projected onto the light,
        :func:`~polygen.discontinuity.illumination.visible_part`) instead of
        the rays' weighted fraction: no sampling noise in penumbra.
    packed : PackedPolygons, keyword-only, optional

    Returns
    -------
    (N, 3) float64
        The light's emission times the occluded point-to-polygon form factor
        (multiply by the reflectance for the reflected radiosity).
    """
    from polygen.radiosity.formfactor import pack_polygons, point_polygon_form_factor, segments_visible

    L = scene.polygons[light_polygon]
    if not L.is_emitter:
        raise ShadowError(f"polygon {light_polygon} ({L.name!r}) emits nothing")
    if packed is None:
        packed = pack_polygons(scene.polygons)
    x = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    poly = np.asarray(polygons, dtype=np.int64).reshape(-1)
    lp = _light_points(L, int(samples))
    lb = _light_points(L, int(samples), corners=True)
    pieces = [(k, pc.vertices) for k, p in enumerate(scene.polygons) if k != light_polygon
              for pc in p.convex_pieces()] if exact else None
    ln = L.normal
    out = np.zeros(len(x))
    for s in range(0, len(x), chunk):
        xs, ns, ps = x[s:s + chunk], n[s:s + chunk], poly[s:s + chunk]
        f = point_polygon_form_factor(xs, ns, L)
        d = lp[None] - xs[:, None]
        r2 = (d * d).sum(-1)
        ca = (d * ns[:, None]).sum(-1)
        cb = -(d * ln).sum(-1)
        w = np.where((ca > 0) & (cb > 0), ca * cb / np.maximum(r2, 1e-300) ** 2, 0.0)
        vis = segments_visible(np.repeat(xs, len(lp), 0), np.tile(lp, (len(xs), 1)), np.repeat(ps, len(lp)),
                               np.full(len(xs) * len(lp), light_polygon), packed=packed)
        vis = vis.reshape(len(xs), len(lp))
        tot = w.sum(1)
        # no ray carries light (the point barely in front of the light): counted visible, as the solver does
        frac = np.where(tot > 0, (w * vis).sum(1) / np.where(tot > 0, tot, 1.0), 1.0)
        out[s:s + chunk] = f * frac
        if exact:
            # partly seen by the centres or by rays to the grid's corners and the light's
            # vertices (a sliver along the light's edge that no centre sees): the visible part of
            # the light, exactly (Lambert's formula over it)
            front = ((lb[None] - xs[:, None]) * ns[:, None]).sum(-1) > 0
            vb = segments_visible(np.repeat(xs, len(lb), 0), np.tile(lb, (len(xs), 1)), np.repeat(ps, len(lb)),
                                  np.full(len(xs) * len(lb), light_polygon), packed=packed)
            vb = vb.reshape(len(xs), len(lb)) & front
            some = vb.any(axis=1) | (vis & (w > 0)).any(axis=1)
            hid = (~vb & front).any(axis=1) | (~vis & (w > 0)).any(axis=1)
            part = np.flatnonzero(some & hid)
            for i in part:
                out[s + i] = _visible_factor(scene, light_polygon, xs[i], ns[i], int(ps[i]), pieces)
    return out[:, None] * np.asarray(L.emission, dtype=np.float64)[None, :]


def _visible_factor(scene, lpoly, x, n, receiver, pieces):
    """Lambert's point-to-polygon factor of the part of the light seen from x."""
    import shapely
    from shapely.geometry.polygon import orient

    from polygen.discontinuity.illumination import visible_part
    from polygen.radiosity.formfactor import point_polygon_form_factor

    L = scene.polygons[lpoly]
    lit, hidden = visible_part(scene, lpoly, x, receiver, n, pieces=pieces)
    if lit is None:
        return 0.0
    seen = lit if hidden is None else lit.difference(hidden)
    f = 0.0
    for g in shapely.get_parts(seen):
        if g.geom_type != "Polygon" or g.area <= 0.0:
            continue
        g = orient(g, 1.0)  # exterior counter-clockwise, holes clockwise: opposite, as the formula wants
        rings = [L.to_3d(np.asarray(g.exterior.coords)[:-1])]
        rings += [L.to_3d(np.asarray(h.coords)[:-1]) for h in g.interiors]
        f += point_polygon_form_factor(x, n, rings)
    return f


def node_radiosity(mesh, result, *, samples=8, exact=True, visibility_samples=2, packed=None):
    """(N, 3) node radiosities: each area light's direct part at the node, the rest by (2.8).

    Parameters
    ----------
    mesh : RadiosityMesh
    result : RadiosityResult
        Its solution (progressive refinement or Gauss-Seidel) with the
        display radiosity ``result.display_radiosity(mesh)``.
    samples : int, keyword-only
        Rays per node to each light: ``samples**2``.
    exact : bool, keyword-only
        Partly hidden lights by their visible part (:func:`light_direct`).
    visibility_samples : int, keyword-only
        The solve's own ``visibility_samples``: the elements' direct part is
        recomputed with it (the same columns as the solve's, bit for bit), so
        that what (2.8) averages is the rest alone.
    packed : PackedPolygons, keyword-only, optional

    Returns
    -------
    (N, 3) float64
        For :func:`polygen.radiosity.raster.render` (Gouraud).

    Notes
    -----
    The elements' direct part is the light patches' columns times their
    emission: the first shot of each light (a light that reflects and shoots
    again sends reflected light, which stays in the averaged part).  Point
    and parallel lights stay in the averaged part: their shadow edges are D0
    lines, across which the mesh has separate nodes already (Fig. 3.11).
    """
    from polygen.radiosity.formfactor import pack_polygons
    from polygen.radiosity.raster import node_intensities

    scene = mesh.scene
    if packed is None:
        packed = pack_polygons(scene.polygons)
    B = np.asarray(result.display_radiosity(mesh), dtype=np.float64)
    el = mesh.elements.ravel()
    owner = np.repeat(np.arange(mesh.n_elements), 3)
    first = np.full(mesh.n_nodes, -1)
    first[el[::-1]] = owner[::-1]
    ok = np.flatnonzero(first >= 0)
    fe = first[ok]
    direct_e = element_direct(mesh, visibility_samples=visibility_samples, packed=packed)
    direct_n = np.zeros((mesh.n_nodes, 3))
    for lpoly in scene.area_lights:
        lit = ok[mesh.element_polygon[fe] != lpoly]
        fl = first[lit]
        direct_n[lit] += mesh.element_reflectance[fl] * light_direct(
            scene, lpoly, mesh.nodes[lit], mesh.element_normal[fl], mesh.element_polygon[fl],
            samples=samples, exact=exact, packed=packed)
    return node_intensities(mesh, B - direct_e) + direct_n


def element_direct(mesh, *, visibility_samples=2, packed=None):
    """(M, 3) the elements' reflected direct light from the area lights, as the solver shoots it.

    rho_e E F(e -> light patch) summed over the light's patches, with the
    solver's form factors (:func:`~polygen.radiosity.formfactor.analytic_column`,
    deterministic: the same columns as the solve's with the same
    ``visibility_samples``).
    """
    from polygen.radiosity.formfactor import analytic_column, pack_polygons

    scene = mesh.scene
    if packed is None:
        packed = pack_polygons(scene.polygons)
    out = np.zeros((mesh.n_elements, 3))
    for lpoly in scene.area_lights:
        E = np.asarray(scene.polygons[lpoly].emission, dtype=np.float64)
        col = np.zeros(mesh.n_elements)
        for p in np.flatnonzero(mesh.patch_polygon == lpoly):
            col += analytic_column(mesh, int(p), packed=packed, visibility_samples=visibility_samples)
        out += mesh.element_reflectance * col[:, None] * E[None, :]
    return out


def exact_direct_image(mesh, result, camera, *, samples=8, visibility_samples=2, packed=None):
    """(H, W, 3) an image whose area lights' direct part is exact at every pixel.

    At each pixel's surface point (:func:`~polygen.radiosity.raster.pixel_points`)
    each area light's reflected direct light is :func:`light_direct` (exact
    over the light's visible part); the rest (reflected light, ambient) is
    the solution's, less its elements' direct part, displayed by (2.8) and
    Gouraud shading.  A reference for images of shadows: no mesh smears its
    penumbrae.

    Parameters
    ----------
    mesh : RadiosityMesh
    result : RadiosityResult
        The solution on ``mesh`` (its ``visibility_samples`` passed here).
    camera : Camera
    samples, visibility_samples, packed : keyword-only
        As :func:`node_radiosity`.

    Returns
    -------
    image : (H, W, 3) float64
        NaN where no surface is seen.
    rest : (H, W, 3) float64
        Its part that is not the area lights' direct light.
    """
    from polygen.radiosity.formfactor import pack_polygons
    from polygen.radiosity.raster import node_intensities, pixel_points, render

    scene = mesh.scene
    if packed is None:
        packed = pack_polygons(scene.polygons)
    B = result.display_radiosity(mesh)
    rest = render(mesh.nodes, mesh.elements, node_intensities(
        mesh, B - element_direct(mesh, visibility_samples=visibility_samples, packed=packed)), camera,
        background=np.nan)
    covered, e, x = pixel_points(mesh, camera)
    flat = rest.reshape(-1, rest.shape[-1]).copy()
    pix = np.flatnonzero(covered.ravel())
    for lpoly in scene.area_lights:
        on = mesh.element_polygon[e] != lpoly
        flat[pix[on]] += mesh.element_reflectance[e[on]] * light_direct(
            scene, lpoly, x[on], mesh.element_normal[e[on]], mesh.element_polygon[e[on]],
            samples=samples, packed=packed)
    return flat.reshape(rest.shape), rest


def node_image(mesh, result, camera, **kwargs):
    """(H, W, 3) ``mesh`` displayed with each area light's direct part at its nodes
    (:func:`node_radiosity`, ``kwargs`` passed to it), Gouraud-shaded; NaN where no surface is seen."""
    from polygen.radiosity.raster import render

    return render(mesh.nodes, mesh.elements, node_radiosity(mesh, result, **kwargs), camera, background=np.nan)


def pixel_states(mesh, discontinuity, camera):
    """(H, W, n_lights) int8: each light's state (``UMBRA`` 3, ``PENUMBRA`` 2, ``BRIGHT`` 1) at each pixel's
    surface point on ``mesh`` (:func:`~polygen.radiosity.raster.pixel_points`), by
    :func:`~polygen.discontinuity.illumination` of ``discontinuity`` (the scene's simplified discontinuity
    phase); 0 where no surface is seen or the light lies behind the point's face. The penumbra pixels of an
    image: ``(pixel_states(...) == PENUMBRA).any(axis=-1)``."""
    from polygen.discontinuity.simplified import illumination
    from polygen.radiosity.raster import pixel_points

    covered, e, x = pixel_points(mesh, camera)
    st = illumination(discontinuity, x, polygons=mesh.element_polygon[e])
    out = np.zeros(covered.shape + st.shape[1:], np.int8)
    out[covered] = st
    return out

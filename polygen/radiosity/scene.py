"""Radiosity input scenes: planar polygons and light sources (thesis Def. 2.1).

Definition 2.1 of the thesis: the input of the radiosity method is a set of
polygons whose vertices lie in one plane; a polygon may have holes.  A polygon
is one-sided by default: its front is the side from which the outer ring
is counter-clockwise (right-hand rule), and only the front emits and
receives light.  A thin double-sided object (an occluder in chapter 3) is
one polygon with ``two_sided=True``: the mesh then carries patches and
elements on both faces, with opposite normals.

Light sources (chapter 3 distinguishes them by the discontinuities they
cast): an *area light* is a convex emitting polygon (D1 discontinuities);
*point* and *parallel* lights are not geometry (D0 discontinuities) and
enter the radiosity solution as direct illumination.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "SceneError",
    "Polygon",
    "AreaLight",
    "PointLight",
    "ParallelLight",
    "Scene",
]


class SceneError(ValueError):
    """Invalid scene input: non-planar, self-intersecting, degenerate polygons etc."""


def _rgb(value, what, name, *, upper=None):
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise SceneError(f"{name}: {what} must be a number or 3 RGB numbers, got {value!r}") from None
    if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] not in (1, 3)):
        raise SceneError(f"{name}: {what} must be a number or 3 RGB numbers, got shape {arr.shape}")
    arr = np.broadcast_to(arr, (3,)).copy()
    if not np.all(np.isfinite(arr)) or np.any(arr < 0.0):
        raise SceneError(f"{name}: {what} must be finite and >= 0, got {arr.tolist()}")
    if upper is not None and np.any(arr > upper):
        raise SceneError(f"{name}: {what} must be <= {upper}, got {arr.tolist()}")
    return arr


def _drop_repeats(ring, eps):
    """A ring without consecutive vertices closer than ``eps`` (the closing one included)."""
    keep = np.ones(len(ring), dtype=bool)
    last = 0
    for i in range(1, len(ring)):
        if np.linalg.norm(ring[i] - ring[last]) <= eps:
            keep[i] = False
        else:
            last = i
    out = ring[keep]
    while len(out) > 1 and np.linalg.norm(out[-1] - out[0]) <= eps:
        out = out[:-1]
    return out


def _newell(ring):
    """Newell's vector: normal * 2 * signed area of a closed 3D ring (n, 3)."""
    nxt = np.roll(ring, -1, axis=0)
    return np.cross(ring, nxt).sum(axis=0)


class Polygon:
    """A planar polygon, possibly concave and with holes (thesis Def. 2.1).

    Parameters
    ----------
    vertices : (n, 3) float64
        Outer ring, n >= 3, not closed (the first vertex is not repeated).
        Its orientation defines the front: counter-clockwise seen from the
        front, i.e. ``normal`` follows the right-hand rule.
    holes : sequence of (k, 3) float64, optional
        Inner rings in the same plane, inside the outer ring.  Their
        orientation is irrelevant (it is normalised to clockwise).
    reflectance : float or (3,) float64, keyword-only
        Diffuse RGB reflectance rho in [0, 1].
    emission : float or (3,) float64, keyword-only
        Self-emitted RGB radiosity E >= 0 (thesis (2.1)).
    name : str, keyword-only
        Used in error messages and by scene builders.
    plane_tol : float, keyword-only
        Largest allowed distance of a vertex from the fitted plane, relative
        to the polygon's diameter.
    two_sided : bool, keyword-only
        A thin double-sided surface: both faces receive (and emit) light,
        and :func:`~polygen.radiosity.mesh.mesh_scene` meshes both, the
        back face with normal ``-normal``.

    Notes
    -----
    Consecutive vertices closer than ``1e-9 * diameter`` are merged (a
    repeated vertex is dropped).  Holes may touch the outer ring or each
    other at isolated vertices (shapely's validity rule); the meshers of
    :mod:`polygen.radiosity.mesh` handle that.

    Raises
    ------
    SceneError
        If vertices are not finite, fewer than 3, not coplanar, the polygon
        has zero area, self-intersects, or a hole lies outside it or crosses
        it (the 2D checks use shapely in the polygon's plane).
    """

    def __init__(self, vertices, holes=(), *, reflectance=0.5, emission=0.0, name="polygon",
                 plane_tol=1e-6, two_sided=False):
        self.name = str(name)
        self.two_sided = bool(two_sided)
        ext = np.array(vertices, dtype=np.float64)
        if ext.ndim != 2 or ext.shape[1] != 3 or ext.shape[0] < 3:
            raise SceneError(f"{self.name}: vertices must have shape (n>=3, 3), got {ext.shape}")
        if not np.all(np.isfinite(ext)):
            raise SceneError(f"{self.name}: vertices contain NaN or inf")
        if np.allclose(ext[0], ext[-1]) and ext.shape[0] > 3:
            ext = ext[:-1]  # a closed ring: drop the repeated vertex
        hole_list = []
        for k, h in enumerate(holes):
            h = np.array(h, dtype=np.float64)
            if h.ndim != 2 or h.shape[1] != 3 or h.shape[0] < 3:
                raise SceneError(f"{self.name}: hole {k} must have shape (k>=3, 3), got {h.shape}")
            if not np.all(np.isfinite(h)):
                raise SceneError(f"{self.name}: hole {k} contains NaN or inf")
            if np.allclose(h[0], h[-1]) and h.shape[0] > 3:
                h = h[:-1]
            hole_list.append(h)
        scale = float(np.ptp(np.vstack([ext] + hole_list), axis=0).max())
        ext = _drop_repeats(ext, 1e-9 * scale)
        if len(ext) < 3:
            raise SceneError(f"{self.name}: fewer than 3 distinct vertices")
        for k, h in enumerate(hole_list):
            hole_list[k] = _drop_repeats(h, 1e-9 * scale)
            if len(hole_list[k]) < 3:
                raise SceneError(f"{self.name}: hole {k} has fewer than 3 distinct vertices")
        self.reflectance = _rgb(reflectance, "reflectance", self.name, upper=1.0)
        self.emission = _rgb(emission, "emission", self.name)

        allpts = np.vstack([ext] + hole_list)
        origin = ext.mean(axis=0)
        centred = allpts - origin
        diameter = float(np.max(np.linalg.norm(centred, axis=1))) * 2.0
        sv = np.linalg.svd(centred, full_matrices=False)
        if diameter == 0.0 or sv[1][1] <= 1e-9 * diameter:
            raise SceneError(f"{self.name}: zero area (vertices are collinear or coincide)")
        # least-squares plane; the front is where the outer ring turns counter-clockwise
        normal = sv[2][2]
        if _newell(ext) @ normal < 0.0:
            normal = -normal
        dist = np.abs(centred @ normal)
        worst = int(np.argmax(dist))
        if dist[worst] > plane_tol * diameter:
            raise SceneError(
                f"{self.name}: vertices are not coplanar: vertex {worst} is "
                f"{dist[worst]:.6g} from the plane (tolerance {plane_tol * diameter:.3g})")
        # an orthonormal frame (u, v, normal) of the plane: u along the first long edge
        e = ext[1] - ext[0]
        if np.linalg.norm(e) < 1e-12 * diameter:
            e = ext[np.argmax(np.linalg.norm(ext - ext[0], axis=1))] - ext[0]
        u = e - (e @ normal) * normal
        u /= np.linalg.norm(u)
        v = np.cross(normal, u)
        self.origin = origin
        self.normal = normal
        self.u = u
        self.v = v

        import shapely

        ext2 = self.to_2d(ext)
        holes2 = [self.to_2d(h) for h in hole_list]
        shp = shapely.Polygon(ext2, holes2)
        if not shapely.is_valid(shp):
            reason = shapely.is_valid_reason(shp)
            if reason.startswith("Hole lies outside shell"):
                raise SceneError(f"{self.name}: a hole lies outside the polygon ({reason})")
            if reason.startswith("Self-intersection") or reason.startswith("Ring Self-intersection"):
                raise SceneError(f"{self.name}: polygon is self-intersecting ({reason})")
            raise SceneError(f"{self.name}: invalid polygon ({reason})")
        if shp.area <= 1e-12 * diameter * diameter:
            raise SceneError(f"{self.name}: zero area")
        # normalise: outer ring CCW, holes CW (in the (u, v) frame, i.e. seen from the front)
        shp = shapely.geometry.polygon.orient(shp, sign=1.0)
        self._shape2d = shp
        self.exterior_2d = np.asarray(shp.exterior.coords, dtype=np.float64)[:-1]
        self.holes_2d = [np.asarray(r.coords, dtype=np.float64)[:-1] for r in shp.interiors]
        self.area = float(shp.area)
        c = np.asarray(shp.centroid.coords, dtype=np.float64)[0]
        self.centroid = self.to_3d(c)
        self.diameter = diameter

    # -- geometry -----------------------------------------------------------
    def to_2d(self, points):
        """Plane coordinates (..., 2) of 3D points (..., 3) in the (u, v) frame."""
        d = np.asarray(points, dtype=np.float64) - self.origin
        return np.stack([d @ self.u, d @ self.v], axis=-1)

    def to_3d(self, points2d):
        """3D points (..., 3) of plane coordinates (..., 2)."""
        p = np.asarray(points2d, dtype=np.float64)
        return self.origin + p[..., :1] * self.u + p[..., 1:2] * self.v

    @property
    def vertices(self):
        """(n, 3) float64: outer ring, counter-clockwise seen from the front."""
        return self.to_3d(self.exterior_2d)

    @property
    def holes(self):
        """list of (k, 3) float64: hole rings, clockwise seen from the front."""
        return [self.to_3d(h) for h in self.holes_2d]

    @property
    def rings(self):
        """Outer ring then holes, 3D, orientations as in :attr:`vertices`/:attr:`holes`."""
        return [self.vertices] + self.holes

    @property
    def is_emitter(self):
        return bool(np.any(self.emission > 0.0))

    @property
    def is_convex(self):
        """True when the polygon has no holes and its outer ring is convex."""
        if self.holes_2d:
            return False
        p = self.exterior_2d
        d1 = np.roll(p, -1, axis=0) - p
        d2 = np.roll(d1, -1, axis=0)
        cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
        return bool(np.all(cross >= -1e-12 * self.diameter ** 2))

    def triangle_fan(self):
        """``(vertices (n, 3), triangles (n-2, 3))``: a convex polygon without holes as a fan from vertex 0."""
        if self.holes or not self.is_convex:
            raise SceneError(f"{self.name}: a triangle fan needs a convex polygon without holes")
        n = len(self.vertices)
        return self.vertices, np.c_[np.zeros(n - 2, int), np.arange(1, n - 1), np.arange(2, n)]

    def flipped(self, name=None):
        """The same polygon seen from the other side (back-to-back twin)."""
        return type(self)(self.vertices[::-1], [h[::-1] for h in self.holes],
                          reflectance=self.reflectance, emission=self.emission,
                          name=name or self.name + "_back", two_sided=self.two_sided)

    def convex_pieces(self):
        """Split into convex polygons without holes (Hertel-Mehlhorn).

        A constrained Delaunay triangulation of the polygon (holes included),
        then every diagonal whose removal leaves both end vertices convex is
        removed, greedily, longest first.  Hertel and Mehlhorn's bound: at
        most four times the minimum number of convex pieces.

        Returns
        -------
        list of Polygon
            Convex, counter-clockwise seen from the same front, with this
            polygon's reflectance, emission and ``two_sided``; named
            ``name + "_convex<k>"``.  ``[self]`` when already convex.
        """
        if self.is_convex:
            return [self]
        from polygen.mesh2d.pslg import convex_partition

        pieces = convex_partition(self.exterior_2d, self.holes_2d)
        return [Polygon(self.to_3d(p), reflectance=self.reflectance, emission=self.emission,
                        name=f"{self.name}_convex{k}", two_sided=self.two_sided)
                for k, p in enumerate(pieces)]

    def __repr__(self):
        two = ", two_sided=True" if self.two_sided else ""
        return (f"{type(self).__name__}(name={self.name!r}, n_vertices={len(self.exterior_2d)}, "
                f"n_holes={len(self.holes_2d)}, area={self.area:.6g}{two})")


class AreaLight(Polygon):
    """An area light source: a convex emitting polygon without holes.

    Same parameters as :class:`Polygon`; ``emission`` must be > 0 in some
    channel.  Chapter 3 builds shadow polyhedra from its vertices, which is
    why it must be convex.
    """

    def __init__(self, vertices, *, emission, reflectance=0.0, name="area_light", plane_tol=1e-6):
        super().__init__(vertices, (), reflectance=reflectance, emission=emission, name=name,
                         plane_tol=plane_tol)
        if not self.is_emitter:
            raise SceneError(f"{self.name}: an area light needs emission > 0, got "
                             f"{self.emission.tolist()}")
        if not self.is_convex:
            raise SceneError(f"{self.name}: an area light must be a convex polygon")

    def flipped(self, name=None):
        return AreaLight(self.vertices[::-1], emission=self.emission, reflectance=self.reflectance,
                         name=name or self.name + "_back")


class PointLight:
    """An isotropic point light.

    Parameters
    ----------
    position : (3,) float64
    intensity : float or (3,) float64
        Radiant intensity per RGB channel (power per steradian): the
        irradiance at distance r, incidence angle theta, is
        ``intensity * cos(theta) / r**2``.
    """

    def __init__(self, position, intensity, *, name="point_light"):
        self.name = str(name)
        self.position = np.asarray(position, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(self.position)):
            raise SceneError(f"{self.name}: position must be finite")
        self.intensity = _rgb(intensity, "intensity", self.name)

    def __repr__(self):
        return f"PointLight(position={self.position.tolist()}, intensity={self.intensity.tolist()})"


class ParallelLight:
    """A parallel (directional) light.

    Parameters
    ----------
    direction : (3,) float64
        Direction the light travels in (normalised here).
    irradiance : float or (3,) float64
        Irradiance per RGB channel on a surface facing the light.
    """

    def __init__(self, direction, irradiance, *, name="parallel_light"):
        self.name = str(name)
        d = np.asarray(direction, dtype=np.float64).reshape(3)
        n = np.linalg.norm(d)
        if not np.isfinite(n) or n == 0.0:
            raise SceneError(f"{self.name}: direction must be a finite non-zero vector")
        self.direction = d / n
        self.irradiance = _rgb(irradiance, "irradiance", self.name)

    def __repr__(self):
        return (f"ParallelLight(direction={self.direction.tolist()}, "
                f"irradiance={self.irradiance.tolist()})")


class Scene:
    """A radiosity scene: polygons (emitting ones included) and non-geometric lights.

    Parameters
    ----------
    polygons : sequence of Polygon
        Area lights are :class:`AreaLight` instances (or any emitting polygon).
    lights : sequence of PointLight or ParallelLight, optional
    name : str, optional
    """

    def __init__(self, polygons, lights=(), *, name="scene"):
        self.name = str(name)
        self.polygons = list(polygons)
        if not self.polygons:
            raise SceneError(f"{self.name}: a scene needs at least one polygon")
        for k, p in enumerate(self.polygons):
            if not isinstance(p, Polygon):
                raise SceneError(f"{self.name}: polygons[{k}] is {type(p).__name__}, not Polygon")
        self.lights = list(lights)
        for k, light in enumerate(self.lights):
            if not isinstance(light, (PointLight, ParallelLight)):
                raise SceneError(f"{self.name}: lights[{k}] is {type(light).__name__}; point and "
                                 "parallel lights go in `lights`, area lights in `polygons`")

    @property
    def area_lights(self):
        """Indices of emitting polygons."""
        return [k for k, p in enumerate(self.polygons) if p.is_emitter]

    @property
    def point_lights(self):
        return [light for light in self.lights if isinstance(light, PointLight)]

    @property
    def parallel_lights(self):
        return [light for light in self.lights if isinstance(light, ParallelLight)]

    @property
    def bounds(self):
        """(2, 3) float64: min and max corner of all polygon vertices."""
        pts = np.vstack([p.vertices for p in self.polygons])
        return np.stack([pts.min(axis=0), pts.max(axis=0)])

    @property
    def total_area(self):
        return float(sum(p.area for p in self.polygons))

    def __len__(self):
        return len(self.polygons)

    def __repr__(self):
        return (f"Scene(name={self.name!r}, n_polygons={len(self.polygons)}, "
                f"n_area_lights={len(self.area_lights)}, n_lights={len(self.lights)})")

"""The polyhedra of :mod:`polygen.discontinuity.shadow` and their lights, as data.

Shared by the per-polygon construction (:mod:`~polygen.discontinuity.shadow`)
and the convex solids' (:mod:`~polygen.discontinuity.solids`), which the
former's scene driver calls: kept apart so that neither imports the other's
module at its top and the two stay free of an import cycle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from polygen.radiosity.scene import ParallelLight, PointLight, Polygon


class ShadowWarning(UserWarning):
    """A scene the discontinuity phase can do nothing with (a light that lights no receiver)."""


class ShadowError(ValueError):
    """A light or occluder that shadow polyhedra cannot be built from (names the polygon)."""


@dataclass(frozen=True, eq=False)
class Polyhedron:
    """A convex polyhedron ``planes[:, :3] @ x <= planes[:, 3]`` (unit normals, outward).

    Attributes
    ----------
    planes : (P, 4) float64
        Its faces; the first is the occluder's plane (the side beyond the
        occluder), the others the side planes.
    generators : tuple of ((int, ...), (int, ...))
        Per plane, the light vertices and occluder vertices it passes
        through (``((), (0, .., n-1))`` for the occluder's plane; for a
        parallel light the light part is empty).
    vertices : (V, 3) float64
        Vertices of the polyhedron cut by the far cap ``cap`` (a box); empty
        when the polyhedron has no interior.
    edges : (E, 2) int64
        Pairs of ``vertices``, the cap's edges included.
    on_cap : (V,) bool
        Vertices lying on the cap (not vertices of the polyhedron itself).
    cap : (2, 3) float64
        Min and max corner of the capping box.
    """

    planes: np.ndarray
    generators: tuple
    vertices: np.ndarray
    edges: np.ndarray
    on_cap: np.ndarray
    cap: np.ndarray

    @property
    def empty(self):
        return len(self.vertices) == 0

    @property
    def bounded(self):
        """True when no vertex lies on the far cap (the umbra of a light larger than its occluder)."""
        return not self.empty and not bool(self.on_cap.any())

    def contains(self, points, *, tol=0.0):
        """(N,) bool: whether points (N, 3) lie inside (within ``tol``)."""
        p = np.atleast_2d(np.asarray(points, dtype=np.float64))
        if self.empty:
            return np.zeros(len(p), bool)
        return np.all(p @ self.planes[:, :3].T <= self.planes[:, 3] + tol, axis=1)


@dataclass(frozen=True, eq=False)
class ShadowPolyhedra:
    """The umbra and penumbra polyhedra of one light and one convex occluder (Def. 3.4).

    Attributes
    ----------
    umbra, penumbra : Polyhedron
        The same object for a point or a parallel light (Def. 3.4).
    kind : str
        ``"area"``, ``"point"`` or ``"parallel"``.
    light_vertices : (m, 3) float64
        The area light's vertices, the point light's position (1, 3), or
        (0, 3) for a parallel light.
    occluder_vertices : (n, 3) float64
        Counter-clockwise seen from the light.
    candidate_planes : int
        EV and VE planes generated (``2 m n`` for an area light, ``n`` else).
    wrap_steps : int
        Faces visited by the gift-wrapping of the penumbra (Fig. 3.7).
    """

    umbra: Polyhedron
    penumbra: Polyhedron
    kind: str
    light_vertices: np.ndarray
    occluder_vertices: np.ndarray
    candidate_planes: int = 0
    wrap_steps: int = 0


# -- input --------------------------------------------------------------------------------------
def _light_arrays(light):
    """``(kind, vertices (m, 3), direction (3,) or None, name)``."""
    if isinstance(light, PointLight):
        return "point", light.position[None, :].copy(), None, light.name
    if isinstance(light, ParallelLight):
        return "parallel", np.zeros((0, 3)), light.direction.copy(), light.name
    if isinstance(light, Polygon):
        if not light.is_convex:
            raise ShadowError(f"{light.name}: an area light must be convex (split it into convex "
                              "lights, one per piece of Polygon.convex_pieces())")
        return "area", light.vertices.copy(), None, light.name
    v = np.asarray(light, dtype=np.float64)
    if v.ndim == 1 and v.shape == (3,):
        return "point", v[None, :].copy(), None, "point light"
    if v.ndim != 2 or v.shape[1] != 3 or len(v) < 3:
        raise ShadowError(f"light: expected a light object, a point (3,) or a convex polygon "
                          f"(m>=3, 3), got shape {v.shape}")
    if not convex_ring_3d(v):
        raise ShadowError("area light: an area light must be convex (split it into convex "
                          "lights, one per piece of Polygon.convex_pieces())")
    return "area", v.copy(), None, "area light"


def convex_ring_3d(v, tol=1e-9):
    """Whether a planar ring (m, 3) is convex: every turn the same way about its Newell normal
    (collinear vertices allowed, ``tol`` relative to the ring's size squared)."""
    v = np.asarray(v, dtype=np.float64)
    nrm = np.zeros(3)
    for a, b in zip(v, np.roll(v, -1, axis=0)):
        nrm += np.cross(a, b)
    e = np.roll(v, -1, axis=0) - v
    turn = np.cross(e, np.roll(e, -1, axis=0)) @ nrm
    scale = float(np.ptp(v, axis=0).max()) ** 2 * float(np.linalg.norm(nrm))
    return bool(np.all(turn >= -tol * scale))


def _empty_pair(kind, S, O, cap):
    e = Polyhedron(np.zeros((0, 4)), (), np.zeros((0, 3)), np.zeros((0, 2), np.int64),
                   np.zeros(0, bool), np.asarray(cap, dtype=np.float64))
    return ShadowPolyhedra(e, e, kind, S, O)


def _cap_and_tol(S, O, bounds, tol):
    """``(bounds, size, atol)`` of a light's points ``S`` and an occluder's ``O`` (both (k, 3)): the capping
    box (2, 3) (default: 10 sizes around both), their size (the largest side of their box) and the
    absolute tolerance (``tol`` times the larger of that and the box's largest side)."""
    pts = np.vstack([S, O])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    size = float(np.max(hi - lo)) or 1.0
    if bounds is None:
        c = 0.5 * (lo + hi)
        bounds = np.stack([c - 10.0 * size, c + 10.0 * size])
    bounds = np.asarray(bounds, dtype=np.float64)
    if bounds.shape != (2, 3) or np.any(bounds[1] <= bounds[0]):
        raise ShadowError(f"bounds: expected (2, 3) min/max corners, got {bounds.tolist()}")
    return bounds, size, tol * max(size, float(np.max(bounds[1] - bounds[0])))

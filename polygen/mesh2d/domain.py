"""Planar domains: an outer polygon with holes (thesis Def. 2.1, requirement 2.1).

A domain is an outer ring, counter-clockwise, plus zero or more holes,
clockwise, each a ``(K, 2) float64`` array of distinct vertices (the
closing vertex is not repeated). :func:`validate_domain` checks a domain
with shapely and returns it normalised: rings re-oriented, a repeated
closing vertex dropped. Everything else in :mod:`polygen.mesh2d` calls it
first, so bad input fails early with :class:`InvalidDomainError`.
"""

import math
from dataclasses import dataclass

import numpy as np
import shapely

__all__ = [
    "InvalidDomainError",
    "Domain",
    "validate_domain",
    "signed_area",
    "points_in_domain",
]


class InvalidDomainError(ValueError):
    """A polygon or hole that cannot be meshed (the message says which and why)."""


def signed_area(ring):
    """Signed area of a ring by the shoelace formula (> 0 when counter-clockwise).

    Parameters
    ----------
    ring : (K, 2) float64
    """
    ring = np.asarray(ring, dtype=np.float64)
    # relative to the first vertex: far from the origin (a square at 1e9) the products of
    # absolute coordinates cancel to nothing
    x, y = ring[:, 0] - ring[0, 0], ring[:, 1] - ring[0, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def local_origin(xy):
    """A translation that brings points far from the origin near it, exactly.

    The meshers work in coordinates relative to this origin, so that a
    domain far from (0, 0) (a part at 1e9 m in a site's frame) meshes as the
    same domain near (0, 0) does. Per axis: 0 when the bounding box's centre
    is within 1024 box sizes of 0 (at most 10 of 53 bits lost there: every
    domain near the origin, e.g. a radiosity polygon in its own plane frame
    or one of its patches, meshes exactly as before); else the centre rounded to a multiple
    of ``2**ceil(log2(size))``, so that ``x - origin`` is exact (Sterbenz:
    both lie within a factor 2 of each other) and a domain shifted by a
    multiple of that power of two meshes identically, up to the shift.

    Parameters
    ----------
    xy : (N, 2) float64
        Finite points (N >= 1).

    Returns
    -------
    origin : (2,) float64
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = float((hi - lo).max())
    centre = 0.5 * (lo + hi)
    if span == 0.0:
        span = float(np.abs(centre).max()) * 2.0**-40 or 1.0
    unit = 2.0 ** math.ceil(math.log2(span))
    origin = np.round(centre / unit) * unit
    origin[np.abs(centre) < 1024.0 * span] = 0.0
    return origin


@dataclass(frozen=True, eq=False)
class Domain:
    """A validated planar domain.

    Attributes
    ----------
    outer : (K, 2) float64
        Outer ring, counter-clockwise, closing vertex not repeated.
    holes : tuple of (K_h, 2) float64
        Hole rings, clockwise.
    """

    outer: np.ndarray
    holes: tuple

    @property
    def rings(self):
        """Outer ring followed by the holes."""
        return (self.outer,) + tuple(self.holes)

    @property
    def polygon(self):
        """The shapely polygon (built on demand)."""
        return shapely.Polygon(self.outer, list(self.holes))

    @property
    def area(self):
        return signed_area(self.outer) + sum(signed_area(h) for h in self.holes)

    @property
    def n_vertices(self):
        return sum(len(r) for r in self.rings)

    def segments(self):
        """Boundary segments in ring order.

        Returns
        -------
        points : (P, 2) float64
            All ring vertices, outer first, then each hole.
        seg : (P, 2) int64
            Segment ``k`` runs from ``points[seg[k, 0]]`` to ``points[seg[k, 1]]``;
            the domain lies to its left. Segment ``k`` starts at vertex ``k``.
        seg_prev : (P,) int64
            The segment that ends where segment ``k`` starts.
        """
        pts, seg, prev = [], [], []
        off = 0
        for r in self.rings:
            k = len(r)
            idx = np.arange(k) + off
            pts.append(r)
            seg.append(np.stack([idx, np.roll(idx, -1)], axis=1))
            prev.append(np.roll(idx, 1))
            off += k
        return (np.concatenate(pts), np.concatenate(seg).astype(np.int64),
                np.concatenate(prev).astype(np.int64))


def _as_ring(ring, what):
    try:
        a = np.asarray(ring, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidDomainError(f"{what}: cannot convert to a float array ({exc})") from None
    if a.ndim != 2 or a.shape[1] != 2:
        raise InvalidDomainError(f"{what}: expected shape (K, 2), got {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = np.flatnonzero(~np.all(np.isfinite(a), axis=1))
        raise InvalidDomainError(f"{what}: non-finite coordinates at vertices {bad[:5].tolist()}")
    if len(a) >= 2 and np.array_equal(a[0], a[-1]):
        a = a[:-1]
    if len(a) < 3:
        raise InvalidDomainError(f"{what}: a ring needs at least 3 distinct vertices, got {len(a)}")
    d = np.linalg.norm(a - np.roll(a, -1, axis=0), axis=1)
    if np.any(d == 0.0):
        raise InvalidDomainError(f"{what}: repeated consecutive vertex at index {int(np.argmin(d))}")
    scale = np.ptp(a, axis=0).max()
    rel = a - a[0]
    collinear = np.abs(rel[:, 0, None] * rel[None, :, 1] - rel[:, 1, None] * rel[None, :, 0]).max() <= 1e-14 * scale**2
    if collinear or scale == 0.0:
        raise InvalidDomainError(f"{what}: zero area (all vertices on one line)")
    lr = shapely.LinearRing(a)
    if not lr.is_simple:
        raise InvalidDomainError(f"{what}: self-intersecting ring ({shapely.is_valid_reason(shapely.Polygon(a))})")
    if abs(signed_area(a)) <= 1e-14 * scale * scale:
        raise InvalidDomainError(f"{what}: zero area")
    return np.ascontiguousarray(a)


def validate_domain(outer, holes=(), *, allow_touching=False):
    """Check and normalise a polygon with holes.

    Parameters
    ----------
    outer : (K, 2) array_like
        Outer boundary; either orientation is accepted and made counter-clockwise.
    holes : sequence of (K_h, 2) array_like
        Holes; made clockwise. Each must lie inside ``outer`` and not touch
        the other holes or the outer ring (unless ``allow_touching``).
    allow_touching : bool, keyword-only
        Accept holes that touch the outer ring or each other at isolated
        points (valid for shapely: the interior stays connected).

    Returns
    -------
    Domain

    Raises
    ------
    InvalidDomainError
        Non-finite coordinates, fewer than 3 vertices, repeated vertices,
        zero area, a self-intersecting ring, a hole not inside the outer
        ring, or holes that overlap each other.
    """
    if isinstance(outer, Domain):
        return outer
    o = _as_ring(outer, "outer polygon")
    if signed_area(o) < 0:
        o = o[::-1].copy()
    if holes is None:
        holes = ()
    if isinstance(holes, np.ndarray) and holes.ndim == 2:
        raise InvalidDomainError("holes: expected a sequence of (K, 2) rings, got one 2-D array; wrap it in a list")
    hs = []
    outer_poly = shapely.Polygon(o)
    for i, h in enumerate(holes):
        a = _as_ring(h, f"hole {i}")
        if signed_area(a) > 0:
            a = a[::-1].copy()
        hp = shapely.Polygon(a)
        if allow_touching:
            if not outer_poly.covers(hp):
                raise InvalidDomainError(f"hole {i}: not inside the outer polygon")
        elif not outer_poly.contains(hp) or outer_poly.exterior.intersects(hp.exterior):
            raise InvalidDomainError(f"hole {i}: not strictly inside the outer polygon")
        for j, other in enumerate(hs):
            inter = shapely.Polygon(other).intersection(hp)
            if inter.area > 0 or (not allow_touching and not inter.is_empty):
                raise InvalidDomainError(f"hole {i}: overlaps or touches hole {j}")
        hs.append(a)
    poly = shapely.Polygon(o, hs)
    if not poly.is_valid:
        raise InvalidDomainError(f"polygon with holes is invalid: {shapely.is_valid_reason(poly)}")
    return Domain(o, tuple(hs))


def points_in_domain(xy, domain, *, boundary=False):
    """Which points lie inside a domain (holes excluded).

    Parameters
    ----------
    xy : (N, 2) float64
    domain : Domain or (K, 2) array_like
        A :class:`Domain`, or an outer ring without holes.
    boundary : bool
        Whether points on the boundary count as inside.

    Returns
    -------
    inside : (N,) bool
    """
    dom = validate_domain(domain)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    poly = dom.polygon
    shapely.prepare(poly)
    if boundary:
        return shapely.intersects_xy(poly, xy[:, 0], xy[:, 1])
    return shapely.contains_xy(poly, xy[:, 0], xy[:, 1])

"""Small convex-geometry helpers of chapter 3: planes, half-space polytopes, 2-D clipping.

Private to :mod:`polygen.discontinuity`; every function takes plain arrays.
A plane is a row ``(nx, ny, nz, d)`` with a unit normal, and stands for the
half-space ``n . x <= d``.
"""

from __future__ import annotations

from itertools import combinations
from math import sqrt

import numpy as np


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    if v.ndim == 1:
        return v / sqrt(float(v @ v))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def norm(v):
    """Length of one vector (faster than np.linalg.norm on 3 numbers)."""
    return sqrt(float(v @ v))


def cross(a, b):
    """The cross product of two 3-vectors, or of rows (np.cross is slow on tiny inputs)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def plane_through(n, p):
    """The row (n, n . p) of a unit normal n through point p."""
    n = unit(n)
    return np.concatenate([n, [float(n @ p)]])


def dedupe_planes(planes, tol):
    """Planes without repeats (same normal and offset within ``tol``); first occurrence kept."""
    keep = []
    for k, p in enumerate(planes):
        if not any(np.abs(p[:3] - planes[j][:3]).max() < 1e-9 and abs(p[3] - planes[j][3]) < tol
                   for j in keep):
            keep.append(k)
    return np.asarray([planes[k] for k in keep], dtype=np.float64).reshape(-1, 4), keep


def box_planes(lo, hi):
    """The six planes of an axis-aligned box."""
    out = []
    for a in range(3):
        e = np.zeros(3)
        e[a] = 1.0
        out.append(np.concatenate([e, [hi[a]]]))
        out.append(np.concatenate([-e, [-lo[a]]]))
    return np.asarray(out)


_TRIPLES = {}


def _triples(P):
    if P not in _TRIPLES:
        _TRIPLES[P] = np.array(list(combinations(range(P), 3)), dtype=np.int64).reshape(-1, 3)
    return _TRIPLES[P]


def polytope_vertices(planes, tol):
    """Vertices and edges of the bounded polytope ``planes[:, :3] @ x <= planes[:, 3]``.

    Every triple of planes is solved; the solutions inside all half-spaces
    (within ``tol``) are merged when closer than ``tol``.  Two vertices are
    joined by an edge when they lie on two common planes (for a convex
    polytope that common part is an edge, never a face diagonal).

    Returns
    -------
    vertices : (V, 3) float64
    edges : (E, 2) int64
    on : (V, P) bool
        Which planes each vertex lies on.
    """
    P = len(planes)
    if P < 4:
        return np.zeros((0, 3)), np.zeros((0, 2), np.int64), np.zeros((0, P), bool)
    tri = _triples(P)
    A = planes[tri, :3]
    b = planes[tri, 3]
    det = np.linalg.det(A)
    ok = np.abs(det) > 1e-12
    x = np.linalg.solve(A[ok], b[ok][..., None])[..., 0]
    inside = np.all(x @ planes[:, :3].T <= planes[:, 3] + tol, axis=1)
    x = x[inside]
    # merge solutions closer than tol (several planes through one vertex), the first kept
    close = np.abs(x[:, None, :] - x[None, :, :]).max(axis=-1) <= tol
    V = x[~np.triu(close, 1).any(axis=0)]
    on = np.abs(V @ planes[:, :3].T - planes[:, 3]) <= tol
    shared = on.astype(np.int64) @ on.T.astype(np.int64)
    i, j = np.nonzero(np.triu(shared >= 2, k=1))
    return V, np.stack([i, j], axis=1).astype(np.int64), on


def clip_polygon(poly, n, d, tol=0.0):
    """Sutherland-Hodgman: the part of a planar convex polygon ``poly (k, 2|3)`` where ``n . x <= d``.

    Returned unchanged when every vertex has ``n . x - d <= tol``.
    """
    if len(poly) == 0:
        return poly
    s = poly @ n - d
    if np.all(s <= tol):
        return poly
    out = []
    k = len(poly)
    for i in range(k):
        p, q = poly[i], poly[(i + 1) % k]
        sp, sq = s[i], s[(i + 1) % k]
        if sp <= 0.0:
            out.append(p)
        if (sp < 0.0 < sq) or (sq < 0.0 < sp):
            out.append(p + (q - p) * (sp / (sp - sq)))
    return np.asarray(out, dtype=np.float64).reshape(-1, np.shape(poly)[1])


def clip_polygon_2d(poly, a, c, tol=0.0):
    """:func:`clip_polygon` of a polygon ``poly (k, 2)`` in the plane: where ``a . x <= c``."""
    return clip_polygon(poly, a, c, tol)


def clip_polygon_3d(poly, n, d):
    """:func:`clip_polygon` of a planar polygon ``poly (k, 3)`` in space: where ``n . x <= d``."""
    return clip_polygon(poly, n, d)


def clean_ring(poly, tol):
    """A convex ring without repeated (closer than ``tol``) or collinear vertices; (0, d) if flat."""
    if len(poly) < 3:
        return np.zeros((0, poly.shape[1]))
    keep = [poly[0]]
    for p in poly[1:]:
        if np.abs(p - keep[-1]).max() > tol:
            keep.append(p)
    while len(keep) > 1 and np.abs(keep[-1] - keep[0]).max() <= tol:
        keep.pop()
    P = np.asarray(keep)
    if len(P) < 3:
        return np.zeros((0, poly.shape[1]))
    # drop vertices on the segment between their neighbours
    changed = True
    while changed and len(P) >= 3:
        changed = False
        for i in range(len(P)):
            a, b, c = P[i - 1], P[i], P[(i + 1) % len(P)]
            ab, ac = b - a, c - a
            L = np.linalg.norm(ac)
            if L == 0.0:
                area2 = 0.0
            elif P.shape[1] == 2:
                area2 = abs(ab[0] * ac[1] - ab[1] * ac[0]) / L
            else:
                area2 = np.linalg.norm(np.cross(ab, ac)) / L
            if area2 <= tol:
                P = np.delete(P, i, axis=0)
                changed = True
                break
    if len(P) < 3:
        return np.zeros((0, poly.shape[1]))
    return P


def area_2d(poly):
    """Signed area of a 2-D ring (positive counter-clockwise)."""
    if len(poly) < 3:
        return 0.0
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))

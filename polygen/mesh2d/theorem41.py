"""Theorem 4.1: the sharper the size variation, the skinnier the triangles.

The appendix's argument: in a relaxed bubble packing two neighbours of
diameters ``r_i, r_j`` sit at ``0.5 (r_i + r_j)`` (2.11), so a triangle
whose vertex sizes are ``r_a <= r_b = s r_a <= r_c = t r_a`` has edges
``AB = 0.5 r_a (1 + s)``, ``BC = 0.5 r_a (s + t)``, ``CA = 0.5 r_a (1 + t)``
and the edge-length ratio

    BC / AB = (s + t) / (1 + s),

increasing in ``t = r_c / r_a``. The appendix stops there; over ``1 <= s <= t``
the ratio decreases in ``s`` (its derivative is ``(1 - t) / (1 + s)^2``), so

    2 t / (1 + t)  <=  BC / AB  <=  (1 + t) / 2,

both bounds increasing in ``t``: the vertex size ratio ``t`` bounds the
packed triangle's shape from both sides. A size field with gradient ``g``
(``|grad size|``) gives neighbours ``size`` apart a size ratio of about
``1 + g``, so sharper variation means larger ``t`` and skinnier triangles.
"""

import numpy as np

__all__ = ["edge_length_ratio", "packed_edge_ratio", "packed_edge_ratio_bounds", "vertex_size_ratio"]


def edge_length_ratio(nodes, triangles):
    """Longest over shortest edge of each triangle.

    Parameters
    ----------
    nodes : (N, 2) float64
    triangles : (T, 3) int64

    Returns
    -------
    (T,) float64
        ``>= 1``; 1 for an equilateral triangle, inf for a zero-length edge.
    """
    p = np.asarray(nodes, dtype=np.float64)[np.asarray(triangles, dtype=np.int64)]
    ln = np.linalg.norm(p - np.roll(p, -1, axis=1), axis=2)
    with np.errstate(divide="ignore"):
        return ln.max(axis=1) / ln.min(axis=1)


def packed_edge_ratio(sizes):
    """The appendix's edge-length ratio of a packed triangle from its vertex sizes.

    Parameters
    ----------
    sizes : (T, 3) float64
        Positive bubble diameters at the three vertices (any order).

    Returns
    -------
    (T,) float64
        ``(s + t) / (1 + s)`` with ``s = r_b / r_a``, ``t = r_c / r_a`` the sorted sizes,
        i.e. the longest over the shortest of the packed edges ``0.5 (r_i + r_j)``.
    """
    r = np.asarray(sizes, dtype=np.float64)
    if r.ndim != 2 or r.shape[1] != 3 or not np.all(r > 0):
        raise ValueError(f"sizes: expected positive (T, 3) values, got shape {r.shape}")
    r = np.sort(r, axis=1)
    s = r[:, 1] / r[:, 0]
    t = r[:, 2] / r[:, 0]
    return (s + t) / (1.0 + s)


def packed_edge_ratio_bounds(t):
    """Bounds ``(2t / (1 + t), (1 + t) / 2)`` of the packed ratio for a vertex size ratio ``t >= 1``.

    Parameters
    ----------
    t : (T,) float64

    Returns
    -------
    lower, upper : (T,) float64
    """
    t = np.asarray(t, dtype=np.float64)
    if np.any(~(t >= 1.0)):
        raise ValueError("t: vertex size ratios must be >= 1")
    return 2.0 * t / (1.0 + t), 0.5 * (1.0 + t)


def vertex_size_ratio(sizes):
    """Largest over smallest vertex size ``t`` of each triangle, ``sizes : (T, 3)`` -> ``(T,)``."""
    r = np.asarray(sizes, dtype=np.float64)
    return r.max(axis=1) / r.min(axis=1)

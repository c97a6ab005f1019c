"""Element quality (requirement 2.3: no tiny or skinny elements).

Two per-triangle measures: the smallest interior angle, and the radius
ratio ``q = 2 r_in / R_circ`` (1 for an equilateral triangle, 0 for a
degenerate one). Histograms are returned as numbers; plotting lives in
``polygen.plotting``.
"""

import numpy as np

from polygen._jit import njit, prange

__all__ = ["triangle_quality", "quality_histogram", "quality_summary", "triangle_areas", "mesh_edges"]


@njit(parallel=True)
def _quality_kernel(nodes, tri, min_angle, q, area):
    for t in prange(tri.shape[0]):
        a = nodes[tri[t, 0]]
        b = nodes[tri[t, 1]]
        c = nodes[tri[t, 2]]
        la = np.hypot(b[0] - c[0], b[1] - c[1])  # opposite a
        lb = np.hypot(c[0] - a[0], c[1] - a[1])
        lc = np.hypot(a[0] - b[0], a[1] - b[1])
        ar = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
        area[t] = ar
        s = 0.5 * (la + lb + lc)
        if ar <= 0.0 or la == 0.0 or lb == 0.0 or lc == 0.0:
            q[t] = 0.0
            min_angle[t] = 0.0
            continue
        r_in = ar / s
        r_circ = la * lb * lc / (4.0 * ar)
        q[t] = 2.0 * r_in / r_circ
        # angles from the law of cosines, clipped against round-off
        ca = min(1.0, max(-1.0, (lb * lb + lc * lc - la * la) / (2 * lb * lc)))
        cb = min(1.0, max(-1.0, (la * la + lc * lc - lb * lb) / (2 * la * lc)))
        cc = min(1.0, max(-1.0, (la * la + lb * lb - lc * lc) / (2 * la * lb)))
        min_angle[t] = np.degrees(min(np.arccos(ca), min(np.arccos(cb), np.arccos(cc))))


def _check(nodes, triangles):
    n = np.ascontiguousarray(nodes, dtype=np.float64)
    t = np.ascontiguousarray(triangles, dtype=np.int64)
    if n.ndim != 2 or n.shape[1] != 2:
        raise ValueError(f"nodes: expected shape (N, 2), got {n.shape}")
    if t.ndim != 2 or t.shape[1] != 3:
        raise ValueError(f"triangles: expected shape (T, 3), got {t.shape}")
    if t.size and (t.min() < 0 or t.max() >= len(n)):
        raise ValueError(f"triangles: node indices outside [0, {len(n)})")
    return n, t


def triangle_quality(nodes, triangles):
    """Smallest angle and radius ratio of each triangle.

    Parameters
    ----------
    nodes : (N, 2) float64
    triangles : (T, 3) int64

    Returns
    -------
    min_angle : (T,) float64
        Smallest interior angle in degrees (60 for equilateral).
    q : (T,) float64
        ``2 r_in / R_circ`` in [0, 1]; 0 for degenerate or clockwise triangles.
    """
    n, t = _check(nodes, triangles)
    ma = np.empty(len(t))
    q = np.empty(len(t))
    ar = np.empty(len(t))
    _quality_kernel(n, t, ma, q, ar)
    return ma, q


def triangle_areas(nodes, triangles):
    """Signed areas ``(T,) float64`` (positive for counter-clockwise)."""
    n, t = _check(nodes, triangles)
    ma = np.empty(len(t))
    q = np.empty(len(t))
    ar = np.empty(len(t))
    _quality_kernel(n, t, ma, q, ar)
    return ar


def mesh_edges(triangles):
    """Unique undirected edges ``(E, 2) int64`` (sorted pairs) of a triangle mesh."""
    t = np.asarray(triangles, dtype=np.int64)
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    e.sort(axis=1)
    return np.unique(e, axis=0)


def quality_histogram(values, *, kind="q", bins=20):
    """Histogram of a quality measure on its natural range.

    Parameters
    ----------
    values : (T,) float64
        ``q`` values (range [0, 1]) or minimum angles (range [0, 60] degrees).
    kind : {"q", "angle"}
    bins : int

    Returns
    -------
    counts : (bins,) int64
    edges : (bins + 1,) float64
    """
    rng = {"q": (0.0, 1.0), "angle": (0.0, 60.0)}
    if kind not in rng:
        raise ValueError(f"kind: expected 'q' or 'angle', got {kind!r}")
    counts, edges = np.histogram(np.asarray(values, dtype=np.float64), bins=bins, range=rng[kind])
    return counts.astype(np.int64), edges


def quality_summary(nodes, triangles):
    """A few numbers describing a mesh: counts, mean/min q and min angle.

    Returns
    -------
    dict
        ``n_nodes, n_triangles, q_mean, q_min, angle_min, angle_mean,
        frac_q_below_0.8``.
    """
    ma, q = triangle_quality(nodes, triangles)
    return {
        "n_nodes": int(len(nodes)),
        "n_triangles": int(len(triangles)),
        "q_mean": float(q.mean()),
        "q_min": float(q.min()),
        "angle_min": float(ma.min()),
        "angle_mean": float(ma.mean()),
        "frac_q_below_0.8": float(np.mean(q < 0.8)),
    }

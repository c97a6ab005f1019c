"""The element-size grid of a polygon (thesis 4.3.2, Def. 4.4, Fig. 4.2).

Sizes known at scattered points (the nodes of a first mesh) become a size
field on a rectangular ``m x n`` grid over the polygon's bounding box:

1. a grid point with nodes in its four adjacent cells gets their
   inverse-distance-weighted mean (4.5);
2. every other grid point gets the height of a thin plate bent through the
   assigned points (assigned ``w`` held, slopes free, edges free), i.e. the
   smoothest surface through them in the sense of the bending energy (4.6),
   computed with the 12-DOF rectangular plate element
   (:mod:`polygen.mesh2d.plate`).

The result is a :class:`~polygen.mesh2d.GridSize`, which the bubble mesh
reads by bilinear interpolation (4.12, 4.13).
"""

from __future__ import annotations

import numpy as np

from polygen.mesh2d.plate import PlateError, solve_plate
from polygen.mesh2d.sizing import GridSize

__all__ = ["grid_lattice", "assign_grid_sizes", "element_size_grid"]


def _check_points(points, sizes):
    p = np.ascontiguousarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) == 0:
        raise ValueError(f"points: expected (K >= 1, 2), got {p.shape}")
    s = np.ascontiguousarray(sizes, dtype=np.float64).reshape(-1)
    if s.shape != (len(p),):
        raise ValueError(f"sizes: expected ({len(p)},), got {s.shape}")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(s))) or s.min() <= 0:
        raise ValueError("points and sizes must be finite, sizes > 0")
    return p, s


def grid_lattice(bounds, grid):
    """The lattice of Def. 4.4 over ``bounds = (xmin, ymin, xmax, ymax)``.

    Parameters
    ----------
    bounds : 4 floats
    grid : float or (m, n) ints
        A target step (the same in x and y, rounded so that the lattice
        spans the bounds exactly), or ``m`` points in x and ``n`` in y.

    Returns
    -------
    origin : (2,) float64
    spacing : (2,) float64
    shape : (ny, nx) ints
    """
    xmin, ymin, xmax, ymax = map(float, bounds)
    w, h = xmax - xmin, ymax - ymin
    if not (np.isfinite(w) and np.isfinite(h) and w > 0 and h > 0):
        raise ValueError(f"bounds: need xmin < xmax and ymin < ymax, got {bounds}")
    if np.ndim(grid) == 0:
        try:
            step = float(grid)
        except (TypeError, ValueError):
            raise ValueError(f"grid: expected a step or (m, n), got {grid!r}") from None
        if not (np.isfinite(step) and step > 0):
            raise ValueError(f"grid: a step must be finite and > 0, got {grid}")
        nx = max(2, int(np.ceil(w / step - 1e-9)) + 1)
        ny = max(2, int(np.ceil(h / step - 1e-9)) + 1)
    else:
        try:
            nx, ny = (int(g) for g in grid)
        except (TypeError, ValueError):
            raise ValueError(f"grid: expected a step or (m, n), got {grid!r}") from None
        if nx < 2 or ny < 2:
            raise ValueError(f"grid: need m, n >= 2, got ({nx}, {ny})")
    return (np.array([xmin, ymin]), np.array([w / (nx - 1), h / (ny - 1)]), (ny, nx))


def assign_grid_sizes(points, sizes, origin, spacing, shape):
    """Inverse-distance-weighted sizes at the grid points that have nodes nearby (4.5).

    Parameters
    ----------
    points : (K, 2) float64
        Node positions (outside the lattice: counted in the border cell).
    sizes : (K,) float64
        Their sizes ``F_i``.
    origin, spacing : (2,) float64
    shape : (ny, nx)

    Returns
    -------
    (ny, nx) float64
        ``sum w_i F_i / sum w_i`` with ``w_i = 1 / dist_i`` over the nodes
        in the four cells around each grid point; NaN where there are none.
    """
    p, s = _check_points(points, sizes)
    ny, nx = shape
    o = np.asarray(origin, dtype=np.float64)
    h = np.asarray(spacing, dtype=np.float64)
    u = (p - o) / h
    ci = np.clip(np.floor(u[:, 0]).astype(np.int64), 0, nx - 2)
    cj = np.clip(np.floor(u[:, 1]).astype(np.int64), 0, ny - 2)
    # each node counts for the four corners of its cell: (K, 4) grid points
    gi = ci[:, None] + np.array([0, 1, 0, 1])
    gj = cj[:, None] + np.array([0, 0, 1, 1])
    d = np.hypot(o[0] + gi * h[0] - p[:, :1], o[1] + gj * h[1] - p[:, 1:])
    # (4.5): dist = 0 replaced by a small positive number
    w = 1.0 / np.maximum(d, 1e-9 * float(h.min()))
    idx = (gj * nx + gi).ravel()
    num = np.bincount(idx, weights=(w * s[:, None]).ravel(), minlength=nx * ny)
    den = np.bincount(idx, weights=w.ravel(), minlength=nx * ny)
    out = np.full(nx * ny, np.nan)
    hit = den > 0
    out[hit] = num[hit] / den[hit]
    return out.reshape(ny, nx)


def element_size_grid(points, sizes, bounds, *, grid, nu=0.3, clip=True):
    """A smooth element-size grid from sizes at scattered nodes (4.5-4.10).

    Parameters
    ----------
    points : (K, 2) float64
        Node positions in the polygon's plane.
    sizes : (K,) float64
        Element sizes at the nodes (``f(D)``, (4.4)).
    bounds : (xmin, ymin, xmax, ymax)
        The polygon's bounding box.
    grid : float or (m, n) ints, keyword-only
        Lattice step or point counts (:func:`grid_lattice`).
    nu : float, keyword-only
        Poisson's ratio of the plate (the thesis does not give one; 0.3, a
        metal's, by default).  It only matters at the plate's free edges.
    clip : bool, keyword-only
        Clip the plate's heights to ``[min(sizes), max(sizes)]``: a bent
        plate overshoots beyond its held points (in the bounding box's
        corners outside the polygon, for one), and a size must stay
        positive.

    Returns
    -------
    GridSize
        With an extra attribute ``assigned`` ((ny, nx) bool): the grid
        points that (4.5) gave a value; the others come from the plate.

    Raises
    ------
    ValueError
        Bad points, sizes, bounds or grid.
    PlateError
        The assigned points do not pin a plate down (all on one line).
    """
    p, s = _check_points(points, sizes)
    origin, spacing, shape = grid_lattice(bounds, grid)
    vals = assign_grid_sizes(p, s, origin, spacing, shape)
    assigned = np.isfinite(vals)
    if not assigned.all():
        held = np.flatnonzero(assigned.ravel())
        try:
            u = solve_plate(shape, spacing, fixed_dofs=3 * held, fixed_values=vals.ravel()[held],
                            nu=nu)
        except PlateError as exc:
            raise PlateError(f"element size grid: {exc}") from None
        vals = u[:, :, 0].copy()
    if clip:
        vals = np.clip(vals, s.min(), s.max())
    out = GridSize(origin, spacing, vals)
    object.__setattr__(out, "assigned", assigned)
    return out

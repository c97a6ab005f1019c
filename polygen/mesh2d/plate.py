"""Thin plates on a rectangular grid: the 12-DOF rectangular plate element (thesis 4.6-4.10).

Chapter 4 fills the grid points of an element-size grid that no node
reached by bending a thin plate through the points that were reached
(assumption 4.1): the fewer the curvature, the smoother the size field, and
by Theorem 4.1 the less skinny the triangles.  The strain energy (4.6) is

    U = 1/2 int eps D eps^T dx dy,   eps = [-w_xx, -w_yy, 2 w_xy],
    D = E h^3 / (12 (1 - nu^2)) [[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu)/2]]

discretised with the 12-DOF rectangular element of Adini-Clough and
Melosh-Zienkiewicz (ACM): on each cell ``w`` is the 12-term polynomial
(4.7) fixed by ``w``, ``dw/dx`` and ``dw/dy`` at the four corners (4.8-4.10).
The thesis's nodal rotations are ``theta_x = -dw/dy`` and ``theta_y = dw/dx``
(up to its sign convention); we keep the slopes ``(w, w_x, w_y)`` themselves,
which is the same element with two columns negated.  The element is
non-conforming (the normal slope jumps across cell edges) but passes the
patch test, and its deflections converge as O(h^2).

All cells of a grid are the same rectangle, so there is one 12 x 12 element
matrix, integrated by 3 x 3 Gauss points (exact for this polynomial).
:func:`assemble_plate` sums it into the global matrix by one vectorised COO
assembly; :func:`solve_plate` writes the free DOFs' block straight into CSC
(a numba kernel over the 3 x 3 grid points around each DOF) in a
nested-dissection order of the grid, and factors it by Cholesky along that
same dissection's tree (:mod:`polygen.mesh2d._multifrontal`: one dense
front per separator line, BLAS for the dense work).  The factor runs with
BLAS pinned to one thread (threadpoolctl): its fronts are many and small,
and a threaded ``gemm`` on each of them spends its time starting and
waiting for threads: on a busy 2-core machine (load 12) OpenBLAS's
default two threads made the 200 x 200 factor 13.5 s against 0.54 s with
one, and the whole step took 1.04 s (0.51 s CPU).  These figures, the
step by phase, and SuperLU on the same matrix and order (1.77 s) are in
``benchmarks/results/intensity_mesh_plate.json`` (``benchmarks/intensity_mesh.py
--only plate``), with the commit they were measured at.
Degrees of freedom are numbered ``3 * (j * nx + i) + c`` for grid point
``(i, j)`` (``x = x0 + i dx``, ``y = y0 + j dy``) and component ``c`` in
``(w, w_x, w_y)``.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from polygen._jit import njit
from polygen.mesh2d import _multifrontal as _mf

__all__ = ["PlateError", "plate_element_stiffness", "plate_element_load", "assemble_plate",
           "plate_edge_dofs", "solve_plate", "square_plate_centre"]

W, WX, WY = 0, 1, 2

# the corners of a cell in natural coordinates, counter-clockwise from (-1, -1)
_CORNERS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
# exponents (p, q) of x^p y^q in (4.7): 1, x, y, x2, xy, y2, x3, x2y, xy2, y3, x3y, xy3
_EXP = np.array([(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3),
                 (3, 1), (1, 3)])


class PlateError(ValueError):
    """Bad input to the plate solver: shapes, spacings, material, or a singular plate."""


def _monomials(xi, eta, dx=0, dy=0):
    """(K, 12) values of the derivative d^dx/dxi d^dy/deta of each monomial of (4.7)."""
    xi = np.atleast_1d(xi)[:, None]
    eta = np.atleast_1d(eta)[:, None]
    p, q = _EXP[:, 0], _EXP[:, 1]

    def falling(n, k):
        out = np.ones_like(n, dtype=np.float64)
        for m in range(k):
            out = out * (n - m)
        return out

    cp, cq = falling(p, dx), falling(q, dy)
    pe, qe = np.maximum(p - dx, 0), np.maximum(q - dy, 0)
    return cp * cq * xi ** pe * eta ** qe


def _shape_coefficients(hx, hy):
    """(12, 12) C^-1: monomial coefficients of the 12 shape functions (4.8-4.10)."""
    sx, sy = 2.0 / hx, 2.0 / hy  # d/dx = (2/hx) d/dxi
    rows = []
    for xi, eta in _CORNERS:
        rows.append(_monomials(xi, eta)[0])
        rows.append(sx * _monomials(xi, eta, 1, 0)[0])
        rows.append(sy * _monomials(xi, eta, 0, 1)[0])
    return np.linalg.inv(np.array(rows))


def _gauss3():
    g, w = np.polynomial.legendre.leggauss(3)
    xi, eta = np.meshgrid(g, g, indexing="ij")
    ww = np.outer(w, w)
    return xi.ravel(), eta.ravel(), ww.ravel()


def _check_spacing(hx, hy):
    hx, hy = float(hx), float(hy)
    if not (np.isfinite(hx) and np.isfinite(hy) and hx > 0 and hy > 0):
        raise PlateError(f"spacing: cell sides must be finite and > 0, got ({hx}, {hy})")
    return hx, hy


def _check_nu(nu):
    nu = float(nu)
    if not -1.0 < nu < 0.5:
        raise PlateError(f"nu: Poisson's ratio must be in (-1, 0.5), got {nu}")
    return nu


def plate_element_stiffness(hx, hy, *, nu=0.3, rigidity=1.0):
    """Stiffness matrix of one ACM plate element (4.6-4.10).

    Parameters
    ----------
    hx, hy : float
        Cell sides.
    nu : float, keyword-only
        Poisson's ratio.
    rigidity : float, keyword-only
        Flexural rigidity ``E h^3 / (12 (1 - nu^2))``.

    Returns
    -------
    (12, 12) float64
        Symmetric; rows/columns ``3 * corner + (w, w_x, w_y)``, corners
        counter-clockwise from the lower left.  ``1/2 u K u`` is (4.6).
    """
    hx, hy = _check_spacing(hx, hy)
    nu = _check_nu(nu)
    cinv = _shape_coefficients(hx, hy)
    sx, sy = 2.0 / hx, 2.0 / hy
    xi, eta, wg = _gauss3()
    # eps = [-w_xx, -w_yy, 2 w_xy] at each Gauss point: (G, 3, 12)
    b = np.stack([-sx * sx * _monomials(xi, eta, 2, 0), -sy * sy * _monomials(xi, eta, 0, 2),
                  2.0 * sx * sy * _monomials(xi, eta, 1, 1)], axis=1) @ cinv
    d = rigidity * np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - nu)]])
    k = np.einsum("g,gai,ab,gbj->ij", wg * (hx * hy / 4.0), b, d, b)
    return 0.5 * (k + k.T)


def plate_element_load(hx, hy):
    """Consistent nodal load of one element under a unit uniform pressure.

    Returns
    -------
    (12,) float64
        ``int N_i dA`` for the 12 shape functions.
    """
    hx, hy = _check_spacing(hx, hy)
    cinv = _shape_coefficients(hx, hy)
    xi, eta, wg = _gauss3()
    return (wg * (hx * hy / 4.0)) @ (_monomials(xi, eta) @ cinv)


def _cell_dofs(nx, ny):
    """(cells, 12) int64 global DOFs of every cell's corners."""
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1))
    i, j = i.ravel(), j.ravel()
    corners = np.stack([j * nx + i, j * nx + i + 1, (j + 1) * nx + i + 1, (j + 1) * nx + i], axis=1)
    return (3 * corners[:, :, None] + np.arange(3)).reshape(-1, 12).astype(np.int64)


@lru_cache(maxsize=16)
def _nested_dissection(nx, ny, leaf=4):
    """The grid points in nested-dissection order and its tree, read-only arrays.

    A grid line separates two halves (a cell spans two lines), so each
    separator is one line of points; boxes of at most ``leaf x leaf`` points
    are not cut further.  Cached: the polygons of a scene share a few grid
    shapes.

    Returns
    -------
    order : (nx ny,) int64
        Grid points, each box before the separator that cuts its parent box.
    ptr : (nb + 1,) int64
        Box or separator ``k`` (postorder) is ``order[ptr[k]:ptr[k + 1]]``.
    parent : (nb,) int64
        The separator whose cut made it, -1 for the first cut.
    """
    rects = []  # (i0, i1, j0, j1) of each leaf box or separator line, in postorder
    parent = []

    def rec(i0, i1, j0, j1):
        w, h = i1 - i0, j1 - j0
        if w <= 0 or h <= 0:
            return []
        if w <= leaf and h <= leaf:
            sub, box = [], (i0, i1, j0, j1)
        elif w >= h:
            m = (i0 + i1) // 2
            sub = rec(i0, m, j0, j1) + rec(m + 1, i1, j0, j1)
            box = (m, m + 1, j0, j1)
        else:
            m = (j0 + j1) // 2
            sub = rec(i0, i1, j0, m) + rec(i0, i1, m + 1, j1)
            box = (i0, i1, m, m + 1)
        k = len(rects)
        rects.append(box)
        parent.append(-1)
        for c in sub:
            parent[c] = k
        return [k]

    rec(0, nx, 0, ny)
    r = np.array(rects, dtype=np.int64).reshape(-1, 4)
    ptr = np.concatenate([[0], np.cumsum((r[:, 1] - r[:, 0]) * (r[:, 3] - r[:, 2]))])
    order = _fill_boxes(r, ptr, nx)
    parent = np.array(parent, dtype=np.int64)
    for a in (order, ptr, parent):
        a.flags.writeable = False
    return order, ptr, parent


@njit
def _fill_boxes(rects, ptr, nx):
    """The grid points of each box ``(i0, i1, j0, j1)``, row by row, one box after another."""
    out = np.empty(ptr[-1], dtype=np.int64)
    for k in range(len(rects)):
        t = ptr[k]
        for j in range(rects[k, 2], rects[k, 3]):
            for i in range(rects[k, 0], rects[k, 1]):
                out[t] = j * nx + i
                t += 1
    return out


def _check_shape(shape):
    try:
        ny, nx = (int(s) for s in shape)
    except (TypeError, ValueError):
        raise PlateError(f"shape: expected (ny, nx), got {shape!r}") from None
    if nx < 2 or ny < 2:
        raise PlateError(f"shape: need at least 2 x 2 grid points, got ({ny}, {nx})")
    return ny, nx


@njit
def _free_system(ke, nx, ny, new, order, u):
    """Stiffness among the free DOFs, straight into CSC, and the held DOFs' right-hand side.

    Parameters
    ----------
    ke : (12, 12) float64
        The element matrix (every cell is the same rectangle).
    nx, ny : int
        Grid points per row and column.
    new : (3 nx ny,) int32
        Position of each DOF among the free ones, -1 where held.
    order : (nf,) int64
        The free DOFs in their new order (``new[order] == arange(nf)``).
    u : (3 nx ny,) float64
        The held values (read where ``new < 0``).

    Returns
    -------
    indptr : (nf + 1,) int64
    indices : (nnz,) int32
        Rows, sorted within each column.
    data : (nnz,) float64
    rhs : (nf,) float64
        ``-K[free, held] u[held]``.

    Serial: a parallel loop measured slower here (0.076 against 0.055 s on 200 x 200 on two
    busy cores; 0.020 against 0.0004 s on 20 x 20, the threads' start).
    """
    nf = len(order)
    count = np.zeros(nf + 1, dtype=np.int64)
    for col in range(nf):
        q = order[col] // 3
        qi, qj = q % nx, q // nx
        c = 0
        for pj in range(max(qj - 1, 0), min(qj + 2, ny)):
            for pi in range(max(qi - 1, 0), min(qi + 2, nx)):
                for c1 in range(3):
                    if new[3 * (pj * nx + pi) + c1] >= 0:
                        c += 1
        count[col + 1] = c
    indptr = np.cumsum(count)
    indices = np.empty(indptr[nf], dtype=np.int32)
    data = np.empty(indptr[nf], dtype=np.float64)
    rhs = np.zeros(nf)
    for col in range(nf):
        g = order[col]
        q, c2 = g // 3, g % 3
        qi, qj = q % nx, q // nx
        k = indptr[col]
        acc = 0.0
        for pj in range(max(qj - 1, 0), min(qj + 2, ny)):
            for pi in range(max(qi - 1, 0), min(qi + 2, nx)):
                for c1 in range(3):
                    # K[(p, c1), (q, c2)]: the cells holding both p and q
                    v = 0.0
                    for cj in range(max(pj, qj) - 1, min(pj, qj) + 1):
                        if cj < 0 or cj > ny - 2:
                            continue
                        for ci in range(max(pi, qi) - 1, min(pi, qi) + 1):
                            if ci < 0 or ci > nx - 2:
                                continue
                            # corners counter-clockwise from (ci, cj)
                            lp = _corner(pi - ci, pj - cj)
                            lq = _corner(qi - ci, qj - cj)
                            v += ke[3 * lp + c1, 3 * lq + c2]
                    r = new[3 * (pj * nx + pi) + c1]
                    if r >= 0:
                        indices[k] = r
                        data[k] = v
                        k += 1
                    else:
                        acc -= v * u[3 * (pj * nx + pi) + c1]
        rhs[col] = acc
        # insertion sort of the column's rows (at most 27)
        a = indptr[col]
        for m in range(a + 1, k):
            ri, rv = indices[m], data[m]
            t = m - 1
            while t >= a and indices[t] > ri:
                indices[t + 1] = indices[t]
                data[t + 1] = data[t]
                t -= 1
            indices[t + 1] = ri
            data[t + 1] = rv
    return indptr, indices, data, rhs


@njit
def _corner(di, dj):
    """Local corner (0..3, counter-clockwise from the lower left) of offset (di, dj) in a cell."""
    if dj == 0:
        return di
    return 3 - di


def _pinned(fixed, nx):
    """Whether holding ``fixed`` DOFs removes the plate's three rigid modes.

    The assembled ACM stiffness of a grid has exactly the rigid modes
    ``w = a + b x + c y`` as zero-energy modes, so the free block is
    positive definite iff the rigid modes' values at the held DOFs, ``R``
    (K, 3), have rank 3.  In grid units with slope rows scaled by the cell
    side, ``R`` is an integer matrix (rows ``[1, i, j]`` for ``w``,
    ``[0, 1, 0]`` for ``w_x``, ``[0, 0, 1]`` for ``w_y``), and its rank is
    decided exactly by the integer determinant of ``R^T R``.
    """
    node, comp = np.divmod(fixed, 3)
    j, i = np.divmod(node, nx)
    r = np.zeros((len(fixed), 3), dtype=np.int64)
    r[comp == W] = np.stack([np.ones_like(i), i, j], axis=1)[comp == W]
    r[comp == WX, 1] = 1
    r[comp == WY, 2] = 1
    g = [[int(v) for v in row] for row in r.T @ r]  # entries < 2^63 for grids below ~10^6 points
    det = (g[0][0] * (g[1][1] * g[2][2] - g[1][2] * g[2][1])
           - g[0][1] * (g[1][0] * g[2][2] - g[1][2] * g[2][0])
           + g[0][2] * (g[1][0] * g[2][1] - g[1][1] * g[2][0]))
    return det != 0


def assemble_plate(shape, spacing, *, nu=0.3, rigidity=1.0):
    """Global stiffness matrix of a plate on an ``ny x nx`` grid of points.

    Parameters
    ----------
    shape : (ny, nx) ints
        Grid points per column and row.
    spacing : (dx, dy) floats
    nu, rigidity : float, keyword-only
        As :func:`plate_element_stiffness`.

    Returns
    -------
    scipy.sparse.csr_matrix, (3 nx ny, 3 nx ny) float64
    """
    ny, nx = _check_shape(shape)
    hx, hy = _check_spacing(*np.asarray(spacing, dtype=np.float64).reshape(2))
    ke = plate_element_stiffness(hx, hy, nu=nu, rigidity=rigidity)
    dofs = _cell_dofs(nx, ny)
    n = 3 * nx * ny
    rows = np.repeat(dofs, 12, axis=1).ravel()
    cols = np.tile(dofs, (1, 12)).ravel()
    data = np.tile(ke.ravel(), len(dofs))
    return sp.coo_matrix((data, (rows, cols)), shape=(n, n)).tocsr()


def plate_edge_dofs(shape, support):
    """DOFs held on the four edges of a rectangular plate.

    Parameters
    ----------
    shape : (ny, nx) ints
    support : {"simply_supported", "clamped"}
        Simply supported: ``w`` and the slope along the edge (which is zero
        once ``w`` is zero along it); clamped: ``w`` and both slopes.

    Returns
    -------
    (K,) int64
        Sorted DOF numbers.
    """
    ny, nx = _check_shape(shape)
    if support not in ("simply_supported", "clamped"):
        raise PlateError(f"support must be 'simply_supported' or 'clamped', got {support!r}")
    j, i = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    node = j * nx + i
    xedge = (i == 0) | (i == nx - 1)  # edges x = const: w_y = 0 along them
    yedge = (j == 0) | (j == ny - 1)  # edges y = const: w_x = 0 along them
    out = [3 * node[xedge | yedge] + W]
    if support == "clamped":
        out += [3 * node[xedge | yedge] + WX, 3 * node[xedge | yedge] + WY]
    else:
        out += [3 * node[xedge] + WY, 3 * node[yedge] + WX]
    return np.unique(np.concatenate(out)).astype(np.int64)


def solve_plate(shape, spacing, *, fixed_dofs, fixed_values=0.0, load=0.0, nu=0.3, rigidity=1.0):
    """Deflection of a plate with some DOFs held: minimise (4.6) minus the load's work.

    Parameters
    ----------
    shape : (ny, nx) ints
    spacing : (dx, dy) floats
    fixed_dofs : (K,) int
        DOFs held (see the module docstring for the numbering), distinct.
    fixed_values : float or (K,) float64, keyword-only
        Their values.
    load : float, keyword-only
        Uniform pressure ``q`` (consistent nodal loads).
    nu, rigidity : float, keyword-only
        As :func:`plate_element_stiffness`.

    Returns
    -------
    (ny, nx, 3) float64
        ``w``, ``dw/dx``, ``dw/dy`` at every grid point.

    Raises
    ------
    PlateError
        Bad shapes or values; a plate the held DOFs do not pin down (e.g.
        ``w`` held at fewer than three non-collinear points).
    """
    ny, nx = _check_shape(shape)
    n = 3 * nx * ny
    fixed = np.asarray(fixed_dofs, dtype=np.int64).reshape(-1)
    if fixed.size and (fixed.min() < 0 or fixed.max() >= n):
        raise PlateError(f"fixed_dofs: outside [0, {n})")
    if len(np.unique(fixed)) != len(fixed):
        raise PlateError("fixed_dofs: repeated DOFs")
    vals = np.broadcast_to(np.asarray(fixed_values, dtype=np.float64), fixed.shape)
    if not np.all(np.isfinite(vals)):
        raise PlateError("fixed_values: must be finite")
    if not np.isfinite(load):
        raise PlateError(f"load: must be finite, got {load}")
    hx, hy = _check_spacing(*np.asarray(spacing, dtype=np.float64).reshape(2))
    ke = plate_element_stiffness(hx, hy, nu=nu, rigidity=rigidity)
    cells = _cell_dofs(nx, ny)
    f = np.zeros(n)
    if load:
        f += np.bincount(cells.ravel(), weights=np.tile(load * plate_element_load(hx, hy),
                                                        len(cells)), minlength=n)
    u = np.zeros(n)
    u[fixed] = vals
    free = np.ones(n, dtype=bool)
    free[fixed] = False
    if not np.any(free):
        return u.reshape(ny, nx, 3)
    if not _pinned(fixed, nx):
        raise PlateError("the held DOFs do not pin the plate down (a zero-energy mode is free: "
                         "hold w at three points not on one line)")
    order, sn_ptr, parent = _free_order(nx, ny, free)
    # assemble straight into the free DOFs' new numbering, as CSC (no COO, no slicing of a
    # global matrix); held DOFs move to the right-hand side
    new = np.full(n, -1, dtype=np.int32)
    new[order] = np.arange(len(order), dtype=np.int32)
    indptr, indices, data, rhs_held = _free_system(ke, nx, ny, new, order, u)
    x = _spd_solve(indptr, indices, data, sn_ptr, parent, f[order] + rhs_held)
    if not np.all(np.isfinite(x)):
        raise PlateError("the plate solve gave non-finite deflections")
    u[order] = x
    return u.reshape(ny, nx, 3)


def _free_order(nx, ny, free, leaf=4):
    """The free DOFs in nested-dissection order, and the dissection's tree over them.

    Returns ``(order, sn_ptr, parent)``: ``order`` (nf,) int64 DOFs; supernode ``k`` (a box or
    a separator line of :func:`_nested_dissection`) holds ``order[sn_ptr[k]:sn_ptr[k + 1]]``.
    """
    points, ptr, parent = _nested_dissection(nx, ny, leaf)
    dofs = 3 * points[:, None] + np.arange(3)
    keep = free[dofs]
    counts = np.concatenate([[0], np.cumsum(keep.sum(axis=1))])
    return dofs[keep], counts[ptr], parent


@lru_cache(maxsize=1)
def _blas_controller():
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()  # finds the loaded BLAS libraries once (numpy's, scipy's)


def _one_blas_thread():
    """A context in which BLAS runs on one thread: the factor's fronts are too small to share.

    The gemm of a front of a few hundred rows is over before threads pay for themselves, and
    on a loaded machine a threaded gemm waits for a core that another process holds.
    """
    return _blas_controller().limit(limits=1, user_api="blas")


def _spd_solve(indptr, indices, data, sn_ptr, parent, rhs):
    """Solve the free block by Cholesky along the dissection's tree (:mod:`._multifrontal`).

    The grid's own dissection is the factor's tree: one dense front per separator line, so
    the fill stays O(n log n) and the flops O(n^1.5), with BLAS doing the dense work.
    """
    bnd_ptr, bnd, stack = _mf.symbolic(indptr, indices, sn_ptr, parent)
    with _one_blas_thread():
        l_ptr, lf, bad = _mf.factor(indptr, indices, data, sn_ptr, parent, bnd_ptr, bnd, stack)
    if bad >= 0:
        raise PlateError("the held DOFs do not pin the plate down (the stiffness of the free "
                         "DOFs is not positive definite)")
    return _mf.solve(sn_ptr, bnd_ptr, bnd, l_ptr, lf, rhs)


def square_plate_centre(support, m, *, nu=0.3):
    """Centre deflection of the unit square plate under unit load on ``m x m`` elements.

    The textbook check of the element: with ``D = q = a = 1`` the exact
    values are 0.00406235 (simply supported) and 0.00126532 (clamped)
    (Timoshenko & Woinowsky-Krieger).

    Parameters
    ----------
    support : {"simply_supported", "clamped"}
    m : int
        Elements along a side, even (the centre is a grid point), >= 2.
    nu : float, keyword-only
        Poisson's ratio.

    Returns
    -------
    float
        ``w`` at the centre, in units of ``q a^4 / D``.
    """
    if not (isinstance(m, (int, np.integer)) and m >= 2 and m % 2 == 0):
        raise PlateError(f"m must be an even int >= 2, got {m!r}")
    n = int(m) + 1
    u = solve_plate((n, n), (1.0 / m, 1.0 / m), fixed_dofs=plate_edge_dofs((n, n), support),
                    load=1.0, nu=nu)
    return float(u[m // 2, m // 2, W])

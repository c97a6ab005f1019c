"""Scalar fields on the nodes: Gaussian bumps, distances, node extrema; the numba kernels and the PCG solver the FEM fields use."""

from __future__ import annotations

import numpy as np

from polygen._jit import njit, prange
from polygen.volume.datasets._base import DatasetError, _as_points, _seed


# ---------------------------------------------------------------- kernels
@njit
def _node_extrema_kernel(edges, values, is_max, is_min):
    # a node is a strict maximum when it is greater than every node it shares an edge with
    for e in range(edges.shape[0]):
        a = edges[e, 0]
        b = edges[e, 1]
        va = values[a]
        vb = values[b]
        if not va > vb:
            is_max[a] = False
        if not vb > va:
            is_max[b] = False
        if not va < vb:
            is_min[a] = False
        if not vb < va:
            is_min[b] = False


@njit(parallel=True)
def _gaussian_sum_kernel(points, centres, amps, sigmas, cutoff, out):
    # sum_k a_k (exp(-r^2 / 2 s_k^2) - exp(-c^2 / 2)) for r < c s_k: continuous, exactly 0 far away
    n = points.shape[0]
    k = centres.shape[0]
    floor = np.exp(-0.5 * cutoff * cutoff)
    for i in prange(n):
        x = points[i, 0]
        y = points[i, 1]
        z = points[i, 2]
        acc = 0.0
        for j in range(k):
            s = sigmas[j]
            r2max = (cutoff * s) ** 2
            dx = x - centres[j, 0]
            d2 = dx * dx
            if d2 >= r2max:
                continue
            dy = y - centres[j, 1]
            d2 += dy * dy
            if d2 >= r2max:
                continue
            dz = z - centres[j, 2]
            d2 += dz * dz
            if d2 >= r2max:
                continue
            acc += amps[j] * (np.exp(-0.5 * d2 / (s * s)) - floor)
        out[i] = acc


@njit
def _separated_kernel(points, candidates, min_dist, max_count, out):
    # greedy: take candidates in the given (seeded) order, keep those at least min_dist from all kept
    n_kept = 0
    d2min = min_dist * min_dist
    for c in range(candidates.shape[0]):
        if n_kept >= max_count:
            break
        i = candidates[c]
        ok = True
        for j in range(n_kept):
            q = out[j]
            dx = points[i, 0] - points[q, 0]
            dy = points[i, 1] - points[q, 1]
            dz = points[i, 2] - points[q, 2]
            if dx * dx + dy * dy + dz * dz < d2min:
                ok = False
                break
        if ok:
            out[n_kept] = i
            n_kept += 1
    return n_kept


@njit
def _csr_matvec(indptr, indices, data, x, out):
    # serial: called once per CG iteration, where waking a thread team costs more than it saves
    for i in range(indptr.size - 1):
        acc = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            acc += data[k] * x[indices[k]]
        out[i] = acc


@njit
def _dot(a, b):
    # serial on purpose: a fixed summation order keeps the solve bit-for-bit reproducible
    acc = 0.0
    for i in range(a.size):
        acc += a[i] * b[i]
    return acc


@njit
def _pcg_kernel(indptr, indices, data, b, x, rtol, maxiter):
    # conjugate gradients with the Jacobi (diagonal) preconditioner, from x; returns iterations
    n = b.size
    inv_diag = np.ones(n)
    for i in range(n):
        for k in range(indptr[i], indptr[i + 1]):
            if indices[k] == i and data[k] != 0.0:
                inv_diag[i] = 1.0 / data[k]
    r = np.empty(n)
    _csr_matvec(indptr, indices, data, x, r)
    for i in range(n):
        r[i] = b[i] - r[i]
    z = r * inv_diag
    p = z.copy()
    q = np.empty(n)
    rz = _dot(r, z)
    bnorm = np.sqrt(_dot(b, b))
    tol = rtol * (bnorm if bnorm > 0.0 else 1.0)
    for it in range(maxiter):
        if np.sqrt(_dot(r, r)) <= tol:
            return it
        _csr_matvec(indptr, indices, data, p, q)
        alpha = rz / _dot(p, q)
        for i in range(n):
            x[i] += alpha * p[i]
            r[i] -= alpha * q[i]
            z[i] = r[i] * inv_diag[i]
        rz_new = _dot(r, z)
        beta = rz_new / rz
        rz = rz_new
        for i in range(n):
            p[i] = z[i] + beta * p[i]
    return -1


def _pcg(rtol=1e-10, maxiter=20000):
    """A ``skfem.solve`` solver: Jacobi-preconditioned CG in numba.

    scipy's ``cg`` would do, but its BLAS dot products spin threads that
    fight on a busy two-core machine (measured: 16 ms for one dot of 26k
    numbers under load, 3 us with one thread), and serial sums keep the
    result reproducible.
    """

    def solver(A, b, **kwargs):
        A = A.tocsr()
        A.sort_indices()
        x = np.zeros(A.shape[0])
        it = _pcg_kernel(
            A.indptr.astype(np.int64), A.indices.astype(np.int64), A.data.astype(np.float64),
            np.ascontiguousarray(b, dtype=np.float64), x, float(rtol), int(maxiter),
        )
        if it < 0:
            raise RuntimeError(f"PCG did not reach rtol={rtol} in {maxiter} iterations")
        return x

    return solver


# ---------------------------------------------------------- public helpers
def node_extrema(vol, field=None):
    """Node extrema of a scalar field: nodes strictly above (below) all edge neighbours.

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str, optional
        Field name; the volume's first field by default.

    Returns
    -------
    maxima, minima : (K,) int64
        Sorted node ids of the strict local maxima and minima. Nodes on a
        plateau (equal to a neighbour) are neither.
    """
    values = vol.scalars(field)
    edges = vol.edges
    is_max = np.ones(vol.n_points, np.bool_)
    is_min = np.ones(vol.n_points, np.bool_)
    _node_extrema_kernel(edges, values, is_max, is_min)
    return np.flatnonzero(is_max), np.flatnonzero(is_min)


def count_extrema(vol, field=None):
    """``(n_maxima, n_minima)`` of :func:`node_extrema`."""
    mx, mn = node_extrema(vol, field)
    return int(mx.size), int(mn.size)


def gaussian_field(points, *, n_bumps, seed=0, width=0.3, cutoff=5.0):
    """A seeded sum of Gaussian bumps of both signs.

    Parameters
    ----------
    points : (N, 3) float64
        Where to evaluate.
    n_bumps : int, keyword-only
        Number of bumps; centres are uniform in the bounding box of
        ``points``, amplitudes ``+-U(0.5, 1)``.
    seed : int, keyword-only
    width : float, keyword-only
        Standard deviation of each bump relative to the mean spacing
        ``(box volume / n_bumps) ** (1/3)``, jittered by ``U(0.7, 1.3)``.
    cutoff : float, keyword-only
        Each bump is shifted down by its value at ``cutoff`` standard
        deviations and clipped there, so the field stays continuous and is
        exactly zero far from every bump.

    Returns
    -------
    values : (N,) float64
    """
    points = _as_points(points)
    if int(n_bumps) < 1:
        raise DatasetError(f"n_bumps must be at least 1; got {n_bumps}")
    if not (width > 0 and cutoff > 0):
        raise DatasetError(f"width and cutoff must be positive; got width={width}, cutoff={cutoff}")
    n_bumps = int(n_bumps)
    rng = np.random.default_rng(_seed(seed))
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = np.maximum(hi - lo, 1e-12)
    centres = lo + rng.random((n_bumps, 3)) * span
    amps = rng.choice([-1.0, 1.0], n_bumps) * rng.uniform(0.5, 1.0, n_bumps)
    spacing = (np.prod(span) / n_bumps) ** (1.0 / 3.0)
    sigmas = width * spacing * rng.uniform(0.7, 1.3, n_bumps)
    out = np.empty(points.shape[0])
    _gaussian_sum_kernel(points, centres, amps, sigmas, float(cutoff), out)
    return out


def distance_origin(points):
    """The default eye for :func:`distance_field`: outside the box, below its low corner.

    ``lo - 0.25 * (hi - lo)`` for the bounding box ``[lo, hi]`` of
    ``points`` (N, 3); returns (3,) float64.
    """
    points = _as_points(points)
    lo, hi = points.min(axis=0), points.max(axis=0)
    return lo - 0.25 * (hi - lo)


def distance_field(points, origin=None):
    """Euclidean distance of each point from ``origin`` (thesis 7.8, equi-distance surfaces).

    Parameters
    ----------
    points : (N, 3) float64
    origin : (3,) float64, optional
        The eye; :func:`distance_origin` by default.

    Returns
    -------
    values : (N,) float64
    """
    points = _as_points(points)
    origin = distance_origin(points) if origin is None else np.asarray(origin, dtype=np.float64)
    if origin.shape != (3,) or not np.all(np.isfinite(origin)):
        raise DatasetError(f"origin must be 3 finite numbers; got {origin!r}")
    return np.sqrt(((points - origin) ** 2).sum(axis=1))

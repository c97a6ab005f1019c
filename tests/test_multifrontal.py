"""The multifrontal Cholesky of the plate solve (polygen.mesh2d._multifrontal).

Oracles: dense ``numpy.linalg`` on the same matrix (factor and solution),
SuperLU on the plate's own systems, and matrices that are not positive
definite or trees that do not separate the matrix, which must be reported.
"""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypothesis import given, settings
from hypothesis import strategies as st

from polygen.mesh2d import _multifrontal as mf
from polygen.mesh2d.plate import _nested_dissection, assemble_plate, solve_plate


def grid_matrix(nx, ny, rng, shift=0.1):
    """A random SPD matrix with the 9-point coupling of an nx x ny grid, in ND order.

    Returns the CSC matrix (full, symmetric) and the dissection's ``(ptr, parent)``.
    """
    order, ptr, parent = _nested_dissection(nx, ny, 3)
    n = nx * ny
    new = np.empty(n, dtype=np.int64)
    new[order] = np.arange(n)
    j, i = np.divmod(np.arange(n), nx)
    rows, cols = [], []
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            ok = (i + di >= 0) & (i + di < nx) & (j + dj >= 0) & (j + dj < ny)
            p = np.flatnonzero(ok)
            rows.append(new[p])
            cols.append(new[(j[p] + dj) * nx + i[p] + di])
    r, c = np.concatenate(rows), np.concatenate(cols)
    w = rng.uniform(-1.0, 1.0, len(r))
    a = sp.coo_matrix((w, (r, c)), shape=(n, n)).tocsc()
    a = a + a.T
    # diagonally dominant, so positive definite
    a = a + sp.diags(np.asarray(abs(a).sum(axis=1)).ravel() + shift)
    a = sp.csc_matrix(a)
    a.sort_indices()
    return a, np.asarray(ptr), np.asarray(parent)


def run(a, ptr, parent, rhs):
    bp, bnd, stack = mf.symbolic(a.indptr.astype(np.int64), a.indices.astype(np.int64),
                                 ptr, parent)
    lp, lf, bad = mf.factor(a.indptr.astype(np.int64), a.indices.astype(np.int64), a.data,
                            ptr, parent, bp, bnd, stack)
    return bad, (mf.solve(ptr, bp, bnd, lp, lf, rhs) if bad < 0 else None), (bp, bnd, lp, lf)


@settings(max_examples=40, deadline=None)
@given(nx=st.integers(1, 23), ny=st.integers(1, 23), seed=st.integers(0, 2**31))
def test_solution_equals_dense_solve(nx, ny, seed):
    rng = np.random.default_rng(seed)
    a, ptr, parent = grid_matrix(nx, ny, rng)
    rhs = rng.standard_normal(a.shape[0])
    bad, x, _ = run(a, ptr, parent, rhs)
    assert bad == -1
    np.testing.assert_allclose(x, np.linalg.solve(a.toarray(), rhs), rtol=1e-9, atol=1e-9)


def test_factor_is_the_cholesky_factor():
    # the stored blocks, scattered back, are numpy's Cholesky factor of the same matrix
    rng = np.random.default_rng(3)
    a, ptr, parent = grid_matrix(13, 11, rng)
    bad, _, (bp, bnd, lp, lf) = run(a, ptr, parent, np.zeros(a.shape[0]))
    assert bad == -1
    n = a.shape[0]
    full = np.zeros((n, n))
    for k in range(len(parent)):
        s0, s1 = ptr[k], ptr[k + 1]
        s, b = s1 - s0, bnd[bp[k]:bp[k + 1]]
        block = lf[lp[k]:lp[k + 1]]
        full[s0:s1, s0:s1] = np.tril(block[:s * s].reshape(s, s))
        full[b, s0:s1] = block[s * s:].reshape(s, len(b)).T
    np.testing.assert_allclose(full, np.linalg.cholesky(a.toarray()), atol=1e-12)


@pytest.mark.parametrize("where", ["leaf", "root"])
def test_a_matrix_that_is_not_positive_definite_is_reported(where):
    rng = np.random.default_rng(5)
    a, ptr, parent = grid_matrix(12, 12, rng)
    k = 0 if where == "leaf" else len(parent) - 1
    i = ptr[k]
    a = sp.lil_matrix(a)
    a[i, i] = -1.0
    a = sp.csc_matrix(a)
    a.sort_indices()
    bad, _, _ = run(a, ptr, parent, np.ones(a.shape[0]))
    assert bad == k


def test_a_tree_that_does_not_separate_the_matrix_is_refused():
    # two leaves coupled to each other directly, under one root
    a = sp.csc_matrix(np.array([[4.0, 1.0, 0.0], [1.0, 4.0, 1.0], [0.0, 1.0, 4.0]]))
    ptr = np.array([0, 1, 2, 3], dtype=np.int64)
    parent = np.array([2, 2, -1], dtype=np.int64)
    with pytest.raises(ValueError, match="separate"):
        mf.symbolic(a.indptr.astype(np.int64), a.indices.astype(np.int64), ptr, parent)
    ok = np.array([1, 2, -1], dtype=np.int64)  # a chain: 0 -> 1 -> 2
    bad, x, _ = run(a, ptr, ok, np.array([1.0, 2.0, 3.0]))
    assert bad == -1
    np.testing.assert_allclose(x, np.linalg.solve(a.toarray(), [1.0, 2.0, 3.0]))


@settings(max_examples=15, deadline=None)
@given(nx=st.integers(2, 40), ny=st.integers(2, 40), seed=st.integers(0, 2**31),
       frac=st.floats(0.02, 0.6))
def test_plate_solve_equals_superlu(nx, ny, seed, frac):
    # the plate's own systems, with random held points and values, against SuperLU on the
    # assembled global matrix
    rng = np.random.default_rng(seed)
    n = nx * ny
    held = rng.choice(n, size=max(3, int(frac * n)), replace=False)
    # three held points not on a line pin the plate
    held = np.unique(np.concatenate([held, [0, nx - 1, n - 1]]))
    vals = rng.uniform(0.5, 2.0, len(held))
    u = solve_plate((ny, nx), (0.3, 0.7), fixed_dofs=3 * held, fixed_values=vals)
    k = assemble_plate((ny, nx), (0.3, 0.7)).tocsc()
    fixed = 3 * held
    free = np.setdiff1d(np.arange(3 * n), fixed)
    ref = np.zeros(3 * n)
    ref[fixed] = vals
    if len(free):
        ref[free] = spla.spsolve(k[free][:, free], -(k[free][:, fixed] @ vals))
    np.testing.assert_allclose(u.ravel(), ref, rtol=1e-7, atol=1e-9 * np.abs(ref).max())

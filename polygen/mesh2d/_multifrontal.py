"""Sparse Cholesky along a given elimination tree of supernodes (multifrontal).

The plate solve of chapter 4 (:mod:`polygen.mesh2d.plate`) factors one
symmetric positive definite matrix per polygon: a grid's stiffness, ordered
by nested dissection.  SuperLU, a general LU, took 1.77 s to factor it on
200 x 200 points where this factor takes 0.54 s (same matrix and order, same
run, ``benchmarks/results/intensity_mesh_plate.json``): LU does twice the
work of Cholesky, and its supernodes do not follow the dissection.  Here the caller's own
dissection tree is the factor's tree, so every separator is one dense front:

* each supernode ``k`` owns the unknowns ``sn_ptr[k]:sn_ptr[k + 1]`` (the
  supernodes in postorder, so a subtree's unknowns are contiguous and come
  before its ancestors');
* its front is those unknowns followed by its *boundary*: the later unknowns
  that the matrix or a child's boundary couples to them
  (:func:`symbolic`);
* :func:`factor` assembles the front from the matrix and the children's
  update matrices (extend-add), eliminates the supernode's unknowns by
  dense Cholesky and passes the Schur complement to the parent, through a
  stack (in postorder a node's children are the top of it).

The dense work calls LAPACK and BLAS through numba's ``np.linalg`` and
``np.dot``: the pivot block by ``potrf``, ``L21^T`` by a blocked triangular
solve whose bulk is ``gemm`` (numba has no ``trsm``), the update by one
``gemm``.  The fronts are many and small, so the caller runs :func:`factor`
with BLAS on one thread (:func:`polygen.mesh2d.plate._one_blas_thread`): a
threaded ``gemm`` on them made the same factor 13.5 s on a loaded 2-core
machine.  The triangular solves of :func:`solve` are numba loops over the
factor (its size, not its cube).

This is the textbook multifrontal method (Duff & Reid 1983; Liu, "The
multifrontal method for sparse matrix solution", SIAM Review 1992) with the
tree given rather than found.
"""

from __future__ import annotations

import numpy as np

from polygen._jit import njit

__all__ = ["symbolic", "factor", "solve", "NotPositiveDefinite"]


class NotPositiveDefinite(ValueError):
    """A front's pivot block was not positive definite: the matrix is not SPD."""


@njit
def _children(parent):
    """CSR of each supernode's children (in increasing order)."""
    nsn = len(parent)
    ptr = np.zeros(nsn + 1, dtype=np.int64)
    for k in range(nsn):
        if parent[k] >= 0:
            ptr[parent[k] + 1] += 1
    for k in range(nsn):
        ptr[k + 1] += ptr[k]
    out = np.empty(ptr[nsn], dtype=np.int64)
    fill = ptr[:-1].copy()
    for k in range(nsn):
        p = parent[k]
        if p >= 0:
            out[fill[p]] = k
            fill[p] += 1
    return ptr, out


@njit
def symbolic(indptr, indices, sn_ptr, parent):
    """The boundary of every supernode's front.

    Parameters
    ----------
    indptr, indices : CSC structure of the (full, symmetric) matrix
    sn_ptr : (nsn + 1,) int64
        Unknowns of supernode ``k``: ``sn_ptr[k]:sn_ptr[k + 1]`` (postorder).
    parent : (nsn,) int64
        Parent supernode, -1 for a root; a parent comes after its children.

    Returns
    -------
    bnd_ptr : (nsn + 1,) int64
    bnd : (total,) int64
        Boundary of supernode ``k``, sorted: ``bnd[bnd_ptr[k]:bnd_ptr[k + 1]]``.
    stack : int64
        Doubles the update stack of :func:`factor` needs at most.
    """
    nsn = len(parent)
    n = sn_ptr[nsn]
    for k in range(nsn):
        if parent[k] >= 0 and parent[k] <= k:
            raise ValueError("parent: a supernode's parent must come after it")
        if sn_ptr[k + 1] < sn_ptr[k]:
            raise ValueError("sn_ptr: decreasing")
    cptr, ch = _children(parent)
    mark = np.full(n, -1, dtype=np.int64)
    bnd_ptr = np.zeros(nsn + 1, dtype=np.int64)
    bnd = np.empty(max(16, 4 * n), dtype=np.int64)
    tmp = np.empty(n, dtype=np.int64)
    depth = 0
    peak = 0
    for k in range(nsn):
        a, b = sn_ptr[k], sn_ptr[k + 1]
        t = 0
        for j in range(a, b):
            for p in range(indptr[j], indptr[j + 1]):
                r = indices[p]
                if r >= b and mark[r] != k:
                    mark[r] = k
                    tmp[t] = r
                    t += 1
        for q in range(cptr[k], cptr[k + 1]):
            c = ch[q]
            for p in range(bnd_ptr[c], bnd_ptr[c + 1]):
                r = bnd[p]
                if r >= b and mark[r] != k:
                    mark[r] = k
                    tmp[t] = r
                    t += 1
            m = bnd_ptr[c + 1] - bnd_ptr[c]
            depth -= m * m
        # the tree must be an elimination tree of the matrix: what a supernode couples to
        # later must belong to its ancestors, so to its parent's front (else the update
        # would be lost); by induction up the tree it is enough to check the parent
        lo = sn_ptr[parent[k]] if parent[k] >= 0 else n
        for i in range(t):
            if tmp[i] < lo:
                raise ValueError("the tree does not separate the matrix: a supernode is "
                                 "coupled to one that is not its ancestor")
        start = bnd_ptr[k]
        if start + t > len(bnd):
            grown = np.empty(2 * (start + t), dtype=np.int64)
            grown[:start] = bnd[:start]
            bnd = grown
        bnd[start:start + t] = np.sort(tmp[:t])
        bnd_ptr[k + 1] = start + t
        depth += t * t
        peak = max(peak, depth)
    return bnd_ptr, bnd[:bnd_ptr[nsn]].copy(), peak


@njit
def factor(indptr, indices, data, sn_ptr, parent, bnd_ptr, bnd, stack_size):
    """Numeric factorisation: ``A = L L^T`` by supernodes.

    Returns
    -------
    l_ptr : (nsn + 1,) int64
        Supernode ``k``'s factor occupies ``L[l_ptr[k]:l_ptr[k + 1]]``: its
        ``s x s`` lower triangle ``L11`` (row-major), then ``L21^T``
        (``s x m``, row-major), ``s`` its unknowns and ``m`` its boundary.
    L : (l_ptr[-1],) float64
    bad : int64
        -1, or the first supernode whose pivot block was not positive
        definite (the factor is then incomplete).

    The front is held as three contiguous blocks (``A11`` in a work buffer,
    ``A12`` in its place in ``L``, the update ``A22`` in a second work
    buffer), so that BLAS gets contiguous operands and the fronts are not
    allocated one by one: on a VM every new page costs a fault, about 1 ms
    per MB here (the BLAS calls' results still are, and are reused by malloc).
    """
    nsn = len(parent)
    n = sn_ptr[nsn]
    cptr, ch = _children(parent)
    l_ptr = np.zeros(nsn + 1, dtype=np.int64)
    smax, mmax = 0, 0
    for k in range(nsn):
        s = sn_ptr[k + 1] - sn_ptr[k]
        m = bnd_ptr[k + 1] - bnd_ptr[k]
        l_ptr[k + 1] = l_ptr[k] + s * (s + m)
        smax, mmax = max(smax, s), max(mmax, m)
    L = np.empty(l_ptr[nsn], dtype=np.float64)
    stack = np.empty(stack_size, dtype=np.float64)
    w11 = np.empty(smax * smax, dtype=np.float64)
    w22 = np.empty(mmax * mmax, dtype=np.float64)
    top = 0
    loc = np.full(n, -1, dtype=np.int64)
    for k in range(nsn):
        a, b = sn_ptr[k], sn_ptr[k + 1]
        s = b - a
        bp = bnd_ptr[k]
        m = bnd_ptr[k + 1] - bp
        for i in range(s):
            loc[a + i] = i
        for i in range(m):
            loc[bnd[bp + i]] = s + i
        o = l_ptr[k]
        a11 = w11[:s * s].reshape(s, s)
        a12 = L[o + s * s:o + s * s + s * m].reshape(s, m)
        a22 = w22[:m * m].reshape(m, m)
        a11[:] = 0.0
        a12[:] = 0.0
        a22[:] = 0.0
        for jj in range(s):
            j = a + jj
            for p in range(indptr[j], indptr[j + 1]):
                r = indices[p]
                if r >= a:
                    li = loc[r]
                    if li < s:
                        a11[li, jj] = data[p]
                    else:
                        a12[jj, li - s] = data[p]
        # the children's updates are the top of the stack, the last child on top; only their
        # upper triangles are kept (symmetric), and as a child's boundary is sorted and the
        # front's numbering increasing, an upper entry lands in A11, A12 or A22's upper triangle
        for q in range(cptr[k + 1] - 1, cptr[k] - 1, -1):
            c = ch[q]
            cp = bnd_ptr[c]
            mc = bnd_ptr[c + 1] - cp
            top -= mc * mc
            for i in range(mc):
                gi = loc[bnd[cp + i]]
                row = top + i * mc
                for jx in range(i, mc):
                    gj = loc[bnd[cp + jx]]
                    v = stack[row + jx]
                    if gj < s:
                        a11[gi, gj] += v
                        if gj != gi:
                            a11[gj, gi] += v
                    elif gi < s:
                        a12[gi, gj - s] += v
                    else:
                        a22[gi - s, gj - s] += v
        if s > 0:
            l11 = _cholesky_or_none(a11)
            if l11.shape[0] != s:
                return l_ptr, L, k
            for i in range(s):
                for jx in range(i + 1):
                    L[o + i * s + jx] = l11[i, jx]
            if m > 0:
                _lower_solve_rows(l11, a12)  # A12 := L11^-1 A12 = L21^T, in place in L
                _upper_update(a22, a12)
        if m > 0:
            stack[top:top + m * m] = w22[:m * m]
            top += m * m
        for i in range(s):
            loc[a + i] = -1
        for i in range(m):
            loc[bnd[bp + i]] = -1
    return l_ptr, L, -1


@njit
def _upper_update(a22, x):
    """The upper triangle of ``a22 -= x^T x`` (``x`` s x m), by blocks of rows: half a ``gemm``."""
    m = x.shape[1]
    nb = 96
    for j0 in range(0, m, nb):
        j1 = min(j0 + nb, m)
        r = np.ascontiguousarray(x[:, j0:])
        a22[j0:j1, j0:] -= np.dot(r[:, :j1 - j0].T.copy(), r)


@njit
def _lower_solve_rows(l11, x):
    """``x := l11^-1 x`` in place, ``l11`` lower triangular (s x s), ``x`` (s x m) row-major.

    Blocked so that most of the work is one ``gemm`` per block of rows.
    """
    s = l11.shape[0]
    nb = 64
    for i0 in range(0, s, nb):
        i1 = min(i0 + nb, s)
        if i0 > 0:
            x[i0:i1] -= np.dot(np.ascontiguousarray(l11[i0:i1, :i0]), x[:i0])
        m = x.shape[1]
        for i in range(i0, i1):
            xi = x[i]
            for j in range(i0, i):
                f = l11[i, j]
                xj = x[j]
                for c in range(m):
                    xi[c] -= f * xj[c]
            d = 1.0 / l11[i, i]
            for c in range(m):
                xi[c] *= d


@njit
def _cholesky_or_none(d):
    """Lower Cholesky factor of ``d``, or a 0 x 0 array if it is not positive definite.

    An unblocked left-looking factor for small blocks (no LAPACK call's overhead);
    ``np.linalg.cholesky`` (LAPACK ``potrf``) for larger ones.
    """
    s = d.shape[0]
    if s > 48:
        try:
            return np.linalg.cholesky(d)
        except Exception:  # numba: LinAlgError("Matrix is not positive definite.")
            return np.empty((0, 0))
    l11 = np.zeros((s, s))
    for j in range(s):
        v = d[j, j]
        for t in range(j):
            v -= l11[j, t] * l11[j, t]
        if not v > 0.0:
            return np.empty((0, 0))
        v = np.sqrt(v)
        l11[j, j] = v
        for i in range(j + 1, s):
            w = d[i, j]
            for t in range(j):
                w -= l11[i, t] * l11[j, t]
            l11[i, j] = w / v
    return l11


@njit
def solve(sn_ptr, bnd_ptr, bnd, l_ptr, L, rhs):
    """``x`` with ``L L^T x = rhs``, from :func:`factor`'s output."""
    nsn = len(sn_ptr) - 1
    y = rhs.astype(np.float64).copy()
    for k in range(nsn):  # forward: L y = rhs
        a = sn_ptr[k]
        s = sn_ptr[k + 1] - a
        bp = bnd_ptr[k]
        m = bnd_ptr[k + 1] - bp
        o = l_ptr[k]
        for i in range(s):
            v = y[a + i]
            for jx in range(i):
                v -= L[o + i * s + jx] * y[a + jx]
            y[a + i] = v / L[o + i * s + i]
        o2 = o + s * s
        for i in range(s):
            yi = y[a + i]
            row = o2 + i * m
            for jx in range(m):
                y[bnd[bp + jx]] -= L[row + jx] * yi
    for k in range(nsn - 1, -1, -1):  # backward: L^T x = y
        a = sn_ptr[k]
        s = sn_ptr[k + 1] - a
        bp = bnd_ptr[k]
        m = bnd_ptr[k + 1] - bp
        o = l_ptr[k]
        o2 = o + s * s
        for i in range(s):
            v = y[a + i]
            row = o2 + i * m
            for jx in range(m):
                v -= L[row + jx] * y[bnd[bp + jx]]
            y[a + i] = v
        for i in range(s - 1, -1, -1):
            v = y[a + i]
            for jx in range(i + 1, s):
                v -= L[o + jx * s + i] * y[a + jx]
            y[a + i] = v / L[o + i * s + i]
    return y

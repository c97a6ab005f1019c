"""The FEM fields: steady heat conduction on the meshed parts, solved with scikit-fem."""

from __future__ import annotations

import numpy as np

from polygen.volume.datasets._base import _seed
from polygen.volume.datasets.fields import _gaussian_sum_kernel, _pcg, _separated_kernel


# ----------------------------------------------------------- FEM solve
# VTK hexahedron node order -> scikit-fem MeshHex1 order (skfem.io.meshio.INV_HEX_MAPPING[:8])
_VTK_TO_SKFEM_HEX = np.array([0, 4, 3, 1, 7, 5, 2, 6])


def _heat_field(points, cells, part, *, spacing, n_sources, seed, noise=0.0, progress=None):
    """Steady heat conduction -lap u = f on the part, u fixed on its Dirichlet patches.

    ``f`` is ``n_sources`` Gaussian sources and sinks (+-), centred on nodes at
    least 5 sigma apart and 2 sigma inside the part, plus ``noise`` times a
    standard normal load on every node. Natural (insulated) boundary elsewhere.
    """
    from scipy.spatial import cKDTree
    from skfem import (
        Basis,
        BilinearForm,
        ElementHex1,
        ElementTetP1,
        LinearForm,
        MeshHex1,
        MeshTet1,
        asm,
        condense,
        solve,
    )
    from skfem.helpers import dot, grad

    rng = np.random.default_rng(_seed(seed))
    if cells.shape[1] == 4:
        mesh = MeshTet1(np.ascontiguousarray(points.T), np.ascontiguousarray(cells.T.astype(np.int32)))
        basis = Basis(mesh, ElementTetP1(), intorder=2)
    else:
        t = np.ascontiguousarray(cells[:, _VTK_TO_SKFEM_HEX].T.astype(np.int32))
        mesh = MeshHex1(np.ascontiguousarray(points.T), t)
        basis = Basis(mesh, ElementHex1(), intorder=2)
    _tick(progress, "assemble")

    @BilinearForm
    def laplace(u, v, w):
        return dot(grad(u), grad(v))

    @LinearForm
    def load(v, w):
        return w.s * v

    # Dirichlet patches: nodes_satisfying on geometric predicates (no facet search)
    u = np.zeros(mesh.nvertices)
    dirichlet = []
    for test, value in part.patches:
        nodes = mesh.nodes_satisfying(test)
        u[nodes] = value
        dirichlet.append(nodes)
    dirichlet = np.unique(np.concatenate(dirichlet))
    if dirichlet.size == 0:  # pragma: no cover - every part has patches on its surface
        raise RuntimeError(f"no Dirichlet nodes found on {part.name}")

    # sources wide enough to span a few cells (spacing = mesh edge length), narrow enough to fit
    volume = float(np.abs(basis.dx).sum())
    sigma = max(0.8 * spacing, 0.1 * (volume / max(n_sources, 1)) ** (1.0 / 3.0))
    # centres at least 2 sigma inside the part, so that the extrema they make are interior nodes
    from polygen.volume.mesh import UnstructuredVolume

    surface = np.unique(UnstructuredVolume(points, cells, validate=False).boundary_face_nodes)
    dist = cKDTree(points[surface]).query(points, k=1)[0]
    candidates = np.flatnonzero(dist > 2.0 * sigma)
    candidates = candidates[rng.permutation(candidates.size)]
    chosen = np.empty(max(n_sources, 1), np.int64)
    n_chosen = _separated_kernel(points, candidates, 5.0 * sigma, n_sources, chosen)
    centres = points[chosen[:n_chosen]]
    signs = np.where(np.arange(n_chosen) % 2 == 0, 1.0, -1.0)  # as many sinks as sources
    amps = signs * rng.uniform(0.7, 1.3, n_chosen) / sigma**2
    s = np.empty(points.shape[0])
    _gaussian_sum_kernel(points, centres, amps, np.full(n_chosen, sigma), 5.0, s)

    K = asm(laplace, basis)
    f = asm(load, basis, s=basis.interpolate(s))
    if noise:
        # a random heat load on every node, scaled by the largest nodal load of the sources
        scale = noise * np.abs(f).max()
        f = f + scale * rng.standard_normal(f.size)
    _tick(progress, "solve")
    x = solve(*condense(K, f, x=u, D=dirichlet), solver=_pcg(rtol=1e-10))
    return np.asarray(x, dtype=np.float64)


def _tick(bar, stage):
    # the previous stage (if any) is done; label the one that starts
    if bar is not None:
        if bar.postfix:
            bar.update(1)
        bar.set_postfix_str(stage)

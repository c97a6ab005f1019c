"""The 12-DOF rectangular (ACM) plate element and the element-size grid (thesis 4.5-4.10).

Oracles: the textbook plates (Timoshenko & Woinowsky-Krieger: centre
deflection of a square plate under uniform load q, 0.00406235 q a^4 / D
simply supported, 0.00126532 q a^4 / D clamped), the element's patch test
(a quadratic w is reproduced with its exact energy), rigid-body modes, and
a brute-force inverse-distance weighting (4.5).
"""

import numpy as np
import pytest
import scipy.sparse as sp

from polygen.mesh2d import GridSize
from polygen.mesh2d.plate import (
    PlateError,
    _free_system,
    _pinned,
    assemble_plate,
    plate_edge_dofs,
    plate_element_load,
    plate_element_stiffness,
    solve_plate,
    square_plate_centre,
)
from polygen.mesh2d.size_grid import assign_grid_sizes, element_size_grid, grid_lattice

TIMOSHENKO = {"simply_supported": 0.00406235, "clamped": 0.00126532}


def _centre_full(support, m):
    """Centre deflection of the unit square plate (D = q = 1) on m x m elements."""
    n = m + 1
    u = solve_plate((n, n), (1.0 / m, 1.0 / m), fixed_dofs=plate_edge_dofs((n, n), support),
                    load=1.0)
    return u[m // 2, m // 2, 0]


def _centre_quarter(support, m):
    """The same on a quarter plate of m x m elements (symmetry lines: zero normal slope)."""
    n = m + 1
    j, i = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    node = j * n + i
    held = [3 * node[(i == 0) | (j == 0)]]  # the two supported edges: w = 0
    if support == "clamped":
        held += [3 * node[(i == 0) | (j == 0)] + 1, 3 * node[(i == 0) | (j == 0)] + 2]
    else:
        held += [3 * node[i == 0] + 2, 3 * node[j == 0] + 1]
    held += [3 * node[i == n - 1] + 1, 3 * node[j == n - 1] + 2]  # symmetry: w_x, w_y = 0
    u = solve_plate((n, n), (0.5 / m, 0.5 / m), fixed_dofs=np.unique(np.concatenate(held)),
                    load=1.0)
    return u[-1, -1, 0]


# -- the element ---------------------------------------------------------------
@pytest.mark.parametrize("hx,hy", [(1.0, 1.0), (0.3, 0.7)])
def test_element_symmetric_with_three_rigid_modes(hx, hy):
    k = plate_element_stiffness(hx, hy)
    np.testing.assert_allclose(k, k.T, atol=1e-12 * np.abs(k).max())
    ev = np.linalg.eigvalsh(k)
    # w = 1, x, y cost no energy; every other mode does
    assert np.sum(ev < 1e-9 * ev.max()) == 3
    assert ev.min() > -1e-9 * ev.max()


def _nodal(fun, grad, xs, ys):
    return np.concatenate([[fun(x, y), *grad(x, y)] for x, y in zip(xs, ys)])


@pytest.mark.parametrize("nu", [0.0, 0.3])
def test_patch_test_quadratic_energy_exact(nu):
    """ACM passes the patch test: a quadratic w is in the element with its exact energy."""
    hx, hy = 0.4, 0.25
    a, b, c = 1.3, -0.7, 0.4  # w = a x^2 + b x y + c y^2
    xs, ys = [0, hx, hx, 0], [0, 0, hy, hy]

    u = _nodal(lambda x, y: a * x * x + b * x * y + c * y * y,
               lambda x, y: (2 * a * x + b * y, b * x + 2 * c * y), xs, ys)
    k = plate_element_stiffness(hx, hy, nu=nu)
    eps = np.array([-2 * a, -2 * c, 2 * b])
    d = np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])
    np.testing.assert_allclose(0.5 * u @ k @ u, 0.5 * eps @ d @ eps * hx * hy, rtol=1e-12)


def test_element_load_sums_to_area():
    f = plate_element_load(0.3, 0.5)
    # sum of the w shape functions is 1 everywhere: the w loads add up to the area
    assert f[0::3].sum() == pytest.approx(0.15, rel=1e-12)
    # symmetric cell: equal corner loads, antisymmetric slope loads
    np.testing.assert_allclose(f[0::3], 0.15 / 4, rtol=1e-12)


def test_assembly_matches_element_sum():
    k = assemble_plate((3, 4), (0.5, 0.25)).toarray()
    ke = plate_element_stiffness(0.5, 0.25)
    ref = np.zeros_like(k)
    for j in range(2):
        for i in range(3):
            corners = [j * 4 + i, j * 4 + i + 1, (j + 1) * 4 + i + 1, (j + 1) * 4 + i]
            dofs = [3 * c + r for c in corners for r in range(3)]
            ref[np.ix_(dofs, dofs)] += ke
    np.testing.assert_allclose(k, ref, atol=1e-12 * np.abs(ke).max())



def _element_by_element(shape, spacing):
    """The global stiffness summed one cell at a time (the straightforward assembly)."""
    ny, nx = shape
    ke = plate_element_stiffness(*spacing)
    k = np.zeros((3 * nx * ny, 3 * nx * ny))
    for j in range(ny - 1):
        for i in range(nx - 1):
            corners = [j * nx + i, j * nx + i + 1, (j + 1) * nx + i + 1, (j + 1) * nx + i]
            dofs = [3 * c + r for c in corners for r in range(3)]
            k[np.ix_(dofs, dofs)] += ke
    return ke, k


@pytest.mark.parametrize("shape", [(5, 6), (2, 2), (4, 2)])
def test_free_system_matches_element_by_element(shape):
    """The CSC kernel: K[free, free] in the solver's order and -K[free, held] u[held]."""
    ny, nx = shape
    rng = np.random.default_rng(3)
    ke, k = _element_by_element(shape, (0.7, 0.3))
    n = 3 * nx * ny
    fixed = np.sort(rng.choice(n, n // 3, replace=False))
    u = np.zeros(n)
    u[fixed] = rng.normal(size=len(fixed))
    free = np.setdiff1d(np.arange(n), fixed)
    order = rng.permutation(free).astype(np.int64)
    new = np.full(n, -1, dtype=np.int32)
    new[order] = np.arange(len(order), dtype=np.int32)
    indptr, indices, data, rhs = _free_system(ke, nx, ny, new, order, u)
    for c in range(len(order)):  # CSC rows sorted within each column, no duplicates
        assert np.all(np.diff(indices[indptr[c]:indptr[c + 1]]) > 0)
    kff = sp.csc_matrix((data, indices, indptr), shape=(len(order),) * 2).toarray()
    tol = 1e-12 * np.abs(ke).max()
    np.testing.assert_allclose(kff, k[np.ix_(order, order)], rtol=0, atol=tol)
    np.testing.assert_allclose(rhs, -k[np.ix_(order, fixed)] @ u[fixed], rtol=0,
                               atol=tol * np.abs(u).sum())


def test_pinned_matches_smallest_eigenvalue():
    """Exact rigid-mode rank test against the free block's spectrum, on random held sets."""
    ny, nx = 4, 5
    _, k = _element_by_element((ny, nx), (0.5, 0.8))
    n = 3 * nx * ny
    rng = np.random.default_rng(7)
    seen = set()
    cases = [3 * np.arange(nx), 3 * np.array([0, 6, 12]), 3 * np.array([0, 7, 13]),
             np.array([0, 3, 1]), np.array([0, 3, 2]), np.array([0, 2, 16])]
    cases += [np.sort(rng.choice(n, m, replace=False)) for m in (1, 2, 3, 3, 3, 4, 5)
              for _ in range(6)]
    for fixed in cases:
        free = np.setdiff1d(np.arange(n), fixed)
        lam = np.linalg.eigvalsh(k[np.ix_(free, free)])
        # rigid modes give roundoff eigenvalues (~1e-16 of the largest); a pinned plate's
        # smallest is >= 2e-5 of it in these cases
        pinned = lam[0] > 1e-10 * lam[-1]
        assert _pinned(fixed, nx) == pinned, fixed
        seen.add(pinned)
    assert seen == {True, False}

# -- textbook plates -------------------------------------------------------------
@pytest.mark.parametrize("support", ["simply_supported", "clamped"])
def test_textbook_plate_16x16_quarter(support):
    """16 x 16 elements on the quarter plate (the literature's convention): within 0.5 %."""
    w = _centre_quarter(support, 16)
    assert abs(w / TIMOSHENKO[support] - 1) < 0.005


def test_quarter_equals_full_plate():
    # the quarter plate of m elements is the full plate of 2m elements, by symmetry
    for support in TIMOSHENKO:
        assert _centre_quarter(support, 4) == pytest.approx(_centre_full(support, 8), rel=1e-9)


def test_simply_supported_full_16x16():
    w = _centre_full("simply_supported", 16)
    assert abs(w / TIMOSHENKO["simply_supported"] - 1) < 0.005


@pytest.mark.parametrize("support", ["simply_supported", "clamped"])
def test_convergence_is_second_order(support):
    ms = np.array([4, 8, 16, 32])
    err = np.array([abs(_centre_full(support, m) / TIMOSHENKO[support] - 1) for m in ms])
    slope = np.polyfit(np.log(1.0 / ms), np.log(err), 1)[0]
    assert 1.8 < slope < 2.2
    # O(h^2) with an O(h^4) remainder: Richardson's extrapolation of 16 and 32 lands on the
    # series value to the remainder, ~ (0.2 %)^2 (a few 1e-6), far inside 1e-4
    w16, w32 = _centre_full(support, 16), _centre_full(support, 32)
    assert abs((4 * w32 - w16) / 3 / TIMOSHENKO[support] - 1) < 1e-4


# -- solver input ----------------------------------------------------------------
def test_plane_through_held_points_is_exact():
    """A free plate held at points of a plane is that plane (zero bending energy)."""
    rng = np.random.default_rng(1)
    ny, nx = 9, 12
    held = rng.choice(nx * ny, 7, replace=False)
    j, i = np.divmod(held, nx)
    plane = lambda x, y: 0.5 + 0.2 * x - 0.3 * y  # noqa: E731
    u = solve_plate((ny, nx), (0.5, 0.4), fixed_dofs=3 * held,
                    fixed_values=plane(i * 0.5, j * 0.4))
    jj, ii = np.mgrid[0:ny, 0:nx]
    np.testing.assert_allclose(u[:, :, 0], plane(ii * 0.5, jj * 0.4), atol=1e-9)
    np.testing.assert_allclose(u[:, :, 1], 0.2, atol=1e-9)
    np.testing.assert_allclose(u[:, :, 2], -0.3, atol=1e-9)


def test_collinear_held_points_are_singular():
    # w held on one grid line: the plate may still rotate about it
    with pytest.raises(PlateError, match="pin"):
        solve_plate((5, 5), (1.0, 1.0), fixed_dofs=3 * np.arange(5), fixed_values=1.0)


@pytest.mark.parametrize("kw,msg", [
    (dict(shape=(1, 5)), "shape"),
    (dict(spacing=(0.0, 1.0)), "spacing"),
    (dict(nu=0.5), "nu"),
    (dict(fixed_dofs=[0, 0, 3, 6]), "repeated"),
    (dict(fixed_dofs=[0, 3, 10_000]), "outside"),
    (dict(load=np.nan), "load"),
])
def test_bad_input(kw, msg):
    args = dict(shape=(4, 4), spacing=(1.0, 1.0), fixed_dofs=[0, 3, 15, 45])
    args.update(kw)
    shape, spacing = args.pop("shape"), args.pop("spacing")
    with pytest.raises(PlateError, match=msg):
        solve_plate(shape, spacing, **args)


# -- the element-size grid -------------------------------------------------------
def test_grid_lattice_spans_bounds():
    o, h, (ny, nx) = grid_lattice((1.0, 2.0, 4.0, 3.0), 0.4)
    assert (ny, nx) == (4, 9)
    np.testing.assert_allclose(o + h * [nx - 1, ny - 1], [4.0, 3.0])
    assert h.max() <= 0.4
    assert grid_lattice((0, 0, 1, 1), (5, 3))[2] == (3, 5)
    for bad in (0.0, (1, 5), "x"):
        with pytest.raises(ValueError, match="grid"):
            grid_lattice((0, 0, 1, 1), bad)


def test_assign_matches_brute_force():
    rng = np.random.default_rng(3)
    pts = rng.uniform([0, 0], [3, 2], size=(40, 2))
    sz = rng.uniform(0.5, 2.0, size=40)
    o, h, shape = grid_lattice((0, 0, 3, 2), 0.5)
    got = assign_grid_sizes(pts, sz, o, h, shape)
    ny, nx = shape
    for j in range(ny):
        for i in range(nx):
            g = o + h * [i, j]
            # nodes in the four cells around grid point (i, j)
            cell = np.floor((pts - o) / h).astype(int)
            cell = np.minimum(cell, [nx - 2, ny - 2])
            near = (np.abs(cell[:, 0] + 0.5 - i) <= 0.5) & (np.abs(cell[:, 1] + 0.5 - j) <= 0.5)
            if not near.any():
                assert np.isnan(got[j, i])
                continue
            w = 1.0 / np.hypot(*(pts[near] - g).T)
            assert got[j, i] == pytest.approx((w * sz[near]).sum() / w.sum(), rel=1e-12)


def test_size_grid_holds_idw_and_bends_between():
    """Assigned grid points keep their (4.5) values; the others are the plate through them."""
    rng = np.random.default_rng(5)
    pts = np.vstack([[[0.1, 0.1], [4.9, 0.2], [0.2, 2.9], [4.8, 2.8]],
                     rng.uniform([0, 0], [5, 3], size=(6, 2))])
    sz = rng.uniform(0.5, 1.5, size=len(pts))
    g = element_size_grid(pts, sz, (0, 0, 5, 3), grid=0.25, clip=False)
    assert isinstance(g, GridSize)
    assert 0 < g.assigned.sum() < g.assigned.size
    idw = assign_grid_sizes(pts, sz, g.origin, g.spacing, g.values.shape)
    np.testing.assert_array_equal(g.assigned, np.isfinite(idw))
    np.testing.assert_allclose(g.values[g.assigned], idw[g.assigned], rtol=1e-12)
    held = np.flatnonzero(g.assigned.ravel())
    u = solve_plate(g.values.shape, g.spacing, fixed_dofs=3 * held,
                    fixed_values=idw.ravel()[held])
    np.testing.assert_allclose(g.values, u[:, :, 0], rtol=1e-12)
    clipped = element_size_grid(pts, sz, (0, 0, 5, 3), grid=0.25)
    assert clipped.values.min() >= sz.min() and clipped.values.max() <= sz.max()


def test_size_grid_constant_sizes():
    rng = np.random.default_rng(6)
    pts = rng.uniform([0, 0], [2, 1], size=(12, 2))
    g = element_size_grid(pts, np.full(12, 0.7), (0, 0, 2, 1), grid=0.1, clip=False)
    np.testing.assert_allclose(g.values, 0.7, rtol=1e-9)


def test_size_grid_bad_input():
    with pytest.raises(ValueError, match="sizes"):
        element_size_grid(np.zeros((3, 2)), [1.0, -1.0, 1.0], (0, 0, 1, 1), grid=0.5)
    with pytest.raises(ValueError, match="points"):
        element_size_grid(np.zeros((3, 3)), [1.0, 1.0, 1.0], (0, 0, 1, 1), grid=0.5)
    with pytest.raises(ValueError, match="bounds"):
        element_size_grid(np.zeros((3, 2)), [1.0, 1.0, 1.0], (0, 0, 0, 1), grid=0.5)


@pytest.mark.parametrize("support", list(TIMOSHENKO))
def test_square_plate_centre(support):
    """The package's helper is the full-plate solve above, and within 1 % of the textbook at 16."""
    assert square_plate_centre(support, 8) == _centre_full(support, 8)
    assert square_plate_centre(support, 16) == pytest.approx(TIMOSHENKO[support], rel=0.01)
    for bad in (3, 0, 2.0):
        with pytest.raises(PlateError, match="even int"):
            square_plate_centre(support, bad)


def test_factor_runs_on_one_blas_thread(monkeypatch):
    # the factor's fronts are small: a threaded gemm on them only waits (13.5 s against
    # 0.54 s on 200 x 200 on a loaded 2-core machine, results/intensity_mesh_plate.json), so
    # solve_plate pins BLAS to one thread around the factor, and gives the threads back after
    from threadpoolctl import threadpool_info

    from polygen.mesh2d import plate

    def blas_threads():
        return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]

    before = blas_threads()
    assert before  # numpy and scipy bring their BLAS
    seen = []
    factor = plate._mf.factor

    def spy(*args):
        seen.append(blas_threads())
        return factor(*args)

    monkeypatch.setattr(plate._mf, "factor", spy)
    ny, nx = 9, 11
    held = np.array([0, nx - 1, nx * ny - 1, nx * (ny - 1)])
    u = solve_plate((ny, nx), (0.5, 0.4), fixed_dofs=3 * held, fixed_values=[1.0, 2.0, 3.0, 4.0])
    assert np.all(np.isfinite(u))
    assert seen == [[1] * len(before)]
    assert blas_threads() == before

"""Per-component isosurfaces (issue 19, Deliver 3): ``IsoSurface.components()`` against analytic shapes.

Grids: the surfaces are isosurfaces of distance fields on tetrahedralised grids of spacing ``h``. The
piecewise-linear interpolant of a distance field whose level set has principal curvature ``<= 1/r``
differs from it by at most ``(1/2)(1/r) R_c**2`` in a cell with circumradius ``R_c <= (sqrt 3 / 2) h``
(a grid cube's tetrahedra), so the surface moves by ``delta <= 3 h**2 / (8 r)`` (the gradient has unit
length). That moves the area by ``<= 2 delta / r = 3 h**2 / (4 r**2)`` and the volume by
``<= 3 delta / r = 9 h**2 / (8 r**2)``. With ``h = r / 12.5`` these are 0.48 % and 0.72 %: within the
issue's 0.5 % (area) and 1 % (volume). (The facets' tilt adds area of the same order with the
opposite sign; the bound does not cover it, the measurement below checks it.)
"""

import numpy as np
import pytest

from _surfaces import grid_volume
from polygen.volume import UnstructuredVolume
from polygen.volume.isosurface import extract
from polygen.volume.surface import component_table

AREA_TOL = 0.005  # issue 19, Must show
VOLUME_TOL = 0.01
R_OVER_H = 12.5  # from the bound in the module docstring


def _box(lo, hi, h):
    """A tetrahedralised grid of spacing ``h`` covering ``lo..hi`` (snapped outwards to whole cells)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    dims = np.ceil((hi - lo) / h - 1e-9).astype(int) + 1
    return grid_volume(tuple(int(d) for d in dims), (h, h, h), tuple(lo))


def _delta(h, r):
    """How far (at most) the piecewise-linear surface lies from the true one: 3 h^2 / (8 r)."""
    return 3 * h * h / (8 * r)


def _check_table(iso, c):
    """Invariants every table obeys, whatever the shape."""
    comp = iso.triangle_components()
    k = c["area"].shape[0]
    assert comp.shape == (iso.n_triangles,) and comp.dtype == np.int64
    np.testing.assert_array_equal(np.bincount(comp, minlength=k), c["triangles"])
    np.testing.assert_allclose(np.bincount(comp, iso.triangle_areas(), minlength=k), c["area"], rtol=1e-12)
    assert np.all(np.diff(c["area"]) <= 0)  # largest first
    assert c["triangles"].sum() == iso.n_triangles
    # the same partition as connected_components (triangle-vertex graph), renumbered
    labels, n = iso.connected_components()
    assert n == k
    pairs = np.unique(np.stack([labels, comp], 1), axis=0)
    assert pairs.shape[0] == k
    # every triangle's vertices inside its component's bounds
    b = c["bounds"][comp]
    p = iso.vertices[iso.triangles]
    assert np.all(p >= b[:, None, 0::2]) and np.all(p <= b[:, None, 1::2])
    assert np.array_equal(np.isnan(c["volume"]), ~c["closed"])
    assert not np.any(c["closed"] & c["touches_boundary"])


@pytest.fixture(scope="module")
def two_spheres():
    r1, r2 = 0.3, 0.25
    c1, c2 = np.array([-0.35, 0.0, 0.0]), np.array([0.6, 0.0, 0.0])
    h = min(r1, r2) / R_OVER_H
    vol = _box((-0.7, -0.35, -0.35), (0.9, 0.35, 0.35), h)
    p = vol.points
    f = np.minimum(np.linalg.norm(p - c1, axis=1) - r1, np.linalg.norm(p - c2, axis=1) - r2)
    return vol, f, h, [(c1, r1), (c2, r2)]


def test_two_spheres(two_spheres):
    vol, f, h, balls = two_spheres
    iso = extract(vol, 0.0, field=f)
    c = iso.components()
    _check_table(iso, c)
    assert set(c) == {"triangles", "area", "volume", "bounds", "closed", "touches_boundary"}
    assert c["area"].shape == (2,)
    assert c["closed"].all() and not c["touches_boundary"].any()
    for i, (centre, r) in enumerate(balls):  # the larger sphere first
        assert abs(c["area"][i] / (4 * np.pi * r * r) - 1) < AREA_TOL
        assert abs(c["volume"][i] / (4 / 3 * np.pi * r ** 3) - 1) < VOLUME_TOL
        expect = np.repeat(centre, 2) + np.tile([-r, r], 3)
        # the surface lies inside the true sphere, by at most delta, and its vertices sample the sphere
        # at most a cell apart (a tangential step s misses the extreme point by s^2 / (2 r) <= h^2 / r)
        np.testing.assert_allclose(c["bounds"][i], expect, atol=_delta(h, r) + h * h / r)


def test_orientation_sign_follows_the_gradient(two_spheres):
    # our triangles' right-hand normal points towards increasing scalar: around a minimum (lower values
    # inside) the enclosed volume is positive, around a maximum it is negative
    vol, f, _, _ = two_spheres
    up, down = extract(vol, 0.0, field=f).components(), extract(vol, 0.0, field=-f).components()
    assert np.all(up["volume"] > 0) and np.all(down["volume"] < 0)
    np.testing.assert_allclose(down["volume"], -up["volume"], rtol=1e-9)
    np.testing.assert_allclose(down["area"], up["area"], rtol=1e-9)


def test_torus():
    R, r = 0.6, 0.3
    h = r / R_OVER_H  # the tube's curvature 1/r is the larger one (R - r >= r)
    vol = _box((-0.95, -0.95, -0.35), (0.95, 0.95, 0.35), h)
    p = vol.points
    f = np.sqrt((np.hypot(p[:, 0], p[:, 1]) - R) ** 2 + p[:, 2] ** 2)
    iso = extract(vol, r, field=f)
    c = iso.components()
    _check_table(iso, c)
    assert c["area"].shape == (1,) and c["closed"][0] and not c["touches_boundary"][0]
    assert abs(c["area"][0] / (4 * np.pi ** 2 * R * r) - 1) < AREA_TOL
    assert abs(c["volume"][0] / (2 * np.pi ** 2 * R * r * r) - 1) < VOLUME_TOL
    # a closed surface of genus 1: Euler characteristic V - E + F = 0
    t = iso.triangles
    e = np.unique(np.sort(t[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    assert iso.n_vertices - e.shape[0] + iso.n_triangles == 0


@pytest.fixture(scope="module")
def holed_cube():
    """The cube [-1, 1]^3 less the cells whose centroid lies within 0.3 of the centre (a void), field |x|."""
    # h <= 0.6 / R_OVER_H for the sphere |x| = 0.6 (the clipped sphere |x| = 1.2 has the smaller error),
    # and a whole number of cells across the cube, so that the grid ends at +-1
    h = 2 / np.ceil(2 / (0.6 / R_OVER_H))
    vol = _box((-1, -1, -1), (1, 1, 1), h)
    keep = np.linalg.norm(vol.points[vol.cells].mean(axis=1), axis=1) >= 0.3
    used, cells = np.unique(vol.cells[keep], return_inverse=True)
    # the void's wall: the nodes of both a kept and a removed cell, and how far they lie from the centre
    wall = np.intersect1d(used, vol.cells[~keep])
    wall_r = np.linalg.norm(vol.points[wall], axis=1)
    pts = vol.points[used]
    vol = UnstructuredVolume(pts, cells.reshape(-1, 4), {"r": np.linalg.norm(pts, axis=1)})
    return vol, h, (wall_r.min(), wall_r.max())


def test_shell_around_a_void(holed_cube):
    vol, h, (wall_lo, wall_hi) = holed_cube
    assert wall_hi < 0.6
    assert vol.boundary_groups is not None
    iso = extract(vol, 0.6, field="r")
    c = iso.components()
    _check_table(iso, c)
    # the sphere around the void: closed, not on the boundary (neither the cube's nor the void's)
    assert c["area"].shape == (1,) and c["closed"][0] and not c["touches_boundary"][0]
    assert abs(c["area"][0] / (4 * np.pi * 0.36) - 1) < AREA_TOL
    assert abs(c["volume"][0] / (4 / 3 * np.pi * 0.216) - 1) < VOLUME_TOL  # the void is inside it
    # a value inside the range of |x| on the void's wall: the surface ends on the wall (the boundary)
    iso = extract(vol, 0.5 * (wall_lo + wall_hi), field="r")
    c = iso.components()
    _check_table(iso, c)
    assert c["area"].shape[0] >= 1 and c["touches_boundary"].all() and not c["closed"].any()
    assert np.all(np.abs(c["bounds"]) <= wall_hi)


def test_sphere_clipped_by_the_cube(holed_cube):
    # |x| = 1.2 leaves the cube [-1, 1]^3 through six disjoint caps (1 < 1.2 < sqrt 2), each of area
    # 2 pi rho (rho - 1): one open piece of area 4 pi rho^2 - 12 pi rho (rho - 1), ending on the boundary
    vol, h, _ = holed_cube
    rho = 1.2
    iso = extract(vol, rho, field="r")
    c = iso.components()
    _check_table(iso, c)
    assert c["area"].shape == (1,) and not c["closed"][0] and c["touches_boundary"][0]
    assert np.isnan(c["volume"][0])
    assert abs(c["area"][0] / (4 * np.pi * rho ** 2 - 12 * np.pi * rho * (rho - 1)) - 1) < AREA_TOL
    np.testing.assert_allclose(c["bounds"][0], [-1, 1] * 3, atol=1e-12)


def test_plane_cutting_the_box():
    # a linear field is interpolated exactly: the plane x + y/2 = 1.01 crosses the box [0,2]x[0,1]x[0,1]
    # in a rectangle sqrt(1.25) by 1, from x = 0.51 (y = 1) to x = 1.01 (y = 0)
    vol = _box((0, 0, 0), (2, 1, 1), 0.25)
    p = vol.points
    iso = extract(vol, 1.01, field=p[:, 0] + 0.5 * p[:, 1])
    c = iso.components()
    _check_table(iso, c)
    assert c["area"].shape == (1,) and not c["closed"][0] and c["touches_boundary"][0]
    assert np.isnan(c["volume"][0])
    np.testing.assert_allclose(c["area"][0], np.sqrt(1.25), rtol=1e-12)
    np.testing.assert_allclose(c["bounds"][0], [0.51, 1.01, 0, 1, 0, 1], atol=1e-12)


def test_table_is_cached_read_only_and_empty_when_the_surface_is():
    vol = _box((0, 0, 0), (1, 1, 1), 0.5)
    p = vol.points
    iso = extract(vol, 0.3, field=p[:, 2])
    c = iso.components()
    assert iso.components()["area"] is c["area"] and iso.triangle_components() is iso.triangle_components()
    with pytest.raises(ValueError):
        c["area"][0] = 1.0
    empty = extract(vol, 5.0, field=p[:, 2])
    e = empty.components()
    assert all(a.shape[0] == 0 for a in e.values()) and e["bounds"].shape == (0, 6)
    assert empty.triangle_components().shape == (0,)


def test_component_table_by_hand():
    # two tetrahedra's boundaries (closed, outward: volume 1/6 each) and one lone triangle, sharing nothing;
    # a vertex used by no triangle is ignored
    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    v = np.concatenate([tet, 2 * tet + 5, [[9, 9, 9], [10, 9, 9], [9, 10, 9], [50, 50, 50]]])
    t = np.concatenate([faces + 8 - 8, faces + 4, [[8, 9, 10]]])
    c = component_table(v, t)
    np.testing.assert_array_equal(c["triangles"], [4, 4, 1])
    np.testing.assert_allclose(c["volume"][:2], [8 / 6, 1 / 6])  # the larger tetrahedron first
    assert np.isnan(c["volume"][2])
    np.testing.assert_array_equal(c["closed"], [True, True, False])
    np.testing.assert_array_equal(c["touches_boundary"], [False, False, True])
    np.testing.assert_allclose(c["area"][2], 0.5)
    np.testing.assert_allclose(c["bounds"][0], [5, 7, 5, 7, 5, 7])
    np.testing.assert_array_equal(c["component"], [1, 1, 1, 1, 0, 0, 0, 0, 2])
    # reversed orientation: negative volume
    np.testing.assert_allclose(component_table(v, t[:, ::-1])["volume"][:2], [-8 / 6, -1 / 6])


def test_cli_prints_the_table(tmp_path, capsys):
    from polygen.cli import main

    vol = _box((-0.7, -0.35, -0.35), (0.9, 0.35, 0.35), 0.05)
    p = vol.points
    f = np.minimum(np.linalg.norm(p - [-0.35, 0, 0], axis=1) - 0.3, np.linalg.norm(p - [0.6, 0, 0], axis=1) - 0.25)
    vol.add_field("f", f)
    path = tmp_path / "spheres.vtu"
    vol.to_meshio().write(path)
    rc = main(["isosurface", str(path), "--field", "f", "--value", "0", "--value", "0.3", "--method", "scan",
               "--components", "--no-compare-vtk", "--no-files"])
    assert rc == 0
    lines = capsys.readouterr().out.splitlines()
    start = next(i for i, s in enumerate(lines) if s.startswith("components (by scan"))
    rows = [s.split() for s in lines[start + 3:]]
    c = extract(vol, 0.0, field="f").components()
    assert [r[:2] for r in rows[:2]] == [["0", "0"], ["0", "1"]]
    for i, r in enumerate(rows[:2]):
        assert int(r[2]) == c["triangles"][i]
        assert float(r[3]) == pytest.approx(c["area"][i], rel=1e-5)
        assert float(r[4]) == pytest.approx(c["volume"][i], rel=1e-5)
        assert r[5:7] == ["yes", "no"]
        np.testing.assert_allclose([float(x) for x in r[7:13]], c["bounds"][i], rtol=1e-3, atol=1e-12)
    # at 0.3 the spheres (radii 0.6, 0.55) leave the box: open pieces, ending on its boundary
    k = extract(vol, 0.3, field="f").components()["area"].shape[0]
    assert k > 1 and len(rows) == 2 + min(k, 10) + (k > 10)
    assert all(r[0] == "0.3" and r[4:7] == ["-", "no", "yes"] for r in rows[2:2 + min(k, 10)])

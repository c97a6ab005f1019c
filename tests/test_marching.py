"""Marching tetrahedra / hexahedra and the full-scan extraction.

Oracles: VTK's contour filter (through pyvista) on the same tetrahedral mesh,
closed-form areas, the tetrahedralised mesh for hexahedra, and invariants
(closed polygons, watertightness, orientation).
"""

import itertools

import time

import numpy as np
import pytest
import pyvista as pv
from scipy.spatial import cKDTree

from polygen.volume import UnstructuredVolume
from polygen.volume import marching as m
from polygen.volume.isosurface import IsoSurfaceError, extract

from _surfaces import grid_volume  # noqa: E402


# ------------------------------------------------------------------ helpers
def vtk_contour(vol, s, value):
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: vol.cells}, vol.points.astype(np.float64))
    grid.point_data["s"] = s
    return grid.contour([value], scalars="s")


def directed_edges(tri):
    return np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])


def on_box_boundary(p, lo, hi, tol=1e-9):
    return np.any((np.abs(p - lo) < tol) | (np.abs(p - hi) < tol), axis=-1)


def assert_watertight(iso, lo, hi):
    """Every directed edge once; an edge used by one triangle lies on one box face."""
    e = directed_edges(iso.triangles)
    _, counts = np.unique(e, axis=0, return_counts=True)
    assert counts.max() == 1, "an edge is traversed twice in the same direction (orientation or duplicate)"
    und, cnt = np.unique(np.sort(e, axis=1), axis=0, return_counts=True)
    assert cnt.max() <= 2
    lone = und[cnt == 1]
    a, b = iso.vertices[lone[:, 0]], iso.vertices[lone[:, 1]]
    same_face = np.zeros(len(lone), bool)
    for d in range(3):
        for bound in (lo[d], hi[d]):
            same_face |= (np.abs(a[:, d] - bound) < 1e-9) & (np.abs(b[:, d] - bound) < 1e-9)
    assert same_face.all(), f"{(~same_face).sum()} open edges inside the volume"


# --------------------------------------------------------------- the tables
def test_tet_table_matches_vtk_cell_by_cell():
    """Each of the 14 non-trivial cases gives VTK's triangles on a single tetrahedron."""
    pts = np.array([[0.1, 0.0, 0.0], [1.3, 0.2, 0.1], [0.2, 1.1, 0.3], [0.3, 0.4, 1.2]])
    vol = UnstructuredVolume(pts, np.array([[0, 1, 2, 3]]))
    rng = np.random.default_rng(3)
    for case in range(1, 15):
        above = np.array([(case >> i) & 1 for i in range(4)], bool)
        s = np.where(above, 1.0 + rng.random(4), rng.random(4) - 1.0)
        iso = extract(vol, 0.0, field=s)
        ref = vtk_contour(vol, s, 0.0)
        assert iso.n_triangles == ref.n_cells == (2 if above.sum() == 2 else 1)
        dist, idx = cKDTree(np.asarray(ref.points)).query(iso.vertices)
        assert dist.max() < 1e-12
        ours = {frozenset(t) for t in idx[iso.triangles].tolist()}
        theirs = {frozenset(t) for t in ref.regular_faces.tolist()}
        assert ours == theirs, f"case {case}: quad split differs from VTK"
        # orientation: towards increasing scalar (the gradient of the linear field)
        grad = np.linalg.solve(pts[1:] - pts[0], s[1:] - s[0])
        v = iso.vertices[iso.triangles]
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        assert np.all(n @ grad > 0)


def test_tet_table_uses_crossed_edges_only():
    table, count = m.tet_case_table()
    for case in range(16):
        above = [(case >> i) & 1 for i in range(4)]
        crossed = {e for e, (a, b) in enumerate(m.TET_EDGES) if above[a] != above[b]}
        used = set(table[case, : 3 * count[case]].tolist())
        assert used == crossed


@pytest.mark.parametrize("node_case", range(256))
def test_hex_cases_closed_and_consistent(node_case):
    """Every case and face-bit choice: closed loops over exactly the crossed edges,
    one segment per simple face, two per ambiguous face, oriented consistently."""
    above = [(node_case >> i) & 1 for i in range(8)]
    crossed = {e for e, (a, b) in enumerate(m.HEX_EDGES) if above[a] != above[b]}
    table, count = m.hex_case_table()
    amb = m.hex_ambiguous_faces(node_case)
    face_edges = []
    for q in m.HEX_FACES:
        face_edges.append({e for e, (a, b) in enumerate(m.HEX_EDGES) if a in q and b in q})
    for bits in itertools.product((0, 1), repeat=len(amb)):
        case = node_case | sum(b << (8 + f) for b, f in zip(bits, amb))
        polys = m.hex_polygons(case)
        flat = [e for p in polys for e in p]
        assert sorted(flat) == sorted(crossed)  # each crossed edge in exactly one loop
        for p in polys:
            assert len(p) >= 3
            for i in range(len(p)):  # consecutive crossings share a face
                assert any({p[i], p[(i + 1) % len(p)]} <= fe for fe in face_edges)
        # triangles: fan of the loops; directed edges unique, boundary = loop edges
        tris = table[case, : 3 * count[case]].reshape(-1, 3)
        assert count[case] == sum(len(p) - 2 for p in polys)
        e = directed_edges(tris)
        assert len({tuple(x) for x in e.tolist()}) == len(e)
        loops = {(p[i], p[(i + 1) % len(p)]) for p in polys for i in range(len(p))}
        und = [tuple(sorted(x)) for x in e.tolist()]
        boundary = {tuple(x) for x, u in zip(e.tolist(), und) if und.count(u) == 1}
        assert boundary == loops
        # segments per face: 1 on a face with two crossings, 2 on an ambiguous one
        for f, fe in enumerate(face_edges):
            n_seg = sum(1 for a, b in loops if {a, b} <= fe)
            n_cross = len(fe & crossed)
            assert n_seg == n_cross // 2


def test_hex_orientation_points_up():
    """On the reference cube, with crossings at edge midpoints, each loop's
    Newell normal has a positive component along below -> above."""
    table, count = m.hex_case_table()
    ref = m._HEX_REF
    mid = ref[m.HEX_EDGES].mean(axis=1)
    for case in range(1, 255):
        above = np.array([(case >> i) & 1 for i in range(8)], bool)
        for poly in m.hex_polygons(case):
            x = mid[poly]
            normal = np.cross(x, np.roll(x, -1, axis=0)).sum(axis=0)
            up = sum(ref[a] - ref[b] if above[a] else ref[b] - ref[a] for a, b in m.HEX_EDGES[poly])
            # symmetric saddles can have a zero Newell projection; never a negative one
            assert normal @ up >= -1e-12


def test_hex_to_tets_conforming():
    vol = grid_volume((4, 3, 3), spacing=(0.5, 1.0, 2.0), tets=False)
    tets = m.hex_to_tets(vol.cells)
    tv = UnstructuredVolume(vol.points, tets)  # validates: positive, no face shared by 3
    assert tv.n_cells == 6 * vol.n_cells
    p = tv.points[tets]
    v6 = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    assert np.all(v6 > 0)
    assert np.isclose(v6.sum() / 6, 1.5 * 2.0 * 4.0)
    assert len(tv.boundary_faces) == 2 * len(vol.boundary_faces)  # each boundary quad -> 2 triangles


# ------------------------------------------------------- against VTK (tetra)
@pytest.mark.parametrize("jitter", [0.0, 0.2])
def test_tetra_matches_vtk_exactly(jitter):
    vol = grid_volume((9, 8, 7), spacing=(0.3, 0.5, 0.7), origin=(1.0, -2.0, 3.0), jitter=jitter, seed=5)
    rng = np.random.default_rng(11)
    x = vol.points
    fields = {
        "random": rng.random(vol.n_points),
        "smooth": np.sin(2 * x[:, 0]) * np.cos(1.5 * x[:, 1]) + 0.3 * x[:, 2] * x[:, 0],
    }
    for name, s in fields.items():
        values = np.linspace(s.min(), s.max(), 9)[1:-1]
        for value in values:
            iso = extract(vol, value, field=s)
            ref = vtk_contour(vol, s, value)
            assert iso.n_triangles == ref.n_cells, (name, value)
            assert iso.n_vertices == ref.n_points, (name, value)
            rp = np.asarray(ref.points, np.float64)
            scale = np.abs(rp).max()
            dist, idx = cKDTree(rp).query(iso.vertices)
            assert dist.max() <= 1e-9 * scale
            assert np.unique(idx).size == idx.size  # a one-to-one vertex match
            ours = {frozenset(t) for t in idx[iso.triangles].tolist()}
            theirs = {frozenset(t) for t in ref.regular_faces.tolist()}
            assert ours == theirs
            assert iso.area() == pytest.approx(ref.area, rel=1e-9)


def test_node_values_equal_to_isovalue():
    """Integer field, integer isovalues: crossings land on nodes.

    VTK merges crossings per edge only, so it keeps zero-area triangles and
    several points at one node; and it makes a face lying at ``C`` between
    two below cells twice. We merge crossings on a node into one vertex,
    drop zero-area triangles and keep such a face once. The non-degenerate
    triangles, as sets of positions, must be VTK's.
    """
    vol = grid_volume((6, 5, 5), jitter=0.15, seed=2)
    rng = np.random.default_rng(4)
    s = rng.integers(0, 4, vol.n_points).astype(float)
    scale = np.abs(vol.points).max()
    for value in (1.0, 2.0, 3.0):
        iso = extract(vol, value, field=s)
        ref = vtk_contour(vol, s, value)
        v = np.asarray(ref.points)[ref.regular_faces]
        ref_area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
        v = v[ref_area > 1e-12 * scale**2]
        theirs = {frozenset(map(tuple, np.round(t, 9))) for t in v}
        ours = [frozenset(map(tuple, np.round(t, 9))) for t in iso.vertices[iso.triangles]]
        assert len(set(ours)) == len(ours), "a duplicate triangle"
        assert set(ours) == theirs
        assert np.unique(iso.vertices, axis=0).shape[0] == iso.n_vertices, "two vertices at one point"
        assert np.all(iso.triangle_areas() > 0)
        unique_area = sum(0.5 * np.linalg.norm(np.cross(*(np.array(sorted(t))[1:] - np.array(sorted(t))[0])))
                          for t in theirs)
        assert iso.area() == pytest.approx(unique_area, rel=1e-9)
        # vertices on nodes are keyed by the node, each once
        on_node = iso.vertex_keys >= vol.edges.shape[0]
        assert on_node.any()
        nodes = iso.vertex_keys[on_node] - vol.edges.shape[0]
        assert np.all(s[nodes] == value)
        np.testing.assert_array_equal(iso.vertices[on_node], vol.points[nodes])


def test_crafted_cells_on_node_values():
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    vol = UnstructuredVolume(pts, np.array([[0, 1, 2, 3], [1, 2, 3, 4]]))
    # shared face (1,2,3) exactly at C, apexes below / above: the face once
    iso = extract(vol, 1.0, field=np.array([0.0, 1, 1, 1, 2]))
    assert iso.n_triangles == 1 and iso.n_vertices == 3
    assert iso.area() == pytest.approx(np.sqrt(3) / 2)
    # ... both apexes below: still once (VTK makes it twice), from the lower cell
    iso = extract(vol, 1.0, field=np.array([0.0, 1, 1, 1, 0]))
    assert iso.n_triangles == 1 and iso.n_vertices == 3 and iso.triangle_cells[0] == 0
    assert vtk_contour(vol, np.array([0.0, 1, 1, 1, 0]), 1.0).n_cells == 2
    # ... both apexes above: nothing (no cell has a node below)
    assert extract(vol, 1.0, field=np.array([2.0, 1, 1, 1, 2])).n_triangles == 0
    # one node at C, the rest below: the surface touches a point, no triangle
    iso = extract(vol, 1.0, field=np.array([0.0, 1, 0, 0, 0]))
    assert iso.n_triangles == 0 and iso.cells_intersected == 2
    # an edge at C, the rest below: no triangle, no duplicate vertex
    iso = extract(vol, 1.0, field=np.array([0.0, 1, 1, 0, 0]))
    assert iso.n_triangles == 0
    # one node at C, one above, rest below: the node is a single shared vertex
    # (VTK: 3 triangles, 2 of zero area, and 5 points, 3 of them at node 1)
    iso = extract(vol, 1.0, field=np.array([0.0, 1, 0, 0, 2]))
    assert iso.n_triangles == 1 and iso.n_vertices == 3
    assert np.count_nonzero(iso.vertex_keys >= vol.edges.shape[0]) == 1
    np.testing.assert_array_equal(np.sort(iso.vertices[:, 0]), [0.5, 0.5, 1.0])


def test_value_outside_range_is_empty():
    vol = grid_volume((4, 4, 4))
    s = vol.points[:, 0].copy()
    for value in (-1.0, 3.5, 100.0):
        iso = extract(vol, value, field=s)
        assert iso.is_empty and iso.n_vertices == 0
        assert iso.cells_tested == vol.n_cells and iso.cells_intersected == 0
        assert iso.area() == 0.0
        assert iso.to_pyvista().n_points == 0
        assert iso.connected_components()[1] == 0
    # the minimum: every node is above (S >= C), nothing is below
    assert extract(vol, 0.0, field=s).is_empty
    # the maximum: the nodes at x = 3 are above, so the surface is that boundary face
    iso = extract(vol, 3.0, field=s)
    assert np.all(iso.vertices[:, 0] == 3.0)
    assert iso.area() == pytest.approx(9.0)


# ------------------------------------------------------------------ hexahedra
@pytest.mark.parametrize("seed", [0, 1])
def test_hexa_watertight_on_random_fields(seed):
    """Random node values make many ambiguous faces; the face-centre rule must agree across cells."""
    vol = grid_volume((8, 7, 6), spacing=(0.3, 0.5, 0.7), tets=False)
    s = np.random.default_rng(seed).random(vol.n_points)
    lo, hi = vol.points.min(axis=0), vol.points.max(axis=0)
    n_amb = 0
    for value in (0.3, 0.5, 0.7):
        iso = extract(vol, value, field=s)
        assert iso.n_triangles > 0
        assert_watertight(iso, lo, hi)
        n_amb += int(np.count_nonzero(_ambiguous_faces(vol, s, value)))
    assert n_amb > 50  # the test exercises the ambiguity rule


def _ambiguous_faces(vol, s, value):
    q = s[vol.cells[:, m.HEX_FACES]] >= value  # (M, 6, 4)
    return (q[..., 0] == q[..., 2]) & (q[..., 1] == q[..., 3]) & (q[..., 0] != q[..., 1])


def test_hexa_area_close_to_tetrahedralised():
    vol = grid_volume((21, 21, 21), spacing=(0.05, 0.05, 0.05), tets=False)
    x = vol.points
    s = np.linalg.norm(x - [0.45, 0.52, 0.48], axis=1) * (1 + 0.3 * x[:, 0] * x[:, 1])
    tv = UnstructuredVolume(vol.points, m.hex_to_tets(vol.cells))
    lo, hi = x.min(axis=0), x.max(axis=0)
    for value in (0.2, 0.3, 0.45):
        a = extract(vol, value, field=s)
        b = extract(tv, value, field=s)
        assert_watertight(a, lo, hi)
        assert a.area() == pytest.approx(b.area(), rel=0.01)


def test_hexa_linear_field_is_exact_plane():
    vol = grid_volume((5, 6, 4), spacing=(0.5, 0.4, 0.3), tets=False, jitter=0.0)
    n = np.array([0.3, -0.5, 0.8])
    s = vol.points @ n
    iso = extract(vol, 0.1234, field=s)  # not through a node: no sliver triangles
    assert np.allclose(iso.vertices @ n, 0.1234)
    assert np.allclose(iso.normals, n / np.linalg.norm(n))


# ------------------------------------------------------ analytic and normals
def test_sphere_area():
    r = 0.35
    vol = grid_volume((41, 41, 41), spacing=(0.025, 0.025, 0.025))
    s = np.linalg.norm(vol.points - 0.5, axis=1)
    iso = extract(vol, r, field=s)
    assert iso.area() == pytest.approx(4 * np.pi * r**2, rel=0.005)
    labels, n = iso.connected_components()
    assert n == 1 and labels.shape == (iso.n_triangles,)
    assert np.allclose(np.linalg.norm(iso.vertices - 0.5, axis=1), r, atol=0.025**2 / r)
    # mean normals point outwards (towards increasing distance), like the gradient ones
    out = (iso.vertices - 0.5) / r
    assert np.all(np.einsum("ij,ij->i", iso.normals, out) > 0.95)
    g = extract(vol, r, field=s, normals="gradient")
    assert np.all(np.einsum("ij,ij->i", g.normals, out) > 0.95)
    assert np.allclose(np.linalg.norm(g.normals, axis=1), 1.0)
    assert extract(vol, r, field=s, normals=None).normals is None


def test_linear_field_normals_and_plane():
    vol = grid_volume((5, 5, 5), jitter=0.2, seed=9)
    n = np.array([1.0, 2.0, -0.5])
    s = vol.points @ n
    for normals in ("mean", "gradient"):
        iso = extract(vol, 3.0, field=s, normals=normals)
        assert np.allclose(iso.vertices @ n, 3.0)
        assert np.allclose(iso.normals, n / np.linalg.norm(n))


def test_two_spheres_two_components_and_pyvista():
    vol = grid_volume((25, 13, 13), spacing=(0.05, 0.05, 0.05))
    x = vol.points
    s = np.minimum(np.linalg.norm(x - [0.3, 0.3, 0.3], axis=1), np.linalg.norm(x - [0.9, 0.3, 0.3], axis=1))
    iso = extract(vol, 0.2, field=s)
    labels, n = iso.connected_components()
    assert n == 2
    assert set(np.unique(labels).tolist()) == {0, 1}
    left = iso.vertices[iso.triangles[labels == labels[0], 0], 0]
    assert np.all(left < 0.6) or np.all(left > 0.6)
    poly = iso.to_pyvista()
    assert poly.n_cells == iso.n_triangles and poly.n_points == iso.n_vertices
    assert poly.area == pytest.approx(iso.area(), rel=1e-12)
    np.testing.assert_allclose(poly.point_data["Normals"], iso.normals)


def test_counters():
    vol = grid_volume((6, 6, 6))
    s = np.linalg.norm(vol.points - 2.5, axis=1)
    t0 = time.perf_counter()
    iso = extract(vol, 1.7, field=s)
    wall = time.perf_counter() - t0
    c = iso.counters()
    assert c["cells_tested"] == vol.n_cells
    assert c["cells_intersected"] == np.unique(iso.triangle_cells).size  # no node hits here
    assert c["n_triangles"] == iso.n_triangles and c["n_vertices"] == iso.n_vertices
    # one look-up per intersected cell and crossed edge
    assert c["vertex_lookups"] == sum(len(np.unique(iso.triangles[iso.triangle_cells == k])) for k in
                                      np.unique(iso.triangle_cells))
    # the stage times fit in the wall time around the call (a wrong clock or unit would not)
    assert 0 < iso.t1 + iso.t2 + iso.t3 <= wall


def test_bad_arguments():
    vol = grid_volume((3, 3, 3))
    s = vol.points[:, 0].copy()
    with pytest.raises(IsoSurfaceError, match="method"):
        extract(vol, 0.5, field=s, method="octree")
    with pytest.raises(IsoSurfaceError, match="normals"):
        extract(vol, 0.5, field=s, normals="phong")
    with pytest.raises(IsoSurfaceError, match="finite"):
        extract(vol, np.nan, field=s)
    with pytest.raises(IsoSurfaceError, match="shape"):
        extract(vol, 0.5, field=s[:-1])
    with pytest.raises(IsoSurfaceError, match="seeds"):
        extract(vol, 0.5, field=s, method="propagate")
    with pytest.raises(IsoSurfaceError, match="UnstructuredVolume"):
        extract(np.zeros((3, 3)), 0.5)
    with pytest.raises(ValueError):
        m.hex_to_tets(np.zeros((2, 4), int))


def test_zero_rows_are_the_rows_without_a_direction():
    """marching.zero_rows: the rows whose |x| + |y| + |z| is not > 0 (zeros, NaN), as numpy finds them."""
    rng = np.random.default_rng(5)
    nrm = rng.normal(size=(1000, 3))
    nrm[rng.choice(1000, 40, replace=False)] = 0.0
    nrm[7] = [0.0, -0.0, 0.0]
    nrm[8] = [np.nan, 1.0, 0.0]
    nrm[9] = [1e-320, 0.0, 0.0]  # subnormal: a direction
    nrm[10] = [np.inf, 0.0, 0.0]
    got = m.zero_rows(nrm)
    np.testing.assert_array_equal(got, np.flatnonzero(~(np.abs(nrm).sum(axis=1) > 0.0)))
    assert 7 in got and 8 in got and 9 not in got and 10 not in got
    assert m.zero_rows(np.empty((0, 3))).shape == (0,)

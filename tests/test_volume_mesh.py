"""The volume model against brute-force references, VTK and hand-counted topology."""

import itertools

import meshio
import numpy as np
import pytest
import pyvista as pv

from polygen.volume import UnstructuredVolume, VolumeError, VolumeWarning
from polygen.volume.mesh import HEX_EDGES, HEX_FACES, TET_EDGES, TET_FACES


def voxel_volume(mask, *, tetra=False, jitter=0.0, seed=0):
    """A hexahedral (or 6-tets-per-hex) volume of the unit voxels where ``mask`` is true."""
    mask = np.asarray(mask, bool)
    grid = pv.ImageData(dimensions=np.array(mask.shape) + 1)
    grid = grid.extract_cells(np.flatnonzero(mask.ravel(order="F"))).clean()
    if tetra:
        grid = grid.triangulate()
    vol = UnstructuredVolume.from_pyvista(grid, orient=True)
    if jitter:
        rng = np.random.default_rng(seed)
        vol = UnstructuredVolume(vol.points + rng.uniform(-jitter, jitter, vol.points.shape), vol.cells)
    return vol


def ring(n=4, hole=2):
    m = np.ones((n, n, 2), bool)
    a = (n - hole) // 2
    m[a:a + hole, a:a + hole, :] = False
    return m


def hollow(n=5):
    m = np.ones((n, n, n), bool)
    m[2:n - 2, 2:n - 2, 2:n - 2] = False
    return m


def genus3():
    m = np.ones((9, 3, 2), bool)
    m[[1, 4, 7], 1, :] = False
    return m


def brute_neighbors(cells, faces):
    seen = {}
    for c, row in enumerate(cells):
        for f, loc in enumerate(faces):
            seen.setdefault(tuple(sorted(row[loc])), []).append((c, f))
    out = -np.ones((len(cells), len(faces)), int)
    for owners in seen.values():
        if len(owners) == 2:
            (a, fa), (b, fb) = owners
            out[a, fa], out[b, fb] = b, a
    return out


# ---------------------------------------------------------------------- adjacency

@pytest.mark.parametrize("tetra", [False, True])
def test_face_neighbors_match_brute_force(tetra):
    vol = voxel_volume(hollow(5), tetra=tetra, jitter=0.1)
    ref = brute_neighbors(vol.cells, vol.local_faces)
    np.testing.assert_array_equal(vol.face_neighbors, ref)
    # symmetric: if b is across face f of a, a is across some face of b
    a, f = np.nonzero(vol.face_neighbors >= 0)
    b = vol.face_neighbors[a, f]
    assert np.all((vol.face_neighbors[b] == a[:, None]).any(axis=1))


def test_faces_touching_with_different_nodes_are_not_neighbours():
    # Def. 5.1: two tets touching geometrically through a face whose nodes are duplicated
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1.0]])
    shared = UnstructuredVolume(pts, [[0, 1, 2, 3], [0, 2, 1, 4]])
    assert (shared.face_neighbors >= 0).sum() == 2
    dup = np.vstack([pts, pts[:3]])
    apart = UnstructuredVolume(dup, [[0, 1, 2, 3], [5, 7, 6, 4]])
    assert (apart.face_neighbors >= 0).sum() == 0
    assert apart.boundary_faces.shape == (8, 2)


@pytest.mark.parametrize("tetra", [False, True])
def test_boundary_faces_match_vtk_surface(tetra):
    vol = voxel_volume(ring(5, 1), tetra=tetra)
    surf = vol.to_pyvista().extract_surface(algorithm="dataset_surface")
    k = 3 if tetra else 4
    faces = surf.faces.reshape(-1, k + 1)[:, 1:]
    ours = {tuple(sorted(f)) for f in vol.boundary_face_nodes.tolist()}
    theirs = {tuple(sorted(f)) for f in surf["vtkOriginalPointIds"][faces].tolist()}
    assert ours == theirs
    # outward: the divergence theorem gives the volume of the solid
    assert vol.group_signed_volume[0] == pytest.approx(ring(5, 1).sum())


@pytest.mark.parametrize("tetra", [False, True])
def test_edge_and_node_incidence(tetra):
    vol = voxel_volume(ring(4, 2), tetra=tetra, jitter=0.05)
    local = TET_EDGES if tetra else HEX_EDGES
    ref = sorted({tuple(sorted(row[e])) for row in vol.cells for e in local})
    assert sorted(map(tuple, vol.edges.tolist())) == ref
    assert np.all(vol.edges[:, 0] < vol.edges[:, 1])
    # cell_edges point to the right node pairs
    pairs = np.sort(vol.cells[:, local], axis=2)
    np.testing.assert_array_equal(vol.edges[vol.cell_edges], pairs)
    off, cells = vol.edge_cells
    for e in [0, len(vol.edges) // 2, len(vol.edges) - 1]:
        around = set(cells[off[e]:off[e + 1]].tolist())
        assert around == set(np.flatnonzero((vol.cell_edges == e).any(axis=1)).tolist())
    off, cells = vol.node_cells
    for n in [0, vol.n_points - 1]:
        assert set(cells[off[n]:off[n + 1]].tolist()) == set(np.flatnonzero((vol.cells == n).any(axis=1)).tolist())


def test_local_faces_are_outward_and_cover_every_edge():
    for faces, edges, k in [(TET_FACES, TET_EDGES, 4), (HEX_FACES, HEX_EDGES, 8)]:
        # every local edge is used by exactly two local faces, in opposite directions
        used = {}
        for f in faces:
            for a, b in zip(f, np.roll(f, -1)):
                used.setdefault((min(a, b), max(a, b)), []).append((a, b))
        assert sorted(used) == sorted(tuple(sorted(e)) for e in edges.tolist())
        assert all(len(v) == 2 and v[0] == v[1][::-1] for v in used.values())


# ------------------------------------------------------------- topology (Defs 5.6-5.8)

@pytest.mark.parametrize("tetra", [False, True])
@pytest.mark.parametrize(
    "mask, genus, voids",
    [(np.ones((2, 2, 2), bool), 0, 0), (ring(4, 2), 1, 0), (hollow(5), 0, 1), (genus3(), 3, 0)],
    ids=["block", "torus", "hollow", "genus3"],
)
def test_genus_and_voids_of_hand_built_volumes(mask, genus, voids, tetra):
    vol = voxel_volume(mask, tetra=tetra)
    assert vol.n_through_holes == genus
    assert vol.n_voids == voids
    assert vol.n_boundary_groups == 1 + voids
    assert vol.group_genus[0] == genus
    assert np.all(vol.group_euler == 2 - 2 * vol.group_genus)
    # group 1 is the outer surface, and its faces are the ones farthest out
    far = np.argmax(vol.points[vol.boundary_face_nodes[:, 0], 0])
    assert vol.boundary_groups[far] == 1
    assert set(np.unique(vol.boundary_groups)) == set(range(1, 2 + voids))
    assert vol.group_is_void.tolist() == [False] + [True] * voids
    assert vol.group_signed_volume.sum() == pytest.approx(mask.sum())


def test_two_bodies_and_nested_void():
    m = np.zeros((12, 5, 5), bool)
    m[:5] = hollow(5)
    m[7:, 1:4, 1:4] = True
    vol = voxel_volume(m)
    assert vol.cell_components[1] == 2
    assert vol.n_voids == 1
    assert vol.group_is_void.tolist() == [False, False, True]
    assert vol.group_signed_volume[0] > vol.group_signed_volume[1] > 0


# ----------------------------------------------------------------- interpolation

def test_interpolation_is_linear_in_tetra_and_trilinear_in_hexa():
    rng = np.random.default_rng(1)
    q = rng.uniform(-0.5, 4.5, (3000, 3))
    for tetra in [True, False]:
        vol = voxel_volume(np.ones((4, 4, 4), bool), tetra=tetra, jitter=0.15)
        vol.add_field("lin", 2 * vol.points[:, 0] - vol.points[:, 1] + 0.5 * vol.points[:, 2])
        val = vol.interpolate(q, "lin")
        cid = vol.to_pyvista().find_containing_cell(q)
        inside = cid >= 0
        # outside is NaN, inside agrees with VTK's point location
        assert np.array_equal(~np.isnan(val), inside)
        np.testing.assert_allclose(val[inside], (q[inside] @ [2, -1, 0.5]), atol=1e-12)
    # non-linear field: agree with a brute-force barycentric search over every cell
    vol = voxel_volume(np.ones((3, 3, 3), bool), tetra=True, jitter=0.15)
    f = np.sin(vol.points).sum(axis=1)
    vol.add_field("q", f)
    q = q[:300] * 0.7
    pts = vol.points[vol.cells]
    lam = np.linalg.solve((pts[:, 1:] - pts[:, :1]).transpose(0, 2, 1)[None], (q[:, None] - pts[None, :, 0])[..., None])[..., 0]
    lam = np.concatenate([1 - lam.sum(axis=2, keepdims=True), lam], axis=2)  # (K, M, 4)
    inside = (lam >= -1e-9).all(axis=2)
    first = np.where(inside.any(axis=1), inside.argmax(axis=1), -1)
    ref = np.where(first >= 0, (lam[np.arange(len(q)), first] * f[vol.cells[first]]).sum(axis=1), np.nan)
    np.testing.assert_allclose(vol.interpolate(q, "q"), ref, atol=1e-10)


def test_trilinear_matches_shape_functions_at_nodes_and_centre():
    vol = voxel_volume(np.ones((1, 1, 1), bool), jitter=0.1, seed=3)
    s = np.arange(8.0) ** 2
    vol.add_field("s", s)
    np.testing.assert_allclose(vol.interpolate(vol.points[vol.cells[0]], "s"), s[vol.cells[0]], atol=1e-9)


# ------------------------------------------------------------------- conversion

def test_pyvista_and_meshio_round_trips(tmp_path):
    vol = voxel_volume(ring(4, 2), tetra=True, jitter=0.1)
    vol.add_field("f", vol.points[:, 2] ** 2)
    back = UnstructuredVolume.from_pyvista(vol.to_pyvista())
    np.testing.assert_array_equal(back.cells, vol.cells)
    np.testing.assert_array_equal(back.fields["f"], vol.fields["f"])
    m = vol.to_meshio()
    # meshers write boundary triangles beside the tetra: they are ignored
    m.cells.append(meshio.CellBlock("triangle", vol.boundary_face_nodes))
    back = UnstructuredVolume.from_meshio(m)
    np.testing.assert_array_equal(back.cells, vol.cells)
    path = tmp_path / "v.vtu"
    vol.to_meshio().write(path)
    back = UnstructuredVolume.read(path)
    np.testing.assert_allclose(back.points, vol.points)
    np.testing.assert_allclose(back.scalars("f"), vol.fields["f"])


def test_voxels_become_hexahedra():
    img = pv.ImageData(dimensions=(3, 3, 3))
    img.point_data["z"] = img.points[:, 2]
    vol = UnstructuredVolume.from_pyvista(img)
    assert vol.cell_type == "hexa" and vol.n_cells == 8
    assert vol.group_signed_volume[0] == pytest.approx(8.0)


# ------------------------------------------------------------------- bad input

def unit_tet():
    return np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]), np.array([[0, 1, 2, 3]])


def test_mixed_cell_types_are_refused():
    tet = pv.UnstructuredGrid({pv.CellType.TETRA: np.array([[0, 1, 2, 3]]), pv.CellType.HEXAHEDRON: np.arange(4, 12)[None]},
                              np.vstack([unit_tet()[0], pv.ImageData(dimensions=(2, 2, 2)).points + 2]))
    with pytest.raises(VolumeError, match="1 tetra, 1 hexahedron"):
        UnstructuredVolume.from_pyvista(tet)
    m = meshio.Mesh(tet.points, [("tetra", [[0, 1, 2, 3]]), ("wedge", [[4, 5, 6, 7, 8, 9]])])
    with pytest.raises(VolumeError, match="1 tetra, 1 wedge"):
        UnstructuredVolume.from_meshio(m)


@pytest.mark.parametrize(
    "points, cells, match",
    [
        (np.zeros((4, 2)), [[0, 1, 2, 3]], r"points must have shape \(N, 3\); got \(4, 2\)"),
        (unit_tet()[0], [[0, 1, 2, 3, 0]], r"cells must have shape .* got \(1, 5\)"),
        (unit_tet()[0], np.zeros((0, 4), int), "cells is empty"),
        (unit_tet()[0], [[0, 1, 2, 4]], r"outside 0..3, e.g. cells \[0\]"),
        (unit_tet()[0], [[0, 1, -1, 3]], r"outside 0..3"),
        (unit_tet()[0], [[0, 1, 1, 3]], r"repeat a node, e.g. cells \[0\]"),
        (np.where(np.eye(4, 3) > 0, np.nan, 0.0), [[0, 1, 2, 3]], r"NaN or infinite coordinates, e.g. points \[0, 1, 2\]"),
    ],
)
def test_malformed_arrays_are_named(points, cells, match):
    with pytest.raises(VolumeError, match=match):
        UnstructuredVolume(points, cells)


def test_bad_scalars_are_named():
    p, c = unit_tet()
    with pytest.raises(VolumeError, match=r"'s' has 1 NaN or infinite values, e.g. at nodes \[2\]"):
        UnstructuredVolume(p, c, {"s": [0, 1, np.nan, 3]})
    with pytest.raises(VolumeError, match=r"'s' has 1 NaN or infinite values, e.g. at nodes \[0\]"):
        UnstructuredVolume(p, c, {"s": [np.inf, 1, 2, 3]})
    with pytest.raises(VolumeError, match=r"field 's' must have shape \(4,\)"):
        UnstructuredVolume(p, c, {"s": [0, 1, 2]})
    with pytest.raises(VolumeError, match="no field 't'"):
        UnstructuredVolume(p, c, {"s": [0, 1, 2, 3]}).scalars("t")


def test_degenerate_and_inverted_cells_are_named():
    p, c = unit_tet()
    pts = np.vstack([p, [[2, 0, 0], [3, 0, 0], [2, 1, 0], [3, 1, 0]]])
    flat = [[0, 1, 2, 3], [4, 5, 6, 7]]  # the second lies in the plane z = 0
    with pytest.raises(VolumeError, match=r"1 degenerate cells have zero volume, e.g. cells \[1\]"):
        UnstructuredVolume(pts, flat)
    pts = np.vstack([p, p + 3])
    inv = [[0, 1, 2, 3], [4, 6, 5, 7]]
    with pytest.raises(VolumeError, match=r"1 of 2 cells are inverted .* e.g. cells \[1\]"):
        UnstructuredVolume(pts, inv)
    fixed = UnstructuredVolume(pts, inv, orient=True)
    assert fixed.cells[1].tolist() == [4, 5, 6, 7]
    # an inverted hexahedron, and one folded at a corner
    cube = pv.ImageData(dimensions=(2, 2, 2)).points[[0, 1, 3, 2, 4, 5, 7, 6]]
    with pytest.raises(VolumeError, match=r"inverted .* cells \[0\]"):
        UnstructuredVolume(cube, [[4, 5, 6, 7, 0, 1, 2, 3]])
    folded = cube.copy()
    folded[6] = [0.2, 0.2, 0.2]  # the far corner pushed inside
    with pytest.raises(VolumeError, match=r"folded or degenerate at a corner .* cells \[0\]"):
        UnstructuredVolume(folded, [list(range(8))])


def test_face_shared_by_three_cells_is_refused():
    p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1], [0.3, 0.3, 2]])
    vol = UnstructuredVolume(p, [[0, 1, 2, 3], [0, 2, 1, 4], [0, 1, 2, 5]], validate=True)
    with pytest.raises(VolumeError, match=r"shared by 3 cells \[0, 1, 2\]"):
        vol.face_neighbors


def test_unreferenced_nodes_are_reported():
    p, c = unit_tet()
    with pytest.warns(VolumeWarning, match=r"1 of 5 nodes are used by no cell, e.g. nodes \[4\]"):
        vol = UnstructuredVolume(np.vstack([p, [[5, 5, 5]]]), c, {"s": np.arange(5.0)})
    assert vol.unreferenced_nodes.tolist() == [4]
    clean = vol.remove_unreferenced_nodes()
    assert clean.n_points == 4 and clean.fields["s"].tolist() == [0, 1, 2, 3]


def test_same_table_as_itertools_reference_on_random_tets():
    # Delaunay tets of random points: face neighbours match the brute-force table
    rng = np.random.default_rng(7)
    cloud = pv.PolyData(rng.uniform(0, 1, (300, 3))).delaunay_3d()
    vol = UnstructuredVolume.from_pyvista(cloud, orient=True)
    np.testing.assert_array_equal(vol.face_neighbors, brute_neighbors(vol.cells, TET_FACES))
    # a convex hull is one sphere-like group
    assert vol.n_boundary_groups == 1 and vol.n_through_holes == 0 and vol.n_voids == 0
    assert len(list(itertools.islice(iter(vol.boundary_cells), 3))) == 3


# ---------------------------------------------------------------------- renumbering

@pytest.mark.parametrize("tetra", [False, True])
def test_reordered_is_the_same_volume_numbered_along_a_curve(tetra):
    from polygen.volume import isosurface

    base = voxel_volume(hollow(6), tetra=tetra)
    rng = np.random.default_rng(3)
    # scramble the numbering first, so that the renumbering has work to do
    pn, pc = rng.permutation(base.n_points), rng.permutation(base.n_cells)
    inv = np.empty_like(pn)
    inv[pn] = np.arange(pn.size)
    values = np.linalg.norm(base.points - base.points.mean(0), axis=1)
    vol = UnstructuredVolume(base.points[pn], inv[base.cells[pc]], {"r": values[pn]})
    new, node_order, cell_order = vol.reordered(return_permutations=True)
    # a relabelling: same points, same cells (as point sets), same field
    np.testing.assert_array_equal(new.points, vol.points[node_order])
    np.testing.assert_array_equal(node_order[new.cells], vol.cells[cell_order])
    np.testing.assert_array_equal(new.fields["r"], vol.fields["r"][node_order])
    assert sorted(node_order.tolist()) == list(range(vol.n_points))
    assert sorted(cell_order.tolist()) == list(range(vol.n_cells))
    # the topology and an isosurface do not depend on the numbering
    assert new.boundary_faces.shape == vol.boundary_faces.shape
    assert new.group_genus.tolist() == vol.group_genus.tolist() and new.n_voids == vol.n_voids == 1
    a = isosurface.extract(vol, 0.4 * values.max())
    b = isosurface.extract(new, 0.4 * values.max())
    assert a.n_triangles == b.n_triangles > 0
    assert abs(a.area() - b.area()) <= 1e-12 * a.area()
    # and neighbours end up closer in number than in the scrambled volume
    def gap(v):
        fn = v.face_neighbors
        c = np.repeat(np.arange(v.n_cells), fn.shape[1])[fn.ravel() >= 0]
        return np.median(np.abs(c - fn.ravel()[fn.ravel() >= 0]))

    assert gap(new) < 0.2 * gap(vol)


def test_points_range_is_numpys_min_max_and_finiteness():
    """The constructor's one-pass coordinate check: numpy's per-axis min and max, False on NaN or inf."""
    from polygen.volume import _topology as k

    rng = np.random.default_rng(3)
    for n in (1, 7, 1000):
        p = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-200, 200, size=(n, 3))
        lo, hi = np.zeros(3), np.zeros(3)
        assert k.points_range(p, lo, hi)
        assert np.array_equal(lo, p.min(axis=0)) and np.array_equal(hi, p.max(axis=0))
        for bad in (np.nan, np.inf, -np.inf):
            q = p.copy()
            q[rng.integers(n), rng.integers(3)] = bad
            assert not k.points_range(q, lo, hi)


def test_field_overflow_check_uses_the_largest_coordinate():
    """``add_field`` compares ``2 (max - min) max|x|`` with float64's range: max|x| is np.abs(points).max()."""
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, -1e300]])
    vol = UnstructuredVolume(pts, np.array([[0, 1, 2, 3]]), validate=False)
    assert vol._coord_abs_max == np.abs(pts).max()
    with pytest.raises(VolumeError, match="overflows float64 in the crossing points"):
        vol.add_field("f", np.array([0.0, 1e10, 2.0, 3.0]))  # 2 * 1e10 * 1e300 overflows
    vol.add_field("g", np.array([0.0, 1e-300, 0.0, 0.0]))  # 2 * 1e-300 * 1e300 is finite


@pytest.mark.parametrize("tetra", [False, True])
def test_group_node_counts_with_a_node_on_two_groups(tetra):
    """Each group's Euler number counts its distinct nodes: a node shared by two groups (two cubes
    touching at a corner: two outer surfaces through one node) is counted in both, as np.unique of the
    (group, node) pairs counts it (the fallback of the node -> group array of ``_groups``)."""
    mask = np.zeros((2, 2, 2), bool)
    mask[0, 0, 0] = mask[1, 1, 1] = True
    vol = voxel_volume(mask, tetra=tetra)
    assert vol.n_boundary_groups == 2
    assert np.all(vol.group_euler == 2)  # two spheres, 8 nodes each (the shared corner in both)


@pytest.mark.parametrize("validate", [True, False])
@pytest.mark.parametrize("tetra", [True, False])
def test_one_pass_id_check_agrees_with_the_exact_checks(tetra, validate):
    # the constructor's parallel pass (ids in range, distinct, and which nodes are used) against numpy
    # on the same cells: bad ids raise the exact check's message whichever path ran; good ones give
    # bincount's unreferenced nodes, also when a cell's geometry is too close to the bound for the pass
    vol = voxel_volume(np.ones((3, 3, 2), bool), tetra=tetra, jitter=0.1, seed=3)
    rng = np.random.default_rng(5)
    n = vol.n_points
    points = np.vstack([vol.points, rng.uniform(0, 1, (4, 3))])  # four spare nodes, used by nobody
    for trial in range(12):
        cells = vol.cells.copy()
        c = int(rng.integers(cells.shape[0]))
        kind = trial % 3
        if kind == 0:
            cells[c, int(rng.integers(cells.shape[1]))] = int(rng.choice([-1, n + 4, n + 100]))
            with pytest.raises(VolumeError, match=r"outside 0\.\.%d, e\.g\. cells \[%d\]" % (n + 3, c)):
                UnstructuredVolume(points, cells, validate=validate)
        elif kind == 1:
            i, j = rng.choice(cells.shape[1], 2, replace=False)
            cells[c, i] = cells[c, j]
            with pytest.raises(VolumeError, match=r"repeat a node, e\.g\. cells \[%d\]" % c):
                UnstructuredVolume(points, cells, validate=validate)
        else:
            with pytest.warns(VolumeWarning, match="4 of"):
                got = UnstructuredVolume(points, cells, validate=validate)
            want = np.flatnonzero(np.bincount(cells.ravel(), minlength=n + 4) == 0)
            assert got.unreferenced_nodes.tolist() == want.tolist() == list(range(n, n + 4))


def test_borderline_tetrahedron_is_counted_in_the_used_nodes(monkeypatch):
    # a tetrahedron the one-pass check cannot call clearly valid but the exact check accepts: its nodes
    # are still counted as used (the pass marks only the cells it calls valid)
    from polygen.volume import mesh as _mesh

    p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1.0]])
    cells = [[0, 1, 2, 3], [1, 2, 3, 4][::-1]]
    vol = UnstructuredVolume(p, cells, orient=True)  # the second one the right way round
    ratios = [abs(float(np.linalg.det(p[c[1:]] - p[c[0]]))) / max(np.linalg.norm(p[a] - p[b]) for a in c for b in c)**3
              for c in vol.cells]
    # the bound a hair below the flatter cell's 6V / longest^3: the exact check (|6V| <= rtol longest^3 is
    # degenerate) accepts it, the pass (with its 1e-9 margin) does not call it clearly valid
    monkeypatch.setattr(_mesh, "_DEGENERATE_RTOL", min(ratios) * (1 - 1e-12))
    got = UnstructuredVolume(p, vol.cells)
    assert got.unreferenced_nodes.size == 0


def test_cells_and_edges_are_int32_and_the_callers_int64_cells_are_untouched():
    """The volume keeps int32 node ids (16 bytes per tetrahedron, not 32) from a caller's int64 cells; it
    neither keeps nor writes the caller's array (orient=True reorders only its copy), and its surfaces are
    VTK's contour of the caller's own int64 mesh."""
    from polygen.volume import datasets, isovalues

    src = datasets.load("data1")
    cells = np.array(src.cells, np.int64)
    cells[::7, 1], cells[::7, 2] = cells[::7, 2].copy(), cells[::7, 1].copy()  # inverted: orient reorders
    before = cells.copy()
    s = src.scalars("fem")
    vol = UnstructuredVolume(src.points, cells, {"fem": s}, orient=True)
    np.testing.assert_array_equal(cells, before)
    assert vol.cells.dtype == vol.edges.dtype == np.int32
    assert not np.shares_memory(vol.cells, cells)
    np.testing.assert_array_equal(vol.cells[1::7], cells[1::7])  # the rows orient did not touch
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: before}, src.points)  # VTK's own int64 ids
    grid.point_data["fem"] = s
    for value in isovalues(s, 5):
        ref = grid.contour([value], scalars="fem")
        for iso in (vol.isosurface(value, prepare=False), vol.isosurface(value, prepare=True)):
            assert (iso.n_triangles, iso.n_vertices) == (ref.n_cells, ref.n_points), value
            assert iso.area() == pytest.approx(ref.area, rel=1e-9), value


@pytest.mark.parametrize("shift", [2**32, -2**32])
def test_int64_ids_that_would_wrap_into_range_are_refused(shift):
    """An int64 id 2**32 away from a valid one narrows to that id in int32: it is named before narrowing."""
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    cells = np.array([[0, 1, 2, 3]], np.int64)
    cells[0, 2] += shift
    with pytest.raises(VolumeError, match="outside 0..3"):
        UnstructuredVolume(points, cells)

"""The volume's topology tables (issue 20): parallel, 32-bit, bucketed by smallest node -- against brute force."""

import numba
import numpy as np
import pytest

from polygen.volume import UnstructuredVolume, VolumeError, datasets
from polygen.volume import _topology as _k


def brute_csr(keys, n_keys):
    order = np.argsort(keys, kind="stable")
    offsets = np.zeros(n_keys + 1, np.int64)
    np.cumsum(np.bincount(keys, minlength=n_keys), out=offsets[1:])
    return offsets, order


def brute_tables(vol):
    """Face neighbours and edges by sorting node-sorted rows with numpy (no buckets, no kernels)."""
    m = vol.n_cells
    faces = np.sort(vol.cells[:, vol.local_faces], axis=2).reshape(m * vol.local_faces.shape[0], -1)
    _, inv, cnt = np.unique(faces, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    nb = np.full(faces.shape[0], -1, np.int64)
    order = np.argsort(inv, kind="stable")
    starts = np.r_[0, np.cumsum(cnt)[:-1]]
    two = starts[cnt == 2]
    a, b = order[two], order[two + 1]
    nf = vol.local_faces.shape[0]
    nb[a], nb[b] = b // nf, a // nf
    edges = np.sort(vol.cells[:, vol.local_edges], axis=2).reshape(-1, 2)
    uniq, inv = np.unique(edges, axis=0, return_inverse=True)  # rows sorted by a, then b
    return nb.reshape(m, nf), uniq, inv.reshape(m, -1)


@pytest.mark.parametrize("n, n_keys", [(1000, 7), (300_000, 50_000), (300_000, 3)])
def test_stable_csr_is_a_stable_counting_sort(n, n_keys):
    keys = np.random.default_rng(n_keys).integers(0, n_keys, n)
    for threads in (1, numba.config.NUMBA_NUM_THREADS):
        numba.set_num_threads(threads)
        try:
            off, order = _k.csr_from_keys(keys, n_keys)
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        ref_off, ref_order = brute_csr(keys, n_keys)
        np.testing.assert_array_equal(off, ref_off)
        np.testing.assert_array_equal(order, ref_order)


@pytest.mark.parametrize("name", ["data1", "hexa1", "data2", "genus3"])
def test_tables_equal_brute_force(name):
    vol = datasets.load(name)
    nb, edges, cell_edges = brute_tables(vol)
    np.testing.assert_array_equal(vol.face_neighbors, nb)
    np.testing.assert_array_equal(vol.edges, edges)
    np.testing.assert_array_equal(vol.cell_edges, cell_edges)
    off, cells = vol.node_cells
    ref_off, order = brute_csr(vol.cells.ravel(), vol.n_points)
    np.testing.assert_array_equal(off, ref_off)
    np.testing.assert_array_equal(cells, order // vol.cells.shape[1])  # ascending cell ids per node
    assert vol.face_neighbors.dtype == vol.cell_edges.dtype == cells.dtype == np.int32
    assert vol.edges.dtype == vol.cells.dtype == np.int32 and off.dtype == np.int64


def test_tables_do_not_depend_on_the_number_of_threads_or_the_node_order():
    base = datasets.load("data2")
    rng = np.random.default_rng(3)
    perm = rng.permutation(base.n_points)  # new node i is old node perm[i]: buckets of other sizes
    inv = np.argsort(perm)
    vol = UnstructuredVolume(base.points[perm], inv[base.cells], validate=False)
    nb, edges, cell_edges = brute_tables(vol)
    for threads in (1, numba.config.NUMBA_NUM_THREADS):
        fresh = UnstructuredVolume(vol.points, vol.cells, validate=False)
        numba.set_num_threads(threads)
        try:
            fresh.build_topology()
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        np.testing.assert_array_equal(fresh.face_neighbors, nb)
        np.testing.assert_array_equal(fresh.edges, edges)
        np.testing.assert_array_equal(fresh.cell_edges, cell_edges)


def test_a_node_in_many_cells_sorts_its_long_bucket():
    # a fan of 200 tetrahedra around one axis: node 0 and 1 are in every cell (buckets of 200-600 entries)
    n = 200
    ang = 2 * np.pi * np.arange(n) / n
    ring = np.c_[np.cos(ang), np.sin(ang), np.zeros(n)]
    points = np.vstack([[0, 0, -1], [0, 0, 1], ring])
    cells = np.array([[0, 1, 2 + i, 2 + (i + 1) % n] for i in range(n)])
    vol = UnstructuredVolume(points, cells, orient=True)
    nb, edges, cell_edges = brute_tables(vol)
    np.testing.assert_array_equal(vol.face_neighbors, nb)
    assert (vol.face_neighbors >= 0).sum() == 2 * n  # each cell meets both its neighbours in the fan
    np.testing.assert_array_equal(vol.edges, edges)
    np.testing.assert_array_equal(vol.cell_edges, cell_edges)
    assert vol.cell_components[1] == 1


def test_a_face_of_three_cells_is_named_from_any_bucket():
    p = np.array([[0.3, 0.3, 2], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1], [0, 0, 0]])
    # the shared face (1, 2, 5)'s smallest node is 1, and node 0 is in one cell only
    cells = [[5, 1, 2, 3], [5, 2, 1, 4], [5, 1, 2, 0]]
    vol = UnstructuredVolume(p, cells, validate=False)
    with pytest.raises(VolumeError, match=r"shared by 3 cells \[0, 1, 2\]"):
        vol.face_neighbors


def test_preparation_drops_the_tables_only_it_reads():
    vol = datasets.load("genus3")
    v = float(np.median(vol.scalars()))
    vol.build_topology()
    full = {k: vol.memory_bytes()[k] for k in ("face_neighbors", "_edge_table", "node_cells", "cell_components")}
    nb, edges, cell_edges = vol.face_neighbors.copy(), vol.edges.copy(), vol.cell_edges.copy()
    iso = vol.isosurface(v, prepare=True)
    mem = vol.memory_bytes()
    assert not {"face_neighbors", "node_cells", "cell_components"} & set(mem)
    assert mem["_edge_table"] == vol.edges.nbytes < full["_edge_table"]  # cell_edges gone, edges kept
    again = vol.isosurface(v)
    assert np.array_equal(again.triangles, iso.triangles) and not {"face_neighbors", "node_cells"} & set(vol.memory_bytes())
    # a later reader builds them again, the same
    np.testing.assert_array_equal(vol.cell_edges, cell_edges)
    np.testing.assert_array_equal(vol.edges, edges)
    np.testing.assert_array_equal(vol.face_neighbors, nb)


def brute_duplicates(cells):
    """(count, (earlier, later) pairs in order of the later cell) by a dict of sorted node tuples."""
    seen, pairs = {}, []
    for c, row in enumerate(np.sort(cells, axis=1)):
        key = tuple(row.tolist())
        if key in seen:
            pairs.append((seen[key], c))
        else:
            seen[key] = c
    return len(pairs), pairs


@pytest.mark.parametrize("name", ["data1", "hexa1"])
def test_duplicate_check_against_a_dictionary(name):
    # the constructor's hash check: the count and the (earlier, later) pairs of a brute-force dictionary of
    # sorted node tuples, with copies in other node orders spread through the volume and at its end
    vol = datasets.load(name)
    rng = np.random.default_rng(5)
    picks = rng.choice(vol.n_cells, 40, replace=False)
    copies = vol.cells[picks][:, rng.permutation(vol.cells.shape[1])]
    # int32 and writable, as the constructor hands its copy to the check (one build of its kernels)
    cells = np.concatenate([vol.cells, copies, vol.cells[picks[:3]]]).astype(np.int32)
    count, pairs = brute_duplicates(cells)
    assert count == 43
    for limit in (5, 50):
        n, got = _k.find_duplicate_cells(cells, limit=limit)
        assert n == count
        np.testing.assert_array_equal(got, np.array(pairs[:limit], np.int64).reshape(-1, 2))
    assert _k.find_duplicate_cells(vol.cells.copy())[0] == 0


@pytest.mark.parametrize("width", [4, 8])
@pytest.mark.parametrize("dtype,readonly", [(np.int32, True), (np.int64, False)])
def test_constructor_pass_against_numpy_and_a_dictionary(width, dtype, readonly):
    """The constructor's one pass (:func:`own_cells`) on 300,000 rows (a slab per thread): its copy is the
    rows narrowed by numpy, in memory of its own; its count of rows that are not clearly valid and its
    marks of used nodes are those of numpy's checks (ids out of range, repeated, inverted or flat
    tetrahedra); and its counts by smallest node give the duplicates of a dictionary of sorted rows."""
    from polygen.volume.mesh import _DEGENERATE_RTOL

    rng = np.random.default_rng(width)
    n, m = 40_000, 300_000
    rows = rng.integers(0, n // 2, m)[:, None] + np.cumsum(rng.integers(1, n // (2 * width), (m, width)), axis=1)
    rows = rng.permuted(rows, axis=1)  # distinct ids, any order
    picks = rng.choice(m, 50, replace=False)
    rows = np.concatenate([rows, rng.permuted(rows[picks], axis=1)])  # 50 repeats in other node orders
    points = rng.random((n, 3))
    broken = rows.copy()
    wrong = rng.choice(m, 60, replace=False)
    broken[wrong[:20], 1] = n  # out of range
    broken[wrong[20:40], 2] = -1
    broken[wrong[40:], 3] = broken[wrong[40:], 0]  # a repeated node
    for cells, geometry in ((broken, width == 4), (rows, False), (rows, width == 4)):
        cells = np.ascontiguousarray(cells, dtype)
        cells.setflags(write=not readonly)
        used = np.zeros(n, np.uint8)
        copy, bad, counted = _k.own_cells(points, cells, np.int32, geometry, _DEGENERATE_RTOL, used)
        np.testing.assert_array_equal(copy, cells.astype(np.int32))
        assert copy.dtype == np.int32 and not np.shares_memory(copy, cells)
        assert counted[0].size - 1 == min(numba.get_num_threads(), 8, (m + 50) // 65536)  # slabs
        ids_ok = ((cells >= 0) & (cells < n)).all(axis=1) & (np.diff(np.sort(cells, axis=1), axis=1) > 0).all(axis=1)
        ok = ids_ok.copy()
        if geometry:
            v6, longest = _k.tet_volumes6(points, np.clip(cells, 0, n - 1))
            bound = _DEGENERATE_RTOL * longest ** 3
            assert not np.any(np.abs(v6 - bound) < 1e-6 * bound)  # no cell on the bound: numpy decides alike
            ok &= v6 > bound
        assert bad == m + 50 - ok.sum() and (bad > 1000 if geometry else bad == 60 * (not ids_ok.all()))
        expect = np.zeros(n, np.uint8)
        expect[cells[ok].ravel()] = 1
        np.testing.assert_array_equal(used, expect)
        if ids_ok.all():
            count, pairs = brute_duplicates(cells)
            assert count == 50
            for given in (counted, None):
                got = _k.find_duplicate_cells(copy, limit=50, n_nodes=n, counted=given)
                assert got[0] == count
                np.testing.assert_array_equal(got[1], np.array(pairs, np.int64))


@pytest.mark.parametrize("width", [4, 8])
def test_duplicate_check_with_a_node_in_very_many_cells(width):
    # one node in every cell (a fan): its group holds them all, past the pairwise comparison's size, and is
    # sorted by hash instead; repeats in other node orders, spread through, against the dictionary
    rng = np.random.default_rng(11)
    rest = np.array([rng.choice(np.arange(1, 60), width - 1, replace=False) for _ in range(400)])
    cells = np.concatenate([np.zeros((400, 1), np.int64), rest], axis=1)
    picks = rng.choice(400, 30, replace=False)
    copies = cells[picks][:, rng.permutation(width)]
    cells = np.ascontiguousarray(np.insert(cells, np.sort(rng.choice(400, 30)), copies, axis=0), np.int32)
    count, pairs = brute_duplicates(cells)
    assert count >= 30
    for limit in (5, 100):
        n, got = _k.find_duplicate_cells(cells, limit=limit)
        assert n == count
        np.testing.assert_array_equal(got, np.array(pairs[:limit], np.int64).reshape(-1, 2))

"""The boundary check (non-manifold boundary edges and nodes) against the sort-based one it replaced.

Oracle: the earlier numpy implementation (a lexsort of every boundary-face
edge, then the corner fans), kept here verbatim except that its union-find
kernel is replaced by scipy's connected components over the corner graph.
Exact equality is asserted: the same edges in the same order, the same
nodes, the same dtypes. Ground truth for planted defects: two cubes that
share only an edge have one edge on four faces and two nodes with two fans;
two that share only a corner have one node with two fans.
"""

import types

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from polygen.volume import _thinning_kernels as _tk
from polygen.volume import datasets
from polygen.volume.homology import boundary_defects
from polygen.volume.thinning import cell_subset_volume

from _surfaces import block_volume  # noqa: E402


def _defects_by_sort(vol):
    """The implementation before the kernel: global lexsort of the face edges, fans by components."""
    fn = np.ascontiguousarray(vol.boundary_face_nodes, np.int64)
    nbf, k = fn.shape
    if nbf == 0:
        return np.zeros((0, 2), np.int64), np.zeros(0, np.int64)
    corner = np.arange(nbf * k, dtype=np.int64).reshape(nbf, k)
    a = fn.ravel()
    b = np.roll(fn, -1, axis=1).ravel()
    ca = corner.ravel()
    cb = np.roll(corner, -1, axis=1).ravel()
    swap = a > b
    lo, hi = np.where(swap, b, a), np.where(swap, a, b)
    clo, chi = np.where(swap, cb, ca), np.where(swap, ca, cb)
    order = np.lexsort((hi, lo))
    lo, hi, clo, chi = lo[order], hi[order], clo[order], chi[order]
    start = np.flatnonzero(np.r_[True, (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])])
    count = np.diff(np.r_[start, lo.size])
    bad_edges = np.stack([lo[start[count != 2]], hi[start[count != 2]]], axis=1)
    two = start[count == 2]
    # corners joined across each edge on two faces: lower node's corners, higher node's corners
    i = np.concatenate([clo[two], chi[two]])
    j = np.concatenate([clo[two + 1], chi[two + 1]])
    n = nbf * k
    _, label = connected_components(coo_matrix((np.ones(i.size), (i, j)), shape=(n, n)), directed=False)
    key = np.unique(a * n + label)
    node_of = key // n
    fans = np.bincount(node_of, minlength=vol.n_points)
    return bad_edges.astype(np.int64), np.flatnonzero(fans > 1).astype(np.int64)


def assert_same(vol):
    got_e, got_n = boundary_defects(vol)
    want_e, want_n = _defects_by_sort(vol)
    assert got_e.dtype == want_e.dtype == np.int64 and got_n.dtype == want_n.dtype == np.int64
    assert got_e.shape == want_e.shape and got_n.shape == want_n.shape
    assert np.array_equal(got_e, want_e) and np.array_equal(got_n, want_n)
    return got_e.shape[0], got_n.shape[0]


@pytest.mark.parametrize("name", ["data1", "data2", "data3", "data4", "hexa1", "hexa2", "hexa3"])
def test_same_as_sort_on_data(name):
    assert assert_same(datasets.load(name)) == (0, 0)


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_planted_edge_and_node(cell_type):
    edge = np.zeros((2, 2, 1), bool)
    edge[0, 0, 0] = edge[1, 1, 0] = True  # two cubes along one edge
    corner = np.zeros((2, 2, 2), bool)
    corner[0, 0, 0] = corner[1, 1, 1] = True  # two cubes at one corner
    vol = block_volume(edge, cell_type)
    assert assert_same(vol) == (1, 2)
    e, n = boundary_defects(vol)
    assert set(e[0].tolist()) == set(n.tolist())  # the shared edge's two nodes have two fans each
    assert assert_same(block_volume(corner, cell_type)) == (0, 1)


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_same_as_sort_on_random_blocks(cell_type):
    rng = np.random.default_rng(20 if cell_type == "tetra" else 21)
    n_edges = n_nodes = 0
    for _ in range(40):
        keep = rng.random(tuple(rng.integers(2, 6, 3))) < rng.uniform(0.3, 0.8)
        if not keep.any():
            continue
        e, n = assert_same(block_volume(keep, cell_type))
        n_edges += e
        n_nodes += n
    assert n_edges > 0 and n_nodes > 0


@pytest.mark.parametrize("name", ["data1", "hexa1"])
def test_same_as_sort_on_random_cell_subsets(name):
    # random sub-selections of an unstructured mesh: many cells touching at edges and nodes only
    vol = datasets.load(name)
    rng = np.random.default_rng(2020)
    n_edges = n_nodes = 0
    for frac in (0.2, 0.5, 0.8, 0.95):
        for _ in range(3):
            e, n = assert_same(cell_subset_volume(vol, rng.random(vol.n_cells) < frac))
            n_edges += e
            n_nodes += n
    assert n_edges > 0 and n_nodes > 0


@pytest.mark.parametrize("k", [3, 4])
def test_empty_boundary(k):
    # a volume always has a boundary; the kernel and the wrapper still answer for none
    stub = types.SimpleNamespace(boundary_face_nodes=np.zeros((0, k), np.int64),
                                 boundary_edge_table=(np.zeros(0, np.int64), np.zeros((0, 2), np.int64)),
                                 n_points=5)
    e, n = boundary_defects(stub)
    assert e.shape == (0, 2) and n.shape == (0,) and e.dtype == n.dtype == np.int64
    e, n = _tk.boundary_defects(stub.boundary_face_nodes, stub.boundary_edge_table[0], 0, 5)
    assert e.shape == (0,) and n.shape == (0,)

"""Uniform refinement (:mod:`polygen.volume.datasets.refine`): every tetrahedron into eight, conforming.

Oracles: the parent's volume (exact on the tiny volumes' integer coordinates, whose midpoints are dyadic);
the constructor's checks (positive, non-degenerate children, no face of three cells); face counts (a
conforming refinement has four times the parent's boundary faces, and interior faces shared by two); the
boundary groups and genera of the parent; the fields at the parent's nodes.
"""

import numpy as np
import pytest

from polygen.volume import UnstructuredVolume, datasets
from polygen.volume.datasets import DatasetError
from polygen.volume.datasets.refine import refine_tetrahedra
from polygen.volume.datasets.registry import _REGISTRY, _refined_builder


def six_volumes(points, cells):
    p = points[cells]
    return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])


@pytest.mark.parametrize("name", ["one_tet", "two_tets", "torus", "hollow_cube", "genus3", "data1"])
@pytest.mark.parametrize("block", [1, 7, 1 << 20])
def test_each_tetrahedron_into_eight_conforming(name, block):
    vol = datasets.load(name)
    points, cells, fields, node_new = refine_tetrahedra(vol, block=block)
    m, n, n_edges = vol.n_cells, vol.n_points, vol.edges.shape[0]
    assert cells.shape == (8 * m, 4) and points.shape == (n + n_edges, 3)
    # the parent's volume, cell by cell: exact where the coordinates are small integers
    parent = six_volumes(vol.points, vol.cells)
    children = six_volumes(points, cells).reshape(m, 8)
    assert np.all(children > 0)
    if name != "data1":
        np.testing.assert_array_equal(children.sum(axis=1), parent)
        np.testing.assert_array_equal(children, np.repeat(parent[:, None] / 8, 8, axis=1))
    else:
        np.testing.assert_allclose(children.sum(axis=1), parent, rtol=1e-12, atol=0)
    # every node used, no duplicate cell, positive and non-degenerate, no face of three cells
    fine = UnstructuredVolume(points, cells, fields, validate=True)
    assert fine.unreferenced_nodes.size == 0
    fn = fine.face_neighbors
    # conforming: each parent's boundary face is split into four, every other face has two cells
    n_boundary = int((fn < 0).sum())
    assert n_boundary == 4 * int((vol.face_neighbors < 0).sum())
    assert (4 * fine.n_cells - n_boundary) % 2 == 0
    assert fine.n_boundary_groups == vol.n_boundary_groups
    np.testing.assert_array_equal(fine.group_genus, vol.group_genus)
    np.testing.assert_allclose(fine.group_signed_volume, vol.group_signed_volume, rtol=1e-12)
    # the coarse nodes keep their coordinates and values; a midpoint is its edge's mean
    np.testing.assert_array_equal(points[node_new], vol.points)
    assert np.all(np.diff(node_new) >= 1) and node_new[0] == 0  # the coarse order is kept
    mids = vol.edges[:, 0] + 1 + np.arange(n_edges)
    np.testing.assert_array_equal(points[mids], 0.5 * (vol.points[vol.edges[:, 0]] + vol.points[vol.edges[:, 1]]))
    for k, values in vol.fields.items():
        np.testing.assert_array_equal(fields[k][node_new], values)
        np.testing.assert_array_equal(fields[k][mids], 0.5 * (values[vol.edges[:, 0]] + values[vol.edges[:, 1]]))


def test_children_inside_their_parent():
    vol = datasets.load("data1")
    points, cells, _, _ = refine_tetrahedra(vol)
    centroids = points[cells].mean(axis=1)
    # barycentric coordinates of each child's centroid in its parent: all positive
    p = vol.points[np.repeat(vol.cells, 8, axis=0)]
    t = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]], axis=2)
    lam = np.linalg.solve(t, (centroids - p[:, 0])[:, :, None])[:, :, 0]
    assert np.all(lam > 0) and np.all(lam.sum(axis=1) < 1)


def test_refine_refuses_what_it_cannot_split():
    with pytest.raises(DatasetError, match="tetrahedra"):
        refine_tetrahedra(datasets.load("one_hex"))
    with pytest.raises(DatasetError, match="fields"):
        refine_tetrahedra(datasets.load("one_tet"), fields="cubic")
    with pytest.raises(DatasetError, match="block"):
        refine_tetrahedra(datasets.load("one_tet"), block=0)


def test_80M_is_10M_refined_with_its_analytic_fields():
    # the registry's builder on a small parent: the analytic fields evaluated again at every node equal the
    # parent's at its nodes (the box, hence the bumps and the eye, is the parent's); the FEM field interpolated
    info = datasets.info("80M")
    assert info.target_cells == 8 * datasets.info("10M").target_cells
    assert info.fields == datasets.info("10M").fields and not _REGISTRY["80M"].reorder
    assert _REGISTRY["80M"].params["parent_params"] == _REGISTRY["10M"].params
    points, cells, fields = _refined_builder("data1")(0, None)
    coarse = datasets.load("data1")
    assert cells.shape[0] == 8 * coarse.n_cells and list(fields) == list(coarse.fields)
    _, _, _, node_new = refine_tetrahedra(coarse, fields=None)
    for k in fields:
        np.testing.assert_array_equal(fields[k][node_new], coarse.scalars(k))

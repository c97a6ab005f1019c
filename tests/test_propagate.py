"""Propagation from seeds (thesis 5.4.2) against the full scan."""

import dataclasses

import numpy as np
import pytest

from polygen.volume import UnstructuredVolume
from polygen.volume.isosurface import IsoSurfaceError, extract
from polygen.volume.propagate import Propagator, propagate

from _surfaces import assert_same_surface, grid_volume  # noqa: E402
from _surfaces import oriented_triangles as triangle_set  # noqa: E402
from naive import one_seed_per_component  # noqa: E402


@pytest.mark.parametrize("tets", [True, False])
def test_propagation_from_all_intersected_cells_equals_scan(tets):
    vol = grid_volume((9, 8, 7), spacing=(0.3, 0.5, 0.7), tets=tets, jitter=0.15 if tets else 0.0, seed=1)
    rng = np.random.default_rng(7)
    s = rng.random(vol.n_points)
    prop = Propagator(vol, s)
    for value in np.linspace(0.05, 0.95, 7):
        scan = extract(vol, value, field=s)
        seeds = np.unique(scan.triangle_cells)
        iso = prop.extract(value, seeds)
        assert iso.method == "propagate"
        assert_same_surface(scan, iso, lookups=True)
        assert iso.cells_tested <= vol.n_cells


@pytest.mark.parametrize("tets", [True, False])
def test_propagation_from_one_seed_per_component(tets):
    vol = grid_volume((16, 14, 12), spacing=(0.1, 0.1, 0.1), tets=tets)
    x = vol.points
    # several blobs: closed surfaces and surfaces cut by the boundary
    s = (np.sin(9 * x[:, 0]) * np.cos(8 * x[:, 1]) * np.sin(7 * x[:, 2] + 0.3) + 0.2 * x[:, 0])
    prop = Propagator(vol, s)
    for value in (-0.5, -0.1, 0.2, 0.6):
        scan = extract(vol, value, field=s)
        seeds = one_seed_per_component(vol, scan)
        iso = prop.extract(value, seeds)
        assert_same_surface(scan, iso, lookups=True)
        assert scan.connected_components()[1] >= 1
        # propagation tests only the surface's cells and their neighbours
        assert iso.cells_tested < vol.n_cells
        assert iso.cells_tested >= iso.cells_intersected


@pytest.mark.parametrize("tets", [True, False])
def test_then_cells_are_tested_only_where_the_propagation_did_not_reach(tets):
    vol = grid_volume((16, 14, 12), spacing=(0.1, 0.1, 0.1), tets=tets)
    x = vol.points
    s = np.sin(9 * x[:, 0]) * np.cos(8 * x[:, 1]) * np.sin(7 * x[:, 2] + 0.3) + 0.2 * x[:, 0]
    prop = Propagator(vol, s)
    rng = np.random.default_rng(3)
    for value in (-0.5, -0.1, 0.2, 0.6):
        scan = extract(vol, value, field=s)
        seeds = one_seed_per_component(vol, scan)
        first, later = seeds[:1], rng.permutation(np.r_[seeds[1:], rng.integers(0, vol.n_cells, 300)])
        iso = prop.extract(value, first, then=later)
        assert_same_surface(scan, iso, lookups=True)
        reached_first = set(prop.extract(value, first).triangle_cells.tolist())
        prop.extract(value, first, then=later)
        # a later cell is tested only if the propagations before it did not reach it ...
        assert prop.last_then_tested <= np.unique(later).size
        assert not set(prop.last_then_seeds.tolist()) & reached_first
        # ... and each crossed one starts a part of the surface of its own (in a hexahedral mesh one
        # propagation can also pass between parts that meet only in a cell)
        labels, n = scan.connected_components()
        part = dict(zip(scan.triangle_cells.tolist(), labels.tolist()))
        started = [part[c] for c in prop.last_then_seeds.tolist()]
        assert len(set(started)) == len(started) <= n - 1
        if tets:
            assert len(started) == n - 1
        assert prop.last_seeds_tested == 1 and prop.last_seeds_crossed == 1


def test_gradient_normals_agree():
    vol = grid_volume((10, 10, 10), spacing=(0.1, 0.1, 0.1))
    s = np.linalg.norm(vol.points - 0.45, axis=1)
    scan = extract(vol, 0.3, field=s, normals="gradient")
    iso = propagate(vol, 0.3, np.unique(scan.triangle_cells)[:1], field=s, normals="gradient")
    assert_same_surface(scan, iso, lookups=True)


def test_generation_counter_and_repeated_queries():
    vol = grid_volume((8, 8, 8))
    s = np.linalg.norm(vol.points - 3.5, axis=1)
    prop = Propagator(vol, s)
    seed = np.unique(extract(vol, 2.0, field=s).triangle_cells)[:1]
    first = prop.extract(2.0, seed)
    g = prop.generation
    for _ in range(3):
        again = prop.extract(2.0, seed)
        assert_same_surface(first, again, lookups=True)
        assert again.cells_tested == first.cells_tested
    assert prop.generation == g + 3
    # the marks are stamps: nothing was reset, the last query's cells carry its generation
    assert np.count_nonzero(prop.visited == prop.generation) == first.cells_tested
    assert np.count_nonzero(prop.visited > 0) >= first.cells_tested


def test_fifo_order_is_breadth_first():
    vol = grid_volume((10, 10, 10))
    s = np.linalg.norm(vol.points - 4.5, axis=1)
    prop = Propagator(vol, s)
    seed = np.unique(extract(vol, 3.0, field=s).triangle_cells)[:1]
    iso = prop.extract(3.0, seed)
    order = prop.last_order
    assert order[0] == seed[0] and order.size == iso.cells_intersected
    assert np.unique(order).size == order.size
    rank = np.full(vol.n_cells, -1)
    rank[order] = np.arange(order.size)
    nb = vol.face_neighbors[order[1:]]
    # each later cell was registered by an earlier one: a face neighbour came before it
    parent_rank = np.where(nb >= 0, rank[np.maximum(nb, 0)], -1)
    parent_rank = np.where(parent_rank >= 0, parent_rank, np.iinfo(np.int64).max)
    assert np.all(parent_rank.min(axis=1) < np.arange(1, order.size))


def test_seeds_that_miss_and_empty_values():
    vol = grid_volume((6, 6, 6))
    s = vol.points[:, 0].copy()
    prop = Propagator(vol, s)
    far = np.flatnonzero(vol.points[vol.cells].mean(axis=1)[:, 0] > 4)[:5]
    iso = prop.extract(0.5, far)  # the plane x = 0.5 does not cross these cells
    assert iso.is_empty and iso.cells_tested == far.size and iso.cells_intersected == 0
    iso = prop.extract(99.0, np.arange(vol.n_cells))  # outside the range
    assert iso.is_empty and iso.cells_tested == vol.n_cells
    assert prop.extract(0.5, []).is_empty


def test_bad_seeds():
    vol = grid_volume((3, 3, 3))
    prop = Propagator(vol, vol.points[:, 0].copy())
    with pytest.raises(IsoSurfaceError, match="seed"):
        prop.extract(0.5, [vol.n_cells])
    with pytest.raises(IsoSurfaceError, match="seed"):
        prop.extract(0.5, [0.5])
    with pytest.raises(IsoSurfaceError, match="seed"):
        prop.extract(0.5, [[0, 1]])
    with pytest.raises(IsoSurfaceError, match="normals"):
        prop.extract(0.5, [0], normals="flat")


def test_same_surface_and_sweep():
    from polygen.volume import methods
    from polygen.volume.isosurface import same_surface

    vol = grid_volume((8, 7, 6), tets=True, jitter=0.1, seed=2)
    vol.add_field("f", np.sin(vol.points[:, 0]) + vol.points[:, 1] * 0.3)
    values = [0.2, 0.9, 1.4]
    ref = [extract(vol, v) for v in values]
    m = methods.get("span-filter")(vol)
    sw = methods.sweep(m, values, reference=ref)
    assert sw.same_as_reference and len(sw.surfaces) == 3
    assert sw.triangles == sum(r.n_triangles for r in ref) and sw.cells_intersected == sum(
        r.cells_intersected for r in ref)
    assert sw.seed_cells_tested > 0 and sw.query_s > 0
    assert same_surface(ref[0], sw.surfaces[0]) and not same_surface(ref[0], ref[1])
    assert not methods.sweep(m, values, reference=ref[::-1]).same_as_reference
    assert methods.sweep(m, values).same_as_reference is None
    moved = dataclasses.replace(ref[0], vertices=ref[0].vertices + 1e-9)
    assert same_surface(ref[0], moved, geometry=False) and not same_surface(ref[0], moved)


def test_one_method_vocabulary():
    # extract, UnstructuredVolume.isosurface and the CLI name methods alike: a registered name
    from polygen.volume import isovalues, registry
    from polygen.volume.surface import same_surface

    vol = grid_volume((7, 6, 5), jitter=0.2, seed=4)
    s = vol.points @ np.array([1.0, 0.4, -0.3])
    vol.add_field("s", s)
    for v in isovalues(s, 3):
        ref = extract(vol, v, field="s")
        assert ref.n_triangles > 0
        for name in registry.method_names():
            assert same_surface(extract(vol, v, field="s", method=name), ref, geometry=False), name
            assert same_surface(vol.isosurface(v, field="s", method=name), ref, geometry=False), name
        seeds = one_seed_per_component(vol, ref)
        assert same_surface(extract(vol, v, field="s", method="propagate", seeds=seeds), ref)
    with pytest.raises(IsoSurfaceError, match="span-space"):  # the message lists the registered names
        extract(vol, 0.5, field="s", method="octree")
    with pytest.raises(IsoSurfaceError, match="seeds"):
        extract(vol, 0.5, field="s", method="span-space", seeds=[0])


def test_isovalues():
    from polygen.volume import isovalues

    s = np.array([3.0, -1.0, 7.0, 2.0])
    np.testing.assert_array_equal(isovalues(s, 3), [1.0, 3.0, 5.0])  # (7 - -1) / 4 apart, ends excluded
    assert isovalues(s, 20).size == 20 and isovalues(s, 20).min() > -1 and isovalues(s, 20).max() < 7
    for bad in (0, -2, 2.5, True):
        with pytest.raises(IsoSurfaceError, match="count"):
            isovalues(s, bad)
    with pytest.raises(IsoSurfaceError, match="finite"):
        isovalues([1.0, np.nan], 3)


@pytest.mark.parametrize("tets", [True, False])
def test_hash_propagation_stores_no_edges(tets):
    """The paper's baseline keeps no edge table: preparing and extracting with the hash search (node-pair keys)
    leaves a fresh volume without its edge table and without the cell records (which hold the edge ids);
    the surface is the scan's once relabelled by edge id."""
    vol = grid_volume((9, 8, 7), spacing=(0.3, 0.5, 0.7), tets=tets, jitter=0.15 if tets else 0.0, seed=3)
    s = np.random.default_rng(5).random(vol.n_points)
    prop = Propagator(vol, s, vertex_keys="node-pairs")
    iso = prop.extract(0.5, np.arange(vol.n_cells))
    assert "_edge_table" not in vol.__dict__ and "cell_records" not in vol.__dict__
    assert set(prop.memory_bytes()) == {"records", "visited", "vertex_table", "buffers"}
    assert prop.memory_bytes()["records"] == prop.rec.nbytes == vol.n_cells * (vol.cells.shape[1]
                                                                               + vol.face_neighbors.shape[1]) * 4
    # the default labels the vertices by edge id: that builds the edge table, and the count says so
    labelled = Propagator(vol, s)
    ref = labelled.extract(0.5, np.arange(vol.n_cells))
    assert "_edge_table" in vol.__dict__
    mem = labelled.memory_bytes()
    assert mem["label_edge_list"] == vol.edges.nbytes and mem["label_cell_edges"] == vol.cell_edges.nbytes
    assert_same_surface(extract(vol, 0.5, field=s), ref, lookups=True)
    relabelled = dataclasses.replace(iso, vertex_keys=labelled._labels(iso.vertex_keys))
    assert_same_surface(ref, relabelled, lookups=True)
    with pytest.raises(IsoSurfaceError, match="node-pairs"):
        Propagator(vol, s, vertex_search="array", vertex_keys="node-pairs")
    with pytest.raises(IsoSurfaceError, match="vertex_keys"):
        Propagator(vol, s, vertex_keys="pairs")


def test_lookups_are_one_per_vertex_of_each_cell_built():
    """``vertex_lookups`` counts the searches the kernel makes, one per distinct polygon vertex of every cell
    it builds: counted again here from the triangles and the cells they were made in, for both searches."""
    vol = grid_volume((9, 8, 7), spacing=(0.3, 0.5, 0.7), tets=True, jitter=0.15, seed=4)
    s = np.random.default_rng(6).random(vol.n_points)
    for search in ("hash", "array"):
        iso = Propagator(vol, s, vertex_search=search).extract(0.45, np.arange(vol.n_cells))
        per_cell = sum(np.unique(iso.triangles[iso.triangle_cells == c]).size for c in np.unique(iso.triangle_cells))
        assert iso.vertex_lookups == per_cell > 0

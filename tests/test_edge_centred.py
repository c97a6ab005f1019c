"""Cell-edge-centred construction (Itoh et al. 2001) against the full scan and the hash-based propagation.

Both variants: the paper's, without stored edges (``EdgeCentredWalk``, method ``edge-centred``), and the one
with an edge table and an edge -> cells index (``EdgeCentredTable``, method ``edge-centred-table``).
"""

import numba
import time

import numpy as np
import pytest

from polygen.volume import UnstructuredVolume, datasets, methods
from polygen.volume.edge_centred import (
    EdgeCentred,
    EdgeCentredMethod,
    EdgeCentredTable,
    EdgeCentredTableMethod,
    EdgeCentredWalk,
    edge_centred,
    seed_source,
)
from polygen.volume.isosurface import IsoSurfaceError, extract, same_surface
from polygen.volume.propagate import Propagator

from _surfaces import assert_same_surface, grid_volume  # noqa: E402
from _surfaces import oriented_triangles as triangle_set  # noqa: E402


def one_seed_per_component(iso):
    """One cell per connected part of the surface (parts joined through shared vertices)."""
    labels, n = iso.connected_components()
    _, first = np.unique(labels, return_index=True)
    return iso.triangle_cells[first]


def expected_visits(vol, iso, collapsed=None):
    """For-loop (3) visits, by brute force: the cells around each vertex's edge (or node).

    ``collapsed``: the end nodes of the vertices registered for polygons that
    collapsed onto nodes and then dropped (``stats["collapsed"]``); they were
    visited too.
    """
    e_off, _ = vol.edge_cells
    n_off, _ = vol.node_cells
    ne = vol.edges.shape[0]
    k = iso.vertex_keys
    if collapsed is not None and len(collapsed):
        a, b = np.asarray(collapsed, np.int64).T
        pair = {(int(x), int(y)): i for i, (x, y) in enumerate(vol.edges)}
        extra = [ne + x if x == y else pair[(x, y)] for x, y in zip(a.tolist(), b.tolist())]
        k = np.concatenate([k, np.array(extra, k.dtype)])
    on_edge = k < ne
    return int(np.sum(np.diff(e_off)[k[on_edge]]) + np.sum(np.diff(n_off)[k[~on_edge] - ne]))


class EdgeCentredTableOtherLayout(EdgeCentredTable):
    """The table variant with the layout that is not its default (``records`` <-> ``volume``)."""

    def __init__(self, vol, field=None, **kw):
        other = {"records": "volume", "volume": "records"}[EdgeCentredTable.DEFAULT_LAYOUT]
        super().__init__(vol, field, layout=other, **kw)


BUILDERS = [EdgeCentredWalk, EdgeCentredTable, EdgeCentredTableOtherLayout]
METHODS = ["edge-centred", "edge-centred-table"]


@pytest.mark.parametrize("builder", BUILDERS)
@pytest.mark.parametrize("tets", [True, False])
def test_same_as_scan_and_hash_propagation(tets, builder):
    vol = grid_volume((9, 8, 7), spacing=(0.3, 0.5, 0.7), tets=tets, jitter=0.15 if tets else 0.0, seed=1)
    s = np.random.default_rng(7).random(vol.n_points)
    ec = builder(vol, s)
    prop = Propagator(vol, s)
    for value in np.linspace(0.05, 0.95, 7):
        scan = extract(vol, value, field=s)
        seeds = np.unique(scan.triangle_cells)
        iso = ec.extract(value, seeds)
        hashed = prop.extract(value, seeds)
        assert iso.method == builder.method
        assert_same_surface(scan, iso)
        assert_same_surface(hashed, iso)
        # the paper's point: no vertex is ever looked up again
        assert iso.vertex_lookups == 0 and hashed.vertex_lookups > iso.n_vertices
        st = ec.stats
        assert st["pops"] == st["constructed"] == iso.cells_intersected
        assert st["visits"] == expected_visits(vol, iso, st["collapsed"])
        assert st["visits"] > st["constructed"]  # a cell is visited several times by for-loop (3)
        assert iso.cells_tested == seeds.size  # every seed tested once; nothing else needs a test


@pytest.mark.parametrize("builder", BUILDERS)
@pytest.mark.parametrize("tets", [True, False])
@pytest.mark.parametrize("order", ["fifo", "lifo"])
def test_one_seed_per_surface_part(tets, order, builder):
    vol = grid_volume((16, 14, 12), spacing=(0.1, 0.1, 0.1), tets=tets)
    x = vol.points
    s = np.sin(9 * x[:, 0]) * np.cos(8 * x[:, 1]) * np.sin(7 * x[:, 2] + 0.3) + 0.2 * x[:, 0]
    ec = builder(vol, s, order=order)
    for value in (-0.5, -0.1, 0.2, 0.6):
        scan = extract(vol, value, field=s)
        seeds = one_seed_per_component(scan)
        assert seeds.size >= 2
        iso = ec.extract(value, seeds)
        assert_same_surface(scan, iso)
        assert iso.cells_tested < vol.n_cells


@pytest.mark.parametrize("builder", BUILDERS)
@pytest.mark.parametrize("tets", [True, False])
def test_values_exactly_on_nodes(tets, builder):
    """Crossings on nodes: the vertex is the node, shared by every cell around the node."""
    vol = grid_volume((8, 7, 6), tets=tets)
    rng = np.random.default_rng(3)
    s = rng.integers(0, 5, vol.n_points).astype(float)  # many nodes exactly at each value
    ec = builder(vol, s)
    every = np.arange(vol.n_cells)
    n_node_vertices = 0
    for value in (1.0, 2.0, 3.0, 4.0, 2.5):
        scan = extract(vol, value, field=s)
        iso = ec.extract(value, every)
        assert_same_surface(scan, iso)
        n_node_vertices += int(np.sum(iso.vertex_keys >= vol.edges.shape[0]))
        # from one seed per part: the node vertices carry the propagation across the node
        part = ec.extract(value, one_seed_per_component(scan))
        assert_same_surface(scan, part, cells=False)
        assert part.vertex_lookups == 0
        assert ec.stats["visits"] == expected_visits(vol, part, ec.stats["collapsed"])
    assert n_node_vertices > 0


@pytest.mark.parametrize("copy", [False, True])
def test_specialised_tetrahedron_kernel_is_the_generic_one(copy, monkeypatch):
    """``construct_tet`` (tetrahedra, records, LIFO) builds the generic kernel's surface: every array equal, in
    the same order, and the same counters -- on random values and on values exactly at many nodes, for the
    builder that owns the records and for a copy (its own stamps, states and slots)."""
    vol = grid_volume((9, 8, 7), spacing=(0.3, 0.5, 0.7), tets=True, jitter=0.15, seed=1)
    rng = np.random.default_rng(11)
    fields = [rng.random(vol.n_points), rng.integers(0, 5, vol.n_points).astype(float)]
    n_node_vertices = 0
    for s, values in zip(fields, [np.linspace(0.05, 0.95, 7), [1.0, 2.0, 2.5, 3.0]]):
        owner = EdgeCentredTable(vol, s)
        b = owner.copy() if copy else owner
        for value in values:
            scan = extract(vol, value, field=s)
            for seeds, cells in ((np.unique(scan.triangle_cells), True), (one_seed_per_component(scan), False)):
                got = {}
                for specialised in (True, False):
                    monkeypatch.setattr(EdgeCentredTable, "SPECIALISED_KERNEL", specialised)
                    iso = b.extract(value, seeds)
                    got[specialised] = (iso, {k: v for k, v in b.stats.items() if k != "restarts"})
                (a, sa), (g, sg) = got[True], got[False]
                for name in ("triangles", "vertices", "normals", "vertex_keys", "triangle_cells"):
                    np.testing.assert_array_equal(getattr(a, name), getattr(g, name), err_msg=f"{value} {name}")
                assert sa == sg
                assert a.cells_tested == g.cells_tested and a.cells_intersected == g.cells_intersected
                # (the mean normal of a node vertex whose triangles nearly cancel depends on their order: value 1.0
                # of the integer field here, from one seed per part; so the scan is compared triangle for triangle)
                assert triangle_set(a) == triangle_set(scan)
                if cells:
                    assert np.array_equal(np.unique(a.triangle_cells), np.unique(scan.triangle_cells))
            n_node_vertices += sa["node_vertices"]
    assert n_node_vertices > 0  # the rare path (a vertex exactly on a node) was taken


@pytest.mark.parametrize("builder", BUILDERS)
def test_face_exactly_at_the_value_kept_once(builder):
    vol = datasets.load("two_tets")
    ab = vol.cells[0][np.isin(vol.cells[0], vol.cells[1])]  # the shared face
    s = np.zeros(vol.n_points)
    s[ab] = 1.0
    scan = extract(vol, 1.0, field=s)
    iso = builder(vol, s).extract(1.0, [1])
    assert scan.n_triangles == 1
    assert_same_surface(scan, iso)


@pytest.mark.parametrize("builder", BUILDERS)
@pytest.mark.parametrize("name", ["torus", "hollow_cube", "genus3", "torus_hex", "hollow_cube_hex", "genus3_hex"])
def test_tiny_volumes_all_fields(name, builder):
    vol = datasets.load(name)
    for field in vol.fields:
        s = vol.scalars(field)
        ec = builder(vol, field)
        for value in np.unique(np.concatenate([np.linspace(s.min(), s.max(), 7), s[:5]])):
            scan = extract(vol, value, field=field)
            assert_same_surface(scan, ec.extract(value, np.arange(vol.n_cells)))


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", ["data1", "data2", "hexa1"])
def test_thinning_seeds_on_data(name, method):
    """The registered methods (volume-thinning seeds) against the full scan and the hash-based thinning method,
    on the twenty values of the paper's tables."""
    vol = datasets.load(name)
    s = vol.scalars("fem")
    ours = methods.get(method)(vol, field="fem")
    hashed = methods.get("thinning")(vol, field="fem")
    assert ours.source.name == "thinning"
    for value in np.linspace(s.min(), s.max(), 22)[1:-1]:
        scan = extract(vol, value, field="fem")
        iso = ours.extract(value)
        old = hashed.extract(value)
        assert_same_surface(scan, iso)
        assert_same_surface(old, iso)
        assert iso.vertex_lookups == 0 and old.vertex_lookups > 0
        assert ours.stats["N_cg"] == hashed.stats["N_cg"]  # the same skeleton cells tested
        assert ours.stats["visits"] == expected_visits(vol, iso, ours.stats["collapsed"])
        assert iso.cells_tested < scan.cells_tested


@pytest.mark.slow
@pytest.mark.parametrize("name", ["data3", "data4"])
def test_large_data_same_as_scan(name):
    """Both variants from the thinning seeds give the scan's surfaces on the paper's volumes 2 and 4, twenty values."""
    vol = datasets.load(name)
    s = vol.scalars("fem")
    ours = [methods.get(m)(vol, field="fem", threads=1) for m in METHODS]  # the serial counters (visits)
    for value in np.linspace(s.min(), s.max(), 22)[1:-1]:
        scan = extract(vol, value, field="fem")
        for m in ours:
            iso = m.extract(value)
            assert same_surface(scan, iso), (m.name, value)
            assert iso.vertex_lookups == 0 and m.stats["visits"] == expected_visits(vol, iso, m.stats["collapsed"])


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("source", ["extrema-graph", "span-filter", "interval-tree"])
def test_other_seed_sources(source, method):
    vol = datasets.load("data1")
    s = vol.scalars("fem")
    t0 = time.perf_counter()
    m = methods.get(method)(vol, field="fem", seeds=source)
    wall = time.perf_counter() - t0
    # the seed source's preprocessing is timed inside the constructor: it fits in the constructor's wall time
    assert m.source.name == source and 0 < m.seed_preprocess_s <= wall
    for value in np.linspace(s.min(), s.max(), 6)[1:-1]:
        assert_same_surface(extract(vol, value, field="fem"), m.extract(value))


@pytest.mark.parametrize("table", [False, True])
def test_gradient_and_no_normals(table):
    vol = grid_volume((10, 10, 10), spacing=(0.1, 0.1, 0.1))
    s = np.linalg.norm(vol.points - 0.45, axis=1)
    scan = extract(vol, 0.3, field=s, normals="gradient")
    iso = edge_centred(vol, 0.3, np.unique(scan.triangle_cells)[:1], field=s, normals="gradient", table=table)
    assert_same_surface(scan, iso)
    bare = edge_centred(vol, 0.3, np.unique(scan.triangle_cells)[:1], field=s, normals=None, table=table)
    assert bare.normals is None and bare.n_triangles == scan.n_triangles


@pytest.mark.parametrize("builder", BUILDERS)
def test_buffers_grow_and_queries_repeat(builder):
    vol = grid_volume((12, 12, 12), tets=True)
    s = np.linalg.norm(vol.points - 5.5, axis=1)
    ec = builder(vol, s)
    seed = np.unique(extract(vol, 4.0, field=s).triangle_cells)[:1]
    first = ec.extract(4.0, seed)
    # shrink every buffer: the query is redone until they fit, the surface is the same
    ec._queue = ec._queue[:1].copy()
    ec._tris = ec._tris[:13].copy()
    ec._tri_cell = ec._tri_cell[:13].copy()
    ec._vkey = ec._vkey[:1].copy()
    ec._vend = ec._vend[:1].copy()
    g = ec.generation
    again = ec.extract(4.0, seed)
    assert ec.stats["restarts"] > 0 and ec.generation > g + 1
    assert_same_surface(first, again)
    for _ in range(3):
        assert_same_surface(first, ec.extract(4.0, seed))
    assert ec.stats["restarts"] == 0


@pytest.mark.parametrize("builder", BUILDERS)
def test_empty_surfaces_and_missing_seeds(builder):
    vol = grid_volume((6, 6, 6))
    s = vol.points[:, 0].copy()
    ec = builder(vol, s)
    far = np.flatnonzero(vol.points[vol.cells].mean(axis=1)[:, 0] > 4)[:5]
    iso = ec.extract(0.5, far)  # the plane x = 0.5 does not cross these cells
    assert iso.is_empty and iso.cells_tested == far.size and iso.vertex_lookups == 0
    assert ec.extract(99.0, np.arange(vol.n_cells)).is_empty
    assert ec.extract(0.5, []).is_empty
    m = methods.get("edge-centred")(vol, field=s, seeds="span-filter")
    assert m.extract(-3.0).is_empty


@pytest.mark.parametrize("builder", BUILDERS)
def test_bad_input(builder):
    vol = grid_volume((4, 4, 4))
    s = vol.points[:, 0].copy()
    ec = builder(vol, s)
    with pytest.raises(IsoSurfaceError, match="seed cells must be in"):
        ec.extract(0.5, [vol.n_cells])
    with pytest.raises(IsoSurfaceError, match="seed cells must be in"):
        ec.extract(0.5, [-1])
    with pytest.raises(IsoSurfaceError, match="integer"):
        ec.extract(0.5, [0.5])
    with pytest.raises(IsoSurfaceError, match="1-D"):
        ec.extract(0.5, [[0, 1]])
    with pytest.raises(IsoSurfaceError, match="value must be"):
        ec.extract(float("nan"), [0])
    with pytest.raises(IsoSurfaceError, match="normals"):
        ec.extract(0.5, [0], normals="flat")
    with pytest.raises(IsoSurfaceError, match="order"):
        builder(vol, s, order="random")
    with pytest.raises(IsoSurfaceError, match="unknown seed source"):
        seed_source(vol, s, "nope")
    with pytest.raises(IsoSurfaceError, match="UnstructuredVolume"):
        builder(np.zeros((3, 3)))
    with pytest.raises(IsoSurfaceError, match="field values"):
        builder(vol, np.zeros(3))
    if builder is EdgeCentredWalk:
        with pytest.raises(IsoSurfaceError, match="vertex_keys"):
            builder(vol, s, vertex_keys="ids")


def test_registered():
    assert "edge-centred" in methods.names() and "edge-centred-table" in methods.names()
    assert methods.get("edge-centred") is EdgeCentredMethod
    assert methods.get("edge-centred-table") is EdgeCentredTableMethod
    assert EdgeCentred is EdgeCentredTable  # the table variant's old name still works


def test_volume_isosurface_uses_the_default_method_prepared_once():
    vol = grid_volume((7, 6, 5), tets=True, jitter=0.2, seed=3)
    vol.add_field("r", np.linalg.norm(vol.points - vol.points.mean(axis=0), axis=1))
    vol.add_field("x", vol.points[:, 0].copy())
    default = methods.default()
    assert default == methods.names()[0] and default in methods.names()
    vol.preparation = "now"  # the behaviour before issue 20: prepare, then answer
    iso = vol.isosurface(1.7)
    assert iso.method == default and iso.n_triangles > 0
    assert_same_surface(extract(vol, 1.7), iso)
    first = vol._iso_methods[("r", default)]
    vol.isosurface(2.1)
    assert vol._iso_methods[("r", default)] is first  # prepared once per field
    assert_same_surface(extract(vol, 2.5, field="x"), vol.isosurface(2.5, field="x"))
    assert_same_surface(extract(vol, 2.5, field="x"), vol.isosurface(2.5, field="x", method="scan"))
    assert_same_surface(extract(vol, 2.5, field="x"), vol.isosurface(2.5, field="x", method="edge-centred-table"))
    vol.add_field("r", -vol.fields["r"])  # replacing a field drops what was prepared on it
    assert ("r", default) not in vol._iso_methods
    assert_same_surface(extract(vol, -1.7), vol.isosurface(-1.7))
    with pytest.raises(Exception, match="no field 'nope'"):
        vol.isosurface(0.5, field="nope")
    with pytest.raises(ValueError, match="unknown isosurface method"):
        vol.isosurface(0.5, method="nope")


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("tets", [True, False])
def test_extract_many_two_at_a_time_gives_the_same_surfaces(tets, method):
    vol = grid_volume((9, 8, 7), tets=tets, jitter=0.15, seed=5)
    c = vol.points.mean(axis=0)
    vol.add_field("f", np.sin(vol.points[:, 0]) + np.cos(1.3 * vol.points[:, 1]) + 0.2 * (vol.points[:, 2] - c[2]))
    s = vol.scalars()
    values = np.linspace(s.min(), s.max(), 13)[1:-1]
    m = methods.get(method)(vol)
    one = [m.extract(v) for v in values]
    stats_one = [m.extract(v) and dict(m.stats) for v in values]  # counters of each query
    many = m.extract_many(values, threads=2)
    assert len(m._builders) == 2
    # the records are shared; the copy keeps its own stamps, states and slots (tetrahedra: 4 slots with the table)
    assert m._builders[1].rec is m.builder.rec and m._builders[1].dyn is not m.builder.dyn
    slots = 4 if tets and method == "edge-centred-table" else (10 if tets else 20)
    assert m._builders[1].dyn.shape == (vol.n_cells, 2 + slots)
    assert m._builders[1].memory_bytes()["query_state"] == vol.n_cells * (2 + slots) * 4
    for a, b, st_a, st_b in zip(one, many, stats_one, m.stats_many):
        assert_same_surface(a, b)
        np.testing.assert_array_equal(a.triangles, b.triangles)  # the same order, too
        for k in ("T_search", "t_label"):  # seconds
            st_a.pop(k, None), st_b.pop(k, None)
        assert st_a == st_b and b.vertex_lookups == 0
    assert_same_surface(extract(vol, values[4]), many[4])
    assert [i.n_triangles for i in m.extract_many(values[::-1], threads=3)] == [i.n_triangles for i in one[::-1]]
    assert m.extract_many([], threads=2) == []
    with pytest.raises(IsoSurfaceError):
        m.extract_many([0.5, np.nan])


# ------------------------------------------------------------------ the paper's variant: no stored edges
@pytest.mark.parametrize("tets", [True, False])
def test_walk_stores_no_edges(tets):
    """Built and queried with node-pair keys, the walk never makes the volume number its edges."""
    vol = grid_volume((8, 7, 6), tets=tets, jitter=0.1 if tets else 0.0, seed=2)
    s = np.sin(vol.points[:, 0]) + np.cos(vol.points[:, 1]) * vol.points[:, 2]
    value = float(np.median(s))
    ec = EdgeCentredWalk(vol, s, vertex_keys="node-pairs")
    iso = ec.extract(value, np.arange(vol.n_cells))
    assert "_edge_table" not in vol.__dict__  # the lazily built edge list was never asked for
    mem = ec.memory_bytes()
    assert set(mem) == {"records", "buffers"}
    nn, nf, ne = (4, 4, 6) if tets else (8, 6, 12)
    assert mem["records"] == vol.n_cells * (2 + nn + nf + ne + nn) * 4
    # the node-pair keys name the scan's edges (crossings on nodes: none for this field)
    scan = extract(vol, value, field=s)
    e = vol.edges[scan.vertex_keys].astype(np.int64)  # int32 node ids: a * N in int64
    assert np.array_equal(np.sort(iso.vertex_keys), np.sort(e[:, 0] * vol.n_points + e[:, 1]))
    assert np.array_equal(np.sort(ec.edge_ids(iso.vertex_keys)), np.sort(scan.vertex_keys))
    assert "label_edge_list" in ec.memory_bytes()
    # the table variant holds the stored edges
    table = EdgeCentredTable(vol, s)
    assert table.memory_bytes()["edge_list"] == vol.edges.nbytes
    assert table.memory_bytes()["edge_cells"] == (vol.n_cells * (6 if tets else 12) + vol.edges.shape[0]) * 4


@pytest.mark.parametrize("tets", [True, False])
def test_walk_counts_its_steps(tets):
    """Each vertex on an edge: one walk round the edge, one face crossing per cell after the first."""
    vol = grid_volume((9, 8, 7), tets=tets, jitter=0.15 if tets else 0.0, seed=4)
    s = np.random.default_rng(1).random(vol.n_points)
    ec = EdgeCentredWalk(vol, s)
    for value in (0.3, 0.5, 0.7):
        iso = ec.extract(value, np.arange(vol.n_cells))
        on_edge = int(np.sum(iso.vertex_keys < vol.edges.shape[0]))
        assert ec.stats["node_vertices"] == iso.n_vertices - on_edge == 0
        assert ec.stats["visits"] == expected_visits(vol, iso, ec.stats["collapsed"])
        assert ec.stats["walk_steps"] == ec.stats["visits"] - on_edge


@pytest.mark.parametrize("name", ["data1", "hexa1"])
def test_lookup_counter_is_live(name):
    """The look-ups are counted by the kernel: none without search, one per triangle corner with it."""
    vol = datasets.load(name)
    s = vol.scalars("fem")
    plain = EdgeCentredWalk(vol, "fem")
    searching = EdgeCentredWalk(vol, "fem", search=True)
    for value in np.linspace(s.min(), s.max(), 7)[1:-1]:
        a = plain.extract(value, np.arange(vol.n_cells))
        b = searching.extract(value, np.arange(vol.n_cells))
        for attr in ("triangles", "vertex_keys", "vertices", "normals", "triangle_cells"):
            np.testing.assert_array_equal(getattr(a, attr), getattr(b, attr))
        assert a.vertex_lookups == plain.stats["lookups"] == plain.stats["probes"] == 0
        assert b.vertex_lookups == searching.stats["lookups"] == 3 * b.n_triangles > 0
        assert searching.stats["probes"] >= b.vertex_lookups


def test_walk_grows_its_buffers_on_node_crossings():
    vol = grid_volume((8, 7, 6), tets=True)
    s = np.random.default_rng(3).integers(0, 5, vol.n_points).astype(float)
    ec = EdgeCentredWalk(vol, s, search=True)
    first = ec.extract(2.0, np.arange(vol.n_cells))
    assert ec.stats["node_vertices"] > 0
    ec._around = ec._around[:1].copy()
    ec._around_local = ec._around_local[:1].copy()
    ec._htable = np.zeros((2, 2), np.int64)
    again = ec.extract(2.0, np.arange(vol.n_cells))
    assert ec.stats["restarts"] > 0
    assert_same_surface(first, again)
    assert_same_surface(extract(vol, 2.0, field=s), again)


# ------------------------------------------------------------------ the baselines: propagation with a vertex search
@pytest.mark.parametrize("tets", [True, False])
def test_propagation_hash_and_array_search(tets):
    """Both searches give the scan's surface with one counted look-up per polygon vertex per cell."""
    vol = grid_volume((9, 8, 7), tets=tets, jitter=0.15 if tets else 0.0, seed=6)
    s = np.random.default_rng(2).random(vol.n_points)
    hashed = Propagator(vol, s, vertex_search="hash", hash_capacity=4)
    arrayed = Propagator(vol, s, vertex_search="array")
    for value in (0.3, 0.5, 0.7):
        scan = extract(vol, value, field=s)
        seeds = np.unique(scan.triangle_cells)  # a random field: many small parts, a seed in each
        a, b = hashed.extract(value, seeds), arrayed.extract(value, seeds)
        assert_same_surface(scan, a, lookups=True)
        assert_same_surface(scan, b, lookups=True)
        # scan's count: the distinct polygon vertices of each cell, summed over the cells
        per_cell = sum(len(np.unique(scan.triangles[scan.triangle_cells == c])) for c in np.unique(scan.triangle_cells))
        assert a.vertex_lookups == b.vertex_lookups == per_cell == hashed.stats["lookups"]
        assert hashed.stats["probes"] >= a.vertex_lookups and arrayed.stats["probes"] == 0
    assert hashed._htable.shape[0] >= 2 * a.n_vertices  # grown from 4 slots
    table = hashed._htable
    again = hashed.extract(0.5, np.unique(extract(vol, 0.5, field=s).triangle_cells))
    assert hashed.stats["hash_grows"] == 0 and hashed._htable is table  # sized once: reused, emptied by stamps
    assert again.vertex_lookups > 0
    stored = {"edge_list", "cell_edges"}  # the array search's edge table (the hash's labels name theirs apart)
    assert stored <= set(arrayed.memory_bytes()) and not stored & set(hashed.memory_bytes())
    with pytest.raises(IsoSurfaceError, match="vertex_search"):
        Propagator(vol, s, vertex_search="tree")


# ------------------------------------------------------------------ the plain kernels behind the intrinsics
def test_intrinsics_in_use_here():
    # on the numba/llvmlite this suite runs with, the probe must succeed: a fallback taken silently
    # everywhere would leave the intrinsic path untested
    from polygen.volume import _edge_centred_kernels as k

    assert k.PREFETCH


def test_ctz_fallback_equals_the_intrinsic():
    import numba

    from polygen.volume import _edge_centred_kernels as k

    @numba.njit(cache=False)
    def both(xs, out):
        for i in range(xs.shape[0]):
            out[i, 0] = k._ctz(xs[i])
            out[i, 1] = k._ctz_plain(xs[i])

    for dtype in (np.int32, np.int64):
        bits = 31 if dtype == np.int32 else 63
        xs = np.array([1 << b for b in range(bits)] + [3, 6, 12, 24, 40, 96, (1 << (bits - 1)) + 8], dtype)
        xs = np.concatenate([xs, np.random.default_rng(0).integers(1, np.iinfo(dtype).max, 500, dtype=dtype)])
        out = np.empty((xs.size, 2), np.int64)
        both(xs, out)
        expect = [(int(x) & -int(x)).bit_length() - 1 for x in xs]  # the lowest set bit, in Python
        assert out[:, 0].tolist() == expect and out[:, 1].tolist() == expect


_FALLBACK_SCRIPT = """
import sys
import numpy as np
from polygen.volume import _edge_centred_kernels as k, datasets, methods

assert not k.PREFETCH, "POLYGEN_PREFETCH=0 did not select the plain kernels"
out = {}
for name in sys.argv[2:]:
    vol = datasets.load(name)
    m = methods.get("edge-centred-table")(vol)
    s = vol.scalars()
    for i, v in enumerate(np.linspace(s.min(), s.max(), 7)[1:-1]):
        iso = m.extract(v)
        for a in ("triangles", "vertex_keys", "vertices", "normals", "triangle_cells"):
            out[f"{name}-{i}-{a}"] = getattr(iso, a)
        out[f"{name}-{i}-visits"] = np.array([m.stats["visits"], m.stats["constructed"]])
np.savez(sys.argv[1], **out)
"""


def test_fallback_kernels_give_the_same_surfaces(tmp_path):
    """``POLYGEN_PREFETCH=0`` (a fresh process: the kernels are chosen at import) builds the very same
    surfaces, array for array and in the same order, as the intrinsic kernels here."""
    from _surfaces import run_without_prefetch

    names = ["torus", "torus_hex", "genus3"]
    theirs = run_without_prefetch(_FALLBACK_SCRIPT, tmp_path / "fallback.npz", *names)
    n = 0
    for name in names:
        vol = datasets.load(name)
        m = methods.get("edge-centred-table")(vol)
        s = vol.scalars()
        for i, v in enumerate(np.linspace(s.min(), s.max(), 7)[1:-1]):
            iso = m.extract(v)
            for a in ("triangles", "vertex_keys", "vertices", "normals", "triangle_cells"):
                np.testing.assert_array_equal(getattr(iso, a), theirs[f"{name}-{i}-{a}"], err_msg=f"{name} {v} {a}")
            np.testing.assert_array_equal([m.stats["visits"], m.stats["constructed"]], theirs[f"{name}-{i}-visits"])
            n += iso.n_triangles
    assert n > 0


# ------------------------------------------------------------------ memory of the table variant
@pytest.mark.parametrize("tets", [True, False])
def test_table_memory_per_cell(tets):
    """Records of whole cache lines (tetrahedra: 64 bytes), or none (layout "volume": stamps, states and
    slots only); 32-bit lists of the cells around the edges; the cells around the nodes built at the first
    crossing exactly on a node."""
    vol = grid_volume((8, 7, 6), tets=tets)
    s = np.random.default_rng(3).integers(0, 5, vol.n_points).astype(float)
    m, nn, ne = vol.n_cells, (4 if tets else 8), (6 if tets else 12)
    slots = 4 if tets else ne + nn
    rec = EdgeCentredTable(vol, s, layout="records")
    flat = EdgeCentredTable(vol, s, layout="volume")
    assert rec.memory_bytes()["records"] == m * (16 if tets else 48) * 4 and "query_state" not in rec.memory_bytes()
    assert flat.memory_bytes()["records"] == 0 and flat.memory_bytes()["query_state"] == m * (2 + slots) * 4
    assert rec.copy().memory_bytes()["query_state"] == m * (2 + slots) * 4  # a copy shares the records
    for b in (rec, flat):
        mem = b.memory_bytes()
        assert mem["edge_cells"] == 4 * (m * ne + vol.edges.shape[0])  # each list after its edge id
        # where each edge's cell list starts: in the records, else one int32 per edge
        assert mem.get("edge_cells_offsets", 0) == (0 if b is rec else 4 * vol.edges.shape[0])
        assert "node_cells" not in mem
        assert_same_surface(extract(vol, 2.5, field=s), b.extract(2.5, np.arange(m)))
        assert "node_cells" not in b.memory_bytes()  # no node at 2.5
        assert_same_surface(extract(vol, 2.0, field=s), b.extract(2.0, np.arange(m)))
        assert b.stats["restarts"] == 1 and b.stats["node_vertices"] > 0  # the query that built them
        assert b.memory_bytes()["node_cells"] == 4 * (vol.n_points + 1) + 4 * m * nn
        b.extract(2.0, np.arange(m))
        assert b.stats["restarts"] == 0
    with pytest.raises(IsoSurfaceError, match="layout"):
        EdgeCentredTable(vol, s, layout="rows")


# ------------------------------------------------------------------ preparation beside the thinning
@pytest.mark.parametrize("tets", [True, False])
def test_records_built_beside_the_thinning_are_the_serial_ones(monkeypatch, tets):
    """The edge table and records built in a second thread while the skeleton is thinned: the same
    records, cell lists, skeleton and surfaces as building one after the other; an error in either
    thread reaches the caller."""
    import threading

    from polygen.volume import edge_centred as ecm

    vol0 = grid_volume((9, 8, 7), tets=tets)
    s = np.random.default_rng(5).normal(size=vol0.n_points)
    fresh = lambda: UnstructuredVolume(vol0.points, vol0.cells, {"f": s}, validate=False)  # noqa: E731
    monkeypatch.setattr(ecm, "_BESIDE_MIN_CELLS", 10**12)
    serial = methods.get("edge-centred-table")(fresh())
    monkeypatch.setattr(ecm, "_BESIDE_MIN_CELLS", 0)
    seen = []
    real = ecm.EdgeCentredTable

    def spy(*a, **k):
        seen.append((threading.current_thread().name, numba.get_num_threads()))
        return real(*a, **k)

    monkeypatch.setattr(ecm, "EdgeCentredTable", spy)
    monkeypatch.setattr(ecm.EdgeCentredTableMethod, "builder_class", staticmethod(ecm.EdgeCentredTable))
    n = numba.get_num_threads()
    beside = methods.get("edge-centred-table")(fresh())
    assert seen == [("polygen-edge-records", n)]  # the other path was taken, on numba's thread count
    # on the cores the thinning's two halves leave, at least one: the same records; the caller's count kept
    monkeypatch.setattr(ecm, "BESIDE_THREADS", "cores left")
    again = methods.get("edge-centred-table")(fresh())
    assert seen[1:] == [("polygen-edge-records", max(1, n - 2))]
    assert numba.get_num_threads() == n
    assert np.array_equal(again.builder.rec, beside.builder.rec)
    assert np.array_equal(serial.builder.rec, beside.builder.rec)
    assert np.array_equal(serial.builder.ec, beside.builder.ec)
    assert np.array_equal(serial.source.structure.cells, beside.source.structure.cells)
    for v in np.quantile(s, [0.2, 0.5, 0.8]):
        assert_same_surface(serial.extract(v), beside.extract(v))

    def broken(*a, **k):
        raise IsoSurfaceError("records failed")

    monkeypatch.setattr(ecm, "EdgeCentredTable", broken)
    monkeypatch.setattr(ecm.EdgeCentredTableMethod, "builder_class", staticmethod(ecm.EdgeCentredTable))
    with pytest.raises(IsoSurfaceError, match="records failed"):
        methods.get("edge-centred-table")(fresh())


@pytest.mark.parametrize("tets", [True, False])
def test_edge_lists_and_records_match_numpy_for_any_thread_count(tets):
    """The parallel counting sort that packs the cells around each edge and fills the records gives numpy's
    stable sort, whatever the number of slabs (cells shuffled, so that every edge's list spans slabs)."""
    from naive import edge_cell_lists

    from polygen.volume import _edge_centred_kernels as k

    vol = grid_volume((30, 30, 25) if tets else (52, 52, 52), tets=tets)
    perm = np.random.default_rng(7).permutation(vol.n_cells)
    vol = UnstructuredVolume(vol.points, vol.cells[perm], validate=False)
    ce, nn = vol.cell_edges, vol.cells.shape[1]
    assert ce.size >= 3 * 65536  # three slabs at least
    os_, _, ost, width = k.record_layout(nn, ce.shape[1])
    ec_ref, starts_ref, rec_ref = edge_cell_lists(vol.cells, ce, vol.edges.shape[0], os_, ost, width)
    for threads in (1, 2, 3):
        rec = np.full((vol.n_cells, width), 99, np.int32)
        ec, starts = k.edge_lists_and_records(vol.cells, ce, vol.edges.shape[0], threads, rec, os_, ost)
        assert np.array_equal(ec, ec_ref) and np.array_equal(starts, starts_ref) and np.array_equal(rec, rec_ref)
        none = np.empty((0, width), np.int32)  # layout "volume": the lists only
        ec, starts = k.edge_lists_and_records(vol.cells, ce, vol.edges.shape[0], threads, none, os_, ost)
        assert np.array_equal(ec, ec_ref) and np.array_equal(starts, starts_ref)

"""The active-cell scan (:mod:`polygen.volume.active_scan`): the full scan's surfaces, from the crossed cells
alone, the same arrays whatever the threads, chunks and rows.

Oracles: the full scan (every cell tested, vertices merged through the edge table), array for array up to
the order of the vertices; the span-space invariant (a query tests the crossed cells plus at most one row).
"""

import numba
import numpy as np
import pytest

from polygen.volume import UnstructuredVolume, datasets, isovalues, methods
from polygen.volume import active_scan, edge_centred
from polygen.volume.active_scan import ActiveScan, ActiveScanMethod
from polygen.volume.isosurface import extract
from polygen.volume.surface import IsoSurfaceError, same_surface
from tests._surfaces import block_volume, grid_volume


def values_of(s, n=9):
    """Values between the nodes', and values exactly at nodes (vertices on nodes, faces at C)."""
    nodes = np.unique(s)
    return list(isovalues(s, n)) + list(nodes[:: max(1, nodes.size // 6)]) + [s.min(), s.max()]


def arrays(iso):
    return iso.vertices, iso.triangles, iso.vertex_keys, iso.triangle_cells


@pytest.mark.parametrize("name", ["data1", "hexa1", "torus", "genus3_hex", "two_tets", "one_hex"])
def test_the_full_scans_surfaces_on_data_sets(name):
    vol = datasets.load(name)
    field = "fem" if "fem" in vol.fields else next(iter(vol.fields))
    scan = ActiveScan(vol, field)
    n_crossed = 0
    for v in values_of(vol.scalars(field)):
        for normals in ("mean", "gradient", None):
            ref = extract(vol, v, field=field, normals=normals)
            iso = scan.extract(v, normals=normals)
            assert same_surface(iso, ref, normals_atol=1e-10), (name, v, normals)
        n_crossed += iso.cells_intersected
    assert n_crossed > 0


def test_integer_field_every_value_at_nodes():
    # an integer field on jittered tetrahedra and on hexahedra: most crossings are on nodes, with faces
    # exactly at C (kept once) and polygons that collapse onto nodes (their vertices dropped)
    for tets in (True, False):
        vol = grid_volume((6, 5, 5), tets=tets, jitter=0.2, seed=4)
        rng = np.random.default_rng(7)
        vol.add_field("k", rng.integers(0, 4, vol.n_points).astype(float))
        scan = ActiveScan(vol, "k")
        on_nodes = 0
        for v in (0.0, 1.0, 2.0, 3.0, 0.5, 2.5):
            ref = extract(vol, v, field="k")
            iso = scan.extract(v)
            assert same_surface(iso, ref, normals_atol=1e-10), (tets, v)
            on_nodes += int(np.sum(iso.vertex_keys >= vol.edges.shape[0]))
        assert on_nodes > 0


def test_maxima_rounded_to_float32_miss_no_cell():
    # node values a hair apart (float32 cannot tell them apart): the rows' maxima are stored as float32
    # rounded up, so a value between two of them, or at the largest, still finds every crossed cell
    vol = grid_volume((5, 5, 4), tets=True, jitter=0.1, seed=2)
    base = 1.0 + np.arange(vol.n_points) * 2.0 ** -45
    vol.add_field("f", base[np.random.default_rng(3).permutation(vol.n_points)])
    scan = ActiveScan(vol, "f", rows=5)
    s = vol.scalars("f")
    assert np.unique(s.astype(np.float32)).size < s.size // 4  # the maxima do collapse in float32
    ordered = np.sort(s)
    between = list((ordered[1:-1:7] + ordered[2::7]) / 2)
    for v in between + list(ordered[1::7]) + [s.max(), np.nextafter(s.max(), 0)]:
        ref = extract(vol, v, field="f")
        assert ref.n_triangles > 0 or v not in between
        assert same_surface(scan.extract(v), ref, normals_atol=1e-9), v


def test_tests_the_crossed_cells_and_at_most_one_row_more():
    # the span-space order's claim: the cells a value crosses are prefixes of the rows, and only the
    # row that holds the value has cells in its prefix that the value does not cross. Node values that
    # float32 holds exactly (multiples of 1/64), so that no maximum is rounded.
    vol = datasets.load("data2")
    s = np.round(vol.scalars("fem") * 64) / 64
    vol.add_field("q", s)
    one = vol.n_cells  # one block
    for rows, block in ((1, one), (7, one), (64, one), (3, 5000), (16, 997)):
        scan = ActiveScan(vol, "q", rows=rows, block=block)
        n_blocks = scan.block_min.size
        widest = int(np.diff(scan.row_off).max())  # one segment: a row of one block
        for v in isovalues(s, 15):
            iso = scan.extract(v)
            crossed = int(np.sum((s[vol.cells].min(axis=1) < v) & (s[vol.cells].max(axis=1) >= v)))
            assert iso.cells_intersected == crossed
            assert crossed <= iso.cells_tested <= crossed + n_blocks * widest
        assert n_blocks == -(-vol.n_cells // block)
        if rows == 1 and block == one:
            assert widest == vol.n_cells


def test_the_same_arrays_whatever_the_threads_and_chunks(monkeypatch):
    monkeypatch.setattr(active_scan, "query_threads", lambda full: full)  # every thread, however busy the machine
    # the vertices are numbered along the table's order, chunk by chunk: the threads and the chunk size
    # change nothing but the rounding of the normal sums; other rows or blocks give another order, the
    # same surface
    vol = datasets.load("data2")
    s = vol.scalars("fem")
    values = isovalues(s, 6)
    ref = ActiveScan(vol, "fem")
    before = numba.get_num_threads()
    try:
        for threads, chunk, rows, block in ((1, 1024, None, None), (before, 1, None, None), (before, 37, None, None),
                                            (1, 5000, None, None), (before, 64, 1, None), (1, 100, 1000, None),
                                            (before, 300, None, 4096)):
            numba.set_num_threads(threads)
            other = ActiveScan(vol, "fem", chunk=chunk, rows=rows, block=block)
            for v in values:
                numba.set_num_threads(before)
                a = ref.extract(v)
                numba.set_num_threads(threads)
                b = other.extract(v)
                assert other.stats["threads"] <= threads
                if rows is None and block is None:
                    for x, y in zip(arrays(a), arrays(b)):
                        np.testing.assert_array_equal(x, y)
                    np.testing.assert_allclose(a.normals, b.normals, atol=1e-12, rtol=0)
                else:
                    assert same_surface(a, b, normals_atol=1e-12)
    finally:
        numba.set_num_threads(before)


def test_a_busy_machine_takes_fewer_threads_and_the_same_surface(monkeypatch):
    """Other programs' runnable tasks (the machine's reading faked) take cores away from a query: the spinning
    barriers of its passes would wait for their time slices. The surface is the same whatever the count."""
    vol = datasets.load("data2")
    s = vol.scalars("fem")
    scan = ActiveScan(vol, "fem", chunk=64)
    busy = {"n": 0}
    monkeypatch.setattr(edge_centred, "_runnable_elsewhere", lambda: busy["n"])
    monkeypatch.setattr(edge_centred, "BUSY_SECONDS", 0.0)  # a reading per query
    monkeypatch.setattr(edge_centred, "_cpus", lambda: 2)
    before = numba.get_num_threads()
    full = min(before, 2)
    v = float(np.median(s))
    try:
        numba.set_num_threads(full)
        seen = {}
        for n_busy, expected in ((0, full), (1, 1), (5, 1)):
            busy["n"] = n_busy
            seen[n_busy] = scan.extract(v)
            assert scan.stats["threads"] == expected, (n_busy, scan.stats)
            assert numba.get_num_threads() == full  # the caller's count is given back
        for x, y in zip(arrays(seen[0]), arrays(seen[5])):
            np.testing.assert_array_equal(x, y)
        monkeypatch.setattr(edge_centred, "_runnable_elsewhere", lambda: None)  # nothing known: every thread
        scan.extract(v)
        assert scan.stats["threads"] == full
    finally:
        numba.set_num_threads(before)


def test_registered_method_memory_and_bad_parameters():
    vol = datasets.load("data1")
    m = methods.get("active-scan")(vol, field="fem")
    assert isinstance(m, ActiveScanMethod)
    v = isovalues(vol.scalars("fem"), 3)[1]
    iso = m.extract(v)
    assert same_surface(iso, extract(vol, v, field="fem"))
    assert m.seed_cells_tested == iso.cells_tested < vol.n_cells
    held = m.scan.memory_bytes()
    # 48 bytes of table and 4 of maxima per tetrahedron; the scratch: ev per edge and a stamp per node
    assert held["table"] == 48 * vol.n_cells and held["maxima"] == 4 * vol.n_cells
    assert held["scratch"] >= 4 * vol.edges.shape[0] + 8 * vol.n_points
    assert m.memory_bytes() >= sum(held.values()) - held["rows"]
    for bad in ({"rows": 0}, {"rows": 2.5}, {"chunk": 0}, {"chunk": True}, {"block": 0}, {"block": "big"}):
        with pytest.raises(IsoSurfaceError, match=next(iter(bad))):
            ActiveScan(vol, "fem", **bad)
    with pytest.raises(IsoSurfaceError, match="finite"):
        m.extract(float("nan"))
    with pytest.raises(IsoSurfaceError, match="normals"):
        m.extract(0.5, normals="flat")


def test_a_replaced_field_is_not_answered_from_the_old_table():
    vol = block_volume(np.ones((3, 2, 2), bool), "tetra", jitter=0.1, seed=5)
    m = methods.get("active-scan")(vol, field="bumps")
    m.extract(0.5)
    vol.add_field("bumps", vol.fields["bumps"] + 1.0)
    with pytest.raises(IsoSurfaceError, match="replaced"):
        m.extract(0.5)


def test_values_outside_the_field_give_empty_surfaces():
    vol = datasets.load("data1")
    s = vol.scalars("fem")
    scan = ActiveScan(vol, "fem")
    for v in (s.min() - 1.0, s.min(), s.max() + 1.0):
        iso = scan.extract(v)
        ref = extract(vol, v, field="fem")
        assert iso.n_triangles == ref.n_triangles == 0 and iso.n_vertices == 0
    assert scan.extract(s.max() + 1.0).cells_tested == 0


def test_blocks_from_a_size_on(monkeypatch):
    # one block below BLOCKS_FROM cells, blocks of BLOCK cells from there: the same surfaces either way
    vol = datasets.load("data2")
    monkeypatch.setattr(ActiveScan, "BLOCKS_FROM", vol.n_cells + 1)
    one = ActiveScan(vol, "fem")
    monkeypatch.setattr(ActiveScan, "BLOCKS_FROM", vol.n_cells)
    monkeypatch.setattr(ActiveScan, "BLOCK", 5000)
    blocked = ActiveScan(vol, "fem")
    assert one.block_min.size == 1 and blocked.block_min.size == -(-vol.n_cells // 5000)
    n_rows = 5000 // ActiveScan.ROW  # a row per ROW cells of a block, bounds of its own
    assert blocked.lower.shape == (blocked.block_min.size, n_rows)
    s = vol.scalars("fem")
    cmin = s[vol.cells].min(axis=1)
    cell = blocked.table[:, -1]
    for b, bounds in enumerate(blocked.lower):
        assert bounds[0] == -np.inf and np.all(np.diff(bounds[np.isfinite(bounds)]) > 0) and np.isfinite(bounds[1])
        upper = np.append(bounds[1:], np.inf)
        for r in range(n_rows):  # each cell in the row of its block whose bounds hold its minimum
            seg = cell[blocked.row_off[b * n_rows + r]:blocked.row_off[b * n_rows + r + 1]]
            assert np.all(seg // 5000 == b)
            assert np.all((cmin[seg] >= bounds[r]) & (cmin[seg] < upper[r]))
    for v in isovalues(vol.scalars("fem"), 7):
        assert same_surface(one.extract(v), blocked.extract(v))


def test_parts_cut_by_work_tile_the_chunks():
    # the vertex and triangle passes give each thread about the same number of items, not of chunks: the
    # parts are consecutive, cover every chunk once, and none holds more than its share plus one chunk
    from polygen.volume._active_scan_kernels import _part_by

    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(1, 40))
        counts = rng.integers(0, 50, n) * (rng.random(n) < 0.7)
        off = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        for n_parts in (1, 2, 3, 7):
            cuts = [_part_by(off, n_parts, q) for q in range(n_parts)]
            assert cuts[0][0] == 0 and cuts[-1][1] == n
            assert all(a[1] == b[0] for a, b in zip(cuts, cuts[1:])) and all(k0 <= k1 for k0, k1 in cuts)
            share = off[-1] / n_parts
            assert all(off[k1] - off[k0] <= share + counts.max() for k0, k1 in cuts)


@pytest.mark.parametrize("block", [1, 7, 5000])
def test_the_owner_column_against_each_edges_first_cell(block):
    # brute force: an edge's owner is the smallest id among its cells; the column says which local edges a
    # cell owns, which are owned in another block, and how many blocks back the earliest owner is
    from polygen.volume._active_scan_kernels import FOREIGN, REACH, REACH_MAX

    vol = datasets.load("data2")
    scan = ActiveScan(vol, "fem", block=block)
    ce = vol.cell_edges
    m, ne = ce.shape
    first = np.full(vol.edges.shape[0], m, np.int64)
    np.minimum.at(first, ce.ravel(), np.repeat(np.arange(m), ne))
    cell = scan.table[:, -1]
    col = scan.table[:, scan.nn + scan.ne].astype(np.int64)
    owner = first[ce[cell]]  # (M, ne), in the table's order
    blk = cell // block
    back = blk[:, None] - owner // block
    w = np.arange(ne)
    np.testing.assert_array_equal((col[:, None] >> w) & 1, owner == cell[:, None])
    np.testing.assert_array_equal((col[:, None] >> (FOREIGN + w)) & 1, back > 0)
    np.testing.assert_array_equal(col >> REACH, np.minimum(back.max(axis=1), REACH_MAX))
    if block == 1:
        assert np.any(col >> REACH == REACH_MAX)  # saturated: the triangle pass then defers by the bits


def _parts_last_first(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask, ranges, roff,
                      chunk, block, st, v_off, t_off, ev, nvid, pos, keys, exact_cells, tris, tri_cell, acc, cuts,
                      side_t, n_side, n_parts, ev_reads):
    """fused_pass's parts one after the other, the last first, with ``ev`` spoiled before: a part that used a
    vertex another part (or a block it has not done) makes would read -1."""
    from polygen.volume import _active_scan_kernels as _k

    ev.fill(-1)
    for q in reversed(range(n_parts)):
        n_side[q] = _k._fused_part(tab, nn, ne, s, value, points, local_edges, tri_table, tri_count, case_mask,
                                   ranges, roff, chunk, block, cuts[q], cuts[q + 1], st, v_off, t_off, ev, nvid,
                                   pos, keys, exact_cells, tris, tri_cell, acc, side_t, ev_reads[q:q + 1])


@pytest.mark.parametrize("normals", ["mean", "gradient", None])
def test_block_by_block_passes_give_the_arrays_of_the_separate_passes(normals, monkeypatch):
    # fused_pass makes each block's vertices then its triangles; a triangle whose corner another part (or a
    # block not yet done) makes waits on the side list. Any number of parts -- more than the cores, cuts in
    # the middle of blocks, run in any order -- must give the separate passes' arrays, and the normals up
    # to rounding
    from polygen.volume import _active_scan_kernels as _k

    vol = datasets.load("data2")
    values = isovalues(vol.scalars("fem"), 5)
    parallel = _k.fused_pass
    for block, chunk in ((500, 37), (3000, 256), (vol.n_cells, 64)):
        scan = ActiveScan(vol, "fem", block=block, chunk=chunk)
        deferred = 0
        for n_parts in (1, 2, 3, 5):
            for v in values:
                monkeypatch.setattr(ActiveScan, "FUSED", False)
                a, _ = scan._extract(v, normals, scan.node_gradients(), scan._scratch, n_parts)
                monkeypatch.setattr(ActiveScan, "FUSED", True)
                for fused_pass in (parallel, _parts_last_first):
                    monkeypatch.setattr(_k, "fused_pass", fused_pass)
                    b, stats = scan._extract(v, normals, scan.node_gradients(), scan._scratch, n_parts)
                    for x, y in zip(arrays(a), arrays(b)):
                        np.testing.assert_array_equal(x, y)
                    if normals is not None:
                        np.testing.assert_allclose(a.normals, b.normals, atol=1e-12, rtol=0)
                if n_parts > 1 and block < vol.n_cells:
                    deferred += stats["side"]
                if n_parts == 2:
                    assert same_surface(b, extract(vol, v, field="fem", normals=normals), normals_atol=1e-9)
        if block < vol.n_cells:
            assert deferred > 0  # the side list was exercised


PREPARED = ("table", "cmx", "lower", "row_off", "block_min", "block_max")


@pytest.mark.parametrize("name, block", [("data2", None), ("data2", 777), ("hexa1", 4096), ("hexa1", 1000)])
def test_the_preparation_by_groups_gives_the_arrays_of_one_pass(name, block):
    # the preparation goes group by group of whole blocks; one group of every block is the one pass over
    # all the cells that it was before: the arrays must not depend on the group size
    vol = datasets.load(name)
    one = ActiveScan(vol, "fem", block=block, group=10**9)
    assert one.group >= vol.n_cells
    for group in (1, 2, 3):
        other = ActiveScan(vol, "fem", block=block, group=group)
        if block is not None:
            assert other.group == group * block < vol.n_cells
        for k in PREPARED:
            np.testing.assert_array_equal(getattr(one, k), getattr(other, k), err_msg=k)


def test_memory_budget_picks_the_group_or_says_what_it_needs():
    vol = datasets.load("data2")
    block = 1000
    free = ActiveScan(vol, "fem", block=block, group=10**9)
    fixed = free.planned_bytes["fixed"]
    per_block = ActiveScan.GROUP_BYTES_PER_CELL * block
    # room for the kept arrays, the edge owners and three blocks' temporaries: groups of three blocks
    three = ActiveScan(vol, "fem", block=block, memory_budget=fixed + 3 * per_block + per_block // 2)
    assert three.group == 3 * block
    for k in PREPARED:
        np.testing.assert_array_equal(getattr(free, k), getattr(three, k), err_msg=k)
    # the budget caps the group it is given
    with pytest.raises(IsoSurfaceError, match="memory_budget"):
        ActiveScan(vol, "fem", block=block, group=4, memory_budget=fixed + 3 * per_block)
    with pytest.raises(IsoSurfaceError, match="memory_budget is 1,000 bytes"):
        ActiveScan(vol, "fem", block=block, memory_budget=1000)
    # a budget below the table alone is refused before the volume builds its edge table
    fresh = UnstructuredVolume(vol.points, vol.cells, {"fem": vol.scalars("fem")})
    with pytest.raises(IsoSurfaceError, match="needs at least"):
        ActiveScan(fresh, "fem", memory_budget=48 * vol.n_cells)
    assert "_edge_table" not in fresh.__dict__
    # through the registry, as a preparation parameter
    m = methods.get("active-scan")(vol, field="fem", memory_budget=fixed + 3 * per_block, block=block)
    assert m.scan.group == 3 * block
    for bad in (0, -5, 2.5, True, "1GB"):
        with pytest.raises(IsoSurfaceError, match="memory_budget"):
            ActiveScan(vol, "fem", memory_budget=bad)
    with pytest.raises(IsoSurfaceError, match="group"):
        ActiveScan(vol, "fem", group=0)


@pytest.mark.parametrize("name, block", [("data2", None), ("data2", 777), ("hexa1", 1000)])
def test_edge_ids_written_into_the_table_give_the_same_arrays(name, block):
    # on a volume that has not built its edge table, the edge ids go straight into the table's columns
    # (no vol.cell_edges beside it); a volume that holds them gives its own: the same arrays
    src = datasets.load(name)
    fresh = UnstructuredVolume(src.points, src.cells, {"fem": src.scalars("fem")})
    direct = ActiveScan(fresh, "fem", block=block, group=2)
    assert direct.edges_in_table
    assert fresh.__dict__["_edge_table"][1] is None  # the volume kept its edges, not the cells' edge ids
    held = UnstructuredVolume(src.points, src.cells, {"fem": src.scalars("fem")})
    held.cell_edges
    ref = ActiveScan(held, "fem", block=block, group=2)
    assert not ref.edges_in_table
    off = ActiveScan(UnstructuredVolume(src.points, src.cells, {"fem": src.scalars("fem")}), "fem", block=block,
                     edges_in_table=False)
    assert not off.edges_in_table
    np.testing.assert_array_equal(fresh.edges, held.edges)
    np.testing.assert_array_equal(fresh.cell_edges, held.cell_edges)  # built again on demand: the same
    for other in (ref, off):
        for k in PREPARED:
            np.testing.assert_array_equal(getattr(direct, k), getattr(other, k), err_msg=k)
    v = isovalues(src.scalars("fem"), 5)[2]
    for x, y in zip(arrays(direct.extract(v)), arrays(ref.extract(v))):
        np.testing.assert_array_equal(x, y)

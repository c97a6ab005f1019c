"""The parallel edge-centred construction (issue 20, Deliver 1): exactly the serial construction's surface.

``EdgeCentredTable(..., threads=T)`` hands the seeds to ``T`` threads that each run the serial construction
on their own stack, claiming cells and contested vertices by compare-and-swap; the oracle is the serial
construction (one thread) and the full scan: the same triangles in the same cells, the same vertices bit for
bit, and, in :func:`canonical_order`, equal arrays.
"""

import threading

import numpy as np
import pytest

from polygen._jit import njit, prange
from polygen.volume import _edge_centred_kernels as _k
from polygen.volume import datasets, methods
from polygen.volume.edge_centred import EdgeCentredTable, canonical_order
from polygen.volume.isosurface import IsoSurfaceError, extract
from polygen.volume.mesh import UnstructuredVolume

from _surfaces import assert_same_surface, block_volume, grid_volume, iso_values, sorted_triangles  # noqa: E402
from test_thinning import ADVERSARIAL, random_shape  # noqa: E402


@njit
def _cas(a, i, old, new):
    return _k._cas(a, i, old, new)


@njit
def _cas_row(a, i, j, old, new):
    return _k._cas_row(a, i, j, old, new)


@njit
def _fetch_add(a, i, inc):
    return _k._fetch_add(a, i, inc)


@njit(parallel=True)
def _race(words, total, n_thr):
    """``n_thr`` threads each try to claim every word (-1 -> its number) by CAS; per thread the words it won."""
    won = np.zeros(n_thr, np.int64)
    for t in prange(n_thr):
        for i in range(words.shape[0]):
            if _k._cas(words, i, -1, t) == -1:
                won[t] += 1
            _k._fetch_add(total, 0, 1)
    return won


def one_seed_per_component(iso):
    labels, _ = iso.connected_components()
    _, first = np.unique(labels, return_index=True)
    return iso.triangle_cells[first]


def assert_same_as_serial(serial, par):
    """``par`` is ``serial``: the same surface, and equal arrays once both are in the canonical order (the
    positions bit for bit; the mean normals to 1e-12: the threads sum each vertex's terms in another order)."""
    assert_same_surface(serial, par)
    a, b = canonical_order(serial), canonical_order(par)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    np.testing.assert_array_equal(a.triangle_cells, b.triangle_cells)
    np.testing.assert_array_equal(a.vertex_keys, b.vertex_keys)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    assert (a.normals is None) == (b.normals is None)
    if a.normals is not None:
        np.testing.assert_allclose(a.normals, b.normals, atol=1e-12, rtol=0)


def both(vol, s, value, seeds, threads=2, **kw):
    ser = EdgeCentredTable(vol, s, **kw)
    par = EdgeCentredTable(vol, s, threads=threads, **kw)
    return ser.extract(value, seeds), par.extract(value, seeds), ser, par


def test_canonical_order_is_one_order_for_fifo_and_lifo():
    vol = grid_volume((9, 8, 7), spacing=(0.3, 0.5, 0.7), jitter=0.15, seed=1)
    s = np.random.default_rng(7).random(vol.n_points)
    seeds = np.arange(vol.n_cells)
    a = EdgeCentredTable(vol, s, order="fifo").extract(0.5, seeds)
    b = EdgeCentredTable(vol, s, order="lifo").extract(0.5, seeds)
    assert not np.array_equal(a.vertex_keys, b.vertex_keys)  # the two orders differ before ...
    assert_same_as_serial(a, b)  # ... and agree after


@pytest.mark.parametrize("threads", [2, 3, 8])
@pytest.mark.parametrize("tets", [True, False])
def test_random_fields_same_as_serial_and_scan(tets, threads):
    vol = grid_volume((9, 8, 7), spacing=(0.3, 0.5, 0.7), tets=tets, jitter=0.15 if tets else 0.0, seed=1)
    s = np.random.default_rng(7).random(vol.n_points)
    ser = EdgeCentredTable(vol, s)
    par = EdgeCentredTable(vol, s, threads=threads)
    for value in np.linspace(0.05, 0.95, 7):
        scan = extract(vol, value, field=s)
        seeds = np.unique(scan.triangle_cells)
        iso = par.extract(value, seeds)
        assert_same_surface(scan, iso)
        assert_same_as_serial(ser.extract(value, seeds), iso)
        st = par.stats
        assert st["threads"] == threads and sum(st["per_thread"]) == st["pops"]
        assert st["constructed"] == iso.cells_intersected == st["pops"]  # every cell taken once, by one thread
        assert iso.vertex_lookups == 0


@pytest.mark.parametrize("tets", [True, False])
def test_one_seed_per_surface_part(tets):
    """Few seeds: the threads that start from them run into each other's cells."""
    vol = grid_volume((16, 14, 12), spacing=(0.1, 0.1, 0.1), tets=tets)
    x = vol.points
    s = np.sin(9 * x[:, 0]) * np.cos(8 * x[:, 1]) * np.sin(7 * x[:, 2] + 0.3) + 0.2 * x[:, 0]
    ser = EdgeCentredTable(vol, s)
    par = EdgeCentredTable(vol, s, threads=2)
    for value in (-0.5, -0.1, 0.2, 0.6):
        scan = extract(vol, value, field=s)
        seeds = one_seed_per_component(scan)
        assert seeds.size >= 2
        iso = par.extract(value, seeds)
        assert_same_surface(scan, iso)
        assert_same_as_serial(ser.extract(value, seeds), iso)


@pytest.mark.parametrize("tets", [True, False])
def test_values_exactly_on_nodes(tets):
    vol = grid_volume((8, 7, 6), tets=tets)
    s = np.random.default_rng(3).integers(0, 5, vol.n_points).astype(float)
    ser = EdgeCentredTable(vol, s)
    par = EdgeCentredTable(vol, s, threads=2)
    every = np.arange(vol.n_cells)
    n_node_vertices = 0
    for value in (1.0, 2.0, 3.0, 4.0, 2.5):
        scan = extract(vol, value, field=s)
        for seeds in (every, one_seed_per_component(scan)):
            iso = par.extract(value, seeds)
            ref = ser.extract(value, seeds)
            assert_same_surface(scan, iso, cells=seeds is every)
            assert_same_as_serial(ref, iso)
            assert sorted(par.stats["collapsed"]) == sorted(ser.stats["collapsed"])
        n_node_vertices += int(np.sum(iso.vertex_keys >= vol.edges.shape[0]))
    assert n_node_vertices > 0


def test_face_exactly_at_the_value_kept_once():
    vol = datasets.load("two_tets")
    s = np.zeros(vol.n_points)
    s[vol.cells[0][np.isin(vol.cells[0], vol.cells[1])]] = 1.0
    scan = extract(vol, 1.0, field=s)
    iso = EdgeCentredTable(vol, s, threads=2).extract(1.0, [1])
    assert scan.n_triangles == 1
    assert_same_surface(scan, iso)


def test_boundary_face_at_the_maximum():
    """``test_fuzz.py::test_edge_centred_boundary_face_at_the_maximum``: the seeds' polygons collapse onto the
    face's nodes, whose vertices must still carry the propagation to the cell that holds the face."""
    vol = block_volume(np.array([[[False], [False]], [[True], [True]]]), "tetra", jitter=0.0, seed=651)
    f = np.array([-1.0, 2.0, 0.0, 0.0, -2.0, -1.0, 0.0, 0.0, 2.0, -1.0, 2.0, 2.0])
    vol = UnstructuredVolume(vol.points, vol.cells, {"f": f})
    scan = extract(vol, 2.0, field="f", method="scan")
    assert scan.n_triangles == 1
    m = methods.get("edge-centred-table")(vol, field="f", threads=2)
    assert_same_surface(scan, m.extract(2.0), cells=False)
    ser = methods.get("edge-centred-table")(vol, field="f")
    assert_same_as_serial(ser.extract(2.0), m.extract(2.0))


@pytest.mark.parametrize("name", ["torus", "hollow_cube", "genus3", "torus_hex", "hollow_cube_hex", "genus3_hex",
                                  "one_tet", "two_tets", "one_hex", "two_hexes"])
def test_tiny_volumes_all_fields(name):
    vol = datasets.load(name)
    for field in vol.fields:
        s = vol.scalars(field)
        ser = EdgeCentredTable(vol, field)
        par = EdgeCentredTable(vol, field, threads=2)
        every = np.arange(vol.n_cells)
        for value in np.unique(np.concatenate([np.linspace(s.min(), s.max(), 9), s[:5]])):
            iso = par.extract(value, every)
            assert_same_surface(extract(vol, value, field=field), iso)
            assert_same_as_serial(ser.extract(value, every), iso)


@pytest.mark.parametrize("name", ["data1", "data2", "data3", "hexa1"])
def test_thinning_seeds_on_data(name):
    """The registered method with ``threads=2`` against one thread and the scan, on the tables' twenty values."""
    vol = datasets.load(name)
    s = vol.scalars("fem")
    ser = methods.get("edge-centred-table")(vol, field="fem")
    par = methods.get("edge-centred-table")(vol, field="fem", threads=2)
    for value in np.linspace(s.min(), s.max(), 22)[1:-1]:
        iso = par.extract(value)
        assert_same_surface(extract(vol, value, field="fem"), iso)
        assert_same_as_serial(ser.extract(value), iso)


def test_compare_and_swap_swaps_only_on_a_match():
    """The intrinsics under the claims: the old value comes back, the store happens only when it matched."""
    assert _k.ATOMICS
    for dt in (np.int32, np.int64):
        a = np.array([5, 6, -1], dt)
        assert _cas(a, 0, 5, 7) == 5 and a.tolist() == [7, 6, -1]  # matched: swapped
        assert _cas(a, 1, 5, 7) == 6 and a.tolist() == [7, 6, -1]  # did not match: unchanged
        assert _cas(a, 2, -1, 2**30) == -1 and a[2] == 2**30
        b = np.zeros((2, 3), dt)
        assert _cas_row(b, 1, 2, 0, 9) == 0 and b[1, 2] == 9 and b.sum() == 9
        assert _cas_row(b, 1, 2, 0, 4) == 9 and b[1, 2] == 9
        assert _fetch_add(a, 1, 10) == 6 and a[1] == 16


def test_compare_and_swap_under_contention():
    """Two threads race for every word many times: each word is won exactly once, counted fetch-adds add up."""
    words = np.full(20_000, -1, np.int32)
    total = np.zeros(1, np.int64)
    won = _race(words, total, 2)
    assert won.sum() == words.size  # each word claimed by exactly one of the threads
    assert set(np.unique(words)) <= {0, 1} and (won == np.bincount(words, minlength=2)).all()
    assert total[0] == 2 * words.size


@pytest.mark.parametrize("tets", [True, False])
def test_two_threads_stress_small_buffers(tets):
    """Many queries by two threads from buffers far too small (restarts through every overflow path), and
    from seeds spread over the whole volume so that the threads meet everywhere: the serial surface each time."""
    vol = grid_volume((11, 10, 9), spacing=(0.1, 0.1, 0.1), tets=tets, seed=3)
    x = vol.points
    s = np.sin(11 * x[:, 0]) * np.cos(9 * x[:, 1]) + np.sin(8 * x[:, 2]) + 0.1 * np.random.default_rng(4).random(
        vol.n_points)
    ser = EdgeCentredTable(vol, s)
    par = EdgeCentredTable(vol, s, threads=2)
    rng = np.random.default_rng(9)
    restarts = contested = 0
    for rep in range(60):
        value = float(rng.uniform(np.quantile(s, 0.2), np.quantile(s, 0.8)))
        seeds = rng.permutation(vol.n_cells)[:rng.integers(1, 400)]
        if rep % 10 == 0:  # back to tiny buffers: the query overflows and restarts
            par._queue, par._tris, par._tri_cell, par._vkey, par._vend = (
                np.empty(2, np.int32), np.empty((2, 3), np.int32), np.empty(2, np.int32), np.empty(2, np.int32),
                np.empty((2, 2), np.int32))
        iso = par.extract(value, seeds)
        assert_same_as_serial(ser.extract(value, seeds), iso)
        assert (par._ev == -1).all()  # the contested ids were put back
        restarts += par.stats["restarts"]
        contested += par.stats["contested"]
    assert restarts > 0  # the overflow path ran (whether the threads met depends on the scheduler: see the
    # interleaved test for a deterministic race)


@pytest.mark.parametrize("tets", [True, False])
def test_stage3_by_the_threads(tets, monkeypatch):
    """Positions and mean normals by the threads (every surface, threshold 0): the serial ones (normals to
    rounding: the per-part sums regroup the serial sum), and the canonical order on request."""
    vol = grid_volume((12, 11, 10), spacing=(0.1, 0.1, 0.1), tets=tets, jitter=0.2 if tets else 0.0, seed=6)
    s = np.random.default_rng(8).random(vol.n_points)
    monkeypatch.setattr(EdgeCentredTable, "STAGE3_PARALLEL_TRIANGLES", 0)
    ser = EdgeCentredTable(vol, s)
    par = EdgeCentredTable(vol, s, threads=2)
    seeds = np.arange(vol.n_cells)
    for value in (0.3, 0.5, 0.7):
        a = ser.extract(value, seeds, canonical=True)
        b = par.extract(value, seeds, canonical=True)
        assert_same_as_serial(a, b)
        np.testing.assert_array_equal(a.triangles, b.triangles)  # canonical: equal arrays as returned
        np.testing.assert_allclose(a.normals, b.normals, atol=1e-12, rtol=0)
        assert np.allclose(np.linalg.norm(b.normals, axis=1), 1.0)


@pytest.mark.parametrize("kernel", ["tetrahedra", "tetrahedra, generic", "hexahedra"])
def test_two_threads_interleaved_cell_by_cell(kernel, monkeypatch):
    """A deterministic race: the two threads' shares take turns of one cell each (on one OS thread), so that
    they claim cells next to each other's all the time and decide many vertices by compare-and-swap, winning
    and losing; from tiny buffers (restarts) and seeds everywhere. The serial surface each time (normals to
    1e-12). Tetrahedra run the specialised kernel (``_flood_tet``: positions and normal sums by the thread
    that creates a vertex, normal terms for another thread's vertex listed and added afterwards; its list
    made too small too) and, ``SPECIALISED_KERNEL = False``, the generic one."""
    tets = kernel != "hexahedra"
    monkeypatch.setattr(EdgeCentredTable, "SPECIALISED_KERNEL", kernel == "tetrahedra")
    vol = grid_volume((9, 8, 7), spacing=(0.1, 0.1, 0.1), tets=tets, seed=4)
    x = vol.points
    s = np.sin(11 * x[:, 0]) * np.cos(9 * x[:, 1]) + np.sin(8 * x[:, 2])
    s[::7] = 0.25  # nodes exactly at one of the values: vertices on nodes, contested too
    ser = EdgeCentredTable(vol, s)
    par = EdgeCentredTable(vol, s, threads=2)
    rng = np.random.default_rng(2)
    contested = restarts = foreign = node_vertices = 0
    causes = set()
    for rep, value in enumerate([0.25, *rng.uniform(np.quantile(s, 0.2), np.quantile(s, 0.8), 7)]):
        seeds = rng.permutation(vol.n_cells)[:rng.integers(2, 300)]
        if rep % 3 == 0:
            par._queue, par._tris, par._tri_cell, par._vkey, par._vend = (
                np.empty(2, np.int32), np.empty((2, 3), np.int32), np.empty(2, np.int32), np.empty(2, np.int32),
                np.empty((2, 2), np.int32))
            par._fcode, par._fval = np.empty(2, np.int32), np.empty((2, 3))
        for turn in (1, 3):
            iso = par._extract_parallel(float(value), par._check_seeds(seeds), "mean", None, 2, interleave=turn)
            assert_same_as_serial(ser.extract(value, seeds), iso)
            assert (par._ev == -1).all()
            # vertices made on nodes: at least those of the surface that lie on a node at the value (a node
            # only touched by the surface is made too, then left without a triangle), at most one per such node
            on_nodes = {tuple(p) for p in x[s == value]} & {tuple(v) for v in iso.vertices}
            assert len(on_nodes) <= par.stats["node_vertices"] <= np.count_nonzero(s == value)
            node_vertices += len(on_nodes)
            assert par.stats["per_thread"][0] > 0 and par.stats["per_thread"][1] > 0
            assert par.stats["kernel"] == ("tetrahedra" if kernel == "tetrahedra" else "generic")
            contested += par.stats["contested"]
            restarts += par.stats["restarts"]
            causes.update(par.stats["restart_causes"])
            foreign += par.stats["foreign_terms"]
    assert contested > 100 and restarts > 0
    assert node_vertices > 0  # value 0.25 hits nodes: some of its vertices were made on nodes
    if kernel == "tetrahedra":  # normal terms passed between the threads, and their list overflowed once at least
        assert foreign > 100 and _k.FULL_FOREIGN in causes
    else:
        assert foreign == 0


def test_lists_grow_and_queries_repeat():
    vol = grid_volume((10, 9, 8), spacing=(0.1, 0.1, 0.1), seed=2)
    s = np.random.default_rng(5).random(vol.n_points)
    ser = EdgeCentredTable(vol, s)
    par = EdgeCentredTable(vol, s, threads=2)
    par._queue = np.empty(2, np.int32)  # too small for any surface here
    seeds = np.arange(vol.n_cells)
    iso = par.extract(0.5, seeds)
    assert par.stats["restarts"] > 0
    assert_same_as_serial(ser.extract(0.5, seeds), iso)
    again = par.extract(0.5, seeds)
    assert par.stats["restarts"] == 0
    assert_same_as_serial(iso, again)
    mem = par.memory_bytes()
    assert mem["parallel"] == 4 * (vol.edges.shape[0] + vol.n_points)  # the contested-vertex ids only
    assert "parallel" not in ser.memory_bytes()


def test_empty_surfaces_and_uncrossed_seeds():
    vol = datasets.load("torus")
    s = vol.scalars()
    par = EdgeCentredTable(vol, threads=2)
    assert par.extract(s.max() + 1, np.arange(vol.n_cells)).n_triangles == 0
    assert par.extract(s.min() - 1, np.arange(vol.n_cells)).n_triangles == 0
    assert par.extract(float(np.median(s)), []).n_triangles == 0


def test_two_threads_share_one_prepared_method():
    """Two Python threads on one method prepared with ``threads=2``: the method's lock runs them one at a
    time, and each gets its surface."""
    vol = datasets.load("data1")
    s = vol.scalars("fem")
    values = np.linspace(s.min(), s.max(), 22)[1:-1]
    ser = methods.get("edge-centred-table")(vol, field="fem")
    ref = [ser.extract(v) for v in values]
    par = methods.get("edge-centred-table")(vol, field="fem", threads=2)
    out = [[None] * len(values) for _ in range(2)]
    errors = []

    def work(k):
        try:
            for i in (range(len(values)) if k == 0 else range(len(values) - 1, -1, -1)):
                out[k][i] = par.extract(values[i])
        except BaseException as exc:
            errors.append(exc)

    pool = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in pool:
        t.start()
    for t in pool:
        t.join()
    assert not errors
    for k in range(2):
        for a, b in zip(ref, out[k]):
            assert_same_as_serial(a, b)
    many = par.extract_many(values, threads=2)  # values side by side, one thread each
    for a, b in zip(ref, many):
        assert_same_as_serial(a, b)


@pytest.mark.parametrize("threads", [0, -1, 1.5, "2", True])
def test_bad_thread_counts_are_refused(threads):
    vol = datasets.load("torus")
    with pytest.raises(IsoSurfaceError, match=f"threads must be a whole number >= 1.*got {threads!r}"):
        EdgeCentredTable(vol, threads=threads)
    ec = EdgeCentredTable(vol)
    with pytest.raises(IsoSurfaceError, match="threads must be a whole number"):
        ec.extract(1.0, [0], threads=threads)


def test_walk_method_refuses_threads():
    vol = datasets.load("torus")
    with pytest.raises(IsoSurfaceError, match="edge-centred-table"):
        methods.get("edge-centred")(vol, threads=2)
    assert methods.get("edge-centred")(vol, threads=1).extract(float(np.median(vol.scalars()))).n_triangles > 0


# ------------------------------------------------------------------ completeness sweeps with two threads
def _assert_complete(vol, field, values):
    """Two threads from the thinning seeds give the full scan's triangles for every value."""
    m = methods.get("edge-centred-table")(vol, field, threads=2)
    for v in values:
        ours = m.extract(v)
        ref = extract(vol, v, field=field)
        a, b = sorted_triangles(ours), sorted_triangles(ref)
        assert a.shape == b.shape and np.array_equal(a, b), (
            f"value {v}: {a.shape[0]} triangles by two threads, {b.shape[0]} by the scan")
        assert ours.cells_intersected == ref.cells_intersected


def test_tiny_volumes_complete_with_two_threads(tiny_volume):
    """The sweeps of the thinning tests (200 values per field) by the parallel construction: the full scan's
    triangles every time."""
    for field in tiny_volume.fields:
        _assert_complete(tiny_volume, field, iso_values(tiny_volume.scalars(field), 200))


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_adversarial_and_tied_volumes_complete_with_two_threads(cell_type):
    for build in ADVERSARIAL.values():
        vol = build(cell_type)
        for field in vol.fields:
            _assert_complete(vol, field, iso_values(vol.scalars(field), 200))
    rng = np.random.default_rng(7 if cell_type == "tetra" else 8)
    for _ in range(8):  # random holes and voids, quantised random fields: many ties and flat extrema
        vol = random_shape(rng, cell_type)
        s = rng.integers(0, int(rng.integers(2, 6)), vol.n_points).astype(float)
        u = np.unique(s)
        _assert_complete(vol, s, np.concatenate([u, (u[:-1] + u[1:]) / 2]))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["data4", "2M"])
def test_twenty_values_on_large_data_same_as_serial(name):
    vol = datasets.load(name)
    s = vol.scalars("fem")
    m = methods.get("edge-centred-table")(vol, field="fem")
    for v in np.linspace(s.min(), s.max(), 22)[1:-1]:
        seeds = m.source.query(v).cells
        assert_same_as_serial(m.builder.extract(v, seeds, threads=1), m.builder.extract(v, seeds, threads=2))


# ------------------------------------------------------------------ threads="auto": the default
def test_crossed_estimate_counts_the_crossed_cells():
    """Every cell sampled (fewer cells than SPAN_SAMPLE): the estimate is the exact count of crossed cells (the
    full scan's); a sample of 4096 cells on a larger grid: within five standard errors of it."""
    vol = grid_volume((12, 11, 10), spacing=(0.1, 0.1, 0.1), jitter=0.2, seed=6)
    s = np.sin(7 * vol.points[:, 0]) + np.cos(5 * vol.points[:, 1]) * vol.points[:, 2]
    ec = EdgeCentredTable(vol, s)
    assert vol.n_cells <= ec.SPAN_SAMPLE
    for value in np.quantile(s, [0.02, 0.3, 0.5, 0.9]):
        assert ec.crossed_estimate(value) == extract(vol, value, field=s).cells_intersected
    assert ec.crossed_estimate(s.min() - 1) == 0 and ec.crossed_estimate(s.max() + 1) == 0
    big = grid_volume((24, 22, 20), spacing=(0.05, 0.05, 0.05), jitter=0.2, seed=7)
    s = np.sin(7 * big.points[:, 0]) + np.cos(5 * big.points[:, 1]) * big.points[:, 2]
    ec = EdgeCentredTable(big, s)
    ec.SPAN_SAMPLE = 4096
    for value in np.quantile(s, [0.3, 0.5, 0.7]):
        true = extract(big, value, field=s).cells_intersected
        est = ec.crossed_estimate(value)
        k = true * 4096 / big.n_cells  # expected sampled cells crossed
        assert abs(est - true) <= 5 * np.sqrt(k) * big.n_cells / 4096, (value, est, true)


def test_auto_threads_policy(monkeypatch):
    """``threads="auto"`` (the default): several threads only for a surface estimated to cross at least
    PARALLEL_MIN_CELLS cells and while no other program's task is runnable; the serial surface either way;
    ``threads=`` at the query or the builder forces a count."""
    import numba

    from polygen.volume import edge_centred as ec_mod

    vol = grid_volume((12, 11, 10), spacing=(0.1, 0.1, 0.1), jitter=0.2, seed=6)
    s = np.random.default_rng(8).random(vol.n_points)
    assert EdgeCentredTable(vol, s).threads == "auto"
    assert methods.get("edge-centred-table")(vol, field=s).builder.threads == "auto"
    ser = EdgeCentredTable(vol, s, threads=1)
    auto = EdgeCentredTable(vol, s)
    seeds = np.arange(vol.n_cells)
    n = min(numba.get_num_threads(), __import__("os").cpu_count())
    many = n if n >= 2 and _k.ATOMICS else 1
    idle = {"busy": 0}
    monkeypatch.setattr(ec_mod, "_runnable_elsewhere", lambda: idle["busy"])
    monkeypatch.setattr(ec_mod, "BUSY_SECONDS", 0.0)  # a reading per query (test_busy_reading_is_reused)
    value = 0.5
    est = auto.crossed_estimate(value)
    assert est > 100
    for min_cells, busy, expected in ((est + 1, 0, 1), (est, 0, many), (est, n - 1, 1), (est, 10, 1)):
        monkeypatch.setattr(EdgeCentredTable, "PARALLEL_MIN_CELLS", min_cells)
        idle["busy"] = busy
        assert_same_as_serial(ser.extract(value, seeds), auto.extract(value, seeds))
        assert auto.stats["threads"] == expected, (min_cells, busy)
    idle["busy"] = 10  # forced counts whatever the machine says
    auto.extract(value, seeds, threads=2)
    assert auto.stats["threads"] == (2 if _k.ATOMICS else 1)
    ser.extract(value, seeds)
    assert ser.stats["threads"] == 1
    with pytest.raises(IsoSurfaceError, match="threads must be a whole number >= 1, 'auto'"):
        EdgeCentredTable(vol, s, threads="all")


def test_busy_reading_is_reused(monkeypatch):
    """One reading of the machine's runnable tasks serves the ``"auto"`` queries of the next BUSY_SECONDS."""
    from polygen.volume import edge_centred as ec_mod

    readings = []
    monkeypatch.setattr(ec_mod, "_runnable_elsewhere", lambda: readings.append(1) or len(readings))
    monkeypatch.setattr(ec_mod, "_busy_reading", [float("-inf"), 0])
    clock = [100.0]
    monkeypatch.setattr(ec_mod.time, "monotonic", lambda: clock[0])
    monkeypatch.setattr(ec_mod, "BUSY_SECONDS", 0.1)
    assert [ec_mod._busy() for _ in range(3)] == [1, 1, 1]
    clock[0] += 0.099
    assert ec_mod._busy() == 1
    clock[0] += 0.002
    assert ec_mod._busy() == 2 and ec_mod._busy() == 2
    monkeypatch.setattr(ec_mod, "BUSY_SECONDS", 0.0)
    assert ec_mod._busy() == 3 and ec_mod._busy() == 4


@pytest.mark.parametrize("tets", [True, False])
def test_gradient_and_no_normals_with_two_threads(tets):
    """``normals="gradient"`` and ``None`` by two threads: the serial positions and gradient normals bit for bit
    (each vertex's own computation; the tetrahedron flood's positions are the serial kernel's expression), none
    asked, none given."""
    vol = grid_volume((10, 9, 8), spacing=(0.1, 0.1, 0.1), tets=tets, jitter=0.2 if tets else 0.0, seed=9)
    s = np.random.default_rng(10).random(vol.n_points)
    ser = EdgeCentredTable(vol, s, threads=1)
    par = EdgeCentredTable(vol, s, threads=2)
    seeds = np.arange(vol.n_cells)
    for value in (0.35, 0.6):
        for normals in ("gradient", None):
            a = ser.extract(value, seeds, normals=normals, canonical=True)
            b = par.extract(value, seeds, normals=normals, canonical=True)
            assert_same_as_serial(a, b)
            if normals is None:
                assert b.normals is None
            else:
                np.testing.assert_array_equal(a.normals, b.normals)


@pytest.mark.parametrize("threads", [1, 2])
def test_surfaces_kept_alive_are_untouched_by_later_queries(threads):
    """The output arrays sit on recycled buffers (polygen._jit.output_empty): a surface the caller keeps is never
    written by a later query, and a dropped one's buffers are taken again (no fresh pages)."""
    from polygen import _jit

    vol = datasets.load("data2")
    s = vol.scalars("fem")
    m = methods.get("edge-centred-table")(vol, field="fem", threads=threads)
    values = np.linspace(s.min(), s.max(), 22)[1:-1]
    kept = []
    for v in list(values) + list(values[::-1]):  # every size class twice, the surfaces all alive
        iso = m.extract(v)
        kept.append((iso, iso.triangles.copy(), iso.vertices.copy(), iso.normals.copy(), iso.vertex_keys.copy()))
        for old, t, x, n, k in kept:
            assert np.array_equal(old.triangles, t) and np.array_equal(old.vertices, x)
            assert np.array_equal(old.normals, n) and np.array_equal(old.vertex_keys, k)
    big = kept[len(values) // 2][0]
    assert isinstance(big.triangles.base, _jit._Lease)
    before = _jit.pool_stats["reused"]
    del kept, iso, old
    for v in values:
        m.extract(v)
    assert _jit.pool_stats["reused"] > before

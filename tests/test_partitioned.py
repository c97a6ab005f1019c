"""Partitioned volumes (issue 21): the stitched surface is the single volume's, here and on Dask.

Oracle: the single volume's surface of the same value (its triangles by the
global node pairs of their vertices' edges, its vertex count, its area),
and the full scan of each partition for the per-partition completeness.
"""

import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from polygen.volume import datasets, isovalues
from polygen.volume.partitioned import (PartitionedVolume, PartitionError, reduce_tree, scale_model, stitch,
                                        tree_stitch)
from polygen.volume.surface import IsoSurfaceError

N_VALUES = 200  # the sweep, without Dask
N_VALUES_DASK = 60  # with the cluster: keeps each Dask test well under a minute on two shared cores


def global_keys(vol, iso):
    """The single volume's vertex keys as global pair keys ``a * N + b`` (``a * (N + 1)`` on a node)."""
    e, n = vol.edges.astype(np.int64), vol.n_points  # int32 node ids: a * N in int64
    k = iso.vertex_keys
    on_edge = k < e.shape[0]
    out = np.empty(k.shape, np.int64)
    out[on_edge] = e[k[on_edge], 0] * n + e[k[on_edge], 1]
    out[~on_edge] = (k[~on_edge] - e.shape[0]) * (n + 1)
    return out


def _edge_counts(tri, n):
    """Distinct undirected edges of triangles over ``n`` vertex ids (as ``a * n + b``) and their uses."""
    e = np.sort(tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(e[:, 0] * n + e[:, 1], return_counts=True)


def assert_same_as_single(vol, single, stitched):
    """Same triangles, vertex count, area (1e-9 relative); no vertex twice; interior edges in two triangles."""
    assert stitched.n_triangles == single.n_triangles
    assert stitched.n_vertices == single.n_vertices
    assert stitched.area() == pytest.approx(single.area(), rel=1e-9, abs=1e-300)
    # one vertex per global key, each made where the single volume makes it, bit for bit: no vertex twice
    # (the stitched vertices come piece after piece: compared in key order)
    o2 = np.argsort(stitched.vertex_keys)
    keys = stitched.vertex_keys[o2]
    assert np.all(np.diff(keys) > 0)
    gk = global_keys(vol, single)
    order = np.argsort(gk)
    np.testing.assert_array_equal(gk[order], keys)
    np.testing.assert_array_equal(single.vertices[order], stitched.vertices[o2])
    # the same triangles, as sets of vertices (single's vertices renumbered as the stitched ones, in key order)
    rank = np.empty(gk.size, np.int64)
    rank[order] = np.arange(gk.size)
    back = np.empty(gk.size, np.int64)
    back[o2] = np.arange(gk.size)
    stitched_tri = back[stitched.triangles]
    nv = max(keys.size, 1)

    def tri_codes(t):
        t = np.sort(t, axis=1)
        return np.sort((t[:, 0] * nv + t[:, 1]) * nv + t[:, 2])

    np.testing.assert_array_equal(tri_codes(rank[single.triangles]), tri_codes(stitched_tri))
    # no crack: every edge is in two triangles but the single volume's open ones, which lie on its boundary
    if stitched.n_triangles:
        u1, c1 = _edge_counts(rank[single.triangles], nv)
        u2, c2 = _edge_counts(stitched_tri, nv)
        np.testing.assert_array_equal(u1[c1 == 1], u2[c2 == 1])
        assert set(np.unique(c2).tolist()) <= {1, 2}
        bnodes = np.zeros(vol.n_points, bool)
        bnodes[vol.boundary_face_nodes] = True
        once = u2[c2 == 1]
        ends = keys[np.stack([once // nv, once % nv])]
        n = vol.n_points
        assert bnodes[ends // n].all() and bnodes[ends % n].all()


@pytest.fixture(scope="module")
def data3():
    return datasets.load("data3")


@pytest.fixture(scope="module")
def data4():
    return datasets.load("data4")


# ------------------------------------------------------------------ exactness without Dask

@pytest.mark.parametrize("name,k", [("data3", 2), ("data3", 8), ("data4", 3), ("data4", 5)])
def test_split_stitched_equals_single(name, k, request):
    vol = request.getfixturevalue(name)
    values = isovalues(vol.scalars(), N_VALUES)
    prepared = PartitionedVolume.split(vol, k).prepare()
    seam = 0
    for v in values:
        single = vol.isosurface(v)
        stitched = prepared.extract(v)
        assert_same_as_single(vol, single, stitched)
        assert len(stitched.partitions) == k
        assert sum(p["n_triangles"] for p in stitched.partitions) == stitched.n_triangles
        seam += stitched.seam_vertices
    assert seam > 0  # the sweep crosses the seams: the stitch had vertices to merge


@pytest.mark.parametrize("method", ["span-space", "extrema-graph", "thinning", "scan"])
def test_other_methods_stitched_equal_single(data3, method):
    values = isovalues(data3.scalars(), 40)
    prepared = PartitionedVolume.split(data3, 4).prepare(method=method)
    for v in values:
        assert_same_as_single(data3, data3.isosurface(v, method="scan"), prepared.extract(v))


def test_each_partition_is_its_full_scan(data3):
    """Completeness per partition: method + seam seeds = the partition's full scan, for every partition."""
    prepared = PartitionedVolume.split(data3, 5).prepare()
    for v in isovalues(data3.scalars(), 60):
        for p in prepared.partitions:
            piece = p.extract(v)
            scan = p.vol.isosurface(v, method="scan")
            assert np.array_equal(np.sort(piece["triangle_cells"]), np.sort(p.cell_ids[scan.triangle_cells]))
            assert np.unique(piece["keys"]).size == scan.n_vertices


def _concat_unique_reference(a, b, keep):
    """The obvious way (the seam pieces' merge before _with_missed): ``a`` and ``b``'s triangles ``keep``
    concatenated, then one vertex per key (the first) by ``np.unique``, the triangles renumbered."""
    keys = np.concatenate([a.vertex_keys, b.vertex_keys])
    verts = np.concatenate([a.vertices, b.vertices])
    tri = np.concatenate([a.triangles, b.triangles[keep] + a.vertices.shape[0]])
    _, first, inv = np.unique(keys, return_index=True, return_inverse=True)
    firsts = np.sort(first)
    new = np.searchsorted(firsts, first[inv.ravel()])
    return verts[firsts], keys[firsts], new[tri], np.concatenate([a.triangle_cells, b.triangle_cells[keep]])


@pytest.mark.parametrize("every", [2, 3, 5])
def test_seam_piece_merged_as_by_unique(data3, every):
    """_with_missed (marks and a binary search, no sort of the surface) against concatenation + np.unique:
    a surface missing the triangles of some cells, and a propagation from them that finds those and others."""
    import dataclasses

    from polygen.volume.partitioned import _with_missed
    from polygen.volume.propagate import Propagator

    p = PartitionedVolume.split(data3, 2).prepare().partitions[1]
    prop = Propagator(p.vol, p.field)
    made = np.zeros(p.vol.n_cells, bool)
    grew = shared = 0
    for v in isovalues(data3.scalars(), 7):
        iso = p.method.extract(v, normals=None)
        cells = np.unique(iso.triangle_cells)
        gone = cells[::every]
        hole = np.isin(iso.triangle_cells, gone)
        used, tri = np.unique(iso.triangles[~hole], return_inverse=True)  # the hole's own vertices go too
        part = dataclasses.replace(iso, vertices=iso.vertices[used], vertex_keys=iso.vertex_keys[used],
                                   triangles=tri.reshape(-1, 3), triangle_cells=iso.triangle_cells[~hole])
        extra = prop.extract(v, cells[:: max(1, cells.size // 5)], normals=None)
        keep = np.isin(extra.triangle_cells, part.triangle_cells, invert=True)
        assert keep.any() and not keep.all()  # the case at hand: some triangles new, some made already
        got = _with_missed(part, extra, made)
        ref = _concat_unique_reference(part, extra, keep)
        for a, b in zip((got.vertices, got.vertex_keys, got.triangles, got.triangle_cells), ref):
            np.testing.assert_array_equal(a, b)
        assert not made.any()
        assert got.normals is None and got.n_triangles == part.n_triangles + keep.sum()
        grew += got.n_vertices > part.n_vertices
        shared += got.n_vertices < part.n_vertices + extra.n_vertices
    assert grew and shared  # new vertices and vertices already there, both exercised


def test_vertices_bitwise_equal_single_and_normals_close(data3):
    prepared = PartitionedVolume.split(data3, 6).prepare()
    for v in isovalues(data3.scalars(), 10):
        single, stitched = data3.isosurface(v), prepared.extract(v)
        gk = global_keys(data3, single)
        o1, o2 = np.argsort(gk), np.argsort(stitched.vertex_keys)
        np.testing.assert_array_equal(single.vertices[o1], stitched.vertices[o2])
        # mean normals summed in another triangle order: equal to rounding
        np.testing.assert_allclose(single.normals[o1], stitched.normals[o2], atol=1e-12, rtol=0)


def test_normals_of_flat_vertices_near_an_extremum(data3):
    """A value a hair above each local minimum: zero-area triangles, whose vertices take their edge's direction."""
    prepared = PartitionedVolume.split(data3, 4).prepare()
    s = data3.scalars()
    flat = 0
    for base in (s.min(), np.sort(s)[len(s) // 3]):
        v = np.nextafter(base, np.inf)
        flat += sum(p.extract(v)["flat"] for p in prepared.partitions)
        # the scan: vertex_normals with the points, as the propagation (the edge-centred method passes none)
        single, stitched = data3.isosurface(v, method="scan"), prepared.extract(v)
        o = np.argsort(global_keys(data3, single))
        # a vertex touching a zero-area triangle has a mean normal made of rounding-level cross products
        # (they may cancel in another order): compared elsewhere only for being a unit vector
        sv, st = single.vertices, single.triangles
        zero_area = ~(np.abs(np.cross(sv[st[:, 1]] - sv[st[:, 0]], sv[st[:, 2]] - sv[st[:, 0]])).sum(axis=1) > 0)
        ill = np.zeros(single.n_vertices, bool)
        ill[st[zero_area].ravel()] = True
        ill = ill[o]
        o2 = np.argsort(stitched.vertex_keys)
        np.testing.assert_allclose(single.normals[o][~ill], stitched.normals[o2][~ill], atol=1e-12, rtol=0)
        on_edge = (stitched.vertex_keys // stitched.n_ids) != (stitched.vertex_keys % stitched.n_ids)
        np.testing.assert_allclose(np.linalg.norm(stitched.normals[on_edge], axis=1), 1.0, atol=1e-12)
        assert ill.any()  # the case was met
    assert flat > 0  # the case was met


def test_pvtu_round_trip(tmp_path, data3):
    pvol = PartitionedVolume.split(data3, 3)
    pieces = pvol.write_pvtu(tmp_path / "d3.pvtu")
    assert len(pieces) == 3 and all(p.exists() for p in pieces)
    back = PartitionedVolume.from_pvtu(tmp_path / "d3.pvtu").prepare()
    for v in isovalues(data3.scalars(), 12):
        single = data3.isosurface(v)
        stitched = back.extract(v)
        # cells are numbered piece after piece here; compare by nodes, which keep their global ids
        assert_same_as_single(data3, single, stitched)


@pytest.mark.parametrize("k", [2, 3, 7])
def test_weighted_split_cuts_at_equal_weight(data3, k):
    """Cut by weights: each Morton range holds 1/k of the total weight to within one cell's weight (the
    closed form of cutting a running sum); unit weights give equal cell counts, as the default."""
    from polygen.volume.partitioned import span_weights

    w = span_weights(data3)
    s = data3.scalars()[data3.cells]
    np.testing.assert_array_equal(w, s.max(axis=1) - s.min(axis=1))
    pvol = PartitionedVolume.split(data3, k, weights=w)
    got = np.array([w[p.cell_ids].sum() for p in pvol.pieces])
    assert got.sum() == pytest.approx(w.sum(), rel=1e-12)
    assert np.abs(got - w.sum() / k).max() <= 2 * w.max()  # a range ends within one cell of its share
    assert sorted(np.concatenate([p.cell_ids for p in pvol.pieces]).tolist()) == list(range(data3.n_cells))
    sizes = [p.cell_ids.size for p in PartitionedVolume.split(data3, k, weights=np.ones(data3.n_cells)).pieces]
    assert max(sizes) - min(sizes) <= 1  # unit weights: equal cell counts, as the default
    # zero weight everywhere but one cell: every range still holds a cell
    z = np.zeros(data3.n_cells)
    z[5] = 1.0
    assert all(p.cell_ids.size for p in PartitionedVolume.split(data3, k, weights=z).pieces)
    with pytest.raises(PartitionError, match="weights"):
        PartitionedVolume.split(data3, k, weights=-w)
    with pytest.raises(PartitionError, match="weights"):
        PartitionedVolume.split(data3, k, weights=w[:-1])


@pytest.mark.parametrize("k", [2, 5])
def test_span_weighted_split_stitched_equals_single(data3, k):
    from polygen.volume.partitioned import span_weights

    prepared = PartitionedVolume.split(data3, k, weights=span_weights(data3)).prepare()
    for v in isovalues(data3.scalars(), 40):
        assert_same_as_single(data3, data3.isosurface(v), prepared.extract(v))


@pytest.mark.slow
@pytest.mark.parametrize("k", [2, 8])
def test_2M_split_stitched_equals_single(k):
    vol = datasets.load("2M")
    prepared = PartitionedVolume.split(vol, k).prepare()
    for v in isovalues(vol.scalars(), N_VALUES):
        assert_same_as_single(vol, vol.isosurface(v), prepared.extract(v))


def _same_arrays(a, b, counters=True):
    for f in ("vertex_keys", "vertices", "triangles", "triangle_cells", "normals"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f), err_msg=f)
    assert a.seam_vertices == b.seam_vertices
    if counters:  # the same pieces: the same counters and stage times
        assert a.partitions == b.partitions


def full_key_stitch(vol, value, pieces, n_ids):
    """The reference stitch: every vertex matched by its global key (``np.unique`` over all of them),
    vertices in key order, mean normals (5.3.1) over the whole stitched surface in piece order, a vertex
    whose normal sums to zero on an edge taking the edge's direction towards increasing scalar (as the
    single volume does), and a triangle at ``C`` in a shared face made by two cells kept once, from the
    lower cell id. Returns keys, vertices, normals, triangles, triangle cells and the vertices merged away."""
    from polygen.volume.marching import _mean_normals

    keys = np.concatenate([p["keys"] for p in pieces])
    offsets = np.cumsum([0] + [p["keys"].shape[0] for p in pieces])
    uniq, first, inv = np.unique(keys, return_index=True, return_inverse=True)
    verts = np.concatenate([p["vertices"] for p in pieces])[first]
    tri = np.concatenate([inv.ravel()[p["triangles"].astype(np.int64) + o] for p, o in zip(pieces, offsets)])
    tcell = np.concatenate([p["triangle_cells"] for p in pieces]).astype(np.int64)
    node = (uniq // n_ids) == (uniq % n_ids)
    cand = np.flatnonzero(np.all(node[tri], axis=1))
    cand = cand[np.argsort(tcell[cand], kind="stable")]
    _, keep_first = np.unique(np.sort(uniq[tri[cand]], axis=1), axis=0, return_index=True)
    keep = np.ones(tri.shape[0], bool)
    keep[cand] = False
    keep[cand[keep_first]] = True
    tri, tcell = np.ascontiguousarray(tri[keep]), tcell[keep]
    nrm = np.empty_like(verts)
    _mean_normals(verts, tri, nrm)
    a, b = uniq // n_ids, uniq % n_ids
    # the flat-fan rule: a vertex touching a zero-area triangle whose normal is zero
    v = verts
    cr = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])
    flat = np.zeros(v.shape[0], bool)
    flat[tri[~np.any(cr != 0, axis=1)].ravel()] = True
    zero = flat & (a != b) & ~(np.abs(nrm).sum(axis=1) > 0)
    s = vol.fields[next(iter(vol.fields))] if len(vol.fields) == 1 else vol.scalars()
    d = (vol.points[b[zero]] - vol.points[a[zero]]) * np.sign(s[b[zero]] - s[a[zero]])[:, None]
    nrm[zero] = d / np.linalg.norm(d, axis=1)[:, None]
    return uniq, verts, nrm, tri, tcell, int(keys.size - uniq.size)


@pytest.mark.parametrize("k", [2, 3, 5])
def test_seam_only_stitch_equals_full_key_stitch(data3, k):
    """The seam-only merge (only seam vertices matched, normals final on the partitions but at the seam) gives
    the reference stitch's arrays bit for bit, vertices in another order; flat fans included."""
    prepared = PartitionedVolume.split(data3, k).prepare()
    s = data3.scalars()
    values = list(isovalues(s, 30)) + [np.nextafter(s.min(), np.inf), np.nextafter(np.sort(s)[len(s) // 3], np.inf)]
    seam = flat = 0
    for v in values:
        pieces = [p.extract(v) for p in prepared.partitions]
        got = stitch(v, pieces, n_ids=prepared.n_ids)
        keys, verts, nrm, tri, tcell, merged = full_key_stitch(data3, v, pieces, prepared.n_ids)
        order = np.argsort(got.vertex_keys)
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        np.testing.assert_array_equal(got.vertex_keys[order], keys)
        np.testing.assert_array_equal(got.vertices[order], verts)
        np.testing.assert_array_equal(got.normals[order], nrm)
        np.testing.assert_array_equal(rank[got.triangles], tri)
        np.testing.assert_array_equal(got.triangle_cells, tcell)
        assert got.seam_vertices == merged
        seam += merged
        flat += sum(p["flat"] for p in pieces)
    assert seam > 0 and flat > 0  # the seams and the flat fans were met


def test_tree_stitch_equals_client_stitch(data3):
    """Pairwise merges up the tree of neighbours (5 partitions: an odd one goes up a level) = all at once."""
    prepared = PartitionedVolume.split(data3, 5).prepare()
    values = isovalues(data3.scalars(), 7)
    for v in values:
        pieces = [p.extract(v) for p in prepared.partitions]
        flat = stitch(v, pieces, n_ids=prepared.n_ids)
        tree = tree_stitch(v, pieces, n_ids=prepared.n_ids)
        _same_arrays(flat, tree)
        assert_same_as_single(data3, data3.isosurface(v), tree)
        assert tree.seam_vertices > 0 and len(tree.partitions) == 5


def test_reduce_tree_pairs_neighbours():
    assert reduce_tree("abcde", lambda a, b: f"({a}{b})") == "(((ab)(cd))e)"
    assert reduce_tree(["a"], lambda a, b: a + b) == "a"
    with pytest.raises(PartitionError, match="no pieces"):
        reduce_tree([], lambda a, b: a)


def test_scale_model_closed_form():
    """512x the cells: 64x the crossed cells and triangles; 64 workers: 6 levels; the formulas by hand."""
    rates = dict(n_cells=1e9 / 512, crossed_per_value=1000.0, triangles_per_value=2000.0, prepare_s_per_cell=1e-6,
                 query_s_per_crossed_cell=1e-6, stitch_s_per_triangle=1e-7, piece_bytes_per_triangle=40.0,
                 surface_bytes_per_triangle=60.0)
    m = scale_model(**rates, bandwidth_bytes_s=1e9)
    assert m["growth"] == pytest.approx(64) and m["levels"] == 6
    assert m["triangles"] == pytest.approx(128000) and m["crossed"] == pytest.approx(64000)
    assert m["prepare_s"] == pytest.approx(1e9 / 64 * 1e-6)
    assert m["extract_s"] == pytest.approx(64000 * 1e-6 / 64)
    assert m["stitch_s"] == pytest.approx(1e-7 * 128000 * (2 - 2 / 64))
    assert m["bytes_between_workers"] == pytest.approx(40 * 128000 * 3)
    assert m["bytes_to_client"] == pytest.approx(60 * 128000)
    assert m["transfer_s"] == pytest.approx((40 * 128000 * 63 / 64 + 60 * 128000) / 1e9)
    assert m["latency_s"] == pytest.approx(m["extract_s"] + m["stitch_s"] + m["transfer_s"])
    # a sweep of 20 values: 20 * 6 / 64 < 2 - 2/64 stitches on the workers; 20 on one client
    assert m["sweep_stitch_workers_s"] == pytest.approx(1e-7 * 128000 * (2 - 2 / 64))
    assert m["sweep_stitch_client_s"] == pytest.approx(1e-7 * 128000 * 20)
    assert m["sweep_client_link_s"] == pytest.approx((20 * 60 * 128000 / 1e9, 20 * 40 * 128000 / 1e9))
    assert scale_model(**rates, sweep=64)["sweep_stitch_workers_s"] == pytest.approx(1e-7 * 128000 * 6)
    # the measured volume on one worker: the measured costs back, nothing merged or moved between workers
    one = scale_model(**rates, target_cells=1e9 / 512, workers=1)
    assert one["extract_s"] == pytest.approx(1000 * 1e-6) and one["stitch_s"] == 0 and one["bytes_between_workers"] == 0
    with pytest.raises(PartitionError, match="power of two"):
        scale_model(**rates, workers=48)


# ------------------------------------------------------------------ bad input

def _tiny_pvtu(tmp_path, k=3):
    vol = datasets.load("torus")
    return vol, PartitionedVolume.split(vol, k).write_pvtu(tmp_path / "t.pvtu")


def test_missing_piece_named(tmp_path):
    _, pieces = _tiny_pvtu(tmp_path)
    pieces[1].unlink()
    with pytest.raises(PartitionError, match="t_1.vtu"):
        PartitionedVolume.from_pvtu(tmp_path / "t.pvtu")
    with pytest.raises(PartitionError, match="no such file"):
        PartitionedVolume.from_pvtu(tmp_path / "nothing.pvtu")


def _rewrite(path, edit):
    import pyvista as pv

    grid = pv.read(path)
    edit(grid)
    grid.save(path)


def test_global_ids_disagreeing_on_shared_coordinates_named(tmp_path):
    _, pieces = _tiny_pvtu(tmp_path)

    def shift(grid):
        grid.point_data["GlobalNodeId"] = np.asarray(grid.point_data["GlobalNodeId"]) + 1000000

    _rewrite(pieces[2], shift)
    with pytest.raises(PartitionError, match=r"t_2\.vtu.*same coordinates|same coordinates"):
        PartitionedVolume.from_pvtu(tmp_path / "t.pvtu").prepare()
    try:
        PartitionedVolume.from_pvtu(tmp_path / "t.pvtu").prepare()
    except PartitionError as e:
        assert "t_2.vtu" in str(e)


def test_pieces_with_different_fields_named(tmp_path):
    _, pieces = _tiny_pvtu(tmp_path)

    def extra(grid):
        grid.point_data["pressure"] = np.zeros(grid.n_points)

    _rewrite(pieces[1], extra)
    with pytest.raises(PartitionError, match=r"t_1\.vtu.*same node fields"):
        PartitionedVolume.from_pvtu(tmp_path / "t.pvtu").prepare()


def test_piece_without_global_ids_named(tmp_path):
    _, pieces = _tiny_pvtu(tmp_path)

    def drop(grid):
        del grid.point_data["GlobalNodeId"]

    _rewrite(pieces[0], drop)
    with pytest.raises(PartitionError, match=r"t_0\.vtu.*GlobalNodeId"):
        PartitionedVolume.from_pvtu(tmp_path / "t.pvtu").prepare()


def test_bad_arguments():
    vol = datasets.load("torus")
    with pytest.raises(PartitionError, match="k must be"):
        PartitionedVolume.split(vol, 0)
    with pytest.raises(PartitionError, match="UnstructuredVolume"):
        PartitionedVolume.split("vol", 2)
    prepared = PartitionedVolume.split(vol, 2).prepare()
    with pytest.raises(IsoSurfaceError, match="gradient"):
        prepared.extract(0.5, normals="gradient")
    with pytest.raises(IsoSurfaceError, match="value"):
        prepared.extract("x")


# ------------------------------------------------------------------ the automatic partition count

def test_auto_partitions_rule():
    """One partition per worker, each of at least MIN_CELLS_PER_PARTITION cells; fewer than two such: not split."""
    from polygen.volume.partitioned import MIN_CELLS_PER_PARTITION as MIN
    from polygen.volume.partitioned import auto_partitions

    assert auto_partitions(100, 8)[0] == 1
    assert auto_partitions(2 * MIN - 1, 8)[0] == 1
    assert auto_partitions(2 * MIN, 8)[0] == 2
    assert auto_partitions(5 * MIN + 7, 8)[0] == 5  # the cells, not the workers, bound it
    assert auto_partitions(100 * MIN, 8)[0] == 8  # the workers bound it
    assert auto_partitions(100 * MIN, 1)[0] == 1
    assert auto_partitions(10 * MIN, 2)[0] == 2
    k, reason = auto_partitions(MIN, 4)
    assert k == 1 and reason.startswith("not split") and f"{MIN:,}" in reason
    assert "split into 3 partitions" in auto_partitions(3 * MIN, 4)[1]
    assert auto_partitions(MIN)[0] == 1  # default workers: this machine's cores
    for bad in (0, -5, 2.5, True, "10"):
        with pytest.raises(PartitionError, match="n_cells"):
            auto_partitions(bad, 2)
    for bad in (0, 1.5, False):
        with pytest.raises(PartitionError, match="workers"):
            auto_partitions(10 * MIN, bad)


def test_split_by_default_leaves_data4_whole_and_says_why(data4, caplog):
    import logging

    with caplog.at_level(logging.INFO, logger="polygen.volume.partitioned"):
        pvol = PartitionedVolume.split(data4, workers=8)
    assert pvol.n_partitions == 1
    assert pvol.split_reason.startswith("not split") and f"{data4.n_cells:,} cells" in pvol.split_reason
    assert pvol.split_reason in caplog.text
    assert PartitionedVolume.split(data4).n_partitions == 1  # this machine's cores
    three = PartitionedVolume.split(data4, 3)
    assert three.n_partitions == 3 and three.split_reason is None


def test_split_by_default_splits_a_large_volume(monkeypatch, data3):
    """The count follows the cells: with the floor lowered below data3's size, data3 splits one per worker."""
    from polygen.volume import partitioned

    monkeypatch.setattr(partitioned, "MIN_CELLS_PER_PARTITION", data3.n_cells // 4)
    pvol = PartitionedVolume.split(data3, workers=3)
    assert pvol.n_partitions == 3 and "one per worker" in pvol.split_reason
    assert PartitionedVolume.split(data3, workers=8).n_partitions == 4
    values = isovalues(data3.scalars(), 3)
    prepared = pvol.prepare()
    for v in values:
        assert_same_as_single(data3, data3.isosurface(v), prepared.extract(v))


def test_stitch_merges_shared_keys_once():
    """Two pieces making one vertex (same key) and one triangle on a shared face at C: each kept once."""
    n = 10
    node = lambda a: a * n + a  # noqa: E731
    piece = lambda cell: {  # noqa: E731
        "keys": np.array([node(1), node(2), node(3), 4 * n + 5]), "vertices": np.eye(4, 3), "normals": None,
        "seam": np.arange(4), "triangles": np.array([[0, 1, 2], [0, 1, 3]], np.int32), "seam_tris": np.arange(2),
        "triangle_cells": np.array([cell, cell]), "fallback": None, "cells_tested": 1, "cells_intersected": 1,
        "vertex_lookups": 3, "seam_seeds": 0, "t1": 0.0, "t2": 0.0, "t3": 0.0, "piece_s": 0.0, "method": "x"}
    s = stitch(0.0, [piece(7), piece(3)], n_ids=n, normals=None)
    assert s.n_vertices == 4 and s.seam_vertices == 4
    # the all-node triangle once (from cell 3, the lower id); the other triangle made by both cells twice
    assert s.n_triangles == 3
    assert sorted(s.triangle_cells[np.all(np.isin(s.triangles, [0, 1, 2]), axis=1)].tolist()) == [3]


# ------------------------------------------------------------------ no dask on the single-volume path

def test_single_volume_path_does_not_import_dask():
    code = ("import sys; from polygen.volume import datasets; import polygen.volume.partitioned; "
            "v = datasets.load('torus'); v.isosurface(0.5); "
            "print(any(m == 'dask' or m.startswith(('dask.', 'distributed')) for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    assert out.stdout.strip() == "False"


def test_missing_dask_is_a_clear_message(monkeypatch):
    from polygen.volume import distributed as pd

    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(PartitionError, match=r"pip install 'polygen\[distributed\]'"):
        pd.require_distributed()


# ------------------------------------------------------------------ on Dask

def dask_prepare(pvol, **kwargs):
    from polygen.volume.distributed import prepare

    return prepare(pvol, **kwargs)


def _cluster_client():
    pytest.importorskip("distributed")
    from polygen.volume.distributed import local_client

    return local_client(2)


@pytest.fixture(scope="module")
def client():
    c = _cluster_client()
    yield c
    c.close()
    c.cluster.close()


@pytest.mark.parametrize("name,k", [("data3", 4), ("data4", 3)])
def test_dask_stitched_equals_single_and_local(client, name, k, request):
    vol = request.getfixturevalue(name)
    values = isovalues(vol.scalars(), N_VALUES_DASK)
    pvol = PartitionedVolume.split(vol, k)
    on_dask = dask_prepare(pvol, client=client)
    local = pvol.prepare()
    assert len(set(on_dask.placement)) == 2  # both workers hold partitions
    surfaces = on_dask.extract_many(values)
    assert on_dask.bytes_last > 0
    for v, s in zip(values, surfaces):
        assert_same_as_single(vol, vol.isosurface(v), s)
        here = local.extract(v)
        np.testing.assert_array_equal(here.vertex_keys, s.vertex_keys)
        np.testing.assert_array_equal(here.vertices, s.vertices)
        np.testing.assert_array_equal(here.triangles, s.triangles)
    on_dask.close()


def test_dask_stitch_on_workers_bytes(client, data3):
    """Stitched on the workers: the client gets the surfaces; one side of the root merge crossed between workers."""
    from polygen.volume.distributed import _nbytes

    values = list(isovalues(data3.scalars(), 6))
    pvol = PartitionedVolume.split(data3, 2)
    auto = dask_prepare(pvol, client=client)
    assert auto.stitch_on == "client"  # "auto" on a LocalCluster: every worker on this machine
    auto.close()
    on_dask = dask_prepare(pvol, client=client, stitch_on="workers")
    assert on_dask.placement[0] != on_dask.placement[1]
    surfaces = on_dask.extract_many(values)
    local = pvol.prepare()
    pieces = [[p.extract(v) for p in local.partitions] for v in values]
    made = sum(_nbytes(p) for per in pieces for p in per)
    assert on_dask.bytes_pieces_last == made
    # two chunks of values, each root on another worker: each moved the other partition's pieces of its chunk
    moved = sum(_nbytes(per[1]) for per in pieces[:3]) + sum(_nbytes(per[0]) for per in pieces[3:])
    assert on_dask.bytes_workers_last == moved
    # the surfaces travelled with int32 triangles and cell ids
    assert on_dask.bytes_last == sum(s.vertices.nbytes + s.normals.nbytes + s.triangles.nbytes // 2
                                     + s.vertex_keys.nbytes + s.triangle_cells.nbytes // 2 for s in surfaces)
    assert all(s.triangles.dtype == np.int64 and s.triangle_cells.dtype == np.int64 for s in surfaces)
    # stitched on the client instead, over TCP: every piece comes here, the same arrays
    on_dask.stitch_on, on_dask.transport = "client", "tcp"
    for a, b in zip(on_dask.extract_many(values), surfaces):
        _same_arrays(a, b, counters=False)
    assert on_dask.bytes_last == made and on_dask.bytes_workers_last == 0
    # through shared memory: the stitched arrays (each on a 64-byte line) and the seam vertices' indices and keys
    on_dask.transport = "shared-memory"
    for a, b in zip(on_dask.extract_many(values), surfaces):
        _same_arrays(a, b, counters=False)
    line = lambda a: -(-a.nbytes // 64) * 64  # noqa: E731
    seams = sum(sum(x.nbytes for x in p.seam_of(p.surface(v)[0])) for v in values for p in local.partitions)
    assert on_dask.bytes_last == seams + sum(line(s.vertex_keys) + line(s.vertices) + line(s.normals)
                                             + line(s.triangles) + line(s.triangle_cells) for s in surfaces)
    on_dask.close()
    with pytest.raises(PartitionError, match="stitch_on"):
        dask_prepare(pvol, client=client, stitch_on="here")


def _left_blocks(prepared):
    """The shared-memory blocks of the last query that still exist (Linux keeps them under /dev/shm)."""
    assert prepared.blocks_last
    return [n for n in prepared.blocks_last if os.path.exists(os.path.join("/dev/shm", n))]


def test_dask_shared_memory_equals_tcp_and_local(client, data3):
    """Rows written by the workers into shared memory, or pieces over TCP, in chunks of values: the local
    stitch's arrays bit for bit, and no shared-memory block name left behind."""
    from polygen.volume.distributed import _direct_chunks

    values = list(isovalues(data3.scalars(), 9)) + [data3.scalars().max() + 1.0]  # the last: an empty surface
    pvol = PartitionedVolume.split(data3, 3)
    local = pvol.prepare()
    on_dask = dask_prepare(pvol, client=client, stitch_on="client")
    assert on_dask.transport == "shared-memory"  # a LocalCluster: every worker on this machine
    got = {}
    for transport, chunk in (("shared-memory", None), ("shared-memory", 1), ("tcp", 4)):
        on_dask.transport, on_dask.chunk_values = transport, chunk
        got[transport, chunk] = on_dask.extract_many(values)
        assert on_dask.bytes_last > 0
        if transport == "shared-memory":  # one block per chunk
            assert len(on_dask.blocks_last) == len(_direct_chunks(values, chunk))
            assert _left_blocks(on_dask) == []
    for j, v in enumerate(values):
        here = local.extract(v)
        for surfaces in got.values():
            _same_arrays(here, surfaces[j], counters=False)
    on_dask.close()


def test_dask_surfaces_outlive_their_blocks(client, data3):
    """The surfaces' arrays are views on their chunk's block: written by the workers, unlinked by name at once,
    they stay intact (and writeable) through later queries and after close(); a surface without normals too."""
    values = list(isovalues(data3.scalars(), 8))
    pvol = PartitionedVolume.split(data3, 2)
    on_dask = dask_prepare(pvol, client=client, stitch_on="client")
    first = on_dask.extract_many(values)
    assert _left_blocks(on_dask) == [] and all(s.vertices.flags.writeable for s in first)
    bare = on_dask.extract_many(values, normals=None)
    assert all(s.normals is None for s in bare)
    on_dask.chunk_values = 3
    again = on_dask.extract_many(values[::-1])[::-1]
    on_dask.close()
    local = pvol.prepare()
    for v, a, b, c in zip(values, first, again, bare):
        here = local.extract(v)
        _same_arrays(here, a, counters=False)
        _same_arrays(here, b, counters=False)
        np.testing.assert_array_equal(here.triangles, c.triangles)
        np.testing.assert_array_equal(here.vertices, c.vertices)


def test_dask_blocks_written_again_once_their_surfaces_are_gone(client, data3):
    """A block is written again by a later query only when no surface views it any more: kept surfaces stay
    intact (new blocks made), dropped ones give their blocks to the next query (none made), the same arrays."""
    import gc

    values = list(isovalues(data3.scalars(), 8))
    pvol = PartitionedVolume.split(data3, 2)
    on_dask = dask_prepare(pvol, client=client, stitch_on="client")
    on_dask.chunk_values = 3  # 3 chunks, 3 blocks
    first = on_dask.extract_many(values)
    n_blocks = len(on_dask.blocks_last)
    assert on_dask.blocks_made_last == n_blocks > 1
    kept = on_dask.extract_many(values)  # the first surfaces are alive: their blocks are not free
    assert on_dask.blocks_made_last == n_blocks
    keys = [s.vertex_keys.copy() for s in first]
    del first
    gc.collect()
    again = on_dask.extract_many(values)
    assert on_dask.blocks_made_last == 0 and len(on_dask.blocks_last) == n_blocks
    assert _left_blocks(on_dask) == []
    local = pvol.prepare()
    for v, k, a, b in zip(values, keys, kept, again):
        here = local.extract(v)
        np.testing.assert_array_equal(here.vertex_keys, k)
        _same_arrays(here, a, counters=False)
        _same_arrays(here, b, counters=False)
    on_dask.close()


def test_dask_free_blocks_kept_for_sweeps_of_the_other_kind(client, data3):
    """Free blocks a query did not use are kept (up to KEEP_FREE x the most bytes one query used): a sweep one value
    at a time after an extract_many, and the reverse, write the blocks of the sweep before instead of making new."""
    import gc

    values = list(isovalues(data3.scalars(), 8))
    pvol = PartitionedVolume.split(data3, 2)
    on_dask = dask_prepare(pvol, client=client, stitch_on="client")

    def one_by_one():
        out, made = [], 0
        for v in values:
            out.append(on_dask.extract(v))
            made += on_dask.blocks_made_last
        return out, made

    many = on_dask.extract_many(values)
    assert on_dask.blocks_made_last == 1
    del many
    gc.collect()
    first, made_first = one_by_one()
    assert made_first == len(values) - 1  # the first value writes extract_many's block again, the others are new
    del first
    gc.collect()
    on_dask.extract_many(values)  # its surfaces go at once
    assert on_dask.blocks_made_last == 0
    gc.collect()
    again, made_again = one_by_one()
    assert made_again < made_first
    assert _left_blocks(on_dask) == []
    local = pvol.prepare()
    for v, s in zip(values, again):
        _same_arrays(local.extract(v), s, counters=False)
    on_dask.close()


def test_local_client_workers_keep_freed_memory(client):
    """local_client starts its workers with glibc told to keep freed memory (no fresh pages for every query's
    arrays): the settings are in their environment from the start, where glibc reads them."""
    from polygen.volume.distributed import WORKER_MALLOC

    seen = client.run(lambda: {k: os.environ.get(k) for k in WORKER_MALLOC})
    assert len(seen) == 2
    for env in seen.values():
        assert env == {k: str(v) for k, v in WORKER_MALLOC.items()}


def test_workers_run_numba_on_their_own_threads_and_leave_this_process_alone(client):
    """Calls on a worker (tasks, actor methods) run numba's parallel regions on the worker's Dask threads (one
    each here), set per call -- not through NUMBA_NUM_THREADS, which numba re-reads at every compilation: in
    the workers' environment (``env=``) it made the first kernel compiled there fail on a fresh install when
    the user's script imports polygen at its top (the spawned workers import that module again; seen with
    no numba cache, not reproduced here), and set before the spawn the nanny leaves it in this process."""
    import numba

    from polygen.volume.distributed import _as_dask_threads

    assert "NUMBA_NUM_THREADS" not in os.environ
    nthreads = client.run(lambda dask_worker: dask_worker.state.nthreads)
    counts = client.gather([client.submit(_as_dask_threads(numba.get_num_threads), pure=False, workers=[w])
                            for w in nthreads])
    assert counts == [nthreads[w] for w in nthreads] == [1, 1]
    assert _as_dask_threads(numba.get_num_threads)() == numba.get_num_threads()  # outside a worker: unchanged
    # a kernel compiled on a worker for the first time (nothing cached: numba re-reads its environment)
    assert client.gather([client.submit(_as_dask_threads(_fresh_parallel_kernel), pure=False, workers=[w])
                          for w in nthreads]) == [45.0, 45.0]


def _fresh_parallel_kernel():
    import numba

    @numba.njit(parallel=True)
    def total(n):
        s = 0.0
        for i in numba.prange(n):
            s += i
        return s

    return total(10)


def test_a_cluster_without_workers_is_a_clear_error(data3, monkeypatch):
    """Preparing on a cluster that lists no worker waits a little for one (the client's list lags a new
    cluster), then names the problem."""
    distributed = pytest.importorskip("distributed")
    from polygen.volume import distributed as pd

    monkeypatch.setattr(pd, "WORKERS_TIMEOUT_S", 0.5)
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as c:
        with pytest.raises(PartitionError, match="no workers"):
            pd.prepare(PartitionedVolume.split(data3, 2), client=c)


def test_direct_stitch_equals_piece_stitch(data3):
    """Each partition writing its rows in place (the local path and the client's on shared memory) gives the
    arrays of the pieces' merge bit for bit, with and without normals; seams, flat fans and empty surfaces met."""
    from polygen.volume.partitioned import direct_stitch

    s = data3.scalars()
    values = list(isovalues(s, 12)) + [np.nextafter(s.min(), np.inf), np.nextafter(np.sort(s)[len(s) // 3], np.inf),
                                       s.max() + 1.0]
    for k in (2, 5):
        prepared = PartitionedVolume.split(data3, k).prepare()
        seam = flat = 0
        for v in values:
            for normals in ("mean", None):
                pieces = [p.extract(v, normals) for p in prepared.partitions]
                want = stitch(v, pieces, n_ids=prepared.n_ids, normals=normals)
                got = direct_stitch(v, prepared.partitions, n_ids=prepared.n_ids, normals=normals)
                for f in ("vertex_keys", "vertices", "triangles", "triangle_cells", "normals"):
                    a, b = getattr(want, f), getattr(got, f)
                    assert (a is None) == (b is None), f
                    if a is not None:
                        assert a.dtype == b.dtype, f
                        np.testing.assert_array_equal(a, b, err_msg=f)
                assert got.seam_vertices == want.seam_vertices
                assert [p["n_triangles"] for p in got.partitions] == [p["n_triangles"] for p in want.partitions]
                seam += got.seam_vertices
                flat += sum(p["flat"] for p in pieces)
        assert seam > 0 and flat > 0


def test_chunks_of_a_query():
    """The values in order, CHUNKS chunks with the last cut in halves down to one value (its stitch is the
    one the workers do not hide); a given size cuts evenly."""
    from polygen.volume.distributed import CHUNKS, _chunked

    for n in (1, 2, 7, 20, 61):
        values = list(range(n))
        chunks = _chunked(values)
        assert [v for c in chunks for v in c] == values and all(chunks)
        assert len(chunks[-1]) == 1
        size = -(-n // CHUNKS)
        assert max(map(len, chunks)) == size == len(chunks[0])
        assert [len(c) for c in _chunked(values, 3)] == [3] * (n // 3) + ([n % 3] if n % 3 else [])
    assert [len(c) for c in _chunked(list(range(20)))] == [4, 4, 4, 4, 2, 1, 1]


def test_unlink_of_a_block_a_killed_worker_left_empty():
    """A worker killed between creating a block and sizing it leaves an empty one (it cannot be mapped):
    the client's clean-up unlinks it by name; a block already gone is no error."""
    _posixshmem = pytest.importorskip("_posixshmem")
    from polygen.volume.distributed import _unlink_quietly

    name = f"polygen-test-{os.getpid()}-empty"
    os.close(_posixshmem.shm_open("/" + name, os.O_CREAT | os.O_EXCL | os.O_RDWR, 0o600))
    assert os.path.exists(os.path.join("/dev/shm", name)) or not os.path.isdir("/dev/shm")
    _unlink_quietly(name)
    with pytest.raises(FileNotFoundError):
        _posixshmem.shm_unlink("/" + name)
    _unlink_quietly(name)


def test_dask_pvtu_pieces_read_on_workers(client, tmp_path, data3):
    PartitionedVolume.split(data3, 2).write_pvtu(tmp_path / "d3.pvtu")
    on_dask = dask_prepare(PartitionedVolume.from_pvtu(tmp_path / "d3.pvtu"), client=client)
    for v, s in zip(isovalues(data3.scalars(), 5), on_dask.extract_many(isovalues(data3.scalars(), 5))):
        assert_same_as_single(data3, data3.isosurface(v), s)
    on_dask.close()


def test_dask_bad_piece_is_named(client, tmp_path):
    _, pieces = _tiny_pvtu(tmp_path)

    def extra(grid):
        grid.point_data["pressure"] = np.zeros(grid.n_points)

    _rewrite(pieces[2], extra)
    with pytest.raises(PartitionError, match=r"t_2\.vtu"):
        dask_prepare(PartitionedVolume.from_pvtu(tmp_path / "t.pvtu"), client=client)


def test_worker_killed_during_query(data3, tmp_path):
    """A worker killed while it extracts its partition's part of a query: the query still returns every
    surface, complete, because the lost partitions are prepared again on the worker left (RETRIES = 1).

    The victim worker's partitions hold every query call they get (``hold_queries_here``: a file made on
    entry, then a wait), and the test kills the worker only once that file exists: the kill lands inside the
    query, never before it and never after the victim's part came back."""
    from polygen.volume import distributed as pd

    def hold_queries_here(flag):
        # runs on the victim (defined here so that it travels by value): every partition call that
        # extracts surfaces marks the file ``flag`` on entry, then waits for the kill
        from polygen.volume import distributed as pd

        cls = pd.SharedMemoryPartition
        for name in ("find_shared", "extract_many"):
            original = getattr(cls, name)

            def held(self, *args, _original=original, _name=name, **kwargs):
                with open(flag, "a") as f:
                    f.write(f"{_name}\n")
                time.sleep(600)  # never returns before the kill; the test fails on its own timeout first
                return _original(self, *args, **kwargs)

            setattr(cls, name, held)
        return os.getpid()

    c = _cluster_client()
    try:
        values = isovalues(data3.scalars(), 60)
        prepared = dask_prepare(PartitionedVolume.split(data3, 4), client=c)
        victim = prepared.placement[0]
        victim_parts = [i for i, w in enumerate(prepared.placement) if w == victim]
        flag = tmp_path / "victim-entered-query"
        pid = c.run(hold_queries_here, str(flag), workers=[victim])[victim]
        result = {}

        def query():
            try:
                result["surfaces"] = prepared.extract_many(values)
            except PartitionError as e:
                result["error"] = e

        t = threading.Thread(target=query)
        t.start()
        deadline = time.monotonic() + 60
        while not flag.exists() and t.is_alive() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert flag.exists(), "the victim never entered the query"
        assert t.is_alive() and not result  # the query waits on the held partition
        os.kill(pid, signal.SIGKILL)
        t.join(120)
        assert not t.is_alive()
        # the pieces came through shared memory: every block the query handed out is gone, the killed
        # worker's included (written or not)
        assert prepared.transport == "shared-memory" and _left_blocks(prepared) == []
        assert "error" not in result, result.get("error")
        # prepared again during this query: the victim's partitions (and only those were lost)
        assert prepared.reprepared == len(victim_parts) and victim not in prepared.placement
        surfaces = result["surfaces"]
        assert len(surfaces) == len(values)
        for v, s in zip(values, surfaces):
            assert_same_as_single(data3, data3.isosurface(v), s)
        # the next query works on what is left
        assert_same_as_single(data3, data3.isosurface(values[7]), prepared.extract(values[7]))
        assert prepared.reprepared == len(victim_parts) and pd.RETRIES >= 1
    finally:
        c.close()
        c.cluster.close()


# ------------------------------------------------------------------ CLI

def test_cli_split_and_pvtu(tmp_path, capsys):
    from polygen.cli import main

    vol = datasets.load("torus")
    rc = main(["isosurface", "torus", "--partitions", "3", "--values", "4", "--json", str(tmp_path / "t.json"),
               "--output", str(tmp_path / "o")])
    assert rc == 0
    import json

    out = json.loads((tmp_path / "t.json").read_text())
    values = isovalues(vol.scalars(), 4)
    assert out["partitions"] == 3
    assert out["triangles"] == [vol.isosurface(v).n_triangles for v in values]
    PartitionedVolume.split(vol, 2).write_pvtu(tmp_path / "t.pvtu")
    (tmp_path / "t_1.vtu").unlink()
    rc = main(["isosurface", str(tmp_path / "t.pvtu"), "--values", "2", "--no-files"])
    assert rc != 0
    assert "t_1.vtu" in capsys.readouterr().err


def test_cli_leaves_a_small_volume_whole_and_says_why(capsys):
    """Without --partitions the count is automatic: a small volume is not split, in one line saying why."""
    from polygen.cli import main

    pytest.importorskip("distributed")
    vol = datasets.load("torus")
    rc = main(["isosurface", "torus", "--workers", "2", "--values", "2", "--no-files"])
    out = capsys.readouterr().out
    assert rc == 0
    assert f"torus: not split: {vol.n_cells:,} cells are fewer than" in out
    assert "torus: 1 partitions" in out
    for v in isovalues(vol.scalars(), 2):
        assert f"{vol.isosurface(v).n_triangles:10d}" in out


def test_cli_on_a_local_cluster(capsys):
    from polygen.cli import main

    pytest.importorskip("distributed")
    vol = datasets.load("torus")
    rc = main(["isosurface", "torus", "--workers", "2", "--partitions", "2", "--values", "3", "--no-files"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "prepared on Dask (2 workers)" in out and "bytes of surfaces came back" in out
    assert "not split" not in out  # --partitions given: no automatic count
    for v in isovalues(vol.scalars(), 3):
        assert f"{vol.isosurface(v).n_triangles:10d}" in out
    rc = main(["isosurface", "torus", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1", "--no-files"])
    assert rc != 0 and "not both" in capsys.readouterr().err

"""Boundary loops generating H1 (tree-cotree), and the extrema graph that uses them in place of boundary lists.

Oracles: the genus of each boundary group from its Euler number (computed
apart, in the volume model), the rank of the loops in H1(boundary; Z2) by
Gaussian elimination over GF(2) against the face boundaries, and the full
scan's isosurface.
"""

import numpy as np
import pytest

from polygen.volume import datasets, methods
from polygen.volume.extrema_graph import ExtremaGraphError, build_extrema_graph
from polygen.volume.homology import boundary_loops

from _surfaces import block_volume, iso_values, sorted_triangles  # noqa: E402

TINY = ["one_tet", "two_hexes", "torus", "torus_hex", "hollow_cube", "hollow_cube_hex", "genus3", "genus3_hex"]


def ring(cell_type, n=4):
    """A square ring of n x n x 1 unit cubes with the middle (n-2)^2 removed: a solid torus."""
    keep = np.ones((n, n, 1), bool)
    keep[1:n - 1, 1:n - 1, 0] = False
    return block_volume(keep, cell_type)


def two_holes_and_a_void(cell_type):
    keep = np.ones((7, 4, 4), bool)
    keep[1, 1:3, :] = False      # a through-hole
    keep[5, :, 1:3] = False      # another, across
    keep[3, 1:3, 1:3] = False    # a void
    return block_volume(keep, cell_type)


def boundary_edges(vol):
    """Set of (a, b), a < b, edges of the boundary faces."""
    f = vol.boundary_face_nodes
    e = np.sort(np.stack([f, np.roll(f, -1, axis=1)], -1).reshape(-1, 2), axis=1)
    return {tuple(r) for r in e.tolist()}


def gf2_rank(m):
    """Rank over GF(2) of a boolean matrix (columns are vectors)."""
    m = m.copy()
    rank = 0
    rows, cols = m.shape
    for c in range(cols):
        piv = np.flatnonzero(m[rank:, c])
        if piv.size == 0:
            continue
        p = rank + piv[0]
        m[[rank, p]] = m[[p, rank]]
        below = np.flatnonzero(m[:, c])
        below = below[below != rank]
        m[below] ^= m[rank]
        rank += 1
        if rank == rows:
            break
    return rank


def h1_rank_of_loops(vol, loops):
    """dim of the span of the loops in H1(boundary; Z2) = rank([d2 | loops]) - rank(d2)."""
    f = vol.boundary_face_nodes.astype(np.int64)  # int32 node ids: a * N in int64
    e = np.sort(np.stack([f, np.roll(f, -1, axis=1)], -1).reshape(-1, 2), axis=1)
    keys, inv = np.unique(e[:, 0] * vol.n_points + e[:, 1], return_inverse=True)
    d2 = np.zeros((keys.size, f.shape[0]), bool)
    d2[inv, np.repeat(np.arange(f.shape[0]), f.shape[1])] = True
    cols = []
    for i in range(loops.n_loops):
        nodes = loops.loop(i)
        pairs = np.sort(np.stack([nodes, np.roll(nodes, -1)], 1), axis=1).astype(np.int64)
        col = np.zeros(keys.size, bool)
        idx = np.searchsorted(keys, pairs[:, 0] * vol.n_points + pairs[:, 1])
        np.logical_xor.at(col, idx, True)
        cols.append(col)
    lm = np.array(cols, bool).T.reshape(keys.size, -1)
    return gf2_rank(np.concatenate([d2, lm], axis=1)) - gf2_rank(d2)


@pytest.mark.parametrize("make", [lambda: datasets.load(n) for n in TINY]
                         + [lambda: ring("tetra"), lambda: ring("hexa"),
                            lambda: two_holes_and_a_void("tetra"), lambda: two_holes_and_a_void("hexa")])
def test_loops_are_a_basis_of_h1(make):
    vol = make()
    loops = boundary_loops(vol)
    genus = int(vol.group_genus.sum())
    assert loops.n_loops == 2 * genus
    edges = boundary_edges(vol)
    for i in range(loops.n_loops):
        nodes = loops.loop(i)
        assert np.unique(nodes).size == nodes.size >= 2    # a simple closed path
        pairs = np.sort(np.stack([nodes, np.roll(nodes, -1)], 1), axis=1)
        assert {tuple(r) for r in pairs.tolist()} <= edges  # along boundary edges
        cells = vol.cells[loops.loop_cells(i)]               # each cell holds its loop edge
        assert ((cells == pairs[:, :1]).any(1) & (cells == pairs[:, 1:]).any(1)).all()
    # independent in H1(boundary; Z2), hence (2g of them) a basis
    if genus:
        assert h1_rank_of_loops(vol, loops) == 2 * genus


def test_loops_on_data():
    for name in ("data1", "hexa1"):
        vol = datasets.load(name)
        loops = boundary_loops(vol)
        assert loops.n_loops == 2 * int(vol.group_genus.sum())
        # a small fraction of the boundary cells stand for the boundary
        assert loops.unique_cells().size * 10 < vol.boundary_cells.size


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_arcs_alone_miss_a_disk_across_the_ring_that_the_loops_find(cell_type):
    # f ~ x on a ring: for a value in the middle the surface is two disks across the ring, each
    # non-separating; the arc between the two extrema goes round one side and crosses one disk
    vol = ring(cell_type, 5)
    p = vol.points
    s = p[:, 0] + 0.013 * p[:, 1] + 0.007 * p[:, 2]
    lists = methods.get("extrema-graph")(vol, s)
    loops = methods.get("extrema-graph-loops")(vol, s)
    missed = 0
    for v in iso_values(s, 60, seed=3):
        ref = lists.extract(v)
        arcs_only = lists.propagator.extract(v, lists.graph.arc_candidates(v)[0])
        missed += arcs_only.n_triangles < ref.n_triangles
        ours = loops.extract(v)
        assert np.array_equal(sorted_triangles(ours), sorted_triangles(ref))
        assert loops.stats["N_ci"] == lists.stats["N_ci"]
        assert loops.stats["seeds"].tested_boundary <= loops.graph.loops.cells.size
    assert missed > 0
    assert loops.graph.stats["loops"] == 2 and loops.graph.blist_min.size == 0


def test_loop_variant_seeds_cover_every_part():
    vol = two_holes_and_a_void("tetra")
    g = build_extrema_graph(vol, "bumps", boundary="loops")
    s = vol.scalars("bumps")
    ref = methods.get("scan")(vol, "bumps")
    separate = methods.get("extrema-graph-loops")(vol, "bumps", order="separate")
    cmin, cmax = s[vol.cells].min(1), s[vol.cells].max(1)
    for v in iso_values(s, 60, seed=1):
        found = g.seeds(v)
        assert ((cmin[found.cells] < v) & (v <= cmax[found.cells])).all()
        assert found.tested_boundary <= g.loops.cells.size
        iso = separate.extract(v)
        assert np.array_equal(sorted_triangles(iso), sorted_triangles(ref.extract(v)))
    with pytest.raises(ExtremaGraphError, match="boundary"):
        build_extrema_graph(vol, "bumps", boundary="faces")


def test_loops_test_far_fewer_cells_than_lists():
    vol = datasets.load("data1")
    s = vol.scalars()
    lists = methods.get("extrema-graph")(vol)
    loops = methods.get("extrema-graph-loops")(vol)
    n = {"lists": 0, "loops": 0, "ci": 0}
    for v in np.linspace(s.min(), s.max(), 22)[1:-1]:
        a, b = lists.extract(v), loops.extract(v)
        assert np.array_equal(sorted_triangles(a), sorted_triangles(b))
        n["lists"] += lists.stats["N_cg"]
        n["loops"] += loops.stats["N_cg"]
        n["ci"] += loops.stats["N_ci"]
    assert n["loops"] * 2 < n["lists"]
    assert n["loops"] * 5 < n["ci"]   # Table 6.5's "far below", which the lists miss on our parts


def tunnelled_block(rng, cell_type):
    """A block with one to three straight one-cell tunnels through it and maybe a one-cell void."""
    dims = rng.integers(4, 8, 3)
    keep = np.ones(dims, bool)
    for _ in range(rng.integers(1, 4)):
        ax = int(rng.integers(3))
        a, b = [k for k in range(3) if k != ax]
        sl = [slice(None)] * 3
        sl[a], sl[b] = int(rng.integers(1, dims[a] - 1)), int(rng.integers(1, dims[b] - 1))
        keep[tuple(sl)] = False
    if rng.random() < 0.5:
        keep[tuple(rng.integers(1, dims - 1))] = False
    return block_volume(keep, cell_type)


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_random_tunnelled_blocks_complete_with_loops(cell_type):
    # many genera, smooth and quantised fields (ties); the loops must stand in for every boundary cell
    rng = np.random.default_rng(11)
    genus = 0
    for _ in range(10):
        vol = tunnelled_block(rng, cell_type)
        p = vol.points
        if rng.random() < 0.3:
            s = rng.integers(0, 4, vol.n_points).astype(float)
        else:
            s = np.sin(p @ rng.normal(size=3)) + 0.5 * np.cos(p @ rng.normal(size=3))
        m = methods.get("extrema-graph-loops")(vol, s)
        if m.graph.stats["loops_fallback"]:  # two tunnels that touch along an edge
            continue
        genus += int(vol.group_genus.sum())
        scan = methods.get("scan")(vol, s)
        for v in iso_values(s, 40, seed=2):
            assert np.array_equal(sorted_triangles(m.extract(v)), sorted_triangles(scan.extract(v))), v
    assert genus >= 10


def test_edge_pinch_falls_back_to_the_lists():
    # two cubes that share only an edge, bridged round by others: a non-manifold boundary edge
    keep = np.zeros((2, 2, 2), bool)
    keep[0, 0, :] = keep[1, 1, 0] = keep[0, 1, 1] = True
    for cell_type in ("tetra", "hexa"):
        vol = block_volume(keep, cell_type)
        assert boundary_loops(vol).nonmanifold_edges > 0
        m = methods.get("extrema-graph-loops")(vol, "bumps")
        assert m.graph.boundary == "lists" and "non-manifold" in m.graph.stats["loops_fallback"]
        scan = methods.get("scan")(vol, "bumps")
        for v in iso_values(vol.scalars("bumps"), 40):
            assert np.array_equal(sorted_triangles(m.extract(v)), sorted_triangles(scan.extract(v)))


def test_node_pinch_falls_back_to_the_lists():
    # two cubes that share one node: the field rises through the node from one cube into the
    # other, so the node is a maximum of the first cube but not an extremum of the volume; no arc
    # and no loop (genus 0) would find the cap around it
    keep = np.zeros((2, 2, 2), bool)
    keep[0, 0, 0] = keep[1, 1, 1] = True
    for cell_type in ("tetra", "hexa"):
        vol = block_volume(keep, cell_type)
        loops = boundary_loops(vol)
        assert loops.nonmanifold_edges == 0 and loops.nonmanifold_nodes == 1 and not loops.manifold
        s = vol.points.sum(axis=1) + 0.01 * vol.points[:, 0]
        m = methods.get("extrema-graph-loops")(vol, s)
        assert m.graph.boundary == "lists" and "1 nodes" in m.graph.stats["loops_fallback"]
        scan = methods.get("scan")(vol, s)
        for v in iso_values(s, 40):
            assert np.array_equal(sorted_triangles(m.extract(v)), sorted_triangles(scan.extract(v)))


def test_manifold_boundaries_have_no_pinched_nodes():
    for name in ("data1", "hexa1", "torus", "genus3_hex", "hollow_cube"):
        loops = boundary_loops(datasets.load(name))
        assert loops.manifold, name

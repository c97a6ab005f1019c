"""Tests of volume thinning (thesis chapter 7): the rules, Thms 7.4-7.6, completeness, the query.

Oracles: Def. 7.5 checked by brute force on the replayed thinning (every
removed cell had no triple-shared edge or quadruple-shared node on the
boundary of the non-removed cells; every cell left fails that test, or is one
of the hexahedral configurations 7.5.2 keeps on purpose); the topology of the
skeleton computed from scratch (connected components, boundary groups and
their genus by Euler numbers); the full scan's isosurface (same triangles).
"""

import dataclasses
import json

import numpy as np
import pytest
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from polygen.cli import main
from polygen.volume import datasets, methods
from polygen.volume.extrema_graph import build_extrema_graph
from polygen.volume.isosurface import extract
from polygen.volume.propagate import Propagator
from polygen.volume import _thinning_kernels as _k
from polygen.volume.thinning import (
    ThinningError,
    ThinningWarning,
    boundary_defects,
    ThinningMethod,
    cell_subset_volume,
    pixel_removable,
    removal_test,
    thin_image,
    thin_volume,
)

from _surfaces import assert_complete as _assert_complete  # noqa: E402
from _surfaces import block_volume as grid_volume  # noqa: E402
from _surfaces import TINY_VOLUMES, iso_values, sorted_triangles  # noqa: E402
from naive import cell_graph_components, intersected_components  # noqa: E402


def assert_complete(vol, field, values, **params):
    """The thinning isosurface equals the full scan's for every value."""
    return _assert_complete("thinning", vol, field, values, **params)

TINY = TINY_VOLUMES


@pytest.fixture(params=[False, True], ids=["serial", "halves"])
def parallel(request):
    """``thin_volume(parallel=...)``: the serial FIFO, or the two halves at once first (then the serial FIFO)."""
    return request.param

# ------------------------------------------------------------------ helpers
def nested_voids(cell_type):
    """A box with a void that holds a floating hollow cube: two parts, two voids."""
    keep = np.ones((7, 7, 7), bool)
    keep[1:6, 1:6, 1:6] = False
    keep[2:5, 2:5, 2:5] = True
    keep[3, 3, 3] = False
    return grid_volume(keep, cell_type)


def two_voids_and_a_hole(cell_type):
    keep = np.ones((8, 5, 4), bool)
    keep[1, 1:4, 1:3] = False  # a slab void
    keep[3, 2, 1] = False  # a one-cell void
    keep[5:7, 2, :] = False  # a through-hole
    return grid_volume(keep, cell_type)


ADVERSARIAL = {
    "nested_voids": nested_voids,
    "two_voids_and_a_hole": two_voids_and_a_hole,
}


def open_boundary(vol, alive):
    """Nodes and edges on the boundary of the cells where ``alive`` (their faces towards no alive cell)."""
    nb = vol.face_neighbors
    open_ = alive[:, None] & ((nb < 0) | ~alive[np.maximum(nb, 0)])
    c, f = np.nonzero(open_)
    fn = vol.cells[c[:, None], vol.local_faces[f]]
    k = fn.shape[1]
    e = np.sort(np.stack([fn, np.roll(fn, -1, axis=1)], -1).reshape(-1, 2), axis=1)
    return set(fn.ravel().tolist()), set(map(tuple, e.tolist()))


def rule_75(vol, alive, c):
    """Def. 7.5 for cell c: (has a triple-shared edge, has a quadruple-shared node, removable)."""
    nb = vol.face_neighbors[c]
    faces = vol.local_faces
    live = [f for f in range(faces.shape[0]) if nb[f] >= 0 and alive[nb[f]]]
    nodes, edges = open_boundary(vol, alive)
    triple = []
    for i in range(len(live)):
        for j in range(i + 1, len(live)):
            shared = np.intersect1d(faces[live[i]], faces[live[j]])
            if shared.size == 2:
                triple.append(tuple(sorted(vol.cells[c, shared].tolist())))
    counts = np.zeros(vol.cells.shape[1], int)
    for f in live:
        counts[faces[f]] += 1
    quad = vol.cells[c, counts >= 3].tolist()
    ok = not any(t in edges for t in triple) and not any(q in nodes for q in quad)
    return len(triple) > 0, len(quad) > 0, ok


def check_rules(vol, sk):
    """Replay the record: every removal obeys Def. 7.5 (or is a prick); nothing removable is left."""
    rec = sk.record
    marked = np.zeros(vol.n_cells, bool)
    marked[sk.marked] = True
    nb = vol.face_neighbors
    prick_steps = set()
    for before, _, k in rec.pricks:
        prick_steps.update(range(before, before + k))
    alive = np.ones(vol.n_cells, bool)
    for step, c in enumerate(rec.removal_order):
        assert alive[c] and not marked[c]
        if step not in prick_steps:
            n_open = np.sum((nb[c] < 0) | ~alive[np.maximum(nb[c], 0)])
            assert n_open >= 1, f"step {step}: cell {c} did not touch the boundary"
            assert rule_75(vol, alive, c)[2], f"step {step}: cell {c} broke Def. 7.5"
        alive[c] = False
    assert np.array_equal(alive, sk.mask())
    # the end: every unmarked cell on the boundary fails Def. 7.5, or is kept on purpose (hexahedra, 7.5.2)
    for c in np.flatnonzero(alive & ~marked):
        live = np.sum((nb[c] >= 0) & alive[np.maximum(nb[c], 0)])
        if live == nb.shape[1]:
            continue
        has_triple, has_quad, ok = rule_75(vol, alive, c)
        if vol.cell_type == "hexa" and ((live == 2 and not has_triple) or (live == 4 and not has_quad)):
            continue
        assert live >= 2 and not ok, f"cell {c} of class {live} could still be removed"


def well_composed(keep):
    """Fill cubes until no edge or corner is shared by diagonal cubes only (a 2-manifold boundary)."""
    k = np.pad(np.asarray(keep, bool), 1)
    corners = np.array(list(np.ndindex(2, 2, 2)))
    changed = True
    while changed:
        changed = False
        for i, j, l in np.ndindex(*(np.array(k.shape) - 1)):
            b = k[i:i + 2, j:j + 2, l:l + 2]
            bad = None
            for ax in range(3):  # four cubes around an edge: a diagonal pair only (either colour)
                for s in range(2):
                    sq = np.take(b, s, axis=ax)
                    if sq[0, 0] == sq[1, 1] != sq[0, 1] == sq[1, 0]:
                        bad = True
            n = b.sum()
            if n in (2, 6):  # two opposite corners (either colour)
                odd = corners[b.ravel() == (n == 2)]
                if (odd[0] + odd[1] == 1).all():
                    bad = True
            if bad:
                empty = np.argwhere(~b)[0]
                k[i + empty[0], j + empty[1], l + empty[2]] = True
                changed = True
    return k[1:-1, 1:-1, 1:-1]


def random_shape(rng, cell_type):
    """A box with random through-holes and voids, made well composed."""
    shape = rng.integers(4, 8, 3)
    keep = np.ones(shape, bool)
    for _ in range(rng.integers(1, 4)):
        lo = rng.integers(1, shape - 1)
        hi = np.minimum(lo + rng.integers(1, 3, 3), shape - 1)
        if rng.random() < 0.5:  # a through-hole along a random axis
            ax = rng.integers(3)
            lo[ax], hi[ax] = 0, shape[ax]
        keep[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] = False
    return grid_volume(well_composed(keep), cell_type)


def boundary_is_manifold(vol):
    """Every boundary edge on two boundary faces and every boundary node's faces in one fan."""
    fn = vol.boundary_face_nodes
    nf, k = fn.shape
    e = np.sort(np.stack([fn, np.roll(fn, -1, axis=1)], -1).reshape(-1, 2), axis=1)
    _, inv, cnt = np.unique(e, axis=0, return_inverse=True, return_counts=True)
    if (cnt != 2).any():
        return False
    # faces around a node joined through the edges at that node: one group per node
    face = np.repeat(np.arange(nf), k)
    inv = inv.ravel()
    pairs = np.full((inv.max() + 1, 2), -1)
    for i, (ed, f) in enumerate(zip(inv, face)):
        pairs[ed, 0 if pairs[ed, 0] < 0 else 1] = f
    edges_u = np.unique(e, axis=0)
    for node in np.unique(fn):
        fs = np.flatnonzero((fn == node).any(axis=1))
        at = np.flatnonzero((edges_u == node).any(axis=1))
        idx = {f: i for i, f in enumerate(fs)}
        a = [idx[pairs[x, 0]] for x in at]
        b = [idx[pairs[x, 1]] for x in at]
        n, _ = connected_components(coo_matrix((np.ones(len(a)), (a, b)), shape=(fs.size, fs.size)), directed=False)
        if n != 1:
            return False
    return True


def topology(vol, alive):
    """(genus sum, voids, boundary groups, components) of the cells where ``alive``."""
    sub = cell_subset_volume(vol, alive)
    return sub.n_through_holes, sub.n_voids, sub.n_boundary_groups, sub.cell_components[1]


def check_theorems(vol, sk, every=1):
    """Thms 7.4-7.6 after every ``every``-th removal, and around every prick."""
    rec = sk.record
    comp_vol, _ = vol.cell_components
    marked = sk.marked
    g0, v0, b0, c0 = topology(vol, np.ones(vol.n_cells, bool))
    assert (g0, v0) == (vol.n_through_holes, vol.n_voids)
    steps = set(range(0, rec.n_removed + 1, every)) | {rec.n_removed}
    for before, _, k in rec.pricks:
        steps |= {before, before + k}
    prick_at = [int(p[0]) + int(p[2]) for p in rec.pricks]
    # the cells of one prick go together: the states between them are not checked
    inside = {int(p[0]) + i for p in rec.pricks for i in range(1, int(p[2]))}
    for k in sorted(steps - inside):
        alive = rec.remaining(k)
        # Thm 7.4: the marked cells of each part of the volume stay joined through face neighbours
        lab = cell_graph_components(vol, alive)
        for part in np.unique(comp_vol[marked]):
            assert np.unique(lab[marked[comp_vol[marked] == part]]).size == 1, f"after {k} removals"
        genus, voids, groups, parts = topology(vol, alive)
        # Thm 7.5: the genus of the boundary is kept; Thm 7.6: voids stay apart until pricked
        assert genus == g0, f"after {k} removals: genus {genus}, volume {g0}"
        pricked = sum(k >= p for p in prick_at)
        assert voids == v0 - pricked, f"after {k} removals: {voids} voids, {pricked} of {v0} pricked"
        assert groups == b0 - pricked and parts == c0


# ------------------------------------------------------------------ the rules and the theorems
@pytest.mark.parametrize("name", TINY)
def test_theorems_on_tiny_volumes(name, parallel):
    vol = datasets.load(name)
    for field in vol.fields:
        sk = thin_volume(vol, field, record=True, parallel=parallel)
        check_rules(vol, sk)
        check_theorems(vol, sk)
        assert sk.unpricked_voids.size == 0


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
@pytest.mark.parametrize("name", list(ADVERSARIAL))
def test_theorems_on_adversarial_volumes(name, cell_type, parallel):
    vol = ADVERSARIAL[name](cell_type)
    assert vol.n_voids >= 2
    sk = thin_volume(vol, "bumps", record=True, parallel=parallel)
    check_rules(vol, sk)
    check_theorems(vol, sk, every=1 if cell_type == "hexa" else 7)
    assert sk.stats["pricks"] == vol.n_voids and sk.unpricked_voids.size == 0
    # without pricking the layers stay and the voids are still there
    sk2 = thin_volume(vol, "bumps", prick_voids=False, parallel=parallel)
    assert topology(vol, sk2.mask())[:2] == (vol.n_through_holes, vol.n_voids)
    assert sk2.n_cells > sk.n_cells


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_theorems_on_random_shapes(cell_type, parallel):
    rng = np.random.default_rng(11 if cell_type == "tetra" else 12)
    n_voids = n_holes = 0
    for _ in range(8):
        vol = random_shape(rng, cell_type)
        assert boundary_is_manifold(vol)
        s = rng.integers(0, 4, vol.n_points).astype(float)  # ties: flat extrema
        sk = thin_volume(vol, s, record=True, parallel=parallel)
        check_rules(vol, sk)
        check_theorems(vol, sk, every=1 if cell_type == "hexa" else 9)
        n_voids += vol.n_voids
        n_holes += vol.n_through_holes
    assert n_voids > 0 and n_holes > 0


def final_skeleton_checks(vol, sk):
    genus, voids, _, parts = topology(vol, sk.mask())
    assert genus == vol.n_through_holes and voids == 0 == sk.unpricked_voids.size
    assert sk.stats["pricks"] == vol.n_voids
    assert parts == vol.cell_components[1]
    lab = cell_graph_components(vol, sk.mask())
    assert np.unique(lab[sk.marked]).size == vol.cell_components[1]
    # every unmarked C1 cell goes (7.5.2): the skeleton's ends are marked cells
    ends = sk.cells[sk.neighbour_counts == 1]
    assert np.isin(ends, sk.marked).all()
    assert sk.stats["C1"] == ends.size <= sk.stats["marked"]
    assert sum(sk.stats[f"C{q}"] for q in range(7)) == sk.n_cells
    assert sk.stats["implicit_removals"] == 0
    # O(n): each cell is taken from each class's FIFO at most once (once in its half and once by the
    # serial FIFO after the halves)
    assert all(n <= vol.n_cells * (2 if sk.stats["parallel"] else 1) for n in sk.stats["processed"].values())


@pytest.mark.parametrize("name", ["data1", "data2", "hexa1"])
def test_skeleton_of_data(name, parallel):
    vol = datasets.load(name)
    for field in vol.fields:
        final_skeleton_checks(vol, thin_volume(vol, field, parallel=parallel))


def test_rules_replayed_on_data1(parallel):
    vol = datasets.load("data1")
    sk = thin_volume(vol, record=True, parallel=parallel)
    # the full replay costs a boundary computation per removal: check the start, the pricks and the end
    rec = sk.record
    marked = np.zeros(vol.n_cells, bool)
    marked[sk.marked] = True
    prick_steps = {int(p[0]) + i for p in rec.pricks for i in range(int(p[2]))}
    for step in sorted({0, 1, 2, 500, 5000, rec.n_removed - 1} | {int(p[0]) + int(p[2]) for p in rec.pricks}):
        if step in prick_steps or step >= rec.n_removed:
            continue
        assert rule_75(vol, rec.remaining(step), rec.removal_order[step])[2]
    check_theorems(vol, sk, every=rec.n_removed // 3)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["data3", "data4", "data5", "hexa2", "hexa3"])
def test_skeleton_of_large_data(name, parallel):
    vol = datasets.load(name)
    for field in vol.fields:
        final_skeleton_checks(vol, thin_volume(vol, field, parallel=parallel))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["data2", "hexa1"])
def test_rules_replayed_on_data(name, parallel):
    vol = datasets.load(name)
    sk = thin_volume(vol, record=True, parallel=parallel)
    check_theorems(vol, sk, every=max(1, sk.record.n_removed // 40))


# ------------------------------------------------------------------ completeness without boundary lists
def test_tiny_volumes_complete(tiny_volume, parallel):
    for field in tiny_volume.fields:
        assert_complete(tiny_volume, field, iso_values(tiny_volume.scalars(field), 200), parallel=parallel)


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_adversarial_volumes_complete(cell_type, parallel):
    for build in ADVERSARIAL.values():
        vol = build(cell_type)
        for field in vol.fields:
            assert_complete(vol, field, iso_values(vol.scalars(field), 200), parallel=parallel)


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_random_volumes_with_ties_complete(cell_type, parallel):
    # random holes and voids, quantised random fields: many ties and flat extrema
    rng = np.random.default_rng(7 if cell_type == "tetra" else 8)
    for _ in range(8):
        vol = random_shape(rng, cell_type)
        s = rng.integers(0, int(rng.integers(2, 6)), vol.n_points).astype(float)
        u = np.unique(s)
        assert_complete(vol, s, np.concatenate([u, (u[:-1] + u[1:]) / 2]), parallel=parallel)


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_non_manifold_volumes_are_flagged(cell_type):
    # cubes that touch at an edge or a corner only are outside the theorems' assumptions (the boundary
    # is no 2-manifold, its genus is not defined): thinning says so, and the surfaces may lose parts --
    # but only whole face-connected parts (propagation completes every part it reaches), never a wrong
    # triangle; the manifold volumes drawn alongside lose nothing
    rng = np.random.default_rng(7 if cell_type == "tetra" else 8)
    n_bad = n_good = n_missed = 0
    for _ in range(12):
        keep = rng.random(tuple(rng.integers(2, 5, 3))) < 0.75
        if not keep.any():
            continue
        vol = grid_volume(keep, cell_type)
        edges, nodes = boundary_defects(vol)
        assert (edges.size + nodes.size == 0) == boundary_is_manifold(vol)
        s = rng.integers(0, int(rng.integers(2, 6)), vol.n_points).astype(float)
        u = np.unique(s)
        if edges.size + nodes.size == 0:
            n_good += 1
            assert_complete(vol, s, (u[:-1] + u[1:]) / 2)
            continue
        n_bad += 1
        with pytest.warns(ThinningWarning, match="not a 2-manifold"):
            m = methods.get("thinning")(vol, s)
        assert m.skeleton.stats["nonmanifold_edges"] == edges.shape[0]
        for v in (u[:-1] + u[1:]) / 2:
            got, full = m.extract(v), extract(vol, v, field=s)
            keys = lambda iso: {tuple(k) for k in np.sort(iso.vertex_keys[iso.triangles], axis=1).tolist()}  # noqa: E731
            assert keys(got) <= keys(full), v
            # every face-connected part of the intersected cells is found whole or not at all
            hit, lab = intersected_components(vol, s, v)
            found = np.zeros(vol.n_cells, bool)
            found[got.triangle_cells] = True
            parts_found = np.unique(lab[found])
            assert np.array_equal(np.isin(lab, parts_found) & hit, found & hit), v
            n_missed += got.n_triangles < full.n_triangles
    # both kinds were drawn, and some surface did lose a part, so the whole-or-nothing check was exercised
    assert n_bad > 0 and n_good > 0 and n_missed > 0


def test_manifold_check_on_data():
    for name in ["data1", "hexa1", "torus", "hollow_cube_hex", "genus3"]:
        edges, nodes = boundary_defects(datasets.load(name))
        assert edges.size == 0 and nodes.size == 0


@pytest.mark.parametrize("name", ["data1", "hexa1"])
def test_complete_on_data(name, parallel):
    vol = datasets.load(name)
    assert_complete(vol, None, iso_values(vol.scalars(), 200), parallel=parallel)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["data1", "data2", "data3", "data4", "data5", "hexa1", "hexa2", "hexa3"])
def test_complete_on_all_data_and_fields(name):
    # both FIFOs (serial, halves first) against one full scan per value
    vol = datasets.load(name)
    for field in vol.fields:
        both = [methods.get("thinning")(vol, field, parallel=p) for p in (False, True)]
        for v in iso_values(vol.scalars(field), 200):
            ref = extract(vol, v, field=field)
            want = sorted_triangles(ref)
            for m in both:
                got = sorted_triangles(m.extract(v))
                assert got.shape == want.shape and np.array_equal(got, want), (field, v, m.skeleton.stats["parallel"])
                assert m.stats["N_ci"] == ref.cells_intersected


@pytest.mark.parametrize("name", ["torus", "genus3_hex"])
def test_fig_7_1_skeleton_finds_what_the_graph_misses(name, parallel):
    # Fig. 7.1: a through-hole cuts an isosurface in parts; the extrema graph's arcs cross only some of
    # them (its boundary lists find the rest); the skeleton's cells alone cross every part
    vol = datasets.load(name)
    s = vol.scalars()
    g = build_extrema_graph(vol, s)
    sk = thin_volume(vol, s, parallel=parallel)
    missed_by_arcs = 0
    for v in iso_values(s, 60, seed=4):
        hit, lab = intersected_components(vol, s, v)
        parts = set(np.unique(lab[hit]).tolist())
        found = sk.seeds(v)
        assert hit[found.cells].all() and np.unique(found.cells).size == found.cells.size
        assert set(lab[found.cells].tolist()) == parts
        arcs = g.seeds(v).cells[:g.seeds(v).n_from_arcs]
        missed_by_arcs += len(parts - set(lab[arcs].tolist()))
    assert missed_by_arcs > 0


# ------------------------------------------------------------------ Tables 7.1, 7.5 on data 1
def test_skeleton_far_smaller_and_fewer_cells_tested():
    vol = datasets.load("data1")
    s = vol.scalars()
    thin = methods.get("thinning")(vol)
    egra = methods.get("extrema-graph")(vol)
    # Table 7.1: N_e2 (skeleton) well below N_e1 (cells on the arcs plus boundary cells)
    n_e1 = egra.graph.stats["graph_cells"] + egra.graph.stats["boundary_cells"]
    assert thin.skeleton.n_cells * 3 < n_e1
    # Table 7.5: fewer cells tested, over 20 isosurfaces
    n_thin = n_egra = 0
    for v in np.linspace(s.min(), s.max(), 22)[1:-1]:
        a = thin.extract(v)
        b = egra.extract(v)
        assert a.triangles.shape == b.triangles.shape
        n_thin += a.cells_tested
        n_egra += b.cells_tested
    assert n_thin < n_egra


# ------------------------------------------------------------------ the plain kernels behind the prefetch hint
_FALLBACK_SCRIPT = """
import sys
import numpy as np
from polygen.volume import _intrinsics, datasets
from polygen.volume.thinning import thin_volume

assert not _intrinsics.PREFETCH, "POLYGEN_PREFETCH=0 did not select the plain kernels"
out = {}
for name in sys.argv[2:]:
    sk = thin_volume(datasets.load(name), record=True, parallel=True)
    rec = sk.record
    for a, x in (("classes", sk.classes), ("cells", sk.cells), ("groups", sk.node_groups),
                 ("order", rec.removal_order), ("dcell", rec.decided_cell), ("dremoved", rec.decided_removed)):
        out[f"{name}-{a}"] = x
np.savez(sys.argv[1], **out)
"""


def test_fallback_kernels_give_the_same_skeleton(tmp_path):
    """``POLYGEN_PREFETCH=0`` (a fresh process: the kernels are chosen at import) runs the halves' FIFO
    without the prefetch hint (``_thinning_kernels.FIFO_LOOKAHEAD``) to the very same skeleton, removals and
    decisions, in the same order, as the intrinsic kernels here."""
    from _surfaces import run_without_prefetch

    from polygen.volume import _intrinsics

    assert _intrinsics.PREFETCH  # here the hint is in: the two runs differ by it
    names = ["data1", "hexa1"]
    theirs = run_without_prefetch(_FALLBACK_SCRIPT, tmp_path / "fallback.npz", *names)
    for name in names:
        sk = thin_volume(datasets.load(name), record=True, parallel=True)
        assert sk.stats["removed_in_halves"] > 0  # the halves' FIFO ran
        rec = sk.record
        for a, x in (("classes", sk.classes), ("cells", sk.cells), ("groups", sk.node_groups),
                     ("order", rec.removal_order), ("dcell", rec.decided_cell), ("dremoved", rec.decided_removed)):
            np.testing.assert_array_equal(x, theirs[f"{name}-{a}"], err_msg=f"{name} {a}")


# ------------------------------------------------------------------ the recorder, the API
def test_record():
    vol = datasets.load("hollow_cube")
    sk = thin_volume(vol, record=True)
    rec = sk.record
    assert rec.n_removed == vol.n_cells - sk.n_cells == np.unique(rec.removal_order).size
    assert rec.remaining(0).all() and np.array_equal(rec.remaining(rec.n_removed), sk.mask())
    assert rec.pricks.shape == (1, 3) and rec.pricks[0, 1] == 2 and rec.pricks[0, 2] in (1, 3)
    steps = rec.steps(5)
    assert steps[0] == 0 and steps[-1] == rec.n_removed
    assert thin_volume(vol).record is None
    with pytest.raises(ThinningError, match="k must be"):
        rec.remaining(rec.n_removed + 1)


def test_registered_method_and_counters():
    assert "thinning" in methods.names()
    assert methods.get("thinning") is ThinningMethod
    vol = datasets.load("hollow_cube")
    m = methods.get("thinning")(vol, "gaussians", n_buckets=3)
    assert m.preprocess_s > 0 and m.skeleton.stats["n_buckets"] == 3
    s = vol.scalars("gaussians")
    iso = m.extract(float(np.median(s)))
    assert m.seed_cells_tested == m.stats["N_cg"] > 0
    assert iso.cells_tested >= m.stats["N_cg"] + iso.cells_intersected
    assert set(m.skeleton.stats) >= {"T_pe", "T_thin", "T_register", "T_total", "extrema", "skeleton_cells",
                                     "C1", "C2", "C3", "C4", "pricks"}
    # out of range: nothing tested, nothing found
    assert m.extract(float(s.max()) + 1).triangles.shape[0] == 0
    assert m.skeleton.seeds(float(s.min()) - 1).n_tested == 0


def test_cli_method(tmp_path, capsys):
    out = tmp_path / "r.json"
    rc = main(["isosurface", "genus3", "--values", "5", "--method", "scan", "--method", "thinning",
               "--json", str(out), "--no-compare-vtk", "--no-files"])
    assert rc == 0
    res = json.loads(out.read_text())
    assert res["methods"]["thinning"]["same_as_first"]
    assert "thinning" in capsys.readouterr().out


def test_subset_volume_and_bad_input():
    vol = datasets.load("two_tets")
    with pytest.raises(ValueError, match="shape"):
        thin_volume(vol, np.zeros(3))
    with pytest.raises(ThinningError, match="n_buckets"):
        thin_volume(vol, n_buckets=0)
    with pytest.raises(ThinningError, match="parallel"):
        thin_volume(vol, parallel="yes")
    assert not thin_volume(vol).stats["parallel"]  # small: the serial FIFO by default
    with pytest.raises(ValueError, match="value"):
        thin_volume(vol).seeds(np.nan)
    with pytest.raises(ThinningError, match="mask"):
        cell_subset_volume(vol, np.ones(3, bool))
    with pytest.raises(ThinningError, match="at least one"):
        cell_subset_volume(vol, np.zeros(2, bool))
    sub = cell_subset_volume(vol, [1])
    assert sub.n_cells == 1 and sub.n_points == 4 and set(sub.fields) == set(vol.fields)
    with pytest.raises(ThinningError, match="2-D"):
        thin_image(np.ones(4, bool))
    with pytest.raises(ThinningError, match="boolean"):
        thin_image(np.full((3, 3), 2))


# ------------------------------------------------------------------ 2D image thinning (7.3, Fig. 7.2)
def image_topology(img):
    fg = ndimage.label(img, structure=[[0, 1, 0], [1, 1, 1], [0, 1, 0]])[1]  # black: 4-connected
    bg = ndimage.label(np.pad(~img, 1, constant_values=True), structure=np.ones((3, 3)))[1]  # white: 8
    return fg, bg


def test_image_thinning_rule_of_fig_7_2():
    # Fig. 7.2 (b)(c): the edge neighbours can be visited in one sweep -> p goes; (d)(e): they cannot;
    # the end of a line stays
    cases = {
        "b": ([[0, 0, 0], [1, 1, 0], [1, 1, 0]], True),
        "c": ([[1, 1, 0], [1, 1, 0], [1, 1, 0]], True),
        "d": ([[0, 1, 0], [0, 1, 0], [0, 1, 0]], False),
        "e": ([[0, 1, 0], [1, 1, 0], [0, 0, 1]], False),
        "end": ([[0, 0, 0], [0, 1, 1], [0, 0, 0]], False),
        "corner only": ([[0, 0, 1], [0, 1, 0], [0, 0, 0]], False),
        "interior": ([[1, 1, 1], [1, 1, 1], [1, 1, 1]], False),
    }
    for name, (patch, removable) in cases.items():
        assert pixel_removable(patch) == removable, name
        # the same on every rotation and mirror image
        for k in range(4):
            assert pixel_removable(np.rot90(np.array(patch), k)) == removable, name
            assert pixel_removable(np.rot90(np.array(patch), k).T) == removable, name
    with pytest.raises(ThinningError, match="3x3"):
        pixel_removable(np.ones((3, 4)))
    with pytest.raises(ThinningError, match="centre"):
        pixel_removable(np.zeros((3, 3)))


def test_image_thinning_keeps_topology_and_is_thin():
    rng = np.random.default_rng(3)
    yy, xx = np.mgrid[:80, :120]
    img = ((xx - 60) ** 2 / 50 ** 2 + (yy - 40) ** 2 / 30 ** 2) < 1
    for cx, cy, r in [(35, 40, 8), (80, 35, 10)]:
        img &= (xx - cx) ** 2 + (yy - cy) ** 2 > r ** 2  # two holes
    img |= (np.abs(xx - 10) < 4) & (yy > 5) & (yy < 75)  # a separate bar
    img &= rng.random(img.shape) > 0.003  # pepper: tiny holes, each kept as a loop
    skel = thin_image(img)
    assert image_topology(skel) == image_topology(img)
    assert (skel <= img).all() and skel.sum() < img.sum() / 4
    assert np.array_equal(thin_image(skel), skel)  # nothing more can go


# ------------------------------------------------------------------ the record of the removal tests (Figs 7.4, 7.6)
@pytest.mark.parametrize("name", ["torus", "hollow_cube", "genus3", "data1"])
def test_recorded_decisions_are_the_tetrahedral_rules(name):
    """Every FIFO decision, replayed from scratch on the state it saw, is 7.5.2's rule for tetrahedra."""
    vol = datasets.load(name)
    assert vol.cell_type == "tetra"
    off, nc = vol.node_cells
    bf = vol.boundary_face_nodes
    boundary_edges = {tuple(sorted(e)) for f in bf.tolist() for e in zip(f, f[1:] + f[:1])}
    for field in (vol.fields if name != "data1" else [None]):
        sk = thin_volume(vol, field, record=True)
        rec = sk.record
        assert np.array_equal(thin_volume(vol, field).classes, sk.classes)    # recording changes nothing
        gone = np.zeros(vol.n_cells, bool)
        on_b = np.zeros(vol.n_points, bool)
        on_b[bf.ravel()] = True
        done = 0
        for k, (c, q, removed) in enumerate(zip(rec.decided_cell, rec.decided_class, rec.decided_removed)):
            for x in rec.removal_order[done:rec.decided_after[k]]:
                gone[x] = True
                on_b[vol.cells[x]] = True
            done = rec.decided_after[k]
            nb = [f for f in range(4) if vol.face_neighbors[c, f] >= 0 and not gone[vol.face_neighbors[c, f]]]
            assert len(nb) == q and not gone[c]
            faces = [set(vol.cells[c, vol.local_faces[f]].tolist()) for f in nb]
            if q == 1:
                rule = True
            elif q == 2:
                a, b = sorted(faces[0] & faces[1])
                ring = np.intersect1d(nc[off[a]:off[a + 1]], nc[off[b]:off[b + 1]])
                rule = (a, b) not in boundary_edges and not gone[ring].any()
            else:
                (x,) = faces[0] & faces[1] & faces[2]
                rule = not on_b[x]
            assert rule == removed, (name, field, k)
        assert rec.decided_removed.sum() + sk.stats["prick_cells"] == rec.n_removed


def test_removal_test_rebuilds_what_the_rules_saw():
    vol = datasets.load("genus3")
    rec = thin_volume(vol, record=True).record
    for k in range(len(rec.decided_cell)):
        t = removal_test(vol, rec, k)
        assert t.neighbours.size == t.cls and t.remaining[t.neighbours].all() and t.remaining[t.cell]
        assert t.shared_edges.shape[0] == {1: 0, 2: 1, 3: 3}[t.cls] and t.quad_nodes.size == (t.cls == 3)
        if t.cls == 3:
            assert t.removed == (not t.on_boundary[t.quad_nodes[0]])
        if t.cls == 2:
            assert t.edge_ring(vol, t.shared_edges[0]).size >= 3 or not t.removed
    with pytest.raises(ThinningError, match="k must be"):
        removal_test(vol, rec, len(rec.decided_cell))
    with pytest.raises(ThinningError, match="no decisions"):
        removal_test(vol, dataclasses.replace(rec, decided_cell=None), 0)


def _same_skeleton(beside, alone):
    """Two thinnings of one volume agree class for class, group for group, removal for removal."""
    np.testing.assert_array_equal(beside.classes, alone.classes)
    np.testing.assert_array_equal(beside.marked, alone.marked)
    np.testing.assert_array_equal(beside.extrema.nodes, alone.extrema.nodes)
    np.testing.assert_array_equal(beside.node_groups, alone.node_groups)
    np.testing.assert_array_equal(beside.group_root, alone.group_root)
    np.testing.assert_array_equal(beside.unpricked_voids, alone.unpricked_voids)
    for k in ("nonmanifold_edges", "pricks", "prick_cells", "walks", "walks_reached", "stale_fifo_entries",
              "processed", "removed_by_class"):
        assert beside.stats[k] == alone.stats[k], k
    if alone.record is not None:
        for k in ("removal_order", "pricks", "decided_cell", "decided_class", "decided_removed", "decided_after"):
            np.testing.assert_array_equal(getattr(beside.record, k), getattr(alone.record, k))


@pytest.mark.parametrize("name", ["data2", "genus3"])
def test_extrema_beside_the_topology_give_the_same_skeleton(name, monkeypatch):
    """The components, the boundary groups and the boundary check run in a second thread on large volumes
    (thinning._thin) while the FIFO runs with the extremum cells as marks and placeholder groups: forced on
    a small one, the skeleton is the one thinning without the thread gives, class for class, group for group."""
    from polygen.volume import UnstructuredVolume
    from polygen.volume import thinning as th

    base = datasets.load(name)
    fresh = lambda: UnstructuredVolume(base.points, base.cells, dict(base.fields), validate=False)  # noqa: E731
    monkeypatch.setattr(th, "_ASIDE_MIN_CELLS", 10**12)
    alone = th.thin_volume(fresh())
    monkeypatch.setattr(th, "_ASIDE_MIN_CELLS", 0)
    calls = []
    real = th._beside_fifo
    monkeypatch.setattr(th, "_beside_fifo",
                        lambda *a: (calls.append(th.threading.current_thread().name), real(*a))[1])
    resolved = []
    real_resolve = th._k.resolve_labels
    monkeypatch.setattr(th._k, "resolve_labels", lambda *a: (resolved.append(a[3]), real_resolve(*a))[1])
    beside = th.thin_volume(fresh())
    if th.parallel_kernels_may_overlap() and (th.os.cpu_count() or 1) >= 2:
        assert calls == ["polygen-thinning-beside"]
        assert len(resolved) == 1  # the deferred path
        # inner nodes came onto the boundary before the groups were put in (genus3 has no inner node)
        assert (resolved[0] > 0) == (name == "data2")
    _same_skeleton(beside, alone)


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
@pytest.mark.parametrize("name", list(ADVERSARIAL))
def test_deferred_groups_give_the_same_pricks(name, cell_type, monkeypatch):
    """Volumes with voids: the FIFO run with placeholder groups, the groups put in afterwards
    (_k.resolve_labels), then pricking -- the same removals, pricks and node groups as one run."""
    from polygen.volume import thinning as th

    if not (th.parallel_kernels_may_overlap() and (th.os.cpu_count() or 1) >= 2):
        pytest.skip("the helper thread needs a thread-safe numba threading layer and two cores")
    vol = ADVERSARIAL[name](cell_type)
    assert vol.n_voids >= 2
    monkeypatch.setattr(th, "_ASIDE_MIN_CELLS", 10**12)
    alone = th.thin_volume(vol, "bumps", record=True)
    monkeypatch.setattr(th, "_ASIDE_MIN_CELLS", 0)
    resolved = []
    real = th._k.resolve_labels
    monkeypatch.setattr(th._k, "resolve_labels", lambda *a: (resolved.append(a[3]), real(*a))[1])
    beside = th.thin_volume(vol, "bumps", record=True)
    assert len(resolved) == 1  # the deferred path
    assert beside.stats["pricks"] == vol.n_voids
    _same_skeleton(beside, alone)


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_deferred_groups_on_random_shapes(cell_type, monkeypatch):
    """Random shapes with voids, holes and inner nodes: the deferred groups (resolved after nodes came
    onto the boundary) give the skeleton, node groups and pricks of one run with the groups known."""
    from polygen.volume import thinning as th

    if not (th.parallel_kernels_may_overlap() and (th.os.cpu_count() or 1) >= 2):
        pytest.skip("the helper thread needs a thread-safe numba threading layer and two cores")
    rng = np.random.default_rng(11 if cell_type == "tetra" else 12)
    resolved = []
    real = th._k.resolve_labels
    monkeypatch.setattr(th._k, "resolve_labels", lambda *a: (resolved.append(a[3]), real(*a))[1])
    voids_with_labels = 0
    for _ in range(8):
        vol = random_shape(rng, cell_type)
        s = rng.integers(0, 4, vol.n_points).astype(float)
        monkeypatch.setattr(th, "_ASIDE_MIN_CELLS", 10**12)
        alone = th.thin_volume(vol, s, record=True)
        monkeypatch.setattr(th, "_ASIDE_MIN_CELLS", 0)
        n = len(resolved)
        beside = th.thin_volume(vol, s, record=True)
        assert len(resolved) == n + 1
        _same_skeleton(beside, alone)
        voids_with_labels += vol.n_voids > 0 and resolved[-1] > 0
    assert voids_with_labels > 0  # pricking read groups that were put in afterwards


def test_part_without_extremum_beside_the_fifo(monkeypatch):
    """Beside the FIFO the marks are the extremum cells; a face-connected part with no extremum (here:
    the extrema of one of two disjoint blocks hidden) is found once the components are there and the
    thinning runs again with its mark -- the skeleton of thinning without the thread, which keeps the part."""
    from polygen.volume import UnstructuredVolume
    from polygen.volume import thinning as th

    if not (th.parallel_kernels_may_overlap() and (th.os.cpu_count() or 1) >= 2):
        pytest.skip("the helper thread needs a thread-safe numba threading layer and two cores")
    keep = np.zeros((9, 4, 4), bool)
    keep[:4] = keep[5:] = True
    vol = grid_volume(keep)  # two disjoint blocks of tetrahedra
    labels, n = vol.cell_components
    assert n == 2
    off, nc = vol.node_cells
    real = th.find_extrema

    def first_block_only(v, field=None):
        ext = real(v, field)
        keep = labels[nc[off[ext.nodes]]] == 0
        return dataclasses.replace(ext, nodes=ext.nodes[keep], is_max=ext.is_max[keep], is_min=ext.is_min[keep])

    monkeypatch.setattr(th, "find_extrema", first_block_only)
    monkeypatch.setattr(th, "_ASIDE_MIN_CELLS", 10**12)
    alone = th.thin_volume(vol, "bumps", record=True)
    assert (labels[alone.marked] == 1).sum() == 1  # the second block's one mark
    monkeypatch.setattr(th, "_ASIDE_MIN_CELLS", 0)
    starts = []
    real_start = th._k.fifo_init
    monkeypatch.setattr(th._k, "fifo_init", lambda *a: (starts.append(1), real_start(*a))[1])
    beside = th.thin_volume(vol, "bumps", record=True)
    assert len(starts) == 2  # thinned again with the missing mark
    _same_skeleton(beside, alone)
    assert (beside.classes[labels == 1] != 0).any()


# ------------------------------------------------------------------ the FIFO in two halves at once
def brute_halves(vol, split):
    """Per cell: 0/1 when every cell touching one of its nodes is in its half ``[0, split)``/``[split, M)``,
    else -1 (brute force over the node -> cells incidence)."""
    halves_at = [set() for _ in range(vol.n_points)]
    for c, nodes in enumerate(vol.cells.tolist()):
        for x in nodes:
            halves_at[x].add(int(c >= split))
    out = np.empty(vol.n_cells, np.int8)
    for c, nodes in enumerate(vol.cells.tolist()):
        h = int(c >= split)
        out[c] = h if all(halves_at[x] == {h} for x in nodes) else -1
    return out


def test_cell_halves_by_brute_force():
    rng = np.random.default_rng(5)
    for vol in (datasets.load("hollow_cube"), random_shape(rng, "tetra"), random_shape(rng, "hexa")):
        shuffled = vol.cells[rng.permutation(vol.n_cells)]  # cell order unrelated to space: a thick band
        for cells in (vol.cells, shuffled):
            v = type(vol)(vol.points, cells, validate=False)
            off, nc = v.node_cells
            for split in (0, 1, v.n_cells // 3, v.n_cells // 2, v.n_cells - 1, v.n_cells):
                got = _k.cell_halves(np.ascontiguousarray(v.cells, np.int64), off, nc, split)
                assert np.array_equal(got, brute_halves(v, split)), split
    # spatially ordered cells: both halves have interior cells and the band is a minority
    vol = grid_volume(np.ones((10, 4, 4), bool), "tetra")
    h = brute_halves(vol, vol.n_cells // 2)
    assert (h == 0).any() and (h == 1).any() and (h < 0).sum() < vol.n_cells // 4


@pytest.mark.parametrize("name", ["data1", "data2", pytest.param("data3", marks=pytest.mark.slow),
                                  pytest.param("data4", marks=pytest.mark.slow)])
def test_halves_skeleton_seeds_every_surface_part(name):
    # the skeleton of the two-halves FIFO crosses every face-connected part of every isosurface (against the
    # full scan's intersected cells), and the halves did the bulk of the removals (the test is not the serial one)
    vol = datasets.load(name)
    n_values = 100 if vol.n_cells < 100_000 else 30
    for field in vol.fields:
        s = vol.scalars(field)
        sk = thin_volume(vol, field, parallel=True)
        assert sk.stats["parallel"] and sk.stats["removed_in_halves"] > sk.stats["removed"] // 2
        assert 0 < sk.stats["band_cells"] < vol.n_cells // 4
        for v in iso_values(s, n_values, seed=9):
            hit, lab = intersected_components(vol, s, v)
            found = sk.seeds(v).cells
            assert hit[found].all()
            assert set(lab[found].tolist()) == set(np.unique(lab[hit]).tolist()), (field, v)


def test_halves_deterministic():
    # the split depends only on the cells: the same removals run after run and for one or two numba threads
    numba = pytest.importorskip("numba")
    vol = datasets.load("data2")
    runs = [thin_volume(vol, record=True, parallel=True) for _ in range(2)]
    n = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        runs.append(thin_volume(vol, record=True, parallel=True))
    finally:
        numba.set_num_threads(n)
    for sk in runs[1:]:
        assert np.array_equal(sk.cells, runs[0].cells)
        assert np.array_equal(sk.record.removal_order, runs[0].record.removal_order)
        assert np.array_equal(sk.record.decided_cell, runs[0].record.decided_cell)
    # and it differs from the serial FIFO's order (the halves ran first), with the same guarantees
    serial = thin_volume(vol, record=True, parallel=False)
    assert not np.array_equal(serial.record.removal_order, runs[0].record.removal_order)


@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_halves_voids_inside_a_half_are_pricked(cell_type):
    # one void deep in each half: its layer is thinned by that half's thread, then pricked by the serial FIFO
    keep = np.ones((14, 6, 6), bool)
    keep[2:4, 2:4, 2:4] = False
    keep[10:12, 2:4, 2:4] = False
    vol = grid_volume(keep, cell_type)
    assert vol.n_voids == 2 and vol.n_through_holes == 0
    off, nc = vol.node_cells
    half = _k.cell_halves(np.ascontiguousarray(vol.cells, np.int64), off, nc, vol.n_cells // 2)
    void_nodes = vol.boundary_face_nodes[vol.boundary_groups >= 2].ravel()
    around = np.unique(np.concatenate([nc[off[x]:off[x + 1]] for x in void_nodes]))
    assert (half[around] >= 0).all() and set(half[around].tolist()) == {0, 1}
    sk = thin_volume(vol, "bumps", record=True, parallel=True)
    check_rules(vol, sk)
    final_skeleton_checks(vol, sk)
    assert sk.stats["pricks"] == 2 and sk.stats["removed_in_halves"] > 0


def test_one_part_known_from_the_boundary():
    # _one_part (no labelling of the cells) never says "one part" of a volume of several; on the manifold
    # volumes of one part with no void-holding parts it says so
    from polygen.volume.thinning import _one_part

    rng = np.random.default_rng(3)
    vols = [datasets.load(n) for n in TINY] + [b(t) for b in ADVERSARIAL.values() for t in ("tetra", "hexa")]
    vols += [random_shape(rng, t) for t in ("tetra", "hexa") for _ in range(4)]
    vols += [grid_volume(rng.random(tuple(rng.integers(2, 5, 3))) < 0.6, t)
             for t in ("tetra", "hexa") for _ in range(8)]
    said = several = 0
    for vol in vols:
        n_parts = vol.cell_components[1]
        one = _one_part(vol, boundary_defects(vol))
        assert not (one and n_parts > 1)
        said += one
        several += n_parts > 1
    assert said > 0 and several > 0


def test_halves_on_unordered_cells():
    # cells in random order: most cells touch both halves (a thick band), the serial FIFO does most of the work,
    # and the guarantees are the same
    vol = datasets.load("data1")
    rng = np.random.default_rng(2)
    mixed = type(vol)(vol.points, vol.cells[rng.permutation(vol.n_cells)], dict(vol.fields), validate=False)
    sk = thin_volume(mixed, parallel=True)
    assert sk.stats["band_cells"] > mixed.n_cells // 2
    final_skeleton_checks(mixed, sk)
    s = mixed.scalars()
    for v in iso_values(s, 40, seed=3):
        hit, lab = intersected_components(mixed, s, v)
        assert set(lab[sk.seeds(v).cells].tolist()) == set(np.unique(lab[hit]).tolist()), v

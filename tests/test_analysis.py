"""``polygen.volume.analysis`` against brute force and closed forms on the tiny volumes."""

import dataclasses

import numpy as np
import pytest

from polygen.volume import VolumeError, datasets
from polygen.volume.analysis import (
    end_cells,
    first_removal_test,
    replay_tetra_decisions,
    side_regions,
    unseeded_parts,
)
from polygen.volume.extrema_graph import build_extrema_graph
from polygen.volume.isosurface import extract
from polygen.volume.thinning import ThinningError, removal_test, thin_volume

TINY = ["torus", "hollow_cube", "genus3", "torus_hex"]


def _regions_brute(vol, s, value):
    """Union-find over the edges whose two nodes lie on one side; regions = roots among the nodes."""
    parent = list(range(vol.n_points))

    def root(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    below = s < value
    for a, b in vol.edges.tolist():
        if below[a] == below[b]:
            parent[root(a)] = root(b)
    return len({root(a) for a in range(vol.n_points)})


@pytest.mark.parametrize("name", TINY)
def test_side_regions_against_union_find(name):
    vol = datasets.load(name)
    for field in vol.fields:
        s = vol.scalars(field)
        for v in np.linspace(s.min(), s.max(), 9):
            assert side_regions(vol, s, v) == _regions_brute(vol, s, v), (field, v)


def test_side_regions_of_a_plane_through_a_ring_and_a_hollow_cube():
    # the plane x = 1.5 cuts the ring (3 x 3 with the middle cell out) in two parts but leaves two
    # regions (a part that does not separate, Fig. 7.11 (b)); it cuts the hollow cube (3 x 3 x 3,
    # the middle a void) in one part, and the regions are one more than the parts (Thm 7.2)
    for name, parts in [("torus", 2), ("hollow_cube", 1)]:
        vol = datasets.load(name)
        x = np.ascontiguousarray(vol.points[:, 0])
        vol.add_field("x", x)
        assert extract(vol, 1.5, field="x").connected_components()[1] == parts
        assert side_regions(vol, x, 1.5) == 2
        assert side_regions(vol, x, -1.0) == 1          # one side empty
    with pytest.raises(VolumeError, match="scalars"):
        side_regions(vol, x[:-1], 1.5)


def test_unseeded_parts_of_a_ring_cut_in_two():
    vol = datasets.load("torus")
    vol.add_field("x", np.ascontiguousarray(vol.points[:, 0]))
    iso = extract(vol, 1.5, field="x")
    comp = iso.triangle_components()
    assert sorted(set(comp.tolist())) == [0, 1]
    assert unseeded_parts(iso, iso.triangle_cells[comp == 0][:1]).tolist() == [1]   # a part missed
    assert unseeded_parts(iso, iso.triangle_cells).tolist() == []                  # none missed
    assert unseeded_parts(iso, []).tolist() == [0, 1]
    # a seed cell that no triangle lies in reaches nothing
    assert unseeded_parts(iso, np.setdiff1d(np.arange(vol.n_cells), iso.triangle_cells)).tolist() == [0, 1]


@pytest.mark.parametrize("name", ["torus", "hollow_cube", "genus3"])
def test_unseeded_parts_against_the_parts_found_by_propagation(name):
    # brute force: a part is reached when one of its triangles' cells is a seed; and Thm 7.3: with
    # no through-hole the arcs miss no part, with one they miss some at some value (Fig. 7.11)
    vol = datasets.load(name)
    s = vol.scalars()
    graph = build_extrema_graph(vol, s)
    missed_any = False
    for v in np.linspace(s.min(), s.max(), 22)[1:-1]:
        iso = extract(vol, v)
        seeds = graph.seeds(v)
        arcs = seeds.cells[:seeds.n_from_arcs]
        comp = iso.triangle_components()
        brute = [p for p in np.unique(comp) if not any(c in set(arcs.tolist()) for c in iso.triangle_cells[comp == p])]
        got = unseeded_parts(iso, arcs)
        assert got.tolist() == brute, v
        assert unseeded_parts(iso, seeds.cells).size == 0      # arcs plus boundary lists reach all
        missed_any |= got.size > 0
    assert missed_any == (vol.n_through_holes > 0)


@pytest.mark.parametrize("name", ["torus", "genus3", "hollow_cube_hex"])
def test_end_cells_against_counting_neighbours(name):
    vol = datasets.load(name)
    sk = thin_volume(vol)
    inside = set(sk.cells.tolist())
    brute = [c for c in sk.cells.tolist() if sum(int(n) in inside for n in vol.face_neighbors[c] if n >= 0) == 1]
    assert end_cells(vol, sk.cells).tolist() == brute
    assert end_cells(vol, sk.mask()).tolist() == brute
    assert set(brute) <= set(sk.marked.tolist())          # Table 7.2: the ends are marked cells


def test_end_cells_of_two_and_one_cells():
    vol = datasets.load("two_tets")
    assert end_cells(vol, [0, 1]).tolist() == [0, 1]
    assert end_cells(vol, [0]).tolist() == []
    with pytest.raises(VolumeError, match="cell ids"):
        end_cells(vol, [2])
    with pytest.raises(VolumeError, match="mask"):
        end_cells(vol, np.ones(3, bool))


@pytest.mark.parametrize("name, field", [("hollow_cube_hex", "gaussians"), ("genus3", "linear")])
def test_first_removal_test_is_the_first_match_of_the_record(name, field):
    vol = datasets.load(name)
    rec = thin_volume(vol, field, record=True).record
    every = [removal_test(vol, rec, k) for k in range(len(rec.decided_cell))]
    found = 0
    for q in range(1, 6):
        for removed in (True, False):
            for n_quad in (None, 0, 1, 2):
                match = [t for t in every if t.cls == q and t.removed == removed
                         and (n_quad is None or t.quad_nodes.size == n_quad)]
                if match:
                    got = first_removal_test(vol, rec, q, removed, n_quad=n_quad)
                    assert (got.cell, got.cls, got.removed) == (match[0].cell, q, removed)
                    assert np.array_equal(got.remaining, match[0].remaining)
                    found += 1
                else:
                    with pytest.raises(ThinningError, match=f"no recorded C{q}"):
                        first_removal_test(vol, rec, q, removed, n_quad=n_quad)
    assert found >= 8          # the kinds above: several classes, both outcomes, 0-2 quadruple-shared nodes
    with pytest.raises(ThinningError, match="record=True"):
        first_removal_test(vol, dataclasses.replace(rec, decided_cell=None), 2, True)


@pytest.mark.parametrize("name", ["genus3", "hollow_cube", "torus"])
def test_replay_agrees_with_the_kernel_and_catches_a_changed_decision(name):
    vol = datasets.load(name)
    for field in vol.fields:
        rec = thin_volume(vol, field, record=True).record
        agree = replay_tetra_decisions(vol, rec)
        assert agree.shape == rec.decided_cell.shape and agree.all(), field
    # the state a test saw comes from the removal order, not from the decisions: flipping one
    # decision, or its class, is caught at that decision and nowhere else
    for k in (0, len(rec.decided_cell) // 2, len(rec.decided_cell) - 1):
        flipped = rec.decided_removed.copy()
        flipped[k] = ~flipped[k]
        assert np.flatnonzero(~replay_tetra_decisions(vol, dataclasses.replace(rec, decided_removed=flipped))).tolist() == [k]
        cls = rec.decided_class.copy()
        cls[k] = 3 if cls[k] != 3 else 2
        assert np.flatnonzero(~replay_tetra_decisions(vol, dataclasses.replace(rec, decided_class=cls))).tolist() == [k]


def test_replay_names_what_it_cannot_replay():
    hexes = datasets.load("genus3_hex")
    with pytest.raises(VolumeError, match="tetrahedral"):
        replay_tetra_decisions(hexes, thin_volume(hexes, record=True).record)
    vol = datasets.load("genus3")
    rec = thin_volume(vol, record=True).record
    with pytest.raises(ThinningError, match="record=True"):
        replay_tetra_decisions(vol, dataclasses.replace(rec, decided_cell=None))

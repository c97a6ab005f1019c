"""Every method on every partition count gives the single volume's surface (a partition's seam is not a 2-manifold).

A Morton range of cells often touches its neighbour along an edge or a node
only. The edge-centred construction walks round an edge from face
neighbour to face neighbour; at such an edge it saw one side, the other side
made the vertex again, and the stitch then read a row it had not laid out
yet (an ``IndexError`` or 1-7 wrong triangles in about a third of the runs).
Oracle: the single volume's full scan, compared vertex for vertex (global
pair keys, positions bit for bit) and triangle for triangle
(:func:`test_partitioned.assert_same_as_single`).
"""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from _surfaces import block_volume, grid_volume
from polygen.volume import UnstructuredVolume, datasets
from polygen.volume.homology import boundary_defects
from polygen.volume.partitioned import PartitionedVolume
from polygen.volume.thinning import ThinningWarning
from polygen.volume.registry import method_names
from test_partitioned import assert_same_as_single

N_VALUES = 20
PARTITIONS = range(1, 9)


def _issue_volume():
    """The volume of the report: a 20^3 grid in tetrahedra, a field with a ridge along x."""
    import pyvista as pv

    g = pv.ImageData(dimensions=(20,) * 3).triangulate()
    p = np.asarray(g.points, float)
    f = np.sin(p[:, 0] / 3) + p[:, 2] / 10 + 0.05 * p[:, 1]
    return UnstructuredVolume(p, np.asarray(g.cell_connectivity).reshape(-1, 4), {"f": f})


def test_reported_edge_centred_partitions():
    """The report's reproducer, on fresh partitions each time (the failure came with a fresh preparation)."""
    vol = _issue_volume()
    single = vol.isosurface(0.7626, method="scan")
    for _ in range(5):
        stitched = PartitionedVolume.split(vol, 2).prepare(method="edge-centred").extract(0.7626)
        assert_same_as_single(vol, single, stitched)


def test_reported_cli_edge_centred_partitions(tmp_path):
    """The report's command: ``polygen isosurface grid.vtu --partitions 5 --method edge-centred``."""
    import json

    from polygen.cli import main

    vol = _issue_volume()
    path = tmp_path / "grid.vtu"
    vol.to_pyvista().save(path)
    rc = main(["isosurface", str(path), "--partitions", "5", "--method", "edge-centred", "--values", "20",
               "--json", str(tmp_path / "out.json"), "--no-files"])
    assert rc == 0
    out = json.loads((tmp_path / "out.json").read_text())
    assert out["triangles"] == [vol.isosurface(v, method="scan").n_triangles for v in out["values"]]


def test_walk_merges_the_vertex_of_a_non_manifold_edge():
    """Two blocks touching along one edge only: the walk sees one side, the merge gives one vertex."""
    keep = np.zeros((2, 2, 1), bool)
    keep[0, 0, 0] = keep[1, 1, 0] = True  # two cubes sharing the edge x = y = 1
    vol = block_volume(keep, "tetra")
    vol.fields["f"] = vol.points[:, 2] + 0.01 * vol.points[:, 0]
    from polygen.volume.edge_centred import EdgeCentredWalk

    walk = EdgeCentredWalk(vol, "f")
    iso = walk.extract(0.5, np.arange(vol.n_cells))
    scan = vol.isosurface(0.5, field="f", method="scan")
    assert walk.stats["merged_non_manifold"] >= 1  # the shared edge's vertex was made once per side
    assert iso.n_vertices == scan.n_vertices
    assert np.unique(iso.vertex_keys).size == iso.n_vertices
    np.testing.assert_array_equal(np.sort(iso.vertex_keys), np.sort(scan.vertex_keys))


def _volumes():
    hexa = grid_volume((9, 8, 7), tets=False, jitter=0.2, seed=3)
    p = hexa.points
    hexa.fields["f"] = np.sin(p[:, 0] / 2) + 0.3 * p[:, 1] - 0.2 * p[:, 2]
    return {"tetra grid": _issue_volume(), "hexa grid": hexa, "data1 (bores and a void)": datasets.load("data1")}


@pytest.fixture(scope="module", params=["tetra grid", "hexa grid", "data1 (bores and a void)"])
def volume(request):
    vol = _volumes()[request.param]
    field = "f" if "f" in vol.fields else None
    s = vol.scalars(field)
    # evenly over the range, and node values (a crossing exactly on a node)
    values = np.r_[np.linspace(s.min(), s.max(), N_VALUES - 4)[1:-1], np.sort(s)[[1, s.size // 3, s.size // 2,
                                                                                     -2]]]
    single = [vol.isosurface(v, field=field, method="scan") for v in values]
    return vol, field, values, single


@pytest.mark.parametrize("method", method_names())
def test_every_method_every_partition_count(volume, method):
    vol, field, values, single = volume
    for k in PARTITIONS:
        prepared = PartitionedVolume.split(vol, k).prepare(field=field, method=method)
        for v, ref in zip(values, single):
            assert_same_as_single(vol, ref, prepared.extract(v))


# ------------------------------------------------------------------ property test

@st.composite
def small_volumes(draw):
    """Blocks of unit cubes (tetrahedra or hexahedra) with holes and voids where some are left out."""
    nx, ny, nz = draw(st.integers(2, 4)), draw(st.integers(2, 4)), draw(st.integers(1, 3))
    seed = draw(st.integers(0, 2**16))
    rng = np.random.default_rng(seed)
    keep = rng.random((nx, ny, nz)) > draw(st.sampled_from([0.0, 0.15, 0.3]))
    if keep.sum() < 2:
        keep[:] = True
    cell_type = draw(st.sampled_from(["tetra", "hexa"]))
    return block_volume(keep, cell_type, jitter=0.15, seed=seed), seed


def test_thinning_partition_pinched_on_its_seam_by_the_volume_itself():
    """A volume whose own boundary is pinched along an edge (blocks touching there), the pinch on a seam of 7
    partitions: the cells around it are tested at every query, like the seam cells. Before, the partition
    counted the pinch as the cut's, and thinning missed 2 of 12 triangles (in two cells at the pinched edge,
    no seam cell among them) with no warning. Drawn once by the property test below (seed 400)."""
    keep = np.ones((4, 2, 2), bool)
    keep[2, 1, 1] = keep[3, 0, 0] = keep[3, 0, 1] = keep[3, 1, 0] = False
    vol = block_volume(keep, "tetra", jitter=0.15, seed=400)
    assert any(a.size for a in boundary_defects(vol))  # the volume's own pinch
    s = vol.scalars("bumps")
    rng = np.random.default_rng(7)
    values = [float(s[rng.integers(s.size)]), float(rng.uniform(s.min(), s.max()))]
    prepared = PartitionedVolume.split(vol, 7).prepare(field="bumps", method="thinning")
    for v in values:
        assert_same_as_single(vol, vol.isosurface(v, field="bumps", method="scan"), prepared.extract(v))


@settings(max_examples=500, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=small_volumes(), method=st.sampled_from(method_names()), k=st.integers(1, 8), which=st.integers(0, 99))
def test_partitioned_equals_single_scan_property(data, method, k, which):
    """Equal to the single volume's scan; where the volume's own boundary is not a 2-manifold (blocks touching
    along an edge only), the methods that rest on Thms 7.4-7.6 may miss a piece, and then they say so."""
    vol, seed = data
    k = min(k, vol.n_cells)
    s = vol.scalars("bumps")
    rng = np.random.default_rng(which)
    values = [float(s[rng.integers(s.size)]),  # exactly a node's value
              float(rng.uniform(s.min(), s.max()))]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ThinningWarning)
        prepared = PartitionedVolume.split(vol, k).prepare(field="bumps", method=method)
    warned = any(issubclass(w.category, ThinningWarning) for w in caught)
    manifold = not any(a.size for a in boundary_defects(vol))
    assert not (warned and manifold), [str(w.message) for w in caught]  # a warning only where the theorems fail
    for v in values:
        single = vol.isosurface(v, field="bumps", method="scan")
        stitched = prepared.extract(v)
        if warned and stitched.n_triangles != single.n_triangles:
            continue  # said: outside the theorems, a piece may be missing (never an extra or a wrong one)
        assert_same_as_single(vol, single, stitched)

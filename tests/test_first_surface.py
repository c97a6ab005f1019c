"""Issue 20: the first surface without prepared topology (the unprepared scan) and the preparation policy.

Oracle: the full scan of :mod:`polygen.volume.isosurface` (itself checked
against VTK on data 1-4 in ``test_isosurface_vtk.py``). The unprepared scan
numbers its vertices in the scan's order of first use, so the arrays --
triangles, vertex positions, normals, triangle cells -- must be equal
element for element, and its lazily looked-up ``vertex_keys`` the scan's
edge ids.
"""

import os

import numpy as np
import pytest

from polygen.volume import datasets, isovalues
from polygen.volume.isosurface import _scan_unprepared, extract
from polygen.volume.surface import PairKeyedIsoSurface, same_surface


def assert_identical(fresh, ref, where):
    assert isinstance(fresh, PairKeyedIsoSurface), where
    for name in ("triangles", "vertices", "normals", "triangle_cells"):
        a, b = getattr(fresh, name), getattr(ref, name)
        assert (a is None) == (b is None), (where, name)
        assert a is None or np.array_equal(a, b), (where, name)
    assert fresh.counters() | {"t1": 0, "t2": 0, "t3": 0} == ref.counters() | {"t1": 0, "t2": 0, "t3": 0}, where
    assert np.array_equal(fresh.vertex_keys, ref.vertex_keys), where
    assert same_surface(fresh, ref), where


def values_with_node_hits(s, n=9):
    """``n`` values from min to max, plus two node values: crossings exactly on nodes are exercised."""
    s = np.asarray(s)
    return np.concatenate([np.linspace(s.min(), s.max(), n), s[[len(s) // 3, len(s) // 2]]])


@pytest.mark.parametrize("normals", ["mean", "gradient", None])
def test_tiny_volumes_give_the_scans_arrays(tiny_volume, normals):
    name = repr(tiny_volume)
    for field in tiny_volume.fields:
        for v in values_with_node_hits(tiny_volume.fields[field]):
            fresh_vol = type(tiny_volume)(tiny_volume.points, tiny_volume.cells, dict(tiny_volume.fields),
                                          validate=False)
            fresh = _scan_unprepared(fresh_vol, v, field, normals)
            assert "_edge_table" not in fresh_vol.__dict__  # no topology was needed
            assert_identical(fresh, extract(tiny_volume, v, field=field, normals=normals), (name, field, v))


@pytest.mark.parametrize("name", ["data1", "data2", "hexa1",
                                  pytest.param("data3", marks=pytest.mark.slow),
                                  pytest.param("data4", marks=pytest.mark.slow)])
def test_data_sets_give_the_scans_arrays(name):
    vol = datasets.load(name)
    s = vol.scalars("fem")
    values = np.concatenate([isovalues(s, 20), s[[0, len(s) // 2]]])
    fresh = [_scan_unprepared(vol, v, "fem", "mean") for v in values]
    assert "_edge_table" not in vol.__dict__ and "face_neighbors" not in vol.__dict__
    assert sum(iso.n_triangles for iso in fresh) > 0
    for v, iso in zip(values, fresh):
        assert_identical(iso, extract(vol, v, field="fem"), (name, v))


def test_empty_and_out_of_range():
    vol = datasets.load("torus")
    s = vol.scalars()
    for v in (s.min() - 1.0, s.max() + 1.0):
        iso = vol.isosurface(v, prepare=False)
        assert iso.is_empty and iso.vertex_keys.shape == (0,) and iso.cells_tested == vol.n_cells


def test_the_policy_answers_first_from_the_scan_then_from_the_prepared_method():
    vol = datasets.load("genus3")
    s = vol.scalars()
    values = isovalues(s, 5)
    first = vol.isosurface(values[0])
    assert isinstance(first, PairKeyedIsoSurface)
    assert vol.wait_prepared(timeout=600) and not vol.preparation_errors
    later = vol.isosurface(values[0])
    from polygen.volume import methods

    assert not isinstance(later, PairKeyedIsoSurface) and later.method == methods.default()  # the prepared method
    assert same_surface(first, later)
    assert same_surface(vol.isosurface(values[1], prepare=False), vol.isosurface(values[1], prepare=True))


# ------------------------------------------------------------------ memory
def test_volume_memory_counts_what_was_built():
    vol = datasets.load("genus3")
    assert vol.memory_bytes() == {}  # nothing derived yet
    vol.isosurface(float(np.median(vol.scalars())), prepare=False)
    assert vol.memory_bytes() == {}  # the unprepared scan builds nothing
    nb = vol.face_neighbors
    mem = vol.memory_bytes()
    assert mem["face_neighbors"] == nb.nbytes
    assert set(mem) == {"face_neighbors"}  # the face ids it was matched from are not kept
    vol.cell_edges
    assert vol.memory_bytes()["_edge_table"] == vol.edges.nbytes + vol.cell_edges.nbytes


def test_method_memory_excludes_the_volume_and_counts_structures():
    from polygen.volume import methods

    vol = datasets.load("genus3")
    v = float(np.median(vol.scalars()))
    for name in methods.names():
        m = methods.get(name)(vol)
        m.extract(v)
        held = m.memory_bytes()
        if name in ("scan", "unprepared-scan"):
            assert held == 0, name
            continue
        assert held > 0, name
        structure = getattr(getattr(m, "source", None), "structure", None)
        if hasattr(structure, "nbytes"):
            assert held >= structure.nbytes, name  # the search structure is part of what is held
    # the volume's arrays are never counted: a method holding only them holds nothing
    m = methods.get("scan")(vol)
    m.borrowed = (vol.cells, vol.face_neighbors, vol.fields[next(iter(vol.fields))])
    assert m.memory_bytes() == 0
    m.own = np.zeros(1000, np.int32)
    assert methods.IsosurfaceMethod.memory_bytes(m) == 4000


# ------------------------------------------------------------------ the constructor's one-pass check
def test_one_pass_cell_check_never_passes_a_cell_the_exact_checks_refuse():
    """``tet_cells_clearly_valid`` may send a valid cell to the exact checks, never the reverse: cells
    flattened to around the degeneracy bound, inverted, with repeated or out-of-range nodes."""
    from polygen.volume import _topology as k
    from polygen.volume.mesh import _DEGENERATE_RTOL

    rng = np.random.default_rng(7)
    base = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    pts, cells = [], []
    for i, h in enumerate(np.concatenate([np.geomspace(1e-12, 1e-8, 400), [1.0, -1.0, 1e-3, -1e-12]])):
        p = base.copy()
        p[3, 2] = h
        p = p @ rng.normal(size=(3, 3)) if i % 2 else p  # rotated (possibly inverting) copies too
        pts.append(p + rng.normal(size=3) * 10.0 ** rng.integers(0, 7))
        cells.append(np.arange(4) + 4 * i)
    points, cells = np.concatenate(pts), np.array(cells)
    cells = np.concatenate([cells, [[0, 0, 1, 2], [0, 1, 2, len(points)], [-1, 0, 1, 2]]])
    vol6, longest = k.tet_volumes6(points, np.clip(cells, 0, len(points) - 1))
    exact_ok = (vol6 > _DEGENERATE_RTOL * longest**3) & (np.diff(np.sort(cells, axis=1), axis=1) > 0).all(axis=1) \
        & (cells >= 0).all(axis=1) & (cells < len(points)).all(axis=1)
    for c in range(len(cells)):
        used = np.zeros(len(points), np.uint8)
        clear = k.tet_cells_clearly_valid(points, cells[c:c + 1], _DEGENERATE_RTOL, used) == 0
        assert not clear or exact_ok[c], c
        assert used.sum() == (4 if clear else 0)
    # both answers occur: the test exercises the bound from both sides
    assert 0 < exact_ok.sum() < len(cells)


def test_background_work_runs_inline_under_the_workqueue_layer():
    """numba's workqueue layer aborts on overlapping parallel regions: polygen then starts no background thread.

    Run in a subprocess with ``NUMBA_THREADING_LAYER=workqueue``: the first
    surface, the default method's preparation (whose thinning and records
    would otherwise overlap) and a second surface, the same triangles as a
    full scan, and no polygen thread left behind.
    """
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent("""
        import threading, numpy as np
        from polygen._jit import parallel_kernels_may_overlap
        from polygen.volume import datasets
        assert not parallel_kernels_may_overlap()
        vol = datasets.load("data4")  # above the sizes that build side by side
        v = float(np.median(vol.scalars("fem")))
        a = vol.isosurface(v, field="fem")
        assert not [t for t in threading.enumerate() if t.name.startswith("polygen")]
        b = vol.isosurface(v, field="fem", prepare=True)
        assert a.n_triangles == b.n_triangles > 0
        print("ok")
    """)
    env = dict(os.environ, NUMBA_THREADING_LAYER="workqueue")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr[-2000:]


def test_more_vertices_than_the_table_was_sized_for():
    """The unprepared scan sizes its hash table for at most ``n_t`` vertices and starts over with a table for
    the bound (``3 n_t``) when there are more: disjoint tetrahedra cut at one corner each give one triangle
    of three vertices of its own (``V = 3 T``), past the first table's half. The result is still the scan's."""
    from polygen.volume import UnstructuredVolume
    from polygen.volume import marching as _m

    k = 5
    corner = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    points = np.concatenate([corner + [3.0 * i, 0, 0] for i in range(k)])
    cells = np.arange(4 * k).reshape(k, 4)
    s = np.tile([1.0, 0.0, 0.0, 0.0], k)
    vol = UnstructuredVolume(points, cells, {"f": s})
    # the kernel on its own: a table with room for n_t = 5 codes (16 slots, 8 at most) refuses 15
    n_t = k
    tri_codes = np.arange(3 * n_t, dtype=np.int64).reshape(n_t, 3) * 7 + 1
    bits = max(4, int(2 * n_t).bit_length())
    out = [np.empty((n_t, 3), np.int64), np.empty((3 * n_t, 2), np.int64), np.empty(3 * n_t, np.int64)]
    got = _m._number_pair_codes(tri_codes, 1000, 64 - bits, np.full(1 << bits, -1, np.int64),
                                np.empty(1 << bits, np.int32), np.empty(3 * n_t, np.int64), *out)
    assert got == -1
    bits = max(4, int(2 * 3 * n_t).bit_length())
    got = _m._number_pair_codes(tri_codes, 1000, 64 - bits, np.full(1 << bits, -1, np.int64),
                                np.empty(1 << bits, np.int32), np.empty(3 * n_t, np.int64), *out)
    assert got == 3 * n_t and np.array_equal(out[0], np.arange(3 * n_t).reshape(n_t, 3))
    # the whole scan
    fresh = _scan_unprepared(vol, 0.5, "f", "mean")
    assert fresh.n_triangles == k and fresh.vertices.shape[0] == 3 * k
    assert_identical(fresh, extract(vol, 0.5, field="f"), "disjoint corners")

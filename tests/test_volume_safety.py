"""Issue 19, items 1-4: threads, changed fields, huge values, unreferenced nodes.

Each test is the issue's reproducer; the oracle is the full scan of a volume
built afresh (or, for threads, the same method called from one thread).
"""

import threading

import numpy as np
import pytest

import polygen.volume  # noqa: F401  (registers every method)
from polygen.volume import registry
from polygen.volume._cells import KUHN_TETS
from polygen.volume.isosurface import extract
from polygen.volume.mesh import UnstructuredVolume, VolumeError, VolumeWarning
from polygen.volume.seeds.span_filter import SpanFilter
from polygen.volume.surface import IsoSurfaceError, same_surface

METHODS = registry.method_names()


def grid_tets(n):
    """(points, cells): an n x n x n grid of unit cubes, each cut into the six Kuhn tetrahedra."""
    g = np.arange(n + 1, dtype=np.float64)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    points = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    corners = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]])
    hexes = ((i[:, None] + corners[:, 0]) * (n + 1) + j[:, None] + corners[:, 1]) * (n + 1) + k[:, None] + corners[:, 2]
    return points, hexes[:, KUHN_TETS].reshape(-1, 4)


def two_blobs(points):
    """A field with two maxima and a saddle between them: two surface components at high values."""
    c = points.mean(axis=0)
    r = points.max() - points.min()
    a = np.exp(-np.sum((points - c - [0.25 * r, 0, 0]) ** 2, axis=1) / (0.04 * r * r))
    b = np.exp(-np.sum((points - c + [0.25 * r, 0, 0]) ** 2, axis=1) / (0.03 * r * r))
    return a + 0.8 * b + 0.01 * points[:, 2] / r


def scan(vol, value, field=None):
    return extract(vol, value, field=field, method="scan")


# ----------------------------------------------------------------- item 1: threads
@pytest.fixture(scope="module")
def grid30():
    points, cells = grid_tets(30)
    return UnstructuredVolume(points, cells, {"f": two_blobs(points)}, orient=True)


def _in_threads(calls, values):
    """``calls[k](v)`` for every value, each ``k`` in its own thread, all started together.

    Returns one result list per call, in the order of ``calls``; the first
    exception of any thread is raised here.
    """
    out = [[None] * len(values) for _ in calls]
    errors = []
    start = threading.Barrier(len(calls))

    def work(t):
        try:
            start.wait()
            for i, v in enumerate(values):
                out[t][i] = calls[t](v)
        except BaseException as exc:  # re-raised below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(t,)) for t in range(len(calls))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if errors:
        raise errors[0]
    return out


def _two_threads(call, values):
    """``call(v)`` for every value in each of two threads started together; the two result lists."""
    return _in_threads([call, call], values)


@pytest.mark.parametrize("method", METHODS)
def test_two_threads_share_one_prepared_method(grid30, method):
    """Issue 19.1: 40 values in each of two threads on one prepared method = one thread's answers."""
    m = registry.get_method(method)(grid30, field="f")
    values = np.linspace(0.05, 0.95, 40)
    alone = [m.extract(v) for v in values]
    assert sum(iso.n_triangles for iso in alone) > 0
    for results in _two_threads(m.extract, values):
        for a, b in zip(results, alone):
            assert a.n_triangles == b.n_triangles
            assert same_surface(a, b, geometry=False)


def test_two_threads_on_vol_isosurface(grid30):
    """Issue 19.1 as reported: ``vol.isosurface(v)`` from two threads, starting unprepared."""
    points, cells = grid30.points, grid30.cells
    vol = UnstructuredVolume(points, cells, {"f": grid30.fields["f"]}, validate=False)
    values = np.linspace(0.05, 0.95, 40)
    both = _two_threads(lambda v: vol.isosurface(v, prepare=True), values)
    assert len(vol._iso_methods) == 1  # prepared once, not once per thread
    for v, a, b in zip(values, *both):
        ref = scan(grid30, v)
        assert same_surface(a, ref, geometry=False) and same_surface(b, ref, geometry=False)


def test_background_preparation_from_two_threads(grid30):
    """Issue 20: the default policy answers at once by the unprepared scan while the edge-centred
    method is prepared in a background thread; two threads asking meanwhile get the scan's surfaces,
    the preparation starts once, and the answers after it are the same surfaces."""
    vol = UnstructuredVolume(grid30.points, grid30.cells, {"f": grid30.fields["f"]}, validate=False)
    assert vol.preparation == "background"
    values = np.linspace(0.05, 0.95, 40)
    first = vol.isosurface(values[0])
    assert type(first).__name__ == "PairKeyedIsoSurface"  # answered without waiting for the preparation
    both = _two_threads(vol.isosurface, values)
    assert vol.wait_prepared(timeout=600)
    assert not vol.preparation_errors
    assert sorted(k[1] for k in vol._iso_methods) == [registry.DEFAULT_METHOD, "unprepared-scan"]
    prepared = vol._iso_methods[("f", registry.DEFAULT_METHOD)]
    after = [vol.isosurface(v) for v in values]
    assert vol._iso_methods[("f", registry.DEFAULT_METHOD)] is prepared  # prepared once
    assert all(type(iso).__name__ == "IsoSurface" for iso in after)  # the prepared method answers now
    for v, a, b, c in zip(values, *both, after):
        ref = scan(grid30, v)
        for iso in (a, b, c):
            assert same_surface(iso, ref)  # vertex keys, positions and normals


def test_prepare_false_never_prepares(grid30):
    vol = UnstructuredVolume(grid30.points, grid30.cells, {"f": grid30.fields["f"]}, validate=False)
    for v in (0.3, 0.6):
        iso = vol.isosurface(v, prepare=False)
        assert not vol._iso_pending and "_edge_table" not in vol.__dict__ and "face_neighbors" not in vol.__dict__
        ref = scan(grid30, v)  # the same numbering: the same arrays (vertex_keys would build the edge table)
        assert np.array_equal(iso.triangles, ref.triangles) and np.array_equal(iso.vertices, ref.vertices)
        assert np.array_equal(iso.normals, ref.normals)
    assert same_surface(iso, ref)  # the edge ids, looked up now
    assert "_edge_table" in vol.__dict__ and "face_neighbors" not in vol.__dict__
    vol.preparation = "never"
    vol.isosurface(0.5)
    assert not vol._iso_pending and list(vol._iso_methods) == [("f", "unprepared-scan")]
    with pytest.raises(VolumeError, match="prepare must be"):
        vol.isosurface(0.5, prepare="yes")
    vol.preparation = "soon"
    with pytest.raises(VolumeError, match="preparation must be one of"):
        vol.isosurface(0.5)


def test_background_preparation_of_a_replaced_field_is_dropped():
    points, cells = grid_tets(12)
    old = two_blobs(points)
    new = two_blobs(points[:, [2, 1, 0]]) * 0.5 + 0.3
    vol = UnstructuredVolume(points, cells, {"f": old}, orient=True)
    fresh = UnstructuredVolume(points, vol.cells, {"f": new}, validate=False)
    vol.isosurface(0.5)  # starts preparing on the old values
    vol.fields["f"] = new
    assert vol.wait_prepared(timeout=600)
    for v in (0.35, 0.5, 0.7):
        assert same_surface(vol.isosurface(v), scan(fresh, v))
    assert vol.wait_prepared(timeout=600)
    for v in (0.35, 0.5, 0.7):
        assert same_surface(vol.isosurface(v), scan(fresh, v))
        assert same_surface(vol.isosurface(v, prepare=True), scan(fresh, v))


def test_every_method_at_once_on_one_volume(grid30):
    """Different methods share the volume's tables: each in its own thread, all at once, via vol.isosurface."""
    vol = UnstructuredVolume(grid30.points, grid30.cells, {"f": grid30.fields["f"]}, validate=False)
    values = np.linspace(0.1, 0.9, 12)
    results = _in_threads([lambda v, name=name: vol.isosurface(v, method=name) for name in METHODS],
                          values)
    out = dict(zip(METHODS, results))
    assert sorted(k[1] for k in vol._iso_methods) == sorted(METHODS)
    for i, v in enumerate(values):
        ref = scan(grid30, v)
        for name in METHODS:
            assert same_surface(out[name][i], ref, geometry=False), (name, v)


# ----------------------------------------------------------------- item 2: changed fields
def test_fields_are_read_only_copies():
    """Issue 19.2: ``vol.fields["f"][:] = new`` raises; the caller's array is copied, not shared."""
    points, cells = grid_tets(6)
    f = two_blobs(points)
    vol = UnstructuredVolume(points, cells, {"f": f}, orient=True)
    before = vol.isosurface(0.5)
    with pytest.raises(ValueError, match="read-only"):
        vol.fields["f"][:] = -f
    f[:] = -f  # the caller's own array: the volume does not see it
    assert same_surface(vol.isosurface(0.5), before, geometry=False)
    assert np.array_equal(vol.fields["f"], -f)


@pytest.mark.parametrize("read_only", [False, True])
@pytest.mark.parametrize("method", METHODS)
def test_a_method_prepared_on_a_callers_array_keeps_its_values(method, read_only):
    """A field given as an array (not by name) is copied: the caller writing it later changes no surface.

    Before, a float64 array was kept as it was, so the method answered for the new values with a preparation
    (ranges, lists, skeletons) made for the old ones. The kernels get the copy read-only, like a named field.
    """
    points, cells = grid_tets(8)
    vol = UnstructuredVolume(points, cells, {"g": points[:, 0]}, orient=True)
    f = two_blobs(points)
    if read_only:  # the caller's own read-only array is copied too: the caller may make it writable again
        f.setflags(write=False)
    m = registry.get_method(method)(vol, field=f)
    refs = [scan(vol, v, field=f.copy()) for v in (0.35, 0.6)]
    f.setflags(write=True)
    f[:] = f[::-1]  # the caller's own array, changed in place
    for v, ref in zip((0.35, 0.6), refs):
        iso = m.extract(v)
        assert ref.n_triangles and same_surface(iso, ref, geometry=False), (method, v)
    assert not same_surface(scan(vol, 0.35, field=f), refs[0], geometry=False)  # a change the test would see


@pytest.mark.parametrize("method", METHODS)
def test_replaced_field_gives_the_new_surface(method):
    """Issue 19.2: ``vol.fields["f"] = new`` after a first extraction: the next one is the new field's."""
    points, cells = grid_tets(10)
    old = two_blobs(points)
    new = two_blobs(points[:, [2, 1, 0]]) * 0.5 + 0.3  # other blobs, other range
    vol = UnstructuredVolume(points, cells, {"f": old}, orient=True)
    fresh = UnstructuredVolume(points, vol.cells, {"f": new}, validate=False)
    for v in (0.35, 0.5, 0.7):
        first = vol.isosurface(v, method=method)
        assert same_surface(first, scan(vol, v), geometry=False)
        vol.fields["f"] = new
        again = vol.isosurface(v, method=method)
        ref = scan(fresh, v)
        assert again.n_triangles == ref.n_triangles and same_surface(again, ref, geometry=False)
        assert again.n_triangles != first.n_triangles  # the test would see a stale surface
        vol.fields["f"] = old


def test_prepared_method_refuses_a_replaced_field():
    """A method held by the caller raises instead of answering for values the volume no longer has."""
    points, cells = grid_tets(6)
    vol = UnstructuredVolume(points, cells, {"f": two_blobs(points), "g": points[:, 0]}, orient=True)
    m = registry.get_method(registry.DEFAULT_METHOD)(vol, field="f")
    m.extract(0.5)
    vol.fields["f"] = points[:, 1]
    with pytest.raises(IsoSurfaceError, match="'f' of the volume was replaced"):
        m.extract(0.5)
    with pytest.raises(IsoSurfaceError, match="replaced"):
        m.extract_many([0.5])
    del vol.fields["f"]
    assert list(vol.fields) == ["g"]
    with pytest.raises(IsoSurfaceError, match="replaced or removed"):
        m.extract(0.5)
    with pytest.raises(VolumeError, match="shape"):
        vol.fields["h"] = np.zeros(3)
    assert list(vol.fields) == ["g"]


# ----------------------------------------------------------------- item 3: huge values
@pytest.mark.parametrize("big", [1e308, 8e307])
def test_overflowing_field_is_rejected(big):
    """Issue 19.3: +-1e308 (max - min = inf) and +-8e307 (x 30 overflows in (5.2)) name the field."""
    points, cells = grid_tets(30)
    f = np.where(points[:, 0] > 15, big, -big)
    with pytest.raises(VolumeError, match="field 'huge' spans .*overflows float64"):
        UnstructuredVolume(points, cells, {"huge": f}, orient=True)
    vol = UnstructuredVolume(points, cells, {"ok": points[:, 0]}, orient=True)
    with pytest.raises(VolumeError, match="field 'huge'"):
        vol.fields["huge"] = f
    assert list(vol.fields) == ["ok"]


def test_overflowing_values_given_as_an_array_are_rejected():
    """The same bound on a field passed as node values rather than by name."""
    points, cells = grid_tets(4)
    vol = UnstructuredVolume(points, cells, {"ok": points[:, 0]}, orient=True)
    with pytest.raises(IsoSurfaceError, match="overflows float64"):
        extract(vol, 0.0, field=np.where(points[:, 0] > 2, 1e308, -1e308))


def test_overflowing_coordinates_are_rejected():
    points, cells = grid_tets(2)
    with pytest.raises(VolumeError, match="max - min of a coordinate overflows"):
        UnstructuredVolume((points - 1) * 1e308, cells, validate=False)


def test_largest_accepted_field_gives_finite_surfaces():
    """Just under the bound 2 (max - min) max|x| < float max, every method gives the scan's finite surface."""
    points, cells = grid_tets(4)  # coordinates 0..4
    scale = np.finfo(np.float64).max / (2 * 4) / 2.0 * 0.999  # range 2 * scale
    f = (two_blobs(points) * 2 - 1) * scale
    f = f / np.abs(f).max() * scale
    vol = UnstructuredVolume(points, cells, {"f": f}, orient=True)
    for method in METHODS:
        for v in (-0.3 * scale, 0.0, 0.4 * scale):
            iso = vol.isosurface(v, method=method)
            ref = scan(vol, v)
            assert ref.n_triangles > 0 and np.all(np.isfinite(ref.vertices))
            assert np.all(np.isfinite(iso.vertices)) and same_surface(iso, ref, geometry=False)


@pytest.mark.parametrize("layout", ["replicate", "by-min"])
def test_span_filter_classes_never_come_from_nan(layout):
    """A class index from (x - lo) / width with width = inf is inf / inf = NaN: it must stay in range."""
    cmin = np.array([-1e308, -1e308, 0.0, 5e307, 1e308])
    cmax = np.array([-1e308, 0.0, 1e308, 1e308, 1e308])
    sf = SpanFilter.build(cmin, cmax, n_buckets=8, layout=layout)
    for v in (-1e308, -1.0, 0.0, 6e307, 1e308):
        active = np.flatnonzero((cmin <= v) & (cmax >= v))
        found = sf.query(v).cells
        assert set(active) <= set(found.tolist()) and set(found.tolist()) <= set(range(5))


# ----------------------------------------------------------------- item 4: unreferenced nodes
@pytest.mark.parametrize("unused_value", ["extreme", "inside"])
@pytest.mark.parametrize("where", ["first", "middle", "last", "all three"])
@pytest.mark.parametrize("cell_type", ["tetra", "hexa"])
def test_unreferenced_nodes_every_method_equals_the_scan(where, cell_type, unused_value):
    """Issue 19.4: unused nodes (first, middle, last), holding the field's extreme values or ones inside its range."""
    points, cells = grid_tets(5)
    if cell_type == "hexa":
        n = 5
        i, j, k = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij"))
        corners = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]])
        cells = ((i[:, None] + corners[:, 0]) * (n + 1) + j[:, None] + corners[:, 1]) * (n + 1) + k[:, None] \
            + corners[:, 2]
    f = two_blobs(points)
    n = points.shape[0]
    at = {"first": [0], "middle": [n // 2], "last": [n], "all three": [0, n // 2, n]}[where]
    # insert unused nodes before the given positions of the original numbering (the last one at the end)
    new_id = np.arange(n) + np.searchsorted(np.array(at), np.arange(n), side="right")
    m = n + len(at)
    unused = np.setdiff1d(np.arange(m), new_id)
    P = np.zeros((m, 3))
    P[new_id] = points
    P[unused] = [100.0, 100.0, 100.0]
    F = np.zeros(m)
    F[new_id] = f
    if unused_value == "extreme":  # the field's global max / min
        F[unused] = np.where(np.arange(len(at)) % 2 == 0, 10.0, -10.0)
    else:  # a value between the isovalues
        F[unused] = 0.2
    with pytest.warns(VolumeWarning, match=f"{len(at)} of {m} nodes are used by no cell"):
        vol = UnstructuredVolume(P, new_id[cells], {"f": F}, orient=True)
    assert vol.unreferenced_nodes.tolist() == unused.tolist()
    plain = UnstructuredVolume(points, cells, {"f": f}, orient=True)
    for method in METHODS:
        for v in (0.1, 0.3, 0.5):
            iso = vol.isosurface(v, method=method)
            ref = scan(vol, v)
            assert ref.n_triangles > 0
            assert same_surface(iso, ref, geometry=False), (method, v)
            assert iso.n_triangles == scan(plain, v).n_triangles
        grad = vol.isosurface(0.3, method=method, normals="gradient")  # node gradients skip the unused nodes
        assert np.all(np.isfinite(grad.normals))


# ----------------------------------------------------------------------------
# item 8: a value a hair above a minimum (vertices round onto the node)
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("name", registry.method_names())
def test_normals_of_a_surface_shrunk_onto_a_node(name):
    from polygen.volume import datasets

    v = datasets.load("hollow_cube")
    p0 = np.array([1.0, 1.0, 0.0])                    # a node on the bottom face z = 0
    vol = UnstructuredVolume(v.points, v.cells, {"f": ((v.points - p0) ** 2).sum(axis=1)})
    for c in (1e-300, 1e-17):
        iso = registry.get_method(name)(vol, field="f").extract(c)
        assert iso.n_triangles > 0
        # every triangle has collapsed onto p0 (zero area): the normals must still be unit
        # vectors, pointing away from the minimum, i.e. into the volume above z = 0
        np.testing.assert_allclose(np.linalg.norm(iso.normals, axis=1), 1.0, rtol=1e-12)
        assert np.all(iso.normals[:, 2] >= 0.0)

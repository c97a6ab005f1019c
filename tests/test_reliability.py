"""Issue 43, items 2-8: reliability, third round.

Each test is the issue's reproducer; the oracle is a volume built afresh
(the full scan of its field) or the one clear error the issue asks for.
"""

import copy
import pickle
import threading

import numpy as np
import pytest

import polygen.volume  # noqa: F401  (registers every method)
from polygen.volume import registry
from polygen.volume.isosurface import extract
from polygen.volume.mesh import UnstructuredVolume, VolumeError, VolumeWarning
from polygen.volume.surface import IsoSurfaceError, same_surface

from tests.test_volume_safety import grid_tets, two_blobs


def scan(vol, value, field=None):
    return extract(vol, value, field=field, method="scan")


@pytest.fixture(scope="module")
def grid8():
    points, cells = grid_tets(8)
    return points, cells, two_blobs(points)


# ------------------------------------------------------- item 2: the caller's arrays
def test_orient_never_writes_the_callers_cells(grid8):
    """orient=True reorders the volume's copy; the caller's cells keep every row."""
    points, cells, f = grid8
    flipped = cells.copy()
    flipped[::3, [1, 2]] = flipped[::3, [2, 1]]  # every third tetrahedron inverted
    before = flipped.copy()
    vol = UnstructuredVolume(points, flipped, {"f": f}, orient=True)
    assert np.array_equal(flipped, before)
    assert not np.shares_memory(vol.cells, flipped) and not np.shares_memory(vol.points, points)


def test_a_later_change_to_the_callers_points_cannot_reach_the_volume(grid8):
    """Mirroring the caller's points after construction inverted every cell and made a solid cube
    report a void; the volume keeps its own read-only copies."""
    points, cells, f = grid8
    p, c = points.copy(), cells.copy()
    vol = UnstructuredVolume(p, c, {"f": f})
    p[:, 0] *= -1.0
    c[:, [1, 2]] = c[:, [2, 1]]
    assert vol.n_voids == 0 and vol.n_boundary_groups == 1
    assert same_surface(vol.isosurface(0.5, method="scan"), scan(UnstructuredVolume(points, cells, {"f": f}), 0.5))
    for a in (vol.points, vol.cells):
        assert not a.flags.writeable
        with pytest.raises(ValueError):
            a[0] = a[1]


# ------------------------------------------------- item 3: a field replaced under readers
STRESS_METHODS = [None, "active-scan", "edge-centred", "span-space", "scan", "unprepared-scan"]


def test_field_replaced_while_four_threads_extract(grid8):
    """4 threads at random: vol.isosurface (every path), vol.extract_many, replacing field "f" and
    add_field of other names, on one volume. No call raises; every surface equals a fresh volume's
    surface for one of the arrays "f" held (the one a query began with)."""
    points, cells, f = grid8
    arrays = [f, 1.0 - f, np.roll(f, 97)]
    values = [0.25, 0.45, 0.65]
    refs = {}
    for k, a in enumerate(arrays):
        fresh = UnstructuredVolume(points, cells, {"f": a})
        for v in values:
            refs[k, v] = scan(fresh, v)
    vol = UnstructuredVolume(points, cells, {"f": arrays[0]})
    errors, checked = [], [0]
    start = threading.Barrier(4)

    def one_of_the_fields(iso, v):
        return any(same_surface(iso, refs[k, v], geometry=False) for k in range(len(arrays)))

    def work(t):
        rng = np.random.default_rng(t)
        try:
            start.wait()
            for _ in range(60):
                op = rng.integers(5)
                if op == 0 or (op == 1 and t == 0):
                    vol.fields["f"] = arrays[rng.integers(len(arrays))]
                elif op == 1:
                    vol.add_field(f"g{t}", arrays[rng.integers(len(arrays))])
                elif op == 2:
                    vs = list(rng.choice(values, 2))
                    many = vol.extract_many(vs, field="f", method=STRESS_METHODS[1 + rng.integers(3)], threads=2)
                    assert len(many) == 2
                    # one call, one field: both surfaces are of the same array
                    assert any(all(same_surface(iso, refs[k, v], geometry=False) for iso, v in zip(many, vs))
                               for k in range(len(arrays)))
                    checked[0] += 2
                else:
                    v = float(rng.choice(values))
                    iso = vol.isosurface(v, field="f", method=STRESS_METHODS[rng.integers(len(STRESS_METHODS))])
                    assert one_of_the_fields(iso, v)
                    checked[0] += 1
        except BaseException as exc:  # reported below, with the others
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(t,)) for t in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join(timeout=600)  # a cold numba cache compiles here first
    assert not any(th.is_alive() for th in threads)
    vol.wait_prepared(timeout=60)
    assert not errors, f"{len(errors)} errors, the first: {errors[0]!r}"
    assert checked[0] > 50


# ------------------------------------------------------------- item 5: duplicate cells
@pytest.mark.parametrize("validate", [True, False])
def test_duplicate_cells_are_refused_by_the_constructor(grid8, validate):
    """A copy of a cell (in another node order) is refused at once, with or without validate, so that no
    path (the default active-scan, scan or unprepared scan) returns doubled triangles."""
    points, cells, f = grid8
    dup = np.concatenate([cells, cells[[7, 300]][:, [1, 2, 3, 0]][:, [0, 2, 1, 3]]])
    with pytest.raises(VolumeError, match=r"2 cells repeat the nodes of an earlier cell \(duplicate cells\), "
                                          r"e\.g\. cells \[3072, 3073\]: cell 3072 has the nodes of cell 7"):
        UnstructuredVolume(points, dup, {"f": f}, validate=validate)
    hexes = np.arange(16).reshape(2, 8)
    pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)[[0, 1, 3, 2, 4, 5, 7, 6]]
    with pytest.raises(VolumeError, match="duplicate cells"):
        UnstructuredVolume(pts, np.stack([hexes[0] % 8, hexes[0] % 8]), {"f": pts[:, 0]}, validate=validate)


# ------------------------------------------------------------ item 6: pickling and copying
def _round_trips(obj):
    return [pickle.loads(pickle.dumps(obj)), copy.deepcopy(obj)]


def test_a_fresh_volume_and_its_first_surface_pickle_and_copy(grid8):
    """The volume (with a background preparation running or done) and its first surface (a
    PairKeyedIsoSurface) pickle and deep-copy; the copies answer as the original, and their arrays
    stay read-only."""
    points, cells, f = grid8
    vol = UnstructuredVolume(points, cells, {"f": f})
    first = vol.isosurface(0.5)
    assert type(first).__name__ == "PairKeyedIsoSurface"
    copies = _round_trips(vol) + _round_trips(first)  # the preparation may still run meanwhile
    vol.wait_prepared(timeout=600)
    copies += _round_trips(vol)
    ref = scan(UnstructuredVolume(points, cells, {"f": f}), 0.5)
    for c in copies:
        v = c if isinstance(c, UnstructuredVolume) else c._volume
        assert not (v.points.flags.writeable or v.cells.flags.writeable or v.fields["f"].flags.writeable)
        iso = c.isosurface(0.5, prepare=True) if c is v else c
        assert same_surface(iso, ref)  # vertex keys read (from the copy's edge table), positions, normals
        v.fields["f"] = 1.0 - f  # the copy's locks work: replacing the field drops what was prepared on it
        assert same_surface(v.isosurface(0.5), scan(UnstructuredVolume(points, cells, {"f": 1.0 - f}), 0.5))
    assert same_surface(vol.isosurface(0.5), ref)  # the original is untouched


@pytest.mark.parametrize("method", registry.method_names())
def test_every_prepared_method_pickles_and_copies(grid8, method):
    points, cells, f = grid8
    vol = UnstructuredVolume(points, cells, {"f": f})
    m = registry.get_method(method)(vol, field="f")
    values = [0.3, 0.6]
    before = m.extract_many(values)
    for c in _round_trips(m):
        assert c is not m and c.vol is not vol
        for a, b in zip(c.extract_many(values), before):
            assert same_surface(a, b)
        assert same_surface(c.extract(0.45), m.extract(0.45))


# ------------------------------------------------ item 8: one clear message per bad input
def test_vector_point_arrays_are_named_not_dropped_silently(grid8):
    import meshio
    import pyvista as pv

    points, cells, f = grid8
    mesh = meshio.Mesh(points, [("tetra", cells)], point_data={"f": f, "velocity": points * 2.0})
    with pytest.warns(VolumeWarning, match=r"'velocity' \(3 components\) are not scalar.*add_field\('velocity_x'"):
        vol = UnstructuredVolume.from_meshio(mesh)
    assert list(vol.fields) == ["f"] and vol.dropped_point_data == {"velocity": "3 components"}
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: cells}, points)
    grid.point_data["f"], grid.point_data["velocity"] = f, points * 2.0
    with pytest.warns(VolumeWarning, match="'velocity' .3 components."):
        UnstructuredVolume.from_pyvista(grid)


def test_voxel_ordered_hexahedra_are_named():
    g = np.arange(3, dtype=float)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    i, j, k = (a.ravel() for a in np.meshgrid(*[np.arange(2)] * 3, indexing="ij"))
    corner = lambda di, dj, dk: ((i + di) * 3 + j + dj) * 3 + k + dk  # noqa: E731
    voxel = np.stack([corner(0, 0, 0), corner(1, 0, 0), corner(0, 1, 0), corner(1, 1, 0),
                      corner(0, 0, 1), corner(1, 0, 1), corner(0, 1, 1), corner(1, 1, 1)], axis=1)
    with pytest.raises(VolumeError, match=r"8 hexahedra are in voxel node order .*cells\[:, \[0, 1, 3, 2, 4, 5, 7, 6\]\]"):
        UnstructuredVolume(pts, voxel, {"f": pts[:, 0]})
    UnstructuredVolume(pts, voxel[:, [0, 1, 3, 2, 4, 5, 7, 6]], {"f": pts[:, 0]})  # the order it asks for


def test_fields_as_a_bare_array(grid8):
    points, cells, f = grid8
    with pytest.raises(VolumeError, match=r"fields must be a dict of name -> \(N,\) values; got ndarray "
                                          r"\(name it: fields=\{'f': values\}\)"):
        UnstructuredVolume(points, cells, f)


def test_from_meshio_and_from_pyvista_given_a_path():
    for where in (UnstructuredVolume.from_meshio, UnstructuredVolume.from_pyvista):
        with pytest.raises(VolumeError, match=r"takes .*; got the path 'x.vtu': UnstructuredVolume.read\(path\)"):
            where("x.vtu")
    with pytest.raises(VolumeError, match="from_meshio takes a meshio.Mesh; got dict"):
        UnstructuredVolume.from_meshio({})


@pytest.fixture(scope="module")
def vol8(grid8):
    points, cells, f = grid8
    return UnstructuredVolume(points, cells, {"f": f})


def test_unknown_method_is_a_volume_error(vol8):
    with pytest.raises(VolumeError, match="unknown isosurface method 'nope'"):
        vol8.isosurface(0.5, method="nope")
    with pytest.raises(VolumeError, match="unknown isosurface method 'nope'"):
        registry.get_method("nope")


@pytest.mark.parametrize("value", ["0.5", True, np.bool_(False), b"0.5"])
def test_a_string_or_bool_is_no_isovalue(vol8, value):
    for method in (None, "scan", "edge-centred"):
        with pytest.raises(IsoSurfaceError, match="value must be a number; got"):
            vol8.isosurface(value, method=method)


@pytest.mark.parametrize("method", registry.method_names())
def test_extract_many_checks_values_and_threads_alike(vol8, method):
    """One rule for every method: values a sequence of numbers, threads a whole number >= 1."""
    m = registry.get_method(method)(vol8, field="f")
    with pytest.raises(IsoSurfaceError, match=r"values must be a sequence of numbers; got float 0.5 "
                                              r"\(extract\(value\) gives one surface\)"):
        m.extract_many(0.5)
    for threads in (0, -1, 1.5, "2", True):
        with pytest.raises(IsoSurfaceError, match=r"threads must be a whole number >= 1 .*got "):
            m.extract_many([0.4, 0.6], threads=threads)
    assert len(m.extract_many(np.array([0.4, 0.6]), threads=1)) == 2
    with pytest.raises(IsoSurfaceError, match="values must be a sequence"):
        vol8.extract_many(0.5, method=method)


# ------------------------------------------------------------ item 4: bounded resources
def test_extract_many_keeps_no_more_builders_than_cores(vol8):
    import os

    def machine_cores():
        return len(os.sched_getaffinity(0))

    m = registry.get_method("edge-centred")(vol8, field="f")
    values = list(np.linspace(0.2, 0.8, machine_cores() + 6))
    many = m.extract_many(values, threads=64)
    assert len(m._builders) <= machine_cores()
    for a, v in zip(many, values):
        assert same_surface(a, m.extract(v))


_RSS_LIMIT = 1.5 * 2**30
# each request in a fresh interpreter whose address space is capped at 4 GiB: code that allocates what it
# cannot hold fails there at once (MemoryError) instead of swapping the machine
_PRELUDE = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
"""
# the peak of this interpreter's own memory (VmHWM: its address space's high-water mark, new at exec);
# getrusage's ru_maxrss is not it: Linux folds the forking parent's peak into the child's at exec, so a
# child of a pytest-xdist worker holding 2.2 GB of data sets reported 2.2 GB
_EPILOGUE = """
hwm = next(line for line in open("/proc/self/status") if line.startswith("VmHWM:"))
print("maxrss", int(hwm.split()[1]) * 1024)
"""


def _refused(code, error, *words, cli=False):
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=str(root), NUMBA_NUM_THREADS="2")
    script = _PRELUDE + code + _EPILOGUE
    res = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=600,
                         cwd=root)
    out = res.stdout + res.stderr
    assert res.returncode == 0, out[-3000:]
    assert "accepted" not in res.stdout, res.stdout
    line = next(x for x in res.stdout.splitlines() if x.startswith("refused "))
    assert line.startswith(f"refused {error}:"), line
    for w in words:
        assert w in line, line
    assert "more than this machine's" in line, line
    rss = int(res.stdout.split("maxrss")[-1])
    assert rss < _RSS_LIMIT, rss


def test_mesh_scene_refuses_a_mesh_larger_than_memory():
    code = """
from polygen.radiosity import mesh_scene
from polygen.radiosity.mesh import MeshError
from polygen.radiosity.scene import Polygon, Scene
square = Scene([Polygon([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], name="square")])
for size, levels in ((1e-4, 1), (0.25, 13)):
    try:
        mesh_scene(square, size, element_levels=levels)
    except MeshError as e:
        print("refused", type(e).__name__ + ":", e)
    else:
        print("accepted", size, levels)
"""
    _refused(code, "MeshError", "mesh_scene(patch_size=0.0001, element_levels=1)", "GiB")


def test_gauss_seidel_refuses_a_form_factor_matrix_larger_than_memory():
    code = """
from polygen.radiosity import mesh_scene, gauss_seidel
from polygen.radiosity.solve import SolverError
from polygen.radiosity.scene import AreaLight, Polygon, Scene
import numpy as np
floor = Polygon([[0, 0, 0], [0, 0, 1], [1, 0, 1], [1, 0, 0]], name="floor")
light = AreaLight(np.array([[0.4, 1, 0.4], [0.4, 1, 0.6], [0.6, 1, 0.6], [0.6, 1, 0.4]])[::-1], emission=1.0)
mesh = mesh_scene(Scene([floor, light]), 0.007, element_levels=1)
try:
    gauss_seidel(mesh)
except SolverError as e:
    print("refused", type(e).__name__ + ":", e, mesh.n_elements, mesh.n_patches)
"""
    _refused(code, "SolverError", "form-factor matrix", "progressive_refinement")


def test_cli_refuses_values_beyond_memory(tmp_path):
    import meshio

    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    meshio.Mesh(pts, [("tetra", np.array([[0, 1, 2, 3]]))], point_data={"f": pts.sum(axis=1)}).write(
        tmp_path / "one.vtu")
    code = f"""
import contextlib, io
from polygen.cli import main
err = io.StringIO()
with contextlib.redirect_stderr(err):
    rc = main(["isosurface", {str(tmp_path / "one.vtu")!r}, "--values", "1000000000", "--no-files",
               "--no-compare-vtk", "--method", "scan"])
lines = err.getvalue().splitlines()
assert rc == 2 and len(lines) == 1, (rc, lines)
print("refused CLIError:", lines[0])
"""
    _refused(code, "CLIError", "polygen isosurface: --values 1000000000 needs about")


def test_a_prepared_partitioned_volume_pickles_and_copies(grid8):
    from polygen.volume.partitioned import PartitionedVolume

    points, cells, f = grid8
    prepared = PartitionedVolume.split(UnstructuredVolume(points, cells, {"f": f}), 2).prepare("f", None)
    ref = prepared.extract(0.5)
    for c in _round_trips(prepared):
        assert same_surface(c.extract(0.5), ref)

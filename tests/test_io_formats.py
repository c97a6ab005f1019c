"""File formats (issue 19, Deliver 5) and cell data (Deliver 2): ``IsoSurface.save`` round trips,
volumes from gmsh MSH v4, XDMF, Exodus II, legacy VTK, cell arrays averaged onto the nodes, and
meshes of mixed cells tetrahedralised on request. Every test file is generated here."""

import sys
import types

import meshio
import numpy as np
import pytest
import pyvista as pv

from polygen.volume import IsoSurfaceError, UnstructuredVolume, VolumeError
from polygen.volume import io as vio
from tests._surfaces import grid_volume

# float32 keeps 24 bits: a coordinate or a normal's component within 2**-24 relative (6e-8) of
# ours; an area (a sum of cross products) within a few of those. OBJ is text with >= 7 digits.
F32_RTOL = 1e-6
# ASCII legacy VTK writes 11 significant digits (5e-11 relative); coordinates up to 6 here, so
# edge vectors of length ~1 within 6e-10
VTK_TEXT_RTOL = 1e-9


def _tolerance(ext, binary):
    if ext == ".vtp" or (ext == ".vtk" and binary):
        return 1e-12  # float64, bit for bit but for the area's summation order
    return VTK_TEXT_RTOL if ext == ".vtk" else F32_RTOL


@pytest.fixture(scope="module")
def sphere_surface():
    vol = grid_volume((7, 7, 7), jitter=0.2, seed=3)
    vol.add_field("r", np.linalg.norm(vol.points - 3.0, axis=1))
    return vol.isosurface(2.2, field="r", method="scan")


def _read_surface(path):
    poly = pv.read(path)
    return poly, poly.triangulate().area


@pytest.mark.parametrize("ext", vio.SURFACE_FORMATS)
@pytest.mark.parametrize("binary", [True, False])
def test_surface_round_trip(tmp_path, sphere_surface, ext, binary):
    iso = sphere_surface
    path = iso.save(tmp_path / f"s{ext}", binary=binary)
    assert path.exists()
    back, area = _read_surface(path)
    assert back.n_cells == iso.n_triangles and back.n_points == iso.n_vertices
    tol = _tolerance(ext, binary)
    assert area == pytest.approx(iso.area(), rel=tol)
    # the same triangles, corner by corner (the readers keep vertex order; STL's merges by position)
    faces = back.regular_faces
    got = np.sort(np.asarray(back.points)[faces].reshape(len(faces), -1), axis=0)
    want = np.sort(iso.vertices[iso.triangles].reshape(iso.n_triangles, -1), axis=0)
    np.testing.assert_allclose(got, want, rtol=0, atol=6 * tol)  # coordinates up to 6
    if ext == ".stl":
        assert "Normals" not in back.point_data  # STL has facet normals only
    else:
        np.testing.assert_allclose(back.point_data["Normals"], iso.normals, rtol=0, atol=tol)


@pytest.mark.parametrize("ext", [".ply", ".obj", ".stl"])
def test_surface_formats_read_by_meshio_too(tmp_path, sphere_surface, ext):
    iso = sphere_surface
    m = meshio.read(iso.save(tmp_path / f"s{ext}"))
    assert len(m.points) == iso.n_vertices and sum(len(c.data) for c in m.cells) == iso.n_triangles


def test_stl_facets_face_increasing_values(tmp_path, sphere_surface):
    # the right-hand order of our triangles points towards increasing scalar: outwards on this sphere
    back = pv.read(sphere_surface.save(tmp_path / "s.stl")).compute_normals(cell_normals=True, point_normals=False,
                                                                             auto_orient_normals=False,
                                                                             consistent_normals=False)
    outward = np.einsum("ij,ij->i", back.cell_data["Normals"], back.cell_centers().points - 3.0)
    assert (outward > 0).all()


def test_empty_surface_and_unknown_format(tmp_path, sphere_surface):
    vol = grid_volume((3, 3, 3))
    vol.add_field("x", vol.points[:, 0])
    empty = vol.isosurface(99.0, field="x", method="scan")
    assert empty.is_empty
    assert pv.read(empty.save(tmp_path / "e.vtp")).n_cells == 0
    for ext in (".stl", ".ply", ".obj"):
        with pytest.raises(IsoSurfaceError, match="empty"):
            empty.save(tmp_path / f"e{ext}")
    with pytest.raises(IsoSurfaceError, match=r"\.vtp, \.vtk, \.ply, \.obj, \.stl"):
        sphere_surface.save(tmp_path / "s.off")


# ------------------------------------------------------------------ volume formats

def _box_volume():
    vol = grid_volume((5, 4, 4), spacing=(0.5, 0.5, 0.5), jitter=0.15, seed=1)
    vol.add_field("t", np.sin(vol.points @ [1.0, 2.0, 0.5]))
    return vol


def _same_volume(back, vol, field="t"):
    assert back.cell_type == vol.cell_type and back.n_cells == vol.n_cells and back.n_points == vol.n_points
    np.testing.assert_allclose(back.points, vol.points, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(back.cells, vol.cells)
    np.testing.assert_allclose(back.fields[field], vol.fields[field], rtol=0, atol=1e-12)
    for c in (-0.3, 0.2, 0.7):
        assert back.isosurface(c, field=field, method="scan").area() == pytest.approx(
            vol.isosurface(c, field=field, method="scan").area(), rel=1e-12)


@pytest.mark.parametrize("fmt", [("gmsh", ".msh"), ("vtk", ".vtk"), ("vtu", ".vtu")])
def test_meshio_written_formats_round_trip(tmp_path, fmt):
    file_format, ext = fmt
    vol = _box_volume()
    path = tmp_path / f"box{ext}"
    # binary MSH: meshio 5.3 cannot read back the $NodeData of the ASCII MSH it writes (an ASCII
    # MSH from gmsh, without node data, is read in test_msh_v4_written_by_gmsh)
    meshio.write(path, vol.to_meshio(), file_format=file_format, **({"binary": ext == ".msh"} if ext != ".vtu" else {}))
    if ext == ".msh":
        assert path.read_bytes().splitlines()[1].startswith(b"4.1")  # gmsh v4
    _same_volume(UnstructuredVolume.read(path), vol)


def test_xdmf_round_trip(tmp_path, monkeypatch):
    vol = _box_volume()
    path = tmp_path / "box.xdmf"
    # meshio's XDMF writer imports h5py even for XML data, which never touches it
    # meshio's XDMF reader and writer import h5py even for XML data, which never touches it: h5py is
    # not a dependency, so a module of that name stands in (an attribute asked of it would fail)
    monkeypatch.setitem(sys.modules, "h5py", types.ModuleType("h5py"))
    meshio.write(path, vol.to_meshio(), data_format="XML")
    _same_volume(UnstructuredVolume.read(path), vol)


def test_xdmf_without_h5py_says_so(tmp_path, monkeypatch):
    path = tmp_path / "box.xdmf"
    monkeypatch.setitem(sys.modules, "h5py", types.ModuleType("h5py"))
    meshio.write(path, _box_volume().to_meshio(), data_format="XML")
    monkeypatch.setitem(sys.modules, "h5py", None)  # as where h5py is not installed
    with pytest.raises(VolumeError, match=r"box.xdmf.*needs the h5py package \(pip install h5py\)"):
        UnstructuredVolume.read(path)


def _write_exodus(path, points, cells, fields):
    """A minimal Exodus II file (netCDF 3, as the Exodus library reads it), written with scipy."""
    from scipy.io import netcdf_file

    nc = netcdf_file(path, "w", version=2)
    nc.api_version = nc.version = np.float32(8.03)
    nc.floating_point_word_size = np.int32(8)
    nc.file_size = np.int32(1)
    nc.title = b"polygen test"
    for name, size in [("time_step", None), ("len_string", 33), ("len_line", 81), ("four", 4), ("len_name", 33),
                       ("num_dim", 3), ("num_nodes", len(points)), ("num_elem", len(cells)), ("num_el_blk", 1),
                       ("num_el_in_blk1", len(cells)), ("num_nod_per_el1", cells.shape[1]),
                       ("num_nod_var", len(fields))]:
        nc.createDimension(name, size)
    nc.createVariable("time_whole", "d", ("time_step",))[0] = 0.0
    for i, axis in enumerate("xyz"):
        nc.createVariable("coord" + axis, "d", ("num_nodes",))[:] = points[:, i]
    nc.createVariable("eb_status", "i", ("num_el_blk",))[:] = 1
    prop = nc.createVariable("eb_prop1", "i", ("num_el_blk",))
    prop[:] = 1
    prop.name = b"ID"
    conn = nc.createVariable("connect1", "i", ("num_el_in_blk1", "num_nod_per_el1"))
    conn[:] = cells + 1  # Exodus numbers nodes from 1
    conn.elem_type = b"TETRA" if cells.shape[1] == 4 else b"HEX8"
    names = nc.createVariable("name_nod_var", "c", ("num_nod_var", "len_name"))
    for k, (name, values) in enumerate(fields.items()):
        names[k] = np.array(list(name.ljust(33, "\0")), dtype="S1")
        nc.createVariable(f"vals_nod_var{k + 1}", "d", ("time_step", "num_nodes"))[0] = values
    nc.close()


@pytest.mark.parametrize("tets", [True, False])
def test_exodus_reads_through_vtk(tmp_path, tets):
    # meshio's Exodus reader needs netCDF4 (not a dependency): the fallback, VTK's reader, reads it
    vol = grid_volume((4, 4, 3), jitter=0.1, seed=2, tets=tets)
    vol.add_field("t", np.cos(vol.points @ [0.7, 1.0, 0.3]))
    path = tmp_path / "box.e"
    _write_exodus(path, vol.points, vol.cells, {"t": vol.fields["t"]})
    back = UnstructuredVolume.read(path)
    assert back.cell_type == vol.cell_type and back.n_cells == vol.n_cells and back.n_points == vol.n_points
    # VTK's reader renumbers nodes (compare by position) and gives float32 coordinates
    order_b, order_v = np.lexsort(back.points.T), np.lexsort(vol.points.T)
    scale = np.abs(vol.points).max()
    np.testing.assert_allclose(back.points[order_b], vol.points[order_v], rtol=0, atol=F32_RTOL * scale)
    np.testing.assert_array_equal(back.fields["t"][order_b], vol.fields["t"][order_v])
    for c in (-0.5, 0.0, 0.5):
        assert back.isosurface(c, field="t", method="scan").area() == pytest.approx(
            vol.isosurface(c, field="t", method="scan").area(), rel=F32_RTOL * scale)


def test_msh_v4_written_by_gmsh(tmp_path):
    gmsh = pytest.importorskip("gmsh")
    path = tmp_path / "cyl.msh"
    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("cyl")
        gmsh.model.occ.addCylinder(0, 0, 0, 0, 0, 1, 0.5)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(3, [1], 1)
        gmsh.model.addPhysicalGroup(2, [s for _, s in gmsh.model.getEntities(2)], 2)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.model.mesh.generate(3)
        types_, tags, _ = gmsh.model.mesh.getElements(3)
        n_tets = sum(len(t) for ty, t in zip(types_, tags) if ty == 4)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    vol = UnstructuredVolume.read(path)  # the boundary triangles gmsh writes beside the tets are ignored
    assert vol.cell_type == "tetra" and vol.n_cells == n_tets > 0
    # the part's volume and a plane section: pi r^2 h, and a disc of area ~ pi r^2 (inscribed polygon)
    assert vio.cell_volumes(vol.points, vol.cells).sum() == pytest.approx(np.pi * 0.25, rel=0.05)
    vol.add_field("z", vol.points[:, 2])
    disc = vol.isosurface(0.5, field="z", method="scan")
    assert 0.9 * np.pi * 0.25 < disc.area() <= np.pi * 0.25


# ------------------------------------------------------------------ cell data

def _naive_cell_to_node(points, cells, values):
    num, den = np.zeros(len(points)), np.zeros(len(points))
    for c, x in zip(cells, values):
        v = vio.cell_volumes(points, c[None])[0]
        for n in c:
            num[n] += v * x
            den[n] += v
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)


@pytest.mark.parametrize("tets", [True, False])
def test_cell_to_node_is_the_volume_weighted_average(tets):
    vol = grid_volume((4, 5, 3), jitter=0.3, seed=4, tets=tets)
    x = np.random.default_rng(5).normal(size=vol.n_cells)
    np.testing.assert_allclose(vio.cell_to_node(vol.points, vol.cells, x),
                               _naive_cell_to_node(vol.points, vol.cells, x), rtol=1e-12, atol=1e-12)


def test_cell_to_node_of_a_linear_field_on_a_regular_grid():
    # an interior node of a regular hexahedral grid is the mean of its 8 cells' centres: a linear
    # function sampled at the centres averages to its value at the node
    vol = grid_volume((5, 5, 5), tets=False)
    f = np.array([1.0, -2.0, 0.5])
    centres = vol.points[vol.cells].mean(axis=1)
    node = vio.cell_to_node(vol.points, vol.cells, centres @ f)
    inner = np.all((vol.points > 0) & (vol.points < 4), axis=1)
    np.testing.assert_allclose(node[inner], vol.points[inner] @ f, atol=1e-12)


def test_cell_volumes_of_a_unit_cube():
    vol = grid_volume((2, 2, 2), tets=False)
    assert vio.cell_volumes(vol.points, vol.cells) == pytest.approx([1.0])
    tets = grid_volume((2, 2, 2), tets=True)
    assert vio.cell_volumes(tets.points, tets.cells).sum() == pytest.approx(1.0)


def _with_cell_data(tmp_path):
    vol = grid_volume((4, 4, 4), tets=False)
    centres = vol.points[vol.cells].mean(axis=1)
    m = meshio.Mesh(vol.points, [("hexahedron", vol.cells)], point_data={"t": vol.points[:, 0]},
                    cell_data={"stress": [centres[:, 2] * 2.0], "t": [centres[:, 1]],
                               "material": [np.arange(vol.n_cells) % 3]})
    path = tmp_path / "cells.vtu"
    m.write(path)
    return vol, centres, path


def test_read_cell_data_average(tmp_path):
    vol, centres, path = _with_cell_data(tmp_path)
    plain = UnstructuredVolume.read(path)
    assert list(plain.fields) == ["t"] and set(plain.cell_data_names) == {"stress", "t", "material"}
    back = UnstructuredVolume.read(path, cell_data="average")
    # node data first; a cell array named as a node field gets a suffix; integer tags are not averaged
    assert list(back.fields) == ["t", "stress", "t (cell average)"]
    assert back.cell_data_converted == ("stress", "t (cell average)")
    np.testing.assert_allclose(back.fields["stress"], vio.cell_to_node(vol.points, vol.cells, centres[:, 2] * 2))
    with pytest.raises(VolumeError, match="cell_data must be one of"):
        UnstructuredVolume.read(path, cell_data="mean")


# ------------------------------------------------------------------ mixed cells

def _mixed_box(n=4, seed=1):
    """A conforming box of hexahedra, wedge pairs (whole columns, so that their triangles meet) and
    six-pyramid hexahedra, in meshio's node order; field ``f`` linear."""
    img = pv.ImageData(dimensions=(n + 1,) * 3).cast_to_unstructured_grid()
    pts = np.asarray(img.points, float)
    hexes = img.cells_dict[pv.CellType.VOXEL][:, [0, 1, 3, 2, 4, 5, 7, 6]]
    rng = np.random.default_rng(seed)
    column = (pts[hexes[:, 0], 0] * (n + 1) + pts[hexes[:, 0], 1]).astype(int)
    wedge_columns = np.unique(column)[rng.random(np.unique(column).size) < 0.4]
    kind = np.where(np.isin(column, wedge_columns), 1, 2 * rng.integers(0, 2, len(hexes)))
    blocks, centres = {"hexahedron": [], "wedge": [], "pyramid": []}, []
    for h, k in zip(hexes, kind):
        if k == 0:
            blocks["hexahedron"].append(h)
        elif k == 1:  # meshio's (gmsh's) wedge: the bottom triangle turns towards the top one
            blocks["wedge"] += [h[[0, 1, 2, 4, 5, 6]], h[[0, 2, 3, 4, 6, 7]]]
        else:  # the base of a VTK pyramid turns towards its apex: the hexahedron's faces, inwards
            apex = len(pts) + len(centres)
            centres.append(pts[h].mean(axis=0))
            for f in ([0, 1, 2, 3], [4, 7, 6, 5], [0, 4, 5, 1], [1, 5, 6, 2], [2, 6, 7, 3], [3, 7, 4, 0]):
                blocks["pyramid"].append([*h[f], apex])
    pts = np.vstack([pts, *centres]) if centres else pts
    cells = [(t, np.array(c)) for t, c in blocks.items() if c]
    return meshio.Mesh(pts, cells, point_data={"f": pts @ [1.0, 0.7, 0.3]},
                       cell_data={"c": [np.full(len(c), float(i)) for i, (_, c) in enumerate(cells)]})


def test_mixed_cells_are_refused_naming_tetrahedralize(tmp_path):
    path = tmp_path / "mixed.vtu"
    _mixed_box().write(path)
    with pytest.raises(VolumeError, match="tetrahedralize=True") as err:
        UnstructuredVolume.read(path)
    assert "mixed.vtu" in str(err.value) and "wedge" in str(err.value) and "pyramid" in str(err.value)


@pytest.mark.parametrize("via", ["file", "meshio", "pyvista"])
def test_tetrahedralize_is_conforming(tmp_path, via):
    n = 4
    mesh = _mixed_box(n)
    path = tmp_path / "mixed.vtu"
    mesh.write(path)
    vol = {"file": lambda: UnstructuredVolume.read(path, tetrahedralize=True),
           "meshio": lambda: UnstructuredVolume.from_meshio(mesh, tetrahedralize=True),
           "pyvista": lambda: UnstructuredVolume.from_pyvista(pv.read(path), tetrahedralize=True)}[via]()
    assert vol.cell_type == "tetra"
    assert vio.cell_volumes(vol.points, vol.cells).sum() == pytest.approx(n ** 3, rel=1e-12)
    # conforming: every interior face is shared by two tetrahedra, so the boundary is the box's
    # 6 n^2 unit squares, two triangles each (a face split two ways would add inner boundary)
    f = vol.boundary_face_nodes
    p = vol.points[f]
    assert len(f) == 12 * n * n
    assert 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum() == pytest.approx(
        6 * n * n, rel=1e-12)
    # a linear field's isosurface is the plane's section of the box, as VTK contours the mixed mesh
    grid = pv.read(path)
    for c in (1.0, 2.5, 4.0):
        assert vol.isosurface(c, field="f", method="scan").area() == pytest.approx(
            grid.contour([c], scalars="f").area, rel=1e-9)


def test_tetrahedralize_keeps_cell_data(tmp_path):
    path = tmp_path / "mixed.vtu"
    _mixed_box().write(path)
    vol = UnstructuredVolume.read(path, tetrahedralize=True, cell_data="average")
    assert vol.cell_data_converted == ("c",)
    # each tetrahedron carries its parent's block number 0..2: the averages stay in that range
    assert vol.fields["c"].min() >= 0 and vol.fields["c"].max() <= 2


def test_tetrahedralize_must_be_a_bool():
    with pytest.raises(VolumeError, match="tetrahedralize must be True or False"):
        UnstructuredVolume.from_meshio(_mixed_box(), tetrahedralize="yes")


# ------------------------------------------------------------------ the command line

def test_cli_tetrahedralize(tmp_path, capsys):
    from polygen.cli import main
    from tests.test_cli_errors import _assert_one_line, _polygen

    path = tmp_path / "mixed.vtu"
    _mixed_box().write(path)
    line = _assert_one_line(_polygen("isosurface", path, "--no-files", "--no-compare-vtk", cwd=tmp_path),
                            "mixed.vtu", "wedge", "--tetrahedralize splits")
    assert "tetrahedralize=True" not in line
    assert main(["isosurface", str(path), "--tetrahedralize", "--method", "scan", "--value", "2.5",
                 "--no-files", "--no-compare-vtk", "--components"]) == 0
    text = capsys.readouterr().out
    assert "tetra cells" in text and "field 'f'" in text


def test_cli_cell_data(tmp_path, capsys):
    from polygen.cli import main
    from tests.test_cli_errors import _assert_one_line, _polygen

    _, _, path = _with_cell_data(tmp_path)
    _assert_one_line(_polygen("isosurface", path, "--field", "stress", cwd=tmp_path),
                     "'stress' is cell data", "--cell-data")
    assert main(["isosurface", str(path), "--cell-data", "--field", "stress", "--method", "scan", "--values", "3",
                 "--no-files", "--no-compare-vtk"]) == 0
    assert "field 'stress' (--field)" in capsys.readouterr().out


def test_cli_picture_is_one_surface_per_panel(tmp_path, capsys):
    import matplotlib.image

    from polygen.cli import main

    assert main(["isosurface", "torus", "--method", "scan", "--values", "20", "--no-compare-vtk",
                 "--output", str(tmp_path)]) == 0
    img = matplotlib.image.imread(tmp_path / "torus-isosurfaces.png")[..., :3]
    assert img.shape[:2] == (2 * 360, 3 * 420)  # six panels of the twenty surfaces
    # every panel shows its surface: pixels of a colour (the outline and the background are grey)
    chroma = img.max(axis=2) - img.min(axis=2)
    for r in range(2):
        for c in range(3):
            panel = chroma[r * 360:(r + 1) * 360, c * 420:(c + 1) * 420]
            assert (panel > 0.1).sum() > 500, (r, c)
    assert "wrote 20 surfaces" in capsys.readouterr().out

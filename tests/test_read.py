"""``UnstructuredVolume.read``: meshio first, pyvista for anything meshio cannot read, and every
reader failure a ``VolumeError`` naming the file (issue 19, item 5)."""

import logging

import meshio
import numpy as np
import pytest

from polygen.volume import UnstructuredVolume, VolumeError


def _random_bytes(path, n=4096, seed=0):
    path.write_bytes(np.random.default_rng(seed).bytes(n))
    return path


@pytest.mark.parametrize("name", ["corrupt.msh", "corrupt.vtu", "corrupt.vtk", "corrupt.xdmf"])
def test_corrupt_bytes_are_a_volume_error_naming_the_file(tmp_path, capfd, name):
    path = _random_bytes(tmp_path / name)
    handlers = list(logging.root.handlers)
    with pytest.raises(VolumeError) as err:  # never SystemExit (meshio ends a failed read with sys.exit)
        UnstructuredVolume.read(path)
    msg = str(err.value)
    assert str(path) in msg and "meshio" in msg and "pyvista" in msg and "\n" not in msg
    out, errtext = capfd.readouterr()
    assert out == "" and errtext == ""  # neither reader (nor VTK) printed anything
    assert logging.root.handlers == handlers  # nor left a logging handler behind


def test_text_file_directory_and_missing_file(tmp_path, capfd):
    txt = tmp_path / "notes.txt"
    txt.write_text("not a mesh\n")
    with pytest.raises(VolumeError, match="notes.txt"):
        UnstructuredVolume.read(txt)
    with pytest.raises(VolumeError, match="is a directory"):
        UnstructuredVolume.read(tmp_path)
    with pytest.raises(VolumeError, match="no such file") as err:
        UnstructuredVolume.read(tmp_path / "missing.vtu")
    assert "missing.vtu" in str(err.value)
    assert capfd.readouterr() == ("", "")


def test_a_valid_file_without_volume_cells_names_the_file(tmp_path):
    path = tmp_path / "triangles.vtu"
    meshio.Mesh(np.eye(3), [("triangle", np.array([[0, 1, 2]]))]).write(path)
    with pytest.raises(VolumeError, match="only tetrahedra or only hexahedra") as err:
        UnstructuredVolume.read(path)
    assert "triangles.vtu" in str(err.value)


def test_legacy_vtk_that_meshio_misreads_falls_back_to_pyvista():
    pv = pytest.importorskip("pyvista")
    from pyvista import examples

    path = examples.hexbeamfile  # ships with pyvista; meshio fails on it with KeyError 'vtktypeint64'
    with pytest.raises(KeyError):
        meshio.read(path)  # the reproducer: if meshio learns to read it, the fallback is untested here
    vol = UnstructuredVolume.read(path)
    grid = pv.read(path)
    assert vol.cell_type == "hexa" and vol.n_cells == grid.n_cells == 40
    np.testing.assert_array_equal(vol.points, np.asarray(grid.points))
    np.testing.assert_array_equal(vol.cells, np.asarray(grid.cell_connectivity).reshape(-1, 8))
    np.testing.assert_array_equal(vol.fields["sample_point_scalars"], grid.point_data["sample_point_scalars"])
    assert vol.cell_data_names == ("sample_cell_scalars",)  # not a field: the CLI says so when asked for it


def test_meshio_round_trip_still_reads(tmp_path):
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    path = tmp_path / "tet.vtu"
    meshio.Mesh(pts, [("tetra", np.array([[0, 1, 2, 3]]))], point_data={"f": pts[:, 0]}).write(path)
    vol = UnstructuredVolume.read(path)
    assert vol.n_cells == 1 and vol.cell_type == "tetra"
    np.testing.assert_array_equal(vol.fields["f"], pts[:, 0])

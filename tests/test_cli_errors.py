"""The ``polygen`` command on bad input: one line on stderr, exit status 2, no traceback unless
``--debug`` (issue 19, item 6). The command runs as a subprocess, as a user runs it."""

import os
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
PTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
GOOD = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])  # cell 1 (1,2,3,4) has positive volume too
INVERTED = GOOD[:, [0, 2, 1, 3]]  # two nodes swapped: negative volume in VTK order


def _polygen(*args, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))  # this checkout's polygen
    return subprocess.run([sys.executable, "-m", "polygen.cli", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def _write(path, cells, field="f"):
    meshio.Mesh(PTS, [("tetra", cells)], point_data={field: PTS.sum(axis=1)}).write(path)
    return path


def _assert_one_line(res, *words):
    lines = res.stderr.splitlines()
    assert res.returncode == 2, res.stderr
    assert len(lines) == 1 and lines[0].startswith("polygen isosurface: "), res.stderr
    assert "Traceback" not in res.stderr and res.stdout == ""
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


def _bad_inputs(tmp):
    text = tmp / "notes.txt"
    text.write_text("not a mesh\n")
    directory = tmp / "adir"
    directory.mkdir()
    corrupt = tmp / "corrupt.msh"
    corrupt.write_bytes(np.random.default_rng(0).bytes(4096))
    tri = tmp / "triangles.vtu"
    meshio.Mesh(PTS[:3], [("triangle", np.array([[0, 1, 2]]))]).write(tri)
    good = _write(tmp / "good.vtu", GOOD)
    inverted = _write(tmp / "inverted.vtu", INVERTED)
    return {
        "text file": ([text], ["notes.txt"]),
        "directory": ([directory], ["adir", "directory"]),
        "random bytes as .msh": ([corrupt], ["corrupt.msh"]),
        "triangles only": ([tri], ["triangles.vtu", "tetrahedra"]),
        "unknown field": ([good, "--field", "nope"], ["'nope'", "node fields are f"]),
        "unknown method": ([good, "--method", "nope"], ["'nope'", "scan"]),
        "inverted cells": ([inverted], ["inverted", "--orient"]),
        "no such file or data set": ([tmp / "missing.vtu"], ["missing.vtu", "data set"]),
        "no values": ([good, "--values", "0"], ["--values"]),
    }


CASES = ["text file", "directory", "random bytes as .msh", "triangles only", "unknown field",
         "unknown method", "inverted cells", "no such file or data set", "no values"]


@pytest.mark.parametrize("case", CASES)
def test_bad_input_is_one_line_and_exit_2(tmp_path, case):
    args, words = _bad_inputs(tmp_path)[case]
    line = _assert_one_line(_polygen("isosurface", *args, "--no-files", "--no-compare-vtk", cwd=tmp_path), *words)
    assert "orient=True" not in line  # no advice the CLI cannot follow


def test_debug_shows_the_traceback(tmp_path):
    args, _ = _bad_inputs(tmp_path)["inverted cells"]
    res = _polygen("isosurface", *args, "--debug", cwd=tmp_path)
    assert res.returncode != 0 and "Traceback" in res.stderr and "VolumeError" in res.stderr


def test_orient_reorders_inverted_cells(tmp_path):
    inverted = _write(tmp_path / "inverted.vtu", INVERTED)
    res = _polygen("isosurface", inverted, "--orient", "--method", "scan", "--values", "2",
                   "--no-files", "--no-compare-vtk", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "scan" in res.stdout and "Traceback" not in res.stderr


def test_datasets_into_a_closed_pipe_is_quiet(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.Popen([sys.executable, "-m", "polygen.cli", "datasets"], cwd=tmp_path, env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()  # the reader is gone before the command writes a byte (as `| head` after its lines)
    _, err = p.communicate(timeout=300)
    assert err.decode() == ""  # no BrokenPipeError traceback, no "Exception ignored" at exit
    assert p.returncode == 1


def test_help_has_examples(tmp_path):
    for cmd in ("isosurface", "datasets"):
        res = _polygen(cmd, "--help", cwd=tmp_path)
        assert res.returncode == 0 and "examples:" in res.stdout and f"polygen {cmd} " in res.stdout


def test_default_field_skips_id_arrays():
    from polygen.cli.isosurface import choose_field
    from polygen.volume import UnstructuredVolume

    x = PTS.sum(axis=1)
    ids = np.arange(len(PTS))
    fields = {"vtkOriginalPointIds": ids, "GlobalNodeId": ids.astype(float), "temperature": x, "stress": -x}
    vol = UnstructuredVolume(PTS, GOOD, fields)
    field, how = choose_field(vol)
    assert field == "temperature" and "vtkOriginalPointIds, GlobalNodeId" in how
    assert choose_field(vol, "stress") == ("stress", "--field")
    only_ids = UnstructuredVolume(PTS, GOOD, {"ids": ids})
    assert choose_field(only_ids)[0] == "ids"  # nothing better: contour what there is


def test_cell_data_asked_for_is_named(tmp_path):
    from pyvista import examples

    # point data: sample_point_scalars, VTKorigID (int64 ids); cell data: sample_cell_scalars
    path = examples.hexbeamfile
    res = _polygen("isosurface", path, "--method", "scan", "--values", "2", "--no-files", "--no-compare-vtk",
                   cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "field 'sample_point_scalars' (the first field; --field to pick another)" in res.stdout
    line = _assert_one_line(_polygen("isosurface", path, "--field", "sample_cell_scalars", cwd=tmp_path),
                            "'sample_cell_scalars' is cell data", "sample_point_scalars")
    assert "no field" not in line


# ------------------------------------------- issue 43, item 7: outputs checked before the work
@pytest.mark.parametrize("case", ["output under a file", "output is a file", "json into a missing folder",
                                  "json is a folder", "read-only output"])
def test_unwritable_outputs_are_refused_before_any_work(tmp_path, case):
    """One line, exit status 2, and nothing on stdout: no volume loaded, no surface extracted, no VTK log."""
    good = _write(tmp_path / "good.vtu", GOOD)
    (tmp_path / "notes.txt").write_text("a file\n")
    (tmp_path / "adir").mkdir()
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o555)
    if case == "read-only output" and os.access(locked, os.W_OK):  # root writes into mode 555 folders
        pytest.skip("the tests run as root: a read-only folder is writable")
    args, words = {
        "output under a file": (["--output", tmp_path / "notes.txt" / "out"], ["--output", "notes.txt"]),
        "output is a file": (["--output", tmp_path / "notes.txt"], ["--output", "not a folder"]),
        "json into a missing folder": (["--no-files", "--json", tmp_path / "nope" / "t.json"],
                                       ["--json", "does not exist"]),
        "json is a folder": (["--no-files", "--json", tmp_path / "adir"], ["--json", "a folder"]),
        "read-only output": (["--output", locked / "out"], ["--output", "cannot write"]),
    }[case]
    res = _polygen("isosurface", good, "--method", "scan", "--values", "2", "--no-compare-vtk", *args, cwd=tmp_path)
    _assert_one_line(res, *words)


def test_vtk_log_stays_off_the_terminal(tmp_path):
    """A surface file VTK cannot open (a folder of its name is in the way): without --debug, one line
    on stderr, none of VTK's error log."""
    good = _write(tmp_path / "good.vtu", GOOD)
    (tmp_path / "out" / "good.vtu-iso00.vtp").mkdir(parents=True)
    res = _polygen("isosurface", good, "--method", "scan", "--value", "1.5", "--no-compare-vtk",
                   "--output", tmp_path / "out", cwd=tmp_path)
    lines = res.stderr.splitlines()
    assert res.returncode == 2 and len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    assert lines[0].startswith("polygen isosurface: --output") and "in the way" in lines[0], lines[0]

"""The ``polygen`` command line on small volumes."""

import json

import numpy as np
import pytest

from polygen.cli import main
from polygen.volume import datasets, methods


def test_isosurface_runs_every_method_and_agrees_with_vtk(tmp_path, capsys):
    out = tmp_path / "r.json"
    rc = main(["isosurface", "torus", "--values", "4", "--json", str(out), "--output", str(tmp_path / "o")])
    assert rc == 0
    res = json.loads(out.read_text())
    assert set(res["methods"]) == set(methods.names())
    tris = {m["triangles"] for m in res["methods"].values()}
    assert len(tris) == 1 and all(m["same_as_first"] for m in res["methods"].values())
    # tetrahedra: the same number of triangles as VTK's contour filter
    assert res["vtk_triangles"] == tris.pop() > 0
    assert res["methods"]["scan"]["cells_tested"] == 4 * datasets.load("torus").n_cells
    assert list((tmp_path / "o").glob("*.vtp")) and list((tmp_path / "o").glob("*.png"))
    text = capsys.readouterr().out
    assert "scan" in text and "VTK" in text
    # the default (fastest) method first, and timed again several values at a time
    assert list(res["methods"])[0] == methods.default() == "active-scan"
    # extract_many timed where a method runs values side by side (the edge-centred table's threads)
    assert res["methods"]["edge-centred-table"]["many_s"] > 0 and res["methods"]["scan"]["many_s"] is None
    assert "at a time (extract_many)" in text


def test_isosurface_on_a_mesh_file_with_an_empty_value(tmp_path, capsys):
    vol = datasets.load("hollow_cube_hex")
    path = tmp_path / "part.vtu"
    vol.to_meshio().write(path)
    s = vol.scalars()
    rc = main(["isosurface", str(path), "--value", str(s.max() + 1), "--value", str(np.median(s)),
               "--method", "scan", "--method", "span-space", "--no-compare-vtk", "--no-files"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "empty surface (0 triangles" in text


def test_isosurface_bad_arguments(tmp_path, capsys):
    # one line on stderr and exit status 2 (tests/test_cli_errors.py runs the command as a process)
    assert main(["isosurface", "torus", "--method", "nope", "--no-files"]) == 2
    assert capsys.readouterr().err == (f"polygen isosurface: unknown method 'nope'; the methods are "
                                       f"{', '.join(methods.names())}\n")
    assert main(["isosurface", str(tmp_path / "missing.vtu")]) == 2
    assert "neither a file nor a data set" in capsys.readouterr().err
    with pytest.raises(ValueError, match="unknown method 'nope'"):  # --debug: the exception itself
        main(["isosurface", "torus", "--method", "nope", "--no-files", "--debug"])


def test_warm_up_helper_started_early_ends_without_work():
    # a first run starts the warm-up's helper before the volume loads; when the command then stops (a bad
    # field, one method) the helper gets no work and must end by itself, not wait for ever
    from polygen.cli import isosurface

    proc = isosurface._start_helper()
    isosurface._end_helper(proc)
    assert proc.returncode == 0


def test_warm_up_compiles_the_topology_kernels_a_large_volume_takes():
    # the main job times the topology after the warm-up: a volume whose node -> cells lists take the parallel
    # sort must find _stable_csr compiled for its cells (int32, read-only), not compile it inside that timing
    from polygen.cli import isosurface
    from polygen.volume import UnstructuredVolume, _topology

    n_cells = _topology._SERIAL_BELOW // 4 + 10
    assert isosurface._large_items(n_cells) == [isosurface._LARGE]
    isosurface._run_tiny(None, isosurface._LARGE, None, n_cells)
    before = list(_topology._stable_csr.signatures)
    rng = np.random.default_rng(0)
    points = rng.random((4 * n_cells, 3))
    cells = np.arange(4 * n_cells).reshape(n_cells, 4)  # disjoint tetrahedra, oriented below
    vol = UnstructuredVolume(points, cells, orient=True)
    _topology.node_cells_csr(vol.cells, vol.n_points)
    assert vol.cells.dtype == np.int32 and not vol.cells.flags.writeable
    assert list(_topology._stable_csr.signatures) == before


_NEW_SIGNATURES = r"""
import sys
import numpy as np
from numba.core.registry import CPUDispatcher
from polygen.cli import isosurface
from polygen.volume import UnstructuredVolume, datasets


def signatures():
    return {(m, k): len(v.signatures) for m, mod in list(sys.modules.items()) if m.startswith("polygen")
            for k, v in list(vars(mod).items()) if isinstance(v, CPUDispatcher)}


d = datasets.load("data1")
vol = UnstructuredVolume(d.points, d.cells, {"f": d.points[:, 0].copy()})
isosurface._warm_up(["active-scan"], vol.cell_type, helper=False, n_cells=vol.n_cells)
before = signatures()
isosurface._build_topology(vol)
after = signatures()
print(sorted(k[1] for k in after if after[k] != before.get(k, 0)))
"""


def test_warm_up_of_one_method_compiles_the_topology_the_command_builds():
    # `polygen isosurface --method active-scan` builds the whole topology before timing the method; the warm-up must
    # have run every kernel of it (else its first run compiled 14 kernels, 9.5 s, inside the topology's line).
    # In a process of its own: this one has built topologies already
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", _NEW_SIGNATURES], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]", out.stdout + out.stderr

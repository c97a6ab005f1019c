"""Volume model: time to build face adjacency, edges and boundary topology.

Issue target: face adjacency for a 2M-tet volume in < 3 s. Uses the ``2M``
data set when ``polygen.volume.datasets`` can build it, else a triangulated
74^3 grid (2.03M tets).

    python benchmarks/volume.py
"""

import sys
import time

import numpy as np

from _common import write_results
from polygen.volume import UnstructuredVolume


def volumes():
    try:
        from polygen.volume import datasets

        yield "2M (gmsh part)", lambda: datasets.load("2M")
    except Exception as exc:  # the data-set module may not be there yet
        print(f"no 2M data set ({exc}); using a triangulated grid", file=sys.stderr)
    import pyvista as pv

    yield "grid 74^3 x 5 tets", lambda: UnstructuredVolume.from_pyvista(pv.ImageData(dimensions=(75, 75, 75)).triangulate(), orient=True)


def main():
    # compile every kernel once on a small volume so that timings exclude JIT
    import pyvista as pv

    small = UnstructuredVolume.from_pyvista(pv.ImageData(dimensions=(4, 4, 4)).triangulate(), orient=True)
    small.face_neighbors, small.boundary_groups, small.edge_cells, small.node_cells
    rows = []
    for label, make in volumes():
        vol = make()
        fresh = UnstructuredVolume(vol.points, vol.cells, validate=False)
        row = {"volume": label, "cells": vol.n_cells, "nodes": vol.n_points}
        t0 = time.perf_counter()
        UnstructuredVolume(vol.points, vol.cells)
        row["construct+validate_s"] = time.perf_counter() - t0
        for name in ["face_neighbors", "boundary_groups", "edges", "edge_cells", "node_cells"]:
            t0 = time.perf_counter()
            getattr(fresh, name)
            row[f"{name}_s"] = time.perf_counter() - t0
        row["boundary_faces"] = len(fresh.boundary_faces)
        row["genus"] = int(fresh.n_through_holes)
        row["voids"] = int(fresh.n_voids)
        rows.append(row)
        print(row)
    cols = ["volume", "cells", "nodes", "construct+validate_s", "face_neighbors_s", "boundary_groups_s",
            "edges_s", "edge_cells_s", "node_cells_s", "boundary_faces", "genus", "voids"]
    path = write_results("volume", rows, cols, title="Volume model: adjacency and topology build times (s)",
                         notes=["target: face adjacency of 2M tets < 3 s"])
    print(path.read_text())


if __name__ == "__main__":
    main()

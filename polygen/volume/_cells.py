"""The cell tables: one copy of each, for every module of :mod:`polygen.volume`.

Local faces, edges and corners of the VTK tetrahedron and hexahedron, and the
Kuhn (Freudenthal) split of a hexahedron into six tetrahedra. This module is
the bottom layer of the package: it imports nothing of ours, and the kernels,
the mesh, the marching tables, the data sets, the plots and the tests all take
their tables from here.
"""

import numpy as np

__all__ = [
    "TET_FACES",
    "HEX_FACES",
    "TET_EDGES",
    "HEX_EDGES",
    "TET_UNIT_CORNERS",
    "HEX_UNIT_CORNERS",
    "HEX_CORNER_FRAMES",
    "KUHN_TETS",
    "index_dtype",
]


def index_dtype(n):
    """The dtype of ids below ``n`` (node ids in cells and edges): int32 when they fit, int64 past 2**31.

    One dtype in practice, so that each kernel is compiled once: a volume's
    ``cells`` and ``edges`` and the cell arrays the array-level functions
    take are converted to it.
    """
    return np.int32 if n <= np.iinfo(np.int32).max + 1 else np.int64

#: (4, 3) local faces of a VTK tetrahedron, outward for a positive cell (Def. 5.3 face numbers).
TET_FACES = np.array([[0, 1, 3], [1, 2, 3], [2, 0, 3], [0, 2, 1]], np.int64)
#: (6, 4) local faces of a VTK hexahedron, outward for a positive cell.
HEX_FACES = np.array([[0, 4, 7, 3], [1, 2, 6, 5], [0, 1, 5, 4],
                      [3, 7, 6, 2], [0, 3, 2, 1], [4, 5, 6, 7]], np.int64)
#: (6, 2) local edges of a VTK tetrahedron.
TET_EDGES = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]], np.int64)
#: (12, 2) local edges of a VTK hexahedron.
HEX_EDGES = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4],
                      [0, 4], [1, 5], [2, 6], [3, 7]], np.int64)

#: (4, 3) int64 corners of the positive reference tetrahedron, in VTK node order.
TET_UNIT_CORNERS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.int64)
#: (8, 3) int64 corners of the unit cube, in VTK hexahedron node order.
HEX_UNIT_CORNERS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                             [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], np.int64)

#: (8, 4) each hexahedron corner, then its neighbours along r, s, t in a right-handed
#: order: the frames of the corner Jacobians.
HEX_CORNER_FRAMES = np.array([[0, 1, 3, 4], [1, 2, 0, 5], [2, 3, 1, 6], [3, 0, 2, 7],
                              [4, 7, 5, 0], [5, 4, 6, 1], [6, 5, 7, 2], [7, 6, 4, 3]], np.int64)

#: (6, 4) the Kuhn (Freudenthal) split of a hexahedron into six positive tetrahedra around
#: its diagonal 0-6, as local hexahedron nodes: a fan around the diagonal. The same split
#: in every cube of a structured grid is conforming.
KUHN_TETS = np.array([[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]],
                     np.int64)

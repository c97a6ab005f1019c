"""Tiny volumes whose topology can be checked by hand: one and two cells, a ring, a hollow cube, a block with three holes."""

from __future__ import annotations

import numpy as np

from polygen.volume._cells import HEX_UNIT_CORNERS, KUHN_TETS
from polygen.volume.datasets.fields import distance_field, gaussian_field


# ----------------------------------------------------------- tiny volumes
def _grid_volume(keep, cell_type):
    """Unit-cube grid over the ``True`` cells of ``keep`` (nx, ny, nz), compacted."""
    keep = np.asarray(keep, bool)
    nx, ny, nz = keep.shape
    ix, iy, iz = np.nonzero(keep)
    corner = ix[:, None] + HEX_UNIT_CORNERS[:, 0]
    cy = iy[:, None] + HEX_UNIT_CORNERS[:, 1]
    cz = iz[:, None] + HEX_UNIT_CORNERS[:, 2]
    hexes = (corner * (ny + 1) + cy) * (nz + 1) + cz
    gx, gy, gz = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1), indexing="ij")
    points = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1).astype(np.float64)
    cells = hexes if cell_type == "hexa" else hexes[:, KUHN_TETS].reshape(-1, 4)
    used, inverse = np.unique(cells, return_inverse=True)
    return points[used], inverse.reshape(cells.shape).astype(np.int64)


def _orient_tets(points, cells):
    """Swap nodes 1 and 2 of negative tetrahedra so that every cell is positive in VTK order."""
    p = points[cells]
    vol6 = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    neg = vol6 < 0
    cells = cells.copy()
    cells[neg, 1], cells[neg, 2] = cells[neg, 2], cells[neg, 1].copy()
    return cells


def _tiny(kind, cell_type):
    if kind == "one":
        if cell_type == "tetra":
            points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float64)
            cells = np.array([[0, 1, 2, 3]], np.int64)
        else:
            return _grid_volume(np.ones((1, 1, 1)), "hexa")
    elif kind == "two":
        if cell_type == "tetra":
            # two tetrahedra sharing the face (1, 2, 3), on both sides of the plane x + y + z = 1
            points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], np.float64)
            cells = np.array([[0, 1, 2, 3], [4, 1, 3, 2]], np.int64)
        else:
            return _grid_volume(np.ones((2, 1, 1)), "hexa")
    elif kind == "torus":
        keep = np.ones((3, 3, 1), bool)
        keep[1, 1, 0] = False
        points, cells = _grid_volume(keep, cell_type)
    elif kind == "hollow_cube":
        keep = np.ones((3, 3, 3), bool)
        keep[1, 1, 1] = False
        points, cells = _grid_volume(keep, cell_type)
    elif kind == "genus3":
        keep = np.ones((7, 3, 1), bool)
        keep[[1, 3, 5], 1, 0] = False
        points, cells = _grid_volume(keep, cell_type)
    else:  # pragma: no cover - registry and builders are defined together
        raise AssertionError(kind)
    if cell_type == "tetra":
        cells = _orient_tets(points, cells)
    return points, cells


def _tiny_fields(points, seed):
    # hand-checkable: a linear field with no ties on integer grids, the distance from
    # the default eye, and three Gaussian bumps
    linear = points[:, 0] + 0.31 * points[:, 1] + 0.097 * points[:, 2]
    return {
        "linear": linear,
        "distance": distance_field(points),
        "gaussians": gaussian_field(points, n_bumps=3, seed=seed, width=0.5),
    }

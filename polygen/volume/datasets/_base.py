"""What every data-set module shares: the error, the info record, the cache format version, argument checks."""

from __future__ import annotations

import dataclasses

import numpy as np



#: Version of the cache format and of the generators; bump it when either
#: changes, so that stale cache files are not read.
FORMAT_VERSION = 2  # 2: cached volumes renumbered along a Morton curve
#: Environment variable that overrides the cache directory.
CACHE_ENV = "POLYGEN_CACHE_DIR"


class DatasetError(ValueError):
    """A data set request is malformed (unknown name or field, bad seed)."""


@dataclasses.dataclass(frozen=True)
class DatasetInfo:
    """What a data set is and what its construction implies.

    Attributes
    ----------
    name : str
    cell_type : str
        ``"tetra"`` or ``"hexa"``.
    target_cells : int
        Number of cells aimed at (the built mesh is within 5 % for the
        meshed parts, exact for the tiny volumes).
    genus : tuple of int
        Genus of each boundary-face group as :class:`UnstructuredVolume`
        numbers them: the outer surface first, then the voids.
    n_voids : int
        Number of internal voids.
    n_through_holes : int
        Sum of the genera (Def. 5.8).
    fields : tuple of str
        Names of the node fields; the first is the default.
    description : str
    thesis : dict
        The thesis's numbers this data set stands in for (cells, nodes,
        boundary cells, extrema), empty when there are none.
    cached : bool
        Whether :func:`load` caches the volume on disk (the tiny volumes
        are built on the fly).
    """

    name: str
    cell_type: str
    target_cells: int
    genus: tuple
    n_voids: int
    n_through_holes: int
    fields: tuple
    description: str
    thesis: dict = dataclasses.field(default_factory=dict)
    cached: bool = True


def _as_points(points):
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] == 0:
        raise DatasetError(f"points must have shape (N, 3) with N > 0; got {points.shape}")
    return np.ascontiguousarray(points)


def _seed(seed):
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise DatasetError(f"seed must be a non-negative integer; got {seed!r}")
    return int(seed)

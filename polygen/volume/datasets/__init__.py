"""Reproducible volume data sets: FEM parts, analytic fields, tiny volumes.

The thesis measured its methods on five tetrahedral volumes that came out of
finite-element analyses (Tables 6.1 and 7.1: 20736, 61680, 346644, 557868 and
458664 cells). Those volumes are not available, so this module makes volumes
of the same kind and size here, deterministically, and caches them on disk:

* **FEM volumes** ``"data1"`` .. ``"data5"``, ``"2M"``, ``"10M"``: gmsh
  meshes (OpenCASCADE geometry, HXT 3D algorithm, one thread so that the
  mesh is the same on every run) of mechanical-looking parts with
  through-holes and internal voids, carrying the node temperature of a
  steady heat-conduction problem solved with scikit-fem: Dirichlet patches
  on some holes and faces, Gaussian heat sources and sinks inside (so that
  there are interior maxima and minima, and isosurfaces that are closed as
  well as ones that end on the boundary). Data 5 adds a random heat load on
  every node, which gives thousands of extrema as in Table 7.1.
* **Hexahedral volumes** ``"hexa1"`` .. ``"hexa3"``: plates and a flange
  with round through-holes and closed voids. gmsh meshes the cross-section
  (holes and void footprints included) with quadrilaterals only (Blossom
  full-quad recombination), and the quads are stacked in layers; the
  hexahedra over a void footprint in the void's layers are left out. The
  mesh is unstructured in plan and follows the curved holes. (gmsh's
  tetrahedron-to-four-hexahedra subdivision was tried first: its distorted
  hexahedra gave the trilinear FEM field hundreds of spurious extrema on the
  boundary.) The FEM field is solved with trilinear hexahedra
  (``ElementHex1``).
* **Analytic fields** on every volume: ``"gaussians"``, a seeded sum of
  Gaussian bumps with many extrema, and ``"distance"``, the distance from a
  point outside the volume (the equi-distance surfaces of thesis 7.8).
* **Tiny volumes** for tests, whose topology can be checked by hand: one
  and two tetrahedra or hexahedra, a ring (genus 1), a hollow cube (one
  void) and a block with three holes (genus 3), as tetrahedra and as
  hexahedra.

Everything is a pure function of the data set's name and the ``seed``: the
geometry and the mesh depend on the name only, the seed moves the heat
sources, the random loads and the Gaussian bumps. Nothing is downloaded.

Built volumes are cached as uncompressed ``.npz`` files under
:func:`cache_dir` (``platformdirs.user_cache_dir("polygen")/volumes``, or
``$POLYGEN_CACHE_DIR``), keyed by the name, the seed, the build parameters
and :data:`FORMAT_VERSION`, and written atomically.

Examples
--------
>>> from polygen.volume import datasets
>>> vol = datasets.load("torus")
>>> vol.cell_type, int(vol.group_genus[0])
('tetra', 1)

The package, module by module: :mod:`~polygen.volume.datasets.registry` (the
names, :func:`info`, :func:`build`, :func:`load` and the cache),
:mod:`~polygen.volume.datasets.fields` (analytic fields, node extrema, the
kernels and the PCG solver), :mod:`~polygen.volume.datasets.tiny`,
:mod:`~polygen.volume.datasets.parts` (the CAD parts),
:mod:`~polygen.volume.datasets.meshing` (gmsh) and
:mod:`~polygen.volume.datasets.fem` (the heat-conduction fields).
"""

from polygen.volume.datasets._base import CACHE_ENV, FORMAT_VERSION, DatasetError, DatasetInfo
from polygen.volume.datasets.fields import (
    count_extrema,
    distance_field,
    distance_origin,
    gaussian_field,
    node_extrema,
)
from polygen.volume.datasets.registry import build, cache_dir, cache_path, info, is_cached, load, names

__all__ = [
    "FORMAT_VERSION",
    "CACHE_ENV",
    "DatasetError",
    "DatasetInfo",
    "names",
    "info",
    "load",
    "build",
    "cache_dir",
    "cache_path",
    "is_cached",
    "node_extrema",
    "count_extrema",
    "gaussian_field",
    "distance_field",
    "distance_origin",
]

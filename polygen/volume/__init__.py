"""Isosurfaces on unstructured volumes (thesis chapters 5-7, the 2001 paper).

The package is layered; imports point one way only (CONTRIBUTING.md):
tables (``_cells``) -> kernels (``_topology``, ``marching``, ``_*_kernels``)
-> the mesh (``mesh``, ``registry``) -> the result and validation
(``surface``) -> search structures (``seeds``) -> constructions
(``propagate``, ``isosurface``, ``edge_centred``'s builder) -> chapter
algorithms and methods (``methods``, ``homology``, ``extrema_graph``,
``thinning``, ``edge_centred``, ``active_scan``). Data sets (``datasets``) build on the mesh.

Importing this package imports every module that registers a method or a
seed source (:mod:`polygen.volume.registry`), so that the registries are
complete; nothing probes for them.
"""

from polygen.volume.mesh import UnstructuredVolume, VolumeError, VolumeWarning
from polygen.volume.surface import IsoSurface, IsoSurfaceError, isovalues

# the modules that register methods and seed sources, bottom up
from polygen.volume import methods  # noqa: E402,F401  isort: skip
from polygen.volume import extrema_graph  # noqa: E402,F401  isort: skip
from polygen.volume import thinning  # noqa: E402,F401  isort: skip
from polygen.volume import edge_centred  # noqa: E402,F401  isort: skip
from polygen.volume import active_scan  # noqa: E402,F401  isort: skip

__all__ = ["UnstructuredVolume", "VolumeError", "VolumeWarning", "IsoSurface", "IsoSurfaceError", "isovalues"]

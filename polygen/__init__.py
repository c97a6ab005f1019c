"""polygen: polygon generation for computer graphics, after T. Itoh.

Two halves:

* ``polygen.volume`` -- isosurfaces on unstructured tetrahedral and
  hexahedral volumes (thesis chapters 5-7 and the 2001 paper);
* ``polygen.radiosity`` and ``polygen.mesh2d`` -- radiosity meshing
  (thesis chapters 2-4).

Figures live in ``polygen.plotting`` and the command line in
``polygen.cli``; no algorithm imports either (``tests/test_layout.py``).
CONTRIBUTING.md describes the layers.
"""

__version__ = "0.1.0"

from polygen.volume.mesh import UnstructuredVolume, VolumeError  # noqa: E402

__all__ = ["UnstructuredVolume", "VolumeError", "__version__"]

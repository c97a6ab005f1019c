"""Isosurfaces on unstructured volumes (thesis chapters 5-7, the 2001 paper)."""

from polygen.volume.mesh import UnstructuredVolume, VolumeError, VolumeWarning

__all__ = ["UnstructuredVolume", "VolumeError", "VolumeWarning"]

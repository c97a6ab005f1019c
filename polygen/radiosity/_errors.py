"""The radiosity mesh's error class, below both the mesh and its layouts (no import cycle)."""


class MeshError(ValueError):
    """Inconsistent patch/element/node arrays, or a mesh that cannot be made as asked."""

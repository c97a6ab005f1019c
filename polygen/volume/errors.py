"""The volume package's error and warning classes, below every module that raises them (no import cycle).

Re-exported where users meet them: :mod:`polygen.volume.mesh` (and
:mod:`polygen.volume`) for :class:`VolumeError` and :class:`VolumeWarning`,
:mod:`polygen.volume.surface` for :class:`IsoSurfaceError`.
"""


class VolumeError(ValueError):
    """A volume's input is malformed; the message names what and where."""


class VolumeWarning(UserWarning):
    """Something in a volume is suspicious but usable (e.g. unreferenced nodes)."""


class IsoSurfaceError(ValueError):
    """Bad arguments to an isosurface extraction (the message says which)."""

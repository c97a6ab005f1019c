"""Volume rendering of unstructured volumes (thesis 7.8): ray casting and translucent equi-distance surfaces.

* :mod:`~polygen.volume.render.raycast`: rays enter through the boundary,
  walk cell to cell through face neighbours (re-entering behind holes and
  voids), sample at equal spacing and composite by (7.1) with (7.2).
* :mod:`~polygen.volume.render.shells`: Koyamada's method sped up by
  volume thinning (7.8.2-7.8.3): the distance from the eye (7.3) is a node
  field, its equi-distance surfaces are isosurfaces built from its thinning
  skeleton by the edge-centred construction, and they are drawn translucent
  far to near. A :class:`ShellRenderer` rebuilds the skeleton only when the
  eye moves.
* :mod:`~polygen.volume.render.view`, :mod:`~polygen.volume.render.transfer`:
  the view and the transfer functions, and the optical models both
  renderers take (:data:`OPTICAL_MODELS`: ``"opacity"``, ours, the table's
  opacity is that of a slab ``unit`` thick; ``"attenuation"``, VTK's, the
  table's opacity per ``unit`` is the attenuation coefficient).
"""

from polygen.volume.render.view import View, RenderError, view_around
from polygen.volume.render.raycast import RayCaster, RenderResult, boundary_triangles, raycast
from polygen.volume.render.shells import ShellRenderer, Shells, eye_distance, foreground, psnr
from polygen.volume.render.transfer import OPTICAL_MODELS, Lighting, TransferFunction

__all__ = [
    "RenderError",
    "View",
    "view_around",
    "TransferFunction",
    "Lighting",
    "RenderResult",
    "RayCaster",
    "raycast",
    "boundary_triangles",
    "eye_distance",
    "Shells",
    "ShellRenderer",
    "psnr",
    "foreground",
    "OPTICAL_MODELS",
]

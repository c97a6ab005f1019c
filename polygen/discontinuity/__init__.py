"""Chapter 3: simplified discontinuity meshing with shadow polyhedra.

* :mod:`~polygen.discontinuity.shadow` -- shadow polyhedra (3.3.1) and
  their sections on receivers (:class:`ShadowSection`).
* :mod:`~polygen.discontinuity.complex` -- the receiver complex (3.3.2);
  :mod:`~polygen.discontinuity.walk` -- the intersection walk (3.3.3);
  :mod:`~polygen.discontinuity.loops` -- loop rebuilding (3.3.4);
  :mod:`~polygen.discontinuity.states` -- illumination states (3.3.5) and
  the output to the mesh model (3.3.6).
"""

from polygen.discontinuity.complex import ComplexError, ReceiverComplex
from polygen.discontinuity.shadow import (
    Polyhedron,
    ShadowError,
    ShadowPolyhedra,
    ShadowSection,
    polyhedron_section,
    scene_sections,
    shadow_polyhedron,
    shadow_sections,
)
from polygen.discontinuity.states import (
    BRIGHT,
    PENUMBRA,
    UMBRA,
    UNPROCESSED,
    discontinuity_segments,
    receiver_complex,
    region_points,
    region_size,
)

__all__ = ["Polyhedron", "ShadowError", "ShadowPolyhedra", "ShadowSection", "polyhedron_section",
           "scene_sections", "shadow_polyhedron", "shadow_sections",
           "ComplexError", "ReceiverComplex", "receiver_complex", "discontinuity_segments",
           "region_points", "region_size", "UNPROCESSED", "BRIGHT", "PENUMBRA", "UMBRA"]

"""Chapter 3: simplified discontinuity meshing with shadow polyhedra.

* :mod:`~polygen.discontinuity.shadow` -- shadow polyhedra (3.3.1) and
  their sections on receivers (:class:`ShadowSection`).
"""

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

__all__ = ["Polyhedron", "ShadowError", "ShadowPolyhedra", "ShadowSection", "polyhedron_section",
           "scene_sections", "shadow_polyhedron", "shadow_sections"]

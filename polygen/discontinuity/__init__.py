"""Chapter 3: simplified discontinuity meshing with shadow polyhedra.

* :mod:`~polygen.discontinuity.shadow` -- shadow polyhedra (3.3.1) and
  their sections on receivers (:class:`ShadowSection`).
"""

from polygen.discontinuity.shadow import ShadowError, ShadowSection, scene_sections, shadow_sections

__all__ = ["ShadowError", "ShadowSection", "shadow_sections", "scene_sections"]

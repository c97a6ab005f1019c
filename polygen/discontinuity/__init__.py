"""Chapter 3: simplified discontinuity meshing with shadow polyhedra.

* :mod:`~polygen.discontinuity.shadow` -- shadow polyhedra (3.3.1, Defs
  3.2-3.4: the umbra by the smallest-angle planes, the penumbra by
  gift-wrapping) and their sections on receivers (:class:`ShadowSection`),
  for a whole scene by :func:`scene_sections`;
* :mod:`~polygen.discontinuity.concave` -- concave occluders, exact: the
  umbra of a whole planar polygon under an area light (its convex pieces'
  umbrae miss what the whole hides but no piece does);
* :mod:`~polygen.discontinuity.solids` -- closed convex solids (the sphere)
  as one occluder: their polyhedra from the silhouette;
* :mod:`~polygen.discontinuity.scene_index` -- the bounding-volume
  hierarchy that keeps the receiver tests sub-quadratic;
* :mod:`~polygen.discontinuity.complex` -- the receiver complex (3.3.2);
  :mod:`~polygen.discontinuity.walk` -- the intersection walk (3.3.3);
  :mod:`~polygen.discontinuity.loops` -- loop rebuilding (3.3.4);
  :mod:`~polygen.discontinuity.states` -- illumination states (3.3.5) and
  the output to the mesh model (3.3.6);
  :mod:`~polygen.discontinuity.simplified` -- the whole method on a scene;
  :mod:`~polygen.discontinuity.illumination` -- each point's state per light
  (and its visible fraction), the phase's answer for any point;
  :mod:`~polygen.discontinuity.meshing` -- lines, regions, patches and elements
  (3.3.6) by the simplified or the conventional method;
  :mod:`~polygen.discontinuity.combined` -- chapter 8's future work: these
  lines and chapter 4's intensity-based bubble mesh together;
* :mod:`~polygen.discontinuity.conventional` -- the baseline of 2.4.3:
  all EV and VE critical surfaces on a receiver;
* :mod:`~polygen.discontinuity.bsp` -- the 2-D BSP split of a receiver
  (Figs 2.10, 3.4(b)).
"""

from polygen.discontinuity.bsp import BSPRegions, bsp_split
from polygen.discontinuity.complex import ComplexError, ReceiverComplex
from polygen.discontinuity.concave import umbra_pieces, umbra_region
from polygen.discontinuity.conventional import (
    CriticalSegments,
    conventional_bsp,
    conventional_segments,
    critical_surfaces,
    ev_ve_planes,
    plane_roles,
    section_segments,
    unique_planes,
)
from polygen.discontinuity.shadow import (
    Polyhedron,
    SceneShadows,
    ShadowError,
    ShadowPolyhedra,
    ShadowWarning,
    ShadowSection,
    polyhedron_section,
    scene_lights,
    scene_sections,
    section_edge_planes,
    shadow_polyhedron,
    shadow_sections,
)
from polygen.discontinuity.solids import check_solid, clip_solid, convex_solids, solid_shadow_polyhedron
from polygen.discontinuity.states import (
    BRIGHT,
    PENUMBRA,
    UMBRA,
    UNPROCESSED,
    discontinuity_segments,
    receiver_complex,
    region_points,
    region_size,
    state_areas,
)
from polygen.discontinuity.simplified import SimplifiedDiscontinuity, illumination, simplified_discontinuity
from polygen.discontinuity.combined import combined_bubble_mesh
from polygen.discontinuity.illumination import light_fraction
from polygen.discontinuity.meshing import (
    DiscontinuityRecord,
    MeshingError,
    conventional_discontinuity,
    discontinuity_mesh,
    element_states,
)

__all__ = [
    "BRIGHT",
    "BSPRegions",
    "ComplexError",
    "CriticalSegments",
    "DiscontinuityRecord",
    "MeshingError",
    "PENUMBRA",
    "Polyhedron",
    "ReceiverComplex",
    "SceneShadows",
    "ShadowError",
    "ShadowPolyhedra",
    "ShadowWarning",
    "ShadowSection",
    "SimplifiedDiscontinuity",
    "UMBRA",
    "UNPROCESSED",
    "umbra_pieces",
    "umbra_region",
    "bsp_split",
    "check_solid",
    "clip_solid",
    "combined_bubble_mesh",
    "conventional_bsp",
    "conventional_discontinuity",
    "conventional_segments",
    "convex_solids",
    "critical_surfaces",
    "discontinuity_mesh",
    "ev_ve_planes",
    "plane_roles",
    "unique_planes",
    "element_states",
    "illumination",
    "light_fraction",
    "discontinuity_segments",
    "polyhedron_section",
    "receiver_complex",
    "region_points",
    "region_size",
    "scene_lights",
    "scene_sections",
    "section_edge_planes",
    "section_segments",
    "shadow_polyhedron",
    "solid_shadow_polyhedron",
    "shadow_sections",
    "state_areas",
    "simplified_discontinuity",
]

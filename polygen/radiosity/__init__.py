"""Radiosity (thesis chapter 2): scenes, patches/elements, form factors, solvers, display.

Layers, each usable on its own (chapters 3 and 4 build on them):

* :mod:`~polygen.radiosity.scene` -- planar polygons with holes, area,
  point and parallel lights (Def. 2.1); :mod:`~polygen.radiosity.scenes`
  -- the Cornell box and the thesis's scenes;
* :mod:`~polygen.radiosity.mesh` -- patches, elements, nodes (Defs 2.2-2.4)
  and pluggable per-polygon meshers (lattice Delaunay, bubble mesh);
* :mod:`~polygen.radiosity.layout` -- the mesh model of chapters 3 and 4:
  constrained D0/D1 segments, regions and their sizes, conforming edges;
* :mod:`~polygen.radiosity.formfactor` (Lambert's contour formula, ray-cast
  visibility) and :mod:`~polygen.radiosity.hemicube` (2.2.1);
* :mod:`~polygen.radiosity.solve` -- progressive refinement (2.2.2) and
  Gauss-Seidel (2.3);
* :mod:`~polygen.radiosity.raster` -- node intensities (2.8) and a Gouraud
  scanline z-buffer (2.9, 2.10);
* :mod:`~polygen.radiosity.adaptive` -- adaptive subdivision of elements
  (Def. 2.6), the baseline of chapters 3 and 4;
* :mod:`~polygen.radiosity.intensity` -- chapter 4's intensity-based
  bubble mesh: intensity variation, size function, size grids, the
  two-pass loop;
* :mod:`~polygen.radiosity.error` -- image error against a reference, and
  the error-vs-elements curves of uniform meshes and adaptive subdivision
  (the yardstick of chapters 3 and 4).
"""

from polygen.radiosity.adaptive import (
    AdaptiveRefinement,
    adaptive_refine,
    element_jumps,
    mark_jumps,
)
from polygen.radiosity.error import (
    ErrorPoint,
    adaptive_curve,
    image_error,
    shade,
    uniform_curve,
)
from polygen.radiosity.formfactor import (
    FormFactorError,
    analytic_column,
    point_polygon_form_factor,
    polygon_form_factor,
)
from polygen.radiosity.hemicube import (
    HemicubeError,
    delta_form_factors,
    hemicube_form_factors,
    hemicube_polygon_form_factor,
)
from polygen.radiosity.intensity import (
    IntensityMesh,
    intensity_bubble_mesh,
    intensity_variation,
    polygon_size_grids,
    size_function,
)
from polygen.radiosity.layout import (
    D0,
    D1,
    RegionSize,
    Segments,
    contact_segments,
    polygon_layout,
)
from polygen.radiosity.mesh import (
    MeshError,
    RadiosityMesh,
    assemble_mesh,
    bubble_element_mesher,
    bubble_mesher,
    lattice_delaunay_mesher,
    mesh_scene,
    split_triangles,
)
from polygen.radiosity.raster import (
    Camera,
    RasterError,
    auto_exposure,
    node_intensities,
    render,
    tone_map,
    to_pyvista,
)
from polygen.radiosity.scene import (
    AreaLight,
    ParallelLight,
    PointLight,
    Polygon,
    Scene,
    SceneError,
)
from polygen.radiosity.solve import (
    RadiosityResult,
    SolverError,
    form_factor_matrix,
    furnace_error,
    gauss_seidel,
    progressive_refinement,
)

__all__ = [
    "IntensityMesh",
    "intensity_bubble_mesh",
    "intensity_variation",
    "polygon_size_grids",
    "size_function",
    "D0",
    "D1",
    "RegionSize",
    "Segments",
    "contact_segments",
    "polygon_layout",
    "AdaptiveRefinement",
    "AreaLight",
    "Camera",
    "ErrorPoint",
    "FormFactorError",
    "HemicubeError",
    "MeshError",
    "ParallelLight",
    "PointLight",
    "Polygon",
    "RadiosityMesh",
    "RadiosityResult",
    "RasterError",
    "Scene",
    "SceneError",
    "SolverError",
    "adaptive_curve",
    "adaptive_refine",
    "analytic_column",
    "auto_exposure",
    "assemble_mesh",
    "bubble_element_mesher",
    "bubble_mesher",
    "delta_form_factors",
    "element_jumps",
    "form_factor_matrix",
    "furnace_error",
    "gauss_seidel",
    "hemicube_form_factors",
    "hemicube_polygon_form_factor",
    "image_error",
    "lattice_delaunay_mesher",
    "mark_jumps",
    "mesh_scene",
    "node_intensities",
    "point_polygon_form_factor",
    "polygon_form_factor",
    "progressive_refinement",
    "render",
    "shade",
    "split_triangles",
    "to_pyvista",
    "tone_map",
    "uniform_curve",
]

"""2-D meshing for radiosity (thesis chapter 2.3-2.4), reusable by chapters 3 and 4.

A planar domain is an outer polygon (counter-clockwise) plus holes
(clockwise), each a ``(K, 2) float64`` array; :func:`validate_domain` checks
it with shapely.

* :func:`triangulate_domain`, :func:`constrained_delaunay` -- constrained
  Delaunay (2.3.2) with ``pythoncdt``.
* :func:`bubble_mesh` -- the bubble mesh (2.3.3), uniform or graded by a
  size field (:mod:`polygen.mesh2d.sizing`); with ``edge_init="tree"``,
  ``init="quadtree"``, ``neighbours="delaunay"`` the intensity-based bubble
  mesh's placement and relaxation (4.3.3; :mod:`polygen.mesh2d.tree_placement`:
  :func:`binary_tree_edge_bubbles`, :func:`quadtree_cells`, :func:`quadtree_face_bubbles`).
* :mod:`polygen.mesh2d.theorem41` -- Theorem 4.1: :func:`edge_length_ratio`,
  :func:`packed_edge_ratio` and its bounds.
* :func:`planar_graph`, :func:`mesh_planar_graph` -- a polygon cut by
  constrained segments (D0/D1) into regions, meshed with conforming nodes
  on every edge; :func:`convex_partition` (Hertel-Mehlhorn).
* :func:`element_size_grid` -- the element-size grid of chapter 4 (4.5):
  inverse-distance weights near the nodes, a thin plate bent through them
  elsewhere (:mod:`polygen.mesh2d.plate`, the 12-DOF ACM element, 4.6-4.10).
* :func:`triangle_quality`, :func:`quality_histogram` -- min angle and
  radius ratio.
* :func:`subdivide_patches` (regular 1 -> 4), :func:`bubble_subdivide_patches`
  (a finer bubble mesh constrained by the patch edges), :func:`adaptive_subdivision`,
  :func:`is_t_vertex_free` -- patches/elements (Defs 2.2-2.5) and adaptive
  subdivision (Def. 2.6).
"""

from polygen.mesh2d.bubble import (
    BubbleMesh,
    bubble_force,
    bubble_mesh,
    bubble_subdivide_patches,
    edge_bubbles,
    locate_in_triangles,
)
from polygen.mesh2d.delaunay import Mesh2D, constrained_delaunay, triangulate_domain
from polygen.mesh2d.domain import (
    Domain,
    InvalidDomainError,
    points_in_domain,
    signed_area,
    validate_domain,
)
from polygen.mesh2d.plate import PlateError, assemble_plate, plate_element_stiffness, solve_plate
from polygen.mesh2d.pslg import (
    D0,
    D1,
    GraphMesh,
    PlanarGraph,
    convex_partition,
    edge_node_parameters,
    merge_close_segments,
    mesh_planar_graph,
    planar_graph,
)
from polygen.mesh2d.quality import (
    mesh_edges,
    quality_histogram,
    quality_summary,
    triangle_areas,
    triangle_quality,
)
from polygen.mesh2d.size_grid import assign_grid_sizes, element_size_grid, grid_lattice
from polygen.mesh2d.sizing import GridSize, as_size_function, uniform_size
from polygen.mesh2d.subdivision import (
    AdaptiveSubdivision,
    PatchElements,
    adaptive_subdivision,
    find_t_vertices,
    is_t_vertex_free,
    refine_marked,
    subdivide_patches,
    triangle_edges,
)
from polygen.mesh2d.theorem41 import (
    edge_length_ratio,
    packed_edge_ratio,
    packed_edge_ratio_bounds,
    vertex_size_ratio,
)
from polygen.mesh2d.tree_placement import (
    binary_tree_edge_bubbles,
    quadtree_cells,
    quadtree_face_bubbles,
)

__all__ = [
    "D0",
    "D1",
    "PlateError",
    "assemble_plate",
    "assign_grid_sizes",
    "element_size_grid",
    "grid_lattice",
    "plate_element_stiffness",
    "solve_plate",
    "GraphMesh",
    "PlanarGraph",
    "convex_partition",
    "merge_close_segments",
    "edge_node_parameters",
    "mesh_planar_graph",
    "planar_graph",
    "AdaptiveSubdivision",
    "BubbleMesh",
    "Domain",
    "GridSize",
    "InvalidDomainError",
    "Mesh2D",
    "PatchElements",
    "adaptive_subdivision",
    "as_size_function",
    "bubble_force",
    "bubble_mesh",
    "bubble_subdivide_patches",
    "binary_tree_edge_bubbles",
    "edge_length_ratio",
    "packed_edge_ratio",
    "packed_edge_ratio_bounds",
    "quadtree_cells",
    "quadtree_face_bubbles",
    "vertex_size_ratio",
    "constrained_delaunay",
    "edge_bubbles",
    "find_t_vertices",
    "is_t_vertex_free",
    "locate_in_triangles",
    "mesh_edges",
    "points_in_domain",
    "quality_histogram",
    "quality_summary",
    "refine_marked",
    "signed_area",
    "subdivide_patches",
    "triangle_areas",
    "triangle_edges",
    "triangle_quality",
    "triangulate_domain",
    "uniform_size",
    "validate_domain",
]

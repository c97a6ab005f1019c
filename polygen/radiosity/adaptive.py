"""Adaptive subdivision of radiosity elements (thesis Def. 2.6, Fig. 2.8).

After a first radiosity solution, elements whose radiosity differs from an
edge neighbour's by more than a threshold are split; neighbours are split at
the same time so that no T-vertex (Def. 2.5) appears.  The thesis does not
say how; by default :func:`polygen.mesh2d.refine_marked` bisects a marked
element twice along longest edges (about 1 -> 4 in area) and its neighbours
along their longest edges (Rivara's LEPP), which keeps the smallest angle
at least half of the first mesh's however many rounds are repeated; the
red-green closure (``method="red-green"``) degrades the angles round after
round.  Patches are kept: every child element stays in its parent's patch
(a bisection never crosses an element, and an element edge on a patch edge
is split on both sides), so the shooting side of progressive refinement is
unchanged and only the gathering side gets finer.  Then the radiosity is
solved again.

This is the h-method baseline that chapters 3 (discontinuity meshing) and
4 (intensity-based bubble mesh) are compared against.  Elements of
different polygons share no nodes, so jumps across polygon edges (a wall
meeting the floor) are not marks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from polygen.mesh2d import refine_marked, triangle_edges
from polygen.radiosity.mesh import MeshError, RadiosityMesh, assemble_mesh

__all__ = ["AdaptiveRefinement", "element_jumps", "mark_jumps", "adaptive_refine", "bright_scale"]


@dataclass(frozen=True, eq=False)
class AdaptiveRefinement:
    """Result of :func:`adaptive_refine`.

    Attributes
    ----------
    mesh : RadiosityMesh
        The refined mesh (same patches, finer elements).
    parent : (M2,) int64
        The element of the input mesh that each new element lies in.
    marked : (M,) bool
        Elements of the input mesh marked by the threshold (before the
        closure that keeps the mesh conforming).
    """

    mesh: RadiosityMesh
    parent: np.ndarray
    marked: np.ndarray

    @property
    def n_marked(self):
        return int(self.marked.sum())


def _face_piece(mesh, k, side):
    """One face of polygon k in local node numbering.

    Returns (global nodes, elements, patches, local node sites, element ids, patch ids); the
    triangles are counter-clockwise in the polygon's (u, v) frame (a back face's are stored
    reversed).
    """
    el = np.flatnonzero((mesh.element_polygon == k) & (mesh.element_side == side))
    pa = np.flatnonzero((mesh.patch_polygon == k) & (mesh.patch_side == side))
    used = np.unique(np.concatenate([mesh.elements[el].ravel(), mesh.patches[pa].ravel()]))
    local = np.full(mesh.n_nodes, -1, dtype=np.int64)
    local[used] = np.arange(len(used))
    site = local[mesh.node_site[used]]
    # a D0 copy whose site lies on another face keeps itself as its site
    site = np.where(site >= 0, site, np.arange(len(used)))
    tris, ptris = local[mesh.elements[el]], local[mesh.patches[pa]]
    if side < 0:
        tris, ptris = tris[:, ::-1], ptris[:, ::-1]
    return used, tris, ptris, site, el, pa


def element_jumps(mesh, element_values):
    """Largest value difference between each element and its edge neighbours.

    Parameters
    ----------
    mesh : RadiosityMesh
    element_values : (M,) or (M, C) float64
        E.g. element radiosities; the largest channel difference counts.

    Returns
    -------
    (M,) float64
        0 for an element without neighbours.
    """
    v = np.asarray(element_values, dtype=np.float64)
    v = v.reshape(len(v), -1)
    if v.shape[0] != mesh.n_elements:
        raise MeshError(f"element_values must have {mesh.n_elements} rows, got {v.shape[0]}")
    if not np.all(np.isfinite(v)):
        raise MeshError("element_values contain NaN or inf")
    # edges of the element mesh: nodes are shared within a polygon only, so an
    # edge used twice joins two elements of the same polygon
    _, tri_edge = triangle_edges(mesh.elements)
    flat = tri_edge.ravel()
    order = np.argsort(flat, kind="stable")
    fs = flat[order]
    pair = np.flatnonzero(fs[1:] == fs[:-1])
    t1 = order[pair] // 3
    t2 = order[pair + 1] // 3
    d = np.abs(v[t1] - v[t2]).max(axis=1)
    out = np.zeros(mesh.n_elements)
    np.maximum.at(out, t1, d)
    np.maximum.at(out, t2, d)
    return out


def mark_jumps(mesh, element_values, threshold, *, min_area=0.0):
    """Elements whose value differs from an edge neighbour's by more than ``threshold``.

    Parameters
    ----------
    mesh : RadiosityMesh
    element_values : (M,) or (M, C) float64
        E.g. element radiosities; the largest channel difference counts.
    threshold : float
        Absolute difference that marks both elements of an edge.
    min_area : float, keyword-only
        Elements not larger than this are never marked (stops the refinement
        at a true discontinuity).

    Returns
    -------
    (M,) bool
    """
    if not (np.isfinite(threshold) and threshold >= 0):
        raise MeshError(f"threshold must be finite and >= 0, got {threshold}")
    return (element_jumps(mesh, element_values) > threshold) & (mesh.element_area > min_area)


def adaptive_refine(mesh, element_values, threshold, *, min_area=0.0, marked=None,
                    method="longest-edge"):
    """One round of adaptive subdivision (Def. 2.6): split elements across big jumps.

    Parameters
    ----------
    mesh : RadiosityMesh
    element_values : (M,) or (M, C) float64
        The first solution's element radiosities.
    threshold : float
        Split both elements of an edge whose values differ by more than this
        (largest RGB channel).
    min_area : float, keyword-only
        Do not split elements of this area or smaller.
    marked : (M,) bool, keyword-only
        Use these marks instead of the threshold test.
    method : {"longest-edge", "red-green"}, keyword-only
        The conforming refinement (:func:`polygen.mesh2d.refine_marked`):
        marked elements bisected twice along longest edges, neighbours along
        theirs; or marked elements split 1 -> 4 and the closure splitting
        neighbours 1 -> 4 or 1 -> 2.

    Returns
    -------
    AdaptiveRefinement
        Conforming within every polygon.
    """
    if not isinstance(mesh, RadiosityMesh):
        raise MeshError(f"mesh must be a RadiosityMesh, got {type(mesh).__name__}")
    if method not in ("longest-edge", "red-green"):
        raise MeshError(f"method must be 'longest-edge' or 'red-green', got {method!r}")
    if marked is None:
        marked = mark_jumps(mesh, element_values, threshold, min_area=min_area)
    marked = np.asarray(marked, dtype=np.bool_).reshape(-1)
    if marked.shape != (mesh.n_elements,):
        raise MeshError(f"marked must have {mesh.n_elements} flags, got {marked.shape}")
    pieces = []
    parents = []
    patch_order = []
    for k, poly in enumerate(mesh.scene.polygons):
        faces = []
        for side in ((1, -1) if poly.two_sided else (1,)):
            used, el_local, pa_local, site, el, pa = _face_piece(mesh, k, side)
            pts2 = poly.to_2d(mesh.nodes[used])
            patch_local = np.full(mesh.n_patches, -1, dtype=np.int64)
            patch_local[pa] = np.arange(len(pa))
            try:
                n2, t2, par, _ = refine_marked(pts2, el_local, marked[el], method=method)
            except ValueError as err:
                raise MeshError(f"polygon {k} ({poly.name!r}): {err}") from None
            # new nodes are their own sites: a bisection never crosses a D0 line
            site2 = np.concatenate([site, np.arange(len(site), len(n2))])
            faces.append((n2, pa_local, t2, patch_local[mesh.element_patch[el[par]]], site2))
            parents.append(el[par])
            patch_order.append(pa)
        pieces.append(tuple(faces) if poly.two_sided else faces[0])
    new = assemble_mesh(mesh.scene, pieces)
    if mesh.patch_region is not None:
        new.layouts = mesh.layouts
        new.patch_region = mesh.patch_region[np.concatenate(patch_order)]
    return AdaptiveRefinement(new, np.concatenate(parents).astype(np.int64), marked)


def bright_scale(mesh, radiosity):
    """The radiosity of the bright surfaces: the 95th percentile over non-emitting elements.

    The scale that a relative adaptive-subdivision threshold multiplies,
    as in :func:`polygen.radiosity.error.adaptive_curve`.
    """
    b = np.asarray(radiosity, dtype=np.float64)
    lit = ~(mesh.element_emission > 0).any(axis=1)
    return float(np.percentile(b[lit].max(axis=1), 95.0)) if lit.any() else float(b.max())

"""Simplified discontinuity meshing and the intensity-based bubble mesh combined.

The thesis closes chapter 4 (4.5) with this as future work: mesh along the
discontinuity lines that simplified discontinuity meshing finds (chapter 3,
:func:`~polygen.discontinuity.simplified_discontinuity`), and size the
elements between them by the intensity variation of a first solution
(:func:`~polygen.radiosity.intensity_bubble_mesh`).  Both meshes of the
two-pass loop keep the lines as constrained segments (D0: nodes duplicated
across, D1: shared); the size grid is built per region, from the nodes of
that region only, so that the plate never carries the fine size of a shadow
boundary across a D0 line into the light or the umbra beside it.

Lines much closer to each other (or to the polygon's edge) than the finest
element are merged first (:func:`polygen.mesh2d.merge_close_segments`), as
the thesis proposes among its future work (chapter 8: delete discontinuity
lines lying much closer than the element size): the penumbra bands of the
Fig. 4.8 scene are 0.04 wide, and a band that narrow meshed at patch size
1.7-2.4 gives triangles of 2 degrees.  What merging leaves narrower than its
size (a line meeting a wall near a corner, a wedge between two lines) gets
its size capped by the region's local width
(:func:`polygen.mesh2d.region_width.region_width`), graded so that the
neighbours of a capped spot follow it.
"""

from __future__ import annotations

import numpy as np

from polygen.discontinuity.simplified import simplified_discontinuity
from polygen.mesh2d import merge_close_segments
from polygen.radiosity.intensity import intensity_bubble_mesh
from polygen.radiosity.layout import Segments
from polygen.radiosity.scene import Scene, SceneError

__all__ = ["combined_bubble_mesh", "merged_lines"]


def merged_lines(scene, segments, *, gap):
    """Every polygon's discontinuity lines with those closer than ``gap`` merged.

    Parameters
    ----------
    scene : Scene
    segments : mapping {polygon index: Segments}
        E.g. :attr:`SimplifiedDiscontinuity.segments`.
    gap : float, keyword-only
        :func:`polygen.mesh2d.merge_close_segments`'s distance, >= 0.

    Returns
    -------
    dict {polygon index: Segments}
        2-D segments in each polygon's frame; a polygon left without lines
        has no entry.
    """
    out = {}
    for k, sg in segments.items():
        poly = scene.polygons[k]
        ends, kinds = sg.in_plane(poly)
        ends, kinds, _ = merge_close_segments(poly.exterior_2d, poly.holes_2d, ends, kinds, gap=gap)
        if len(ends):
            out[k] = Segments(np.asarray(ends), kinds)
    return out


def combined_bubble_mesh(scene, *, size_initial, size_min, size_max, discontinuity=None,
                         merge_gap=None, width_cap=True, **kwargs):
    """The two-pass loop of Fig. 4.3 on a mesh cut by the scene's discontinuity lines.

    Parameters
    ----------
    scene : Scene
    size_initial, size_min, size_max : float, keyword-only
        As :func:`~polygen.radiosity.intensity_bubble_mesh` (patch sizes;
        ``size_max < size_initial < size_min``).
    discontinuity : SimplifiedDiscontinuity or None, keyword-only
        The scene's discontinuity phase; None: computed here.
    merge_gap : float or None, keyword-only
        Lines closer than this to each other or to a polygon's edge are
        merged (:func:`merged_lines`); None: half the finest element's size,
        ``size_max / 2**element_levels / 2`` ("much closer than the element
        size", chapter 8); 0: the lines as found.
    width_cap : bool, keyword-only
        Cap every region's size by its local width, never below the finest element's size
        ``size_max / 2**element_levels`` (twice the default merge gap: elements of a strip
        as narrow as merging leaves are as long as it is wide), and let sizes grow from a
        cap by at most 0.5 per unit length
        (:func:`~polygen.radiosity.intensity.width_capped_sizes`), in both meshes; False:
        the size grids as they are (regions narrower than their size get slivers).  The cap
        costs elements: on the scene of Fig. 4.8 at ``size_initial`` 2.4 the first mesh has
        2440 elements instead of 1288 (smallest angle 12.3 degrees instead of 6.9), and the
        image error per element is worse (benchmarks/results/intensity_mesh.md).
    **kwargs
        Other keywords of :func:`~polygen.radiosity.intensity_bubble_mesh`
        (``grid``, ``element_levels``, ``seed``, ``solve``, ``first`` ...).

    Returns
    -------
    IntensityMesh
        Its ``parameters["segments"]`` are the lines used (after merging);
        both meshes have regions (``element_region``).

    Raises
    ------
    SceneError
        ``scene`` is not a Scene, or ``discontinuity`` is of another scene.
    MeshError
        As :func:`~polygen.radiosity.intensity_bubble_mesh`.
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"scene must be a Scene, got {type(scene).__name__}")
    if discontinuity is None:
        discontinuity = simplified_discontinuity(scene)
    elif discontinuity.scene is not scene:
        raise SceneError("discontinuity was computed for another scene")
    if "segments" in kwargs:
        raise TypeError("combined_bubble_mesh takes its segments from the discontinuity phase")
    if merge_gap is None:
        merge_gap = 0.5 * float(size_max) / 2 ** int(kwargs.get("element_levels", 1))
    lines = discontinuity.segments
    if merge_gap > 0:
        first = kwargs.get("first")
        if first is not None and first.parameters.get("merge_gap") == merge_gap:
            lines = first.parameters["segments"]   # the same merged lines, for `first=`
        else:
            lines = merged_lines(scene, discontinuity.segments, gap=merge_gap)
    floor = float(size_max) / 2 ** int(kwargs.get("element_levels", 1)) if width_cap else None
    run = intensity_bubble_mesh(scene, size_initial=size_initial, size_min=size_min,
                                size_max=size_max, segments=lines, width_floor=floor, **kwargs)
    run.parameters["merge_gap"] = float(merge_gap)
    return run

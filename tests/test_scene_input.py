"""Bad input to scenes and meshes (issue 13, part 5): it meshes, or it raises a clear error.

Never a raw error from the triangulation library: before, a repeated vertex
or a hole touching the outer ring reached pythoncdt, which raised
``RuntimeError: Duplicate vertex detected ... Triangulation.hpp``.
"""

import numpy as np
import pytest

from polygen.mesh2d import InvalidDomainError, validate_domain
from polygen.radiosity import Polygon, RegionSize, Scene, SceneError, Segments
from polygen.radiosity.mesh import (
    MeshError,
    bubble_mesher,
    lattice_delaunay_mesher,
    mesh_scene,
)

SQ = [[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0]]
MESHERS = [lattice_delaunay_mesher, bubble_mesher]


def _meshes_exactly(poly, mesher):
    m = mesh_scene(Scene([poly]), 0.5, mesher=mesher)
    assert m.element_area.sum() == pytest.approx(poly.area, rel=1e-12)
    assert len(m.t_vertices()) == 0
    return m


@pytest.mark.parametrize("mesher", MESHERS, ids=["lattice", "bubble"])
def test_repeated_vertex_meshes(mesher):
    poly = Polygon([[0, 0, 0], [4, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0], [0, 0, 0]], name="rep")
    assert len(poly.vertices) == 4
    _meshes_exactly(poly, mesher)


@pytest.mark.parametrize("mesher", MESHERS, ids=["lattice", "bubble"])
def test_hole_touching_outer_ring_meshes(mesher):
    poly = Polygon(SQ, [[[0, 0, 0], [1, 2, 0], [2, 1, 0]]], name="touch")
    assert poly.area == pytest.approx(16.0 - 1.5)
    _meshes_exactly(poly, mesher)


def test_hole_cutting_polygon_in_two_is_a_scene_error():
    # a hole touching the ring at two points disconnects the interior
    with pytest.raises(SceneError, match="pinched: invalid polygon .Interior is disconnected"):
        Polygon(SQ, [[[0, 0, 0], [4, 4, 0], [3, 1, 0]]], name="pinched")


def test_touching_holes_accepted_only_on_request():
    outer = np.array(SQ, dtype=float)[:, :2]
    hole = [[0, 0], [1, 2], [2, 1]]
    with pytest.raises(InvalidDomainError, match="hole 0"):
        validate_domain(outer, [hole])
    dom = validate_domain(outer, [hole], allow_touching=True)
    assert dom.area == pytest.approx(14.5)
    with pytest.raises(InvalidDomainError, match="overlaps"):
        validate_domain(outer, [[[1, 1], [3, 1], [3, 3]], [[2, 1.5], [3.5, 1.5], [3.5, 3.5]]],
                        allow_touching=True)


@pytest.mark.parametrize("kw,match", [
    (dict(emission=[1.0, 2.0]), "emission must be a number or 3 RGB numbers"),
    (dict(emission=[[1.0, 1.0, 1.0]]), "emission must be a number or 3 RGB numbers"),
    (dict(reflectance=[0.1, 0.2, 0.3, 0.4]), "reflectance must be a number or 3 RGB numbers"),
    (dict(reflectance="grey"), "reflectance must be a number or 3 RGB numbers"),
    (dict(reflectance=1.5), "reflectance must be <= 1"),
    (dict(emission=-1.0), "emission must be finite and >= 0"),
])
def test_material_errors_name_the_polygon(kw, match):
    with pytest.raises(SceneError, match=f"wall: {match}"):
        Polygon(SQ, name="wall", **kw)


def _mesh_with(segs, kinds="D1", **kw):
    poly = Polygon(SQ, name="floor")
    return mesh_scene(Scene([Polygon(SQ, name="other", two_sided=True), poly]), 1.0,
                      segments={"floor": Segments(segs, kinds)}, **kw)


@pytest.mark.parametrize("segs,kinds,match", [
    ([[[1, 1, 0], [5, 5, 0]]], "D1", r"segment 0 .*outside the polygon"),
    ([[[1, 1, 0], [2, 2, 0]], [[1, 1, 1], [2, 2, 1]]], "D1", "segment 1: off the polygon's plane"),
    ([[[1, 1, 0], [3, 3, 0]], [[1, 3, 0], [3, 1, 0]]], "D0", "segments 0 and 1 cross without a common vertex"),
    ([[[1, 1, 0], [1, 1, 0]]], "D1", "segment 0: degenerate"),
    ([[[1, 1, 0], [2, 2, 0]]], "D2", "segment 0: kind must be 'D0' or 'D1'"),
    ([[[1, 1, 0], [np.nan, 2, 0]]], "D1", "segment 0: non-finite"),
])
def test_bad_segments_name_polygon_and_segment(segs, kinds, match):
    with pytest.raises(MeshError, match=r"polygon 1 \('floor'\): " + match):
        _mesh_with(segs, kinds)


def test_segments_crossing_at_a_common_vertex_are_fine():
    # crossing through each other's end points / meeting at a vertex is a planar graph
    m = _mesh_with([[[1, 1, 0], [3, 3, 0]], [[1, 3, 0], [2, 2, 0]], [[2, 2, 0], [3, 1, 0]]], "D0")
    assert len(m.t_vertices()) == 0


def test_other_mesh_scene_errors():
    s = Scene([Polygon(SQ, name="floor")])
    with pytest.raises(MeshError, match="no polygon 'ceiling'"):
        mesh_scene(s, 1.0, segments={"ceiling": Segments([[[1, 1, 0], [2, 2, 0]]])})
    with pytest.raises(MeshError, match="patch_size must be > 0"):
        mesh_scene(s, -1.0)
    with pytest.raises(MeshError, match="patch_size for polygon 0 .*expected a number"):
        mesh_scene(s, ["big"])
    with pytest.raises(MeshError, match="need one entry per polygon"):
        mesh_scene(s, [1.0, 2.0])
    seg = Segments([[[2, 0, 0], [2, 4, 0]]], "D0")
    with pytest.raises(MeshError, match=r"polygon 0 \('floor'\): RegionSize: 1 sizes for 2 regions"):
        mesh_scene(s, RegionSize([1.0]), segments=[seg])
    with pytest.raises(MeshError, match="no size for region .* and no default"):
        mesh_scene(s, RegionSize([1.0], at=[[1, 1, 0]]), segments=[seg])
    with pytest.raises(MeshError, match="point 0 is outside the polygon"):
        mesh_scene(s, RegionSize([1.0], at=[[9, 9, 0]], default=0.5), segments=[seg])
    m = mesh_scene(s, RegionSize([0.5], at=[[1, 1, 0]], default=1.0), segments=[seg])
    assert m.n_elements > 0

    def custom(exterior, holes, size):
        return lattice_delaunay_mesher(exterior, holes, size)

    with pytest.raises(MeshError, match="segments and RegionSize need"):
        mesh_scene(s, 1.0, mesher=custom, segments=[seg])
    with pytest.raises(MeshError, match="lattice Delaunay mesh: invalid polygon"):
        lattice_delaunay_mesher(np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]), [], 0.2)

"""The light's visibility on a discontinuity mesh against the region states (3.3.5) and brute force.

An element of a discontinuity mesh lies wholly in one region of its
receiver (the region edges are constrained segments), so where the region is
bright every ray from the element to the light is free and where it is umbra
every such ray is blocked: the solver's visibility estimate there must be
exact, whatever its number of rays.  The oracle is ray casting: many rays
from points spread over each element to points spread over the light.
"""

import copy

import numpy as np
import pytest

from polygen.discontinuity import BRIGHT, PENUMBRA, UMBRA, element_states, simplified_discontinuity
from polygen.discontinuity.meshing import MeshingError, discontinuity_mesh
from polygen.radiosity import mesh_scene, scenes
from polygen.radiosity.formfactor import analytic_column, box_tree, pack_polygons, segments_visible

# barycentric points spread over a triangle (its vertices pulled in by 1e-6 of the
# element: a vertex may lie on a region edge, where a ray grazes an occluder's edge)
_B = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5],
               [1 / 3, 1 / 3, 1 / 3], [2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6],
               [1 / 6, 1 / 6, 2 / 3]])
_B = (1 - 1e-6) * _B + 1e-6 / 3


@pytest.fixture(scope="module")
def room():
    sc = scenes.two_rectangles_room()
    sd = simplified_discontinuity(sc)
    mesh = discontinuity_mesh(sc, patch_size=3.3, penumbra_patch_size=1.1, discontinuity=sd)
    return sc, sd, mesh


def _light_points(sc, light):
    """(L, 3) points spread over the light's patches (barycentric points of each)."""
    lm = mesh_scene(sc, 0.5, element_levels=0)
    tri = lm.nodes[lm.patches[lm.patch_polygon == light]]
    return np.einsum("kb,tbc->tkc", _B[3:], tri).reshape(-1, 3)


def _brute_fraction(sc, mesh, rows, light):
    """(len(rows),) fraction of free rays from 10 points of each element to the light's points."""
    packed = pack_polygons(sc.polygons)
    lp = _light_points(sc, light)
    pts = np.einsum("kb,ebc->ekc", _B, mesh.nodes[mesh.elements[rows]])  # (E, 10, 3)
    a = np.repeat(pts.reshape(-1, 3), len(lp), axis=0)
    b = np.tile(lp, (pts.shape[0] * pts.shape[1], 1))
    skip_a = np.repeat(mesh.element_polygon[rows], pts.shape[1] * len(lp))
    vis = segments_visible(a, b, skip_a, np.full(len(a), light), packed=packed)
    return vis.reshape(len(rows), -1).mean(axis=1)


def test_element_states_cover_the_receivers(room):
    sc, sd, mesh = room
    st = element_states(mesh, sd)
    assert st.shape == (mesh.n_elements, 1)
    on_receiver = np.isin(mesh.element_polygon, list(sd.complexes))
    facing = np.einsum("ij,ij->i", mesh.element_normal, sc.polygons[sc.area_lights[0]].centroid - mesh.element_centroid) > 0
    assert np.all(st[on_receiver & facing, 0] > 0)  # every centroid falls in a face
    assert np.all(st[~facing, 0] == 0)  # the light behind: no state
    assert np.all(st[~on_receiver, 0] == 0)
    assert {BRIGHT, PENUMBRA, UMBRA} <= set(np.unique(st[on_receiver, 0]).tolist())


def test_bright_and_umbra_elements_agree_with_brute_force_rays(room):
    sc, sd, mesh = room
    light = sc.area_lights[0]
    st = element_states(mesh, sd)[:, 0]
    for state, want in ((BRIGHT, 1.0), (UMBRA, 0.0)):
        rows = np.flatnonzero(st == state)
        frac = _brute_fraction(sc, mesh, rows, light)
        # 10 points per element x 96 points on the light: every ray free, or every ray blocked
        assert np.all(frac == want), (state, np.flatnonzero(frac != want)[:5])
    # the oracle can tell: penumbra elements see part of the light
    rows = np.flatnonzero(st == PENUMBRA)
    frac = _brute_fraction(sc, mesh, rows, light)
    assert np.mean((frac > 0) & (frac < 1)) > 0.5


@pytest.mark.parametrize("k", [1, 2])
def test_solver_visibility_is_exact_outside_penumbra(room, k):
    """The solver's element -> light-patch factors: the unoccluded factor on bright elements, 0 in
    umbra, with any number of visibility rays (the speckle of the paired benchmark is not there)."""
    sc, sd, mesh = room
    light = sc.area_lights[0]
    st = element_states(mesh, sd)[:, 0]
    packed = pack_polygons(sc.polygons)
    free = copy.copy(packed)  # the same scene with no polygon allowed to block
    free.occluders = packed.occluders[:0]
    free.occluder_box = packed.occluder_box[:0]
    free.occluder_front = np.ascontiguousarray(packed.occluder_front[:, :, :0])
    free.occluder_tree = box_tree(np.zeros((0, 2, 3)))
    for p in np.flatnonzero(mesh.patch_polygon == light):
        f = analytic_column(mesh, int(p), packed=packed, visibility_samples=k)
        f0 = analytic_column(mesh, int(p), packed=free, visibility_samples=k)
        bright, umbra = st == BRIGHT, st == UMBRA
        # every ray free: the unoccluded factor itself
        np.testing.assert_array_equal(f[bright], f0[bright])
        assert np.all(f[umbra] == 0.0)
        assert np.all(f0[umbra] > 0.0)  # umbra elements face the light: the zero is the blocking
        pen = st == PENUMBRA
        assert np.any(f[pen] < f0[pen])


def test_element_states_refuse_another_scene(room):
    sc, sd, mesh = room
    other = simplified_discontinuity(scenes.two_rectangles_room())
    with pytest.raises(MeshingError, match="discontinuity"):
        element_states(mesh, other)

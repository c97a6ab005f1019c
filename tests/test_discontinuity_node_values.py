"""``node_radiosity``: each area light's direct part at the node (issue 41)."""

import numpy as np
import pytest

from polygen.discontinuity.node_values import light_direct, node_radiosity
from polygen.radiosity import mesh_scene, progressive_refinement
from polygen.radiosity.formfactor import point_polygon_form_factor
from polygen.radiosity.scene import Polygon, Scene


def _scene(occluder=True):
    floor = Polygon([[0, 0, 0], [6, 0, 0], [6, 0, 6], [0, 0, 6]][::-1], reflectance=0.5, name="floor")
    light = Polygon([[2.5, 5, 2.5], [3.5, 5, 2.5], [3.5, 5, 3.5], [2.5, 5, 3.5]], emission=10.0,
                    reflectance=0.0, name="light")
    polys = [floor, light]
    if occluder:
        polys.append(Polygon([[2.2, 2, 2.0], [3.4, 2, 2.0], [3.4, 2, 3.1], [2.2, 2, 3.1]], reflectance=0.0,
                             name="plate", two_sided=True))
    return Scene(polys)


def test_unoccluded_nodes_get_lamberts_formula():
    sc = _scene(occluder=False)
    m = mesh_scene(sc, 1.5, element_levels=1)
    n_light = int(np.sum(m.patch_polygon == 1))
    res = progressive_refinement(m, max_shots=n_light, ambient=False, visibility_samples=2)
    nodes = node_radiosity(m, res)
    on = np.unique(m.elements[m.element_polygon == 0])
    want = 0.5 * 10.0 * point_polygon_form_factor(m.nodes[on], np.tile([0.0, 1.0, 0.0], (len(on), 1)), sc.polygons[1])
    # the floor's elements hold only the light's shot, so (2.8)'s part is zero there
    assert np.allclose(nodes[on], want[:, None], rtol=1e-9, atol=1e-12)


def test_partly_hidden_light_exactly_against_many_rays():
    sc = _scene()
    rng = np.random.default_rng(3)
    x = np.c_[rng.uniform(0, 6, 600), np.zeros(600), rng.uniform(0, 6, 600)]
    n = np.tile([0.0, 1.0, 0.0], (600, 1))
    poly = np.zeros(600, np.int64)
    exact = light_direct(sc, 1, x, n, poly, samples=8, exact=True)[:, 0]
    rays = light_direct(sc, 1, x, n, poly, samples=48, exact=False)[:, 0]
    free = 10.0 * point_polygon_form_factor(x, n, sc.polygons[1])
    part = (exact > 1e-9 * free) & (exact < free * (1 - 1e-9))
    assert part.sum() > 50
    # a 48 x 48 grid against a shadow bounded by straight edges: within 1/20 of the unoccluded value
    assert np.all(np.abs(exact - rays) <= 0.05 * free)
    # fully seen and fully hidden points agree exactly
    assert np.allclose(exact[~part], np.where(rays[~part] > 0.5 * free[~part], free[~part], 0.0), rtol=1e-9)


def test_light_direct_refuses_a_non_emitter():
    from polygen.discontinuity import ShadowError

    with pytest.raises(ShadowError, match="floor"):
        light_direct(_scene(), 0, np.zeros((1, 3)), np.array([[0.0, 1, 0]]), [0])


def test_exact_direct_image_against_many_rays_per_pixel():
    from polygen.discontinuity.node_values import exact_direct_image
    from polygen.radiosity import Camera
    from polygen.radiosity.raster import pixel_points

    sc = _scene()
    m = mesh_scene(sc, 1.5, element_levels=1)
    n_light = int(np.sum(m.patch_polygon == 1))
    # the light's shots only: on the floor everything is the light's direct part
    res = progressive_refinement(m, max_shots=n_light, ambient=False, visibility_samples=2)
    cam = Camera([3.0, 4.0, -3.0], [3.0, 0.0, 3.0], fov=60.0, width=40, height=40, near=0.01)
    img, rest = exact_direct_image(m, res, cam)
    covered, e, x = pixel_points(m, cam)
    floor = m.element_polygon[e] == 0
    got = img[covered][floor, 0]
    n = np.tile([0.0, 1.0, 0.0], (int(floor.sum()), 1))
    rays = 0.5 * light_direct(sc, 1, x[floor], n, np.zeros(int(floor.sum()), np.int64), samples=48,
                              exact=False)[:, 0]
    free = 0.5 * 10.0 * point_polygon_form_factor(x[floor], n, sc.polygons[1])
    assert np.any(got < 0.5 * free) and np.any(got > 0.99 * free)     # the shadow is in view
    assert np.all(np.abs(got - rays) <= 0.05 * free)
    assert np.allclose(rest[covered][floor], 0.0, atol=1e-9 * free.max())
    assert np.isnan(img[~covered]).all()


def test_pixel_states_and_node_image_against_rays():
    # pixel_states: each floor pixel's penumbra state against the light's visible part by many rays; node_image:
    # over those penumbra pixels, nearer the exact image than the same mesh displayed by (2.8)
    from polygen.discontinuity import PENUMBRA, simplified_discontinuity
    from polygen.discontinuity.node_values import exact_direct_image, node_image, pixel_states
    from polygen.radiosity import Camera
    from polygen.radiosity.error import image_error, shade
    from polygen.radiosity.raster import pixel_points

    sc = _scene()
    m = mesh_scene(sc, 0.5, element_levels=1)
    res = progressive_refinement(m, max_shots="lights", ambient=False, visibility_samples=2)
    cam = Camera([3.0, 4.0, -3.0], [3.0, 0.0, 3.0], fov=60.0, width=40, height=40, near=0.01)
    states = pixel_states(m, simplified_discontinuity(sc), cam)
    covered, e, x = pixel_points(m, cam)
    assert states.shape == covered.shape + (1,) and np.all(states[~covered] == 0)
    floor = m.element_polygon[e] == 0
    n = np.tile([0.0, 1.0, 0.0], (int(floor.sum()), 1))
    free = point_polygon_form_factor(x[floor], n, sc.polygons[1])
    frac = light_direct(sc, 1, x[floor], n, np.zeros(int(floor.sum()), np.int64), samples=48, exact=False)[:, 0]
    frac = frac / (10.0 * free)
    pen = states[covered][floor, 0] == PENUMBRA
    assert pen.any() and (~pen).any()
    clear = (frac > 0.02) & (frac < 0.98)   # partly visible by the rays, away from the band's edges
    assert np.all(pen[clear]) and np.all((frac[pen] > 0.0) & (frac[pen] < 1.0 + 1e-9))
    ref = exact_direct_image(m, res, cam)[0]
    mask = (states == PENUMBRA).any(axis=-1)
    assert image_error(node_image(m, res, cam), ref, mask=mask) < image_error(
        shade(m, res.display_radiosity(m), cam), ref, mask=mask)

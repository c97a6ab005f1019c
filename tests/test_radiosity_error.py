"""The image-error yardstick of chapters 3 and 4 (polygen.radiosity.error)."""

import numpy as np
import pytest

from polygen.radiosity import (
    Camera,
    MeshError,
    RasterError,
    adaptive_curve,
    image_error,
    mesh_scene,
    progressive_refinement,
    scenes,
    shade,
    uniform_curve,
)
from polygen.radiosity.error import adaptive_at_count
from polygen.radiosity.raster import pixel_points

CAM = Camera([5.0, 7.0, -5.0], [5.0, 0.5, 5.0], fov=50.0, width=48, height=48, near=0.01)
SOLVE = {"tol": 0.05, "form_factors": "hemicube", "resolution": 32}


@pytest.fixture(scope="module")
def room():
    return scenes.small_shadows_room()


@pytest.fixture(scope="module")
def reference(room):
    m = mesh_scene(room, 2.0)
    r = progressive_refinement(m, **SOLVE)
    return m, r, shade(m, r.display_radiosity(m), CAM)


def test_image_error_definition():
    rng = np.random.default_rng(3)
    ref = rng.uniform(0.5, 1.0, (8, 8, 3))
    ref[0] = np.nan                                    # background row
    img = ref * 1.1
    # a uniform 10 % excess is a relative RMS error of exactly 0.1
    assert image_error(img, ref) == pytest.approx(0.1)
    assert image_error(ref, ref) == 0.0
    with pytest.raises(RasterError, match="shape"):
        image_error(img[:4], ref)
    with pytest.raises(RasterError, match="no covered pixel"):
        image_error(np.full((2, 2, 3), np.nan), np.ones((2, 2, 3)))
    # over a mask: the masked pixels' difference, on the scale of the whole reference
    mask = np.zeros((8, 8), bool)
    mask[4:, 2:5] = True
    part = np.where(mask[..., None], img, ref)
    want = 0.1 * np.sqrt(np.mean(ref[mask] ** 2)) / np.sqrt(np.mean(ref[1:] ** 2))
    assert image_error(part, ref, mask=mask) == pytest.approx(want)
    assert image_error(part, ref, mask=~mask) == 0.0
    with pytest.raises(RasterError, match="mask must be"):
        image_error(img, ref, mask=mask[:4])
    with pytest.raises(RasterError, match="mask covers no pixel"):
        image_error(img, ref, mask=np.zeros((8, 8), bool))


def test_shade_background_is_nan_and_shading_checked(reference):
    m, r, img = reference
    seen = np.isfinite(img).all(axis=2)
    assert 0.5 < seen.mean() < 1.0                    # floor and walls, not the sky above the box
    flat = shade(m, r.display_radiosity(m), CAM, shading="flat")
    # flat and Gouraud shading differ only inside the surfaces, never in what is covered
    np.testing.assert_array_equal(np.isfinite(flat).all(axis=2), seen)
    with pytest.raises(RasterError, match="radiosity"):
        shade(m, r.radiosity[:-1], CAM)


def test_uniform_curve_against_its_own_reference_is_zero(room, reference):
    _, _, img = reference
    pts = uniform_curve(room, CAM, img, [2.0, 4.0], solve=SOLVE)
    assert pts[0].error == 0.0                         # same mesh, same (deterministic) solve
    assert pts[1].error > 0.0 and pts[1].n_elements < pts[0].n_elements


def test_adaptive_curve_levels(room, reference):
    _, _, img = reference
    pts = adaptive_curve(room, CAM, img, 4.0, 2, threshold=0.1, solve=SOLVE)
    assert [p.label for p in pts] == ["adaptive level 0", "adaptive level 1", "adaptive level 2"]
    assert pts[0].n_elements < pts[1].n_elements < pts[2].n_elements
    assert len({p.n_patches for p in pts}) == 1       # subdivision keeps the patches
    with pytest.raises(MeshError, match="threshold"):
        adaptive_curve(room, CAM, img, 4.0, 1, threshold=1.5)


def test_adaptive_at_count_lands_within_rtol(room):
    start = mesh_scene(room, 4.0).n_elements
    for target in (2 * start, 5 * start):
        m, r = adaptive_at_count(room, target, patch_size=4.0, solve=SOLVE)
        assert abs(m.n_elements - target) <= 0.02 * target
        assert r.radiosity.shape[0] == m.n_elements    # the solution is of that mesh
    with pytest.raises(MeshError, match="starting mesh"):
        adaptive_at_count(room, start // 2, patch_size=4.0, solve=SOLVE)


def test_pixel_points_lie_on_the_seen_element_under_the_pixel(reference):
    m, _, img = reference
    covered, e, x = pixel_points(m, CAM)
    np.testing.assert_array_equal(covered, np.isfinite(img).all(axis=2))
    # on the element's plane ...
    d = np.einsum("ij,ij->i", x - m.element_centroid[e], m.element_normal[e])
    assert np.abs(d).max() < 1e-9 * m.scene.polygons[0].diameter
    # ... inside the element (barycentric coordinates >= 0 up to round-off) ...
    t = m.nodes[m.elements[e]]
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    lam = [np.einsum("ij,ij->i", np.cross(q - p, x - p), n) / nn for p, q in ((b, c), (c, a), (a, b))]
    assert min(v.min() for v in lam) > -1e-3
    # ... and projected by the camera onto the pixel's centre
    q = (x - CAM.position) @ CAM.view_matrix().T
    col = q[:, 0] / q[:, 2] * CAM.focal + 0.5 * CAM.width - 0.5
    row = 0.5 * CAM.height - q[:, 1] / q[:, 2] * CAM.focal - 0.5
    rr, cc = np.nonzero(covered)
    np.testing.assert_allclose(col, cc, atol=1e-6)
    np.testing.assert_allclose(row, rr, atol=1e-6)

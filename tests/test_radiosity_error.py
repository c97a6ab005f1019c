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

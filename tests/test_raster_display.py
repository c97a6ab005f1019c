"""Display of radiosity: exposure, the sRGB transfer function, the pyvista colours."""

import numpy as np
import pytest

from polygen.radiosity import Polygon, Scene, mesh_scene
from polygen.radiosity.raster import RasterError, auto_exposure, tone_map, to_pyvista


def test_srgb_transfer_function():
    # IEC 61966-2-1 values: the linear toe, the knee at 0.0031308 and mid grey
    x = np.array([0.0, 0.002, 0.0031308, 0.18, 0.5, 1.0, 2.0])
    y = tone_map(x, exposure=1.0)
    np.testing.assert_allclose(y, [0.0, 0.02584, 0.040449936, 0.461356, 0.735357, 1.0, 1.0],
                               atol=2e-6)
    # continuous at the knee, increasing
    assert np.all(np.diff(y[:-1]) > 0)
    np.testing.assert_allclose(tone_map(np.array([0.25]), exposure=1.0, gamma=2.0), [0.5])


def test_auto_exposure_ignores_background():
    img = np.full((10, 10, 3), np.nan)
    img[:5] = np.linspace(0.0, 4.0, 150).reshape(5, 10, 3)
    e = auto_exposure(img)
    assert e == pytest.approx(1.0 / np.percentile(img[:5], 99.0))
    out = tone_map(img)
    assert np.isnan(out[5:]).all() and np.nanmax(out) == pytest.approx(1.0)
    assert auto_exposure(np.zeros(4)) == 1.0


def test_bad_gamma():
    with pytest.raises(RasterError, match="gamma"):
        tone_map(np.ones(3), gamma="linear")
    with pytest.raises(RasterError, match="gamma"):
        tone_map(np.ones(3), gamma=0.0)


def test_pyvista_colours_take_the_image_exposure():
    m = mesh_scene(Scene([Polygon([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])]), 0.5)
    c = np.linspace(0.0, 2.0, 3 * m.n_nodes).reshape(-1, 3)
    pd = to_pyvista(m, c, exposure=0.5)
    want = (tone_map(c, exposure=0.5) * 255.0 + 0.5).astype(np.uint8)
    np.testing.assert_array_equal(pd.point_data["rgb"], want)
    assert pd.point_data["rgb"].max() == 255 and pd.point_data["rgb"].min() == 0

"""``view_around`` (the notebooks' framing of a volume) and the transfer-function editor's callback."""

import matplotlib.pyplot as plt
import numpy as np
import pytest

from polygen.plotting import render as plot_render
from polygen.volume import datasets
from polygen.volume.render import RenderError, ShellRenderer, TransferFunction, view_around


@pytest.mark.parametrize("name", ["data1", "hollow_cube", "genus3"])
def test_view_around_frames_the_box(name):
    pts = datasets.load(name).points
    lo, hi = pts.min(0), pts.max(0)
    eye = np.array([1.2, -1.6, 0.9])
    view, diag = view_around(pts, eye=eye, fov=35, size=(40, 30))
    assert diag == pytest.approx(np.linalg.norm(hi - lo), rel=1e-15)
    assert np.allclose(view.target, (lo + hi) / 2, atol=1e-12)
    assert np.allclose(np.subtract(view.eye, view.target), diag * eye, atol=1e-12)
    assert view.size == (40, 30) and view.fov == 35
    # the whole box is in sight: from 2.2 diagonals its corners are at most asin(0.5 / 2.18) = 13.3
    # degrees off the axis, inside the 17.5 degrees of half the vertical field of view (and of the wider
    # horizontal one)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    f, r, u = view.basis()
    rel = corners - np.array(view.eye)
    depth = rel @ f
    assert np.all(depth > 0)
    assert np.all(np.abs(rel @ u) / depth <= np.tan(np.radians(17.5)))
    assert view_around(pts, size=16)[0].size == (16, 16)


def test_view_around_names_bad_input():
    with pytest.raises(RenderError, match="points"):
        view_around(np.zeros((0, 3)))
    with pytest.raises(RenderError, match="zero size"):
        view_around(np.ones((4, 3)))
    with pytest.raises(RenderError, match="non-zero direction"):
        view_around(np.eye(3), eye=(0, 0, 0))
    with pytest.raises(RenderError, match="fov"):
        view_around(np.eye(3), fov=180)


@pytest.fixture
def renderer():
    vol = datasets.load("hollow_cube")
    view, _ = view_around(vol.points, size=20)
    return ShellRenderer(vol, view)


def test_plot_shell_render_draws_the_render(renderer):
    s = renderer.values
    tf = TransferFunction.ramp(s.min(), s.max(), opacity=(0.1, 0.7))
    fig, res = plot_render.plot_shell_render(renderer, tf, step=0.3)
    try:
        assert np.array_equal(fig.axes[0].images[0].get_array(), np.clip(res.image, 0, 1))
        assert np.array_equal(res.image, renderer.render(tf, step=0.3).image)
    finally:
        plt.close(fig)


def test_show_shell_render_is_the_editor_state(renderer, monkeypatch):
    # the callback's image is the render with the ramp and count it was given (unit: a twentieth of the diagonal)
    shown = []
    monkeypatch.setattr(plt, "show", lambda: shown.append(plt.gcf()))
    plot_render.show_shell_render(renderer, "magma", 0.2, 0.8, 30)
    assert len(shown) == 1
    diag = np.linalg.norm(np.ptp(renderer.vol.points, axis=0))
    s = renderer.values
    tf = TransferFunction.ramp(s.min(), s.max(), cmap="magma", opacity=(0.2, 0.8), unit=diag / 20)
    builds = renderer.rebuilds
    expected = np.clip(renderer.render(tf, step=diag / 30).image, 0, 1)
    try:
        assert np.array_equal(shown[0].axes[0].images[0].get_array(), expected)
        assert renderer.rebuilds == builds == 1        # one skeleton for the eye, whatever the sliders do
    finally:
        plt.close("all")

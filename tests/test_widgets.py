"""``polygen.widgets``: the isosurface explorer (issue 19, Deliver 4), driven without a kernel."""

import base64
import io

import numpy as np
import pytest
from PIL import Image

from polygen.volume import VolumeError, methods
from polygen.volume.isosurface import extract
from polygen.volume.surface import same_surface
from polygen.widgets import isosurface_explorer
from tests._surfaces import grid_volume

SIZE = (320, 240)


@pytest.fixture(scope="module")
def vol():
    v = grid_volume((8, 8, 8), jitter=0.1, seed=7)
    v.add_field("r", np.linalg.norm(v.points - 3.5, axis=1))
    v.add_field("x", v.points[:, 0])
    return v


def _image(png):
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def _gold(img):
    """Pixels of the surface's colour (goldenrod, shaded): red well above blue, unlike grey and white."""
    return int(((img[..., 0] - img[..., 2]) > 60).sum())


@pytest.fixture
def explorer(vol):
    ex = isosurface_explorer(vol, field="r", window_size=SIZE)
    yield ex
    ex.close()


def test_first_state_is_the_median_surface(vol, explorer):
    s = vol.fields["r"]
    assert explorer.value == pytest.approx(float(np.median(s)))
    assert explorer.method == methods.names()[0]
    assert same_surface(explorer.surface, extract(vol, explorer.value, field="r", method="scan"))
    img = _image(explorer.png)
    assert img.shape[:2] == (SIZE[1], SIZE[0]) and _gold(img) > 100
    # the picture is in the Output widget, where the static fallback finds it
    (out,) = explorer._picture.outputs
    assert base64.b64decode(out["data"]["image/png"]) == explorer.png
    assert f"{explorer.surface.n_triangles:,} triangles" in explorer._counters.value
    assert "cells tested" in explorer._counters.value and " ms" in explorer._counters.value


def test_slider_extracts_and_draws(vol, explorer):
    first = explorer.png
    for v in (1.0, 2.5, 4.0):
        explorer._slider.value = v
        assert explorer.value == v
        assert same_surface(explorer.surface, extract(vol, v, field="r", method="scan"))
        assert f"C = {v:.6g}:" in explorer._counters.value
    assert explorer.png != first


def test_method_and_field_pickers(vol, explorer):
    explorer._method.value = "scan"
    assert explorer.surface.method == "scan" and explorer.method == "scan"
    explorer._field.value = "x"
    x = vol.fields["x"]
    assert (explorer._slider.min, explorer._slider.max) == (x.min(), x.max())
    assert explorer.field == "x" and explorer.value == pytest.approx(float(np.median(x)), abs=explorer._slider.step)
    assert same_surface(explorer.surface, extract(vol, explorer.value, field="x", method="scan"))
    explorer.update(field="r")  # the API moves the pickers too
    assert explorer._field.value == "r" and explorer._slider.max == vol.fields["r"].max()


def test_empty_surface_draws_no_surface(vol, explorer):
    explorer._slider.value = explorer._slider.min  # the field's minimum: a point, no triangles
    assert explorer.surface.is_empty
    assert _gold(_image(explorer.png)) == 0
    explorer._slider.value = 2.0
    assert _gold(_image(explorer.png)) > 100


def test_bad_arguments(vol):
    from polygen.volume import UnstructuredVolume

    bare = UnstructuredVolume(vol.points, vol.cells)
    with pytest.raises(VolumeError, match="no node field"):
        isosurface_explorer(bare)
    with pytest.raises(VolumeError, match="no field 'nope'"):
        isosurface_explorer(vol, field="nope")
    with pytest.raises(VolumeError, match="unknown isosurface method 'nope'"):
        isosurface_explorer(vol, method="nope")


def test_redraw_from_another_thread(vol, explorer):
    """A widget callback may run on a kernel subshell's thread (issue 46): the picture must not turn black.

    Before the render thread, a plotter made by the cell and drawn from another thread read back
    a black frame (VTK: "Error setting 'vertexMC' in shader VAO").
    """
    import threading

    from polygen.plotting import _render_thread

    explorer.update(value=2.5)
    here = explorer.png
    pictures, threads = [], []

    def callback():
        for v in (2.0, 2.5):
            explorer.update(value=v)
            pictures.append(explorer.png)
            threads.append(threading.get_ident())

    t = threading.Thread(target=callback, name="subshell-like")
    t.start()
    t.join(timeout=120)
    assert not t.is_alive() and len(pictures) == 2
    assert _gold(_image(pictures[0])) > 100
    assert pictures[1] == here  # the same value draws the same picture from either thread
    assert _render_thread.ident() not in (threads[0], threading.get_ident())


def test_updates_from_two_threads_run_one_after_the_other(vol, explorer):
    """ipykernel 7 sends each widget's messages to the subshell that last published on it, so the field
    dropdown's callback (the kernel's main shell) and the slider's (a subshell) can run at once.

    Seen in a live JupyterLab: the field change drew the old field's value with the new field's surface, and
    the counters disagreed with the picture. A slider move that comes while a field change draws must wait.
    """
    import threading

    entered, release = threading.Event(), threading.Event()
    render = explorer._render

    def held_render(iso):  # the field change stops before drawing until the slider's move has been tried
        if threading.current_thread().name == "main-shell-like":
            entered.set()
            release.wait(60)
        return render(iso)

    explorer._render = held_render
    field_change = threading.Thread(target=lambda: explorer.update(field="x"), name="main-shell-like")
    field_change.start()
    assert entered.wait(60)
    slider = threading.Thread(target=lambda: explorer.update(value=3.0), name="subshell-like")
    slider.start()
    slider.join(timeout=2.0)
    waited = slider.is_alive()
    release.set()
    field_change.join(timeout=60)
    slider.join(timeout=60)
    assert waited, "the slider's update ran while the field change was drawing"
    assert explorer.field == "x" and explorer.value == 3.0
    assert same_surface(explorer.surface, extract(vol, 3.0, field="x", method="scan"))
    assert "C = 3:" in explorer._counters.value


def test_field_change_sends_the_new_range_in_one_message(explorer, monkeypatch):
    """Sent one by one, the new minimum reached the page while it still held the old value, which the page
    sent back after the new field's median: the slider ended on the old field's value. In one message, the
    page applies the names in order, and a value before the new step is rounded onto the old grid."""
    sent = []
    monkeypatch.setattr(explorer._slider, "_send", lambda msg, buffers=None: sent.append(msg["state"]))
    explorer._field.value = "x"
    assert [list(s) for s in sent] == [["min", "max", "step", "value"]]
    assert sent[0]["value"] == pytest.approx(float(np.median(explorer.vol.fields["x"])))

"""ipywidgets front ends for the notebooks: the isosurface explorer.

:func:`isosurface_explorer` builds a panel -- an isovalue slider, a field and
a method picker, live counters (cells tested, triangles, extraction time) and
the surface drawn by pyvista off-screen -- for any
:class:`~polygen.volume.UnstructuredVolume`. The picture is a PNG inside an
``ipywidgets.Output``, so the panel needs no JavaScript renderer beyond
ipywidgets itself, and a notebook executed without a front end (nbval, the
book) keeps the PNG of the first state in the output, which
``docs/execute_notebooks.py`` places beside the widget as its static fallback.

The drawing runs on one render thread (``polygen.plotting._render_thread``)
that makes the off-screen plotter and alone uses its OpenGL context: JupyterLab
4.6 sends widget messages over a kernel subshell, whose thread runs the
callbacks, and a context used from another thread than its own draws black.

Any thread may call :meth:`IsosurfaceExplorer.update`, and calls may overlap:
ipykernel 7 sends each widget's messages to the subshell that last published
on that widget, so the slider's and a dropdown's callbacks can run at the same
time on two threads (the kernel's main shell and a subshell). One lock per
explorer makes each change -- new range, extraction, picture, counters -- run
whole before the next begins.

Like the plotting modules, nothing in the algorithm packages imports this
one; pyvista, ipywidgets and PIL are imported inside the functions.
"""

from __future__ import annotations

import base64
import io
import threading
import time
import weakref

import numpy as np

__all__ = ["IsosurfaceExplorer", "isosurface_explorer"]


class IsosurfaceExplorer:
    """The state and the widgets of :func:`isosurface_explorer`.

    Attributes
    ----------
    vol : UnstructuredVolume
    field, method : str
        The current choices.
    value : float
        The current isovalue.
    surface : IsoSurface
        The last surface extracted.
    extract_s : float
        Wall-clock seconds of the last extraction (``vol.isosurface``; the
        first call for a field and method also prepares the method).
    render_s : float
        Seconds to draw the last PNG.
    png : bytes
        The last picture.
    widget : ipywidgets.VBox
        The panel: slider, pickers, counters, picture.
    """

    def __init__(self, vol, *, field=None, method=None, value=None, window_size=(640, 420), steps=200):
        import ipywidgets as w

        from polygen.volume import VolumeError, methods

        if not vol.fields:
            raise VolumeError("the volume has no node field to explore; add one with add_field(name, values)")
        names = methods.names()
        self.vol = vol
        self.field = next(iter(vol.fields)) if field is None else str(field)
        vol.scalars(self.field)  # VolumeError naming the fields when unknown
        self.method = names[0] if method is None else str(method)
        if self.method not in names:
            raise VolumeError(f"unknown isosurface method {self.method!r}; the methods are {names}")
        if int(steps) < 2:
            raise VolumeError(f"steps must be at least 2; got {steps!r}")
        self._steps = int(steps)
        # held by every change of state: two threads may deliver the widgets' messages at once (module doc);
        # re-entrant because update(field=...) sets the dropdown, whose observer calls back on the same thread
        self._lock = threading.RLock()
        self._window_size = tuple(int(x) for x in window_size)
        # [pyvista.Plotter or None], made, drawn and closed on the render thread only; a box so that
        # the finalizer closes it there without holding the explorer
        self._plotter_box = [None]
        self._closer = weakref.finalize(self, _close_plotter, self._plotter_box)
        self._closer.atexit = False  # at exit the render thread is gone; the process frees the context
        self.surface = None
        self.extract_s = self.render_s = 0.0
        self.png = b""

        s = vol.scalars(self.field)
        self.value = float(np.median(s)) if value is None else float(value)
        self._slider = w.FloatSlider(description="C", continuous_update=True, readout_format=".4g",
                                     layout=w.Layout(width="60%"))
        self._updating = False
        self._set_range(s, self.value)
        self._field = w.Dropdown(options=list(vol.fields), value=self.field, description="field")
        self._method = w.Dropdown(options=names, value=self.method, description="method")
        self._counters = w.HTML()
        self._picture = w.Output()
        self._slider.observe(lambda change: self.update(value=change["new"]), names="value")
        self._field.observe(lambda change: self._field_changed(change["new"]), names="value")
        self._method.observe(lambda change: self.update(method=change["new"]), names="value")
        self.widget = w.VBox([w.HBox([self._field, self._method]), self._slider, self._counters, self._picture])
        self.update()

    # ---------------------------------------------------------------- state
    def _set_range(self, s, value):
        lo, hi = float(np.min(s)), float(np.max(s))
        if hi <= lo:  # a constant field: a slider of one position
            hi = lo + 1.0
        self._updating = True  # moving the bounds moves the value: no extraction meanwhile
        try:
            with self._slider.hold_sync():
                # the slider keeps min <= max at every assignment: widen first, then narrow
                if lo > self._slider.max:
                    self._slider.max, self._slider.min = hi, lo
                else:
                    self._slider.min, self._slider.max = lo, hi
                self._slider.step = (hi - lo) / self._steps
                self._slider.value = min(max(value, lo), hi)
                # hold_sync would send the held names in a set's order, random per process
                self._slider._states_to_send.clear()
            # One message, the range before the value. Sent one by one, the new min reached the page with
            # the old value still there, which the page sent back after the new one. In one message the
            # page applies the names in the message's order, and a value that comes before the new step
            # is rounded onto the old field's grid and sent back (7.15 came back as 7.14471).
            self._slider.send_state(["min", "max", "step", "value"])
        finally:
            self._updating = False

    def _field_changed(self, field):
        with self._lock:
            s = self.vol.scalars(field)
            self.field = field
            self._set_range(s, float(np.median(s)))
            self.update(value=self._slider.value)

    def update(self, value=None, *, field=None, method=None):
        """Extract the surface for the current (or given) value, field and method, and draw it.

        Parameters
        ----------
        value : float, optional
        field, method : str, optional, keyword-only
            Changing the field moves the slider to that field's range.

        Returns
        -------
        IsoSurface

        Notes
        -----
        Thread-safe: a call from another thread waits until the one running has drawn its picture.
        """
        with self._lock:
            return self._update(value, field=field, method=method)

    def _update(self, value, *, field, method):
        if getattr(self, "_updating", False):
            return self.surface
        if field is not None and field != self.field:
            self._field.value = field  # its observer sets the range and extracts
            return self.surface
        if method is not None:
            self.method = method
            if self._method.value != method:
                self._method.value = method  # its observer calls back with the same method
                return self.surface
        if value is not None:
            self.value = float(value)
        t0 = time.perf_counter()
        self.surface = self.vol.isosurface(self.value, field=self.field, method=self.method)
        self.extract_s = time.perf_counter() - t0
        iso = self.surface
        t0 = time.perf_counter()
        self.png = self._render(iso)
        self.render_s = time.perf_counter() - t0
        self._counters.value = (
            f"<tt>C = {self.value:.6g}: {iso.n_triangles:,} triangles, {iso.n_vertices:,} vertices; "
            f"{iso.cells_tested:,} cells tested, {iso.cells_intersected:,} intersected; "
            f"extraction {1e3 * self.extract_s:.1f} ms ({self.method}), drawing {1e3 * self.render_s:.0f} ms</tt>")
        self._picture.outputs = ({"output_type": "display_data", "metadata": {},
                                  "data": {"image/png": base64.b64encode(self.png).decode("ascii"),
                                           "text/plain": repr(iso)}},)
        return iso

    # ---------------------------------------------------------------- drawing
    def _render(self, iso):
        from polygen.plotting import _render_thread

        # the plotter and its OpenGL context live on the one render thread: a widget's callback
        # may run on another thread than the cell's (a kernel subshell), where the context is not current
        return _render_thread.call(self._draw, iso)

    def _draw(self, iso):
        from PIL import Image

        from polygen.plotting import setup_notebook
        from polygen.plotting._common import _plotter, boundary_surface

        p = self._plotter_box[0]
        if p is None:
            setup_notebook()
            p = self._plotter_box[0] = _plotter(window_size=self._window_size)
            p.add_mesh(boundary_surface(self.vol), color="lightgray", opacity=0.15, name="outline")
            p.view_isometric()
        if iso.is_empty:
            p.remove_actor("surface")
        else:
            p.add_mesh(iso.to_pyvista(), color="goldenrod", smooth_shading=iso.normals is not None, name="surface",
                       reset_camera=False)
        p.add_text(f"{self.field} = {self.value:.4g}", font_size=10, name="label")
        img = p.screenshot(return_img=True)
        buf = io.BytesIO()
        Image.fromarray(np.asarray(img)).save(buf, format="PNG")
        return buf.getvalue()

    def close(self):
        """Free the off-screen renderer and close the widgets."""
        self._closer.detach()
        _close_plotter(self._plotter_box, wait=True)
        for child in (self._field, self._method, self._slider, self._counters, self._picture):
            child.close()
        self.widget.close()

    def _repr_mimebundle_(self, **kwargs):
        return self.widget._repr_mimebundle_(**kwargs)


def _close_plotter(box, *, wait=False):
    """Close the plotter in ``box`` on the render thread (the thread whose OpenGL context it holds)."""
    from polygen.plotting import _render_thread

    def close():
        if box[0] is not None:
            box[0].close()
            box[0] = None

    if box[0] is not None:
        if wait:
            _render_thread.call(close)
        else:
            _render_thread.call_soon(close)


def isosurface_explorer(vol, *, field=None, method=None, value=None, window_size=(640, 420), steps=200):
    """An ipywidgets panel to explore a volume's isosurfaces.

    Moving the slider extracts the surface with ``vol.isosurface`` (the
    method is prepared once per field, then answers in milliseconds) and
    draws it; the counters show the triangles, the cells tested and
    intersected, and the extraction and drawing times.

    Parameters
    ----------
    vol : UnstructuredVolume
    field : str, optional, keyword-only
        The first field by default.
    method : str, optional, keyword-only
        One of ``polygen.volume.methods.names()``; the default method (the
        fastest measured) by default.
    value : float, optional, keyword-only
        The first isovalue; the field's median by default.
    window_size : (int, int), keyword-only
        Pixels of the picture.
    steps : int, keyword-only
        Slider positions across the field's range.

    Returns
    -------
    IsosurfaceExplorer
        Displaying it shows the panel; its ``widget`` is the
        ``ipywidgets.VBox``.

    Raises
    ------
    VolumeError
        A volume without fields, an unknown field or method.
    """
    return IsosurfaceExplorer(vol, field=field, method=method, value=value, window_size=window_size, steps=steps)

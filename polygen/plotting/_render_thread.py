"""One long-lived thread for the widgets' off-screen OpenGL work.

An OpenGL context is current on the thread that made it. JupyterLab 4.6 sends
widget messages over a kernel subshell, and ipykernel 7 runs a widget's
callbacks on that subshell's thread, not on the thread that ran the cell: a
plotter made by the cell and drawn from a slider's callback read back a black
or garbled frame (EGL, Mesa). Every pyvista call of a widget therefore runs
here, on one thread that makes the plotters and owns their contexts; a
callback hands it the work and waits for the picture.

:func:`call` runs a function on that thread and returns its result (or raises
its exception); called from the thread itself, it just runs the function. The
thread starts on the first call and idles, without holding any lock, between
calls; it is a daemon-like executor worker that the interpreter joins at exit.
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

__all__ = ["call", "ident"]

_lock = threading.Lock()
_executor = None
_ident = None


def _started():
    global _ident
    _ident = threading.get_ident()


def ident():
    """``threading.get_ident()`` of the render thread, None before its first call."""
    return _ident


def call(fn, /, *args, **kwargs):
    """``fn(*args, **kwargs)`` on the render thread; its result, or its exception raised here."""
    global _executor
    if threading.get_ident() == _ident:
        return fn(*args, **kwargs)
    with _lock:
        if _executor is None:
            # one worker, made once and kept: it makes every context and is the only one to use them
            _executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="polygen-render", initializer=_started)
        future = _executor.submit(fn, *args, **kwargs)
    return future.result()


def call_soon(fn, /, *args, **kwargs):
    """Queue ``fn(*args, **kwargs)`` on the render thread without waiting (for finalizers); False if it cannot."""
    if threading.get_ident() == _ident:
        fn(*args, **kwargs)
        return True
    with _lock:
        if _executor is None:
            return False
        try:
            _executor.submit(fn, *args, **kwargs)
        except RuntimeError:  # the interpreter is shutting the executor down
            return False
    return True

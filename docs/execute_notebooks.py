"""Regenerate every notebook's ``.ipynb`` from its ``.py`` and store its outputs.

Usage, from the repository root::

    python docs/execute_notebooks.py                   # all notebooks in notebooks/
    python docs/execute_notebooks.py 05_volume_data    # some of them, by name

Each ``notebooks/NN_title.py`` (jupytext percent format, the source) is read, run
top to bottom in a fresh ``python3`` kernel with ``notebooks/`` as its working
directory, at the default (reduced) sizes — ``POLYGEN_FULL`` is removed from the
kernel's environment — and written to ``notebooks/NN_title.ipynb`` with its outputs:
matplotlib figures and pyvista's static renderings as PNG (pyvista's JPEG copy is
dropped), printed tables as text; a widget (``interact``) gets a PNG of what it first
showed beside it, for the book and any viewer without a kernel.
Cell ids are numbered (``c00``, ``c01``, ...) so that a re-run changes only outputs.

Rendering is off-screen (VTK through EGL) and matplotlib draws inline. A notebook
bigger than ``--max-mb`` (3 MB) or one whose cell raises makes the command exit 1
after the others have run; a failing notebook is still written, outputs up to the
error included, so that the pair stays in sync and the traceback can be read.
"""

import argparse
import os
import re
import sys
import time
from pathlib import Path
from queue import Empty

import jupytext
from nbclient import NotebookClient
from nbclient.exceptions import CellControlSignal, CellExecutionError, DeadKernelError

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = ROOT / "notebooks"


def kernel_environment():
    """The environment the notebooks' kernel starts with (this process's, adjusted)."""
    env = dict(os.environ)
    env.pop("POLYGEN_FULL", None)  # default sizes
    env.pop("MPLBACKEND", None)  # ipykernel then draws matplotlib inline (PNG)
    env.setdefault("PYVISTA_OFF_SCREEN", "true")
    env.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    # polygen from this checkout even when it is not installed
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


WIDGET_VIEW = "application/vnd.jupyter.widget-view+json"
WIDGET_STATE = "application/vnd.jupyter.widget-state+json"


def _widget_states(nb):
    return nb.metadata.get("widgets", {}).get(WIDGET_STATE, {}).get("state", {})


def keep_png_only(nb):
    """Drop the JPEG copy of a figure that also comes as PNG (pyvista sends both).

    In the cells' outputs and in the stored state of output widgets (``interact``).
    """
    outputs = [o for cell in nb.cells for o in cell.get("outputs", [])]
    for model in _widget_states(nb).values():
        outputs += model.get("state", {}).get("outputs", [])
    for output in outputs:
        data = output.get("data", {})
        if "image/png" in data:
            data.pop("image/jpeg", None)


def _first_png(states, model_id, seen=None):
    """The first PNG that widget `model_id` or one of its children displays."""
    seen = set() if seen is None else seen
    if model_id in seen or model_id not in states:
        return None
    seen.add(model_id)
    state = states[model_id].get("state", {})
    for output in state.get("outputs", []):
        if "image/png" in output.get("data", {}):
            return output["data"]["image/png"]
    for child in state.get("children", []):
        found = _first_png(states, str(child).removeprefix("IPY_MODEL_"), seen)
        if found is not None:
            return found
    return None


def add_widget_fallbacks(nb):
    """Give each displayed widget (an ``interact``) a PNG of what it first showed.

    The widget itself needs JavaScript and a kernel to move; the PNG beside it in the
    same output is what the book (and any viewer without widgets) shows.
    """
    states = _widget_states(nb)
    for cell in nb.cells:
        for output in cell.get("outputs", []):
            data = output.get("data", {})
            if WIDGET_VIEW in data and "image/png" not in data:
                png = _first_png(states, data[WIDGET_VIEW].get("model_id"))
                if png is not None:
                    data["image/png"] = png


def _poll_in_slices(channel, step=1.0):
    """Make `channel` wait for a message in polls of at most `step` seconds.

    A single long ``poll`` on a kernel channel can miss the wake-up of a message
    that has arrived (seen here after a cell showing an ``interact`` widget: the
    execute reply, there at once, was read only when the cell's whole time-out ran
    out, or never when no time-out was set). A poll that ends looks again, so
    slicing bounds that stall to `step`.
    """
    get_msg = channel.get_msg

    async def get_msg_in_slices(timeout=None):
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = step if deadline is None else max(0.0, min(step, deadline - time.monotonic()))
            try:
                return await get_msg(timeout=left)
            except Empty:
                if deadline is not None and time.monotonic() >= deadline:
                    raise

    channel.get_msg = get_msg_in_slices


class _Client(NotebookClient):
    """nbclient's client, its shell and IOPub channels polled in slices."""

    async def async_start_new_kernel_client(self):
        kc = await super().async_start_new_kernel_client()
        _poll_in_slices(kc.shell_channel)
        _poll_in_slices(kc.iopub_channel)
        return kc


def execute(py_path, *, timeout=900, kernel_name="python3"):
    """Run the notebook whose source is `py_path`; write its ``.ipynb``.

    Returns ``(error, seconds, megabytes)``, `error` being ``None`` when every cell ran.
    """
    nb = jupytext.read(py_path)
    nb.metadata["kernelspec"] = {"name": kernel_name, "display_name": "Python 3", "language": "python"}
    for i, cell in enumerate(nb.cells):
        cell["id"] = f"c{i:02d}"
    client = _Client(
        nb, timeout=timeout, kernel_name=kernel_name, record_timing=False,
        resources={"metadata": {"path": str(py_path.parent)}},
    )
    error = None
    t0 = time.perf_counter()
    saved = dict(os.environ)
    os.environ.clear()
    os.environ.update(kernel_environment())  # the kernel inherits this process's environment
    try:
        client.execute()
    except CellExecutionError as exc:
        text = re.sub(r"\x1b\[[0-9;]*m", "", str(exc)).strip()  # no terminal colours
        error = text.splitlines()[-1] if text else repr(exc)
    except (CellControlSignal, DeadKernelError) as exc:  # a cell ran out of time, the kernel died
        error = f"{type(exc).__name__}: {exc}"
    finally:
        os.environ.clear()
        os.environ.update(saved)
    seconds = time.perf_counter() - t0
    keep_png_only(nb)
    add_widget_fallbacks(nb)
    out = py_path.with_suffix(".ipynb")
    jupytext.write(nb, out, fmt="ipynb")
    return error, seconds, out.stat().st_size / 1e6


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="notebook names (default: all of notebooks/*.py)")
    parser.add_argument("--max-mb", type=float, default=3.0, help="largest allowed .ipynb, in MB (default 3)")
    parser.add_argument("--timeout", type=int, default=900, help="seconds allowed per cell (default 900)")
    args = parser.parse_args(argv)

    if args.names:
        paths = [NOTEBOOKS / f"{Path(n).stem}.py" for n in args.names]
        missing = [p.name for p in paths if not p.exists()]
        if missing:
            parser.error(f"no such notebook source in notebooks/: {', '.join(missing)}")
    else:
        paths = sorted(NOTEBOOKS.glob("*.py"))

    failed = []
    total = time.perf_counter()
    for py in paths:
        print(f"{py.stem}: running ...", flush=True)
        error, seconds, mb = execute(py, timeout=args.timeout)
        status = "ok" if error is None else f"FAILED: {error}"
        if mb > args.max_mb:
            status += f"; TOO BIG: {mb:.2f} MB > {args.max_mb} MB"
        print(f"{py.stem}: {seconds:.0f} s, {mb:.2f} MB, {status}", flush=True)
        if error is not None or mb > args.max_mb:
            failed.append(py.stem)
    print(f"{len(paths)} notebooks in {time.perf_counter() - total:.0f} s"
          + (f"; failed: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

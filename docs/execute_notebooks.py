"""Regenerate every notebook's ``.ipynb`` from its ``.py`` and store its outputs.

Usage, from the repository root::

    python docs/execute_notebooks.py                   # all notebooks in notebooks/
    python docs/execute_notebooks.py 05_volume_data    # some of them, by name

Each ``notebooks/NN_title.py`` (jupytext percent format, the source) is read, run
top to bottom in a fresh ``python3`` kernel with ``notebooks/`` as its working
directory, at the default (reduced) sizes — ``POLYGEN_FULL`` is removed from the
kernel's environment — and written to ``notebooks/NN_title.ipynb`` with its outputs:
matplotlib figures and pyvista's static renderings as PNG (pyvista's JPEG copy is
dropped), printed tables as text.
Cell ids are numbered (``c00``, ``c01``, ...) so that a re-run changes only outputs.

Rendering is off-screen (VTK through EGL) and matplotlib draws inline. A notebook
bigger than ``--max-mb`` (3 MB) or one whose cell raises makes the command exit 1
after the others have run; a failing notebook is still written, outputs up to the
error included, so that the pair stays in sync and the traceback can be read.
"""

import argparse
import os
import sys
import time
from pathlib import Path

import jupytext
import nbformat
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


def keep_png_only(nb):
    """Drop the JPEG copy of a figure that also comes as PNG (pyvista sends both)."""
    for cell in nb.cells:
        for output in cell.get("outputs", []):
            data = output.get("data", {})
            if "image/png" in data:
                data.pop("image/jpeg", None)


def execute(py_path, *, timeout=900, kernel_name="python3"):
    """Run the notebook whose source is `py_path`; write its ``.ipynb``.

    Returns ``(error, seconds, megabytes)``, `error` being ``None`` when every cell ran.
    """
    nb = jupytext.read(py_path)
    nb.metadata["kernelspec"] = {"name": kernel_name, "display_name": "Python 3", "language": "python"}
    for i, cell in enumerate(nb.cells):
        cell["id"] = f"c{i:02d}"
    client = NotebookClient(
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
        error = str(exc).strip().splitlines()[-1] if str(exc).strip() else repr(exc)
    except (CellControlSignal, DeadKernelError) as exc:  # a cell ran out of time, the kernel died
        error = f"{type(exc).__name__}: {exc}"
    finally:
        os.environ.clear()
        os.environ.update(saved)
    seconds = time.perf_counter() - t0
    keep_png_only(nb)
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

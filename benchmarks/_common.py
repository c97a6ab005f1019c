"""Small helpers shared by the benchmark scripts: timing, writing results, and the VTK filter we compare with."""

import json
import os
import platform
import time
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"


def best_of(fn, repeat=3):
    """Smallest wall time of ``repeat`` calls of ``fn()``, and its last result."""
    best = float("inf")
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _git(*args):
    import subprocess

    try:
        out = subprocess.run(["git", *args], cwd=Path(__file__).resolve().parent, capture_output=True,
                             text=True, timeout=30, check=True)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip()


def machine():
    """Where and from what a result was made: the machine, the commit (``+dirty`` when tracked files
    differ from it) and the date (UTC). Every results file records it, so that a figure can be traced
    to the code that gave it."""
    from datetime import datetime, timezone

    commit = _git("rev-parse", "HEAD")
    # results files don't count: a script that writes several of them (or rewrites its own .json
    # after its .md) would otherwise mark its own run "+dirty"
    if commit is not None and _git("status", "--porcelain", "--untracked-files=no", "--", ":/",
                                   ":(exclude,top)benchmarks/results"):
        commit += "+dirty"
    return {"python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count(),
            "commit": commit, "date": datetime.now(timezone.utc).isoformat(timespec="seconds")}


def write_results(name, rows, columns, *, title, notes=()):
    """Write ``results/NAME.json`` and ``results/NAME.md`` (a markdown table)."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / f"{name}.json").write_text(json.dumps({"machine": machine(), "rows": rows}, indent=2) + "\n")
    lines = [f"# {title}", "", "| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for r in rows:
        cells = []
        for c in columns:
            v = r.get(c, "")
            cells.append(f"{v:.4g}" if isinstance(v, float) else str(v))
        lines.append("| " + " | ".join(cells) + " |")
    lines += [""] + [f"- {n}" for n in notes] + [f"- machine: {machine()}"]
    (RESULTS / f"{name}.md").write_text("\n".join(lines) + "\n")
    return RESULTS / f"{name}.md"


def fmt(v):
    """A table cell: booleans as words, floats to 4 significant digits."""
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def thesis_table(title, rows, keys, thesis=None):
    """Markdown lines: one column per data set (``row["data"]`` = "dataK"), one line per key.

    Keys found in ``thesis`` (key -> values for data1, data2, ...) get the
    thesis's value in parentheses.
    """
    lines = [f"## {title}", "", "| quantity | " + " | ".join(r["data"] for r in rows) + " |",
             "|---|" + "---|" * len(rows)]
    for k in keys:
        cells = []
        for r in rows:
            c = fmt(r.get(k, ""))
            if thesis and k in thesis:
                c += f" ({fmt(thesis[k][int(r['data'][-1]) - 1])})"
            cells.append(c)
        lines.append(f"| {k} | " + " | ".join(cells) + " |")
    return lines + [""]


def vtk_contour(grid, field, *, linear_grid=False, span_space=False):
    """VTK's isosurface filter on ``grid``'s point array ``field``, set up as every benchmark compares with.

    One contour value, normals on, scalars off; ``linear_grid`` takes ``vtkContour3DLinearGrid``
    (it merges points always, VTK >= 9.7) instead of ``vtkContourFilter``; ``span_space`` gives it
    a ``vtkSpanSpace`` scalar tree (built by the first update), otherwise no tree.

    Returns
    -------
    filter : vtkAlgorithm
    one : callable
        ``one(value) -> (triangles, points)`` of the surface at ``value``.
    """
    import vtk

    if linear_grid:
        f = vtk.vtkContour3DLinearGrid()
        f.SetInterpolateAttributes(False)
    else:
        f = vtk.vtkContourFilter()
    f.SetInputData(grid)
    f.SetInputArrayToProcess(0, 0, 0, vtk.vtkDataObject.FIELD_ASSOCIATION_POINTS, field)
    f.ComputeNormalsOn()
    f.ComputeScalarsOff()
    if span_space:
        f.SetScalarTree(vtk.vtkSpanSpace())
        f.UseScalarTreeOn()
    else:
        f.UseScalarTreeOff()
    f.SetNumberOfContours(1)

    def one(v):
        f.SetValue(0, float(v))
        f.Update()
        out = f.GetOutput()
        return out.GetNumberOfCells(), out.GetNumberOfPoints()

    return f, one

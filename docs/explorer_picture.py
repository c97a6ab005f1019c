"""The README's picture of the isosurface explorer, and how fast it extracts on data 4.

Builds :func:`polygen.widgets.isosurface_explorer` on data set 4 (560k
tetrahedra), moves its slider over 40 positions across the field's range as
a user would, and writes

* ``docs/_static/explorer.png``: the picture the explorer shows, with its
  counter line and its state (field, method, value) under it;
* ``docs/_static/explorer.json``: the extraction time of each slider
  position (``vol.isosurface`` with the default method, prepared before),
  the drawing time, and their median and largest values.

Run from the repository root: ``python docs/explorer_picture.py`` (about a
minute with data 4 cached). Timings depend on the machine and its load.
"""

import json
import re
import time
from pathlib import Path

import numpy as np

from polygen.volume import datasets
from polygen.widgets import isosurface_explorer

OUT = Path(__file__).resolve().parent / "_static"
DATA = "data4"
POSITIONS = 40


def main():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    vol = datasets.load(DATA)
    t0 = time.perf_counter()
    explorer = isosurface_explorer(vol, window_size=(900, 560))  # prepares the default method on the field
    first_s = time.perf_counter() - t0
    s = vol.scalars(explorer.field)
    extract_ms, draw_ms, triangles = [], [], []
    for v in np.linspace(s.min(), s.max(), POSITIONS + 2)[1:-1]:
        explorer._slider.value = float(v)  # as the slider moves
        extract_ms.append(1e3 * explorer.extract_s)
        draw_ms.append(1e3 * explorer.render_s)
        triangles.append(explorer.surface.n_triangles)
    explorer._slider.value = float(np.quantile(s, 0.4))
    img = np.asarray(Image.open(__import__("io").BytesIO(explorer.png)))
    counters = re.sub(r"<[^>]+>", "", explorer._counters.value)

    fig = plt.figure(figsize=(9, 6.1), dpi=100)
    ax = fig.add_axes([0, 0.08, 1, 0.92])
    ax.imshow(img)
    ax.set_axis_off()
    fig.text(0.01, 0.045, f"{DATA}: {vol.n_cells:,} tetrahedra, field {explorer.field!r}, method {explorer.method!r}",
             fontsize=9, family="monospace")
    fig.text(0.01, 0.012, counters, fontsize=8, family="monospace")
    OUT.mkdir(exist_ok=True)
    fig.savefig(OUT / "explorer.png")
    stats = {"data": DATA, "cells": vol.n_cells, "method": explorer.method, "field": explorer.field,
             "first_call_s": first_s, "positions": POSITIONS, "triangles": triangles,
             "extract_ms": extract_ms, "draw_ms": draw_ms,
             "extract_ms_median": float(np.median(extract_ms)), "extract_ms_max": float(np.max(extract_ms)),
             "draw_ms_median": float(np.median(draw_ms))}
    (OUT / "explorer.json").write_text(json.dumps(stats, indent=1) + "\n")
    explorer.close()
    print(f"{DATA}: first call (prepares {explorer.method}) {first_s:.2f} s; extraction median "
          f"{stats['extract_ms_median']:.1f} ms, largest {stats['extract_ms_max']:.1f} ms over {POSITIONS} "
          f"positions; drawing median {stats['draw_ms_median']:.0f} ms; wrote {OUT / 'explorer.png'}")


if __name__ == "__main__":
    main()

"""Write a notebook from a list of cells: ``("md", text)`` or ``("code", text)``.

The notebooks in ``notebooks/`` are committed without outputs; this keeps
their sources reviewable as Python (see ``tools/nb_*.py``).
"""

import sys
from pathlib import Path

import nbformat


def write(path, cells):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.metadata["language_info"] = {"name": "python"}
    for kind, text in cells:
        text = text.strip("\n")
        nb.cells.append(nbformat.v4.new_markdown_cell(text) if kind == "md" else nbformat.v4.new_code_cell(text))
    for i, c in enumerate(nb.cells):
        c["id"] = f"c{i:02d}"
    path = Path(__file__).resolve().parent.parent / path
    Path(path).write_text(nbformat.writes(nb))
    print(f"wrote {path} ({len(cells)} cells)", file=sys.stderr)

"""Every notebook is a pair: ``notebooks/NN_title.py`` (jupytext percent format, the
source) and ``notebooks/NN_title.ipynb`` (the same cells, with outputs). The pair must
hold the same cells in the same order: same type, same source. The ``.ipynb`` is
committed with its outputs (``python docs/execute_notebooks.py``), at most 3 MB.

After editing a ``.py``: ``jupytext --sync notebooks/*.py`` (or
``python docs/execute_notebooks.py``, which also runs them and stores the outputs).
"""

import shutil
from pathlib import Path

import jupytext
import nbformat
import pytest

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"


def _cells(nb):
    return [(c.cell_type, c.source) for c in nb.cells]


def unpaired(folder):
    """Stems of the notebooks in `folder` that lack their ``.py`` or their ``.ipynb``."""
    py = {p.stem for p in folder.glob("*.py")}
    ipynb = {p.stem for p in folder.glob("*.ipynb")}
    return sorted(py ^ ipynb)


def pair_differences(py_path):
    """Where the ``.py`` at `py_path` and its ``.ipynb`` differ, as readable lines.

    Returns an empty list when both hold the same cells (type and source, in order).
    """
    text = jupytext.read(py_path)
    ipynb = nbformat.read(py_path.with_suffix(".ipynb"), as_version=4)
    a, b = _cells(text), _cells(ipynb)
    out = []
    if len(a) != len(b):
        out.append(f"{py_path.name}: {len(a)} cells in the .py, {len(b)} in the .ipynb")
    for i, (ca, cb) in enumerate(zip(a, b)):
        if ca != cb:
            first = (ca[1].splitlines() or [""])[0][:60]
            out.append(f"{py_path.name}: cell {i} differs ({ca[0]} in the .py, {cb[0]} in the .ipynb; "
                       f".py starts {first!r})")
            break
    return out


def test_there_are_notebooks():
    assert len(list(NOTEBOOKS.glob("*.ipynb"))) >= 6


def test_every_notebook_has_its_pair():
    assert unpaired(NOTEBOOKS) == [], "notebooks without their .py or .ipynb pair"


@pytest.mark.parametrize("py", sorted(NOTEBOOKS.glob("*.py")), ids=lambda p: p.stem)
def test_pair_in_sync(py):
    diff = pair_differences(py)
    assert diff == [], "\n".join(diff) + "\nrun: jupytext --sync notebooks/*.py"


# -- the check itself can fail ---------------------------------------------------------

@pytest.fixture
def pair(tmp_path):
    py = sorted(NOTEBOOKS.glob("*.py"))[0]
    shutil.copy(py, tmp_path / py.name)
    shutil.copy(py.with_suffix(".ipynb"), tmp_path / py.with_suffix(".ipynb").name)
    return tmp_path / py.name


def test_copy_in_sync(pair):
    assert pair_differences(pair) == []


def test_edited_code_cell_detected(pair):
    text = pair.read_text()
    first_code = text.index("\n# %%\n") + len("\n# %%\n")
    pair.write_text(text[:first_code] + "x = 1  # edited\n" + text[first_code:])
    diff = pair_differences(pair)
    assert len(diff) == 1 and "differs" in diff[0]


def test_edited_markdown_in_ipynb_detected(pair):
    ipynb = pair.with_suffix(".ipynb")
    nb = nbformat.read(ipynb, as_version=4)
    md = next(c for c in nb.cells if c.cell_type == "markdown")
    md.source += "\nan added line"
    nbformat.write(nb, ipynb)
    assert len(pair_differences(pair)) == 1


def test_added_cell_detected(pair):
    pair.write_text(pair.read_text() + "\n# %%\nprint('one more')\n")
    assert "cells in the .py" in pair_differences(pair)[0]


def test_cell_type_change_detected(pair):
    ipynb = pair.with_suffix(".ipynb")
    nb = nbformat.read(ipynb, as_version=4)
    i = next(i for i, c in enumerate(nb.cells) if c.cell_type == "code")
    nb.cells[i] = nbformat.v4.new_markdown_cell(nb.cells[i].source)
    nbformat.write(nb, ipynb)
    assert len(pair_differences(pair)) == 1


def test_missing_pair_detected(pair):
    pair.with_suffix(".ipynb").unlink()
    assert unpaired(pair.parent) == [pair.stem]


# -- committed with their outputs -------------------------------------------------------

@pytest.mark.parametrize("ipynb", sorted(NOTEBOOKS.glob("*.ipynb")), ids=lambda p: p.stem)
def test_notebook_at_most_3_mb(ipynb):
    assert ipynb.stat().st_size <= 3_000_000, f"{ipynb.name}: {ipynb.stat().st_size / 1e6:.2f} MB > 3 MB"


@pytest.mark.parametrize("ipynb", sorted(NOTEBOOKS.glob("*.ipynb")), ids=lambda p: p.stem)
def test_notebook_stored_with_outputs(ipynb):
    nb = nbformat.read(ipynb, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert any(c.outputs for c in code), (
        f"{ipynb.name} has no stored outputs: run python docs/execute_notebooks.py {ipynb.stem}")
    errors = [c.id for c in code for o in c.outputs if o.output_type == "error"]
    assert errors == [], f"{ipynb.name}: cells {errors} stored an error"


# -- the runner that stores the outputs (docs/execute_notebooks.py) ----------------------

def _runner():
    import importlib.util

    path = NOTEBOOKS.parent / "docs" / "execute_notebooks.py"
    spec = importlib.util.spec_from_file_location("execute_notebooks", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


TINY = '''# %% [markdown]
# # A tiny notebook

# %%
import matplotlib.pyplot as plt
print("n  n^2")
for n in range(3):
    print(n, n * n)

# %%
plt.plot([0, 1, 2], [0, 1, 4])
plt.show()
'''


def test_runner_stores_text_and_png(tmp_path):
    py = tmp_path / "01_tiny.py"
    py.write_text(TINY)
    error, seconds, mb = _runner().execute(py, timeout=120)
    assert error is None
    nb = nbformat.read(py.with_suffix(".ipynb"), as_version=4)
    assert [c.id for c in nb.cells] == ["c00", "c01", "c02"]
    assert "".join(o.get("text", "") for o in nb.cells[1].outputs) == "n  n^2\n0 0\n1 1\n2 4\n"
    assert [o for o in nb.cells[2].outputs if "image/png" in o.get("data", {})], "the figure is not a PNG"
    assert pair_differences(py) == []
    assert 0 < mb < 1


def test_runner_reports_a_failing_cell_and_keeps_the_pair(tmp_path):
    py = tmp_path / "01_fails.py"
    py.write_text(TINY + "\n# %%\n1 / 0\n")
    error, _, _ = _runner().execute(py, timeout=120)
    assert error == "ZeroDivisionError: division by zero"
    assert pair_differences(py) == []


def test_widget_gets_its_png_and_jpeg_copies_go():
    runner = _runner()
    nb = nbformat.v4.new_notebook()
    view = {runner.WIDGET_VIEW: {"model_id": "box"}, "text/plain": "interactive(...)"}
    nb.cells = [nbformat.v4.new_code_cell("interact(...)", outputs=[
        nbformat.v4.new_output("display_data", data=view),
        nbformat.v4.new_output("display_data", data={"image/png": "P0", "image/jpeg": "J0"}),
    ])]
    nb.metadata["widgets"] = {runner.WIDGET_STATE: {"state": {
        "box": {"state": {"children": ["IPY_MODEL_slider", "IPY_MODEL_out"]}},
        "slider": {"state": {"value": 0.5}},
        "out": {"state": {"outputs": [{"output_type": "display_data",
                                        "data": {"image/jpeg": "J1", "image/png": "P1"}}]}},
    }}}
    runner.keep_png_only(nb)
    runner.add_widget_fallbacks(nb)
    first, second = nb.cells[0].outputs
    assert first["data"]["image/png"] == "P1" and runner.WIDGET_VIEW in first["data"]
    assert second["data"] == {"image/png": "P0"}
    out = nb.metadata["widgets"][runner.WIDGET_STATE]["state"]["out"]["state"]["outputs"][0]
    assert out["data"] == {"image/png": "P1"}

"""The index of the originals' figures and tables keeps in step with the notebooks.

``docs/figures.yaml`` lists every figure and table of the thesis (Figs 2.1-7.21, Tables
3.1-7.5) and of the 2001 paper, once each, with where a notebook reproduces it or why none
does; ``docs/figure_index.py`` makes the book's page ``figures.md`` from it. Here: the list
is complete and has no duplicate; each "reproduced" entry names a notebook section and a
cell in it whose stored outputs hold an image (a figure) or a printed table (a table); each
"see" resolves too; and the built page shows each number once, with links that land on the
chapter pages' headings. A renamed heading or an edited cell fails here, not in a reader's
browser.
"""

import re
import sys
from pathlib import Path

import pytest

import _book

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "docs"))
import figure_index as fi  # noqa: E402  (docs/figure_index.py)

ENTRIES = fi.load()
REPRODUCED = [e for e in ENTRIES if fi.status(e) == "reproduced"]
SEE = [e for e in ENTRIES if e.get("see")]
KEYS = {"ref", "caption", "notebook", "section", "cell", "missing", "why", "see", "note"}


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    return _book.site(tmp_path_factory)


def test_every_figure_and_table_of_the_originals_once_in_order():
    refs = [e["ref"] for e in ENTRIES]
    expected = fi.expected_refs()
    assert len(expected) == 89 + 16 + 7 + 2
    twice = sorted({r for r in refs if refs.count(r) > 1})
    assert not twice, f"listed more than once: {twice}"
    assert not set(expected) - set(refs), f"not listed: {sorted(set(expected) - set(refs))}"
    assert not set(refs) - set(expected), f"not in the originals: {sorted(set(refs) - set(expected))}"
    assert refs == expected, "figures.yaml is not in the originals' order"


@pytest.mark.parametrize("entry", ENTRIES, ids=lambda e: e.get("ref", "?"))
def test_each_entry_says_where_or_why(entry):
    assert set(entry) <= KEYS, f"unknown keys {sorted(set(entry) - KEYS)}"
    assert entry.get("caption"), "no caption"
    said = [k for k in ("notebook", "missing", "why") if entry.get(k)]
    assert len(said) == 1, f"give one of notebook (reproduced), missing, why; got {said}"
    if entry.get("notebook"):
        assert entry.get("section") and entry.get("cell"), "a reproduction names its section and cell"
        assert not entry.get("see")
    for where in [entry.get("see")] if entry.get("see") else []:
        assert set(where) == {"notebook", "section", "cell"}


def _locate(where):
    try:
        return fi.locate(where["notebook"], where["section"], where["cell"])
    except LookupError as e:   # a heading renamed or a cell rewritten: say where to follow it
        pytest.fail(f"{e} (update the entry in docs/figures.yaml)")


@pytest.mark.parametrize("entry", REPRODUCED, ids=lambda e: e["ref"])
def test_reproduced_links_to_a_cell_that_stores_it(entry):
    place = _locate(entry)
    wanted = "table" if "Table" in entry["ref"] else "image"
    assert wanted in place.kinds, (
        f"{entry['ref']}: cell {place.cell} of {place.notebook} (§ {place.heading}) stores "
        f"{list(place.kinds) or 'no image and no table'}")


@pytest.mark.parametrize("entry", SEE, ids=lambda e: e["ref"])
def test_see_links_resolve(entry):
    _locate(entry["see"])


def test_output_kinds():
    figure = {"outputs": [{"output_type": "display_data", "data": {"image/png": "..."}}]}
    ruled = {"outputs": [{"output_type": "stream", "text": [" a   b\n", "--  --\n", " 1   2\n"]}]}
    aligned = {"outputs": [{"output_type": "stream", "text": "x  N_1  N_2\nd1  3 (4)  5\nd2  6  7 (8)\n"}]}
    prose = {"outputs": [{"output_type": "stream", "text": "12 cells, 3 extrema  -- all found\n"}]}
    assert fi.output_kinds(figure) == ("image",)
    assert fi.output_kinds(ruled) == fi.output_kinds(aligned) == ("table",)
    assert fi.output_kinds(prose) == ()


def test_the_page_shows_each_number_once_and_its_links_land(site):
    html = (site / "figures.html").read_text()
    rows = re.findall(r'<tr class="row-(?:odd|even)"><td><p>([^<]*)</p></td>', html)
    assert sorted(rows) == sorted(fi.expected_refs()), "the page's rows are not the originals' numbers, once each"
    links = set(re.findall(r'href="(notebooks/[^"#]+\.html)#([^"]+)"', html))
    assert len({page for page, _ in links}) >= 8
    for page, anchor in sorted(links):
        assert f'id="{anchor}"' in (site / page).read_text(), f"{page}#{anchor} lands nowhere"
    assert 'href="figures.html"' in (site / "index.html").read_text(), "the index does not link the page"

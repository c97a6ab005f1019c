"""The index of the originals' figures and tables, from ``docs/figures.yaml``.

``figures.yaml`` is the data: one entry per figure or table of the thesis (chapters 2-7)
and of the 2001 paper, saying where a notebook reproduces it or why none does. This
module reads it, finds each entry's cell in the committed notebook, and writes the book's
page ``docs/figures.md`` (generated at each build by ``conf.py``, like
``notebooks/index.md``). ``tests/test_figure_index.py`` holds the page to the notebooks.

A link names a section heading of the notebook (its anchor on the chapter page) and a
snippet of the code cell's source below it; neither changes when a notebook is
re-executed, and the test fails when either is renamed. Cell ids are not used: the
notebooks' ids (``c08``) follow the cell's position, which a new cell upstream shifts.
"""

import json
import re
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DATA = HERE / "figures.yaml"

# what the originals contain (captions read in the thesis and the paper, chapter by chapter)
THESIS_FIGURES = {2: 10, 3: 23, 4: 13, 5: 7, 6: 15, 7: 21}   # 89: Fig. 2.1 to Fig. 7.21
THESIS_TABLES = {3: 2, 4: 2, 5: 2, 6: 5, 7: 5}               # 16: Table 3.1 to Table 7.5
PAPER_FIGURES = 7
PAPER_TABLES = 2

# a printed table, as ``polygen.plotting.table`` (and tabulate) draws it: a rule of dashes
_RULE = re.compile(r"^\s*-{2,}(?:\s+-{2,})+\s*$", re.M)


def _is_table(text):
    """A printed table: a rule of dashes under the header, or at least three lines in a row
    (a header and two rows) of the same number (3 or more) of columns two spaces apart."""
    if _RULE.search(text):
        return True
    run, width = 0, 0
    for line in text.splitlines():
        n = len(re.split(r"\s{2,}", line.strip())) if line.strip() else 0
        run = run + 1 if n >= 3 and n == width else (1 if n >= 3 else 0)
        width = n
        if run >= 3:
            return True
    return False


def expected_refs():
    """Every reference the index must hold once, in order: chapter by chapter, its figures
    then its tables, then the paper's."""
    refs = []
    for c, n in THESIS_FIGURES.items():
        refs += [f"Fig. {c}.{k}" for k in range(1, n + 1)]
        refs += [f"Table {c}.{k}" for k in range(1, THESIS_TABLES.get(c, 0) + 1)]
    refs += [f"2001 Fig. {k}" for k in range(1, PAPER_FIGURES + 1)]
    refs += [f"2001 Table {k}" for k in range(1, PAPER_TABLES + 1)]
    return refs


@dataclass(frozen=True)
class Place:
    """A cell of a committed notebook, found by its section heading and a source snippet."""

    notebook: str   # file stem under notebooks/
    heading: str    # the section's heading text, as written after the #s
    anchor: str     # its id on the chapter page
    cell: int       # index of the code cell in the .ipynb
    kinds: tuple    # what the cell's stored outputs show: "image", "table"


def load():
    """The entries of ``figures.yaml`` (a list of dicts), in their order."""
    import yaml  # myst-parser's own dependency

    return yaml.safe_load(DATA.read_text())


def _slug(heading):
    """The anchor myst gives a heading (``myst_heading_anchors``): GitHub's slug of its text."""
    from myst_parser.slugs import github_slugify

    return github_slugify(re.sub(r"[`*_]", "", heading))


def output_kinds(cell):
    """``("image",)``, ``("table",)``, both or neither: what a code cell's outputs show."""
    kinds = set()
    for out in cell.get("outputs", []):
        data = out.get("data", {})
        if any(k.startswith("image/") for k in data):
            kinds.add("image")
        text = "".join(out.get("text", "")) + "".join(data.get("text/plain", ""))
        if "<table" in "".join(data.get("text/html", "")) or _is_table(text):
            kinds.add("table")
    return tuple(sorted(kinds))


def locate(notebook, section, snippet=None, *, root=ROOT):
    """Find the cell: the section whose heading starts with ``section``, then in it the code
    cell whose source contains ``snippet`` (or, without one, its first cell with an image or
    a table). Raises ``LookupError`` saying what was not found."""
    path = root / "notebooks" / f"{notebook}.ipynb"
    if not path.exists():
        raise LookupError(f"no notebook {path.name}")
    cells = json.loads(path.read_text())["cells"]
    starts = []   # (cell index, level, heading)
    for i, c in enumerate(cells):
        if c["cell_type"] == "markdown":
            for line in "".join(c["source"]).splitlines():
                m = re.match(r"(#{1,6})\s+(.*\S)", line)
                if m:
                    starts.append((i, len(m.group(1)), m.group(2)))
    hits = [s for s in starts if s[2].startswith(section)]
    if len(hits) != 1:
        raise LookupError(f"{notebook}: {len(hits)} headings start with {section!r}")
    first, level, heading = hits[0]
    # the section runs to the next heading of the same or a higher level
    end = next((i for i, lv, _ in starts if i > first and lv <= level), len(cells))
    code = [(i, cells[i]) for i in range(first, end) if cells[i]["cell_type"] == "code"]
    if snippet is None:
        found = [(i, c) for i, c in code if output_kinds(c)][:1]
    else:
        found = [(i, c) for i, c in code if snippet in "".join(c["source"])]
    if len(found) != 1:
        what = f"a cell containing {snippet!r}" if snippet else "a cell with an image or a table"
        raise LookupError(f"{notebook} § {heading!r}: {len(found)} matches for {what}")
    i, c = found[0]
    return Place(notebook, heading, _slug(heading), i, output_kinds(c))


def _cell_link(where, title=None):
    place = locate(where["notebook"], where["section"], where.get("cell"))
    text = title or f"{place.notebook.split('_')[0]} § {place.heading}"
    return f"[{_md(text)}](notebooks/{place.notebook}.ipynb#{place.anchor})"


def _md(text):
    return str(text).replace("|", "\\|").replace("\n", " ").strip()


def status(e):
    """``"reproduced"``, ``"missing"`` (a notebook could draw it and does not) or
    ``"not reproduced"`` (nothing to draw: a concept diagram, pseudo-code, a proof's sketch)."""
    return "reproduced" if e.get("notebook") else "missing" if e.get("missing") else "not reproduced"


def _row(e):
    if status(e) == "reproduced":
        where = "reproduced: " + _cell_link(e)
    else:
        where = f"{status(e)}: " + _md(e.get("missing") or e["why"])
        if e.get("see"):
            where += " — see " + _cell_link(e["see"])
    note = _md(e.get("note", ""))
    return f"| {e['ref']} | {_md(e['caption'])} | {where} | {note} |"


def counts(entries):
    """``{group: {status: count}}`` for the page's summary."""
    groups = {"thesis figures": lambda r: r.startswith("Fig."),
              "thesis tables": lambda r: r.startswith("Table"),
              "2001 figures": lambda r: r.startswith("2001 Fig."),
              "2001 tables": lambda r: r.startswith("2001 Table")}
    out = {}
    for name, is_in in groups.items():
        mine = [status(e) for e in entries if is_in(e["ref"])]
        out[name] = {s: mine.count(s) for s in ("reproduced", "missing", "not reproduced")}
    return out


def _table(entries):
    head = "| No. | In the original | Here | Note |\n|---|---|---|---|\n"
    return head + "\n".join(_row(e) for e in entries) + "\n"


def render(entries=None):
    """The text of ``figures.md``."""
    entries = load() if entries is None else entries
    summary = "\n".join(f"- {name} ({sum(c.values())}): " + ", ".join(f"{n} {s}" for s, n in c.items() if n)
                        for name, c in counts(entries).items())
    parts = [
        "# Figures and tables of the originals\n",
        "Every figure (Figs 2.1–7.21) and table (Tables 3.1–7.5) of the thesis, and those of\n"
        "the 2001 paper: where a notebook reproduces it — a link to the section, whose cell\n"
        "with the stored figure or table is named in `docs/figures.yaml` — or why none does.\n"
        "Captions are the originals' (Japanese), in English. This page is generated from\n"
        "`docs/figures.yaml`; `tests/test_figure_index.py` checks every link against the\n"
        "committed notebooks.\n",
        summary + "\n",
    ]
    for chapter in THESIS_FIGURES:
        mine = [e for e in entries if re.match(rf"(Fig\.|Table) {chapter}\.", e["ref"])]
        parts.append(f"## Chapter {chapter}\n\n" + _table(mine))
    paper = [e for e in entries if e["ref"].startswith("2001 ")]
    parts.append("## The 2001 paper\n\nItoh, Yamaguchi, Koyamada, *A fast polygon construction method "
                 "for isosurface generation* (IPSJ journal, 2001).\n\n" + _table(paper))
    return "\n".join(parts)


def write(path=HERE / "figures.md"):
    """Write the page if its text changed (an unchanged file keeps Sphinx's cache)."""
    text = render()
    if not path.exists() or path.read_text() != text:
        path.write_text(text)
    return path

"""Where each committed result came from: the commit and date it was made at.

Every script records ``machine()`` (``_common.py``: the commit, ``+dirty`` when tracked files
differed, and the UTC date) in its results. Results written before the scripts did so get, once,
the commit that wrote them into the repository and that commit's date, taken from git's history
and marked as such (``"commit_from": "git history"``; the measured code is that commit's, or its
parent's when the results came in with the change they measure); their markdown gets the same line.

Usage, from the repository root::

    python benchmarks/provenance.py            # stamp what lacks a stamp, print the table
    python benchmarks/provenance.py --check    # only print; exit 1 when a results file lacks a stamp
"""

import argparse
import json
import sys

from _common import RESULTS, _git


def stamp(path):
    """The results file's ``(commit, date, source)``, stamping it from git's history when it has none."""
    data = json.loads(path.read_text())
    m = data.get("machine") if isinstance(data, dict) else None
    if isinstance(m, dict) and m.get("commit"):
        return m["commit"], m.get("date"), m.get("commit_from", "the script")
    log = _git("log", "-1", "--format=%H %cI", "--", str(path))
    if not log:
        return None, None, "not committed"
    commit, date = log.split()
    if isinstance(data, dict) and isinstance(data.setdefault("machine", {}), dict):
        data["machine"].update(commit=commit, date=date, commit_from="git history")
        path.write_text(json.dumps(data, indent=1) + "\n")
    md = path.with_suffix(".md")
    if md.exists():
        md.write_text(md.read_text().rstrip("\n") + f"\n\nMade before the script recorded its commit: "
                      f"committed in `{commit[:10]}` on {date[:10]} (from git's history).\n")
    return commit, date, "git history"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="print only; exit 1 when a file lacks a stamp")
    args = ap.parse_args()
    missing = 0
    print("| results file | commit | date | recorded by |\n|---|---|---|---|")
    for path in sorted(RESULTS.glob("*.json")):
        if args.check:
            m = json.loads(path.read_text())
            m = m.get("machine", {}) if isinstance(m, dict) else {}
            commit, date, source = m.get("commit"), m.get("date"), m.get("commit_from", "the script")
        else:
            commit, date, source = stamp(path)
        missing += commit is None
        print(f"| {path.name} | {(commit or '-')[:10]} | {(date or '-')[:10]} | {source} |")
    return 1 if args.check and missing else 0


if __name__ == "__main__":
    sys.exit(main())

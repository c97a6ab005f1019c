"""Write ``tests/durations.json`` from a JUnit XML report: each test file's seconds, longest first.

The test command's workers take whole files in that order (``conftest.py``), so that no long file
starts last while the other worker idles. Refresh it after a test file grows or shrinks a lot::

    python -m pytest -n auto --dist loadfile --junitxml=/tmp/junit.xml   # on a fresh clone
    python tests/_durations.py /tmp/junit.xml
"""

import collections
import json
import pathlib
import sys
import xml.etree.ElementTree as ET


def file_seconds(junit_path):
    """``{file: seconds}``: the time of the test cases of each file (notebook cells under the notebook)."""
    per = collections.Counter()
    for case in ET.parse(junit_path).getroot().iter("testcase"):
        name = case.get("classname", "")
        if name.endswith(".ipynb"):  # notebooks.02_x.ipynb
            path = name.replace(".", "/", name.count(".") - 1)
        else:  # tests.test_x
            path = name.replace(".", "/") + ".py"
        per[path] += float(case.get("time", 0))
    return {f: round(s, 1) for f, s in sorted(per.items(), key=lambda kv: -kv[1])}


if __name__ == "__main__":
    out = pathlib.Path(__file__).with_name("durations.json")
    out.write_text(json.dumps(file_seconds(sys.argv[1]), indent=0) + "\n")
    print(f"wrote {out}")

import json
import os

# Headless rendering: VTK's EGL window needs no X server (set before VTK loads).
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("MPLBACKEND", "Agg")
# Idle OpenMP threads sleep at once instead of spinning (libgomp reads this when numba first loads it).
# Two pytest-xdist workers on two cores run four kernel threads: a spinning thread holds the core its
# partner waits for. Measured on this 2-core machine (load 3.4-5, test_active_scan + test_partitioned in
# two workers): 165-203 s spinning, 85-89 s passive. The tests assert no timings; the benchmarks and
# the CLI keep libgomp's default.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

import pytest  # noqa: E402


def pytest_addoption(parser):
    parser.addoption("--runslow", action="store_true", default=False, help="run tests marked slow")


def pytest_configure(config):
    # pytest-xdist hands out test files largest-count first; the order below (longest first) is kept instead
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


# Seconds each test file took in the test command on a fresh clone (tests/durations.json: a scheduling
# hint, not a result; a file not listed counts as the median). With --dist loadfile the workers take whole
# files in this order, longest first, so that no long file starts last while the other worker idles.
_DURATIONS = os.path.join(os.path.dirname(__file__), "tests", "durations.json")


def _longest_files_first(config, items):
    try:
        with open(_DURATIONS) as f:
            cost = json.load(f)
    except (OSError, ValueError):
        return
    default = sorted(cost.values())[len(cost) // 2] if cost else 0.0
    root = str(config.rootpath)
    def file_of(item):
        return os.path.relpath(str(item.path), root).replace(os.sep, "/")
    first = {}
    for i, item in enumerate(items):
        first.setdefault(file_of(item), i)
    items.sort(key=lambda item: (-cost.get(file_of(item), default), first[file_of(item)]))


def pytest_collection_modifyitems(config, items):
    _longest_files_first(config, items)
    if config.getoption("--runslow"):
        return
    skip_slow = pytest.mark.skip(reason="slow: run with --runslow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip_slow)

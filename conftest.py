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
    order = sorted(first, key=lambda f: (-cost.get(f, default), first[f]))
    rank = {f: i for i, f in enumerate(_apart_at_start(root, order))}
    items.sort(key=lambda item: rank[file_of(item)])


def _apart_at_start(root, order):
    """``order`` with its second file the longest that does not share the first's numba kernels.

    The workers take the first two files at once, on an empty numba cache: two files of the volume
    kernels then compile the same kernels side by side, each for itself (the two edge-centred files:
    99 kernels, 56 CPU-seconds compiled twice, measured from numba's compile events). A file that
    imports no ``polygen.volume`` (the radiosity half) goes second instead, and the next volume file
    starts when the first has already cached much of what it compiles.
    """
    def volume(f):
        try:
            with open(os.path.join(root, f), encoding="utf-8") as fh:
                return "polygen.volume" in fh.read()
        except OSError:
            return True
    if len(order) < 3 or not (volume(order[0]) and volume(order[1])):
        return order
    other = next((f for f in order[2:] if not volume(f)), None)
    if other is None:
        return order
    rest = [f for f in order[1:] if f != other]
    return [order[0], other, *rest]


def pytest_collection_modifyitems(config, items):
    _longest_files_first(config, items)
    if config.getoption("--runslow"):
        return
    skip_slow = pytest.mark.skip(reason="slow: run with --runslow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip_slow)

import os

# Headless rendering: VTK's EGL window needs no X server (set before VTK loads).
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("MPLBACKEND", "Agg")

import pytest  # noqa: E402


def pytest_addoption(parser):
    parser.addoption("--runslow", action="store_true", default=False, help="run tests marked slow")


def pytest_configure(config):
    """On a first run with pytest-xdist (no kernel in numba's cache yet), compile the volume kernels once,
    here, before the workers start: else each worker compiles what it first meets, often the same kernels at
    the same moment (on a fresh clone the slowest tests were first-use compiles). The main job's warm-up does
    it (two processes, both cell types, the large volumes' paths); on a second run nothing compiles and this
    costs nothing."""
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    import time

    from polygen.cli.isosurface import _early_helper, _method_names, _warm_up

    helper = _early_helper(2)
    if helper is None:  # kernels cached, one core or numba's cache off: nothing to share
        return
    t0 = time.perf_counter()
    names = _method_names()
    _warm_up(names, "tetra", helper=helper, n_cells=10**7)
    _warm_up(names, "hexahedron", n_cells=10**7)
    print(f"polygen: compiled the volume kernels before the workers started: {time.perf_counter() - t0:.0f} s")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--runslow"):
        return
    skip_slow = pytest.mark.skip(reason="slow: run with --runslow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip_slow)

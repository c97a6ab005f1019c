"""The package's layers, read from the source: no algorithm imports plotting or the CLI, no cycle, and
the modules of ``polygen/volume`` import only their own layer or the layers below.

Every ``import`` statement counts, at module level or inside a function (a lazy import is still an
arrow). The checks run on a source tree given as a path, so the last test can plant violations in a
copy and see each check catch them.
"""

import ast
import shutil
from pathlib import Path

import polygen

ROOT = Path(polygen.__file__).parent

#: subpackages holding algorithms: none of them may import FORBIDDEN
ALGORITHMS = ("volume", "radiosity", "mesh2d")
FORBIDDEN = ("polygen.plotting", "polygen.cli", "polygen.widgets")

#: Cycles that are known and accepted (none now): the test fails when one of them goes away
#: (remove it here) as much as when a new one appears.
KNOWN_CYCLES = []

#: polygen/volume, bottom up: a module may import its own layer or lower ones (CONTRIBUTING.md)
VOLUME_LAYERS = [
    ("tables", ["_cells", "registry", "errors"]),
    ("kernels", ["_topology", "marching", "_intrinsics", "_edge_centred_kernels", "_edge_walk_kernels",
                 "_vertex_hash", "_extrema_kernels", "_thinning_kernels", "_active_scan_kernels"]),
    ("formats", ["io"]),
    ("mesh", ["mesh"]),
    ("data sets", ["datasets"]),
    ("result and validation", ["surface"]),
    ("search structures", ["seeds"]),
    ("constructions", ["propagate", "isosurface"]),
    ("methods", ["methods"]),
    ("chapter methods", ["homology", "extrema_graph", "thinning", "edge_centred", "active_scan", "analysis", "constructions"]),
    ("applications", ["render"]),
    ("partitioned volumes", ["partitioned", "distributed"]),
]


def modules(root):
    """``{dotted name: path}`` of every module under ``root`` (a ``polygen`` directory)."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = ("polygen",) + path.relative_to(root).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def imports(name, path, known):
    """``[(target module, line)]``: what module ``name`` imports, resolved against ``known`` names."""
    is_pkg = path.name == "__init__.py"
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = name.split(".") if is_pkg else name.split(".")[:-1]
                pkg = pkg[: len(pkg) - node.level + 1]
                base = ".".join(pkg + ([base] if base else []))
            # "from pkg import sub" imports the submodule when there is one
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
        else:
            continue
        for t in targets:
            if t.startswith("polygen"):
                out.append((t, node.lineno))
    return out


def graph(root):
    """``{module: {imported polygen module: first line}}`` over the tree ``root``."""
    mods = modules(root)
    g = {}
    for name, path in mods.items():
        edges = {}
        for target, line in imports(name, path, mods):
            # "import polygen.volume.mesh" names the deepest module that exists
            while target not in mods and "." in target:
                target = target.rsplit(".", 1)[0]
            if target in mods and target != name:
                edges.setdefault(target, line)
        g[name] = edges
    return g


def forbidden_imports(root):
    """``["module:line -> target"]`` for every algorithm module importing plotting, the CLI or widgets."""
    bad = []
    for name, edges in graph(root).items():
        if name.split(".")[1:2] and name.split(".")[1] in ALGORITHMS:
            bad += [f"{name}:{line} -> {t}" for t, line in edges.items() if t.startswith(FORBIDDEN)]
    return bad


def cycles(root, *, skip_packages=True):
    """Every strongly connected set of two or more modules (Tarjan), as sorted lists.

    A package's ``__init__`` that imports its submodules to re-export them is left out
    (``skip_packages``): importing a submodule runs its package first by Python's rules, not by an
    arrow in our code.
    """
    g = graph(root)
    pkgs = {p for p in g if (root / Path(*p.split(".")[1:]) / "__init__.py").exists()} if skip_packages else set()
    g = {a: [b for b in e if b not in pkgs] for a, e in g.items() if a not in pkgs}
    index, low, on, stack, out = {}, {}, set(), [], []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in g.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def layer_of(name):
    """Index in :data:`VOLUME_LAYERS` of a ``polygen.volume`` module (``None`` outside it)."""
    parts = name.split(".")
    if parts[:2] != ["polygen", "volume"] or len(parts) < 3:
        return None
    for i, (_, mods) in enumerate(VOLUME_LAYERS):
        if parts[2] in mods:
            return i
    raise AssertionError(f"{name} is in no layer of VOLUME_LAYERS: add it (and to CONTRIBUTING.md)")


def upward_imports(root):
    """``["module (layer) -> target (layer)"]`` for every import from a lower to a higher volume layer."""
    bad = []
    for name, edges in graph(root).items():
        a = layer_of(name)
        if a is None:
            continue
        for t, line in edges.items():
            b = layer_of(t)
            if b is not None and b > a:
                bad.append(f"{name}:{line} ({VOLUME_LAYERS[a][0]}) -> {t} ({VOLUME_LAYERS[b][0]})")
    return bad


def test_no_algorithm_imports_plotting_or_cli():
    assert forbidden_imports(ROOT) == []


def test_no_import_cycle():
    assert [set(c) for c in cycles(ROOT)] == KNOWN_CYCLES


def test_volume_layers_point_down():
    assert upward_imports(ROOT) == []


def test_the_walk_sees_the_imports_it_should():
    # a check that sees nothing passes for the wrong reason
    g = graph(ROOT)
    assert "polygen.volume.marching" in g["polygen.volume.surface"]  # a module-level import
    assert "polygen.volume.registry" in g["polygen.volume.mesh"]
    assert "polygen.plotting.extrema" in g["polygen.plotting.thinning"]  # an import inside a function
    assert "polygen.volume.seeds.base" in g["polygen.volume.seeds.full_scan"]
    assert any(t.startswith("polygen.plotting") for t in g["polygen.cli.isosurface"])


def test_checks_catch_planted_violations(tmp_path):
    root = tmp_path / "polygen"
    shutil.copytree(ROOT, root, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    assert forbidden_imports(root) == upward_imports(root) == []
    assert [set(c) for c in cycles(root)] == KNOWN_CYCLES

    def plant(rel, line):
        """Append ``line`` to the copy of ``rel``; the line number of its last line."""
        p = root / rel
        p.write_text(p.read_text() + "\n\n" + line + "\n")
        return len(p.read_text().splitlines())

    n1 = plant("volume/marching.py", "def _f():\n    from polygen.plotting import volume  # noqa")
    n2 = plant("mesh2d/quality.py", "import polygen.cli.isosurface  # noqa")
    assert sorted(forbidden_imports(root)) == [f"polygen.mesh2d.quality:{n2} -> polygen.cli.isosurface",
                                               f"polygen.volume.marching:{n1} -> polygen.plotting.volume"]
    # as in issue 18, where marching took its tables from the mesh: a kernel reaching up to a module
    # that stands on it
    plant("volume/marching.py", "from polygen.volume.surface import IsoSurface  # noqa")
    assert any({"polygen.volume.marching", "polygen.volume.surface"} <= set(c) for c in cycles(root))
    plant("volume/mesh.py", "from polygen.volume import methods  # noqa")
    assert any(b.startswith("polygen.volume.mesh:") and b.endswith("-> polygen.volume.methods (methods)")
               for b in upward_imports(root))
    plant("volume/_cells.py", "from .thinning import thin_volume  # noqa")
    assert any(b.startswith("polygen.volume._cells:") for b in upward_imports(root))

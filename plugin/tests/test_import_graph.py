"""No import loops inside the hairbsdf package.

The graph is read from the source's AST, so imports inside functions count too (a loop that
works only because one side imports late is still a loop). `from . import name` is an edge to
the submodule `name` when there is one; the compiled modules (plugin/CMakeLists.txt's
pybind11_add_module targets) import nothing of ours."""

import ast
import re
from pathlib import Path

PLUGIN = Path(__file__).resolve().parent.parent


def package_modules(root: Path, package: str) -> dict:
    """{dotted name: (path or None for a compiled module, is a package)}"""
    mods = {}
    for path in (root / package).rglob("*.py"):
        parts = list(path.relative_to(root).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        mods[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    cmake = root / "CMakeLists.txt"
    if cmake.exists():
        for name in re.findall(r"pybind11_add_module\((\w+)", cmake.read_text()):
            mods[f"{package}.{name}"] = (None, False)
    return mods


def _known(mods, name):
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name


def import_graph(root: Path, package: str) -> dict:
    """{module: set of the package's modules it imports anywhere in its source}"""
    mods = package_modules(root, package)
    graph = {}
    for mod, (path, is_package) in mods.items():
        deps = set()
        if path is not None:
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.Import):
                    deps |= {_known(mods, a.name) for a in node.names if a.name.split(".")[0] == package}
                elif isinstance(node, ast.ImportFrom):
                    here = mod.split(".") if is_package else mod.split(".")[:-1]
                    if node.level:
                        here = here[:len(here) - (node.level - 1)]
                        base = ".".join(here + ([node.module] if node.module else []))
                    else:
                        base = node.module or ""
                    if base.split(".")[0] != package:
                        continue
                    deps |= {f"{base}.{a.name}" if f"{base}.{a.name}" in mods else _known(mods, base)
                             for a in node.names}
        graph[mod] = {d for d in deps if d and d != mod}
    return graph


def import_loops(graph: dict) -> list:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, loops = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                loops.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return loops


def test_the_package_has_no_import_loops():
    graph = import_graph(PLUGIN, "hairbsdf")
    assert len(graph) > 40 and "hairbsdf.blender.export_materials" in graph
    assert import_loops(graph) == []


def test_a_loop_through_a_late_import_is_found(tmp_path):
    """The checker itself: a loop closed by an import inside a function, and `from . import`
    of a submodule, are both found; a compiled module ends a path."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from . import _native\n")
    (pkg / "a.py").write_text("from .sub import b\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "b.py").write_text("def f():\n    from .. import a\n    return a\n")
    (pkg / "c.py").write_text("from . import _native\n")
    (tmp_path / "CMakeLists.txt").write_text("pybind11_add_module(_native MODULE x.cpp)\n")
    graph = import_graph(tmp_path, "pkg")
    assert graph["pkg.a"] == {"pkg.sub.b"} and graph["pkg.c"] == {"pkg._native"}
    assert import_loops(graph) == [["pkg.a", "pkg.sub.b"]]

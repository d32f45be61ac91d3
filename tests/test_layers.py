"""Layers point down and no litl module imports itself back, read from the source with `ast`.

Every import between litl modules counts: at module level, inside a function (deferred) and under
``if TYPE_CHECKING:``. A deferred or type-only import hides a cycle from Python's import
machinery, not from the design: the two modules still depend on each other, and moving the
import to the top (or starting to run the code under TYPE_CHECKING) would break. Importing
``litl.a.b`` also runs ``litl/a/__init__.py`` and so counts as importing the package ``litl.a``,
unless the importer is inside it (a package's modules import their siblings while its
``__init__`` runs; that is how every package here starts). Imports by name at run time
(`importlib`, as `litl.__init__` loads its subpackages lazily) are not seen.
"""

from __future__ import annotations

import ast
import dataclasses
import pathlib

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / "litl"

# (a package, packages it must not import): each layer imports only the ones below it.
FORBIDDEN = {
    "litl.sim": ("litl.robots", "litl.models", "litl.observers", "litl.loop"),
    "litl.models": ("litl.observers", "litl.loop"),
    "litl.observers": ("litl.loop", "litl.controllers"),
    "litl.controllers": ("litl.loop", "litl.observers"),
    # The settings' machinery is the bottom: what every section, registry and reader builds on.
    "litl.settings": (
        "litl.config",
        "litl.sim",
        "litl.robots",
        "litl.models",
        "litl.observers",
        "litl.controllers",
        "litl.worlds",
        "litl.optimizers",
        "litl.designs",
        "litl.loop",
    ),
    # Inside it: dotted trees below old spellings, the schema below registries below parts.
    "litl.settings.trees": ("litl.settings.old", "litl.settings.registry", "litl.settings.parts"),
    "litl.settings.old": ("litl.settings.registry", "litl.settings.parts"),
    "litl.settings.registry": ("litl.settings.parts",),
    # What runs' records mean is plain Python, read by the report and the claims without JAX.
    "litl.records": ("litl.sim", "litl.robots", "litl.models", "litl.loop", "litl.report", "litl.claims"),
}


@dataclasses.dataclass(frozen=True)
class Import:
    """One import of a litl module by another (`kind`: "module", "deferred" or "type_checking")."""

    importer: str
    imported: str
    path: pathlib.Path  # the importer's file, from the package's parent folder
    line: int
    kind: str

    def __str__(self) -> str:
        how = "" if self.kind == "module" else f" ({self.kind.replace('_', ' ')})"
        return f"{self.importer} imports {self.imported} at {self.path}:{self.line}{how}"


def modules(root: pathlib.Path) -> dict[str, pathlib.Path]:
    """{dotted name: file} of every module of the package at `root`."""
    found = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _absolute(node: ast.ImportFrom, importer: str, is_package: bool) -> str:
    """The module ``from ... import`` reads from, relative imports made absolute."""
    if not node.level:
        return node.module or ""
    parts = importer.split(".")
    parts = parts[: len(parts) - node.level + (1 if is_package else 0)]
    return ".".join(parts + ([node.module] if node.module else []))


def _resolve(name: str, known) -> str | None:
    """The module that importing `name` runs (``a.b.f``, a function of ``a.b``: ``a.b``)."""
    while name and name not in known:
        name = name.rpartition(".")[0]
    return name or None


def _targets(node: ast.Import | ast.ImportFrom, importer: str, is_package: bool, known) -> set[str]:
    """The package's modules that `node` imports, named in it."""
    if isinstance(node, ast.Import):
        found = {_resolve(alias.name, known) for alias in node.names}
    else:
        base = _absolute(node, importer, is_package)
        # ``from a import b``: the module ``a.b`` if there is one, else ``a`` itself.
        found = {
            f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else _resolve(base, known)
            for alias in node.names
        }
    return {target for target in found if target is not None and target != importer}


def _module_imports(importer: str, path: pathlib.Path, root: pathlib.Path, known) -> list[Import]:
    is_package = path.name == "__init__.py"
    where = path.relative_to(root.parent)
    found: list[Import] = []

    def visit(node: ast.AST, kind: str) -> None:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            for target in _targets(node, importer, is_package, known):
                # Importing litl.a.b runs the packages above it that the importer is not in.
                parts = target.split(".")
                packages = {".".join(parts[:i]) for i in range(1, len(parts))}
                outside = {p for p in packages if not (importer == p or importer.startswith(p + "."))}
                for imported in sorted({target} | (outside & known.keys())):
                    found.append(Import(importer, imported, where, node.lineno, kind))
            return
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            kind = "deferred"
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for child in node.body:
                visit(child, "type_checking")
            for child in node.orelse:
                visit(child, kind)
            return
        for child in ast.iter_child_nodes(node):
            visit(child, kind)

    visit(ast.parse(path.read_text(), str(path)), "module")
    return found


def imports(root: pathlib.Path) -> list[Import]:
    """Every import of one of the package's modules by another (see the module docstring)."""
    known = modules(root)
    return [edge for importer, path in known.items() for edge in _module_imports(importer, path, root, known)]


def _groups(graph: dict[str, dict[str, Import]]) -> list[set[str]]:
    """The strongly connected groups of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    groups: list[set[str]] = []

    def connect(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for other in graph[node]:
            if other not in index:
                connect(other)
                low[node] = min(low[node], low[other])
            elif other in stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            group = set()
            while True:
                member = stack.pop()
                group.add(member)
                if member == node:
                    break
            if len(group) > 1:
                groups.append(group)

    for node in sorted(graph):
        if node not in index:
            connect(node)
    return groups


def _shortest_cycle(graph: dict[str, dict[str, Import]], group: set[str], start: str) -> list[Import]:
    """The fewest imports inside `group` that lead from `start` back to it (breadth first)."""
    reached_by: dict[str, Import] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for other, edge in sorted(graph[node].items()):
                if other == start:
                    path = [edge]
                    while path[0].importer != start:
                        path.insert(0, reached_by[path[0].importer])
                    return path
                if other in group and other not in reached_by:
                    reached_by[other] = edge
                    following.append(other)
        frontier = following
    raise AssertionError(f"{start} is in no cycle of {sorted(group)}")


def cycles(edges: list[Import]) -> list[list[Import]]:
    """One shortest cycle through each group of modules that import each other, as the imports
    that close it."""
    graph: dict[str, dict[str, Import]] = {}
    for edge in edges:
        graph.setdefault(edge.importer, {}).setdefault(edge.imported, edge)
        graph.setdefault(edge.imported, {})
    return [_shortest_cycle(graph, group, min(group)) for group in _groups(graph)]


def describe(cycle: list[Import]) -> str:
    names = " -> ".join([cycle[0].importer] + [edge.imported for edge in cycle])
    return names + "\n" + "\n".join(f"  {edge}" for edge in cycle)


def test_no_litl_module_imports_itself_back():
    found = cycles(imports(PACKAGE))
    assert not found, "import cycles in litl (break each by moving the shared piece down):\n" + "\n".join(
        describe(cycle) for cycle in found
    )


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_layers_import_only_the_layers_below(layer):
    above = FORBIDDEN[layer]
    wrong = [
        edge
        for edge in imports(PACKAGE)
        if (edge.importer == layer or edge.importer.startswith(layer + "."))
        and any(edge.imported == a or edge.imported.startswith(a + ".") for a in above)
    ]
    assert not wrong, f"{layer} must not import {', '.join(above)}:\n" + "\n".join(map(str, wrong))


def test_a_cycle_through_deferred_and_type_only_imports_is_found_and_named(tmp_path):
    package = tmp_path / "pkg"
    (package / "sub").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "sub" / "__init__.py").write_text("from pkg.sub.b import B\n")
    (package / "a.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.sub.b import B\n"
    )
    (package / "sub" / "b.py").write_text("def f():\n    from pkg import a\n")
    (package / "c.py").write_text("from pkg.sub import b\n")  # no cycle: nothing imports c
    found = cycles(imports(package))
    assert len(found) == 1
    text = describe(found[0])
    assert text.splitlines()[0] in ("pkg.a -> pkg.sub -> pkg.sub.b -> pkg.a", "pkg.a -> pkg.sub.b -> pkg.a")
    assert "(type checking)" in text and "(deferred)" in text

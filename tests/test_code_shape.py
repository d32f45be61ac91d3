"""The code's shape, read from the source with `ast`: functions outside `litl/viz` stay at most 80
lines, and no module imports another's private name (a leading underscore), in litl, its tests
and its benchmarks alike."""

from __future__ import annotations

import ast
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
MAX_LINES = 80


def _sources(*folders: str) -> list[pathlib.Path]:
    return sorted(p for folder in folders for p in (ROOT / folder).rglob("*.py"))


def test_no_function_outside_viz_runs_past_80_lines():
    long = []
    for path in _sources("litl"):
        if "viz" in path.relative_to(ROOT).parts:
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1  # type: ignore[operator]
                if lines > MAX_LINES:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({lines} lines)")
    assert not long, "split these functions:\n" + "\n".join(long)


@pytest.mark.parametrize("folder", ["litl", "tests", "benchmarks"])
def test_no_private_name_is_imported_from_a_litl_module(folder):
    found = []
    for path in _sources(folder):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("litl"):
                private = [
                    a.name for a in node.names if a.name.startswith("_") and not a.name.startswith("__")
                ]
                if private:
                    found.append(
                        f"{path.relative_to(ROOT)}:{node.lineno} imports {private} from {node.module}"
                    )
    assert not found, "make these names public, or keep them in their module:\n" + "\n".join(found)


def test_every_script_in_benchmarks_is_named_in_the_benchmarks_page():
    page = (ROOT / "docs" / "results" / "benchmarks.md").read_text()
    index = page.split("## What `benchmarks/` holds", 1)[1].split("\n## ", 1)[0]
    unnamed = [p.name for p in sorted((ROOT / "benchmarks").glob("*.py")) if f"`{p.name}`" not in index]
    assert not unnamed, f"name these in docs/results/benchmarks.md's index, or move them out: {unnamed}"

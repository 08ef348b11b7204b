"""No import cycle between tzsl modules (issue 24, item 1), checked on the source with :mod:`ast`.

Every ``import`` and ``from ... import`` counts, inside functions and under ``if TYPE_CHECKING:`` too
(a lazy import ties two modules together as firmly as a top-level one, and a type-only import says
that one module's types belong to the other: issue 34 put result types in modules of their own). A module
importing its own package or subpackage (``tzsl.models`` from ``tzsl.models._dap`` to reach a sibling through
the package) is not counted: packages re-export their modules, so that
edge says nothing about the design.

The modules are the nodes of a directed graph, imports its edges; a cycle is a strongly connected
component of more than one module (Tarjan's algorithm).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

PACKAGE_ROOT = Path(__file__).resolve().parents[1] / "tzsl"
REPO_ROOT = PACKAGE_ROOT.parent

#: Cycles left for now, each while the change that breaks it is under way. Do not add to it.
KNOWN_CYCLES: frozenset[frozenset[str]] = frozenset()


def module_files() -> dict[str, Path]:
    """``{"tzsl.models._dap": Path(...), "tzsl.models": Path(".../__init__.py"), ...}``."""
    modules = {}
    for path in sorted(PACKAGE_ROOT.rglob("*.py")):
        parts = path.relative_to(REPO_ROOT).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def imported_modules(module: str, path: Path, modules: set[str]) -> set[str]:
    """The tzsl modules ``module`` imports (``from tzsl.x import name`` counts ``tzsl.x`` and,
    when ``name`` is a module, ``tzsl.x.name``)."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    targets: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            targets.add(source)
            targets.update(f"{source}.{alias.name}" for alias in node.names)
    return {t for t in targets
            if t in modules and t != module and not module.startswith(t + ".") and not t.startswith(module + ".")}


def import_cycles() -> list[frozenset[str]]:
    """Every strongly connected component of more than one module (Tarjan, iterative)."""
    files = module_files()
    graph = {m: sorted(imported_modules(m, p, set(files))) for m, p in files.items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[frozenset[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, 0)]
        while work:
            node, child = work.pop()
            if child == 0:
                index[node] = low[node] = len(index)
                stack.append(node)
                on_stack.add(node)
            if child < len(graph[node]):
                work.append((node, child + 1))
                nxt = graph[node][child]
                if nxt not in index:
                    work.append((nxt, 0))
                elif nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
                continue
            if low[node] == index[node]:
                component = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.add(member)
                    if member == node:
                        break
                if len(component) > 1:
                    cycles.append(frozenset(component))
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
    return cycles


def test_finds_a_cycle(tmp_path, monkeypatch):
    """The checker itself: two modules importing each other (one lazily) are one cycle."""
    package = tmp_path / "tzsl"
    (package / "sub").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "sub" / "__init__.py").write_text("")
    (package / "sub" / "a.py").write_text("from tzsl.sub import b\n")
    (package / "sub" / "b.py").write_text("def f():\n    from tzsl.sub.a import x\n")
    (package / "sub" / "c.py").write_text("from tzsl.sub import d\n")
    (package / "sub" / "d.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                          "    from tzsl.sub import c\n")
    this = sys.modules[__name__]
    monkeypatch.setattr(this, "PACKAGE_ROOT", package)
    monkeypatch.setattr(this, "REPO_ROOT", tmp_path)
    assert sorted(sorted(c) for c in import_cycles()) == [["tzsl.sub.a", "tzsl.sub.b"], ["tzsl.sub.c", "tzsl.sub.d"]]


def test_no_new_import_cycle():
    cycles = import_cycles()
    new = [sorted(c) for c in cycles if not any(c <= known for known in KNOWN_CYCLES)]
    assert not new, "import cycles between tzsl modules (break them; in-function imports count):\n" + "\n".join(
        " <-> ".join(c) for c in new)


def test_known_cycles_still_exist():
    """An entry of KNOWN_CYCLES that no longer matches a cycle is stale: delete it (none is left)."""
    cycles = import_cycles()
    stale = [sorted(k) for k in KNOWN_CYCLES if not any(c & k for c in cycles)]
    assert not stale, f"KNOWN_CYCLES entries that are no longer cycles: {stale}"

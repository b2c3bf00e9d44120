"""The package's shape: no import cycles, no private names borrowed across modules.

Read from the sources with ``ast`` (nothing is imported), so the test sees every module,
including the ones an import would not reach. Imports made inside functions count for the
private-name rule but not for cycles: a deferred import is how a lower layer may reach an
optional upper one at call time (for example a report on demand) without a cycle at import.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "pumpid"


def module_name(path: Path) -> str:
    parts = ["pumpid", *path.relative_to(SRC).with_suffix("").parts]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def resolve(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The absolute module an ``ImportFrom`` names."""
    if node.level == 0:
        return node.module or ""
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, *([node.module] if node.module else [])])


def imports(path: Path, modules: set[str]) -> tuple[set[str], set[str], list[str]]:
    """(modules imported at module level, all imported modules, private names borrowed)."""
    name = module_name(path)
    is_package = path.name == "__init__.py"
    tree = ast.parse(path.read_text(encoding="utf-8"))
    top_level: set[str] = set()
    everywhere: set[str] = set()
    private: list[str] = []
    deferred = {id(n) for f in ast.walk(tree)
                if isinstance(f, ast.FunctionDef | ast.AsyncFunctionDef)
                for n in ast.walk(f)}
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            source = resolve(name, is_package, node)
            targets = [source]
            for alias in node.names:
                sub = f"{source}.{alias.name}"
                if sub in modules:
                    targets.append(sub)
                elif (alias.name.startswith("_") and not alias.name.startswith("__")
                      and source.startswith("pumpid") and source != name):
                    private.append(f"{name} imports {alias.name} from {source}")
        for target in targets:
            if target.startswith("pumpid") and target != name:
                everywhere.add(target)
                if id(node) not in deferred and not _type_checking_only(tree, node):
                    top_level.add(target)
    return top_level, everywhere, private


def _type_checking_only(tree: ast.Module, node: ast.AST) -> bool:
    for stmt in tree.body:
        if (isinstance(stmt, ast.If) and isinstance(stmt.test, ast.Name)
                and stmt.test.id == "TYPE_CHECKING"):
            if any(n is node for n in ast.walk(stmt)):
                return True
    return False


def graph() -> tuple[dict[str, set[str]], list[str]]:
    paths = sorted(SRC.rglob("*.py"))
    modules = {module_name(p) for p in paths}
    edges: dict[str, set[str]] = {}
    private: list[str] = []
    for path in paths:
        top, _all, borrowed = imports(path, modules)
        # Importing pumpid.a.b runs pumpid.a's __init__ too, but that edge is the
        # package's own business (a package may import its submodules); only edges
        # between modules are followed.
        edges[module_name(path)] = {m for m in top if m in modules}
        private += borrowed
    return edges, private


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt):], nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def test_there_are_modules_to_check() -> None:
    edges, _ = graph()
    assert len(edges) > 30 and "pumpid.engine.solvers" in edges


def test_no_import_cycles() -> None:
    edges, _ = graph()
    # A package's __init__ re-exporting its submodules is not a cycle with them.
    cycle = find_cycle({m: {t for t in ts if not m.startswith(t + ".")}
                        for m, ts in edges.items()})
    assert cycle is None, " -> ".join(cycle or [])


def test_no_private_names_imported_across_modules() -> None:
    _, private = graph()
    assert private == [], "\n".join(private)


@pytest.mark.parametrize("upper,lower", [
    ("pumpid.cli", "pumpid.engine"), ("pumpid.cli", "pumpid.models"),
    ("pumpid.report", "pumpid.engine"), ("pumpid.fleet", "pumpid.engine"),
    ("pumpid.cli", "pumpid.rods"), ("pumpid.fleet", "pumpid.rods"),
    ("pumpid.job", "pumpid.rods"),
])
def test_lower_layers_do_not_import_upper_ones(upper: str, lower: str) -> None:
    paths = [p for p in SRC.rglob("*.py") if module_name(p).startswith(lower)]
    modules = {module_name(p) for p in SRC.rglob("*.py")}
    offenders = [module_name(p) for p in paths
                 if any(m.startswith(upper) for m in imports(p, modules)[1])]
    assert offenders == []

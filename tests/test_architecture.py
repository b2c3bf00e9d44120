"""The package's shape: layers, no import cycles, no private names borrowed, no long modules,
no public function with a long parameter list.

Read from the sources with ``ast`` (nothing is imported), so the test sees every module,
including the ones an import would not reach. Every import counts, wherever it is written:
at module level, inside a function (a deferred import still ties the two modules together,
only later) and under ``if TYPE_CHECKING:`` (the annotation still names the other module).
"""

from __future__ import annotations

import ast
import itertools
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

#: The layers, top to bottom. A module may import modules of its own layer and of lower
#: ones only, in any form of import. A module's layer is named by the first part of its
#: name after ``pumpid``; ``pumpid`` itself (the public facade, for users) is above all.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("pumpid", "__main__"),
    ("cli",),
    ("fleet",),
    ("pump",),
    ("flow", "paper"),
    ("profile",),
    ("job",),
    ("inference",),
    # The rod string's wave equation needs no fit: above the result and its reports,
    # below the fleet and the command line, out of reach of the fitting layers.
    ("rods",),
    ("report",),
    ("result",),
    ("engine",),
    ("models", "cards"),
    ("interrupts", "version"),
)

#: No module may be longer (lines); the compiled kernels are not exempt.
MAX_LINES = 700

#: No public function or method may take more parameters (self and cls not counted; ``*args``
#: and ``**kwargs`` count one each). Settings that belong together go in one object instead.
#: Compiled kernels (decorated with ``pumpid.engine.compiled.jit``) are exempt: numba takes
#: arrays and scalars, not objects, so their arguments are spelt out.
MAX_PARAMETERS = 12
COMPILED = "pumpid.engine.compiled"

SRC = Path(__file__).resolve().parents[1] / "src" / "pumpid"
LEVEL = {part: level for level, parts in enumerate(LAYERS) for part in parts}


@dataclass(frozen=True)
class Import:
    """One module naming another: where, and in which form."""

    importer: str
    imported: str
    kind: str  # "module-level", "deferred" (inside a function) or "type-checking"
    path: Path
    line: int

    @property
    def key(self) -> str:
        return f"{self.importer} -> {self.imported}"

    def __str__(self) -> str:
        return (f"{self.key} ({self.kind} import, "
                f"{self.path.relative_to(SRC.parents[1]).as_posix()}:{self.line})")


def module_name(path: Path) -> str:
    parts = ["pumpid", *path.relative_to(SRC).with_suffix("").parts]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def resolve(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The absolute module an ``ImportFrom`` names."""
    if node.level == 0:
        return node.module or ""
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, *([node.module] if node.module else [])])


def is_type_checking(test: ast.expr) -> bool:
    return ((isinstance(test, ast.Name) and test.id == "TYPE_CHECKING")
            or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"))


def import_nodes(nodes: Iterable[ast.AST], kind: str = "module-level",
                 ) -> Iterator[tuple[ast.Import | ast.ImportFrom, str]]:
    """Every import statement under ``nodes`` with its kind (type-checking wins)."""
    for node in nodes:
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node, kind
        elif isinstance(node, ast.If) and is_type_checking(node.test):
            yield from import_nodes(node.body, "type-checking")
            yield from import_nodes(node.orelse, kind)
        elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
            inner = "deferred" if kind == "module-level" else kind
            yield from import_nodes(ast.iter_child_nodes(node), inner)
        else:
            yield from import_nodes(ast.iter_child_nodes(node), kind)


@dataclass
class Package:
    modules: dict[str, Path]
    imports: list[Import]
    private: list[str]


def read_package() -> Package:
    paths = sorted(SRC.rglob("*.py"))
    modules = {module_name(p): p for p in paths}
    found: list[Import] = []
    private: list[str] = []
    for path in paths:
        name = module_name(path)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node, kind in import_nodes(tree.body):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                source = resolve(name, path.name == "__init__.py", node)
                for alias in node.names:
                    sub = f"{source}.{alias.name}"
                    if sub in modules:
                        targets.append(sub)  # a submodule, not a name of the package
                        continue
                    targets.append(source)
                    if (alias.name.startswith("_") and not alias.name.startswith("__")
                            and source.startswith("pumpid") and source != name):
                        private.append(f"{name} imports {alias.name} from {source} "
                                       f"(line {node.lineno})")
            for target in dict.fromkeys(targets):
                if target in modules and target != name:
                    found.append(Import(name, target, kind, path, node.lineno))
    return Package(modules, found, private)


PACKAGE = read_package()


def layer_violations() -> list[Import]:
    return [i for i in PACKAGE.imports
            if layer(i.imported) in LEVEL and layer(i.importer) in LEVEL
            and LEVEL[layer(i.imported)] < LEVEL[layer(i.importer)]]


def long_modules() -> dict[str, str]:
    out = {}
    for name, path in PACKAGE.modules.items():
        lines = len(path.read_text(encoding="utf-8").splitlines())
        if lines > MAX_LINES:
            out[name] = f"{name}: {lines} lines (at most {MAX_LINES})"
    return out


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
    assert len(PACKAGE.modules) > 30 and "pumpid.engine.solvers" in PACKAGE.modules
    kinds = {i.kind for i in PACKAGE.imports}
    assert kinds == {"module-level", "deferred", "type-checking"}


def test_every_module_has_a_layer() -> None:
    missing = sorted({layer(m) for m in PACKAGE.modules} - set(LEVEL))
    assert missing == [], f"add these to LAYERS: {missing}"


def test_lower_layers_do_not_import_upper_ones() -> None:
    found = [f"{i}: {layer(i.importer)} may not import {layer(i.imported)}, a higher layer"
             for i in layer_violations()]
    assert found == [], "\n".join(found)


def test_no_import_cycles() -> None:
    edges: dict[str, set[str]] = {}
    for i in PACKAGE.imports:
        edges.setdefault(i.importer, set()).add(i.imported)
    cycle = find_cycle(edges)
    if cycle is not None:
        steps = ["; ".join(str(i) for i in PACKAGE.imports if (i.importer, i.imported) == pair)
                 for pair in itertools.pairwise(cycle)]
        pytest.fail("import cycle:\n" + "\n".join(steps))


def test_no_private_names_imported_across_modules() -> None:
    assert PACKAGE.private == [], "\n".join(PACKAGE.private)


def test_no_module_is_too_long() -> None:
    found = [text for _name, text in sorted(long_modules().items())]
    assert found == [], "\n".join(found)


def compiled_decorators(name: str, path: Path, tree: ast.Module) -> set[str]:
    """The names under which a module sees the compiled-kernel decorator."""
    names = {"jit"} if name == COMPILED else set()
    for node in ast.walk(tree):
        if (isinstance(node, ast.ImportFrom)
                and resolve(name, path.name == "__init__.py", node) == COMPILED):
            names |= {alias.asname or alias.name for alias in node.names if alias.name == "jit"}
    return names


def is_compiled(fn: ast.FunctionDef | ast.AsyncFunctionDef, decorators: set[str]) -> bool:
    for dec in fn.decorator_list:
        target = dec.func if isinstance(dec, ast.Call) else dec
        if isinstance(target, ast.Name) and target.id in decorators:
            return True
    return False


def parameter_count(fn: ast.FunctionDef | ast.AsyncFunctionDef, method: bool) -> int:
    a = fn.args
    positional = [*a.posonlyargs, *a.args]
    static = any(isinstance(d, ast.Name) and d.id == "staticmethod" for d in fn.decorator_list)
    if method and not static and positional:
        positional = positional[1:]  # self or cls
    return (len(positional) + len(a.kwonlyargs) + (a.vararg is not None)
            + (a.kwarg is not None))


def functions(body: Iterable[ast.AST], method: bool = False,
              ) -> Iterator[tuple[ast.FunctionDef | ast.AsyncFunctionDef, bool]]:
    """Functions and methods defined in ``body`` (also under ``if`` or ``try``), not the ones
    nested inside functions (those are no one's interface)."""
    for node in body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            yield node, method
        elif isinstance(node, ast.ClassDef):
            yield from functions(node.body, method=True)
        else:
            yield from functions(ast.iter_child_nodes(node), method)


def long_signatures() -> list[str]:
    found = []
    for name, path in PACKAGE.modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        decorators = compiled_decorators(name, path, tree)
        for fn, method in functions(tree.body):
            if fn.name.startswith("_") or is_compiled(fn, decorators):
                continue
            count = parameter_count(fn, method)
            if count > MAX_PARAMETERS:
                found.append(f"{name}.{fn.name} ({path.relative_to(SRC.parents[1]).as_posix()}:"
                             f"{fn.lineno}): {count} parameters (at most {MAX_PARAMETERS})")
    return found


def test_no_public_function_has_a_long_parameter_list() -> None:
    found = long_signatures()
    assert found == [], "\n".join(found)


def test_the_parameter_rule_sees_what_it_should() -> None:
    """The scan counts keyword-only and variadic parameters, skips self, private names
    and compiled kernels only: checked on made-up sources, so the rule cannot pass by
    seeing nothing."""
    source = """
from pumpid.engine.compiled import jit as kernel
def wide(a, b, c, d, e, f, g, *, h, i, j, k, l, m): ...
def spread(a, *args, b, c, d, e, f, g, h, i, j, k, **kw): ...
def _hidden(a, b, c, d, e, f, g, h, i, j, k, l, m): ...
@kernel
def fast(a, b, c, d, e, f, g, h, i, j, k, l, m): ...
class Thing:
    def method(self, a, b, c, d, e, f, g, h, i, j, k, l): ...
    def wider(self, a, b, c, d, e, f, g, h, i, j, k, l, m): ...
    @staticmethod
    def static(a, b, c, d, e, f, g, h, i, j, k, l, m): ...
"""
    tree = ast.parse(source)
    decorators = compiled_decorators("pumpid.somewhere", SRC / "somewhere.py", tree)
    counts = {fn.name: parameter_count(fn, method) for fn, method in functions(tree.body)
              if not fn.name.startswith("_") and not is_compiled(fn, decorators)}
    assert counts == {"wide": 13, "spread": 13, "method": 12, "wider": 13, "static": 13}
    assert any(fn.name == "fast" for fn, _m in functions(tree.body))

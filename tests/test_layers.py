"""The import layers of pyconnect (docs/architecture.md), checked by reading the source with ast.

Nothing is imported or executed: every ``import`` statement of every module under
``src/pyconnect`` counts, wherever it stands (module top, inside a function, under
``TYPE_CHECKING``), because a lazy import is still a dependency.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parent.parent / "src"

# Lowest first. A module may import modules of its own layer and of the layers below it.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("base", ("pyconnect", "pyconnect.errors", "pyconnect.utils")),
    ("typesys", ("pyconnect.typesys",)),
    ("renderer", ("pyconnect.codegen",)),
    ("codecs", ("pyconnect.codecs",)),
    (
        "runtime",
        (
            "pyconnect.record",
            "pyconnect.ros",
            "pyconnect.transport",
            "pyconnect.commands",
            "pyconnect.cli",
        ),
    ),
    (
        "codecgen command",
        (
            "pyconnect.codegen.cli",
            "pyconnect.codegen.build",
            "pyconnect.codegen.__main__",
            "pyconnect.codegen.compile",
        ),
    ),
)


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def all_modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted((SRC / "pyconnect").rglob("*.py"))}


def _matches(module: str, prefix: str) -> bool:
    if prefix == "pyconnect.codegen.compile":  # compile, compile_cli, ...: the compile command
        return module.startswith(prefix)
    return module == prefix or module.startswith(prefix + ".")


def layer_of(module: str) -> int:
    """The index of the layer with the longest prefix of ``module``."""
    matches = [
        (len(prefix), index)
        for index, (_, prefixes) in enumerate(LAYERS)
        for prefix in prefixes
        if _matches(module, prefix)
    ]
    if not matches:
        raise AssertionError(f"{module} belongs to no layer: add it to LAYERS in {__file__}")
    return max(matches)[1]


def imports_of(module: str, path: Path, known: set[str]) -> set[str]:
    """The pyconnect modules ``module`` imports (``from pkg import sub`` names ``pkg.sub``)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_package = path.name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".")
                base = base[: len(base) - node.level + (1 if is_package else 0)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                found.add(sub if sub in known else target)
    return {name for name in found if name in known and name != module}


def import_graph() -> dict[str, set[str]]:
    modules = all_modules()
    known = set(modules)
    return {name: imports_of(name, path, known) for name, path in modules.items()}


def test_every_module_belongs_to_a_layer() -> None:
    for module in all_modules():
        layer_of(module)


def test_no_module_imports_a_higher_layer() -> None:
    wrong = [
        f"{module} ({LAYERS[layer_of(module)][0]}) imports {target} ({LAYERS[layer_of(target)][0]})"
        for module, targets in sorted(import_graph().items())
        for target in sorted(targets)
        if layer_of(target) > layer_of(module)
    ]
    assert wrong == []


def strongly_connected(graph: dict[str, set[str]]) -> list[frozenset[str]]:
    """Tarjan's algorithm: the groups of modules that import each other (size > 1)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[frozenset[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in sorted(graph[node]):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            group = set()
            while True:
                top = stack.pop()
                on_stack.discard(top)
                group.add(top)
                if top == node:
                    break
            if len(group) > 1:
                groups.append(frozenset(group))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return groups


def test_no_import_circles() -> None:
    assert sorted(sorted(c) for c in strongly_connected(import_graph())) == []


@pytest.mark.parametrize(
    ("module", "layer"),
    [
        ("pyconnect.errors", "base"),
        ("pyconnect.typesys.model", "typesys"),
        ("pyconnect.codegen.render", "renderer"),
        ("pyconnect.codegen", "renderer"),
        ("pyconnect.codecs.registry", "codecs"),
        ("pyconnect.record.bag_reader", "runtime"),
        ("pyconnect.cli", "runtime"),
        ("pyconnect.codegen.cli", "codecgen command"),
        ("pyconnect.codegen.compile_package", "codecgen command"),
    ],
)
def test_layer_of(module: str, layer: str) -> None:
    assert LAYERS[layer_of(module)][0] == layer


def test_the_checks_see_a_broken_order_and_a_circle() -> None:
    graph = {
        "pyconnect.typesys.a": {"pyconnect.codecs.b"},
        "pyconnect.codecs.b": {"pyconnect.typesys.a"},
    }
    assert layer_of("pyconnect.codecs.b") > layer_of("pyconnect.typesys.a")
    assert strongly_connected(graph) == [frozenset(graph)]

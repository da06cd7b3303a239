"""The shape of the source tree (issue 37): import cycles, module and function sizes.

    python bench/structure.py [--json]

Reads every module of ``src/bimrobot`` with :mod:`ast` (imports inside functions count: they still tie
two modules together), builds the import graph with networkx and reports

- the import cycles (strongly connected components of more than one module),
- modules over 600 lines and functions over 60 lines (the issue's limits), with the totals.

No timing: it is a count, the same on every machine.
"""

from __future__ import annotations

import argparse
import ast
import json
from pathlib import Path

import networkx as nx

SRC = Path(__file__).resolve().parents[1] / "src"
MODULE_LINES = 600
FUNCTION_LINES = 60


def module_name(path: Path) -> str:
    parts = path.relative_to(SRC).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted((SRC / "bimrobot").rglob("*.py")) if "ros2_pkg" not in p.parts}


def imported(tree: ast.AST, known: set[str]) -> set[str]:
    """The bimrobot modules a module imports (``from a.b import c`` counts a.b.c when c is a module)."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        else:
            continue
        found.update(n for n in names if n in known)
    return found


def long_functions(tree: ast.AST) -> list[tuple[str, int]]:
    return [(node.name, node.end_lineno - node.lineno + 1) for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > FUNCTION_LINES]


def measure() -> dict:
    found = modules()
    graph = nx.DiGraph()
    big_modules, big_functions, functions = [], [], 0
    for name, path in found.items():
        text = path.read_text()
        tree = ast.parse(text)
        graph.add_node(name)
        graph.add_edges_from((name, other) for other in imported(tree, set(found)) if other != name)
        lines = text.count("\n")
        if lines > MODULE_LINES:
            big_modules.append((name, lines))
        functions += sum(isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) for n in ast.walk(tree))
        big_functions += [(f"{name}.{f}", n) for f, n in long_functions(tree)]
    cycles = sorted(sorted(c) for c in nx.strongly_connected_components(graph) if len(c) > 1)
    return {"modules": len(found), "imports": graph.number_of_edges(), "cycles": cycles,
            "modules_over_600_lines": sorted(big_modules, key=lambda m: -m[1]),
            "functions": functions, "functions_over_60_lines": sorted(big_functions, key=lambda f: -f[1])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    figures = measure()
    if parser.parse_args().json:
        print(json.dumps(figures, indent=1))
        return
    print(f"{figures['modules']} modules, {figures['imports']} imports between them")
    print(f"import cycles: {len(figures['cycles'])}")
    for cycle in figures["cycles"]:
        print("  " + " <-> ".join(cycle))
    print(f"modules over {MODULE_LINES} lines: {len(figures['modules_over_600_lines'])}")
    for name, lines in figures["modules_over_600_lines"]:
        print(f"  {lines:5d} {name}")
    print(f"functions over {FUNCTION_LINES} lines: {len(figures['functions_over_60_lines'])} of {figures['functions']}")
    for name, lines in figures["functions_over_60_lines"]:
        print(f"  {lines:5d} {name}")


if __name__ == "__main__":
    main()

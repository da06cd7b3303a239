"""The shape of the source tree (issue 37): import cycles, module and function sizes.

    python bench/structure.py [--json]

Reads every module of ``src/bimrobot`` with :mod:`ast` (imports inside functions count: they still tie
two modules together; imports written in docstrings do not), builds the import graph with networkx and
reports

- the import cycles (strongly connected components of more than one module),
- the upward imports: a module of a lower layer of docs/architecture.md importing one of a higher layer
  (:data:`LAYERS`; the DRL benchmark, ``assembly`` then ``rl``, stands beside them and reads only ``core``),
- modules over 600 lines and functions over 60 lines (the issue's limits), with the totals.

No timing: it is a count, the same on every machine.
"""

from __future__ import annotations

import argparse
import ast
import json
import re
from pathlib import Path

import networkx as nx

SRC = Path(__file__).resolve().parents[1] / "src"
MODULE_LINES = 600
FUNCTION_LINES = 60

#: The layers of docs/architecture.md, lowest first: a part may import its own layer and those below.
LAYERS = (("core",), ("bim",), ("sco",), ("site",), ("export",), ("schedule",), ("coordination",), ("planning",),
          ("lbd",), ("physics",), ("rcan",), ("replay", "report"), ("pipeline",))
#: The optional DRL benchmark beside the layers: it reads only core, and rl reads assembly.
BESIDE = {"assembly": {"core", "assembly"}, "rl": {"core", "assembly", "rl"}}
#: The commands on top, which may import every part.
TOP = {"cli", "__main__"}


def command_modules() -> set[str]:
    """The modules that register a command (the owners in ``bimrobot.cli.COMMANDS``, e.g.
    ``bimrobot.coordination.cli``, ``bimrobot.pipeline``): each is the top of its part, where a command's
    options reach the parts they choose (``simulate --planner`` reaches planning), so they stand with
    ``cli`` on top. The table is read with :mod:`ast`, not imported."""
    tree = ast.parse((SRC / "bimrobot" / "cli.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and any(getattr(target, "id", None) == "COMMANDS" for target in node.targets):
            return {owner.elts[0].value for owner in node.value.values}
    raise ValueError("bimrobot/cli.py has no COMMANDS table")


def part_of(module: str) -> str:
    """The part of the tree a module belongs to: ``bimrobot.site.fleet`` -> ``site``; the package root -> ""."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def may_import(importer: str, imported_part: str) -> bool:
    """Whether part ``importer`` may import part ``imported_part`` (the root package is under everything)."""
    if imported_part in ("", importer) or importer in TOP:
        return True
    if importer in BESIDE:
        return imported_part in BESIDE[importer]
    ranks = {part: rank for rank, layer in enumerate(LAYERS) for part in layer}
    if importer not in ranks or imported_part not in ranks:
        return False  # a part the doc does not place, or the main chain reaching into the DRL benchmark
    return ranks[imported_part] <= ranks[importer]


def upward(graph: nx.DiGraph) -> list[tuple[str, str]]:
    """The imports (importer, imported) that point up the layers, sorted: a command module
    (:func:`command_modules`) may import any part; any other module may import neither a part above its
    own nor the command module of another part."""
    commands = command_modules()

    def points_up(importer: str, imported: str) -> bool:
        if importer in commands:
            return False
        if imported in commands and part_of(imported) != part_of(importer):
            return True
        return not may_import(part_of(importer), part_of(imported))

    return sorted((a, b) for a, b in graph.edges if points_up(a, b))


def module_name(path: Path) -> str:
    parts = path.relative_to(SRC).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted((SRC / "bimrobot").rglob("*.py")) if "ros2_pkg" not in p.parts}


#: a line that starts an import statement (``import a.b``, ``from a.b import c``), at any indentation
IMPORT_START = re.compile(r"[ \t]*(?:from[ \t]+[\w.]+[ \t]+import\b|import[ \t]+[\w.])")


def _open_string(line: str, quote: str | None) -> str | None:
    """The triple quote still open after ``line`` (None: none), given the one open before it."""
    at = 0
    while True:
        if quote:
            end = line.find(quote, at)
            if end < 0:
                return quote
            at, quote = end + 3, None
        else:
            starts = [(line.find(q, at), q) for q in ('"""', "'''") if line.find(q, at) >= 0]
            if not starts:
                return None
            start, quote = min(starts)
            at = start + 3


def import_statements(text: str) -> list[ast.stmt]:
    """The import statements of a module's source at any depth (inside functions too), outside triple-quoted
    strings: each line that starts one, with its parenthesised continuation, parsed by :mod:`ast` alone
    (parsing whole modules costs about ten times as much: the test of this graph must stay fast)."""
    lines, found, quote = text.splitlines(), [], None
    for number, line in enumerate(lines):
        if quote is None and IMPORT_START.match(line):
            statement, end = line.split("#")[0], number
            while statement.count("(") > statement.count(")") and end + 1 < len(lines):
                end += 1
                statement += "\n" + lines[end].split("#")[0]
            try:
                found.extend(ast.parse(statement.strip()).body)
            except SyntaxError:
                pass  # not a statement after all
        quote = _open_string(line, quote)
    return found


def imported(statements: list[ast.stmt], known: set[str]) -> set[str]:
    """The bimrobot modules imported by ``statements`` (``from a.b import c`` counts a.b.c when c is a module)."""
    found = set()
    for node in statements:
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


def import_graph() -> nx.DiGraph:
    """Module -> the bimrobot modules it imports (every module a node)."""
    found = modules()
    graph = nx.DiGraph()
    for name, path in found.items():
        graph.add_node(name)
        statements = import_statements(path.read_text())
        graph.add_edges_from((name, other) for other in imported(statements, set(found)) if other != name)
    return graph


def cycles_of(graph: nx.DiGraph) -> list[list[str]]:
    """The import cycles: strongly connected components of more than one module, sorted."""
    return sorted(sorted(c) for c in nx.strongly_connected_components(graph) if len(c) > 1)


def measure() -> dict:
    graph = import_graph()
    big_modules, big_functions, functions = [], [], 0
    for name, path in modules().items():
        text = path.read_text()
        tree = ast.parse(text)
        lines = text.count("\n")
        if lines > MODULE_LINES:
            big_modules.append((name, lines))
        functions += sum(isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) for n in ast.walk(tree))
        big_functions += [(f"{name}.{f}", n) for f, n in long_functions(tree)]
    return {"modules": graph.number_of_nodes(), "imports": graph.number_of_edges(), "cycles": cycles_of(graph),
            "upward": upward(graph), "modules_over_600_lines": sorted(big_modules, key=lambda m: -m[1]),
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
    print(f"upward imports: {len(figures['upward'])}")
    for importer, imported_module in figures["upward"]:
        print(f"  {importer} -> {imported_module}")
    print(f"modules over {MODULE_LINES} lines: {len(figures['modules_over_600_lines'])}")
    for name, lines in figures["modules_over_600_lines"]:
        print(f"  {lines:5d} {name}")
    print(f"functions over {FUNCTION_LINES} lines: {len(figures['functions_over_60_lines'])} of {figures['functions']}")
    for name, lines in figures["functions_over_60_lines"]:
        print(f"  {lines:5d} {name}")


if __name__ == "__main__":
    main()

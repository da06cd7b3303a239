"""The shape of the import graph (issue 37): no import cycle, no upward import.

``bench/structure.py`` reads every module of ``src/bimrobot`` with :mod:`ast` (imports inside functions
count, imports written in docstrings do not) and the layers of docs/architecture.md (its ``LAYERS``); the
modules that register a command (``bimrobot.cli.COMMANDS``) stand on top with ``cli``. Since 2026-11-28 it
counts no import cycle and no upward import; this test keeps it so. Reading the graph takes about 0.2 s
(no module is imported).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

def _structure():
    path = Path(__file__).resolve().parents[2] / "bench" / "structure.py"
    spec = importlib.util.spec_from_file_location("bench_structure", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_no_import_cycle_and_no_upward_import():
    structure = _structure()
    graph = structure.import_graph()
    cycles, upward = structure.cycles_of(graph), structure.upward(graph)
    assert len(graph) > 100  # the whole tree was read
    assert not cycles, f"an import cycle: {cycles}"
    assert not upward, "an upward import: " + ", ".join(f"{a} -> {b}" for a, b in upward)


def test_the_layers_name_every_part_of_the_tree():
    """Every folder and top module of ``src/bimrobot`` has its place in the layers: a new part is placed
    in docs/architecture.md (and ``LAYERS``) before anything can say whether its imports point down."""
    structure = _structure()
    placed = {part for layer in structure.LAYERS for part in layer} | set(structure.BESIDE) | structure.TOP
    parts = {structure.part_of(name) for name in structure.modules()} - {""}
    assert parts <= placed, f"parts the layers do not place: {sorted(parts - placed)}"
